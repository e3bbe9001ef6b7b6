/* The ocean mixed layer in a forecast (issue 20; core/ocean.h,
 * docs/ocean.md): its grid on the model plane, the capacity new ice
 * needs, and the forcing of its cells (the atmosphere over open water, the
 * SST it is restored to), sampled by the same coupling as the particles
 * at the cells' centres. */
#include <math.h>
#include <string.h>

#include "forecast_impl.h"
#include "core/ocean.h"
#include "util/log.h"

static int ocean_on(const engine *e) { return e->cfg->model.ocean.mixed_layer; }

/* The plane box the seeding lattice covers (the land mask's). */
static void plane_box(const engine *e, double *x0, double *x1, double *y0, double *y1)
{
    *x0 = e->plane.x0;
    *y0 = e->plane.y0;
    *x1 = e->plane.x0 + e->plane.nx * e->plane.dx;
    *y1 = e->plane.y0 + e->plane.ny * e->plane.dy;
}

/* The grid's cell (m) and its count of cells. */
static double grid_cell(const engine *e, int *nx, int *ny)
{
    double x0, x1, y0, y1, d = fc_spacing_m(e);
    plane_box(e, &x0, &x1, &y0, &y1);
    double cell = e->prm.ocean.cell > 0.0 ? e->prm.ocean.cell : 4.0 * d;
    *nx = (int)fmin(ceil((x1 - x0) / cell), 1e7);
    *ny = (int)fmin(ceil((y1 - y0) / cell), 1e7);
    return cell;
}

size_t fc_ocean_capacity(const engine *e, size_t count)
{
    if (!ocean_on(e))
        return count;
    int nx, ny;
    grid_cell(e, &nx, &ny);
    double cells = (double)nx * ny;
    if (cells < 1e7 && (size_t)cells > count)
        count = (size_t)cells; /* the coupling samples the cells in the particles' arrays */
    if (!e->cfg->model.ocean.create)
        return count;
    double x0, x1, y0, y1, d = fc_spacing_m(e);
    plane_box(e, &x0, &x1, &y0, &y1);
    double n = (floor((x1 - x0) / d) + 2.0) * (floor((y1 - y0) / d) + 2.0);
    size_t lattice = n < 1e9 ? (size_t)n : (size_t)1e9;
    return lattice > count ? lattice : count;
}

int fc_ocean_setup(engine *e, sph_error *err)
{
    if (!ocean_on(e))
        return SPH_OK;
    const sph_params *p = &e->prm;
    /* plain continuity density with new particles: a particle the wind
     * pulls off the edge of a pack spreads without bound, its leads freeze
     * more ice than the sea under it holds and a slab drains (bench_season:
     * day 71; the freeze-up scene: day 20). With the density re-initialised
     * by summation every density_reinit_steps steps it runs (docs/ocean.md) */
    if (p->ocean.create && !p->summation_density && p->density_reinit_steps <= 0)
        return sph_err_set(err, SPH_ERR_CONFIG,
                           "config: model.new_ice.create with continuity density needs "
                           "model.density_reinit_steps > 0 (or model.summation_density true): plain "
                           "continuity lets the footprints of particles pulled off a wall grow without "
                           "bound over a season (docs/ocean.md)");
    double x0, x1, y0, y1, d = fc_spacing_m(e);
    plane_box(e, &x0, &x1, &y0, &y1);
    int nx, ny;
    double cell = grid_cell(e, &nx, &ny);
    if (cell < d)
        return sph_err_set(err, SPH_ERR_CONFIG,
                           "config: model.ocean.cell %g m is smaller than the seeding lattice spacing %g m "
                           "(initial.spacing): set model.ocean.cell to at least %g", cell, d, d);
    if (nx < 1 || ny < 1 || (double)nx * ny > 1e7)
        return sph_err_set(err, SPH_ERR_CONFIG, "config: model.ocean.cell %g m gives a %d x %d grid", cell, nx, ny);
    /* the seeding lattice: points at ((i + 1/2) d, (j + 1/2) d) (io/seed.c) */
    sph_ocean_grid g = {nx, ny, x0, y0, cell, cell, 0.5 * d, 0.5 * d, d};
    if (sph_model_ocean_create(e->m, &g) != SPH_STEP_OK)
        return sph_err_set(err, SPH_ERR_NOMEM, "forecast: cannot create the mixed layer (%d x %d cells)", nx, ny);
    size_t nc = (size_t)nx * (size_t)ny;
    if (nc > e->cap)
        return sph_err_set(err, SPH_ERR_CONFIG, "config: model.ocean.cell %g m gives more cells (%zu) than the "
                           "model holds particles (%zu)", cell, nc, e->cap);
    int rc = fc_ocean_points(e, &g, err);
    if (rc)
        return rc;
    e->ocean_fresh = e->req->warm_start == NULL;
    log_info("forecast %s: mixed layer on a %d x %d grid of %.0f m cells, depth %g m%s", e->cname, nx, ny, cell,
             p->ocean.depth, p->ocean.create ? ", new ice in open water" : "");
    return SPH_OK;
}

int fc_ocean_points(engine *e, const sph_ocean_grid *g, sph_error *err)
{
    size_t nc = (size_t)g->nx * (size_t)g->ny;
    e->ocean_pts = sph_particles_create(nc, 1);
    if (!e->ocean_pts)
        return sph_err_set(err, SPH_ERR_NOMEM, "forecast: out of memory (mixed layer)");
    e->ocean_pts->n = nc;
    for (size_t c = 0; c < nc; c++) {
        e->ocean_pts->x[c] = g->x0 + ((double)(c % (size_t)g->nx) + 0.5) * g->dx;
        e->ocean_pts->y[c] = g->y0 + ((double)(c / (size_t)g->nx) + 0.5) * g->dy;
        e->ocean_pts->id[c] = (long)c;
    }
    return SPH_OK;
}

/* 1 when the plane's land mask says (x, y) is land. */
static int plane_land(const engine *e, double x, double y)
{
    const sph_landmask *L = &e->plane;
    long i = (long)floor((x - L->x0) / L->dx), j = (long)floor((y - L->y0) / L->dy);
    return L->land && i >= 0 && j >= 0 && i < L->nx && j < L->ny && L->land[(size_t)j * L->nx + i];
}

/* The bathymetry says land at a cell centre the land mask calls sea. */
static int bathy_refusal(engine *e, double b, size_t c, sph_error *err)
{
    forcing_var_info info[32];
    const char *file = "?", *var = "?", *src = "?";
    for (size_t s = 0; s < e->cpl.nforc; s++) {
        size_t n = forcing_describe(e->cpl.forc[s], info, 32);
        for (size_t k = 0; k < n && k < 32; k++)
            if (!strncmp(info[k].standard_name, "sea_floor_depth", 15)) {
                file = info[k].file;
                var = info[k].variable;
                src = e->cpl.forc_name[s];
            }
        if (strcmp(file, "?"))
            break;
    }
    char ll[64];
    coupling_format_lonlat(e->cpl.lon[c], e->cpl.lat[c], ll, sizeof ll);
    return sph_err_set(err, SPH_ERR_BAD_DATA,
                       "forcing %s: %s: variable %s (sea-floor depth) is %g m, land, at %s where the land mask "
                       "says sea: the bathymetry and the land mask disagree (set landmask.path to the ocean "
                       "model's own mask)", src, file, var, b, ll);
}

int fc_ocean_fill(engine *e, double t, sph_error *err) { return fc_ocean_fill_to(e, sph_model_ocean(e->m), t, err); }

int fc_ocean_fill_to(engine *e, sph_ocean *o, double t, sph_error *err)
{
    sph_particles *Q = e->ocean_pts;
    if (!o || !Q)
        return SPH_OK;
    int rc = coupling_fill(&e->cpl, e->proj, &e->cfg->model.thermo, e->thermo_on, Q, t, err);
    if (rc)
        return rc;
    for (size_t c = 0; c < o->ncell; c++) {
        o->tair[c] = Q->tair[c];
        o->qair[c] = Q->qair[c];
        o->ua[c] = Q->ua[c];
        o->va[c] = Q->va[c];
        o->swdn[c] = Q->swdn[c];
        o->lwdn[c] = Q->lwdn[c];
        o->lat[c] = Q->lat[c];
        o->sst_restore[c] = Q->sst[c]; /* NaN where no source gives it: no restoring there */
    }
    if (e->ocean_fresh) { /* a cold start: the slab starts at the forcing's SST, not below freezing */
        e->ocean_fresh = 0;
        const sph_ocean_params *op = &e->prm.ocean;
        for (size_t c = 0; c < o->ncell; c++) {
            double d = op->depth;
            if (isfinite(e->cpl.mld[c]))
                d = e->cpl.mld[c]; /* never negative: the reader refuses that */
            double b = e->cpl.bathy[c];
            if (isfinite(b) && b <= 0.0 && !plane_land(e, Q->x[c], Q->y[c]))
                return bathy_refusal(e, b, c, err);
            if (isfinite(b) && b < d)
                d = b; /* shallow water: the slab reaches the sea floor */
            if (d < op->min_depth)
                d = op->min_depth;
            double Tf = sph_ocean_freezing_point(op->freezing, e->prm.thermo.mu, o->sal[c]);
            double T = isfinite(Q->sst[c]) && Q->sst[c] > Tf ? Q->sst[c] : Tf;
            sph_ocean_set_cell(o, c, d, o->sal[c], T);
        }
    }
    return SPH_OK;
}
