/* Atmospheric quantities the forcing may leave out, from the air
 * temperature alone: the defaults of docs/engine.md, beside the formulas
 * of the thermodynamics they copy. Pure functions, no state. */
#ifndef SPHICE_CORE_ATMOS_H
#define SPHICE_CORE_ATMOS_H

#define SPH_ATMOS_DEFAULT_RH 0.9    /* relative humidity over water when none is given */
#define SPH_ATMOS_DEFAULT_CLOUD 0.5 /* cloud fraction for the longwave default */
#define SPH_ATMOS_SIGMA_SB 5.670374419e-8 /* Stefan-Boltzmann constant, W m-2 K-4 */

/* Specific humidity (kg/kg) at relative humidity rh over water, air
 * temperature t_c (deg C) and air pressure pa (Pa): the saturation vapour
 * pressure of the thermodynamics' check, es = 611.2 exp(17.62 T / (243.12 + T)) Pa,
 * and q = 0.622 e / (p - 0.378 e). */
double sph_atmos_qair_rh(double t_c, double rh, double pa);

/* Downwelling longwave radiation (W/m^2) at air temperature t_c (deg C)
 * under cloud fraction cloud: Koenig-Langlo & Augstein (1994),
 * eps = 0.765 + 0.22 N^3, L = eps sigma T^4. */
double sph_atmos_lwdn_cloud(double t_c, double cloud);

#endif
