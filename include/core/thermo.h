/* Sea-ice thermodynamics on every particle (PHYSICS.md section 5).
 * CONTRACT SKELETON: the thermodynamics module fills this header in;
 * the names below are what the model driver calls and must stay. */
#ifndef SPHICE_CORE_THERMO_H
#define SPHICE_CORE_THERMO_H

#include <stddef.h>
#include "core/particles.h"
#include "core/status.h"

typedef enum {
    SPH_THERMO_OFF = 0,
    SPH_THERMO_ZERO_LAYER,  /* Semtner (1976) */
    SPH_THERMO_MULTI_LAYER, /* Bitz & Lipscomb (1999) */
    SPH_THERMO_AUTO         /* zero-layer below auto_thickness, multi-layer above */
} sph_thermo_model;

typedef struct sph_thermo_params {
    sph_thermo_model model;
    int nlayers;           /* multi-layer column layers */
    double auto_thickness; /* m: threshold of the automatic choice */
    double rho_i;          /* kg/m^3 */
    /* ... the module adds its parameters here, each with a default ... */
} sph_thermo_params;

void sph_thermo_params_default(sph_thermo_params *p);

/* Workspace for sph_thermo_step, allocated once (no allocation in a step). */
typedef struct sph_thermo_work sph_thermo_work;
sph_thermo_work *sph_thermo_work_create(size_t cap, int nlayers);
void sph_thermo_work_free(sph_thermo_work *w);

/* Sets a fresh particle's column (tsurf, enthalpy) consistent with its
 * thickness and the air temperature tair (deg C). */
void sph_thermo_init_particle(const sph_thermo_params *p, sph_particles *P, size_t k, double tair);

/* One thermodynamic step of length dt on every live particle. Changes
 * thick, conc, mass (and snow, tsurf, enth); adds growth/melt/new ice to
 * the budget (deterministically: no atomics, fixed summation order). A
 * particle that melts completely gets mass = 0; the model removes it. */
int sph_thermo_step(const sph_thermo_params *p, sph_particles *P, double dt,
                    sph_thermo_work *w, sph_budget *b, sph_status *st);

#endif
