/* The modified / adaptive EVP stress solver (Kimmritz et al. 2015, 2016):
 * pseudo-time iterations whose fixed point is the implicit time-discrete
 * momentum equation. Its workspace holds the rheology's target stress of
 * each iteration; its step is bounded by the measured stability envelope. */
#include "../lanes.h"
#include "../model_impl.h"
#include "../rheology/vp_lanes.h"
#include "core/dd.h"
#include "core/rheology.h"

#include <math.h>
#include <stdlib.h>

/* Measured stability envelope (bench_stability, 4-day coast runs):
 * fixed-parameter mEVP (alpha = beta = 300) blew up or clumped at
 * dt 300 s below 2 km and at 1800 s; adaptive EVP is stable at dt/dx =
 * 0.06 s/m and blew up at 0.3 s/m (1 km, 300 s) and clumped at 0.45;
 * refused above 0.2 s/m (between the two; runs at 0.14 are tested).
 * On the current core the same channel no longer blows up at 0.3-0.9 s/m
 * in 96 h, but the state departs from the small-step one (docs/dynamics.md,
 * "Auto time stepping"); the bound stays until the envelope is re-measured
 * with an accuracy criterion. */
#define SPH_MEVP_FIXED_DT_MAX 300.0
#define SPH_MEVP_FIXED_DT_FINE 60.0
#define SPH_AEVP_DT_PER_M 0.2
/* m/s: the relative residual's scale where the ice is (nearly) at rest */
#define SPH_MEVP_SPEED_FLOOR 1e-4

typedef struct mevp_work {
    double *t11, *t22, *t12; /* the rheology's target stress, per particle */
    double *res2;            /* per particle: (beta |u' - u|)^2 of the last iteration */
    /* under a decomposition (core/dd.h no_overlap 0): the active set split
     * into interior particles (owned, every neighbour owned and real) and
     * the rest, each in the active set's order */
    int *inner, *outer;
    size_t ninner, nouter;
    double *ds2;             /* per particle: squared stress change of the last iteration */
    /* per particle: the air stress over M (sph_momentum's tax / rho_h,
     * tay / rho_h), which a step's iterations do not change: computed once
     * per step for the active set (the same operations, the same bits) */
    double *qax, *qay;
    double *gair; /* [2 x slots] the air stress on each coast ghost's source, once per step */
    double *imd2; /* per slot: 1 / M^2 for the divergence's records (sph_model.div_imd2) */
    double *im;   /* per particle: 1 / M for the strain rates (sph_model.strain_im) */
    /* model.evp.anderson (depth > 0 at create): the iterate before the
     * sweep, the last sweep's residual f = g(x) - x and image g, and the
     * ring of their differences; 5 components (u, v, s11, s22, s12) of
     * nslot each */
    int depth;
    size_t nslot;
    double *x0, *fprev, *gprev, *dF, *dG;
} mevp_work;

#define AA_NC 5 /* components of the Anderson state */

static void mevp_free(void *ws)
{
    mevp_work *w = ws;
    if (!w)
        return;
    free(w->t11);
    free(w->t22);
    free(w->t12);
    free(w->res2);
    free(w->ds2);
    free(w->qax);
    free(w->qay);
    free(w->gair);
    free(w->imd2);
    free(w->im);
    free(w->inner);
    free(w->outer);
    free(w->x0);
    free(w->fprev);
    free(w->gprev);
    free(w->dF);
    free(w->dG);
    free(w);
}

static int mevp_create(const sph_model *m, void **ws)
{
    size_t n = sph_model_slots(m);
    mevp_work *w = calloc(1, sizeof *w);
    *ws = w;
    if (!w)
        return -1;
    w->t11 = calloc(n, sizeof(double));
    w->t22 = calloc(n, sizeof(double));
    w->t12 = calloc(n, sizeof(double));
    w->res2 = calloc(n, sizeof(double));
    w->ds2 = calloc(n, sizeof(double));
    w->qax = calloc(n, sizeof(double));
    w->qay = calloc(n, sizeof(double));
    w->gair = calloc(2 * n, sizeof(double));
    w->imd2 = calloc(n, sizeof(double));
    w->im = calloc(n, sizeof(double));
    w->inner = malloc((n + 1) * sizeof(int));
    w->outer = malloc((n + 1) * sizeof(int));
    int ok = w->t11 && w->t22 && w->t12 && w->res2 && w->ds2 && w->qax && w->qay && w->gair && w->imd2 && w->im && w->inner &&
             w->outer;
    w->depth = m->prm.evp_anderson;
    w->nslot = n;
    if (ok && w->depth > 0) {
        size_t d = (size_t)w->depth;
        w->x0 = calloc(AA_NC * n, sizeof(double));
        w->fprev = calloc(AA_NC * n, sizeof(double));
        w->gprev = calloc(AA_NC * n, sizeof(double));
        w->dF = calloc(d * AA_NC * n, sizeof(double));
        w->dG = calloc(d * AA_NC * n, sizeof(double));
        ok = w->x0 && w->fprev && w->gprev && w->dF && w->dG;
    }
    if (ok)
        return 0;
    mevp_free(w);
    *ws = NULL;
    return -1;
}

/* One mEVP iteration (a sweep) over the active set: ghost velocities,
 * strain rates, the rheology's stress, the stress relaxation, ghost
 * stresses, the divergence and the velocity update. Writes the largest
 * velocity change, the sum of squared changes, of squared momentum
 * residuals and of squared speeds, summed serially in the active set's
 * order (the same with any thread count). */
typedef struct mevp_sums {
    double dmax, s2, q2, u2;
    double ds2, p2; /* squared stress changes and strengths (model.evp.change_tol) */
} mevp_sums;

/* The stress relaxation of particle k towards the rheology's stress
 * (t11, t22, t12); alpha: aEVP's or the fixed one. */
static inline void relax_one(sph_model *m, mevp_work *w, size_t k, double t11, double t22,
                             double t12, double dt, double visc)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    double z = m->zeta[k];
    double alpha = p->evp_alpha;
    if (p->evp_adaptive) {
        /* aEVP (Kimmritz, Losch & Danilov 2016): alpha = beta = 2 sqrt(gamma),
         * gamma = dt lambda_max of the SPH viscous operator. Power
         * iteration on lattices gives lambda_max h^2 / nu = 0.68-0.74
         * (Gaussian, h = dx) and 1.15-1.23 (Wendland C2, cubic spline,
         * h = 1.3 dx), nu = zeta (1 + e^-2) / M; SPH_VISCOUS_EIG = 1.25
         * bounds them all (docs/dynamics.md). visc = 1 + e^-2. */
        double gam = SPH_VISCOUS_EIG * z * visc * dt / (P->dens[k] * P->sml[k] * P->sml[k]);
        alpha = sph_fmax(2.0 * sqrt(gam), 10.0);
    }
    m->scratch[k] = alpha; /* beta = alpha */
    double ia = 1.0 / alpha;
    double d11 = (t11 - P->s11[k]) * ia, d22 = (t22 - P->s22[k]) * ia, d12 = (t12 - P->s12[k]) * ia;
    w->ds2[k] = d11 * d11 + d22 * d22 + 2.0 * d12 * d12;
    P->s11[k] += d11; /* (t11 - s11) ia, as d11 */
    P->s22[k] += d22;
    P->s12[k] += d12;
}

/* relax_one for k0 and k1 in two lanes (lanes.h: the same bits). */
static inline void relax_two(sph_model *m, mevp_work *w, size_t k0, size_t k1, sph_v2d t11,
                             sph_v2d t22, sph_v2d t12, double dt, double visc)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    sph_v2d alpha = splat2(p->evp_alpha);
    if (p->evp_adaptive) {
        sph_v2d z = ld2(m->zeta, k0, k1), h = ld2(P->sml, k0, k1);
        sph_v2d gam = splat2(SPH_VISCOUS_EIG) * z * splat2(visc) * splat2(dt) /
                      (ld2(P->dens, k0, k1) * h * h);
        alpha = fmax2(splat2(2.0) * sqrt2(gam), splat2(10.0));
    }
    st2(m->scratch, k0, k1, alpha);
    sph_v2d ia = splat2(1.0) / alpha;
    sph_v2d s11 = ld2(P->s11, k0, k1), s22 = ld2(P->s22, k0, k1), s12 = ld2(P->s12, k0, k1);
    sph_v2d d11 = (t11 - s11) * ia, d22 = (t22 - s22) * ia, d12 = (t12 - s12) * ia;
    st2(w->ds2, k0, k1, d11 * d11 + d22 * d22 + splat2(2.0) * d12 * d12);
    st2(P->s11, k0, k1, s11 + d11);
    st2(P->s22, k0, k1, s22 + d22);
    st2(P->s12, k0, k1, s12 + d12);
}

#if defined(SPH_HAVE_LANES4)
/* relax_two for the four particles k[0..3] in four lanes (lanes.h);
 * contig: k[l] = k[0] + l. */
SPH_LANES4_INLINE void relax_four(sph_model *m, mevp_work *w, const size_t *k, int contig,
                                  sph_v4d t11, sph_v4d t22, sph_v4d t12, double dt, double visc)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    sph_v4d alpha = splat4(p->evp_alpha);
    if (p->evp_adaptive) {
        sph_v4d z = ld4(m->zeta, k, contig), h = ld4(P->sml, k, contig);
        sph_v4d gam = splat4(SPH_VISCOUS_EIG) * z * splat4(visc) * splat4(dt) /
                      (ld4(P->dens, k, contig) * h * h);
        alpha = fmax4(splat4(2.0) * sqrt4(gam), splat4(10.0));
    }
    st4(m->scratch, k, contig, alpha);
    sph_v4d ia = splat4(1.0) / alpha;
    sph_v4d s11 = ld4(P->s11, k, contig), s22 = ld4(P->s22, k, contig), s12 = ld4(P->s12, k, contig);
    sph_v4d d11 = (t11 - s11) * ia, d22 = (t22 - s22) * ia, d12 = (t12 - s12) * ia;
    st4(w->ds2, k, contig, d11 * d11 + d22 * d22 + splat4(2.0) * d12 * d12);
    st4(P->s11, k, contig, s11 + d11);
    st4(P->s22, k, contig, s22 + d22);
    st4(P->s12, k, contig, s12 + d12);
}
#endif

/* The VP law (rheology/vp.c's stress pass, per particle) and the
 * relaxation of k in one go: no target-stress arrays in between. */
static inline void vp_relax_one(sph_model *m, mevp_work *w, size_t k, double dt, double visc)
{
    const sph_particles *P = m->P;
    double t11 = 0.0, t22 = 0.0, t12 = 0.0;
    if (m->loose[k])
        m->zeta[k] = 0.0; /* sph_stress_loose */
    else
        m->zeta[k] = sph_vp_stress(&m->prm, P->pres[k], P->e11[k], P->e22[k], P->e12[k], &t11, &t22,
                                   &t12);
    relax_one(m, w, k, t11, t22, t12, dt, visc);
}

#define MEVP_VP_BLOCK 32

#if defined(SPH_HAVE_LANES4)
#define MEVP_VP_BLOCK4 16

/* list entries 4i .. 4i + 3 (i < count / 4), four lanes where none is
 * loose (else particle by particle), k[l] contiguous or gathered */
SPH_LANES4_INLINE void quad_of(const int *list, size_t i, size_t *k)
{
    for (int l = 0; l < 4; l++)
        k[l] = (size_t)list[4 * i + (size_t)l];
}

SPH_LANES4_INLINE int quad_contig(const size_t *k)
{
    return k[1] == k[0] + 1 && k[2] == k[0] + 2 && k[3] == k[0] + 3;
}

/* mevp_relax's VP branch for the quads [i0, i1) of list in four lanes
 * (the law for the block into a buffer, then its relaxation, as the
 * two-lane branch's blocks); a loose particle's lane takes zero stress
 * and zeta (sph_stress_loose) in place of the law's, and its relaxation
 * is then vp_relax_one's; a function of its own with the target (the
 * threads' loop around it is compiled for the baseline CPU) */
SPH_LANES4_TARGET static void relax_vp4_block(sph_model *m, mevp_work *w, const int *act, size_t i0,
                                              size_t i1, double dt, double visc, double inv_e2)
{
    const sph_params *p = &m->prm;
    const sph_particles *P = m->P;
    const sph_v4d zero = splat4(0.0);
    sph_v4d t11[MEVP_VP_BLOCK4], t22[MEVP_VP_BLOCK4], t12[MEVP_VP_BLOCK4];
    unsigned char ct[MEVP_VP_BLOCK4];
    for (size_t i = i0; i < i1; i++) {
        size_t k[4];
        quad_of(act, i, k);
        ct[i - i0] = (unsigned char)quad_contig(k);
        sph_v4d z, a11, a22, a12;
        if (ct[i - i0])
            z = sph_vp_stress_four(p, inv_e2, ld4(P->pres, k, 1), ld4(P->e11, k, 1), ld4(P->e22, k, 1),
                                   ld4(P->e12, k, 1), &a11, &a22, &a12);
        else
            z = sph_vp_stress_four(p, inv_e2, ld4(P->pres, k, 0), ld4(P->e11, k, 0), ld4(P->e22, k, 0),
                                   ld4(P->e12, k, 0), &a11, &a22, &a12);
        const sph_v4l lz = {-(long long)(m->loose[k[0]] != 0), -(long long)(m->loose[k[1]] != 0),
                            -(long long)(m->loose[k[2]] != 0), -(long long)(m->loose[k[3]] != 0)};
        t11[i - i0] = sel4(lz, zero, a11);
        t22[i - i0] = sel4(lz, zero, a22);
        t12[i - i0] = sel4(lz, zero, a12);
        st4(m->zeta, k, ct[i - i0], sel4(lz, zero, z));
    }
    for (size_t i = i0; i < i1; i++) {
        size_t k[4];
        quad_of(act, i, k);
        if (ct[i - i0])
            relax_four(m, w, k, 1, t11[i - i0], t22[i - i0], t12[i - i0], dt, visc);
        else
            relax_four(m, w, k, 0, t11[i - i0], t22[i - i0], t12[i - i0], dt, visc);
    }
}

/* mevp_relax's VP branch for list entries [0, 4 (count / 4)) */
static void mevp_relax_vp4(sph_model *m, mevp_work *w, const int *act, size_t na, double dt,
                           double visc, double inv_e2)
{
    const size_t nq = na / 4;
    const size_t nblk = (nq + MEVP_VP_BLOCK4 - 1) / MEVP_VP_BLOCK4;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(na))
    for (size_t b = 0; b < nblk; b++) {
        const size_t i0 = b * MEVP_VP_BLOCK4;
        relax_vp4_block(m, w, act, i0, i0 + MEVP_VP_BLOCK4 < nq ? i0 + MEVP_VP_BLOCK4 : nq, dt, visc,
                        inv_e2);
    }
}
#endif

/* The rheology's stress and its relaxation for the particles of list
 * (per particle: the order of the list does not matter); entries 2i and
 * 2i + 1 in two lanes. The VP law (rheology vp_law) is evaluated here,
 * fused with the relaxation; another rheology's stress pass fills the
 * workspace's target stress first. */
static void mevp_relax(sph_model *m, mevp_work *w, const int *act, size_t na, double dt)
{
    const sph_params *p = &m->prm;
    const double visc = 1.0 + 1.0 / (p->ecc * p->ecc);
    const size_t half = na / 2;
    if (m->rheo->vp_law) {
        /* blocks of MEVP_VP_BLOCK pairs: the law for the block into a
         * buffer on the stack, then the block's relaxation (two short
         * chains of divisions and roots, as the two passes had, instead of
         * one long one per pair); with four lanes the list's quads first,
         * then the rest in pairs */
        const sph_particles *P = m->P;
        const double inv_e2 = 1.0 / (p->ecc * p->ecc);
        size_t done = 0;
#if defined(SPH_HAVE_LANES4)
        if (m->lanes4) {
            mevp_relax_vp4(m, w, act, na, dt, visc, inv_e2);
            done = na / 4 * 4;
        }
#endif
        act += done;
        na -= done;
        const size_t half2 = na / 2;
        const size_t nblk = (half2 + MEVP_VP_BLOCK - 1) / MEVP_VP_BLOCK;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(na))
        for (size_t b = 0; b < nblk; b++) {
            sph_v2d t11[MEVP_VP_BLOCK], t22[MEVP_VP_BLOCK], t12[MEVP_VP_BLOCK];
            unsigned char lz[MEVP_VP_BLOCK];
            const size_t i0 = b * MEVP_VP_BLOCK;
            const size_t i1 = i0 + MEVP_VP_BLOCK < half2 ? i0 + MEVP_VP_BLOCK : half2;
            for (size_t i = i0; i < i1; i++) {
                size_t k0 = (size_t)act[2 * i], k1 = (size_t)act[2 * i + 1];
                lz[i - i0] = m->loose[k0] || m->loose[k1];
                if (lz[i - i0])
                    continue;
                sph_v2d z = sph_vp_stress_two(p, inv_e2, ld2(P->pres, k0, k1), ld2(P->e11, k0, k1),
                                              ld2(P->e22, k0, k1), ld2(P->e12, k0, k1), &t11[i - i0],
                                              &t22[i - i0], &t12[i - i0]);
                st2(m->zeta, k0, k1, z);
            }
            for (size_t i = i0; i < i1; i++) {
                size_t k0 = (size_t)act[2 * i], k1 = (size_t)act[2 * i + 1];
                if (lz[i - i0]) {
                    vp_relax_one(m, w, k0, dt, visc);
                    vp_relax_one(m, w, k1, dt, visc);
                } else {
                    relax_two(m, w, k0, k1, t11[i - i0], t22[i - i0], t12[i - i0], dt, visc);
                }
            }
        }
        if (na % 2)
            vp_relax_one(m, w, (size_t)act[na - 1], dt, visc);
        return;
    }
    m->rheo->stress(m, act, na, w->t11, w->t22, w->t12);
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(na))
    for (size_t i = 0; i < half; i++) {
        size_t k0 = (size_t)act[2 * i], k1 = (size_t)act[2 * i + 1];
        relax_two(m, w, k0, k1, ld2(w->t11, k0, k1), ld2(w->t22, k0, k1), ld2(w->t12, k0, k1), dt,
                  visc);
    }
    if (na % 2) {
        size_t k = (size_t)act[na - 1];
        relax_one(m, w, k, w->t11[k], w->t22[k], w->t12[k], dt, visc);
    }
}

/* Splits the active set into interior particles (owned, every neighbour
 * an owned live particle: their strain rates read no halo copy and no
 * coast ghost) and the rest (core/dd.h no_overlap). */
static void mevp_split(sph_model *m, mevp_work *w)
{
    const sph_nbr *nb = m->nb;
    const unsigned char *own = m->dd_owned;
    size_t n = m->P->n;
    w->ninner = w->nouter = 0;
    for (size_t i = 0; i < m->nactive; i++) {
        int k = m->active[i];
        int in = own[k];
        for (int q = 0; in && q < nb->count[k]; q++) {
            size_t j = (size_t)nb->idx[nb->off[k] + (size_t)q];
            in = j < n && own[j];
        }
        if (in)
            w->inner[w->ninner++] = k;
        else
            w->outer[w->nouter++] = k;
    }
}

/* The air stress over M of the active set (sph_momentum's tax / rho_h and
 * tay / rho_h: wind, drag factor and M do not change within a step). */
static void momentum_setup(sph_model *m, mevp_work *w)
{
    const sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    const double ca = m->cos_air, sna = m->sin_air;
    const size_t na = m->nactive;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(na))
    for (size_t i = 0; i < na; i++) {
        size_t k = (size_t)m->active[i];
        double rho_h = P->dens[k];
        double ua = P->ua[k], va = P->va[k];
        double sa = sqrt(ua * ua + va * va);
        double dA = sph_drag_factor(m, k);
        double tax = dA * p->rho_a * p->Ca * sa * (ua * ca - va * sna);
        double tay = dA * p->rho_a * p->Ca * sa * (ua * sna + va * ca);
        w->qax[k] = tax / rho_h;
        w->qay[k] = tay / rho_h;
    }
}

/* One iteration's velocity update of k0 and k1 in two lanes: lane l is
 * sph_momentum (model_impl.h) for its particle with the step's air stress
 * from momentum_setup, then the velocity change and the momentum residual,
 * each operation as the scalar code's, in its order (lanes.h). */
static inline void momentum_two(sph_model *m, mevp_work *w, size_t k0, size_t k1, double dt)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    const sph_v2d beta = p->evp_adaptive ? ld2(m->scratch, k0, k1) : splat2(p->evp_beta);
    const sph_v2d up = ld2(P->u, k0, k1), vp = ld2(P->v, k0, k1);
    const sph_v2d un = ld2(m->un, k0, k1), vn = ld2(m->vn, k0, k1);
    const sph_v2d rho_h = ld2(P->dens, k0, k1);
    const sph_v2d dA = p->drag_scaling == SPH_DRAG_CONCENTRATION ? ld2(P->conc, k0, k1) : splat2(1.0);
    const sph_v2d uw = ld2(P->uw, k0, k1), vw = ld2(P->vw, k0, k1);
    const sph_v2d dux = uw - up, duy = vw - vp;
    const sph_v2d c = dA * splat2(p->rho_w) * splat2(p->Cw) * sqrt2(dux * dux + duy * duy) / rho_h;
    const sph_v2d cw = splat2(m->cos_water), sw = splat2(m->sin_water), vdt = splat2(dt);
    const sph_v2d f = ld2(m->fcor, k0, k1), half = splat2(0.5), g = splat2(p->gravity);
    const sph_v2d rx = beta * up + un +
                       vdt * (ld2(P->ax, k0, k1) + ld2(w->qax, k0, k1) + c * (cw * uw - sw * vw) -
                              g * ld2(P->sshx, k0, k1) + half * f * vn);
    const sph_v2d ry = beta * vp + vn +
                       vdt * (ld2(P->ay, k0, k1) + ld2(w->qay, k0, k1) + c * (sw * uw + cw * vw) -
                              g * ld2(P->sshy, k0, k1) - half * f * un);
    const sph_v2d d11 = splat2(1.0) + beta + vdt * c * cw, d22 = d11;
    const sph_v2d d12 = -vdt * (c * sw + half * f), d21 = -d12;
    const sph_v2d det = d11 * d22 - d12 * d21;
    const sph_v2d u = (d22 * rx - d12 * ry) / det;
    const sph_v2d v = (d11 * ry - d21 * rx) / det;
    st2(m->dvel, k0, k1, fmax2(fabs2(u - up), fabs2(v - vp)));
    const sph_v2d bu = beta * (u - up), bv = beta * (v - vp);
    st2(w->res2, k0, k1, bu * bu + bv * bv);
    st2(P->u, k0, k1, u);
    st2(P->v, k0, k1, v);
}

#if defined(SPH_HAVE_LANES4)
/* momentum_two for the four particles k[0..3] in four lanes (lanes.h);
 * contig: k[l] = k[0] + l. */
SPH_LANES4_INLINE void momentum_four(sph_model *m, mevp_work *w, const size_t *k, int contig,
                                     double dt)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    const sph_v4d beta = p->evp_adaptive ? ld4(m->scratch, k, contig) : splat4(p->evp_beta);
    const sph_v4d up = ld4(P->u, k, contig), vp = ld4(P->v, k, contig);
    const sph_v4d un = ld4(m->un, k, contig), vn = ld4(m->vn, k, contig);
    const sph_v4d rho_h = ld4(P->dens, k, contig);
    const sph_v4d dA = p->drag_scaling == SPH_DRAG_CONCENTRATION ? ld4(P->conc, k, contig) : splat4(1.0);
    const sph_v4d uw = ld4(P->uw, k, contig), vw = ld4(P->vw, k, contig);
    const sph_v4d dux = uw - up, duy = vw - vp;
    const sph_v4d c = dA * splat4(p->rho_w) * splat4(p->Cw) * sqrt4(dux * dux + duy * duy) / rho_h;
    const sph_v4d cw = splat4(m->cos_water), sw = splat4(m->sin_water), vdt = splat4(dt);
    const sph_v4d f = ld4(m->fcor, k, contig), half = splat4(0.5), g = splat4(p->gravity);
    const sph_v4d rx = beta * up + un +
                       vdt * (ld4(P->ax, k, contig) + ld4(w->qax, k, contig) + c * (cw * uw - sw * vw) -
                              g * ld4(P->sshx, k, contig) + half * f * vn);
    const sph_v4d ry = beta * vp + vn +
                       vdt * (ld4(P->ay, k, contig) + ld4(w->qay, k, contig) + c * (sw * uw + cw * vw) -
                              g * ld4(P->sshy, k, contig) - half * f * un);
    const sph_v4d d11 = splat4(1.0) + beta + vdt * c * cw, d22 = d11;
    const sph_v4d d12 = -vdt * (c * sw + half * f), d21 = -d12;
    const sph_v4d det = d11 * d22 - d12 * d21;
    const sph_v4d u = (d22 * rx - d12 * ry) / det;
    const sph_v4d v = (d11 * ry - d21 * rx) / det;
    st4(m->dvel, k, contig, fmax4(fabs4(u - up), fabs4(v - vp)));
    const sph_v4d bu = beta * (u - up), bv = beta * (v - vp);
    st4(w->res2, k, contig, bu * bu + bv * bv);
    st4(P->u, k, contig, u);
    st4(P->v, k, contig, v);
}

/* The velocity update of the quads [i0, i1) of list in four lanes (its
 * own function with the target, as relax_vp4_block) */
SPH_LANES4_TARGET static void momentum_block4(sph_model *m, mevp_work *w, const int *act, size_t i0,
                                              size_t i1, double dt)
{
    for (size_t i = i0; i < i1; i++) {
        size_t k[4];
        quad_of(act, i, k);
        if (quad_contig(k))
            momentum_four(m, w, k, 1, dt);
        else
            momentum_four(m, w, k, 0, dt);
    }
}

/* ... of list entries [0, 4 (count / 4)), blocks of MEVP_VP_BLOCK4 quads */
static void momentum_pass4(sph_model *m, mevp_work *w, const int *act, size_t na, double dt)
{
    const size_t nq = na / 4;
    const size_t nblk = (nq + MEVP_VP_BLOCK4 - 1) / MEVP_VP_BLOCK4;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(na))
    for (size_t b = 0; b < nblk; b++) {
        const size_t i0 = b * MEVP_VP_BLOCK4;
        momentum_block4(m, w, act, i0, i0 + MEVP_VP_BLOCK4 < nq ? i0 + MEVP_VP_BLOCK4 : nq, dt);
    }
}
#endif

/* pending: a halo refresh is in flight (posted after the last iteration);
 * the interior particles' strain and stress are computed before it is
 * completed, then the boundary ones'. */
static mevp_sums mevp_iteration(sph_model *m, mevp_work *w, double dt, int pending, int full)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    const int *act = m->active;
    size_t na = m->nactive;
    if (pending) {
        sph_strain_pass(m, w->inner, w->ninner);
        mevp_relax(m, w, w->inner, w->ninner, dt);
        m->dd->exchange(m->dd->ctx, m, SPH_DD_ITER_WAIT);
        sph_ghost_velocity(m, P->u, P->v, 1);
        sph_strain_pass(m, w->outer, w->nouter);
        mevp_relax(m, w, w->outer, w->nouter, dt);
    } else {
        sph_ghost_velocity(m, P->u, P->v, 1);
        sph_strain_pass(m, act, na);
        mevp_relax(m, w, act, na, dt);
    }
    sph_ghost_stress_air(m, w->gair);
    sph_divergence_pass(m, act, na);
    /* velocity update, entries 2i and 2i + 1 of the active set in two
     * lanes (with four lanes: its quads first, the rest in pairs); the
     * max change is reduced serially afterwards */
    size_t done = 0;
#if defined(SPH_HAVE_LANES4)
    if (m->lanes4) {
        momentum_pass4(m, w, act, na, dt);
        done = na / 4 * 4;
    }
#endif
    const size_t half = (na - done) / 2; /* (na - done) % 2 == na % 2 */
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(na - done))
    for (size_t i = 0; i < half; i++)
        momentum_two(m, w, (size_t)act[done + 2 * i], (size_t)act[done + 2 * i + 1], dt);
    if (na % 2) {
        size_t k = (size_t)act[na - 1];
        double beta = p->evp_adaptive ? m->scratch[k] : p->evp_beta;
        double u, v;
        sph_momentum(m, k, beta, P->u[k], P->v[k], m->un[k], m->vn[k], dt, &u, &v);
        m->dvel[k] = sph_fmax(fabs(u - P->u[k]), fabs(v - P->v[k]));
        /* the momentum residual of the time-discrete equation at u':
         * (I + dt D) u' - rhs = -beta (u' - u) */
        double bu = beta * (u - P->u[k]), bv = beta * (v - P->v[k]);
        w->res2[k] = bu * bu + bv * bv;
        P->u[k] = u;
        P->v[k] = v;
    }
    /* the stress sums only for model.evp.change_tol, their only reader,
     * the residual's and the speeds' only with full (else mevp_rel_sums
     * where the solve needs them; each sum is its own chain: leaving some
     * out changes no other) */
    mevp_sums s = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    const int change = p->evp_change_tol > 0.0;
    if (!full) {
        for (size_t i = 0; i < na; i++) {
            double d = m->dvel[(size_t)act[i]];
            s.dmax = sph_fmax(s.dmax, d);
            s.s2 += d * d;
        }
        return s;
    }
    for (size_t i = 0; i < na; i++) {
        size_t k = (size_t)act[i];
        double d = m->dvel[k];
        s.dmax = sph_fmax(s.dmax, d);
        s.s2 += d * d;
        s.q2 += w->res2[k];
        s.u2 += P->u[k] * P->u[k] + P->v[k] * P->v[k];
        if (change) {
            s.ds2 += w->ds2[k];
            s.p2 += P->pres[k] * P->pres[k];
        }
    }
    return s;
}

/* mevp_iteration's sums of squared residuals and speeds for the state it
 * left (the same sums in the same order) */
static void mevp_rel_sums(const sph_model *m, const mevp_work *w, mevp_sums *s)
{
    const sph_particles *P = m->P;
    const int *act = m->active;
    s->q2 = s->u2 = 0.0;
    for (size_t i = 0; i < m->nactive; i++) {
        size_t k = (size_t)act[i];
        s->q2 += w->res2[k];
        s->u2 += P->u[k] * P->u[k] + P->v[k] * P->v[k];
    }
}

/* ---- Anderson acceleration (model.evp.anderson; Walker & Ni 2011, type
 * II): the sweep is a map x -> g(x) on x = (u, v, s11, s22, s12); with
 * f = g(x) - x and the differences dF, dG of the last mk residuals and
 * images, gamma minimises |f - dF gamma| and the next iterate is
 * g - dG gamma. Stresses are weighted by dt / (M h) (the velocity change
 * their divergence makes in a step) in the inner products. All sums run
 * serially in the active set's order. */

static double *aa_comp(double *base, size_t n, int c) { return base + (size_t)c * n; }

static void aa_save(const sph_model *m, mevp_work *w)
{
    const sph_particles *P = m->P;
    size_t n = w->nslot;
    const double *src[AA_NC] = {P->u, P->v, P->s11, P->s22, P->s12};
    for (int c = 0; c < AA_NC; c++) {
        double *x = aa_comp(w->x0, n, c);
        for (size_t i = 0; i < m->nactive; i++) {
            size_t k = (size_t)m->active[i];
            x[k] = src[c][k];
        }
    }
}

static double aa_weight(const sph_model *m, size_t k, int c, double dt)
{
    if (c < 2)
        return 1.0;
    double s = dt / (m->P->dens[k] * m->P->sml[k]);
    return s * s;
}

/* Solves the mk x mk system A g = b (A symmetric positive semi-definite,
 * regularised) by Gaussian elimination with partial pivoting; returns 0,
 * or -1 when singular. */
static int aa_solve(int mk, double A[][16], double *b, double *g)
{
    for (int c = 0; c < mk; c++) {
        int piv = c;
        for (int r = c + 1; r < mk; r++)
            if (fabs(A[r][c]) > fabs(A[piv][c]))
                piv = r;
        if (!(fabs(A[piv][c]) > 0.0))
            return -1;
        if (piv != c) {
            for (int j = 0; j < mk; j++) {
                double t = A[c][j];
                A[c][j] = A[piv][j];
                A[piv][j] = t;
            }
            double t = b[c];
            b[c] = b[piv];
            b[piv] = t;
        }
        for (int r = c + 1; r < mk; r++) {
            double f = A[r][c] / A[c][c];
            for (int j = c; j < mk; j++)
                A[r][j] -= f * A[c][j];
            b[r] -= f * b[c];
        }
    }
    for (int r = mk - 1; r >= 0; r--) {
        double s = b[r];
        for (int j = r + 1; j < mk; j++)
            s -= A[r][j] * g[j];
        g[r] = s / A[r][r];
    }
    return 0;
}

/* After sweep it (0-based) of a step: records f and g, and replaces the
 * state by the Anderson mix of the last min(depth, it) differences. */
static void aa_mix(sph_model *m, mevp_work *w, int it, double dt)
{
    sph_particles *P = m->P;
    size_t n = w->nslot, na = m->nactive;
    const int *act = m->active;
    double *cur[AA_NC] = {P->u, P->v, P->s11, P->s22, P->s12};
    int d = w->depth;
    int col = (it - 1 + d) % d; /* ring slot of the difference this sweep makes */
    if (it > 0) {
        for (int c = 0; c < AA_NC; c++) {
            double *x = aa_comp(w->x0, n, c), *fp = aa_comp(w->fprev, n, c), *gp = aa_comp(w->gprev, n, c);
            double *df = aa_comp(w->dF + (size_t)col * AA_NC * n, n, c);
            double *dg = aa_comp(w->dG + (size_t)col * AA_NC * n, n, c);
            for (size_t i = 0; i < na; i++) {
                size_t k = (size_t)act[i];
                double g = cur[c][k], f = g - x[k];
                df[k] = f - fp[k];
                dg[k] = g - gp[k];
            }
        }
    }
    for (int c = 0; c < AA_NC; c++) {
        double *x = aa_comp(w->x0, n, c), *fp = aa_comp(w->fprev, n, c), *gp = aa_comp(w->gprev, n, c);
        for (size_t i = 0; i < na; i++) {
            size_t k = (size_t)act[i];
            gp[k] = cur[c][k];
            fp[k] = cur[c][k] - x[k];
        }
    }
    int mk = it < d ? it : d;
    if (mk == 0)
        return;
    double A[16][16], b[16], g[16];
    for (int a = 0; a < mk; a++) {
        b[a] = 0.0;
        for (int e = 0; e <= a; e++)
            A[a][e] = 0.0;
    }
    for (size_t i = 0; i < na; i++) {
        size_t k = (size_t)act[i];
        for (int c = 0; c < AA_NC; c++) {
            double wt = aa_weight(m, k, c, dt), f = aa_comp(w->fprev, n, c)[k];
            for (int a = 0; a < mk; a++) {
                double fa = aa_comp(w->dF + (size_t)a * AA_NC * n, n, c)[k] * wt;
                b[a] += fa * f;
                for (int e = 0; e <= a; e++)
                    A[a][e] += fa * aa_comp(w->dF + (size_t)e * AA_NC * n, n, c)[k];
            }
        }
    }
    double tr = 0.0;
    for (int a = 0; a < mk; a++) {
        for (int e = 0; e < a; e++)
            A[e][a] = A[a][e];
        tr += A[a][a];
    }
    if (!(tr > 0.0))
        return;
    for (int a = 0; a < mk; a++)
        A[a][a] += 1e-10 * tr / mk;
    if (aa_solve(mk, A, b, g) != 0)
        return;
    for (int c = 0; c < AA_NC; c++)
        for (size_t i = 0; i < na; i++) {
            size_t k = (size_t)act[i];
            double v = cur[c][k];
            for (int a = 0; a < mk; a++)
                v -= g[a] * aa_comp(w->dG + (size_t)a * AA_NC * n, n, c)[k];
            cur[c][k] = v;
        }
}

static int mevp_solve_iterations(sph_model *m, mevp_work *w, sph_status *st);

/* The iterations with the divergence's 1 / M^2 per slot computed once
 * (sph_model.div_imd2: M is constant within the solve; its first
 * divergence pass fills it, after the first ghost stresses) and the
 * strain pass's 1 / M_k once (sph_model.strain_im). */
static int mevp_solve(sph_model *m, void *ws, sph_status *st)
{
    mevp_work *w = ws;
    const sph_particles *P = m->P;
    const size_t na = m->nactive;
    m->div_imd2 = w->imd2;
    m->div_imd2_ready = 0;
    /* the strain pass's 1 / M_k for the active set (every list it is
     * given in the solve is part of it), the pass's own division */
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(na))
    for (size_t i = 0; i < na; i++) {
        size_t k = (size_t)m->active[i];
        w->im[k] = 1.0 / P->dens[k];
    }
    m->strain_im = w->im;
    m->pass_pairs_on = 1; /* the lists' pair counts once per solve */
    m->pass_pairs_n = 0;
    m->pk_mass_ready = 0;
    int rc = mevp_solve_iterations(m, w, st);
    m->div_imd2 = NULL;
    m->div_imd2_ready = 0;
    m->strain_im = NULL;
    m->pass_pairs_on = 0;
    m->pass_pairs_n = 0;
    m->pk_mass_ready = 0;
    return rc;
}

static int mevp_solve_iterations(sph_model *m, mevp_work *w, sph_status *st)
{
    const sph_params *p = &m->prm;
    double dt = p->dt;
    size_t na = m->nactive;
    int it;
    double resid = 0.0, rel = 0.0;
    /* auto: stall detection on the RMS velocity change (the maximum is
     * dominated by single particles and is no measure of progress): no new
     * minimum in win iterations */
    const int win = p->physics == SPH_PHYSICS_AUTO ? p->evp_stall_window : 0;
    const int aa = w->depth > 0 && p->evp_anderson > 0;
    /* Anderson's mixing and change_tol's stress sums are neither reduced
     * over the ranks nor followed by a halo refresh (core/dd.h) */
    if (m->canonical && (p->evp_anderson > 0 || p->evp_change_tol > 0.0))
        return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_PARAMETER, -1,
                              "model.evp.anderson or model.evp.change_tol",
                              p->evp_anderson > 0 ? (double)p->evp_anderson : p->evp_change_tol, 0.0,
                              "is not supported in the canonical (domain-decomposed) mode; refused");
    double rms_ref = 0.0;
    int it_ref = 0;
    m->stats.stalled = 0;
    /* under a decomposition: the refresh completed inside the next
     * iteration, after the interior particles' work (core/dd.h) */
    const int overlap = m->dd && !m->dd->no_overlap;
    int pending = 0;
    if (overlap)
        mevp_split(m, w);
    momentum_setup(m, w);
    sph_ghost_air_setup(m, w->gair);
    for (it = 0; it < p->evp_iterations; it++) {
        if (aa)
            aa_save(m, w);
        /* the residual's sums where a rule reads them, or for the
         * statistics of the last iteration (mevp_rel_sums at a break) */
        const int full = p->evp_rel_tol > 0.0 || p->evp_change_tol > 0.0 || m->dd ||
                         it + 1 == p->evp_iterations;
        mevp_sums s = mevp_iteration(m, w, dt, pending, full);
        pending = 0;
        double nna = (double)na;
        if (m->dd)
            m->dd->exchange(m->dd->ctx, m, SPH_DD_ITER_POST);
        if (m->canonical) /* owned particles, exact, over the ranks (core/dd.h) */
            sph_dd_mevp_norms(m, m->active, na, w->res2, &s.dmax, &s.s2, &s.q2, &s.u2, &nna);
        if (overlap)
            pending = 1;
        else if (m->dd)
            m->dd->exchange(m->dd->ctx, m, SPH_DD_ITER_WAIT);
        /* decomposed, every rank iterates (the exchange is collective):
         * with no active particle on any rank the step is the serial
         * one's, which skips the solver (iterations 0) */
        if (m->canonical && nna == 0.0) {
            it = 0;
            break;
        }
        double r = s.dmax;
        resid = r;
        /* without them, the sums where the iteration stops below (the
         * tolerance or the stall rule), the state unchanged since (no
         * decomposition, no exchange: full otherwise) */
        if (!full && (r < p->evp_tol ||
                      (win > 0 && !(it == 0 || sqrt(s.s2 / nna) < rms_ref) && it - it_ref >= win)))
            mevp_rel_sums(m, w, &s);
        /* relative to the RMS speed, floored at SPH_MEVP_SPEED_FLOOR (ice
         * at rest has no scale of its own) */
        double urms = sqrt(s.u2 / nna);
        rel = sqrt(s.q2 / nna) / fmax(urms, SPH_MEVP_SPEED_FLOOR);
        if (!isfinite(r)) {
            if (pending)
                m->dd->exchange(m->dd->ctx, m, SPH_DD_ITER_WAIT);
            return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_NONFINITE, -1, "mEVP residual", r, 0.0,
                                  "is not finite (the stress iteration diverged)");
        }
        if (r < p->evp_tol || (p->evp_rel_tol > 0.0 && rel < p->evp_rel_tol)) {
            it++;
            break;
        }
        /* model.evp.change_tol: the iteration's relative change, RMS
         * velocity change over RMS speed and RMS stress change over RMS
         * strength, both below the tolerance (at least two iterations) */
        if (p->evp_change_tol > 0.0 && it > 0 &&
            sqrt(s.s2 / nna) < p->evp_change_tol * fmax(urms, SPH_MEVP_SPEED_FLOOR) &&
            !(sqrt(s.ds2) >= p->evp_change_tol * sqrt(s.p2))) {
            it++;
            break;
        }
        if (win > 0) {
            double rms = sqrt(s.s2 / nna);
            if (it == 0 || rms < rms_ref) {
                rms_ref = rms;
                it_ref = it;
            } else if (it - it_ref >= win) {
                m->stats.stalled = 1;
                it++;
                break;
            }
        }
        if (aa && it + 1 < p->evp_iterations)
            aa_mix(m, w, it, dt);
    }
    if (pending) /* the halo current after the solver, as without the overlap */
        m->dd->exchange(m->dd->ctx, m, SPH_DD_ITER_WAIT);
    m->stats.iterations = it;
    m->stats.residual = resid;
    m->stats.rel_residual = rel;
    m->stats.unconverged = p->evp_rel_tol > 0.0 && !(rel < p->evp_rel_tol) && !(resid < p->evp_tol);
    return SPH_STEP_OK;
}

/* fixed parameters: 60 s below 2 km spacing, else 300 s; adaptive:
 * dt / spacing at most 0.2 s/m */
static double mevp_stable_dt(const sph_params *p, double spacing, const char **why)
{
    if (!p->evp_adaptive) {
        *why = "is outside the measured stable region of fixed-parameter mEVP "
               "(blow-up or clumping measured beyond it); refused";
        return spacing < 2000.0 ? SPH_MEVP_FIXED_DT_FINE : SPH_MEVP_FIXED_DT_MAX;
    }
    *why = "is outside the measured stable region of adaptive EVP "
           "(dt / spacing above 0.2 s/m; stable at 0.06-0.15, blow-up measured at 0.3 on "
           "an earlier core); refused";
    return SPH_AEVP_DT_PER_M * spacing;
}

const sph_solver_ops sph_solver_mevp = {
    .name = "mevp", .create = mevp_create, .free = mevp_free, .solve = mevp_solve,
    .stable_dt = mevp_stable_dt,
};
