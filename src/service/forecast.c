/* The forecast engine (service/forecast.h): configuration -> projection,
 * land mask, forcing, initial particles -> model steps -> products and the
 * restart file of the next cycle. docs/engine.md describes every choice.
 *
 * Invariants:
 *  - nothing in the stage dir survives a failed or cancelled run (the
 *    product writer is aborted, a restart file already written is removed);
 *  - nothing depends on the wall clock or on uninitialised memory: a run
 *    is a function of the configuration, the request and the input files
 *    (for a fixed OpenMP thread count), so `run` and `hindcast` of one
 *    cycle write identical data variables.
 */
#include "service/forecast.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/model.h"
#include "io/forcing.h"
#include "io/geo.h"
#include "io/landmask.h"
#include "io/products.h"
#include "io/raster.h"
#include "io/restart.h"
#include "io/seed.h"
#include "service/config.h"
#include "service/cycle.h"
#include "service/schedule.h"
#include "util/log.h"
#include "util/timeutil.h"

#ifndef SPHICE_VERSION
#define SPHICE_VERSION "unknown"
#endif
#ifndef SPHICE_GIT
#define SPHICE_GIT "unknown"
#endif

#define DEG2RAD (M_PI / 180.0)
#define METRES_PER_DEGREE (6371000.0 * DEG2RAD) /* along a meridian, sphere R = 6371 km */
#define MAX_PLANE_CELLS 16000000L /* plane land mask cells */
#define MAX_LL_CELLS 4000000L     /* lon/lat land mask cells (GSHHG rasterisation) */
#define SIGMA_SB 5.670374419e-8
/* Defaults for quantities no forcing source provides (docs/engine.md). */
#define DEFAULT_RH 0.9          /* relative humidity over water */
#define DEFAULT_CLOUD 0.5       /* cloud fraction for the longwave default */

typedef struct engine {
    const struct sph_config *cfg;
    const forecast_request *req;
    char cname[32];          /* cycle name, for messages */
    double t0, t_end;        /* forecast start and end, s since 1970 */
    geo_proj *proj;
    landmask *lm;            /* lon/lat land mask, NULL: none */
    sph_landmask plane;      /* the model's land mask on the plane */
    unsigned char *plane_land;
    forcing *forc[8];        /* one per source: a source that cannot serve a point is known */
    int forc_kind[8];
    const char *forc_name[8];
    size_t nforc;
    long coast_fallbacks;    /* particle-steps with no ocean/tide data (unresolved coast) */
    ice_raster *raster;      /* cold start raster (or the raster grid) */
    char raster_path[4096];
    sph_model *m;
    size_t cap;
    int thermo_on;
    sph_params prm;          /* the model's parameters: config, dt resolved */
    int dt_auto;             /* model.dt = 0: auto time stepping */
    double dt_base;          /* the interval the auto step divides, s */
    unsigned provided;       /* forcing quantities found at the first sample */
    /* per-particle work arrays [cap] */
    double *lon, *lat, *angle, *ue, *vn, *uwe, *vwn, *gxe, *gyn, *ssh;
    double *tair, *qair, *swdn, *lwdn, *sst, *fw;
    double *q[13];                    /* one source's sample, see sample_source */
    unsigned char *bad;               /* the source could not serve this particle */
    double *pue, *pvn, *div, *shear;  /* output: east/north velocity, strain invariants */
    long *ids_before;                 /* ids at the last forcing fill (error messages) */
    double *lon_before, *lat_before;
    size_t n_before;
    /* output grid */
    prod_grid grid;
    size_t npts;
    double *gx, *gy, *g_conc, *g_hbar, *g_thick, *g_u, *g_v, *g_pres, *g_div, *g_shear, *g_dens;
    unsigned char *g_land;
    prod_writer *pw;
    char restart_path[4200];
    int restart_written;
    char start_mode[16];
} engine;

/* --------------------------------------------------------------- helpers */

static void iso(double t, char *buf, size_t len) { time_format_iso(t, buf, len); }

static void fmt_lonlat(double lon, double lat, char *buf, size_t len)
{
    if (!isfinite(lon) || !isfinite(lat)) {
        snprintf(buf, len, "an unknown position");
        return;
    }
    snprintf(buf, len, "%.2f%c %.2f%c", fabs(lon), lon < 0 ? 'W' : 'E', fabs(lat),
             lat < 0 ? 'S' : 'N');
}

/* "speed 12.3 exceeds the speed limit 10 (numerical blow-up)": the limit
 * goes before a parenthesised remark of the core's sentence for a bound the
 * value crossed, after it as "(limit L)" for a range, and nowhere else. */
static void fmt_status(const sph_status *st, char *buf, size_t len)
{
    const char *what = st->what && *st->what ? st->what : "failed";
    switch (st->kind) {
    case SPH_FAULT_SPEED:
    case SPH_FAULT_THICKNESS:
    case SPH_FAULT_SUBSTEPS: {
        if (st->limit == 0.0)
            break;
        const char *paren = strstr(what, " (");
        if (paren)
            snprintf(buf, len, "%s %.6g %.*s %.6g%s", st->quantity, st->value, (int)(paren - what), what,
                     st->limit, paren);
        else
            snprintf(buf, len, "%s %.6g %s %.6g", st->quantity, st->value, what, st->limit);
        return;
    }
    case SPH_FAULT_TIMESTEP:
    case SPH_FAULT_RANGE:
    case SPH_FAULT_PARAMETER:
        snprintf(buf, len, "%s %.6g %s (limit %.6g)", st->quantity, st->value, what, st->limit);
        return;
    default:
        break;
    }
    snprintf(buf, len, "%s %.6g %s", st->quantity, st->value, what);
}

static void *xcalloc(size_t n, size_t size, int *ok)
{
    void *p = calloc(n ? n : 1, size);
    if (!p)
        *ok = 0;
    return p;
}

static void engine_free(engine *e)
{
    products_abort(e->pw);
    e->pw = NULL;
    if (e->restart_written)
        unlink(e->restart_path);
    geo_proj_free(e->proj);
    landmask_free(e->lm);
    free(e->plane_land);
    for (size_t k = 0; k < e->nforc; k++)
        forcing_close(e->forc[k]);
    for (int k = 0; k < 13; k++)
        free(e->q[k]);
    free(e->bad);
    ice_raster_free(e->raster);
    sph_model_free(e->m);
    double *arrays[] = {e->lon, e->lat, e->angle, e->ue, e->vn, e->uwe, e->vwn, e->gxe, e->gyn,
                        e->ssh, e->tair, e->qair, e->swdn, e->lwdn, e->sst, e->fw, e->pue, e->pvn,
                        e->div, e->shear, e->lon_before, e->lat_before, e->gx, e->gy, e->g_conc,
                        e->g_hbar, e->g_thick, e->g_u, e->g_v, e->g_pres, e->g_div, e->g_shear,
                        e->g_dens};
    for (size_t k = 0; k < sizeof arrays / sizeof arrays[0]; k++)
        free(arrays[k]);
    free(e->ids_before);
    free(e->g_land);
}

/* ------------------------------------------------------------ parameters */

static int check_params(const struct sph_config *cfg, const sph_params *prm, sph_error *err)
{
    const char *name = "";
    double lo = 0, hi = 0;
    if (sph_params_check(prm, &name, &lo, &hi) != SPH_STEP_OK) {
        /* report the offending value: find it by name among the common ones */
        const sph_params *p = prm;
        double v = NAN;
        if (!strcmp(name, "dt")) v = p->dt;
        else if (!strcmp(name, "thermo_dt")) v = p->thermo_dt;
        else if (!strcmp(name, "sml_factor")) v = p->sml_factor;
        else if (!strcmp(name, "kernel_radius")) v = p->kernel_radius;
        else if (!strcmp(name, "rho_i")) v = p->rho_i;
        else if (!strcmp(name, "P0")) v = p->P0;
        else if (!strcmp(name, "speed_limit")) v = p->speed_limit;
        else if (!strcmp(name, "thickness_limit")) v = p->thickness_limit;
        else if (!strcmp(name, "max_neighbours")) v = p->max_neighbours;
        if (isfinite(v))
            return sph_err_set(err, SPH_ERR_PARAM, "model: parameter %s = %g outside [%g, %g]", name, v,
                               lo, hi);
        return sph_err_set(err, SPH_ERR_PARAM, "model: parameter %s outside [%g, %g]", name, lo, hi);
    }
    if (cfg->model.thermo_dt > 0 && cfg->model.thermo.model != SPH_THERMO_OFF &&
        sph_thermo_params_check(&cfg->model.thermo, &name, &lo, &hi) != SPH_STEP_OK)
        return sph_err_set(err, SPH_ERR_PARAM, "model.thermo: parameter %s outside [%g, %g]", name, lo,
                           hi);
    return SPH_OK;
}

/* Whole seconds shared by the thermodynamic step, the output interval and
 * the distance to the next cycle (its restart): the auto step divides it,
 * so none of them falls between two steps. 0 when none is whole. */
static double auto_dt_base(const engine *e, double t_next)
{
    const double iv[3] = {e->thermo_on ? e->cfg->model.thermo_dt : 0.0,
                          e->cfg->output.interval_hours * 3600.0, t_next - e->t0};
    long g = 0;
    for (int i = 0; i < 3; i++) {
        if (!(iv[i] >= 1.0) || fabs(iv[i] - round(iv[i])) > 1e-6)
            continue;
        long a = lround(iv[i]), b = g;
        while (b) {
            long t = a % b;
            a = b;
            b = t;
        }
        g = a;
    }
    return (double)g;
}

/* Auto time stepping: the step from the measured envelope at the placed
 * particles' spacing (sph_params_auto_dt), before the model's envelope
 * check in sph_model_init / sph_model_resume. */
static int resolve_dt(engine *e, sph_error *err)
{
    if (!e->dt_auto)
        return SPH_OK;
    double spacing = sph_model_spacing(e->m);
    const char *why = "";
    double stable = sph_params_stable_dt(&e->prm, spacing, NULL);
    e->prm.dt = sph_params_auto_dt(&e->prm, spacing, e->dt_base, &why);
    if (e->thermo_on && e->prm.dt > e->cfg->model.thermo_dt)
        e->prm.dt = e->cfg->model.thermo_dt;
    if (sph_model_set_params(e->m, &e->prm) != SPH_STEP_OK)
        return sph_err_set(err, SPH_ERR_PARAM, "model: auto time step %g s not accepted", e->prm.dt);
    if (isfinite(stable))
        log_info("forecast %s: auto time step %g s (spacing %.0f m, measured stable step %.0f s; set by %s)",
                 e->cname, e->prm.dt, spacing, stable, why);
    else
        log_info("forecast %s: auto time step %g s (spacing %.0f m, no stability bound; set by %s)", e->cname,
                 e->prm.dt, spacing, why);
    return SPH_OK;
}

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
    for (size_t s = 0; s < cfg->nforcing && s < 8; s++)
        if (cfg->forcing[s].kind == FORCING_OCEAN && req->forcing_files[s] && req->forcing_files[s][0])
            return req->forcing_files[s][0];
    for (size_t s = 0; s < cfg->nforcing && s < 8; s++)
        if (req->forcing_files[s] && req->forcing_files[s][0])
            return req->forcing_files[s][0];
    return NULL;
}

static int build_landmask(engine *e, double xmin, double xmax, double ymin, double ymax, double cell,
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
        if (!cfg->landmask.path || !cfg->landmask.path[0])
            return sph_err_set(err, SPH_ERR_CONFIG, "config: landmask.path: required for source netcdf");
        /* the default "mask" is one of the names the automatic search tries
         * (after land_binary_mask, sea_binary_mask, lsm ...) */
        e->lm = landmask_read_netcdf(cfg->landmask.path,
                                     cfg->landmask.variable && cfg->landmask.variable[0] &&
                                             strcmp(cfg->landmask.variable, "mask")
                                         ? cfg->landmask.variable : NULL,
                                     LANDMASK_NC_AUTO, err);
        if (!e->lm)
            return err->code ? err->code : SPH_ERR_IO;
        break;
    case CFG_LAND_FORCING: {
        const char *path = cfg->landmask.path && cfg->landmask.path[0] ? cfg->landmask.path
                                                                       : ocean_file(cfg, e->req);
        if (!path)
            return sph_err_set(err, SPH_ERR_CONFIG,
                               "config: landmask.source forcing: no forcing file to take the land from");
        e->lm = landmask_read_netcdf(path, cfg->landmask.variable, LANDMASK_NC_FILL, err);
        if (!e->lm)
            return err->code ? err->code : SPH_ERR_IO;
        break;
    }
    default:
        return sph_err_set(err, SPH_ERR_CONFIG, "config: landmask.source: unknown value %d",
                           cfg->landmask.source);
    }
    /* plane grid over the projected domain box */
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
static int plane_box(engine *e, double *xmin, double *xmax, double *ymin, double *ymax, sph_error *err)
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

/* --------------------------------------------------------------- forcing */

int forecast_source_spec(const struct sph_config *cfg, size_t s, const char *const *files,
                         forcing_source_spec *sp, forcing_name_map **map, sph_error *err)
{
    const cfg_forcing_source *src = &cfg->forcing[s];
    size_t nfiles = 0;
    while (files && files[nfiles])
        nfiles++;
    memset(sp, 0, sizeof *sp);
    *map = NULL;
    sp->name = src->name;
    sp->kind = (forcing_kind)src->kind;
    sp->files = files;
    sp->nfiles = nfiles;
    if (src->variables.n) {
        *map = calloc(src->variables.n, sizeof **map);
        if (!*map)
            return sph_err_set(err, SPH_ERR_NOMEM, "forcing: out of memory");
        for (size_t k = 0; k < src->variables.n; k++) {
            (*map)[k].standard_name = src->variables.key[k];
            (*map)[k].variable = src->variables.val[k];
        }
        sp->map = *map;
        sp->nmap = src->variables.n;
    }
    for (size_t k = 0; k < src->required.n; k++)
        sp->required |= (unsigned)config_quantity_flag(src->required.v[k]);
    for (size_t k = 0; k < src->optional_q.n; k++)
        sp->optional |= (unsigned)config_quantity_flag(src->optional_q.v[k]);
    return SPH_OK;
}

static int open_forcing(engine *e, sph_error *err)
{
    const struct sph_config *cfg = e->cfg;
    const forecast_request *req = e->req;
    size_t ns = cfg->nforcing < 8 ? cfg->nforcing : 8;
    forcing_source_spec specs[8];
    forcing_name_map *maps[8] = {0};
    size_t nspecs = 0;
    int rc = SPH_OK;
    for (size_t s = 0; s < ns; s++) {
        const cfg_forcing_source *src = &cfg->forcing[s];
        const char *const *files = req->forcing_files[s];
        size_t nfiles = 0;
        while (files && files[nfiles])
            nfiles++;
        if (nfiles == 0) {
            if (src->optional_source) {
                log_warn("forecast %s: optional forcing %s has no files: left out", e->cname, src->name);
                continue;
            }
            rc = sph_err_set(err, SPH_ERR_COVERAGE, "forcing %s: no files for cycle %s", src->name,
                             e->cname);
            break;
        }
        rc = forecast_source_spec(cfg, s, files, &specs[nspecs], &maps[s], err);
        if (rc != SPH_OK)
            break;
        nspecs++;
    }
    /* one forcing object per source (same checks and messages as opening
     * them together); currents and SSH are summed over sources here */
    for (size_t k = 0; k < nspecs && rc == SPH_OK; k++) {
        rc = forcing_open(&e->forc[k], &specs[k], 1, e->t0, e->t_end, cfg->domain.lon_min,
                          cfg->domain.lon_max, cfg->domain.lat_min, cfg->domain.lat_max, err);
        if (rc == SPH_OK) {
            e->forc_kind[k] = specs[k].kind;
            e->forc_name[k] = specs[k].name;
            e->nforc = k + 1;
        }
    }
    if (rc == SPH_OK && nspecs == 0)
        rc = sph_err_set(err, SPH_ERR_CONFIG, "forcing: no source has files for cycle %s", e->cname);
    for (size_t s = 0; s < 8; s++)
        free(maps[s]);
    return rc;
}

enum { Q_UE, Q_VN, Q_TAIR, Q_QAIR, Q_SWDN, Q_LWDN, Q_UWE, Q_VWN, Q_SSH, Q_GXE, Q_GYN, Q_SST, Q_FW };

static void sample_view(engine *e, size_t k, forcing_sample *s)
{
    memset(s, 0, sizeof *s);
    s->u_east = e->q[Q_UE] + k;
    s->v_north = e->q[Q_VN] + k;
    s->tair = e->q[Q_TAIR] + k;
    s->qair = e->q[Q_QAIR] + k;
    s->swdn = e->q[Q_SWDN] + k;
    s->lwdn = e->q[Q_LWDN] + k;
    s->uw_east = e->q[Q_UWE] + k;
    s->vw_north = e->q[Q_VWN] + k;
    s->ssh = e->q[Q_SSH] + k;
    s->ssh_dx_east = e->q[Q_GXE] + k;
    s->ssh_dy_north = e->q[Q_GYN] + k;
    s->sst = e->q[Q_SST] + k;
    s->fw = e->q[Q_FW] + k;
}

/* Samples source src at the n particles into e->q. An ocean or tide
 * source whose grid has no water near some particles (a coast the ocean
 * model does not resolve) serves the others; those get no current, no
 * sea-surface slope and the other defaults (e->bad). Any other failure,
 * or a source that can serve no particle at all, is an error. */
static int sample_source(engine *e, size_t src, double t, size_t n, unsigned *got, sph_error *err)
{
    forcing_sample s;
    sample_view(e, 0, &s);
    memset(e->bad, 0, n);
    sph_error local;
    sph_error_clear(&local);
    char when[32];
    iso(t, when, sizeof when);
    int rc = forcing_sample_at(e->forc[src], t, n, e->lon, e->lat, &s, &local);
    if (rc == SPH_OK) {
        *got = s.provided;
        return SPH_OK;
    }
    if (rc != SPH_ERR_COVERAGE || e->forc_kind[src] == FORCING_ATMOSPHERE || n < 2)
        return sph_err_set(err, rc, "forcing at %s: %s", when, local.msg);
    size_t nbad = 0, first_bad = 0;
    unsigned flags = 0;
    for (size_t k = 0; k < n; k++) {
        forcing_sample one;
        sample_view(e, k, &one);
        sph_error e1;
        sph_error_clear(&e1);
        int r1 = forcing_sample_at(e->forc[src], t, 1, e->lon + k, e->lat + k, &one, &e1);
        if (r1 == SPH_OK) {
            flags |= one.provided;
        } else if (r1 == SPH_ERR_COVERAGE) {
            if (!nbad++)
                first_bad = k;
            e->bad[k] = 1;
        } else {
            return sph_err_set(err, r1, "forcing at %s: %s", when, e1.msg);
        }
    }
    if (nbad == n)
        return sph_err_set(err, rc, "forcing at %s: %s", when, local.msg);
    if (!e->coast_fallbacks) {
        char ll[64];
        fmt_lonlat(e->lon[first_bad], e->lat[first_bad], ll, sizeof ll);
        log_warn("forecast %s: forcing %s has no water near %zu particle(s) (first at %s, %s): "
                 "no current or sea-surface slope there (reported once)", e->cname, e->forc_name[src],
                 nbad, ll, when);
    }
    e->coast_fallbacks += (long)nbad;
    *got = flags;
    return SPH_OK;
}

/* Adds one source's sample to the particle forcing: currents and SSH sum
 * over sources (ocean + tide, as the forcing reader does), other
 * quantities come from the first source that provides them. */
static void merge_source(engine *e, size_t n, unsigned got, unsigned before)
{
    static const struct { int q; unsigned flag; int sum; } map[] = {
        {Q_UE, FQ_WIND, 0}, {Q_VN, FQ_WIND, 0}, {Q_TAIR, FQ_TAIR, 0}, {Q_QAIR, FQ_HUMIDITY, 0},
        {Q_SWDN, FQ_SWDN, 0}, {Q_LWDN, FQ_LWDN, 0}, {Q_UWE, FQ_CURRENT, 1}, {Q_VWN, FQ_CURRENT, 1},
        {Q_SSH, FQ_SSH, 1}, {Q_GXE, FQ_SSH, 1}, {Q_GYN, FQ_SSH, 1}, {Q_SST, FQ_SST, 0},
        {Q_FW, FQ_OCEAN_FLUX, 0}};
    double *dst[13] = {e->ue, e->vn, e->tair, e->qair, e->swdn, e->lwdn, e->uwe, e->vwn, e->ssh, e->gxe,
                       e->gyn, e->sst, e->fw};
    for (size_t m = 0; m < sizeof map / sizeof map[0]; m++) {
        if (!(got & map[m].flag) || (!map[m].sum && (before & map[m].flag)))
            continue;
        const double *q = e->q[map[m].q];
        double *d = dst[map[m].q];
        for (size_t k = 0; k < n; k++) {
            if (e->bad[k])
                continue; /* keeps the default (or the other sources' sum) */
            d[k] = map[m].sum ? d[k] + q[k] : q[k];
        }
    }
}

/* Fills every live particle's forcing at time t (see docs/engine.md for
 * the defaults of quantities no source provides). */
static int fill_forcing(engine *e, double t, sph_error *err)
{
    sph_particles *P = sph_model_particles(e->m);
    size_t n = P->n;
    if (n == 0)
        return SPH_OK;
    int rc = geo_inverse(e->proj, n, P->x, P->y, e->lon, e->lat, err);
    if (rc)
        return rc;
    const double tf = sph_freezing_point(&e->cfg->model.thermo);
    for (size_t k = 0; k < n; k++) {
        e->ue[k] = e->vn[k] = 0.0;
        e->uwe[k] = e->vwn[k] = 0.0;
        e->gxe[k] = e->gyn[k] = 0.0;
        e->ssh[k] = 0.0;
        e->tair[k] = tf;
        e->qair[k] = NAN;
        e->swdn[k] = 0.0;
        e->lwdn[k] = NAN;
        e->sst[k] = NAN; /* the thermodynamics takes the freezing point */
        e->fw[k] = NAN;  /* the thermodynamics takes fw_default */
    }
    unsigned provided = 0;
    for (size_t src = 0; src < e->nforc; src++) {
        unsigned got = 0;
        int rc2 = sample_source(e, src, t, n, &got, err);
        if (rc2)
            return rc2;
        merge_source(e, n, got, provided);
        provided |= got;
    }
    e->provided = provided;
    if (e->thermo_on && !(provided & FQ_TAIR))
        return sph_err_set(err, SPH_ERR_MISSING_VAR,
                           "forcing: no source provides air_temperature, which the thermodynamics "
                           "needs (add it, or set model.thermo.dt 0)");
    double pa = e->cfg->model.thermo.air_pressure;
    for (size_t k = 0; k < n; k++) {
        double a = geo_grid_angle(e->proj, e->lon[k], e->lat[k]);
        if (!isfinite(a))
            a = 0.0;
        e->angle[k] = a;
        double c = cos(a), sn = sin(a);
        /* east/north -> plane x/y (io/geo.h) */
        P->ua[k] = e->ue[k] * c + e->vn[k] * sn;
        P->va[k] = -e->ue[k] * sn + e->vn[k] * c;
        P->uw[k] = e->uwe[k] * c + e->vwn[k] * sn;
        P->vw[k] = -e->uwe[k] * sn + e->vwn[k] * c;
        P->sshx[k] = e->gxe[k] * c + e->gyn[k] * sn;
        P->sshy[k] = -e->gxe[k] * sn + e->gyn[k] * c;
        P->lat[k] = e->lat[k];
        double T = e->tair[k];
        P->tair[k] = T;
        if (!(provided & FQ_HUMIDITY)) {
            /* DEFAULT_RH over water, the saturation formula of the thermo check */
            double es = DEFAULT_RH * 611.2 * exp(17.62 * T / (243.12 + T));
            e->qair[k] = 0.622 * es / (pa - 0.378 * es);
        }
        P->qair[k] = e->qair[k];
        P->swdn[k] = e->swdn[k];
        if (!(provided & FQ_LWDN)) {
            /* Koenig-Langlo & Augstein (1994): eps = 0.765 + 0.22 N^3 */
            double eps = 0.765 + 0.22 * DEFAULT_CLOUD * DEFAULT_CLOUD * DEFAULT_CLOUD;
            double tk = T + 273.15;
            e->lwdn[k] = eps * SIGMA_SB * tk * tk * tk * tk;
        }
        P->lwdn[k] = e->lwdn[k];
        P->sst[k] = e->sst[k];
        P->fw[k] = e->fw[k];
        P->fsens[k] = NAN;
        P->flat[k] = NAN;
    }
    /* for messages about a step that fails */
    memcpy(e->ids_before, P->id, n * sizeof *P->id);
    memcpy(e->lon_before, e->lon, n * sizeof *e->lon);
    memcpy(e->lat_before, e->lat, n * sizeof *e->lat);
    e->n_before = n;
    return SPH_OK;
}

/* ---------------------------------------------------- initial particles */

static int read_raster(engine *e, const char *tmpl, int format, const char *conc_var, double valid_time,
                       ice_raster **out, char *path, size_t plen, const char *what, sph_error *err)
{
    const struct sph_config *cfg = e->cfg;
    int rc = cycle_expand_template(tmpl, valid_time, path, plen, err);
    if (rc)
        return rc;
    ice_raster_options o;
    ice_raster_options_default(&o);
    o.default_thickness = cfg->initial.default_thickness;
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

static double spacing_m(const engine *e)
{
    if (e->cfg->initial.spacing_deg > 0)
        return e->cfg->initial.spacing_deg * METRES_PER_DEGREE;
    if (e->raster) {
        int j = e->raster->nlat / 2;
        return sqrt(ice_raster_cell_area(e->raster, j));
    }
    return 2000.0;
}

static int alloc_work(engine *e, sph_error *err)
{
    size_t c = e->cap ? e->cap : 1;
    int ok = 1;
    double **arrays[] = {&e->lon, &e->lat, &e->angle, &e->ue, &e->vn, &e->uwe, &e->vwn, &e->gxe, &e->gyn,
                         &e->ssh, &e->tair, &e->qair, &e->swdn, &e->lwdn, &e->sst, &e->fw, &e->pue,
                         &e->pvn, &e->div, &e->shear, &e->lon_before, &e->lat_before};
    for (size_t k = 0; k < sizeof arrays / sizeof arrays[0]; k++)
        *arrays[k] = xcalloc(c, sizeof(double), &ok);
    e->ids_before = xcalloc(c, sizeof(long), &ok);
    for (int k = 0; k < 13; k++)
        e->q[k] = xcalloc(c, sizeof(double), &ok);
    e->bad = xcalloc(c, 1, &ok);
    return ok ? SPH_OK : sph_err_set(err, SPH_ERR_NOMEM, "forecast: out of memory (%zu particles)", c);
}

/* Names a particle's problem: "particle 17 at 121.80E 40.61N". */
static void particle_where(const engine *e, long id, char *buf, size_t len)
{
    for (size_t k = 0; k < e->n_before; k++)
        if (e->ids_before[k] == id) {
            char ll[64];
            fmt_lonlat(e->lon_before[k], e->lat_before[k], ll, sizeof ll);
            snprintf(buf, len, "particle %ld at %s", id, ll);
            return;
        }
    if (id >= 0)
        snprintf(buf, len, "particle %ld", id);
    else
        snprintf(buf, len, "all particles");
}

/* A refusal by the model that the configuration causes, not the input:
 * the step outside the measured stability envelope (no particle at fault).
 * A bad clock or particle count stays the file's fault. */
static int settings_fault(const sph_status *st)
{
    return st->particle < 0 && (st->kind == SPH_FAULT_TIMESTEP || st->kind == SPH_FAULT_SUBSTEPS);
}

static int cold_start(engine *e, sph_error *err)
{
    const struct sph_config *cfg = e->cfg;
    if (!cfg->initial.path || !cfg->initial.path[0])
        return sph_err_set(err, SPH_ERR_CONFIG,
                           "forecast %s: no warm-start file and initial.path is empty: nothing to start from",
                           e->cname);
    int rc;
    if (!e->raster &&
        (rc = read_raster(e, cfg->initial.path, cfg->initial.format, cfg->initial.conc_var, e->t0,
                          &e->raster, e->raster_path, sizeof e->raster_path, "initial field", err)))
        return rc;
    seed_options so;
    seed_options_default(&so);
    so.threshold = cfg->initial.threshold;
    so.spacing_m = cfg->initial.spacing_deg > 0 ? cfg->initial.spacing_deg * METRES_PER_DEGREE : 0.0;
    so.sml_factor = cfg->model.sml_factor;
    so.rho_ice = cfg->model.rho_i;
    so.first_id = 0;
    if (so.spacing_m > 0) { /* lattice over the model's plane box */
        so.xmin = e->plane.x0;
        so.ymin = e->plane.y0;
        so.xmax = e->plane.x0 + e->plane.nx * e->plane.dx;
        so.ymax = e->plane.y0 + e->plane.ny * e->plane.dy;
    }
    size_t count = 0;
    if ((rc = seed_count(e->raster, e->proj, e->lm, &so, &count, err)))
        return rc;
    e->cap = count > 0 ? count : 1;
    e->m = sph_model_create(&e->prm, e->cap, &e->plane);
    if (!e->m)
        return sph_err_set(err, SPH_ERR_NOMEM, "model: cannot create a model for %zu particles", e->cap);
    sph_particles *P = sph_model_particles(e->m);
    if ((rc = seed_from_raster(e->raster, e->proj, e->lm, &so, P, err)))
        return rc;
    /* particles outside the model's plane box would leave at once: drop them */
    size_t dropped = 0;
    double x1 = e->plane.x0 + e->plane.nx * e->plane.dx, y1 = e->plane.y0 + e->plane.ny * e->plane.dy;
    for (size_t k = P->n; k-- > 0;)
        if (!(P->x[k] >= e->plane.x0 && P->x[k] < x1 && P->y[k] >= e->plane.y0 && P->y[k] < y1)) {
            sph_particles_remove(P, k);
            dropped++;
        }
    if (dropped)
        log_info("forecast %s: %zu seeded particles outside the domain box left out", e->cname, dropped);
    for (size_t k = 0; k < P->n; k++) {
        P->snow[k] = 0.0;
        P->sml0[k] = 0.0; /* sph_model_init takes sml */
        P->s11[k] = P->s22[k] = P->s12[k] = 0.0;
    }
    if ((rc = alloc_work(e, err)))
        return rc;
    if ((rc = fill_forcing(e, e->t0, err)))
        return rc;
    for (size_t k = 0; k < P->n; k++)
        sph_thermo_init_particle(&cfg->model.thermo, P, k, P->tair[k]);
    if ((rc = resolve_dt(e, err)))
        return rc;
    sph_status st;
    if (sph_model_init(e->m, &st) != SPH_STEP_OK) {
        char what[256];
        fmt_status(&st, what, sizeof what);
        if (settings_fault(&st))
            return sph_err_set(err, SPH_ERR_CONFIG, "model settings: %s (initial field %s)", what,
                               e->raster_path);
        return sph_err_set(err, SPH_ERR_BAD_DATA, "initial field %s: particle %ld: %s", e->raster_path,
                           st.particle, what);
    }
    snprintf(e->start_mode, sizeof e->start_mode, "cold");
    log_info("forecast %s: cold start from %s: %zu particles", e->cname, e->raster_path, P->n);
    return SPH_OK;
}

static int warm_start(engine *e, sph_error *err)
{
    const char *path = e->req->warm_start;
    restart_header h;
    int rc = restart_read_header(path, &h, err);
    if (rc)
        return rc;
    e->cap = h.n > 0 ? h.n : 1;
    e->m = sph_model_create(&e->prm, e->cap, &e->plane);
    if (!e->m)
        return sph_err_set(err, SPH_ERR_NOMEM, "model: cannot create a model for %zu particles", e->cap);
    sph_particles *P = sph_model_particles(e->m);
    if ((rc = restart_read(path, geo_proj_definition(e->proj), &h, P, err)))
        return rc;
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
    double mass = 0;
    for (size_t k = 0; k < P->n; k++)
        mass += P->mass[k];
    c.budget.mass_initial = c.budget.mass = mass;
    if ((rc = resolve_dt(e, err)))
        return rc;
    sph_status st;
    if (sph_model_resume(e->m, &c, &st) != SPH_STEP_OK) {
        char what[256];
        fmt_status(&st, what, sizeof what);
        if (settings_fault(&st))
            return sph_err_set(err, SPH_ERR_CONFIG, "model settings: %s (warm start %s)", what, path);
        return sph_err_set(err, SPH_ERR_BAD_DATA, "warm start %s: particle %ld: %s", path, st.particle, what);
    }
    if ((rc = alloc_work(e, err)))
        return rc;
    if ((rc = fill_forcing(e, e->t0, err)))
        return rc;
    snprintf(e->start_mode, sizeof e->start_mode, "warm");
    log_info("forecast %s: warm start from %s: %zu particles", e->cname, path, P->n);
    return SPH_OK;
}

/* --------------------------------------------------------------- products */

static int setup_grid(engine *e, sph_error *err)
{
    const struct sph_config *cfg = e->cfg;
    if (cfg->output.grid.mode == CFG_GRID_RASTER) {
        int rc;
        if (!e->raster &&
            (rc = read_raster(e, cfg->initial.path, cfg->initial.format, cfg->initial.conc_var, e->t0,
                              &e->raster, e->raster_path, sizeof e->raster_path, "initial field", err)))
            return rc;
        e->grid.nlon = e->raster->nlon;
        e->grid.nlat = e->raster->nlat;
        e->grid.lon0 = e->raster->lon[0];
        e->grid.lat0 = e->raster->lat[0];
        e->grid.dlon = e->raster->dlon;
        e->grid.dlat = e->raster->dlat;
    } else {
        e->grid.nlon = cfg->output.grid.nlon;
        e->grid.nlat = cfg->output.grid.nlat;
        e->grid.lon0 = cfg->output.grid.lon0;
        e->grid.lat0 = cfg->output.grid.lat0;
        e->grid.dlon = cfg->output.grid.dlon;
        e->grid.dlat = cfg->output.grid.dlat;
    }
    int rc = prod_grid_check(&e->grid, err);
    if (rc)
        return rc;
    size_t n = (size_t)e->grid.nlon * e->grid.nlat;
    e->npts = n;
    int ok = 1;
    double **arrays[] = {&e->gx, &e->gy, &e->g_conc, &e->g_hbar, &e->g_thick, &e->g_u, &e->g_v,
                         &e->g_pres, &e->g_div, &e->g_shear, &e->g_dens};
    for (size_t k = 0; k < sizeof arrays / sizeof arrays[0]; k++)
        *arrays[k] = xcalloc(n, sizeof(double), &ok);
    e->g_land = xcalloc(n, 1, &ok);
    if (!ok)
        return sph_err_set(err, SPH_ERR_NOMEM, "output grid: out of memory (%zu points)", n);
    double *glon = e->g_conc, *glat = e->g_hbar; /* scratch until the first output */
    for (int j = 0; j < e->grid.nlat; j++)
        for (int i = 0; i < e->grid.nlon; i++) {
            size_t k = (size_t)j * e->grid.nlon + i;
            glon[k] = e->grid.lon0 + i * e->grid.dlon;
            glat[k] = e->grid.lat0 + j * e->grid.dlat;
            e->g_land[k] = e->lm && landmask_is_land(e->lm, glon[k], glat[k]) == 1;
        }
    sph_error local;
    sph_error_clear(&local);
    if (geo_forward(e->proj, n, glon, glat, e->gx, e->gy, &local) != SPH_OK) {
        /* points that do not project are far from every particle */
        for (size_t k = 0; k < n; k++)
            if (!isfinite(e->gx[k]) || !isfinite(e->gy[k]))
                e->gx[k] = e->gy[k] = 1e30;
    }
    return SPH_OK;
}

static int open_products(engine *e, prod_station *stations, sph_error *err)
{
    const struct sph_config *cfg = e->cfg;
    prod_options o;
    products_options_default(&o);
    o.edge_threshold = cfg->output.edge_threshold;
    if (cfg->output.edge_reference.name && cfg->output.edge_reference.name[0]) {
        o.has_reference = 1;
        o.ref_lon = cfg->output.edge_reference.lon;
        o.ref_lat = cfg->output.edge_reference.lat;
        o.ref_name = cfg->output.edge_reference.name;
    }
    int ns = 0;
    if (cfg->output.products.stations)
        for (size_t s = 0; s < cfg->nstations; s++) {
            snprintf(stations[ns].name, sizeof stations[ns].name, "%s", cfg->stations[s].name);
            stations[ns].lon = cfg->stations[s].lon;
            stations[ns].lat = cfg->stations[s].lat;
            ns++;
        }
    o.stations = ns ? stations : NULL;
    o.nstations = ns;
    o.write_particles = cfg->output.products.particles;
    if (cfg->output.products.maps) {
        /* maps every k output times: k from the smallest gap of map_times */
        double gap = 24.0;
        for (size_t k = 1; k < cfg->output.map_times.n; k++) {
            double d = cfg->output.map_times.v[k] - cfg->output.map_times.v[k - 1];
            if (d > 0 && d < gap)
                gap = d;
        }
        int every = (int)lround(gap / cfg->output.interval_hours);
        o.quicklook_every = every > 0 ? every : 1;
    }
    prod_meta meta;
    memset(&meta, 0, sizeof meta);
    char title[160];
    snprintf(title, sizeof title, "sphice sea-ice forecast, %s", cfg->domain.name ? cfg->domain.name : "domain");
    meta.title = title;
    meta.summary = "SPH sea-ice model forecast: concentration, thickness, drift, pressure, deformation";
    meta.institution = "sphice";
    meta.region = cfg->domain.name;
    meta.model_version = SPHICE_VERSION;
    meta.git_revision = SPHICE_GIT;
    meta.config_sha256 = cfg->sha256;
    meta.forcing_sha256 = e->req->forcing_sha256;
    meta.cycle_time = e->t0;
    meta.stale_forcing = e->req->stale;
    meta.start_mode = e->start_mode;
    int rc = products_open(&e->pw, &o, &e->grid, &meta, e->req->stage_dir, err);
    if (rc)
        e->pw = NULL;
    return rc;
}

/* Observed concentration regridded to the output grid (bilinear; NaN
 * outside the observation's cell centres). */
static int set_observation(engine *e, sph_error *err)
{
    const struct sph_config *cfg = e->cfg;
    ice_raster *obs = NULL;
    ice_raster_options o;
    ice_raster_options_default(&o);
    o.valid_time = e->t_end;
    if (cfg->observations.format != CFG_INIT_ESRI)
        o.conc_variable = cfg->observations.conc_var;
    sph_error local;
    sph_error_clear(&local);
    int rc = ice_raster_read(e->req->observation, &o, &obs, &local);
    if (rc == SPH_ERR_MISSING_VAR && o.conc_variable && !strcmp(o.conc_variable, "sea_ice_concentration")) {
        o.conc_variable = NULL;
        sph_error_clear(&local);
        rc = ice_raster_read(e->req->observation, &o, &obs, &local);
    }
    if (rc)
        return sph_err_set(err, rc, "observation: %s", local.msg);
    double *c = malloc(e->npts * sizeof *c);
    if (!c) {
        ice_raster_free(obs);
        return sph_err_set(err, SPH_ERR_NOMEM, "observation: out of memory");
    }
    for (int j = 0; j < e->grid.nlat; j++)
        for (int i = 0; i < e->grid.nlon; i++) {
            size_t k = (size_t)j * e->grid.nlon + i;
            double th;
            if (!ice_raster_sample(obs, e->grid.lon0 + i * e->grid.dlon, e->grid.lat0 + j * e->grid.dlat,
                                   &c[k], &th))
                c[k] = NAN;
        }
    /* valid at the observation's own time when it has one, else at the end */
    double t_obs = isfinite(obs->valid_time) ? obs->valid_time : e->t_end;
    rc = products_set_observation(e->pw, t_obs, c, err);
    free(c);
    ice_raster_free(obs);
    return rc;
}

/* One output time: particles -> grid through the SPH interpolation. */
static int write_output(engine *e, double t, sph_error *err)
{
    sph_particles *P = sph_model_particles(e->m);
    size_t n = P->n;
    const double rho_i = e->cfg->model.rho_i;
    sph_error local;
    sph_error_clear(&local);
    if (n > 0 && geo_inverse(e->proj, n, P->x, P->y, e->lon, e->lat, &local) != SPH_OK)
        return sph_err_set(err, SPH_ERR_NUMERICS, "output: %s", local.msg);
    for (size_t k = 0; k < n; k++) {
        double a = geo_grid_angle(e->proj, e->lon[k], e->lat[k]);
        if (!isfinite(a))
            a = 0.0;
        double c = cos(a), s = sin(a);
        /* plane x/y -> east/north: the inverse of the rotation in fill_forcing */
        e->pue[k] = P->u[k] * c - P->v[k] * s;
        e->pvn[k] = P->u[k] * s + P->v[k] * c;
        e->div[k] = P->e11[k] + P->e22[k];
        double d = P->e11[k] - P->e22[k];
        e->shear[k] = sqrt(d * d + 4.0 * P->e12[k] * P->e12[k]);
    }
    if (n > 0) {
        const double *fields[6] = {P->thick, e->pue, e->pvn, P->pres, e->div, e->shear};
        double *out[6] = {e->g_thick, e->g_u, e->g_v, e->g_pres, e->g_div, e->g_shear};
        if (sph_model_interpolate(e->m, e->npts, e->gx, e->gy, 6, fields, out, e->g_dens) != SPH_STEP_OK)
            return sph_err_set(err, SPH_ERR_NUMERICS,
                               "output: SPH interpolation: too many particles near one grid point");
    } else {
        for (size_t k = 0; k < e->npts; k++) {
            e->g_thick[k] = e->g_u[k] = e->g_v[k] = e->g_pres[k] = e->g_div[k] = e->g_shear[k] = NAN;
            e->g_dens[k] = 0.0;
        }
    }
    for (size_t k = 0; k < e->npts; k++) {
        /* the raw mass density conserves volume; the normalised h_i gives A */
        double hbar = e->g_dens[k] / rho_i;
        e->g_hbar[k] = hbar;
        double hi = e->g_thick[k];
        e->g_conc[k] = hbar > 0 && hi > 0 ? fmin(1.0, hbar / hi) : 0.0;
    }
    prod_fields f;
    memset(&f, 0, sizeof f);
    f.conc = e->g_conc;
    f.hbar = e->g_hbar;
    f.thick = e->g_thick;
    f.u_east = e->g_u;
    f.v_north = e->g_v;
    f.pressure = e->g_pres;
    f.divergence = e->g_div;
    f.shear = e->g_shear;
    f.land = e->lm ? e->g_land : NULL;
    prod_particles_view pv;
    pv.n = n;
    pv.lon = e->lon;
    pv.lat = e->lat;
    pv.u_east = e->pue;
    pv.v_north = e->pvn;
    pv.mass = P->mass;
    pv.thick = P->thick;
    pv.conc = P->conc;
    pv.id = P->id;
    return products_add_time(e->pw, t, &f, e->cfg->output.products.particles ? &pv : NULL, err);
}

static int write_restart(engine *e, double t, sph_error *err)
{
    restart_header h;
    memset(&h, 0, sizeof h);
    h.time = t;
    h.cycle_time = e->t0;
    snprintf(h.projection, sizeof h.projection, "%s", geo_proj_definition(e->proj));
    sph_model_get_clock(e->m, &h.clock);
    int rc = restart_write(e->restart_path, sph_model_particles(e->m), &h, err);
    if (rc == SPH_OK)
        e->restart_written = 1;
    return rc;
}

/* ------------------------------------------------------------------- run */

static int step_error(engine *e, const sph_status *st, long step, double t, sph_error *err)
{
    char when[32], where[128], what[256];
    iso(t, when, sizeof when);
    particle_where(e, st->particle, where, sizeof where);
    fmt_status(st, what, sizeof what);
    return sph_err_set(err, SPH_ERR_NUMERICS, "model step %ld (%s): %s: %s; nothing written", step, when,
                       where, what);
}

int forecast_run(const struct sph_config *cfg, const forecast_request *req, forecast_progress *prog,
                 const volatile sig_atomic_t *cancel, forecast_result *res, sph_error *err)
{
    double wall0 = time_monotonic();
    forecast_progress local_prog;
    if (!prog)
        prog = &local_prog;
    forecast_result local_res;
    if (!res)
        res = &local_res;
    memset(res, 0, sizeof *res);
    res->edge_distance_nm = NAN;
    engine eng;
    memset(&eng, 0, sizeof eng);
    engine *e = &eng;
    e->cfg = cfg;
    e->req = req;
    e->t0 = req->cycle_time;
    double hours = req->hours > 0 ? req->hours : cfg->schedule.forecast_hours;
    e->t_end = e->t0 + hours * 3600.0;
    cycle_name(e->t0, e->cname, sizeof e->cname);
    e->thermo_on = cfg->model.thermo_dt > 0 && cfg->model.thermo.model != SPH_THERMO_OFF;
    prog->phase = FC_PHASE_INITIALISING;
    prog->model_time = e->t0;
    prog->percent = 0;
    int rc;
    prod_station *stations = NULL;
    sph_error e_local;
    sph_error_clear(&e_local);
    sph_error *er = &e_local;

    if (!req->stage_dir || !req->stage_dir[0]) {
        rc = sph_err_set(er, SPH_ERR_PARAM, "forecast: no stage directory");
        goto fail;
    }
    /* the model's parameters; model.dt = 0 is resolved once the particles
     * are placed (resolve_dt), checked meanwhile with a valid stand-in */
    e->prm = cfg->model;
    e->dt_auto = cfg->model.dt == 0.0; /* negative: refused by check_params */
    e->dt_base = auto_dt_base(e, schedule_next(cfg, e->t0));
    if (e->dt_auto)
        e->prm.dt = e->dt_base > 0.0 ? e->dt_base : 60.0;
    if ((rc = check_params(cfg, &e->prm, er)))
        goto fail;
    if (!(cfg->domain.lon_max > cfg->domain.lon_min) || !(cfg->domain.lat_max > cfg->domain.lat_min)) {
        rc = sph_err_set(er, SPH_ERR_CONFIG, "config: domain: lon_max/lat_max must exceed lon_min/lat_min");
        goto fail;
    }

    /* 1. projection and plane box */
    double lonc = 0.5 * (cfg->domain.lon_min + cfg->domain.lon_max);
    double latc = 0.5 * (cfg->domain.lat_min + cfg->domain.lat_max);
    e->proj = geo_proj_create(cfg->domain.projection, lonc, latc, er);
    if (!e->proj) {
        rc = er->code ? er->code : SPH_ERR_CONFIG;
        goto fail;
    }
    double xmin, xmax, ymin, ymax;
    if ((rc = plane_box(e, &xmin, &xmax, &ymin, &ymax, er)))
        goto fail;

    /* 3. forcing (before anything heavier: a missing file fails fast) */
    if ((rc = open_forcing(e, er)))
        goto fail;

    /* the raster is read first on a cold start: the mask cell size may depend on it */
    if (!req->warm_start && cfg->initial.spacing_deg <= 0 && cfg->initial.path && cfg->initial.path[0] &&
        (rc = read_raster(e, cfg->initial.path, cfg->initial.format, cfg->initial.conc_var, e->t0, &e->raster,
                          e->raster_path, sizeof e->raster_path, "initial field", er)))
        goto fail;

    /* 2. land mask, cell = half the initial spacing */
    if ((rc = build_landmask(e, xmin, xmax, ymin, ymax, 0.5 * spacing_m(e), er)))
        goto fail;

    /* 4-5. particles and model */
    rc = req->warm_start ? warm_start(e, er) : cold_start(e, er);
    if (rc)
        goto fail;
    sph_particles *P = sph_model_particles(e->m);
    res->particles_start = (long)P->n;
    prog->particles = (long)P->n;

    /* products */
    if ((rc = setup_grid(e, er)))
        goto fail;
    stations = calloc(cfg->nstations ? cfg->nstations : 1, sizeof *stations);
    if (!stations) {
        rc = sph_err_set(er, SPH_ERR_NOMEM, "forecast: out of memory");
        goto fail;
    }
    if ((rc = open_products(e, stations, er)))
        goto fail;
    if (req->observation && cfg->output.products.verification && (rc = set_observation(e, er)))
        goto fail;

    /* restart file for the next cycle */
    double t_next = schedule_next(cfg, e->t0);
    char rname[64];
    cycle_restart_name(t_next, rname, sizeof rname);
    snprintf(e->restart_path, sizeof e->restart_path, "%s/%s", req->stage_dir, rname);

    /* 6. time loop */
    const double dt = e->prm.dt;
    prog->dt = dt;
    prog->dt_auto = e->dt_auto;
    const long nsteps = (long)ceil(hours * 3600.0 / dt - 1e-9);
    const double out_dt = cfg->output.interval_hours * 3600.0;
    long restart_step = (long)ceil((t_next - e->t0) / dt - 1e-9);
    if (restart_step > nsteps || restart_step < 1)
        restart_step = nsteps;
    if (fabs(restart_step * dt - (t_next - e->t0)) > 1e-6 * dt && restart_step != nsteps)
        log_warn("forecast %s: the next cycle is not a whole number of steps away: restart written at +%g s",
                 e->cname, restart_step * dt);
    int nout = 0;
    double next_out = e->t0;
    double sum_fd = 0, sum_rh = 0, sum_zl = 0, sum_ml = 0, sum_it = 0, sum_stall = 0;
    long nstat = 0;
    prog->phase = FC_PHASE_RUNNING;
    if ((rc = write_output(e, e->t0, er)))
        goto fail;
    nout++;
    next_out = e->t0 + out_dt;
    for (long s = 0; s < nsteps; s++) {
        if (cancel && *cancel) {
            char when[32];
            iso(e->t0 + s * dt, when, sizeof when);
            rc = sph_err_set(er, SPH_ERR_CANCELLED, "forecast %s: cancelled at model time %s", e->cname, when);
            goto fail;
        }
        double t = e->t0 + s * dt;
        if (s > 0 && (rc = fill_forcing(e, t, er)))
            goto fail;
        sph_status st;
        if (sph_model_step(e->m, &st) != SPH_STEP_OK) {
            rc = step_error(e, &st, s + 1, t, er);
            goto fail;
        }
        double t1 = e->t0 + (s + 1) * dt;
        const sph_step_stats *ss = sph_model_stats(e->m);
        sum_fd += ss->frac_free_drift;
        sum_rh += ss->frac_rheology;
        sum_zl += ss->frac_zero_layer;
        sum_ml += ss->frac_multi_layer;
        sum_it += ss->iterations;
        sum_stall += ss->stalled;
        nstat++;
        prog->model_time = t1;
        prog->percent = 100.0 * (double)(s + 1) / (double)nsteps;
        prog->particles = (long)P->n;
        prog->frac_free_drift = ss->frac_free_drift;
        prog->frac_rheology = ss->frac_rheology;
        prog->frac_zero_layer = ss->frac_zero_layer;
        prog->frac_multi_layer = ss->frac_multi_layer;
        if (s + 1 == restart_step && (rc = write_restart(e, t1, er)))
            goto fail;
        int last = s + 1 == nsteps;
        if (t1 >= next_out - 1e-6 * dt || last) {
            if ((rc = write_output(e, t1, er)))
                goto fail;
            nout++;
            while (next_out <= t1 + 1e-6 * dt)
                next_out += out_dt;
        }
    }
    if (nsteps == 0 && (rc = write_restart(e, e->t0, er)))
        goto fail;

    /* 7. close the products */
    prog->phase = FC_PHASE_WRITING;
    const sph_budget *b = sph_model_budget(e->m);
    double expect = b->mass_initial + b->growth + b->new_ice - b->melt_top - b->melt_bottom - b->lateral_melt -
                    b->outflow;
    double resid = b->mass_initial > 0 ? fabs(expect - b->mass) / b->mass_initial : 0.0;
    prod_run_info info;
    memset(&info, 0, sizeof info);
    if (nstat > 0) {
        info.frac_free_drift = sum_fd / nstat;
        info.frac_rheology = sum_rh / nstat;
        info.frac_zero_layer = sum_zl / nstat;
        info.frac_multi_layer = sum_ml / nstat;
        info.solver_iterations = sum_it / nstat;
        info.solver_stalled = sum_stall / nstat;
    }
    info.particles_start = res->particles_start;
    info.particles_end = (long)P->n;
    info.budget_residual = resid;
    info.dt = dt;
    info.dt_auto = e->dt_auto;
    products_set_run_info(e->pw, &info);
    prod_summary sum;
    rc = products_close(e->pw, &sum, er);
    e->pw = NULL;
    if (rc)
        goto fail;

    res->particles_end = (long)P->n;
    res->ice_area_km2 = sum.ice_area_km2;
    res->ice_volume_km3 = sum.ice_volume_km3;
    res->ice_mass_kg = b->mass;
    res->edge_distance_nm = sum.edge_distance_nm;
    res->has_scores = sum.has_scores;
    if (sum.has_scores) {
        res->iiee_km2 = sum.scores.iiee_km2;
        res->aee_km2 = sum.scores.aee_km2;
        res->me_km2 = sum.scores.me_km2;
        res->edge_displacement_km = sum.scores.displacement_km;
        res->conc_bias = sum.scores.conc_bias;
        res->conc_rmse = sum.scores.conc_rmse;
        res->skill_persistence = sum.scores.skill_persistence;
    }
    res->frac_free_drift = info.frac_free_drift;
    res->frac_rheology = info.frac_rheology;
    res->frac_zero_layer = info.frac_zero_layer;
    res->frac_multi_layer = info.frac_multi_layer;
    res->solver_iterations = info.solver_iterations;
    res->solver_stalled = info.solver_stalled;
    res->dt = dt;
    res->dt_auto = e->dt_auto;
    res->budget_residual = resid;
    snprintf(res->start_mode, sizeof res->start_mode, "%.15s", e->start_mode);
    int np = 0;
    for (int k = 0; k < sum.nproducts && np < FC_MAX_PRODUCTS - 1; k++)
        snprintf(res->products[np++], sizeof res->products[0], "%s", sum.products[k]);
    snprintf(res->products[np++], sizeof res->products[0], "%s", rname);
    res->nproducts = np;
    res->wall_seconds = time_monotonic() - wall0;
    log_info("forecast %s: %ld steps, %d output times, %ld -> %ld particles, budget residual %.3g, %.1f s",
             e->cname, nsteps, nout, res->particles_start, res->particles_end, resid, res->wall_seconds);
    e->restart_written = 0; /* keep it */
    engine_free(e);
    free(stations);
    prog->phase = FC_PHASE_DONE;
    prog->percent = 100;
    return SPH_OK;

fail:
    engine_free(e);
    free(stations);
    prog->phase = FC_PHASE_FAILED;
    res->wall_seconds = time_monotonic() - wall0;
    return sph_err_set(err, rc ? rc : SPH_ERR_INTERNAL, "%s", er->msg[0] ? er->msg : "forecast: failed");
}
