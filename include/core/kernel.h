/* SPH smoothing kernels in two dimensions (PHYSICS.md section 4).
 *
 * Each kernel W(r, h) integrates to 1 over the plane. Support radius is
 * `radius * h`: Wendland C2 and the cubic spline have compact support 2h;
 * the seed's Gaussian exp(-q^2)/(pi h^2) is truncated at q = radius and
 * renormalised by 1/(1 - exp(-radius^2)) so that it still integrates to 1.
 * gradient: grad_k W(r_k - r_j) = F(r) (r_k - r_j) with F = W'(r)/r.
 */
#ifndef SPHICE_CORE_KERNEL_H
#define SPHICE_CORE_KERNEL_H

#include "core/kinds.h"

typedef struct sph_kernel {
    sph_kernel_kind kind;
    double radius; /* support in units of h */
    double norm;   /* normalisation constant times h^2 */
} sph_kernel;

/* radius is used by the Gaussian only (compact kernels have 2). */
void sph_kernel_init(sph_kernel *k, sph_kernel_kind kind, double radius);

/* W and F = (dW/dr)/r at distance r for smoothing length h; 0 outside. */
static inline void sph_kernel_eval(const sph_kernel *k, double r2, double h, double *W, double *F);

#include <math.h>
static inline void sph_kernel_eval(const sph_kernel *k, double r2, double h, double *W, double *F)
{
    double ih = 1.0 / h;
    double q2 = r2 * ih * ih;
    double R = k->radius;
    if (q2 >= R * R) {
        *W = 0.0;
        *F = 0.0;
        return;
    }
    double c = k->norm * ih * ih;
    switch (k->kind) {
    case SPH_KERNEL_GAUSSIAN: {
        double e = exp(-q2);
        *W = c * e;
        *F = -2.0 * c * e * ih * ih; /* d/dr exp(-r^2/h^2) / r = -2/h^2 exp */
        break;
    }
    case SPH_KERNEL_WENDLAND_C2: {
        /* W = c (1 - q/2)^4 (1 + 2q), q < 2 */
        double q = sqrt(q2);
        double t = 1.0 - 0.5 * q;
        double t3 = t * t * t;
        *W = c * t3 * t * (1.0 + 2.0 * q);
        /* dW/dq = c * (-5 q) t^3 ; F = dW/dq / (q h^2) */
        *F = -5.0 * c * t3 * ih * ih;
        break;
    }
    default: { /* cubic spline (Monaghan & Lattanzio 1985) */
        double q = sqrt(q2);
        double dWdq;
        if (q < 1.0) {
            *W = c * (1.0 - 1.5 * q2 + 0.75 * q2 * q);
            dWdq = c * (-3.0 * q + 2.25 * q2);
            *F = c * (-3.0 + 2.25 * q) * ih * ih;
        } else {
            double t = 2.0 - q;
            *W = c * 0.25 * t * t * t;
            dWdq = -c * 0.75 * t * t;
            *F = dWdq / q * ih * ih;
        }
        (void)dWdq;
        break;
    }
    }
}

#endif
