#include "core/kernel.h"

#include <math.h>

void sph_kernel_init(sph_kernel *k, sph_kernel_kind kind, double radius)
{
    k->kind = kind;
    switch (kind) {
    case SPH_KERNEL_GAUSSIAN:
        k->radius = radius > 0.0 ? radius : 3.0;
        /* Truncated at q = R: renormalise so the truncated kernel integrates to 1. */
        k->norm = 1.0 / (M_PI * (1.0 - exp(-k->radius * k->radius)));
        break;
    case SPH_KERNEL_WENDLAND_C2:
        k->radius = 2.0;
        k->norm = 7.0 / (4.0 * M_PI);
        break;
    default:
        k->kind = SPH_KERNEL_CUBIC_SPLINE;
        k->radius = 2.0;
        k->norm = 10.0 / (7.0 * M_PI);
        break;
    }
}
