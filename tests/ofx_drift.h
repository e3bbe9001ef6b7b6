/* Test helper: one particle in steady free drift (no Coriolis, the water
 * turned by 25 degrees) under a wind over a current, then nsum steps of
 * accumulated ice-ocean stress (P->ofx_taux, ofx_tauy), and the water's
 * drag on the ice from the momentum equation's formula
 * rho_w C_w |U_w - u| R(theta_w) (U_w - u) evaluated here with the
 * particle's velocity: what the fluxes file's stress must be minus of
 * (tests/test_ocean_fluxes.c, tests/test_ocean_fluxes_curv.c). */
#ifndef SPHICE_TESTS_OFX_DRIFT_H
#define SPHICE_TESTS_OFX_DRIFT_H

#include <math.h>

#include "core/model.h"
#include "lattice.h"

typedef struct {
    sph_params p;
    sph_model *m;
    sph_particles *P;
    double T;        /* s: the accumulation interval */
    double fp;       /* m^2: the footprint m / M */
    double drag[2];  /* N m-2: the water's drag on the ice, x and y */
} ofx_drift;

/* 0 on success; d->m is freed by the caller (sph_model_free). */
static inline int ofx_drift_run(ofx_drift *d, double ua, double va, double uw, double vw, int nsum)
{
    sph_params_default(&d->p);
    d->p.physics = SPH_PHYSICS_FREE_DRIFT;
    d->p.thermo_dt = 0;
    d->p.coriolis = 0;
    d->p.turn_water = 25.0;
    d->p.thermo.ocean_fluxes = 1;
    d->m = sph_model_create(&d->p, 1, NULL);
    if (!d->m)
        return -1;
    d->P = sph_model_particles(d->m);
    lattice_fill(d->P, &d->p, 1, 1, 0, 0, 2000.0, 0.5, 0.9, 40.0);
    lattice_set_forcing(d->P, ua, va, uw, vw, 0, 0);
    sph_status st;
    if (sph_model_init(d->m, &st) != 0)
        return -1;
    for (int s = 0; s < 3000; s++) /* steady state */
        if (sph_model_step(d->m, &st) != 0)
            return -1;
    d->P->ofx_taux[0] = d->P->ofx_tauy[0] = 0.0;
    for (int s = 0; s < nsum; s++)
        if (sph_model_step(d->m, &st) != 0)
            return -1;
    d->T = nsum * d->p.dt;
    d->fp = d->P->mass[0] / d->P->dens[0];
    double dux = uw - d->P->u[0], duy = vw - d->P->v[0], sp = hypot(dux, duy), th = 25.0 * M_PI / 180.0;
    d->drag[0] = d->p.rho_w * d->p.Cw * sp * (cos(th) * dux - sin(th) * duy);
    d->drag[1] = d->p.rho_w * d->p.Cw * sp * (sin(th) * dux + cos(th) * duy);
    return 0;
}

#endif
