/* Test helper: a regular lattice of ice particles on the model plane. */
#ifndef SPHICE_TESTS_LATTICE_H
#define SPHICE_TESTS_LATTICE_H

#include "core/model.h"

/* Fills nx*ny particles at spacing dx starting at (x0, y0) with ice of
 * thickness h_i and concentration A; mass = rho_i A h_i dx^2;
 * smoothing length sml_factor * dx; latitude lat; forcing zero. */
static inline size_t lattice_fill(sph_particles *P, const sph_params *p, int nx, int ny,
                                  double x0, double y0, double dx, double h_i, double A,
                                  double lat)
{
    size_t k = P->n;
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++, k++) {
            P->x[k] = x0 + i * dx;
            P->y[k] = y0 + j * dx;
            P->u[k] = P->v[k] = 0.0;
            P->thick[k] = h_i;
            P->conc[k] = A;
            P->mass[k] = p->rho_i * A * h_i * dx * dx;
            P->sml[k] = p->sml_factor * dx;
            P->sml0[k] = P->sml[k];
            P->lat[k] = lat;
            P->id[k] = (long)k;
            P->ua[k] = P->va[k] = P->uw[k] = P->vw[k] = 0.0;
            P->sshx[k] = P->sshy[k] = 0.0;
            P->s11[k] = P->s22[k] = P->s12[k] = 0.0;
        }
    P->n = k;
    return k;
}

static inline void lattice_set_forcing(sph_particles *P, double ua, double va, double uw,
                                       double vw, double sshx, double sshy)
{
    for (size_t k = 0; k < P->n; k++) {
        P->ua[k] = ua;
        P->va[k] = va;
        P->uw[k] = uw;
        P->vw[k] = vw;
        P->sshx[k] = sshx;
        P->sshy[k] = sshy;
    }
}

/* Small random velocities (uniform in +-amp/2 per component, a fixed
 * linear congruential sequence from seed) and a wind va = -10 m/s: every
 * strain rate of a packed lattice non-zero (the benchmarks' state). */
static inline void lattice_random_velocities(sph_particles *P, unsigned seed, double amp)
{
    unsigned s = seed;
    for (size_t k = 0; k < P->n; k++) {
        s = s * 1103515245u + 12345u;
        P->u[k] = amp * ((double)(s >> 8 & 0xffff) / 65535.0 - 0.5);
        s = s * 1103515245u + 12345u;
        P->v[k] = amp * ((double)(s >> 8 & 0xffff) / 65535.0 - 0.5);
        P->va[k] = -10.0;
    }
}

#endif
