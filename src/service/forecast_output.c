/* The forecast's output (forecast_impl.h): the output grid, the product
 * writer with its metadata, the observation to score against, each output
 * time (particles -> grid through the SPH interpolation) and the restart
 * file of the next cycle. */
#include "forecast_impl.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/ocean.h"
#include "io/ocean_grid.h"
#include "io/restart.h"
#include "util/log.h"
#include "util/version.h"

int fc_setup_grid(engine *e, sph_error *err)
{
    if (e->dd == 2 && e->dd_rank > 0) /* parallel.decomposition "domain": rank 0 writes */
        return SPH_OK;
    const struct sph_config *cfg = e->cfg;
    if (cfg->output.grid.mode == CFG_GRID_RASTER) {
        int rc;
        if (!e->raster &&
            (rc = fc_read_raster(e, cfg->initial.path, cfg->initial.format, cfg->initial.conc_var, e->t0,
                              &e->raster, e->raster_path, sizeof e->raster_path, "initial field", err)))
            return rc;
        if (e->raster->kind != ICE_RASTER_LONLAT)
            return sph_err_set(err, SPH_ERR_CONFIG,
                               "output.grid.mode: \"raster\" needs a regular lon/lat initial raster; "
                               "%s is %s: set output.grid.mode to \"regular\" with its lon/lat keys",
                               e->raster->path, e->raster->grid);
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
                         &e->g_pres, &e->g_div, &e->g_shear, &e->g_dens, &e->g_snow};
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

int fc_open_products(engine *e, prod_station *stations, sph_error *err)
{
    if (e->dd == 2 && e->dd_rank > 0) /* parallel.decomposition "domain": rank 0 writes */
        return SPH_OK;
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
    /* the ice-load product's structures (products_loads.c; copied by products_open) */
    prod_structure *structures = calloc(cfg->nstations ? cfg->nstations : 1, sizeof *structures);
    if (!structures)
        return sph_err_set(err, SPH_ERR_NOMEM, "products: out of memory");
    if (cfg->output.products.stations)
        for (size_t s = 0; s < cfg->nstations; s++) {
            snprintf(stations[ns].name, sizeof stations[ns].name, "%s", cfg->stations[s].name);
            stations[ns].lon = cfg->stations[s].lon;
            stations[ns].lat = cfg->stations[s].lat;
            if (cfg->stations[s].structure_kind) {
                structures[ns].w = cfg->stations[s].structure_diameter;
                structures[ns].c_r = cfg->stations[s].structure_c_r * 1e6;
                structures[ns].mass = cfg->stations[s].structure_mass * 1e3;
                structures[ns].stiffness = cfg->stations[s].structure_stiffness * 1e3;
                structures[ns].damping = cfg->stations[s].structure_damping;
                if (cfg->stations[s].structure_kind == 2) { /* cone */
                    structures[ns].w = cfg->stations[s].structure_waterline_diameter;
                    structures[ns].cone_angle = cfg->stations[s].structure_cone_angle;
                    structures[ns].neck = cfg->stations[s].structure_neck_diameter;
                    structures[ns].sigma_f = cfg->stations[s].structure_flexural_strength * 1e6;
                    structures[ns].mu = cfg->stations[s].structure_friction;
                }
            }
            ns++;
        }
    o.stations = ns ? stations : NULL;
    o.nstations = ns;
    o.structures = ns ? structures : NULL;
    /* the load model's keys (loads.*) */
    o.loads.model = cfg->loads.model;
    o.loads.min_speed = cfg->loads.dem_min_speed;
    o.loads.min_thickness = cfg->loads.dem_min_thickness;
    o.loads.duration = cfg->loads.dem_duration;
    o.loads.particle_diameter = cfg->loads.dem_particle_diameter;
    o.loads.sheet_length = cfg->loads.dem_sheet_length;
    o.loads.sheet_width = cfg->loads.dem_sheet_width;
    o.loads.dt = cfg->loads.dem_dt;
    o.loads.max_particles = cfg->loads.dem_max_particles;
    o.loads.cache_thickness = cfg->loads.dem_cache_thickness;
    o.loads.cache_speed = cfg->loads.dem_cache_speed;
    o.loads.map_threshold = cfg->loads.map_threshold_kn * 1e3;
    o.loads.elastic_modulus = cfg->loads.dem_elastic_modulus * 1e9;
    o.loads.bond_tensile = cfg->loads.dem_bond_tensile * 1e6;
    o.loads.bond_shear = cfg->loads.dem_bond_shear * 1e6;
    o.loads.cancel = e->cancel;
    o.write_particles = cfg->output.products.particles;
    o.deflate_level = cfg->output.deflate_level;
    o.write_geojson = cfg->output.products.geojson;
    o.write_snow = fc_snow_possible(cfg);
    if (cfg->output.products.maps) {
        /* maps every k output times: k from the smallest gap of map_times (daily with fewer than two;
         * a gap longer than a day only from two or more times, as the 30-day season scene has) */
        double gap = cfg->output.map_times.n >= 2 ? HUGE_VAL : 24.0;
        for (size_t k = 1; k < cfg->output.map_times.n; k++) {
            double d = cfg->output.map_times.v[k] - cfg->output.map_times.v[k - 1];
            if (d > 0 && d < gap)
                gap = d;
        }
        if (!isfinite(gap))
            gap = 24.0;
        int every = (int)lround(gap / cfg->output.interval_hours);
        o.quicklook_every = every > 0 ? every : 1;
        o.quicklook_drift = cfg->output.map_drift;
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
    free(structures);
    if (rc)
        e->pw = NULL;
    return rc;
}

/* Observed concentration regridded to the output grid (bilinear; NaN
 * outside the observation's cell centres). */
int fc_read_observation(const struct sph_config *cfg, const char *path, const prod_grid *g, double t_valid,
                        double **out, double *t_obs, sph_error *err)
{
    *out = NULL;
    ice_raster *obs = NULL;
    ice_raster_options o;
    ice_raster_options_default(&o);
    o.valid_time = t_valid;
    o.thickness_kind = ICE_THICK_ICE; /* unused: verification compares concentration only */
    if (cfg->observations.format != CFG_INIT_ESRI)
        o.conc_variable = cfg->observations.conc_var;
    sph_error local;
    sph_error_clear(&local);
    int rc = ice_raster_read(path, &o, &obs, &local);
    if (rc == SPH_ERR_MISSING_VAR && o.conc_variable && !strcmp(o.conc_variable, "sea_ice_concentration")) {
        o.conc_variable = NULL;
        sph_error_clear(&local);
        rc = ice_raster_read(path, &o, &obs, &local);
    }
    if (rc)
        return sph_err_set(err, rc, "observation: %s", local.msg);
    if (!ice_raster_can_sample(obs)) {
        rc = sph_err_set(err, SPH_ERR_CONFIG, "observation %s: cannot be regridded for "
                         "verification: its grid (%s) cannot be sampled", obs->path, obs->grid);
        ice_raster_free(obs);
        return rc;
    }
    size_t npts = (size_t)g->nlon * g->nlat;
    double *c = malloc((npts ? npts : 1) * sizeof *c);
    if (!c) {
        ice_raster_free(obs);
        return sph_err_set(err, SPH_ERR_NOMEM, "observation: out of memory");
    }
    for (int j = 0; j < g->nlat; j++)
        for (int i = 0; i < g->nlon; i++) {
            size_t k = (size_t)j * g->nlon + i;
            double th;
            if (!ice_raster_sample(obs, g->lon0 + i * g->dlon, g->lat0 + j * g->dlat, &c[k], &th))
                c[k] = NAN;
        }
    /* valid at the observation's own time when it has one, else at t_valid */
    *t_obs = isfinite(obs->valid_time) ? obs->valid_time : t_valid;
    ice_raster_free(obs);
    *out = c;
    return SPH_OK;
}

int fc_set_observation(engine *e, sph_error *err)
{
    if (e->dd == 2 && e->dd_rank > 0) /* parallel.decomposition "domain": rank 0 writes */
        return SPH_OK;
    double *c, t_obs;
    int rc = fc_read_observation(e->cfg, e->req->observation, &e->grid, e->t_end, &c, &t_obs, err);
    if (rc)
        return rc;
    rc = products_set_observation(e->pw, t_obs, c, err);
    free(c);
    return rc;
}

/* 1 when snow can appear: a forcing source lists snowfall or
 * precipitation, or lists no quantities (then it reads whatever its kind
 * provides, snowfall included). Products then carry sisnthick. */
int fc_snow_possible(const struct sph_config *cfg)
{
    unsigned want = FQ_SNOWFALL | FQ_PRECIP;
    for (size_t s = 0; s < cfg->nforcing; s++) {
        const cfg_forcing_source *src = &cfg->forcing[s];
        if (src->kind != FORCING_ATMOSPHERE)
            continue;
        if (src->required.n == 0 && src->optional_q.n == 0)
            return 1;
        const cfg_strlist *lists[2] = {&src->required, &src->optional_q};
        for (int l = 0; l < 2; l++)
            for (size_t j = 0; j < lists[l]->n; j++) {
                int f = config_quantity_flag(lists[l]->v[j]);
                if (f > 0 && ((unsigned)f & want))
                    return 1;
            }
    }
    return 0;
}
static int ofx_record(engine *e, double t, sph_error *err);

static int write_output(engine *e, double t, sph_error *err);

/* output.writer_thread auto with a writer thread: a memory-bound run
 * (core/params.h SPH_MEMORY_BOUND_PARTICLES) writes its products here,
 * in the step loop, as a one-thread run does: the thread's job would hold
 * the output arrays and copies of the particles' fields (64 B per
 * particle) while the next steps make their peak (docs/bench.md, Session
 * 11: memory at 1e6). The same files either way. */
static int bgw_inline(const engine *e, size_t n)
{
    return e->bgw && e->cfg->output.writer_thread == CFG_WRITER_AUTO && n >= SPH_MEMORY_BOUND_PARTICLES;
}

/* One output time: particles -> grid through the SPH interpolation. Without
 * the writer thread (or with it, written here: bgw_inline) the
 * per-particle positions and east/north velocities (olon olat pue pvn,
 * read by nothing after this call) live in the model's idle pair
 * gradients when they are large enough (sph_model_idle_scratch: memory
 * the last step made resident), and the engine's own arrays stay
 * untouched; with the thread's job they are read while the next steps
 * run. */
int fc_write_output(engine *e, double t, sph_error *err)
{
    double *own[4] = {e->olon, e->olat, e->pue, e->pvn};
    size_t len = 0, n = sph_model_particles(e->m)->n;
    double *idle = e->bgw && !bgw_inline(e, n) ? NULL : sph_model_idle_scratch(e->m, &len);
    if (idle && n > 0 && len / 4 >= n) {
        e->olon = idle;
        e->olat = idle + n;
        e->pue = idle + 2 * n;
        e->pvn = idle + 3 * n;
    }
    int rc = write_output(e, t, err);
    e->olon = own[0];
    e->olat = own[1];
    e->pue = own[2];
    e->pvn = own[3];
    return rc;
}

static int write_output(engine *e, double t, sph_error *err)
{
    if (e->dd == 2 && e->dd_rank > 0) { /* parallel.decomposition "domain": rank 0 writes */
        /* rank 0 records the ocean fluxes of the particles just gathered
         * (fc_dd_sync) over the interval ending at t: each rank's own
         * accumulators restart from zero, as the serial run's do */
        if (e->cfg->output.ocean_fluxes && t > e->ofx_t0) {
            fc_ofx_zero(sph_model_particles(e->dd_m));
            sph_ocean_clear_fluxes(sph_model_ocean(e->dd_m)); /* the mixed layer's cells too */
            e->ofx_t0 = t;
        }
        return SPH_OK;
    }
    /* the previous output time's job reads the arrays written below */
    int wrc = fc_bgw_wait(e, err);
    if (wrc)
        return wrc;
    sph_particles *P = sph_model_particles(e->m);
    size_t n = P->n;
    const double rho_i = e->cfg->model.rho_i;
    sph_error local;
    sph_error_clear(&local);
    int grc = e->cpl.plane ? geo_plane_lookup(e->cpl.plane, n, P->x, P->y, e->olon, e->olat, e->cpl.cs,
                                              e->cpl.sn, &local)
                           : geo_inverse(e->proj, n, P->x, P->y, e->olon, e->olat, &local);
    if (n > 0 && grc != SPH_OK)
        return sph_err_set(err, SPH_ERR_NUMERICS, "output: %s", local.msg);
    for (size_t k = 0; k < n; k++) {
        double c, s;
        if (e->cpl.plane) { /* domain.plane_tables */
            c = e->cpl.cs[k];
            s = e->cpl.sn[k];
        } else {
            double a = geo_grid_angle(e->proj, e->olon[k], e->olat[k]);
            if (!isfinite(a))
                a = 0.0;
            c = cos(a);
            s = sin(a);
        }
        /* plane x/y -> east/north: the inverse of the rotation in coupling_fill */
        e->pue[k] = P->u[k] * c - P->v[k] * s;
        e->pvn[k] = P->u[k] * s + P->v[k] * c;
        e->div[k] = P->e11[k] + P->e22[k];
        double d = P->e11[k] - P->e22[k];
        e->shear[k] = sqrt(d * d + 4.0 * P->e12[k] * P->e12[k]);
    }
    const int snow = fc_snow_possible(e->cfg);
    if (n > 0) {
        const double *fields[7] = {P->thick, e->pue, e->pvn, P->pres, e->div, e->shear, P->snow};
        double *out[7] = {e->g_thick, e->g_u, e->g_v, e->g_pres, e->g_div, e->g_shear, e->g_snow};
        if (sph_model_interpolate(e->m, e->npts, e->gx, e->gy, snow ? 7 : 6, fields, out, e->g_dens) != SPH_STEP_OK)
            return sph_err_set(err, SPH_ERR_NUMERICS,
                               "output: SPH interpolation: too many particles near one grid point");
    } else {
        for (size_t k = 0; k < e->npts; k++) {
            e->g_thick[k] = e->g_u[k] = e->g_v[k] = e->g_pres[k] = e->g_div[k] = e->g_shear[k] = NAN;
            e->g_snow[k] = NAN;
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
    prod_fields f = {.conc = e->g_conc, .hbar = e->g_hbar, .thick = e->g_thick, .u_east = e->g_u,
                     .v_north = e->g_v, .pressure = e->g_pres, .divergence = e->g_div,
                     .shear = e->g_shear, .snow = snow ? e->g_snow : NULL,
                     .land = e->lm ? e->g_land : NULL};
    /* snow only where the products write it (opts.write_snow is the same
     * fc_snow_possible): the writer thread copies what the view carries */
    prod_particles_view pv = {.n = n, .lon = e->olon, .lat = e->olat, .u_east = e->pue, .v_north = e->pvn,
                              .mass = P->mass, .thick = P->thick, .conc = P->conc,
                              .snow = snow ? P->snow : NULL, .id = P->id};
    const prod_particles_view *pvp = e->cfg->output.products.particles ? &pv : NULL;
    if (e->bgw && !bgw_inline(e, n)) /* output.writer_thread: written while the next steps run (forecast_writer.c) */
        return fc_bgw_submit(e, t, &f, pvp, err);
    if (e->bgw && !e->inline_logged) {
        e->inline_logged = 1;
        log_info("forecast %s: %zu particles: products written in the step loop (output.writer_thread auto, "
                 "from %d particles: the thread's copies would add to the steps' memory)",
                 e->cname, n, SPH_MEMORY_BOUND_PARTICLES);
    }
    int rc = products_add_time(e->pw, t, &f, pvp, err);
    if (rc == SPH_OK && e->ofx && t > e->ofx_t0)
        rc = ofx_record(e, t, err);
    return rc;
}

int fc_write_restart(engine *e, double t, sph_error *err)
{
    if (e->dd == 2 && e->dd_rank > 0) /* parallel.decomposition "domain": rank 0 writes */
        return SPH_OK;
    restart_header h;
    memset(&h, 0, sizeof h);
    h.time = t;
    h.cycle_time = e->t0;
    snprintf(h.projection, sizeof h.projection, "%s", geo_proj_definition(e->proj));
    sph_model_get_clock(e->dd_m ? e->dd_m : e->m, &h.clock);
    if (e->dd) /* the exact budget of the particles in id order: the same on any number of ranks */
        fc_dd_budget(e, &h.clock.budget);
    sph_ocean *o = e->prm.ocean.mixed_layer ? sph_model_ocean(e->m) : NULL; /* the mixed layer too */
    int rc = restart_write_ocean(e->restart_path, sph_model_particles(e->m), &h, o, err);
    if (rc == SPH_OK)
        e->restart_written = 1;
    return rc;
}

/* ------------------------------------------------------------ ocean fluxes */

#define OFX_FILE "sphice_ocean_fluxes.nc"

void fc_free_ocean_fluxes(engine *e)
{
    ofx_abort(e->ofx);
    e->ofx = NULL;
    free(e->ofx_buf);
    free(e->ofx_area);
    free(e->ofx_lon);
    free(e->ofx_lat);
    free(e->ofx_land);
    free(e->ofx_to);
    free(e->ofx_rot);
    free(e->ofx_bxy);
    free(e->ofx_east);
    ocean_grid_free(e->ofx_curv);
    e->ofx_curv = NULL;
    e->ofx_bxy = e->ofx_east = NULL;
    e->ofx_to = NULL;
    e->ofx_rot = NULL;
    e->ofx_buf = e->ofx_area = e->ofx_lon = e->ofx_lat = NULL;
    e->ofx_land = NULL;
}

/* The particles' accumulators restart from zero at the cycle time: each
 * cycle's file starts its first interval there (a warm start's restart
 * file carries the previous cycle's last interval, already published). */
void fc_ofx_zero(sph_particles *P)
{
    size_t b = P->n * sizeof(double);
    memset(P->ofx_heat_ice, 0, b);
    memset(P->ofx_heat_lead, 0, b);
    memset(P->ofx_water, 0, b);
    memset(P->ofx_salt, 0, b);
    memset(P->ofx_taux, 0, b);
    memset(P->ofx_tauy, 0, b);
    memset(P->ofx_swbase, 0, b);
}

/* The first file of the first ocean source with files, or NULL. */
static const char *ofx_ocean_file(const engine *e)
{
    for (size_t s = 0; s < e->cfg->nforcing && s < SPHICE_MAX_SOURCES; s++)
        if (e->cfg->forcing[s].kind == FORCING_OCEAN && e->req->forcing_files[s] && e->req->forcing_files[s][0])
            return e->req->forcing_files[s][0];
    return NULL;
}

/* The longitude of a cell centre moved by whole turns next to lonc. */
static double ofx_near(double lon, double lonc)
{
    while (lon - lonc > 180.0)
        lon -= 360.0;
    while (lon - lonc < -180.0)
        lon += 360.0;
    return lon;
}

/* A curvilinear ocean grid (io/ocean_grid.h) over the domain: its
 * cells, corners and areas; centres and corners on the plane, the plane's
 * angle from east at each centre (e->ofx_curv, e->ofx_area with cx/cy in
 * its tail, e->ofx_bxy, e->ofx_east). */
static int ofx_ocean_curv(engine *e, const char *path, int *nx, int *ny, double **cx, double **cy,
                          unsigned char **land, sph_error *err)
{
    const struct sph_config *cfg = e->cfg;
    double box[4] = {cfg->domain.lon_min, cfg->domain.lon_max, cfg->domain.lat_min, cfg->domain.lat_max};
    int rc = ocean_grid_read(path, box, "output.ocean_fluxes_grid", &e->ofx_curv, err);
    if (rc)
        return rc;
    const ocean_grid *g = e->ofx_curv;
    size_t n = (size_t)g->nx * (size_t)g->ny;
    int ok = 1;
    e->ofx_area = xcalloc(3 * n, sizeof(double), &ok);
    e->ofx_bxy = xcalloc(8 * n, sizeof(double), &ok);
    e->ofx_east = xcalloc(n, sizeof(double), &ok);
    if (!ok)
        return sph_err_set(err, SPH_ERR_NOMEM, "output.ocean_fluxes: out of memory (%zu cells)", n);
    memcpy(e->ofx_area, g->area, n * sizeof(double));
    *cx = e->ofx_area + n;
    *cy = e->ofx_area + 2 * n;
    sph_error local;
    sph_error_clear(&local);
    /* points that do not project stay NaN: never reached */
    if (geo_forward(e->proj, n, g->lon, g->lat, *cx, *cy, &local) != SPH_OK)
        for (size_t c = 0; c < n; c++)
            if (!isfinite((*cx)[c]) || !isfinite((*cy)[c]))
                (*cx)[c] = (*cy)[c] = NAN;
    sph_error_clear(&local);
    if (geo_forward(e->proj, 4 * n, g->blon, g->blat, e->ofx_bxy, e->ofx_bxy + 4 * n, &local) != SPH_OK)
        for (size_t c = 0; c < 4 * n; c++)
            if (!isfinite(e->ofx_bxy[c]) || !isfinite(e->ofx_bxy[4 * n + c]))
                e->ofx_bxy[c] = e->ofx_bxy[4 * n + c] = NAN;
    for (size_t c = 0; c < n; c++) {
        double a = geo_grid_angle(e->proj, g->lon[c], g->lat[c]);
        e->ofx_east[c] = isfinite(a) ? a : 0.0;
    }
    *nx = g->nx;
    *ny = g->ny;
    *land = g->land;
    log_info("forecast %s: ocean fluxes on the ocean's grid %s: %s", e->cname, path, g->desc);
    return SPH_OK;
}

/* The ocean forcing's regular lon/lat grid over the domain (cells whose
 * centres lie within one cell of the domain box), its land from the fill
 * pattern of the file's current: e->ofx_lon/lat/area, e->ofx_land, cx/cy
 * (in e->ofx_buf's tail), *nx, *ny. */
static int ofx_ocean_grid(engine *e, const char *path, int *nx, int *ny, double **cx, double **cy,
                          unsigned char **land, sph_error *err)
{
    const struct sph_config *cfg = e->cfg;
    landmask_read_opts o;
    memset(&o, 0, sizeof o);
    o.from = LANDMASK_FROM_FILL;
    o.land_value = NAN;
    landmask *m = landmask_read_model(path, &o, err);
    if (!m || landmask_is_native(m)) { /* not a regular lon/lat grid: the curvilinear reader decides */
        sph_error regular = *err;
        int read = m != NULL;
        landmask_free(m);
        sph_error_clear(err);
        int rc = ofx_ocean_curv(e, path, nx, ny, cx, cy, land, err);
        if (rc == SPH_ERR_MISSING_VAR && !read) { /* neither reader understood it: both reasons */
            char mine[700];
            snprintf(mine, sizeof mine, "%.690s", err->msg);
            rc = sph_err_set(err, SPH_ERR_CONFIG, "%s (as a regular lon/lat grid: %.300s)", mine, regular.msg);
        }
        return rc;
    }
    int gx, gy;
    double lon0, lat0, dlon, dlat;
    landmask_get_grid(m, &gx, &gy, &lon0, &lat0, &dlon, &dlat);
    const unsigned char *ml = landmask_data(m);
    double lonc = 0.5 * (cfg->domain.lon_min + cfg->domain.lon_max);
    int i0 = -1, i1 = -1, j0 = -1, j1 = -1, ok = 1;
    for (int i = 0; i < gx; i++) {
        double c = ofx_near(lon0 + (i + 0.5) * dlon, lonc);
        if (c >= cfg->domain.lon_min - dlon && c <= cfg->domain.lon_max + dlon) {
            if (i1 >= 0 && i != i1 + 1)
                ok = 0; /* the grid's seam inside the domain */
            if (i0 < 0)
                i0 = i;
            i1 = i;
        }
    }
    for (int j = 0; j < gy; j++) {
        double c = lat0 + (j + 0.5) * dlat;
        if (c >= cfg->domain.lat_min - dlat && c <= cfg->domain.lat_max + dlat) {
            if (j0 < 0)
                j0 = j;
            j1 = j;
        }
    }
    if (i0 < 0 || j0 < 0 || !ok) {
        landmask_free(m);
        return sph_err_set(err, SPH_ERR_CONFIG,
                           "output.ocean_fluxes_grid: the ocean forcing %s's grid %s the domain: set "
                           "output.ocean_fluxes_grid to \"output\"", path,
                           ok ? "has no cell over" : "has its longitude seam inside");
    }
    *nx = i1 - i0 + 1;
    *ny = j1 - j0 + 1;
    size_t n = (size_t)*nx * (size_t)*ny;
    e->ofx_lon = xcalloc((size_t)*nx, sizeof(double), &ok);
    e->ofx_lat = xcalloc((size_t)*ny, sizeof(double), &ok);
    e->ofx_area = xcalloc(3 * n, sizeof(double), &ok); /* area, then the centres' x and y */
    e->ofx_land = xcalloc(n, 1, &ok);
    if (!ok) {
        landmask_free(m);
        return sph_err_set(err, SPH_ERR_NOMEM, "output.ocean_fluxes: out of memory (%zu cells)", n);
    }
    for (int i = 0; i < *nx; i++)
        e->ofx_lon[i] = ofx_near(lon0 + (i0 + i + 0.5) * dlon, lonc);
    double *glon = *cx = e->ofx_area + n, *glat = *cy = e->ofx_area + 2 * n;
    for (int j = 0; j < *ny; j++) {
        double la = lat0 + (j0 + j + 0.5) * dlat;
        e->ofx_lat[j] = la;
        /* R^2 |dlon| |sin(lat_n) - sin(lat_s)|, the sphere of io/edge.h */
        double a = 6371000.0 * 6371000.0 * fabs(dlon) * DEG2RAD *
                   fabs(sin((la + 0.5 * dlat) * DEG2RAD) - sin((la - 0.5 * dlat) * DEG2RAD));
        for (int i = 0; i < *nx; i++) {
            size_t c = (size_t)j * *nx + i;
            e->ofx_area[c] = a;
            e->ofx_land[c] = ml[(size_t)(j0 + j) * gx + (i0 + i)];
            glon[c] = e->ofx_lon[i];
            glat[c] = la;
        }
    }
    landmask_free(m);
    *land = e->ofx_land;
    sph_error local;
    sph_error_clear(&local);
    if (geo_forward(e->proj, n, glon, glat, glon, glat, &local) != SPH_OK)
        for (size_t c = 0; c < n; c++)
            if (!isfinite(glon[c]) || !isfinite(glat[c]))
                glon[c] = glat[c] = NAN; /* never reached */
    return SPH_OK;
}

/* The mixed layer's open water (model.ocean.mixed_layer): each of its
 * cells goes whole to the file's cell containing its centre (ofx_locate),
 * or the nearest water cell within its diagonal plus one file cell, so
 * the file's integral is the cells' sum (docs/ocean-coupling.md). */
static int ofx_map_mixed_layer(engine *e, sph_error *err)
{
    sph_ocean *o = sph_model_ocean(e->m);
    if (!o || !e->ocean_pts || !e->prm.ocean.mixed_layer)
        return SPH_OK;
    sph_ocean_clear_fluxes(o);
    int ok = 1;
    size_t nc = o->ncell;
    e->ofx_to = xcalloc(nc, sizeof(long), &ok);
    e->ofx_rot = xcalloc(2 * nc, sizeof(double), &ok);
    double *lon = xcalloc(2 * nc, sizeof(double), &ok);
    if (!ok) {
        free(lon);
        return sph_err_set(err, SPH_ERR_NOMEM, "output.ocean_fluxes: out of memory (mixed layer)");
    }
    double *lat = lon + nc, amax = 0.0;
    sph_error local;
    sph_error_clear(&local);
    if (geo_inverse(e->proj, nc, e->ocean_pts->x, e->ocean_pts->y, lon, lat, &local) != SPH_OK)
        for (size_t c = 0; c < nc; c++)
            if (!isfinite(lon[c]) || !isfinite(lat[c]))
                lon[c] = lat[c] = NAN;
    size_t ncells = e->ofx_ncell;
    for (size_t c = 0; c < ncells; c++)
        amax = fmax(amax, e->ofx_area[c]);
    double reach = hypot(o->g.dx, o->g.dy) + sqrt(amax);
    for (size_t c = 0; c < nc; c++) {
        e->ofx_to[c] = ofx_locate(e->ofx, lon[c], lat[c], e->ocean_pts->x[c], e->ocean_pts->y[c], reach);
        /* plane x/y -> east/north at the centre, as for the particles (ofx_record) */
        double a = isfinite(lon[c]) ? geo_grid_angle(e->proj, lon[c], lat[c]) : 0.0;
        if (!isfinite(a))
            a = 0.0;
        e->ofx_rot[c] = cos(a);
        e->ofx_rot[nc + c] = sin(a);
    }
    free(lon);
    return SPH_OK;
}

int fc_open_ocean_fluxes(engine *e, sph_error *err)
{
    if (e->dd == 2 && e->dd_rank > 0) { /* rank 0 writes the file; the workers' accumulators start from zero */
        fc_ofx_zero(sph_model_particles(e->dd_m));
        e->ofx_t0 = e->t0;
        return SPH_OK;
    }
    const struct sph_config *cfg = e->cfg;
    const prod_grid *g = &e->grid;
    const char *ocean = ofx_ocean_file(e);
    int mode = cfg->output.ocean_fluxes_grid;
    if (mode == CFG_OFX_GRID_OCEAN && !ocean)
        return sph_err_set(err, SPH_ERR_CONFIG, "output.ocean_fluxes_grid: \"ocean\" but no ocean forcing has "
                           "files: set output.ocean_fluxes_grid to \"output\" or \"auto\"");
    int ok = 1, nx = 0, ny = 0;
    double *cx = NULL, *cy = NULL;
    unsigned char *land = NULL;
    e->ofx_buf = xcalloc(6 * e->cap, sizeof(double), &ok);
    if (!ok)
        return sph_err_set(err, SPH_ERR_NOMEM, "output.ocean_fluxes: out of memory");
    if (mode != CFG_OFX_GRID_OUTPUT && ocean) {
        int rc = ofx_ocean_grid(e, ocean, &nx, &ny, &cx, &cy, &land, err);
        if (rc)
            return rc;
        snprintf(e->ofx_grid_from, sizeof e->ofx_grid_from, "ocean forcing %s", ocean);
    } else {
        nx = g->nlon;
        ny = g->nlat;
        e->ofx_area = xcalloc(e->npts, sizeof(double), &ok);
        e->ofx_lon = xcalloc((size_t)g->nlon, sizeof(double), &ok);
        e->ofx_lat = xcalloc((size_t)g->nlat, sizeof(double), &ok);
        if (!ok)
            return sph_err_set(err, SPH_ERR_NOMEM, "output.ocean_fluxes: out of memory");
        for (int i = 0; i < g->nlon; i++)
            e->ofx_lon[i] = g->lon0 + i * g->dlon;
        for (int j = 0; j < g->nlat; j++) {
            e->ofx_lat[j] = g->lat0 + j * g->dlat;
            double a = prod_grid_cell_area_m2(g, j);
            for (int i = 0; i < g->nlon; i++)
                e->ofx_area[(size_t)j * g->nlon + i] = a;
        }
        cx = e->gx;
        cy = e->gy;
        land = e->lm ? e->g_land : NULL;
        snprintf(e->ofx_grid_from, sizeof e->ofx_grid_from, "output grid");
    }
    e->ofx_ncell = (size_t)nx * (size_t)ny;
    ofx_grid og = {.kind = OFX_GRID_LONLAT, .nx = nx, .ny = ny, .xaxis = e->ofx_lon, .yaxis = e->ofx_lat,
                   .cx = cx, .cy = cy, .area = e->ofx_area, .land = land,
                   .projection = geo_proj_definition(e->proj), .grid_source = e->ofx_grid_from};
    if (e->ofx_curv) { /* the ocean's curvilinear grid: cells the polygons of their corners */
        size_t n = e->ofx_ncell;
        og.kind = OFX_GRID_CURV;
        og.lon = e->ofx_curv->lon;
        og.lat = e->ofx_curv->lat;
        og.blon = e->ofx_curv->blon;
        og.blat = e->ofx_curv->blat;
        og.bx = e->ofx_bxy;
        og.by = e->ofx_bxy + 4 * n;
        og.east = e->ofx_east;
        og.corners = e->ofx_curv->corners;
        snprintf(e->ofx_grid_from, sizeof e->ofx_grid_from, "ocean forcing %s (%s)", ocean, e->ofx_curv->desc);
    }
    char title[160];
    snprintf(title, sizeof title, "sphice fluxes into the ocean, %s",
             e->cfg->domain.name ? e->cfg->domain.name : "domain");
    ofx_meta meta = {.title = title, .institution = "sphice", .model_version = SPHICE_VERSION,
                     .git_revision = SPHICE_GIT, .cycle_time = e->t0};
    char path[4200];
    snprintf(path, sizeof path, "%s/%s", e->req->stage_dir, OFX_FILE);
    int rc = ofx_open(&e->ofx, &og, &meta, path, err);
    if (rc)
        return rc;
    fc_ofx_zero(sph_model_particles(e->m));
    if (e->dd_m) /* parallel.decomposition "domain": rank 0's own decomposed particles too */
        fc_ofx_zero(sph_model_particles(e->dd_m));
    e->ofx_t0 = e->t0;
    return ofx_map_mixed_layer(e, err);
}

/* One record: the mean over [e->ofx_t0, t]. e->olon/olat hold the
 * particles' positions (fc_write_output). */
static int ofx_record(engine *e, double t, sph_error *err)
{
    sph_particles *P = sph_model_particles(e->m);
    size_t n = P->n;
    const double rho_i = e->cfg->model.rho_i, kr = e->prm.kernel_radius;
    double *rad = e->ofx_buf, *tx = rad + e->cap, *ty = tx + e->cap, *ia = ty + e->cap,
           *iv = ia + e->cap;
    for (size_t k = 0; k < n; k++) {
        /* plane x/y -> east/north, as the velocities in fc_write_output; a
         * curvilinear grid takes the plane's and turns them to its i/j */
        double a = e->ofx_curv ? 0.0 : geo_grid_angle(e->proj, e->olon[k], e->olat[k]);
        if (!isfinite(a))
            a = 0.0;
        double c = cos(a), s = sin(a);
        tx[k] = P->ofx_taux[k] * c - P->ofx_tauy[k] * s;
        ty[k] = P->ofx_taux[k] * s + P->ofx_tauy[k] * c;
        /* spread over a disc whose kernel (1 - d^2/R^2)^2 integrates to the
         * footprint m/M: pi R^2 / 3 = footprint, so that ice packed edge to
         * edge gives its own concentration, not more, near coasts too */
        double fp = P->dens[k] > 0.0 ? P->mass[k] / P->dens[k] : 0.0;
        rad[k] = fp > 0.0 ? sqrt(3.0 * fp / M_PI) : kr * P->sml[k];
        ia[k] = P->thick[k] > 0.0 ? P->mass[k] / (rho_i * P->thick[k]) : 0.0; /* A x footprint */
        iv[k] = P->mass[k] / rho_i;
    }
    ofx_particles op = {.n = n, .x = P->x, .y = P->y, .radius = rad, .heat_ice = P->ofx_heat_ice,
                        .heat_lead = P->ofx_heat_lead, .water = P->ofx_water, .salt = P->ofx_salt,
                        .taux = tx, .tauy = ty, .swbase = P->ofx_swbase, .ice_area = ia, .ice_volume = iv};
    int rc = ofx_add_particles(e->ofx, &op, err);
    sph_ocean *o = e->ofx_to ? sph_model_ocean(e->m) : NULL;
    double lost[3] = {0.0, 0.0, 0.0};
    if (!rc && o) /* the mixed layer's open water with no particle, and the removed particles */
        rc = ofx_add_ocean_cells(e->ofx, o->ncell, e->ofx_to, e->ofx_rot, o->ofx_heat, o->ofx_water, o->ofx_salt,
                                 o->ofx_heat_ice, o->ofx_taux, o->ofx_tauy, o->ofx_swbase, t - e->ofx_t0, lost, err);
    if (!rc)
        rc = ofx_write_record(e->ofx, e->ofx_t0, t, err);
    if (rc)
        return rc;
    if (lost[0] != 0.0 || lost[1] != 0.0 || lost[2] != 0.0)
        log_warn("forecast %s: ocean fluxes: mixed-layer cells outside the ocean-fluxes grid's water gave %g J, "
                 "%g kg of water and %g kg of salt that are not in the record ending %.0f s after the cycle",
                 e->cname, lost[0], lost[1], lost[2], t - e->t0);
    if (o)
        sph_ocean_clear_fluxes(o);
    if (ofx_lost(e->ofx) > 0)
        log_warn("forecast %s: ocean fluxes: %zu particles lie outside the ocean-fluxes grid or far from its "
                 "water cells; their fluxes are not in the record ending %.0f s after the cycle (particles_lost)",
                 e->cname, ofx_lost(e->ofx), t - e->t0);
    fc_ofx_zero(P);
    if (e->dd_m) { /* the decomposed run's particles and cells, whose copies were recorded */
        fc_ofx_zero(sph_model_particles(e->dd_m));
        sph_ocean_clear_fluxes(sph_model_ocean(e->dd_m));
    }
    e->ofx_t0 = t;
    return SPH_OK;
}

int fc_close_ocean_fluxes(engine *e, sph_error *err)
{
    int rc = ofx_close(e->ofx, err);
    e->ofx = NULL;
    if (rc)
        return rc;
    return products_add_file(e->pw, OFX_FILE, err);
}
