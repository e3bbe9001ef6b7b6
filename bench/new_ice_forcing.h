/* The new-ice benches' forcing (bench_new_ice.c, bench_mpi_ocean.c). */
#ifndef SPHICE_BENCH_NEW_ICE_FORCING_H
#define SPHICE_BENCH_NEW_ICE_FORCING_H

#include "core/model.h"
#include "core/ocean.h"

/* -15 C, dark, wind 6 m/s east, over every particle and every cell the
 * model holds (a decomposed rank: its own). */
static inline void new_ice_forcing(sph_model *m)
{
    sph_particles *P = sph_model_particles(m);
    sph_ocean *o = sph_model_ocean(m);
    const double val[7] = {-15.0, 8e-4, 6.0, 0.0, 0.0, 190.0, 40.0};
    double *const dst[2][7] = {{P->tair, P->qair, P->ua, P->va, P->swdn, P->lwdn, P->lat},
                               {o ? o->tair : NULL, o ? o->qair : NULL, o ? o->ua : NULL, o ? o->va : NULL,
                                o ? o->swdn : NULL, o ? o->lwdn : NULL, o ? o->lat : NULL}};
    const size_t n[2] = {P->n, o ? o->ncell : 0};
    for (int s = 0; s < 2; s++)
        for (int q = 0; q < 7; q++)
            for (size_t k = 0; k < n[s]; k++)
                dst[s][q][k] = val[q];
    for (size_t k = 0; k < P->n; k++)
        P->uw[k] = P->vw[k] = 0.0;
}

#endif
