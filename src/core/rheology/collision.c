/* Shen, Hibler & Lepparanta (1987) floe-collision rheology: the stress
 * pass over a particle list from the strain rates and the fluctuating
 * velocity v' the strain pass fills (SPH_RHEO_FIELD_VFLUCT). No yield
 * ellipse, so no projection of the stress memory, and no measured step
 * bound of its own. The per-particle law is sph_collision_stress
 * (include/core/rheology.h). */
#include "../model_impl.h"

#include "core/rheology.h"

static void collision_stress(sph_model *m, const int *list, size_t count, double *s11,
                             double *s22, double *s12)
{
    const sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    const double *vf = m->vfluct;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(count))
    for (size_t i = 0; i < count; i++) {
        size_t k = list ? (size_t)list[i] : i;
        if (!sph_stress_loose(m, k, s11, s22, s12))
            m->zeta[k] = sph_collision_stress(p, P->thick[k], P->conc[k], vf[k], P->e11[k],
                                              P->e22[k], P->e12[k], &s11[k], &s22[k],
                                              &s12[k]);
    }
}

/* the viscosity follows v', not a cap: the last stress pass's zeta */
static void collision_zeta_bound(const sph_model *m, const int *list, size_t count, double *out)
{
    for (size_t i = 0; i < count; i++) {
        size_t k = list ? (size_t)list[i] : i;
        out[k] = m->zeta[k];
    }
}

/* no projection of the memory, no step bound of its own */
const sph_rheology_ops sph_rheology_collision = {
    .name = "collision", .fields = SPH_RHEO_FIELD_VFLUCT, .stress = collision_stress,
    .zeta_bound = collision_zeta_bound, .project_memory = NULL, .stable_dt = NULL,
};
