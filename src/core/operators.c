/* The SPH passes over the particle arrays: ordering, density, diagnosis,
 * the active set, strain rates, stress divergence, kernel gradient
 * correction, free drift, continuity, smoothing length, and interpolation
 * to arbitrary points. Each pass runs over a list of particles (NULL: all
 * live particles), threaded where that pays. */
#include "model_impl.h"

#include <math.h>

#include "core/kernel.h"
#include "core/neighbours.h"
#include "core/rheology.h"
#include "lanes.h"

/* ------------------------------------------------------------------ */
/* SPH passes                                                          */

double sph_max_sml(const sph_particles *P, size_t n)
{
    double hmax = 0.0;
    for (size_t k = 0; k < n; k++)
        hmax = fmax(hmax, P->sml[k]);
    return hmax;
}

/* Reorders live particles by cell so that neighbours are close in memory. */
void sph_reorder(sph_model *m)
{
    sph_particles *P = m->P;
    size_t n = P->n;
    if (n < 2)
        return;
    double cell = m->kern.radius * sph_max_sml(P, n);
    sph_nbr_grid(m->nb, n, P->x, P->y, cell);
    int ident = 1;
    for (size_t i = 0; i < n; i++) {
        m->order[i] = m->nb->sorted[i];
        ident &= m->order[i] == (int)i;
    }
    if (!ident)
        sph_particles_permute(P, m->order, m->scratch);
}

void sph_density_pass(sph_model *m)
{
    sph_particles *P = m->P;
    const sph_nbr *nb = m->nb;
    size_t n = P->n;
    double scale = m->dens_scale;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++) {
        const size_t base = nb->off[k];
        double s = 0.0;
        for (int q = 0; q < nb->count[k]; q++)
            s += P->mass[nb->idx[base + q]] * nb->w[base + q];
        P->dens[k] = scale * s;
    }
    /* merged coast ghosts count the mass of the reflections they stand for
     * (model_impl.h ghost_mass), not their volume-carrying P->mass */
    if (m->ghosts_thinned == 0)
        return;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++) {
        const size_t base = nb->off[k];
        double s = 0.0;
        int any = 0;
        for (int q = 0; q < nb->count[k]; q++) {
            size_t j = (size_t)nb->idx[base + q];
            if (j >= n && m->ghost_mass[j - n] != P->mass[j]) {
                any = 1;
                break;
            }
        }
        if (!any)
            continue;
        for (int q = 0; q < nb->count[k]; q++) {
            size_t j = (size_t)nb->idx[base + q];
            s += (j < n ? P->mass[j] : m->ghost_mass[j - n]) * nb->w[base + q];
        }
        P->dens[k] = scale * s;
    }
}

/* Concentration, ridging, strength, and the auto regime's loose flags. */
void sph_diagnose_pass(sph_model *m)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    size_t n = P->n;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++) {
        double factor = sph_diagnose_one(P, p, k, &P->conc[k], &P->pres[k]);
        m->loose[k] = p->physics == SPH_PHYSICS_FREE_DRIFT ||
                      (p->physics == SPH_PHYSICS_AUTO && factor < p->auto_tolerance);
    }
}

/* Active set: particles that are packed or have a packed neighbour. */
void sph_select_active(sph_model *m)
{
    sph_particles *P = m->P;
    const sph_nbr *nb = m->nb;
    size_t n = P->n, na = 0;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++) {
        int act = 0;
        if (m->prm.physics != SPH_PHYSICS_FREE_DRIFT) {
            const size_t base = nb->off[k];
            for (int q = 0; q < nb->count[k] && !act; q++) {
                int j = nb->idx[base + q];
                size_t src = (size_t)j < n ? (size_t)j : (size_t)m->ghost_src[(size_t)j - n];
                act = !m->loose[src];
            }
        }
        P->regime[k] &= (unsigned char)~(SPH_REGIME_FREE_DRIFT | SPH_REGIME_RHEOLOGY);
        P->regime[k] |= act ? SPH_REGIME_RHEOLOGY : SPH_REGIME_FREE_DRIFT;
    }
    for (size_t k = 0; k < n; k++) /* serial: the list in particle order */
        if (P->regime[k] & SPH_REGIME_RHEOLOGY)
            m->active[na++] = (int)k;
    m->nactive = na;
}

/* Two particles' sums side by side (GNU C vector extension: two doubles,
 * SSE2 on x86-64, NEON on AArch64; no wider target assumed). A pair sum
 * over neighbours is a reduction in list order; vectorising it along the
 * list would reorder it (and change the last bits). Across particles it
 * does not: lane 0 adds particle k0's pairs in k0's list order, lane 1
 * those of k1, with the scalar code's operations in the scalar code's
 * order (IEEE operations are exact per lane; no contraction under
 * -std=c11). The common part of the two lists runs in the lanes, each
 * longer list's rest in scalar code, so every particle's result is bit
 * for bit the scalar pass's. */
/* (sph_v2d, ld2: lanes.h) */

/* Strain rates (seed eq. 15, sign settled by the linear-field test) and
 * the fluctuating velocity for the collision rheology, for the listed
 * particles (list NULL: all live particles). gc (gradient correction)
 * and fluct (the collision rheology's v') are constants in each
 * instantiation, so the plain pair loop carries no branch; the operations
 * and their order are those of a single loop testing the flags per pair.
 * acc: a11, a22, a12, a21, fl, wsum; strain_sum adds pairs [q0, count). */
static inline __attribute__((always_inline)) void strain_sum(const sph_model *m, size_t k, int gc,
                                                            int fluct, int ff, int q0, double *acc)
{
    const sph_particles *P = m->P;
    const sph_nbr *nb = m->nb;
    const double *restrict u = P->u, *restrict v = P->v, *restrict mass = P->mass;
    const double *restrict gxs = nb->gx, *restrict gys = nb->gy, *restrict xy = nb->xy;
    const int *restrict idx = nb->idx;
    const size_t base = nb->off[k];
    const int cnt = nb->count[k];
    const double uk = u[k], vk = v[k];
    const double xk = ff ? xy[2 * k] : 0.0, yk = ff ? xy[2 * k + 1] : 0.0;
    double a11 = acc[0], a22 = acc[1], a12 = acc[2], a21 = acc[3], fl = acc[4], wsum = acc[5];
    for (int q = q0; q < cnt; q++) {
        size_t s = base + (size_t)q;
        int j = idx[s];
        double du = u[j] - uk, dv = v[j] - vk;
        double gx, gy;
        if (ff) { /* sph_nbr_grad's factor form */
            gx = gxs[s] * (xk - xy[2 * (size_t)j]);
            gy = gxs[s] * (yk - xy[2 * (size_t)j + 1]);
        } else {
            gx = gxs[s];
            gy = gys[s];
        }
        double mj = mass[j];
        a11 += mj * du * gx;
        a22 += mj * dv * gy;
        if (gc) { /* the two off-diagonal gradients apart */
            a12 += mj * dv * gx;
            a21 += mj * du * gy;
        } else {
            a12 += mj * (dv * gx + du * gy);
        }
        if (fluct) {
            double wj = mj / P->dens[j] * nb->w[s];
            fl += wj * (du * du + dv * dv);
            wsum += wj;
        }
    }
    acc[0] = a11;
    acc[1] = a22;
    acc[2] = a12;
    acc[3] = a21;
    acc[4] = fl;
    acc[5] = wsum;
}

static inline __attribute__((always_inline)) void strain_finish(sph_model *m, size_t k, int gc,
                                                               int fluct, const double *acc)
{
    sph_particles *P = m->P;
    double a11 = acc[0], a22 = acc[1], a12 = acc[2], a21 = acc[3];
    /* within a stress solve 1 / M_k once per solve (m->strain_im) */
    double iM = m->strain_im ? m->strain_im[k] : 1.0 / P->dens[k];
    if (gc) {
        /* velocity gradient G_ab = sum_j m_j dv_a g_b / M_k, i.e.
         * [[a11, a21], [a12, a22]]; corrected: G B_k^-1 */
        const double *bi = m->binv + 6 * k;
        double g11 = a11 * bi[0] + a21 * bi[1], g12 = a11 * bi[1] + a21 * bi[2];
        double g21 = a12 * bi[0] + a22 * bi[1], g22 = a12 * bi[1] + a22 * bi[2];
        a11 = g11;
        a22 = g22;
        a12 = g12 + g21;
    }
    P->e11[k] = a11 * iM;
    P->e22[k] = a22 * iM;
    P->e12[k] = 0.5 * a12 * iM;
    if (fluct) {
        double vf = acc[5] > 0 ? sqrt(acc[4] / acc[5]) : 0.0;
        m->vfluct[k] = fmax(vf, m->prm.coll_vfluct_min);
    }
}

static inline __attribute__((always_inline)) void strain_one(sph_model *m, size_t k, int gc,
                                                            int fluct, int ff)
{
    double acc[6] = {0, 0, 0, 0, 0, 0};
    strain_sum(m, k, gc, fluct, ff, 0, acc);
    strain_finish(m, k, gc, fluct, acc);
}

/* The gradients of slots s0 and s1 (neighbours j0, j1 of the lanes'
 * particles at xk, yk) in two lanes, as sph_nbr_grad: the stored
 * components, or with ff (the factor form, a constant in each
 * instantiation) F * dx and F * dy, the build's operations, each
 * neighbour's position one 16-byte load from the interleaved nb->xy. */
static inline __attribute__((always_inline)) void pair_grad2(const sph_nbr *nb, int ff, size_t s0,
                                                            size_t s1, size_t j0, size_t j1,
                                                            sph_v2d xk, sph_v2d yk, sph_v2d *gx,
                                                            sph_v2d *gy)
{
    const double *restrict gxs = nb->gx;
    if (ff) {
        const double *restrict xy = nb->xy;
        const sph_v2d p0 = *(const sph_v2d *)(const void *)(xy + 2 * j0),
                      p1 = *(const sph_v2d *)(const void *)(xy + 2 * j1);
        const sph_v2d F = ld2(gxs, s0, s1);
        *gx = F * (xk - (sph_v2d){p0[0], p1[0]});
        *gy = F * (yk - (sph_v2d){p0[1], p1[1]});
    } else {
        *gx = ld2(gxs, s0, s1);
        *gy = ld2(nb->gy, s0, s1);
    }
}

/* The strain rates of k0 and k1 in two lanes (no v'; gc: the gradient
 * correction, a constant in each instantiation). */
static inline __attribute__((always_inline)) void strain_two(sph_model *m, size_t k0, size_t k1,
                                                            int gc, int packed, int ff)
{
    const sph_particles *P = m->P;
    const sph_nbr *nb = m->nb;
    const double *restrict u = P->u, *restrict v = P->v, *restrict mass = P->mass;
    const double *restrict pk = nb->pk;
    const int *restrict idx = nb->idx;
    const size_t b0 = nb->off[k0], b1 = nb->off[k1];
    const int c0 = nb->count[k0], c1 = nb->count[k1], cm = c0 < c1 ? c0 : c1;
    const sph_v2d uk = ld2(u, k0, k1), vk = ld2(v, k0, k1);
    const sph_v2d xk = ff ? ld2(nb->xy, 2 * k0, 2 * k1) : splat2(0.0),
                  yk = ff ? ld2(nb->xy, 2 * k0 + 1, 2 * k1 + 1) : splat2(0.0);
    sph_v2d a11 = {0, 0}, a22 = {0, 0}, a12 = {0, 0}, a21 = {0, 0};
    for (int q = 0; q < cm; q++) {
        size_t s0 = b0 + (size_t)q, s1 = b1 + (size_t)q;
        size_t j0 = (size_t)idx[s0], j1 = (size_t)idx[s1];
        sph_v2d du, dv, mj;
        if (packed) { /* pack_velocity_slot's records: (u, v) in one 16-byte load */
            const sph_v2d *r0 = (const sph_v2d *)(const void *)(pk + 4 * j0),
                          *r1 = (const sph_v2d *)(const void *)(pk + 4 * j1);
            const sph_v2d a0 = r0[0], a1 = r1[0];
            du = (sph_v2d){a0[0], a1[0]} - uk;
            dv = (sph_v2d){a0[1], a1[1]} - vk;
            mj = (sph_v2d){pk[4 * j0 + 3], pk[4 * j1 + 3]};
        } else {
            du = ld2(u, j0, j1) - uk;
            dv = ld2(v, j0, j1) - vk;
            mj = ld2(mass, j0, j1);
        }
        sph_v2d gx, gy;
        pair_grad2(nb, ff, s0, s1, j0, j1, xk, yk, &gx, &gy);
        a11 += mj * du * gx;
        a22 += mj * dv * gy;
        if (gc) {
            a12 += mj * dv * gx;
            a21 += mj * du * gy;
        } else {
            a12 += mj * (dv * gx + du * gy);
        }
    }
    double acc0[6] = {a11[0], a22[0], a12[0], a21[0], 0, 0};
    double acc1[6] = {a11[1], a22[1], a12[1], a21[1], 0, 0};
    strain_sum(m, k0, gc, 0, ff, cm, acc0);
    strain_sum(m, k1, gc, 0, ff, cm, acc1);
    strain_finish(m, k0, gc, 0, acc0);
    strain_finish(m, k1, gc, 0, acc1);
}

/* The strain pass's per-slot record in nb->pk (u, v, -, m_j; the
 * divergence fills its own afterwards, m_j in the same place): the pair
 * loop gathers one record per neighbour instead of three arrays (the same
 * values, bit for bit). wmass 0: m_j is already there (within a solve,
 * after its first packing: sph_model.pk_mass_ready). */
static inline void pack_velocity_slot(const sph_particles *P, double *pk, size_t j, int wmass)
{
    pk[0] = P->u[j];
    pk[1] = P->v[j];
    if (wmass)
        pk[3] = P->mass[j];
}

#define SPH_LIST_K(i) (list ? (size_t)list[(i)] : (size_t)(i))
/* the factor form (sph_nbr_grad) as a constant of each instantiation */
#define SPH_FF(CALL, ...) (ff ? CALL(__VA_ARGS__, 1) : CALL(__VA_ARGS__, 0))

/* The pairs the passes visit for list (the sum of the neighbour counts),
 * within a solve (m->pass_pairs_on) summed once per list. */
static size_t list_pairs(sph_model *m, const int *list, size_t count)
{
    const sph_nbr *nb = m->nb;
    if (m->pass_pairs_on)
        for (int e = 0; e < m->pass_pairs_n; e++)
            if (m->pass_pairs_list[e] == list && m->pass_pairs_count[e] == count)
                return m->pass_pairs_sum[e];
    size_t pairs = 0;
    for (size_t i = 0; i < count; i++)
        pairs += (size_t)nb->count[SPH_LIST_K(i)];
    if (m->pass_pairs_on && m->pass_pairs_n < 3) {
        m->pass_pairs_list[m->pass_pairs_n] = list;
        m->pass_pairs_count[m->pass_pairs_n] = count;
        m->pass_pairs_sum[m->pass_pairs_n++] = pairs;
    }
    return pairs;
}
#define SPH_STRAIN_LOOP(GC, FL)                                                                \
    _Pragma("omp parallel for schedule(static) if (SPH_OMP_WORTH(count))")                  \
    for (size_t i = 0; i < count; i++)                                                         \
        SPH_FF(strain_one, m, SPH_LIST_K(i), GC, FL)

void sph_strain_pass(sph_model *m, const int *list, size_t count)
{
    int want_fluct = (m->rheo->fields & SPH_RHEO_FIELD_VFLUCT) != 0;
    const int gc = m->prm.gradient_correction != 0, ff = m->nb->factor;
    if (!want_fluct) {
        /* list entries 2i and 2i + 1 in two lanes; where the lists visit
         * more pairs than there are slots, through per-slot records */
        const sph_nbr *nb = m->nb;
        const size_t nall = m->P->n + m->ng, half = count / 2;
        const size_t pairs = list_pairs(m, list, count);
        const int packed = pairs > nall && nb->pk;
        const int wmass = !m->pk_mass_ready;
#pragma omp parallel if (SPH_OMP_WORTH(count))
        {
            if (packed) {
#pragma omp for schedule(static)
                for (size_t j = 0; j < nall; j++)
                    pack_velocity_slot(m->P, nb->pk + 4 * j, j, wmass);
            }
            if (gc && packed) {
#pragma omp for schedule(static)
                for (size_t i = 0; i < half; i++)
                    SPH_FF(strain_two, m, SPH_LIST_K(2 * i), SPH_LIST_K(2 * i + 1), 1, 1);
            } else if (gc) {
#pragma omp for schedule(static)
                for (size_t i = 0; i < half; i++)
                    SPH_FF(strain_two, m, SPH_LIST_K(2 * i), SPH_LIST_K(2 * i + 1), 1, 0);
            } else if (packed) {
#pragma omp for schedule(static)
                for (size_t i = 0; i < half; i++)
                    SPH_FF(strain_two, m, SPH_LIST_K(2 * i), SPH_LIST_K(2 * i + 1), 0, 1);
            } else {
#pragma omp for schedule(static)
                for (size_t i = 0; i < half; i++)
                    SPH_FF(strain_two, m, SPH_LIST_K(2 * i), SPH_LIST_K(2 * i + 1), 0, 0);
            }
        }
        if (packed && m->pass_pairs_on)
            m->pk_mass_ready = 1; /* m_j stays in the records for the solve */
        if (count % 2)
            SPH_FF(strain_one, m, SPH_LIST_K(count - 1), gc, 0);
    } else if (gc) {
        SPH_STRAIN_LOOP(1, 1);
    } else {
        SPH_STRAIN_LOOP(0, 1);
    }
}
#undef SPH_STRAIN_LOOP

/* The coast ghosts' part of particle k's velocity divergence (the strain
 * pass's sum restricted to ghost neighbours). */
static double coast_divergence(const sph_model *m, size_t k)
{
    const sph_particles *P = m->P;
    const sph_nbr *nb = m->nb;
    const size_t base = nb->off[k], n = P->n;
    /* without the correction B^-1 is the identity, which m->binv holds only
     * where a reader needs it (model.c prepare_lists): the same values */
    static const double ident[3] = {1.0, 0.0, 1.0};
    const double *bi = m->prm.gradient_correction ? m->binv + 6 * k : ident;
    double a = 0.0;
    for (int q = 0; q < nb->count[k]; q++) {
        size_t s = base + (size_t)q;
        size_t j = (size_t)nb->idx[s];
        if (j < n)
            continue;
        double g0x, g0y;
        sph_nbr_grad(nb, k, j, s, &g0x, &g0y);
        double gx = bi[0] * g0x + bi[1] * g0y, gy = bi[1] * g0x + bi[2] * g0y;
        a += P->mass[j] * ((P->u[j] - P->u[k]) * gx + (P->v[j] - P->v[k]) * gy);
    }
    return a / P->dens[k];
}

/* Symmetric stress divergence (seed eq. 13): a_k = [div(hbar sigma)/M]_k,
 * a_k = sum_j m_j (S_j / M_j^2 + S_k / M_k^2) grad_k W_kj.
 *
 * S_j / M_j^2 is a property of particle j, not of the pair: where the
 * lists visit more pairs than there are slots (live particles and ghosts)
 * it is computed once per slot into nb->pk (t11, t22, t12, m_j: one
 * 32-byte record, one cache line per gathered neighbour) and the pair loop
 * reads it, instead of a division and four products per pair. The values
 * are the same operations on the same operands (bit for bit), and each
 * particle's sum runs over its list in the list's order either way. */
static inline void pack_stress_slot(const sph_particles *P, double *pk, size_t j, double iMj2,
                                    int wmass)
{
    pk[0] = P->s11[j] * iMj2;
    pk[1] = P->s22[j] * iMj2;
    pk[2] = P->s12[j] * iMj2;
    if (wmass) /* else already there (pack_velocity_slot) */
        pk[3] = P->mass[j];
}

/* One particle's divergence from the packed records, pairs [q0, count)
 * added to acc (ax, ay); gc: the kernel gradient correction (a constant
 * in each instantiation, so the plain pair loop carries no branch). */
static inline __attribute__((always_inline)) void divergence_sum(const sph_model *m, size_t k,
                                                                int gc, int q0, double *acc, int ff)
{
    const sph_nbr *nb = m->nb;
    const double *restrict pk = nb->pk;
    const double *restrict gxs = nb->gx, *restrict gys = nb->gy, *restrict xy = nb->xy;
    const int *restrict idx = nb->idx;
    const size_t base = nb->off[k];
    const int cnt = nb->count[k];
    const double tk11 = pk[4 * k], tk22 = pk[4 * k + 1], tk12 = pk[4 * k + 2];
    const double xk = ff ? xy[2 * k] : 0.0, yk = ff ? xy[2 * k + 1] : 0.0;
    const double *bk = m->binv + 6 * k + 3;
    double ax = acc[0], ay = acc[1];
    for (int q = q0; q < cnt; q++) {
        size_t s = base + (size_t)q;
        const double *r = pk + 4 * (size_t)idx[s];
        double t11 = r[0] + tk11, t22 = r[1] + tk22, t12 = r[2] + tk12;
        double gx, gy;
        if (ff) { /* sph_nbr_grad's factor form */
            const size_t j = (size_t)idx[s];
            gx = gxs[s] * (xk - xy[2 * j]);
            gy = gxs[s] * (yk - xy[2 * j + 1]);
        } else {
            gx = gxs[s];
            gy = gys[s];
        }
        if (gc) { /* (B_k^-1 + B_j^-1)/2 grad W: still antisymmetric in k, j */
            const double *bj = m->binv + 6 * (size_t)idx[s] + 3;
            double cx = 0.5 * ((bk[0] + bj[0]) * gx + (bk[1] + bj[1]) * gy);
            gy = 0.5 * ((bk[1] + bj[1]) * gx + (bk[2] + bj[2]) * gy);
            gx = cx;
        }
        ax += r[3] * (t11 * gx + t12 * gy);
        ay += r[3] * (t12 * gx + t22 * gy);
    }
    acc[0] = ax;
    acc[1] = ay;
}

static inline __attribute__((always_inline)) void divergence_packed(const sph_model *m, size_t k,
                                                                   int gc, int ff)
{
    double acc[2] = {0, 0};
    divergence_sum(m, k, gc, 0, acc, ff);
    m->P->ax[k] = acc[0];
    m->P->ay[k] = acc[1];
}

/* The divergence of k0 and k1 in two lanes (see ld2: each lane is its
 * particle's scalar sum, in its list's order); gc as in divergence_sum. */
static inline __attribute__((always_inline)) void divergence_two(const sph_model *m, size_t k0,
                                                                size_t k1, int gc, int ff)
{
    const sph_nbr *nb = m->nb;
    const double *restrict pk = nb->pk;
    const double *restrict bi = m->binv;
    const int *restrict idx = nb->idx;
    const size_t b0 = nb->off[k0], b1 = nb->off[k1];
    const int c0 = nb->count[k0], c1 = nb->count[k1], cm = c0 < c1 ? c0 : c1;
    const sph_v2d tk11 = ld2(pk, 4 * k0, 4 * k1), tk22 = ld2(pk, 4 * k0 + 1, 4 * k1 + 1),
                  tk12 = ld2(pk, 4 * k0 + 2, 4 * k1 + 2);
    const sph_v2d xk = ff ? ld2(nb->xy, 2 * k0, 2 * k1) : splat2(0.0),
                  yk = ff ? ld2(nb->xy, 2 * k0 + 1, 2 * k1 + 1) : splat2(0.0);
    const size_t o0 = 6 * k0 + 3, o1 = 6 * k1 + 3;
    const sph_v2d bk0 = ld2(bi, o0, o1), bk1 = ld2(bi, o0 + 1, o1 + 1), bk2 = ld2(bi, o0 + 2, o1 + 2);
    sph_v2d ax = {0, 0}, ay = {0, 0};
    for (int q = 0; q < cm; q++) {
        size_t s0 = b0 + (size_t)q, s1 = b1 + (size_t)q;
        size_t j0 = (size_t)idx[s0], j1 = (size_t)idx[s1];
        /* each record as two 16-byte loads (pk is 32-byte aligned), the
         * lanes' values paired by unpacking: half the loads of one per value */
        const sph_v2d *r0 = (const sph_v2d *)(const void *)(pk + 4 * j0),
                      *r1 = (const sph_v2d *)(const void *)(pk + 4 * j1);
        const sph_v2d a0 = r0[0], a1 = r1[0], e0 = r0[1], e1 = r1[1];
        sph_v2d t11 = (sph_v2d){a0[0], a1[0]} + tk11, t22 = (sph_v2d){a0[1], a1[1]} + tk22,
                t12 = (sph_v2d){e0[0], e1[0]} + tk12;
        sph_v2d gx, gy;
        pair_grad2(nb, ff, s0, s1, j0, j1, xk, yk, &gx, &gy);
        if (gc) {
            const size_t p0 = 6 * j0 + 3, p1 = 6 * j1 + 3;
            sph_v2d c0v = bk0 + ld2(bi, p0, p1), c1v = bk1 + ld2(bi, p0 + 1, p1 + 1),
                    c2v = bk2 + ld2(bi, p0 + 2, p1 + 2);
            sph_v2d cx = 0.5 * (c0v * gx + c1v * gy);
            gy = 0.5 * (c1v * gx + c2v * gy);
            gx = cx;
        }
        sph_v2d mj = {e0[1], e1[1]};
        ax += mj * (t11 * gx + t12 * gy);
        ay += mj * (t12 * gx + t22 * gy);
    }
    double acc0[2] = {ax[0], ay[0]}, acc1[2] = {ax[1], ay[1]};
    divergence_sum(m, k0, gc, cm, acc0, ff);
    divergence_sum(m, k1, gc, cm, acc1, ff);
    m->P->ax[k0] = acc0[0];
    m->P->ay[k0] = acc0[1];
    m->P->ax[k1] = acc1[0];
    m->P->ay[k1] = acc1[1];
}

/* The same sum with S / M^2 evaluated per pair (few pairs: a small active
 * set among many particles). */
static void divergence_direct(const sph_model *m, size_t k)
{
    sph_particles *P = m->P;
    const sph_nbr *nb = m->nb;
    const int gc = m->prm.gradient_correction;
    const size_t base = nb->off[k];
    double iMk2 = 1.0 / (P->dens[k] * P->dens[k]);
    double tk11 = P->s11[k] * iMk2, tk22 = P->s22[k] * iMk2, tk12 = P->s12[k] * iMk2;
    double ax = 0, ay = 0;
    const double *bk = m->binv + 6 * k + 3;
    for (int q = 0; q < nb->count[k]; q++) {
        size_t s = base + (size_t)q;
        int j = nb->idx[s];
        double iMj2 = 1.0 / (P->dens[j] * P->dens[j]);
        double t11 = P->s11[j] * iMj2 + tk11, t22 = P->s22[j] * iMj2 + tk22,
               t12 = P->s12[j] * iMj2 + tk12;
        double gx, gy;
        sph_nbr_grad(nb, k, (size_t)j, s, &gx, &gy);
        if (gc) {
            const double *bj = m->binv + 6 * (size_t)j + 3;
            double cx = 0.5 * ((bk[0] + bj[0]) * gx + (bk[1] + bj[1]) * gy);
            gy = 0.5 * ((bk[1] + bj[1]) * gx + (bk[2] + bj[2]) * gy);
            gx = cx;
        }
        ax += P->mass[j] * (t11 * gx + t12 * gy);
        ay += P->mass[j] * (t12 * gx + t22 * gy);
    }
    P->ax[k] = ax;
    P->ay[k] = ay;
}

void sph_divergence_pass(sph_model *m, const int *list, size_t count)
{
    sph_particles *P = m->P;
    const sph_nbr *nb = m->nb;
    const int gc = m->prm.gradient_correction, ff = nb->factor;
    const size_t nall = P->n + m->ng;
    const size_t pairs = list_pairs(m, list, count);
    if (pairs <= nall || !nb->pk) {
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(count))
        for (size_t i = 0; i < count; i++)
            divergence_direct(m, list ? (size_t)list[i] : i);
        return;
    }
    double *pk = nb->pk;
    double *imd2 = m->div_imd2;
    const int ready = m->div_imd2_ready;
    const int wmass = !m->pk_mass_ready;
#pragma omp parallel if (SPH_OMP_WORTH(count))
    {
        /* 1 / M_j^2: within a stress solve (m->div_imd2) computed by its
         * first pass and read by the others, the same operation on the
         * same operand (M is constant within a solve) */
        if (imd2 && ready) {
#pragma omp for schedule(static)
            for (size_t j = 0; j < nall; j++)
                pack_stress_slot(P, pk + 4 * j, j, imd2[j], wmass);
        } else if (imd2) {
#pragma omp for schedule(static)
            for (size_t j = 0; j < nall; j++) {
                imd2[j] = 1.0 / (P->dens[j] * P->dens[j]);
                pack_stress_slot(P, pk + 4 * j, j, imd2[j], wmass);
            }
        } else {
#pragma omp for schedule(static)
            for (size_t j = 0; j < nall; j++)
                pack_stress_slot(P, pk + 4 * j, j, 1.0 / (P->dens[j] * P->dens[j]), wmass);
        }
        /* list entries 2i and 2i + 1 in two lanes */
        const size_t half = count / 2;
        if (gc) {
#pragma omp for schedule(static)
            for (size_t i = 0; i < half; i++)
                SPH_FF(divergence_two, m, SPH_LIST_K(2 * i), SPH_LIST_K(2 * i + 1), 1);
        } else {
#pragma omp for schedule(static)
            for (size_t i = 0; i < half; i++)
                SPH_FF(divergence_two, m, SPH_LIST_K(2 * i), SPH_LIST_K(2 * i + 1), 0);
        }
#pragma omp single
        if (count % 2)
            SPH_FF(divergence_packed, m, SPH_LIST_K(count - 1), gc);
    }
    if (imd2)
        m->div_imd2_ready = 1;
    if (m->pass_pairs_on)
        m->pk_mass_ready = 1;
}

/* Free drift (no internal force) for the particles not in the active set. */
void sph_free_drift_pass(sph_model *m)
{
    sph_particles *P = m->P;
    size_t n = P->n;
    double dt = m->prm.dt;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++) {
        if (P->regime[k] & SPH_REGIME_RHEOLOGY)
            continue;
        P->ax[k] = P->ay[k] = 0.0;
        P->s11[k] = P->s22[k] = P->s12[k] = 0.0;
        /* Picard sweeps on the lagged drag speed until the velocity settles
         * (long steps need more than a few: c dt >> 1) */
        double u = m->un[k], v = m->vn[k];
        for (int it = 0; it < 60; it++) {
            double un, vn;
            sph_momentum(m, k, 0.0, u, v, m->un[k], m->vn[k], dt, &un, &vn);
            double d = fabs(un - u) + fabs(vn - v);
            /* the plain lagged iteration oscillates when c dt >> 1 (its
             * derivative tends to -1); averaging removes that mode */
            if (it == 0) {
                u = un;
                v = vn;
            } else {
                u = 0.5 * (u + un);
                v = 0.5 * (v + vn);
            }
            if (d <= 1e-13 * (1.0 + fabs(u) + fabs(v)))
                break;
        }
        P->u[k] = u;
        P->v[k] = v;
    }
}

/* One parcel's set-up: G = (gr, gi), |G|, a, b and the Newton start s0. */
typedef struct {
    double gr, gi, G, a, b, s;
} parcel_sys;

static inline void parcel_setup(const sph_model *m, size_t k, parcel_sys *o)
{
    const sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    const double dt = p->dt, ca = m->cos_air, sna = m->sin_air;
    const double kair = p->rho_a * p->Ca, kw = p->rho_w * p->Cw, g = p->gravity;
    double M = P->dens[k], iM = 1.0 / M, dA = sph_drag_factor(m, k); /* drag_scaling */
    double ua = P->ua[k], va = P->va[k];
    double sa = sqrt(ua * ua + va * va);
    double fx = P->ax[k] + dA * kair * sa * (ua * ca - va * sna) * iM - g * P->sshx[k];
    double fy = P->ay[k] + dA * kair * sa * (ua * sna + va * ca) * iM - g * P->sshy[k];
    double a = 0.5 * dt * m->fcor[k], b = dt * dA * kw * iM;
    double uw = P->uw[k], vw = P->vw[k], un = m->un[k], vn = m->vn[k];
    /* G = (1 + i a) Z_w - (1 - i a) z_n - dt F */
    double gr = (uw - a * vw) - (un + a * vn) - dt * fx;
    double gi = (vw + a * uw) - (vn - a * un) - dt * fy;
    double G = sqrt(gr * gr + gi * gi);
    /* start: the relative speed at the start of the step (close in a
     * slowly varying drift); from below, Newton's first step lands
     * above the root, then it descends monotonically */
    double s = sqrt((uw - un) * (uw - un) + (vw - vn) * (vw - vn));
    if (!(s > 0.0))
        s = G / sqrt(1.0 + a * a);
    o->gr = gr;
    o->gi = gi;
    o->G = G;
    o->a = a;
    o->b = b;
    o->s = s;
}

/* Newton on phi(s) for one parcel: at most 50 steps, stopping at a step
 * below 1e-15 s, or at s = 0. */
static inline double parcel_newton(const parcel_sys *q0, double cw, double sw)
{
    const double a = q0->a, b = q0->b, G = q0->G;
    double s = q0->s;
    for (int it = 0; it < 50; it++) {
        double re = 1.0 + b * s * cw, im = a + b * s * sw;
        double q = sqrt(re * re + im * im);
        double phi = s * q - G;
        double dphi = q + s * b * (re * cw + im * sw) / q;
        double ds = phi / dphi;
        s -= ds;
        if (!(s > 0.0)) {
            s = 0.0;
            break;
        }
        if (fabs(ds) <= 1e-15 * s)
            break;
    }
    return s;
}

/* The same Newton steps for PARCEL_LANES parcels at once, lane l doing
 * parcel_newton's operations on its own parcel in the same order (IEEE
 * operations are exact per lane: the same bits); a lane that has stopped
 * keeps its value while the others go on. GNU C vector extension of two
 * doubles (SSE2 on x86-64); sqrt through SSE2's sqrtpd where there is one
 * (correctly rounded, as sqrt is), per lane otherwise. Eight parcels: four
 * independent two-lane chains keep the divider and sqrt unit busy (the
 * step is a chain of two divisions and a sqrt; with four parcels it waited
 * on their latency). */
#define PARCEL_LANES 8
#if defined(__GNUC__)
/* (sph_v2l, sqrt2, sel2: lanes.h) */

/* One Newton step in two lanes (parcel_newton's operations, same order). */
static inline __attribute__((always_inline)) void newton_two(sph_v2d a, sph_v2d b, sph_v2d G, sph_v2d vcw,
                                                             sph_v2d vsw, sph_v2d *s, sph_v2l *done)
{
    const sph_v2d one = {1.0, 1.0}, zero = {0.0, 0.0}, tol = {1e-15, 1e-15};
    sph_v2d bs = b * *s;
    sph_v2d re = one + bs * vcw, im = a + bs * vsw;
    sph_v2d qq = sqrt2(re * re + im * im);
    sph_v2d phi = *s * qq - G;
    sph_v2d dphi = qq + *s * b * (re * vcw + im * vsw) / qq;
    sph_v2d ds = phi / dphi;
    sph_v2d sn = *s - ds;
    /* !(s > 0): s = 0 and stop; |ds| <= 1e-15 s: stop */
    sph_v2l pos = (sph_v2l)(sn > zero);
    sph_v2d t = tol * sn;
    sph_v2l small = (sph_v2l)(ds <= t) & (sph_v2l)(-ds <= t);
    sn = (sph_v2d)(pos & (sph_v2l)sn); /* zero where not positive */
    *s = sel2(*done, *s, sn);
    *done |= ~pos | small;
}

static void parcel_newton_lanes(const parcel_sys *q, double cw, double sw, double *out)
{
    const sph_v2d vcw = {cw, cw}, vsw = {sw, sw};
#define LANE_PAIR(h)                                                                               \
    const sph_v2d a##h = {q[2 * h].a, q[2 * h + 1].a}, b##h = {q[2 * h].b, q[2 * h + 1].b},        \
                  G##h = {q[2 * h].G, q[2 * h + 1].G};                                             \
    sph_v2d s##h = {q[2 * h].s, q[2 * h + 1].s};                                                   \
    sph_v2l d##h = {0, 0}
    LANE_PAIR(0);
    LANE_PAIR(1);
    LANE_PAIR(2);
    LANE_PAIR(3);
#undef LANE_PAIR
    for (int it = 0; it < 50; it++) {
        newton_two(a0, b0, G0, vcw, vsw, &s0, &d0);
        newton_two(a1, b1, G1, vcw, vsw, &s1, &d1);
        newton_two(a2, b2, G2, vcw, vsw, &s2, &d2);
        newton_two(a3, b3, G3, vcw, vsw, &s3, &d3);
        sph_v2l all = d0 & d1 & d2 & d3;
        if (all[0] & all[1])
            break;
    }
    const sph_v2d *sv[4] = {&s0, &s1, &s2, &s3};
    for (int h = 0; h < 4; h++) {
        out[2 * h] = (*sv[h])[0];
        out[2 * h + 1] = (*sv[h])[1];
    }
}
#else
static void parcel_newton_lanes(const parcel_sys *q, double cw, double sw, double *out)
{
    for (int l = 0; l < PARCEL_LANES; l++)
        out[l] = parcel_newton(q + l, cw, sw);
}
#endif

static inline void parcel_finish(sph_model *m, size_t k, const parcel_sys *q, double s)
{
    sph_particles *P = m->P;
    const double cw = m->cos_water, sw = m->sin_water;
    double re = 1.0 + q->b * s * cw, im = q->a + q->b * s * sw, id = 1.0 / (re * re + im * im);
    double wr = (q->gr * re + q->gi * im) * id, wi = (q->gi * re - q->gr * im) * id;
    P->u[k] = P->uw[k] - wr;
    P->v[k] = P->vw[k] - wi;
    sph_set_zero(&P->s11[k]); /* zero from the first step on: read, not written */
    sph_set_zero(&P->s22[k]);
    sph_set_zero(&P->s12[k]);
}

/* Free drift of every live particle as an independent parcel
 * (model.free_drift_parcels): the fixed point sph_free_drift_pass reaches
 * by Picard sweeps, solved directly. With z = u + i v, W = Z_w - z the
 * velocity relative to the water, a = f dt / 2, b = dt rho_w C_w / M and
 * e^{i theta} the water turning, sph_momentum's 2x2 system at its fixed
 * point (c = rho_w C_w |W| / M) is
 *     (1 + i a + b |W| e^{i theta}) W = G,
 *     G = (1 + i a) Z_w - (1 - i a) z_n - dt F
 * (F: internal force, air stress / M, -g grad xi). Its modulus gives
 * s = |W| as the root of phi(s) = s |1 + i a + b s e^{i theta}| - |G|,
 * increasing and convex for |theta| <= 90 degrees: Newton from
 * s0 = |G| / |1 + i a| >= the root converges monotonically (from any
 * s0 > 0 after its first step); started at the last step's relative speed.
 * Then W = G / (1 + i a + b s e^{i theta}) and z = Z_w - W: an algebraic
 * solve, no transcendental function. It agrees with the Picard sweeps to
 * their stopping tolerance (1e-13 relative; tests/test_parcels.c).
 * Parcels in groups of PARCEL_LANES run their Newton steps side by side
 * (parcel_newton_lanes: the same bits as one at a time, which the rest
 * take; tests/test_parcels.c checks the two against each other). */
void sph_parcels_drift_pass(sph_model *m)
{
    const size_t n = m->P->n, nb = n / PARCEL_LANES;
    const double cw = m->cos_water, sw = m->sin_water;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t g = 0; g < nb; g++) {
        parcel_sys q[PARCEL_LANES];
        double s[PARCEL_LANES];
        size_t k0 = g * PARCEL_LANES;
        for (int l = 0; l < PARCEL_LANES; l++)
            parcel_setup(m, k0 + (size_t)l, q + l);
        parcel_newton_lanes(q, cw, sw, s);
        for (int l = 0; l < PARCEL_LANES; l++)
            parcel_finish(m, k0 + (size_t)l, q + l, s[l]);
    }
    for (size_t k = nb * PARCEL_LANES; k < n; k++) {
        parcel_sys q;
        parcel_setup(m, k, &q);
        parcel_finish(m, k, &q, parcel_newton(&q, cw, sw));
    }
}

void sph_parcels_drift_range(sph_model *m, size_t k0, size_t k1)
{
    const double cw = m->cos_water, sw = m->sin_water;
    size_t k = k0;
    for (; k + PARCEL_LANES <= k1; k += PARCEL_LANES) {
        parcel_sys q[PARCEL_LANES];
        double s[PARCEL_LANES];
        for (int l = 0; l < PARCEL_LANES; l++)
            parcel_setup(m, k + (size_t)l, q + l);
        parcel_newton_lanes(q, cw, sw, s);
        for (int l = 0; l < PARCEL_LANES; l++)
            parcel_finish(m, k + (size_t)l, q + l, s[l]);
    }
    for (; k < k1; k++) {
        parcel_sys q;
        parcel_setup(m, k, &q);
        parcel_finish(m, k, &q, parcel_newton(&q, cw, sw));
    }
}

/* Kernel gradient correction (model.gradient_correction; Bonet & Lok
 * 1999, Randles & Libersky 1996). The SPH gradient of a linear field is
 * B_k times the true one, B_k = sum_j V_j (-F_kj) d d^T (d = r_k - r_j);
 * B = I only on a regular lattice with a kernel whose lattice sums are
 * exact. Where the smoothing length varies (seed eq. 10 under uniaxial
 * compression shrinks h across the flow too) or spacing is anisotropic,
 * B departs from I by a few per cent, and the resting stress gradient a
 * uniform wind needs comes out that much steeper (R300: ridged zone
 * +2.7 % without, +0.47 % with; docs/dynamics.md). With the correction
 * the strain rates use B_k^-1 grad W_kj, with V_j = m_j / M_k (the strain
 * pass's weights: exact for a linear velocity field), and the symmetric
 * stress divergence (B_k^-1 + B_j^-1)/2 grad W_kj with V_j = m_j / M_j
 * (the divergence's own consistency weights), which stays antisymmetric
 * in k, j: internal forces still sum to zero. B^-1 = I where the
 * correction is off, and where B is ill-conditioned (det B < 1/4: a
 * corner, a particle with few neighbours). Ghosts take their source's
 * B^-1, mirrored. */
static void invert_moment(double b11, double b12, double b22, double *bi)
{
    double det = b11 * b22 - b12 * b12;
    if (det > 0.25 && b11 > 0.0 && b22 > 0.0) {
        bi[0] = b22 / det;
        bi[1] = -b12 / det;
        bi[2] = b11 / det;
    } else {
        bi[0] = 1.0;
        bi[1] = 0.0;
        bi[2] = 1.0;
    }
}

void sph_gradient_correction_pass(sph_model *m)
{
    sph_particles *P = m->P;
    const sph_nbr *nb = m->nb;
    const size_t n = P->n;
    if (!m->prm.gradient_correction)
        return; /* binv stays the identity sph_model_create set */
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++) {
        double b11 = 0, b12 = 0, b22 = 0, c11 = 0, c12 = 0, c22 = 0;
        const size_t base = nb->off[k];
        for (int q = 0; q < nb->count[k]; q++) {
            size_t s = base + (size_t)q;
            int j = nb->idx[s];
            double dx = P->x[k] - P->x[j], dy = P->y[k] - P->y[j];
            double gx, gy;
            sph_nbr_grad(nb, k, (size_t)j, s, &gx, &gy);
            double t11 = -gx * dx, t12 = -gx * dy, t22 = -gy * dy;
            b11 += P->mass[j] * t11;
            b12 += P->mass[j] * t12;
            b22 += P->mass[j] * t22;
            double V = P->mass[j] / P->dens[j];
            c11 += V * t11;
            c12 += V * t12;
            c22 += V * t22;
        }
        double iM = 1.0 / P->dens[k];
        invert_moment(b11 * iM, b12 * iM, b22 * iM, m->binv + 6 * k);
        invert_moment(c11, c12, c22, m->binv + 6 * k + 3);
    }
    for (size_t g = 0; g < m->ng; g++) {
        size_t q = n + g, k = (size_t)m->ghost_src[g];
        for (int h = 0; h < 6; h += 3) {
            double a = m->binv[6 * k + h], b = m->binv[6 * k + h + 1], c = m->binv[6 * k + h + 2];
            sph_reflect_tensor(m->ghost_nx[g], m->ghost_ny[g], &a, &b, &c);
            sph_reflect_tensor(m->ghost_n2x[g], m->ghost_n2y[g], &a, &b, &c);
            m->binv[6 * q + h] = a;
            m->binv[6 * q + h + 1] = b;
            m->binv[6 * q + h + 2] = c;
        }
    }
}

/* Continuity in the Lagrangian frame, implicit so M stays positive, from
 * the final strain rates (summation_density = 0). Ghosts are true
 * mirrors, so compression against a coast and its release balance (a row
 * oscillating at a wall does not ratchet up); the release is capped by
 * what the coast compressed (coastc), so ice leaving a coast opens water
 * behind it instead of stretching its parcel. */
void sph_continuity_pass(sph_model *m)
{
    sph_particles *P = m->P;
    const double dt = m->prm.dt, rho_i = m->prm.rho_i;
    const size_t n = P->n;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++) {
        double div = P->e11[k] + P->e22[k];
        if (P->regime[k] & SPH_REGIME_NEAR_COAST) {
            double dg = coast_divergence(m, k);
            if (dg < 0.0) {
                P->coastc[k] -= dt * dg;
            } else {
                double rel = fmin(dg, P->coastc[k] / dt);
                P->coastc[k] -= dt * rel;
                div -= dg - rel;
            }
        }
        double fac = 1.0 + dt * div;
        P->dens[k] /= fac > 0.1 ? fac : 0.1;
        /* a parcel spread below SPH_CONC_MIN is open water with a trace
         * of ice: its footprint stops growing (docs/dynamics.md) */
        double floor_dens = SPH_CONC_MIN * rho_i * P->thick[k];
        if (P->dens[k] < floor_dens)
            P->dens[k] = floor_dens;
    }
}

void sph_update_sml(sph_model *m)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    if (!p->variable_sml)
        return;
    size_t n = P->n;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++)
        P->sml[k] = sph_sml_one(P, p, k);
}

int sph_model_interpolate(sph_model *m, size_t npts, const double *px, const double *py,
                          int nf, const double *const *fields, double *const *out_f,
                          double *out_dens)
{
    sph_particles *P = m->P;
    size_t n = P->n;
    double hmax = sph_max_sml(P, n);
    double R = m->kern.radius;
    sph_nbr_grid(m->nb, n, P->x, P->y, R * hmax);
    const int maxc = 4096;
    int bad = 0;
#pragma omp parallel
    {
        int cand[4096];
#pragma omp for schedule(static)
        for (size_t i = 0; i < npts; i++) {
            int nc = sph_nbr_candidates(m->nb, px[i], py[i], cand, maxc);
            if (nc == maxc)
                bad = 1;
            double wsum = 0.0, dsum = 0.0;
            double acc[16] = {0};
            for (int c = 0; c < nc; c++) {
                int j = cand[c];
                double dx = px[i] - P->x[j], dy = py[i] - P->y[j];
                double W, F;
                sph_kernel_eval(&m->kern, dx * dx + dy * dy, P->sml[j], &W, &F);
                if (W <= 0.0)
                    continue;
                double wj = P->mass[j] / P->dens[j] * W;
                wsum += wj;
                dsum += P->mass[j] * W;
                for (int f = 0; f < nf && f < 16; f++)
                    acc[f] += wj * fields[f][j];
            }
            for (int f = 0; f < nf && f < 16; f++)
                out_f[f][i] = wsum > 0.0 ? acc[f] / wsum : NAN;
            if (out_dens)
                out_dens[i] = dsum;
        }
    }
    return bad || nf > 16 ? SPH_STEP_RECOVERABLE : SPH_STEP_OK;
}

