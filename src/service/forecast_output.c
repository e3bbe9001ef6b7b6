/* The forecast's output (forecast_impl.h): the output grid, the product
 * writer with its metadata, the observation to score against, each output
 * time (particles -> grid through the SPH interpolation) and the restart
 * file of the next cycle. */
#include "forecast_impl.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/restart.h"
#include "util/version.h"

int fc_setup_grid(engine *e, sph_error *err)
{
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

int fc_open_products(engine *e, prod_station *stations, sph_error *err)
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
int fc_set_observation(engine *e, sph_error *err)
{
    const struct sph_config *cfg = e->cfg;
    ice_raster *obs = NULL;
    ice_raster_options o;
    ice_raster_options_default(&o);
    o.valid_time = e->t_end;
    o.thickness_kind = ICE_THICK_ICE; /* unused: verification compares concentration only */
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
    if (!ice_raster_can_sample(obs)) {
        rc = sph_err_set(err, SPH_ERR_CONFIG, "observation %s: cannot be regridded for "
                         "verification: its grid (%s) cannot be sampled", obs->path, obs->grid);
        ice_raster_free(obs);
        return rc;
    }
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
int fc_write_output(engine *e, double t, sph_error *err)
{
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
    prod_fields f = {.conc = e->g_conc, .hbar = e->g_hbar, .thick = e->g_thick, .u_east = e->g_u,
                     .v_north = e->g_v, .pressure = e->g_pres, .divergence = e->g_div,
                     .shear = e->g_shear, .land = e->lm ? e->g_land : NULL};
    prod_particles_view pv = {.n = n, .lon = e->olon, .lat = e->olat, .u_east = e->pue, .v_north = e->pvn,
                              .mass = P->mass, .thick = P->thick, .conc = P->conc, .id = P->id};
    return products_add_time(e->pw, t, &f, e->cfg->output.products.particles ? &pv : NULL, err);
}

int fc_write_restart(engine *e, double t, sph_error *err)
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
