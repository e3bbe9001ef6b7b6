/* The forecast's initial state (forecast_impl.h): the plane box, the land
 * mask on the plane, the ice rasters, and the particles of a cold start
 * (seeded from the initial raster) or a warm start (the previous cycle's
 * restart file), with their first forcing and the resolved time step. */
#include "forecast_impl.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/dd.h"
#include "io/restart.h"
#include "io/seed.h"
#include "service/cycle_name.h"
#include "util/log.h"

#define MAX_PLANE_CELLS 16000000L /* plane land mask cells */
#define MAX_LL_CELLS 4000000L     /* lon/lat land mask cells (GSHHG rasterisation) */

/* ------------------------------------------------------------ land mask */

static const char *gshhg_path(const struct sph_config *cfg, char *buf, size_t len)
{
    if (cfg->landmask.path && cfg->landmask.path[0])
        return cfg->landmask.path;
    static const char letters[] = "clihf";
    int r = cfg->landmask.resolution;
    const char *dirs[] = {"/usr/share/gmt-gshhg", "/usr/share/gshhg-gmt-nc4"};
    for (size_t d = 0; d < 2; d++) {
        snprintf(buf, len, "%s/binned_GSHHS_%c.nc", dirs[d], letters[r >= 0 && r < 5 ? r : 2]);
        if (access(buf, R_OK) == 0)
            return buf;
    }
    return landmask_gshhg_default_path(); /* the best installed one */
}

/* The first file of the first ocean source (land from its fill pattern). */
static const char *ocean_file(const struct sph_config *cfg, const forecast_request *req)
{
    for (size_t s = 0; s < cfg->nforcing && s < SPHICE_MAX_SOURCES; s++)
        if (cfg->forcing[s].kind == FORCING_OCEAN && req->forcing_files[s] && req->forcing_files[s][0])
            return req->forcing_files[s][0];
    for (size_t s = 0; s < cfg->nforcing && s < SPHICE_MAX_SOURCES; s++)
        if (req->forcing_files[s] && req->forcing_files[s][0])
            return req->forcing_files[s][0];
    return NULL;
}

int forecast_landmask_read(const struct sph_config *cfg, const char *path, landmask **out,
                           char *why, size_t why_len, sph_error *err)
{
    *out = NULL;
    int from_forcing = cfg->landmask.source == CFG_LAND_FORCING;
    if (!path || !path[0])
        return sph_err_set(err, SPH_ERR_CONFIG, from_forcing
                           ? "config: landmask.source forcing: no forcing file to take the land "
                             "from (set landmask.path)"
                           : "config: landmask.path: required for source netcdf");
    landmask_read_opts o;
    memset(&o, 0, sizeof o);
    o.variable = cfg->landmask.variable;
    o.from = (landmask_from)cfg->landmask.from;
    if (!from_forcing && o.from == LANDMASK_FROM_AUTO)
        o.from = LANDMASK_FROM_MASK; /* a mask file: its mask, never a fill guess */
    o.polarity = (landmask_polarity)cfg->landmask.polarity;
    o.fill_fallback = from_forcing;
    o.land_value = NAN;
    const char *lv = cfg->landmask.land_value;
    if (lv && lv[0]) {
        char *end = NULL;
        o.land_value = strtod(lv, &end);
        while (end && (*end == ' ' || *end == '\t'))
            end++;
        if (!end || end == lv || *end || !isfinite(o.land_value))
            return sph_err_set(err, SPH_ERR_CONFIG, "config: landmask.land_value: \"%s\" is not a "
                               "number", lv);
    }
    *out = landmask_read_model(path, &o, err);
    if (!*out)
        return err->code ? err->code : SPH_ERR_IO;
    if (why && why_len) {
        int nx, ny;
        landmask_get_grid(*out, &nx, &ny, NULL, NULL, NULL, NULL);
        size_t nl = 0;
        const unsigned char *d = landmask_data(*out);
        for (size_t k = 0; k < (size_t)nx * (size_t)ny; k++)
            nl += d[k];
        snprintf(why, why_len, "%s: %zu of %zu cells land on its %s grid (%d x %d)", path, nl,
                 (size_t)nx * (size_t)ny, landmask_is_native(*out) ? "native" : "lon/lat", nx, ny);
    }
    return SPH_OK;
}

int fc_build_landmask(engine *e, double xmin, double xmax, double ymin, double ymax, double cell,
                          sph_error *err)
{
    const struct sph_config *cfg = e->cfg;
    switch (cfg->landmask.source) {
    case CFG_LAND_NONE:
        e->lm = NULL;
        break;
    case CFG_LAND_GSHHG: {
        char buf[4096];
        const char *path = gshhg_path(cfg, buf, sizeof buf);
        /* the lon/lat box of the plane box (its corners reach beyond the domain box) */
        landmask_grid g;
        double lon_span = cfg->domain.lon_max - cfg->domain.lon_min;
        double lat_span = cfg->domain.lat_max - cfg->domain.lat_min;
        g.lon_min = cfg->domain.lon_min - 0.1 * lon_span;
        g.lon_max = cfg->domain.lon_max + 0.1 * lon_span;
        g.lat_min = fmax(-90, cfg->domain.lat_min - 0.1 * lat_span);
        g.lat_max = fmin(90, cfg->domain.lat_max + 0.1 * lat_span);
        g.resolution = 0.01;
        while ((g.lon_max - g.lon_min) * (g.lat_max - g.lat_min) / (g.resolution * g.resolution) >
               (double)MAX_LL_CELLS)
            g.resolution *= 1.5;
        e->lm = landmask_create_gshhg(path, &g, err);
        if (!e->lm)
            return err->code ? err->code : SPH_ERR_IO;
        break;
    }
    case CFG_LAND_NETCDF:
    case CFG_LAND_FORCING: {
        /* netcdf: landmask.path only; forcing: else the first ocean file */
        const char *path = cfg->landmask.path && cfg->landmask.path[0] ? cfg->landmask.path
                           : cfg->landmask.source == CFG_LAND_FORCING ? ocean_file(cfg, e->req)
                                                                      : NULL;
        int rc = forecast_landmask_read(cfg, path, &e->lm, NULL, 0, err);
        if (rc)
            return rc;
        break;
    }
    case CFG_LAND_RASTER:
        if (!e->raster)
            return sph_err_set(err, SPH_ERR_CONFIG, "config: landmask.source raster: no initial raster "
                               "(initial.path) to take the land from");
        if (!(e->lm = landmask_from_raster(e->raster, "landmask.source raster", err)))
            return err->code ? err->code : SPH_ERR_CONFIG;
        break;
    default:
        return sph_err_set(err, SPH_ERR_CONFIG, "config: landmask.source: unknown value %d",
                           cfg->landmask.source);
    }
    if (cfg->landmask.raster_land && cfg->landmask.source != CFG_LAND_RASTER) {
        /* the raster's own land, coast and lake flags as well */
        if (!e->raster)
            return sph_err_set(err, SPH_ERR_CONFIG, "config: landmask.raster_land: no initial raster "
                               "(initial.path) to take the land from");
        landmask *rl = landmask_from_raster(e->raster, "landmask.raster_land", err);
        if (!rl)
            return err->code ? err->code : SPH_ERR_CONFIG;
        if (e->lm)
            landmask_add(e->lm, rl);
        else
            e->lm = rl;
    }
    /* plane grid over the projected domain box; on a native model grid in
     * cells of at most a third of the model's, so that its coast is kept */
    if (e->lm && landmask_native_spacing_m(e->lm) / 3 < cell) /* NaN: no native grid */
        cell = landmask_native_spacing_m(e->lm) / 3;
    int nx = (int)ceil((xmax - xmin) / cell), ny = (int)ceil((ymax - ymin) / cell);
    while ((double)nx * ny > (double)MAX_PLANE_CELLS) {
        cell *= 1.5;
        nx = (int)ceil((xmax - xmin) / cell);
        ny = (int)ceil((ymax - ymin) / cell);
    }
    if (nx < 1) nx = 1;
    if (ny < 1) ny = 1;
    e->plane_land = calloc((size_t)nx * ny, 1);
    if (!e->plane_land)
        return sph_err_set(err, SPH_ERR_NOMEM, "land mask: out of memory (%d x %d cells)", nx, ny);
    if (e->lm) {
        int rc = landmask_to_plane(e->lm, e->proj, xmin, ymin, cell, cell, nx, ny, e->plane_land, err);
        if (rc)
            return rc;
    }
    e->plane.nx = nx;
    e->plane.ny = ny;
    e->plane.x0 = xmin;
    e->plane.y0 = ymin;
    e->plane.dx = cell;
    e->plane.dy = cell;
    e->plane.land = e->plane_land;
    e->plane.closed_outside = 0; /* leaving the domain box is an open boundary */
    return SPH_OK;
}

/* Bounding box of the projected domain box (its edges sampled densely). */
int fc_plane_box(engine *e, double *xmin, double *xmax, double *ymin, double *ymax, sph_error *err)
{
    const struct sph_config *cfg = e->cfg;
    enum { NS = 64 };
    double lon[4 * NS], lat[4 * NS], x[4 * NS], y[4 * NS];
    double l0 = cfg->domain.lon_min, l1 = cfg->domain.lon_max;
    double p0 = cfg->domain.lat_min, p1 = cfg->domain.lat_max;
    for (int k = 0; k < NS; k++) {
        double f = (double)k / (NS - 1);
        lon[k] = l0 + f * (l1 - l0), lat[k] = p0;
        lon[NS + k] = l0 + f * (l1 - l0), lat[NS + k] = p1;
        lon[2 * NS + k] = l0, lat[2 * NS + k] = p0 + f * (p1 - p0);
        lon[3 * NS + k] = l1, lat[3 * NS + k] = p0 + f * (p1 - p0);
    }
    int rc = geo_forward(e->proj, 4 * NS, lon, lat, x, y, err);
    if (rc)
        return rc;
    *xmin = *ymin = HUGE_VAL;
    *xmax = *ymax = -HUGE_VAL;
    for (int k = 0; k < 4 * NS; k++) {
        *xmin = fmin(*xmin, x[k]);
        *xmax = fmax(*xmax, x[k]);
        *ymin = fmin(*ymin, y[k]);
        *ymax = fmax(*ymax, y[k]);
    }
    return SPH_OK;
}

/* ---------------------------------------------------- initial particles */

void fc_raster_options(const struct sph_config *cfg, ice_raster_options *o)
{
    if (cfg->initial.ims_ice_conc > 0)
        o->ims_ice_conc = cfg->initial.ims_ice_conc;
    if (cfg->initial.ims_ice_thick > 0)
        o->ims_ice_thick = cfg->initial.ims_ice_thick;
    o->gdal_conc_band = cfg->initial.gdal_conc_band;
    o->gdal_thick_band = cfg->initial.gdal_thick_band;
    o->gdal_conc_units = cfg->initial.gdal_conc_units;
    double wl = fmax(1, (cfg->domain.lon_max - cfg->domain.lon_min) / 4);
    double wp = fmax(1, (cfg->domain.lat_max - cfg->domain.lat_min) / 4);
    if (cfg->domain.lon_max - cfg->domain.lon_min + 2 * wl < 360) {
        o->bbox[0] = cfg->domain.lon_min - wl;
        o->bbox[1] = cfg->domain.lon_max + wl;
    } else {
        o->bbox[0] = -180;
        o->bbox[1] = 180;
    }
    o->bbox[2] = fmax(-90, cfg->domain.lat_min - wp);
    o->bbox[3] = fmin(90, cfg->domain.lat_max + wp);
}

int fc_read_raster(engine *e, const char *tmpl, int format, const char *conc_var, double valid_time,
                       ice_raster **out, char *path, size_t plen, const char *what, sph_error *err)
{
    const struct sph_config *cfg = e->cfg;
    int rc = cycle_expand_template(tmpl, valid_time, path, plen, err);
    if (rc)
        return rc;
    ice_raster_options o;
    ice_raster_options_default(&o);
    o.default_thickness = cfg->initial.default_thickness;
    o.thickness_kind = cfg->initial.thickness_kind;
    fc_raster_options(cfg, &o);
    char thick_path[4096] = "";
    if (format == CFG_INIT_ESRI) {
        /* ESRI: initial.thick_var names the thickness grid file (a template) */
        o.valid_time = valid_time;
        if (e->raster == NULL && cfg->initial.thick_var && cfg->initial.thick_var[0] &&
            !strcmp(what, "initial field")) {
            if ((rc = cycle_expand_template(cfg->initial.thick_var, valid_time, thick_path,
                                            sizeof thick_path, err)))
                return rc;
            o.thickness_path = thick_path;
        }
    } else {
        o.conc_variable = conc_var && conc_var[0] ? conc_var : NULL;
        if (!strcmp(what, "initial field"))
            o.thick_variable = cfg->initial.thick_var && cfg->initial.thick_var[0] ? cfg->initial.thick_var
                                                                                  : NULL;
    }
    if (access(path, R_OK) != 0)
        return sph_err_set(err, SPH_ERR_IO, "%s %s: cannot read the file", what, path);
    sph_error local;
    sph_error_clear(&local);
    rc = ice_raster_read(path, &o, out, &local);
    /* the configuration's default name is a standard name, not a variable:
     * fall back to the reader's search by standard_name and usual names */
    if (rc == SPH_ERR_MISSING_VAR && o.conc_variable && !strcmp(o.conc_variable, "sea_ice_concentration")) {
        o.conc_variable = NULL;
        sph_error_clear(&local);
        rc = ice_raster_read(path, &o, out, &local);
    }
    if (rc)
        return sph_err_set(err, rc, "%s", local.msg);
    return SPH_OK;
}

double fc_spacing_m(const engine *e)
{
    if (e->cfg->initial.cell_particles > 0 && e->raster) {
        int j = e->raster->nlat / 2;
        return sqrt(ice_raster_area(e->raster, e->raster->nlon / 2, j)) / e->cfg->initial.cell_particles;
    }
    if (e->cfg->initial.spacing_deg > 0)
        return e->cfg->initial.spacing_deg * METRES_PER_DEGREE;
    if (e->raster) {
        int j = e->raster->nlat / 2;
        return sqrt(ice_raster_area(e->raster, e->raster->nlon / 2, j));
    }
    return 2000.0;
}

/* The work arrays for cap particles: the coupling's and the output's. */
static int alloc_work(engine *e, sph_error *err)
{
    int rc = coupling_alloc(&e->cpl, e->cap, err);
    if (rc)
        return rc;
    size_t c = e->cap ? e->cap : 1;
    int ok = 1;
    double **arrays[] = {&e->olon, &e->olat, &e->pue, &e->pvn};
    for (size_t k = 0; k < sizeof arrays / sizeof arrays[0]; k++)
        *arrays[k] = xcalloc(c, sizeof(double), &ok);
    /* the particles' divergence and shear live from fc_write_output's loop
     * to its SPH interpolation: in the coupling's grid-angle cosines and
     * sines, which that loop has read (the same k) and the next fill
     * writes anew (not freed with the engine's own arrays) */
    e->div = e->cpl.cs;
    e->shear = e->cpl.sn;
    return ok ? SPH_OK : sph_err_set(err, SPH_ERR_NOMEM, "forecast: out of memory (%zu particles)", c);
}

/* Sets *flag (or fails, by initial.gate) with the one line in msg. */
static int gate(engine *e, const char *msg, sph_error *err)
{
    if (e->cfg->initial.gate == CFG_GATE_FLAG) {
        log_warn("forecast %s: %s: published flagged (initial.gate flag)", e->cname, msg);
        if (e->res && !e->res->quality_flag[0])
            snprintf(e->res->quality_flag, sizeof e->res->quality_flag, "%s", msg);
        return SPH_OK;
    }
    return sph_err_set(err, SPH_ERR_BAD_DATA, "%s (initial.gate flag publishes it flagged)", msg);
}

void fc_seed_options(const engine *e, seed_options *so)
{
    const struct sph_config *cfg = e->cfg;
    seed_options_default(so);
    so->threshold = cfg->initial.threshold;
    so->spacing_m = cfg->initial.spacing_deg > 0 ? cfg->initial.spacing_deg * METRES_PER_DEGREE : 0.0;
    so->cell_n = cfg->initial.cell_particles;
    if (so->cell_n > 0)
        so->spacing_m = 0.0; /* n x n per cell, whatever initial.spacing says */
    so->sml_factor = cfg->model.sml_factor;
    so->rho_ice = cfg->model.rho_i;
    so->first_id = 0;
    so->plane_land = e->plane.land; /* what the model calls land */
    so->plane_x0 = e->plane.x0;
    so->plane_y0 = e->plane.y0;
    so->plane_dx = e->plane.dx;
    so->plane_dy = e->plane.dy;
    so->plane_nx = e->plane.nx;
    so->plane_ny = e->plane.ny;
    if (so->spacing_m > 0) { /* lattice over the model's plane box */
        so->xmin = e->plane.x0;
        so->ymin = e->plane.y0;
        so->xmax = e->plane.x0 + e->plane.nx * e->plane.dx;
        so->ymax = e->plane.y0 + e->plane.ny * e->plane.dy;
    }
}

int fc_seed(engine *e, const seed_options *so, sph_particles *P, fc_seeded *out, sph_error *err)
{
    memset(out, 0, sizeof *out);
    seed_totals st;
    int rc = seed_from_raster_totals(e->raster, e->proj, e->lm, so, P, &st, err);
    if (rc)
        return rc;
    /* particles outside the model's plane box would leave at once: drop them */
    double x1 = e->plane.x0 + e->plane.nx * e->plane.dx, y1 = e->plane.y0 + e->plane.ny * e->plane.dy;
    for (size_t k = P->n; k-- > 0;)
        if (!(P->x[k] >= e->plane.x0 && P->x[k] < x1 && P->y[k] >= e->plane.y0 && P->y[k] < y1)) {
            sph_particles_remove(P, k);
            out->dropped++;
        }
    /* the raster's ice against the seeded particles': a lattice's over the
     * plane area its footprints tile (within half a spacing of the plane
     * box at each edge; the region its scaling matched), per cell over the
     * model's plane box (its sea cells above the threshold) */
    if (st.rescaled) {
        out->raster_area = st.raster_area_m2;
        out->raster_volume = st.raster_volume_m3;
    } else {
        double box[4] = {e->plane.x0, x1, e->plane.y0, y1};
        if ((rc = seed_raster_totals(e->raster, e->proj, e->lm, so, box, &out->raster_area,
                                     &out->raster_volume, err)))
            return rc;
    }
    for (size_t k = 0; k < P->n; k++) {
        out->volume += P->mass[k] / so->rho_ice;
        out->area += P->mass[k] / (so->rho_ice * P->thick[k]);
    }
    /* what the seeding itself gave: the lattice before its scaling */
    out->rescaled = st.rescaled;
    out->raw_area = st.rescaled ? st.raw_area_m2 : out->area;
    out->raw_volume = st.rescaled ? st.raw_volume_m3 : out->volume;
    out->n = P->n;
    return SPH_OK;
}

/* The cold start's sanity gates (issue 19 item 7) on fc_seed's numbers. */
static int seed_gate(engine *e, const seed_options *so, const fc_seeded *s, sph_error *err)
{
    double ra = s->raster_area, rv = s->raster_volume, sa = s->area, sv = s->volume;
    double ga = s->raw_area, gv = s->raw_volume;
    if (e->res) {
        e->res->raster_ice_area_km2 = ra / 1e6;
        e->res->raster_ice_volume_km3 = rv / 1e9;
        e->res->seeded_ice_area_km2 = sa / 1e6;
        e->res->seeded_ice_volume_km3 = sv / 1e9;
        if (s->rescaled) {
            e->res->lattice_raw_area_km2 = ga / 1e6;
            e->res->lattice_raw_volume_km3 = gv / 1e9;
        }
        snprintf(e->res->raster_assumed, sizeof e->res->raster_assumed, "%s", e->raster->assumed);
    }
    char msg[sizeof e->raster_path + 400];
    if (!(ra > 0)) {
        if (e->res)
            e->res->open_water = 1;
        log_info("forecast %s: initial field %s has no ice in the domain (threshold %g): an open-water "
                 "start", e->cname, e->raster_path, so->threshold);
        return SPH_OK;
    }
    log_info("forecast %s: initial field %s: ice area %.6g km2, volume %.6g km3 over the domain's sea; "
             "seeded %zu particles, %.6g km2, %.6g km3%s", e->cname, e->raster_path, ra / 1e6, rv / 1e9,
             s->n, sa / 1e6, sv / 1e9, s->rescaled ? "" : " (per cell)");
    if (s->rescaled)
        log_info("forecast %s: the lattice sampled %+.3f %% of the raster's area and %+.3f %% of its volume "
                 "before its scaling", e->cname, 100 * (ga / ra - 1), 100 * (gv / rv - 1));
    if (s->n == 0) {
        snprintf(msg, sizeof msg, "initial field %s: ice area %.6g km2 and volume %.6g km3 in the domain "
                 "but no particle seeded", e->raster_path, ra / 1e6, rv / 1e9);
        return gate(e, msg, err);
    }
    double da = ga / ra - 1, dv = gv / rv - 1;
    if (!(fabs(da) <= 0.05) || !(fabs(dv) <= 0.05)) {
        snprintf(msg, sizeof msg, "initial field %s: seeded ice area %.6g km2 and volume %.6g km3 differ "
                 "from the raster's %.6g km2 and %.6g km3 over the domain's sea by %+.1f %% and %+.1f %% "
                 "(more than 5 %%)", e->raster_path, ga / 1e6, gv / 1e9, ra / 1e6, rv / 1e9, 100 * da,
                 100 * dv);
        return gate(e, msg, err);
    }
    return SPH_OK;
}

double fc_land_fraction(const sph_landmask *L, const sph_particles *P, size_t *count)
{
    size_t on = 0;
    for (size_t k = 0; L->land && k < P->n; k++) {
        long i = (long)floor((P->x[k] - L->x0) / L->dx), j = (long)floor((P->y[k] - L->y0) / L->dy);
        if (i >= 0 && j >= 0 && i < L->nx && j < L->ny && L->land[(size_t)j * L->nx + i])
            on++;
    }
    if (count)
        *count = on;
    return P->n ? (double)on / (double)P->n : 0.0;
}

int fc_land_gate(engine *e, sph_error *err)
{
    const sph_particles *P = sph_model_particles(e->m);
    size_t on = 0;
    double f = fc_land_fraction(&e->plane, P, &on);
    if (e->res)
        e->res->land_fraction = f;
    if (f > 0.01) {
        char msg[200];
        snprintf(msg, sizeof msg, "forecast %s: %zu of %zu particles (%.2f %%) on land at the end (more "
                 "than 1 %%)", e->cname, on, P->n, 100 * f);
        return gate(e, msg, err);
    }
    return SPH_OK;
}

/* The end of a cold or a warm start. The line for model.compact_gradients
 * auto's choice (the first lists are built). Then the engine reads the
 * plane's land mask from the model's own copy (sph_model_create copied
 * it) and gives its own back: one byte per cell, 6.6 B per particle at
 * 1e6 particles (docs/bench.md, Session 11: memory at 1e6). The same
 * cells. */
static void start_done(engine *e)
{
    if (e->cfg->model.compact_gradients == SPH_COMPACT_AUTO && sph_model_compact_form(e->m))
        log_info("forecast %s: %zu particles: the pair gradients in their factor form (model.compact_gradients "
                 "auto, from %d particles: the same results, less memory)",
                 e->cname, sph_model_particles(e->m)->n, SPH_MEMORY_BOUND_PARTICLES);
    const sph_landmask *ml = sph_model_landmask(e->m);
    if (!ml || !e->plane_land || ml->nx != e->plane.nx || ml->ny != e->plane.ny)
        return;
    e->plane.land = ml->land;
    free(e->plane_land);
    e->plane_land = NULL;
}

int fc_cold_start(engine *e, sph_error *err)
{
    const struct sph_config *cfg = e->cfg;
    if (!cfg->initial.path || !cfg->initial.path[0])
        return sph_err_set(err, SPH_ERR_CONFIG,
                           "forecast %s: no warm-start file and initial.path is empty: nothing to start from",
                           e->cname);
    int rc;
    if (!e->raster &&
        (rc = fc_read_raster(e, cfg->initial.path, cfg->initial.format, cfg->initial.conc_var, e->t0,
                          &e->raster, e->raster_path, sizeof e->raster_path, "initial field", err)))
        return rc;
    seed_options so;
    fc_seed_options(e, &so);
    size_t count = 0;
    if ((rc = seed_count(e->raster, e->proj, e->lm, &so, &count, err)))
        return rc;
    e->cap = fc_ocean_capacity(e, count > 0 ? count : 1);
    e->m = sph_model_create(&e->prm, e->cap, &e->plane);
    if (!e->m)
        return sph_err_set(err, SPH_ERR_NOMEM, "model: cannot create a model for %zu particles", e->cap);
    if (e->dd && sph_model_set_canonical(e->m, 1)) /* parallel.decomposition "domain" (forecast_domain.c) */
        return sph_err_set(err, SPH_ERR_NOMEM, "model: no memory for the canonical order (%zu particles)", e->cap);
    sph_particles *P = sph_model_particles(e->m);
    fc_seeded seeded;
    if ((rc = fc_seed(e, &so, P, &seeded, err)))
        return rc;
    if (seeded.dropped)
        log_info("forecast %s: %zu seeded particles outside the domain box left out", e->cname, seeded.dropped);
    if ((rc = seed_gate(e, &so, &seeded, err)))
        return rc;
    for (size_t k = 0; k < P->n; k++) {
        P->snow[k] = 0.0;
        P->sml0[k] = 0.0; /* sph_model_init takes sml */
        P->s11[k] = P->s22[k] = P->s12[k] = 0.0;
    }
    if (e->req->member)
        fc_member_perturb_initial(e->req->member, P);
    if ((rc = alloc_work(e, err)))
        return rc;
    if ((rc = fc_ocean_setup(e, err)))
        return rc;
    if ((rc = fc_fill_forcing(e, e->t0, err)))
        return rc;
    for (size_t k = 0; k < P->n; k++)
        sph_thermo_init_particle(&cfg->model.thermo, P, k, P->tair[k]);
    if ((rc = fc_resolve_dt(e, err)))
        return rc;
    sph_status st;
    if (sph_model_init(e->m, &st) != SPH_STEP_OK) {
        char what[256];
        fc_fmt_status(&st, what, sizeof what);
        if (fc_settings_fault(&st))
            return sph_err_set(err, SPH_ERR_CONFIG, "model settings: %s (initial field %s)", what,
                               e->raster_path);
        return sph_err_set(err, SPH_ERR_BAD_DATA, "initial field %s: particle %ld: %s", e->raster_path,
                           st.particle, what);
    }
    start_done(e);
    snprintf(e->start_mode, sizeof e->start_mode, "cold");
    log_info("forecast %s: cold start from %s: %zu particles", e->cname, e->raster_path, P->n);
    return SPH_OK;
}

int fc_warm_start(engine *e, sph_error *err)
{
    const char *path = e->req->warm_start;
    restart_header h;
    int rc = restart_read_header(path, &h, err);
    if (rc)
        return rc;
    e->cap = fc_ocean_capacity(e, h.n > 0 ? h.n : 1);
    e->m = sph_model_create(&e->prm, e->cap, &e->plane);
    if (!e->m)
        return sph_err_set(err, SPH_ERR_NOMEM, "model: cannot create a model for %zu particles", e->cap);
    if (e->dd && sph_model_set_canonical(e->m, 1)) /* parallel.decomposition "domain", as a cold start */
        return sph_err_set(err, SPH_ERR_NOMEM, "model: no memory for the canonical order (%zu particles)", e->cap);
    sph_particles *P = sph_model_particles(e->m);
    if ((rc = restart_read(path, geo_proj_definition(e->proj), &h, P, err)))
        return rc;
    if ((rc = fc_ocean_setup(e, err)))
        return rc;
    sph_ocean *o = sph_model_ocean(e->m);
    int found = 0;
    if (o && (rc = restart_read_ocean(path, o, &found, err)))
        return rc;
    if (o && !found) /* a file without the mixed layer: it starts afresh at its freezing point (docs/ocean.md) */
        log_info("forecast %s: warm-start file %s has no mixed layer: it starts at its freezing point", e->cname,
                 path);
    if (fabs(h.time - e->t0) > 1.0) {
        char a[32], b[32];
        iso(h.time, a, sizeof a);
        iso(e->t0, b, sizeof b);
        log_warn("forecast %s: warm-start file %s is valid at %s, not at the cycle time %s", e->cname, path, a,
                 b);
    }
    /* a new run: its own clock and mass budget, the thermodynamic phase kept */
    sph_model_clock c = h.clock;
    c.time = 0.0;
    c.steps = 0;
    memset(&c.budget, 0, sizeof c.budget);
    if (e->req->member)
        fc_member_perturb_initial(e->req->member, P);
    double mass = 0;
    for (size_t k = 0; k < P->n; k++)
        mass += P->mass[k];
    c.budget.mass_initial = c.budget.mass = mass;
    if ((rc = fc_resolve_dt(e, err)))
        return rc;
    sph_status st;
    if (sph_model_resume(e->m, &c, &st) != SPH_STEP_OK) {
        char what[256];
        fc_fmt_status(&st, what, sizeof what);
        if (fc_settings_fault(&st))
            return sph_err_set(err, SPH_ERR_CONFIG, "model settings: %s (warm start %s)", what, path);
        return sph_err_set(err, SPH_ERR_BAD_DATA, "warm start %s: particle %ld: %s", path, st.particle, what);
    }
    if ((rc = alloc_work(e, err)))
        return rc;
    if ((rc = fc_fill_forcing(e, e->t0, err)))
        return rc;
    start_done(e);
    snprintf(e->start_mode, sizeof e->start_mode, "warm");
    log_info("forecast %s: warm start from %s: %zu particles", e->cname, path, P->n);
    return SPH_OK;
}
