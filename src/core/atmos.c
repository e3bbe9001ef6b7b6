/* Atmospheric defaults (core/atmos.h). */
#include "core/atmos.h"

#include <math.h>

double sph_atmos_qair_rh(double t_c, double rh, double pa)
{
    double es = rh * 611.2 * exp(17.62 * t_c / (243.12 + t_c));
    return 0.622 * es / (pa - 0.378 * es);
}

double sph_atmos_lwdn_cloud(double t_c, double cloud)
{
    double eps = 0.765 + 0.22 * cloud * cloud * cloud;
    double tk = t_c + 273.15;
    return eps * SPH_ATMOS_SIGMA_SB * tk * tk * tk * tk;
}
