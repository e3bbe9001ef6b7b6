/* TEMPORARY until the thermodynamics module lands: defaults only; the
 * step refuses to run. Deleted when src/core/thermo.c is merged. */
#include <stdlib.h>
#include "core/thermo.h"

struct sph_thermo_work { int unused; };

void sph_thermo_params_default(sph_thermo_params *p)
{
    p->model = SPH_THERMO_OFF;
    p->nlayers = 1;
    p->auto_thickness = 0.5;
    p->rho_i = 900.0;
}
sph_thermo_work *sph_thermo_work_create(size_t cap, int nlayers)
{
    (void)cap; (void)nlayers;
    return calloc(1, sizeof(sph_thermo_work));
}
void sph_thermo_work_free(sph_thermo_work *w) { free(w); }
void sph_thermo_init_particle(const sph_thermo_params *p, sph_particles *P, size_t k, double tair)
{
    (void)p; (void)P; (void)k; (void)tair;
}
int sph_thermo_step(const sph_thermo_params *p, sph_particles *P, double dt, sph_thermo_work *w,
                    sph_budget *b, sph_status *st)
{
    (void)p; (void)P; (void)dt; (void)w; (void)b;
    return sph_status_set(st, SPH_STEP_FATAL, -1, "thermodynamics", 0, 0, "is not built yet");
}
