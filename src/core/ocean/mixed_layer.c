/* The slab mixed layer's grid and state (core/ocean.h): allocation, the
 * freezing point, cell lookup. The step that couples it to the particles
 * is new_ice.c. */
#include "core/ocean.h"

#include <math.h>
#include <stdlib.h>

double sph_ocean_freezing_point(int kind, double mu, double S)
{
    if (kind == SPH_FREEZING_UNESCO) {
        double s = S > 0.0 ? S : 0.0;
        return -0.0575 * s + 1.710523e-3 * s * sqrt(s) - 2.154996e-4 * s * s;
    }
    return -mu * S;
}

void sph_ocean_free(sph_ocean *o)
{
    if (!o)
        return;
    double **d[] = {&o->temp, &o->sal, &o->depth, &o->water, &o->salt, &o->frazil, &o->frazil_enth,
                    &o->tair, &o->qair, &o->ua, &o->va, &o->swdn, &o->lwdn, &o->lat,
                    &o->sst_restore, &o->sss_restore, &o->ow_heat, &o->ow_fresh, &o->ow_salt,
                    &o->ofx_heat, &o->ofx_water, &o->ofx_salt, &o->ofx_heat_ice, &o->ofx_taux, &o->ofx_tauy,
                    &o->ofx_swbase, &o->pfoot, &o->penth, &o->pmass, &o->psnowfall, &o->cfoot, &o->seafrac, &o->acc_e, &o->acc_w};
    for (size_t i = 0; i < sizeof d / sizeof d[0]; i++)
        free(*d[i]);
    free(o->bin_start);
    free(o->bin_list);
    free(o->pcell);
    free(o);
}

sph_ocean *sph_ocean_create(const sph_ocean_grid *g, size_t cap, double depth, double S0, double Tf0)
{
    if (!g || g->nx < 1 || g->ny < 1 || !(g->dx > 0.0) || !(g->dy > 0.0) || !(g->ds > 0.0) ||
        !isfinite(g->x0) || !isfinite(g->y0) || !isfinite(g->lx0) || !isfinite(g->ly0) || cap == 0)
        return NULL;
    sph_ocean *o = calloc(1, sizeof *o);
    if (!o)
        return NULL;
    o->g = *g;
    o->ncell = (size_t)g->nx * (size_t)g->ny;
    o->cap = cap;
    size_t nc = o->ncell;
    double **cells[] = {&o->temp, &o->sal, &o->depth, &o->water, &o->salt, &o->frazil, &o->frazil_enth,
                        &o->tair, &o->qair, &o->ua, &o->va, &o->swdn, &o->lwdn, &o->lat,
                        &o->sst_restore, &o->sss_restore, &o->ow_heat, &o->ow_fresh, &o->ow_salt,
                        &o->ofx_heat, &o->ofx_water, &o->ofx_salt, &o->ofx_heat_ice, &o->ofx_taux,
                        &o->ofx_tauy, &o->ofx_swbase, &o->cfoot, &o->seafrac, &o->acc_e, &o->acc_w};
    int ok = 1;
    for (size_t i = 0; i < sizeof cells / sizeof cells[0]; i++)
        ok &= (*cells[i] = calloc(nc, sizeof(double))) != NULL;
    ok &= (o->pfoot = calloc(cap, sizeof(double))) != NULL;
    ok &= (o->penth = calloc(cap, sizeof(double))) != NULL;
    ok &= (o->pmass = calloc(cap, sizeof(double))) != NULL;
    ok &= (o->psnowfall = calloc(cap, sizeof(double))) != NULL;
    ok &= (o->bin_start = calloc(nc + 1, sizeof(int))) != NULL;
    ok &= (o->bin_list = calloc(cap, sizeof(int))) != NULL;
    ok &= (o->pcell = calloc(cap, sizeof(int))) != NULL;
    if (!ok) {
        sph_ocean_free(o);
        return NULL;
    }
    for (size_t c = 0; c < nc; c++) {
        o->sst_restore[c] = o->sss_restore[c] = NAN;
        o->seafrac[c] = 1.0;
        sph_ocean_set_cell(o, c, depth, S0, Tf0);
    }
    return o;
}

size_t sph_ocean_cell(const sph_ocean *o, double x, double y)
{
    double fi = floor((x - o->g.x0) / o->g.dx), fj = floor((y - o->g.y0) / o->g.dy);
    long i = isfinite(fi) ? (long)fmax(0.0, fmin(fi, (double)(o->g.nx - 1))) : 0;
    long j = isfinite(fj) ? (long)fmax(0.0, fmin(fj, (double)(o->g.ny - 1))) : 0;
    return (size_t)j * (size_t)o->g.nx + (size_t)i;
}


void sph_ocean_set_cell(sph_ocean *o, size_t c, double depth, double S, double T)
{
    if (c >= o->ncell)
        return;
    double area = o->g.dx * o->g.dy * fmax(o->seafrac[c], SPH_OCEAN_MIN_SEAFRAC);
    o->depth[c] = depth;
    o->temp[c] = T;
    o->sal[c] = S;
    o->water[c] = SPH_OCEAN_RHO_WATER * depth * area;
    o->salt[c] = o->water[c] * S / 1000.0;
}

size_t sph_ocean_open_water_fluxes(const sph_ocean *o, const double **heat, const double **fresh,
                                   const double **salt)
{
    if (heat)
        *heat = o->ow_heat;
    if (fresh)
        *fresh = o->ow_fresh;
    if (salt)
        *salt = o->ow_salt;
    return o->ncell;
}

void sph_ocean_clear_fluxes(sph_ocean *o)
{
    if (!o)
        return;
    for (size_t c = 0; c < o->ncell; c++) {
        o->ofx_heat[c] = o->ofx_water[c] = o->ofx_salt[c] = 0.0;
        o->ofx_heat_ice[c] = o->ofx_taux[c] = o->ofx_tauy[c] = o->ofx_swbase[c] = 0.0;
    }
}
