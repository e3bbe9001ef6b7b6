/* A column's energy from the definitions (not the code's): the ice
 * layers' enthalpy and the snow's q_s = -rho_s (L0 - c0 T_s) per m^3.
 * Shared by test_snow and test_thermo_sw. */
#ifndef SPHICE_TESTS_COLUMN_ENERGY_H
#define SPHICE_TESTS_COLUMN_ENERGY_H

#include "core/thermo.h"

#include <math.h>

static inline double q_snow(const sph_thermo_params *p, double T) { return -p->rho_s * (p->L0 - p->c0 * fmin(T, 0.0)); }

static inline double column_energy_here(const sph_thermo_params *p, const sph_column *c)
{
    double e = 0.0;
    for (int k = 0; k < c->nlayers; k++)
        e += c->enth[k] * c->thick / c->nlayers;
    return e + q_snow(p, c->tsnow) * c->snow;
}

#endif
