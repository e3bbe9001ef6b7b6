/* Test helper: the open water of the slab mixed layer written out from
 * the formulas (docs/thermo.md, docs/ocean.md), for tests/test_new_ice.c
 * and tests/test_ocean_fluxes_mixed.c: the bulk open-water flux, the
 * Bitz & Lipscomb (1999) new-ice enthalpy and mean salinity, and one step
 * of a slab of open water (per m^2) that cools and freezes frazil. */
#ifndef SPHICE_TESTS_OCEAN_COLUMN_H
#define SPHICE_TESTS_OCEAN_COLUMN_H

#include <math.h>

#include "core/model.h"
#include "core/ocean.h"
#include "lattice.h"

#define OC_RHO_A 1.3
#define OC_CP_A 1005.0
#define OC_CH 1.3e-3
#define OC_LV_W 2.501e6
#define OC_SIGMA 5.670374419e-8

/* The open-water flux of docs/thermo.md written out: (1 - 0.06) SW + 0.97 LW
 * - 0.97 sigma T^4 + rho_a cp_a ch U (Ta - T) + rho_a Lv ce U (q - qsat(T)),
 * qsat from Magnus (WMO 2008) over water at 101325 Pa. */
static inline double ow_flux(double T, double ta, double q, double U, double sw, double lw)
{
    double es = 611.2 * exp(17.62 * T / (243.12 + T));
    double qs = 0.622 * es / (101325.0 - 0.378 * es);
    double Tk = T + 273.15;
    return 0.94 * sw + 0.97 * lw - 0.97 * OC_SIGMA * Tk * Tk * Tk * Tk + OC_RHO_A * OC_CP_A * OC_CH * U * (ta - T) +
           OC_RHO_A * OC_LV_W * OC_CH * U * (q - qs);
}

/* Bitz & Lipscomb (1999) salinity profile S(z) = 1.6 (1 - cos(pi z^(0.407/(z+0.573)))), ppt. */
static inline double bl_salinity(double z) { return 1.6 * (1.0 - cos(M_PI * pow(z, 0.407 / (z + 0.573)))); }

/* Its mean over the midpoints of n layers, ppt. */
static inline double bl_mean_salinity(int n)
{
    double s = 0.0;
    for (int i = 0; i < n; i++)
        s += bl_salinity((i + 0.5) / n) / n;
    return s;
}

/* Bitz & Lipscomb (1999) new-ice enthalpy at Tf over n layers, written out. */
static inline double q_new(int n, double Tf)
{
    double q = 0.0;
    for (int i = 0; i < n; i++) {
        double S = bl_salinity((i + 0.5) / n);
        double Tm = -0.054 * S, T = Tf < Tm ? Tf : Tm;
        q += S > 0 ? -900.0 * (2106.0 * (Tm - T) + 3.34e5 * (1.0 - Tm / T)) : -900.0 * (3.34e5 - 2106.0 * T);
    }
    return q / n;
}

/* A slab of open water per m^2: temperature T (deg C), water W and salt
 * (kg/m^2), heat capacity H (J/m^2/K, fixed). */
typedef struct {
    double T, W, salt, H;
} oc_slab;

/* One step of dt s under the open-water flux F (W/m^2) of its
 * temperature: it cools (warms); below the linear freezing point of its
 * salinity (-0.054 S) the deficit freezes frazil at -q_new of n layers,
 * which takes its water and the ice's mean salinity. Returns the frazil
 * formed, kg/m^2. */
static inline double oc_slab_step(oc_slab *s, double F, double dt, int n)
{
    s->T += F * dt / s->H;
    double tf = -0.054 * 1000.0 * s->salt / s->W;
    if (!(s->T < tf))
        return 0.0;
    double dm = 900.0 * s->H * (tf - s->T) / -q_new(n, tf);
    s->W -= dm;
    s->salt -= dm * bl_mean_salinity(n) / 1000.0;
    s->T = tf;
    return dm;
}

/* The fluxes tests' model (tests/test_ocean_fluxes_mixed.c, _meltout.c):
 * free drift without Coriolis or wind drag (the wind enters the bulk
 * formulas only), the multi-layer column, ocean fluxes accumulated, time
 * step dt, a mixed layer of three 10 km cells in a row from (0, 0), each
 * 20 m deep at 32 psu and temperature T[c], and a 2 x 2 lattice of ice
 * particles 2 km apart from (24, 4) km in cell 2 (0.5 m, concentration
 * 0.9, latitude 40), capacity 64. *p gets the parameters. NULL on failure. */
static inline sph_model *oc_row_model(sph_params *p, double dt, const double T[3])
{
    sph_params_default(p);
    p->dt = dt;
    p->thermo_dt = dt;
    p->physics = SPH_PHYSICS_FREE_DRIFT;
    p->coriolis = 0;
    p->Ca = 0.0;
    p->thermo.model = SPH_THERMO_MULTI_LAYER;
    p->thermo.ocean_fluxes = 1;
    p->ocean.mixed_layer = 1;
    sph_model *m = sph_model_create(p, 64, NULL);
    sph_ocean_grid g = {3, 1, 0.0, 0.0, 1e4, 1e4, 1250.0, 1250.0, 2500.0};
    if (!m || sph_model_ocean_create(m, &g) != SPH_STEP_OK) {
        sph_model_free(m);
        return NULL;
    }
    for (size_t c = 0; c < 3; c++)
        sph_ocean_set_cell(sph_model_ocean(m), c, 20.0, 32.0, T[c]);
    lattice_fill(sph_model_particles(m), p, 2, 2, 24000.0, 4000.0, 2000.0, 0.5, 0.9, 40.0);
    return m;
}

/* The same atmosphere (air temperature deg C, specific humidity, wind
 * m/s, shortwave and longwave down W/m^2) and latitude over every particle
 * and every cell of the mixed layer of m. */
static inline void oc_fill_atm(sph_model *m, double ta, double q, double ua, double va, double sw, double lw,
                               double lat)
{
    sph_particles *P = sph_model_particles(m);
    sph_ocean *o = sph_model_ocean(m);
    const double val[7] = {ta, q, ua, va, sw, lw, lat};
    double *const dst[2][7] = {{P->tair, P->qair, P->ua, P->va, P->swdn, P->lwdn, P->lat},
                               {o->tair, o->qair, o->ua, o->va, o->swdn, o->lwdn, o->lat}};
    const size_t n[2] = {P->n, o->ncell};
    for (int s = 0; s < 2; s++)
        for (int k = 0; k < 7; k++)
            for (size_t i = 0; i < n[s]; i++)
                dst[s][k][i] = val[k];
}

/* The ocean tests' common set-up: hourly free drift without wind, Coriolis
 * or ocean drag forcing, the given column and the mixed layer on. */
static inline void oc_params(sph_params *p, sph_thermo_model column)
{
    sph_params_default(p);
    p->dt = 3600.0;
    p->thermo_dt = 3600.0;
    p->physics = SPH_PHYSICS_FREE_DRIFT;
    p->coriolis = 0;
    p->Ca = 0.0;
    p->thermo.model = column;
    p->ocean.mixed_layer = 1;
}

#endif
