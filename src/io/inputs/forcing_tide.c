/* Harmonic tide grids ("harmonic-1" format, docs/forcing.md), format-free:
 * a driver reads the amplitudes and Greenwich phase lags of the
 * constituents on a lon/lat grid (forcing_driver.tide), ftide_constants
 * keeps them as harmonic constants, and the forcing reader synthesises
 * the elevation and current fields on the grid nodes at the sample time
 * and then interpolates them like any other slice, so missing (land)
 * nodes, SSH gradients and point location are shared code. */
#include "forcing_impl.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DEG (M_PI / 180.0)

int ftide_constants(fsource *s, fvar *v, const int *index, size_t nc, const double *cube,
                    const double *phase, sph_error *err)
{
    const char *path = s->paths[0];
    size_t nn = v->grid->nx * v->grid->ny;
    size_t nmiss = 0;
    for (size_t k = 0; k < nc; k++) {
        int c = index[k];
        if (v->harm->present[c])
            continue; /* a repeated constituent: the first wins */
        v->harm->present[c] = 1;
        v->harm->c[c] = malloc(nn * sizeof(double));
        v->harm->s[c] = malloc(nn * sizeof(double));
        if (!v->harm->c[c] || !v->harm->s[c]) {
            return forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
        }
        for (size_t p = 0; p < nn; p++) {
            double A = cube[k * nn + p], G = phase[k * nn + p] * DEG;
            if (isnan(A) || isnan(G)) {
                v->harm->c[c][p] = v->harm->s[c][p] = NAN;
                nmiss += k == 0;
            } else {
                v->harm->c[c][p] = A * cos(G);
                v->harm->s[c][p] = A * sin(G);
            }
        }
    }
    v->fill_fraction = (double)nmiss / (double)nn;
    return 0;
}

void ftide_synth(fvar *v, const tide_args *a, double t, double *out)
{
    size_t nn = v->grid->nx * v->grid->ny;
    for (size_t p = 0; p < nn; p++)
        out[p] = 0.0;
    for (int k = 0; k < TIDE_NCONST; k++) {
        if (!v->harm->present[k])
            continue;
        /* f A cos(phi - G) = f (A cos G cos phi + A sin G sin phi) */
        double phi = tide_phase_rad(a, k, t);
        double fc = a->f[k] * cos(phi), fs = a->f[k] * sin(phi);
        const double *c = v->harm->c[k], *s = v->harm->s[k];
        for (size_t p = 0; p < nn; p++)
            out[p] += fc * c[p] + fs * s[p];
    }
}
