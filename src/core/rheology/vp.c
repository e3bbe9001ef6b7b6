/* Hibler (1979) viscous-plastic rheology: the stress pass over a particle
 * list, its viscosity bound, the projection of the EVP stress memory onto
 * the yield ellipse, and the plastic-wave step bound with replacement
 * pressure. The per-particle law is sph_vp_stress (include/core/rheology.h). */
#include "../lanes.h"
#include "../model_impl.h"
#include "vp_lanes.h"

#include <math.h>

#include "core/rheology.h"

/* With replacement pressure: plastic-wave Courant number dt c_p / spacing,
 * c_p = sqrt(k P0 / rho_i) the uniaxial plastic wave speed of packed ice
 * (PHYSICS.md s. 8). Measured on the R300 channel (tests/test_r300.c,
 * docs/dynamics.md): holds its steady state at 0.137 (5 km, 120 s),
 * drifts with growing kinetic energy at 0.205 (5 km 180 s; 2.5 km 90 s). */
#define SPH_REPLACEMENT_COURANT_MAX 0.15

static inline void vp_stress_one(sph_model *m, size_t k, double *s11, double *s22, double *s12)
{
    const sph_particles *P = m->P;
    if (!sph_stress_loose(m, k, s11, s22, s12))
        m->zeta[k] = sph_vp_stress(&m->prm, P->pres[k], P->e11[k], P->e22[k], P->e12[k], &s11[k],
                                   &s22[k], &s12[k]);
}

/* List entries 2i and 2i + 1 in two lanes where neither is loose. */
static void vp_stress(sph_model *m, const int *list, size_t count, double *s11, double *s22,
                      double *s12)
{
    const sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    const double inv_e2 = 1.0 / (p->ecc * p->ecc);
    const size_t half = count / 2;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(count))
    for (size_t i = 0; i < half; i++) {
        size_t k0 = list ? (size_t)list[2 * i] : 2 * i, k1 = list ? (size_t)list[2 * i + 1] : 2 * i + 1;
        if (m->loose[k0] || m->loose[k1]) {
            vp_stress_one(m, k0, s11, s22, s12);
            vp_stress_one(m, k1, s11, s22, s12);
            continue;
        }
        sph_v2d a11, a22, a12;
        sph_v2d z = sph_vp_stress_two(p, inv_e2, ld2(P->pres, k0, k1), ld2(P->e11, k0, k1),
                                  ld2(P->e22, k0, k1), ld2(P->e12, k0, k1), &a11, &a22, &a12);
        st2(m->zeta, k0, k1, z);
        st2(s11, k0, k1, a11);
        st2(s22, k0, k1, a22);
        st2(s12, k0, k1, a12);
    }
    if (count % 2)
        vp_stress_one(m, list ? (size_t)list[count - 1] : count - 1, s11, s22, s12);
}

/* zeta never exceeds either cap: P / (2 Delta_min) and zeta_max_factor P */
static void vp_zeta_bound(const sph_model *m, const int *list, size_t count, double *out)
{
    const sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    for (size_t i = 0; i < count; i++) {
        size_t k = list ? (size_t)list[i] : i;
        out[k] = fmin(P->pres[k] / (2.0 * p->delta_min), p->zeta_max_factor * P->pres[k]);
    }
}

/* The EVP stress memory can lag behind a strength that fell (divergence,
 * melt): a stress outside the current yield ellipse is projected back
 * onto it, S = -P/2 I + (S + P/2 I) / r, r the ellipse radius. Without
 * this a diluted parcel kept the stress of its packed past and S/M^2
 * blew up near coasts (demo). */
static void vp_project_memory(sph_model *m)
{
    sph_particles *P = m->P;
    double e = m->prm.ecc;
    size_t n = P->n;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++) {
        double Pk = P->pres[k];
        double a = P->s11[k], b = P->s22[k], c = P->s12[k];
        if (!(Pk > 0.0)) {
            P->s11[k] = P->s22[k] = P->s12[k] = 0.0;
            continue;
        }
        double sI = 0.5 * (a + b), sII = sqrt(0.25 * (a - b) * (a - b) + c * c);
        double x = (sI + 0.5 * Pk) / (0.5 * Pk), y = sII / (0.5 * Pk / e);
        double r = sqrt(x * x + y * y);
        if (r > 1.0) {
            double h = 0.5 * Pk;
            P->s11[k] = -h + (a + h) / r;
            P->s22[k] = -h + (b + h) / r;
            P->s12[k] = c / r;
        }
    }
}

static double vp_stable_dt(const sph_params *p, double spacing, const char **why)
{
    /* the bound was measured as the drift of a moving state (R300); a
     * fixed state (model.fixed_state, a comparison option) has none:
     * box2001 at 432-3200 s, docs/dynamics.md */
    if (!p->replacement_pressure || p->fixed_state)
        return HUGE_VAL;
    double k = 0.5 * (1.0 + sqrt(1.0 + 1.0 / (p->ecc * p->ecc)));
    double cp = sqrt(k * p->P0 / p->rho_i);
    *why = "is outside the measured stable region with replacement pressure "
           "(plastic-wave Courant number dt c_p / spacing above 0.15; "
           "stable at 0.137, drift and growth measured at 0.205); refused";
    return cp > 0.0 ? SPH_REPLACEMENT_COURANT_MAX * spacing / cp : HUGE_VAL;
}

const sph_rheology_ops sph_rheology_vp = {
    .name = "vp", .fields = 0, .vp_law = 1, .stress = vp_stress, .zeta_bound = vp_zeta_bound,
    .project_memory = vp_project_memory, .stable_dt = vp_stable_dt,
};
