/* The Jacobian-free Newton-Krylov stress solver (Knoll & Keyes 2004;
 * Lemieux et al. 2010, Losch et al. 2014 for sea-ice grids): Newton's
 * method on the time-discrete momentum equation of the active particles,
 * each Newton step a right-preconditioned restarted GMRES whose products
 * J v are finite differences of the residual. The preconditioner is a
 * block ILU(0) (2x2 blocks, one per particle pair) of the Jacobian itself,
 * assembled by finite differences with a distance-2 colouring of the
 * Jacobian's pattern (Curtis, Powell & Reid 1974) and refreshed when a
 * linear solve needs many iterations. Its workspace holds the vectors,
 * the Krylov basis and the sparse pattern, all allocated at create.
 *
 * The residual is the fixed point of mEVP and of the implicit solver:
 *   F(u) = (I + dt (c(u) R_w + f/2 J)) u - u_n
 *          - dt (a_int(u) + tau_a/M + c(u) R_w U_w - g grad xi - f/2 J u_n)
 * with a_int(u) the SPH stress divergence of the rheology's stress at the
 * strain rates of u (the same passes mEVP runs) and the water drag's
 * c(u) = rho_w C_w |U_w - u| / M at u (not lagged). F is in m/s; the
 * Jacobian is I plus positive (semi-)definite drag and viscous parts, so
 * |F| bounds the velocity error. */
#include "../model_impl.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>

#include "core/rheology.h"

#define JFNK_KRYLOV 60       /* GMRES restart length */
#define JFNK_LINEAR_MAX 240  /* Krylov iterations per Newton step at most */
#define JFNK_LS_HALVINGS 10  /* backtracking line search */
#define JFNK_EW_GAMMA 0.9    /* Eisenstat-Walker choice 2 */
#define JFNK_EW_ALPHA 1.618
#define JFNK_ETA_MAX 0.5
#define JFNK_ETA_MIN 1e-4
#define JFNK_PICARD 1 /* Picard steps first in a step, and after a failed line search */
/* blocks per row of the Jacobian's pattern (particles within two
 * neighbour hops), in units of max_neighbours: a 2-D neighbourhood of
 * twice the radius holds four times the particles */
#define JFNK_PATTERN_FACTOR 4

typedef struct jfnk_work {
    size_t nmax;  /* unknowns: 2 per live particle slot */
    size_t nbb;   /* blocks per row at most */
    double *x, *f, *xs, *fs, *dx, *z, *w;
    double *V;                   /* (JFNK_KRYLOV + 1) x nmax */
    double H[(JFNK_KRYLOV + 1) * JFNK_KRYLOV], g[JFNK_KRYLOV + 1], cs[JFNK_KRYLOV], sn[JFNK_KRYLOV],
        y[JFNK_KRYLOV];
    int *pos;     /* [P->cap] active index of a live particle, -1 otherwise */
    int *rowptr;  /* [cap + 1] block rows (active index) */
    int *col;     /* [cap nbb] block columns, ascending in each row */
    double *blk;  /* [4 cap nbb] 2x2 blocks of the Jacobian, row-major */
    double *lu;   /* [4 cap nbb] their block ILU(0) */
    int assembled; /* 1: GMRES multiplies by blk; 0: by finite differences of F */
    /* Picard's frozen coefficients (per particle slot, at the velocities
     * u* of the last freeze): bulk viscosity, replacement pressure, water
     * drag; frozen = 1: the residual uses them (linear in u) */
    double *fz, *fpr, *fc;
    int frozen;
    int *diag;    /* [cap] position of the diagonal block of each row */
    double *ib;   /* [4 cap] inverse of the ILU's diagonal blocks */
    int *tptr, *tpos; /* the transpose: for column j, the positions of its blocks */
    int *trow;
    int *mark;    /* [cap] scatter of a row's columns */
    int *colour, *cptr, *clist, *forbid; /* [cap] the colouring */
    int ncolour;
    long fevals;  /* residual evaluations of this step */
} jfnk_work;

static void jfnk_free(void *ws)
{
    jfnk_work *w = ws;
    if (!w)
        return;
    free(w->x);
    free(w->f);
    free(w->xs);
    free(w->fs);
    free(w->dx);
    free(w->z);
    free(w->w);
    free(w->V);
    free(w->pos);
    free(w->rowptr);
    free(w->col);
    free(w->blk);
    free(w->lu);
    free(w->fz);
    free(w->fpr);
    free(w->fc);
    free(w->diag);
    free(w->ib);
    free(w->tptr);
    free(w->tpos);
    free(w->trow);
    free(w->mark);
    free(w->colour);
    free(w->cptr);
    free(w->clist);
    free(w->forbid);
    free(w);
}

static int jfnk_create(const sph_model *m, void **ws)
{
    jfnk_work *w = calloc(1, sizeof *w);
    *ws = w;
    if (!w)
        return -1;
    size_t cap = m->cap, nslot = sph_model_slots(m);
    w->nmax = 2 * cap;
    w->nbb = (size_t)JFNK_PATTERN_FACTOR * (size_t)m->prm.max_neighbours;
    if (w->nbb > cap)
        w->nbb = cap;
    size_t nz = cap * w->nbb + 1;
    w->x = calloc(w->nmax + 1, sizeof(double));
    w->f = calloc(w->nmax + 1, sizeof(double));
    w->xs = calloc(w->nmax + 1, sizeof(double));
    w->fs = calloc(w->nmax + 1, sizeof(double));
    w->dx = calloc(w->nmax + 1, sizeof(double));
    w->z = calloc(w->nmax + 1, sizeof(double));
    w->w = calloc(w->nmax + 1, sizeof(double));
    w->V = calloc((JFNK_KRYLOV + 1) * w->nmax + 1, sizeof(double));
    w->pos = malloc((nslot + 1) * sizeof(int));
    w->rowptr = calloc(cap + 2, sizeof(int));
    w->col = calloc(nz, sizeof(int));
    w->blk = calloc(4 * nz, sizeof(double));
    w->lu = calloc(4 * nz, sizeof(double));
    w->fz = calloc(nslot + 1, sizeof(double));
    w->fpr = calloc(nslot + 1, sizeof(double));
    w->fc = calloc(nslot + 1, sizeof(double));
    w->diag = calloc(cap + 1, sizeof(int));
    w->ib = calloc(4 * cap + 4, sizeof(double));
    w->tptr = calloc(cap + 2, sizeof(int));
    w->tpos = calloc(nz, sizeof(int));
    w->trow = calloc(nz, sizeof(int));
    w->mark = malloc((cap + 1) * sizeof(int));
    w->colour = calloc(cap + 1, sizeof(int));
    w->cptr = calloc(cap + 2, sizeof(int));
    w->clist = calloc(cap + 1, sizeof(int));
    w->forbid = malloc((cap + 1) * sizeof(int));
    if (w->x && w->f && w->xs && w->fs && w->dx && w->z && w->w && w->V && w->pos && w->rowptr && w->col &&
        w->blk && w->lu && w->fz && w->fpr && w->fc && w->diag && w->ib && w->tptr && w->tpos && w->trow && w->mark && w->colour && w->cptr &&
        w->clist && w->forbid && (size_t)INT32_MAX > nz) {
        for (size_t k = 0; k <= nslot; k++)
            w->pos[k] = -1;
        for (size_t k = 0; k <= cap; k++)
            w->mark[k] = -1;
        return 0;
    }
    jfnk_free(w);
    *ws = NULL;
    return -1;
}

/* the live particle whose velocity neighbour slot j carries (a mirror
 * ghost's source) */
static inline size_t jfnk_src(const sph_model *m, size_t j)
{
    size_t n = m->P->n;
    return j < n ? j : (size_t)m->ghost_src[j - n];
}

/* F(x) into f (2 entries per active particle, the active set's order):
 * the velocities x into the particles, then mEVP's passes (ghost
 * velocity, strain, the rheology's stress, ghost stress, divergence) and
 * the momentum residual. Leaves the particles' velocities, strain rates,
 * stresses and zeta those of x. */
static void jfnk_residual(sph_model *m, jfnk_work *w, const double *x, double *f)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    const int *act = m->active;
    const size_t na = m->nactive;
    const double dt = p->dt;
    for (size_t i = 0; i < na; i++) {
        size_t k = (size_t)act[i];
        P->u[k] = x[2 * i];
        P->v[k] = x[2 * i + 1];
    }
    sph_ghost_velocity(m, P->u, P->v, 1);
    sph_strain_pass(m, act, na);
    if (w->frozen) {
        /* Picard: the VP law with zeta and P_r of u* (linear in u) */
        const double ie2 = 1.0 / (p->ecc * p->ecc);
        for (size_t i = 0; i < na; i++) {
            size_t k = (size_t)act[i];
            double zeta = w->fz[k], eta = zeta * ie2;
            double e11 = P->e11[k], e22 = P->e22[k], iso = (zeta - eta) * (e11 + e22) - 0.5 * w->fpr[k];
            P->s11[k] = 2.0 * eta * e11 + iso;
            P->s22[k] = 2.0 * eta * e22 + iso;
            P->s12[k] = 2.0 * eta * P->e12[k];
        }
    } else {
        m->rheo->stress(m, act, na, P->s11, P->s22, P->s12);
    }
    sph_ghost_stress(m);
    sph_divergence_pass(m, act, na);
    const double cw = m->cos_water, sw = m->sin_water, ca = m->cos_air, sna = m->sin_air;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(na))
    for (size_t i = 0; i < na; i++) {
        size_t k = (size_t)act[i];
        double rho_h = P->dens[k];
        double ua = P->ua[k], va = P->va[k], sa = sqrt(ua * ua + va * va);
        double dA = sph_drag_factor(m, k);
        double tax = dA * p->rho_a * p->Ca * sa * (ua * ca - va * sna);
        double tay = dA * p->rho_a * p->Ca * sa * (ua * sna + va * ca);
        double u = x[2 * i], v = x[2 * i + 1];
        double uw = P->uw[k], vw = P->vw[k];
        double dux = uw - u, duy = vw - v;
        double c = w->frozen ? w->fc[k] : dA * p->rho_w * p->Cw * sqrt(dux * dux + duy * duy) / rho_h;
        double fc = m->fcor[k], un = m->un[k], vn = m->vn[k];
        double rx = un + dt * (P->ax[k] + tax / rho_h + c * (cw * uw - sw * vw) - p->gravity * P->sshx[k] +
                               0.5 * fc * vn);
        double ry = vn + dt * (P->ay[k] + tay / rho_h + c * (sw * uw + cw * vw) - p->gravity * P->sshy[k] -
                               0.5 * fc * un);
        double d11 = 1.0 + dt * c * cw, d12 = -dt * (c * sw + 0.5 * fc);
        f[2 * i] = d11 * u + d12 * v - rx;
        f[2 * i + 1] = -d12 * u + d11 * v - ry;
    }
    w->fevals++;
}

/* Picard's coefficients at the particles' current velocities and strain
 * rates (those of the last unfrozen residual): zeta and P_r as
 * sph_vp_stress makes them, the water drag's c */
static void jfnk_freeze(sph_model *m, jfnk_work *w)
{
    const sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    const double ie2 = 1.0 / (p->ecc * p->ecc);
    for (size_t i = 0; i < m->nactive; i++) {
        size_t k = (size_t)m->active[i];
        double zeta = 0.0, pr = 0.0;
        if (!m->loose[k]) {
            double eI = P->e11[k] + P->e22[k], d = P->e11[k] - P->e22[k];
            double Delta = sqrt(eI * eI + (d * d + 4.0 * P->e12[k] * P->e12[k]) * ie2);
            double Dreg = Delta > p->delta_min ? Delta : p->delta_min;
            zeta = P->pres[k] / (2.0 * Dreg);
            if (zeta > p->zeta_max_factor * P->pres[k])
                zeta = p->zeta_max_factor * P->pres[k];
            pr = p->replacement_pressure ? 2.0 * zeta * Delta : P->pres[k];
        }
        w->fz[k] = zeta;
        w->fpr[k] = pr;
        double dux = P->uw[k] - P->u[k], duy = P->vw[k] - P->v[k];
        w->fc[k] = sph_drag_factor(m, k) * p->rho_w * p->Cw * sqrt(dux * dux + duy * duy) / P->dens[k];
    }
}

/* sums in index order (the same with any thread count) */
static double jfnk_dot(const double *a, const double *b, size_t n)
{
    double s = 0.0;
    for (size_t i = 0; i < n; i++)
        s += a[i] * b[i];
    return s;
}

static double jfnk_rms(const double *a, size_t n) { return n ? sqrt(jfnk_dot(a, a, n) / (double)n) : 0.0; }

/* The Jacobian's block pattern (active particles within two neighbour
 * hops, mirror ghosts standing for their sources), its transpose and a
 * distance-2 colouring of its columns (no two columns of one colour share
 * a row); -1 when a row holds more than nbb blocks. */
static int jfnk_pattern(sph_model *m, jfnk_work *w)
{
    const sph_nbr *nb = m->nb;
    const int *act = m->active;
    const size_t na = m->nactive;
    int *mark = w->mark, *col = w->col;
    for (size_t i = 0; i < na; i++)
        w->pos[act[i]] = (int)i;
    size_t nz = 0;
    for (size_t i = 0; i < na; i++) {
        size_t start = nz;
        w->rowptr[i] = (int)nz;
        mark[i] = (int)nz;
        col[nz++] = (int)i;
        /* the first hop (k's neighbours), then each first-hop particle's */
        size_t end1 = 0;
        for (int hop = 0; hop < 2; hop++) {
            size_t a0 = start, a1 = hop == 0 ? start + 1 : end1;
            for (size_t a = a0; a < a1; a++) {
                size_t ka = (size_t)act[col[a]];
                for (int q = 0; q < nb->count[ka]; q++) {
                    int c = w->pos[jfnk_src(m, (size_t)nb->idx[nb->off[ka] + (size_t)q])];
                    if (c < 0 || mark[c] >= (int)start)
                        continue;
                    if (nz - start >= w->nbb) {
                        for (size_t b = start; b < nz; b++)
                            mark[col[b]] = -1;
                        for (size_t b = 0; b < na; b++)
                            w->pos[act[b]] = -1;
                        return -1;
                    }
                    mark[c] = (int)nz;
                    col[nz++] = c;
                }
            }
            end1 = nz;
        }
        /* ascending columns (insertion sort: rows of tens of blocks) */
        for (size_t a = start + 1; a < nz; a++) {
            int c = col[a];
            size_t b = a;
            while (b > start && col[b - 1] > c) {
                col[b] = col[b - 1];
                b--;
            }
            col[b] = c;
        }
        for (size_t a = start; a < nz; a++) {
            mark[col[a]] = -1;
            if (col[a] == (int)i)
                w->diag[i] = (int)a;
        }
    }
    w->rowptr[na] = (int)nz;
    /* transpose */
    for (size_t j = 0; j <= na; j++)
        w->tptr[j] = 0;
    for (size_t a = 0; a < nz; a++)
        w->tptr[col[a] + 1]++;
    for (size_t j = 0; j < na; j++)
        w->tptr[j + 1] += w->tptr[j];
    for (size_t j = 0; j < na; j++)
        mark[j] = w->tptr[j];
    for (size_t i = 0; i < na; i++)
        for (int a = w->rowptr[i]; a < w->rowptr[i + 1]; a++) {
            int j = col[a], t = mark[j]++;
            w->trow[t] = (int)i;
            w->tpos[t] = a;
        }
    for (size_t j = 0; j < na; j++)
        mark[j] = -1;
    /* greedy distance-2 colouring of the columns, in index order */
    for (size_t j = 0; j < na; j++)
        w->forbid[j] = -1;
    int nc = 0;
    for (size_t j = 0; j < na; j++) {
        for (int t = w->tptr[j]; t < w->tptr[j + 1]; t++) {
            int i = w->trow[t];
            for (int a = w->rowptr[i]; a < w->rowptr[i + 1]; a++)
                if (col[a] < (int)j)
                    w->forbid[w->colour[col[a]]] = (int)j;
        }
        int c = 0;
        while (w->forbid[c] == (int)j)
            c++;
        w->colour[j] = c;
        if (c + 1 > nc)
            nc = c + 1;
    }
    w->ncolour = nc;
    for (int c = 0; c <= nc; c++)
        w->cptr[c] = 0;
    for (size_t j = 0; j < na; j++)
        w->cptr[w->colour[j] + 1]++;
    for (int c = 0; c < nc; c++)
        w->cptr[c + 1] += w->cptr[c];
    for (int c = 0; c < nc; c++)
        w->forbid[c] = w->cptr[c];
    for (size_t j = 0; j < na; j++)
        w->clist[w->forbid[w->colour[j]]++] = (int)j;
    for (size_t b = 0; b < na; b++)
        w->pos[act[b]] = -1;
    return 0;
}

/* inverse of the 2x2 block a into b; -1 when singular */
static int inv2(const double *a, double *b)
{
    double det = a[0] * a[3] - a[1] * a[2];
    if (!(fabs(det) > 0.0) || !isfinite(det))
        return -1;
    b[0] = a[3] / det;
    b[1] = -a[1] / det;
    b[2] = -a[2] / det;
    b[3] = a[0] / det;
    return 0;
}

/* c = a b (2x2) */
static inline void mul2(const double *a, const double *b, double *c)
{
    double c0 = a[0] * b[0] + a[1] * b[2], c1 = a[0] * b[1] + a[1] * b[3];
    double c2 = a[2] * b[0] + a[3] * b[2], c3 = a[2] * b[1] + a[3] * b[3];
    c[0] = c0;
    c[1] = c1;
    c[2] = c2;
    c[3] = c3;
}

/* The Picard matrix A(u*) at w->x (jfnk_freeze called with the
 * particles at x) into blk, by differences of the frozen residual (linear
 * in u: exact up to rounding), one residual per colour and component;
 * then its block ILU(0) into lu; -1 when a pivot block is singular. */
static int jfnk_precond(sph_model *m, jfnk_work *w)
{
    const size_t na = m->nactive, nu = 2 * na;
    double xmax = 0.0;
    for (size_t q = 0; q < nu; q++)
        xmax = fmax(xmax, fabs(w->x[q]));
    const double h = fmax(xmax, 1e-2);
    w->frozen = 1;
    jfnk_residual(m, w, w->x, w->z);
    for (int c = 0; c < w->ncolour; c++)
        for (int d = 0; d < 2; d++) {
            for (size_t q = 0; q < nu; q++)
                w->xs[q] = w->x[q];
            for (int e = w->cptr[c]; e < w->cptr[c + 1]; e++)
                w->xs[2 * w->clist[e] + d] += h;
            jfnk_residual(m, w, w->xs, w->fs);
            for (int e = w->cptr[c]; e < w->cptr[c + 1]; e++) {
                int j = w->clist[e];
                for (int t = w->tptr[j]; t < w->tptr[j + 1]; t++) {
                    int i = w->trow[t];
                    double *b = w->blk + 4 * (size_t)w->tpos[t];
                    b[d] = (w->fs[2 * i] - w->z[2 * i]) / h;
                    b[2 + d] = (w->fs[2 * i + 1] - w->z[2 * i + 1]) / h;
                }
            }
        }
    w->frozen = 0;
    /* block ILU(0), row by row (IKJ) */
    const size_t nzb = (size_t)w->rowptr[na];
    for (size_t q = 0; q < 4 * nzb; q++)
        w->lu[q] = w->blk[q];
    int *mark = w->mark;
    for (size_t i = 0; i < na; i++) {
        int r0 = w->rowptr[i], r1 = w->rowptr[i + 1];
        for (int a = r0; a < r1; a++)
            mark[w->col[a]] = a;
        for (int a = r0; a < r1 && w->col[a] < (int)i; a++) {
            int k = w->col[a];
            double *aik = w->lu + 4 * (size_t)a;
            mul2(aik, w->ib + 4 * (size_t)k, aik);
            for (int b = w->diag[k] + 1; b < w->rowptr[k + 1]; b++) {
                int t = mark[w->col[b]];
                if (t < 0)
                    continue;
                double prod[4];
                mul2(aik, w->lu + 4 * (size_t)b, prod);
                double *aij = w->lu + 4 * (size_t)t;
                for (int e = 0; e < 4; e++)
                    aij[e] -= prod[e];
            }
        }
        for (int a = r0; a < r1; a++)
            mark[w->col[a]] = -1;
        if (inv2(w->lu + 4 * (size_t)w->diag[i], w->ib + 4 * i) != 0)
            return -1;
    }
    return 0;
}

/* z = M^-1 r (the ILU's forward and backward sweeps) */
static void jfnk_apply_precond(const sph_model *m, const jfnk_work *w, const double *r, double *z)
{
    const size_t na = m->nactive;
    for (size_t i = 0; i < na; i++) {
        double s0 = r[2 * i], s1 = r[2 * i + 1];
        for (int a = w->rowptr[i]; a < w->diag[i]; a++) {
            const double *b = w->lu + 4 * (size_t)a;
            int k = w->col[a];
            s0 -= b[0] * z[2 * k] + b[1] * z[2 * k + 1];
            s1 -= b[2] * z[2 * k] + b[3] * z[2 * k + 1];
        }
        z[2 * i] = s0;
        z[2 * i + 1] = s1;
    }
    for (size_t i = na; i-- > 0;) {
        double s0 = z[2 * i], s1 = z[2 * i + 1];
        for (int a = w->diag[i] + 1; a < w->rowptr[i + 1]; a++) {
            const double *b = w->lu + 4 * (size_t)a;
            int k = w->col[a];
            s0 -= b[0] * z[2 * k] + b[1] * z[2 * k + 1];
            s1 -= b[2] * z[2 * k] + b[3] * z[2 * k + 1];
        }
        const double *ib = w->ib + 4 * i;
        z[2 * i] = ib[0] * s0 + ib[1] * s1;
        z[2 * i + 1] = ib[2] * s0 + ib[3] * s1;
    }
}

/* out = J v: by a finite difference of F at w->x (w->f = F(x)), or
 * with the assembled Jacobian (w->assembled) */
static void jfnk_jv(sph_model *m, jfnk_work *w, const double *v, double *out)
{
    const size_t nu = 2 * m->nactive;
    if (w->assembled) {
        for (size_t i = 0; i < m->nactive; i++) {
            double s0 = 0.0, s1 = 0.0;
            for (int a = w->rowptr[i]; a < w->rowptr[i + 1]; a++) {
                const double *b = w->blk + 4 * (size_t)a;
                int k = w->col[a];
                s0 += b[0] * v[2 * k] + b[1] * v[2 * k + 1];
                s1 += b[2] * v[2 * k] + b[3] * v[2 * k + 1];
            }
            out[2 * i] = s0;
            out[2 * i + 1] = s1;
        }
        return;
    }
    double vr = jfnk_rms(v, nu), xr = jfnk_rms(w->x, nu);
    if (!(vr > 0.0)) {
        for (size_t q = 0; q < nu; q++)
            out[q] = 0.0;
        return;
    }
    double eps = sqrt(DBL_EPSILON) * fmax(xr, 1e-3) / vr;
    for (size_t q = 0; q < nu; q++)
        w->xs[q] = w->x[q] + eps * v[q];
    jfnk_residual(m, w, w->xs, out);
    for (size_t q = 0; q < nu; q++)
        out[q] = (out[q] - w->f[q]) / eps;
}

/* GMRES(JFNK_KRYLOV), right-preconditioned: J dx = -f to the relative
 * residual eta; returns the Krylov iterations used, *rel the relative
 * residual reached. */
static int jfnk_gmres(sph_model *m, jfnk_work *w, double eta, double *rel)
{
    const size_t nu = 2 * m->nactive, ld = w->nmax;
    double *V = w->V, *H = w->H, *g = w->g;
    for (size_t q = 0; q < nu; q++)
        w->dx[q] = 0.0;
    double fnorm = sqrt(jfnk_dot(w->f, w->f, nu));
    *rel = 1.0;
    if (!(fnorm > 0.0)) {
        *rel = 0.0;
        return 0;
    }
    int total = 0;
    double beta = fnorm; /* r0 = -f at dx = 0 */
    for (size_t q = 0; q < nu; q++)
        V[q] = -w->f[q] / beta;
    while (total < JFNK_LINEAR_MAX) {
        int j, used = 0;
        for (int e = 0; e <= JFNK_KRYLOV; e++)
            g[e] = 0.0;
        g[0] = beta;
        for (j = 0; j < JFNK_KRYLOV && total < JFNK_LINEAR_MAX; j++) {
            double *vj = V + (size_t)j * ld, *vn = V + (size_t)(j + 1) * ld;
            jfnk_apply_precond(m, w, vj, w->z);
            jfnk_jv(m, w, w->z, vn);
            total++;
            for (int i = 0; i <= j; i++) { /* modified Gram-Schmidt */
                double hij = jfnk_dot(vn, V + (size_t)i * ld, nu);
                H[i * JFNK_KRYLOV + j] = hij;
                for (size_t q = 0; q < nu; q++)
                    vn[q] -= hij * V[(size_t)i * ld + q];
            }
            double hn = sqrt(jfnk_dot(vn, vn, nu));
            H[(j + 1) * JFNK_KRYLOV + j] = hn;
            if (hn > 0.0)
                for (size_t q = 0; q < nu; q++)
                    vn[q] /= hn;
            for (int i = 0; i < j; i++) { /* the earlier rotations */
                double a = H[i * JFNK_KRYLOV + j], b = H[(i + 1) * JFNK_KRYLOV + j];
                H[i * JFNK_KRYLOV + j] = w->cs[i] * a + w->sn[i] * b;
                H[(i + 1) * JFNK_KRYLOV + j] = -w->sn[i] * a + w->cs[i] * b;
            }
            double a = H[j * JFNK_KRYLOV + j], b = H[(j + 1) * JFNK_KRYLOV + j];
            double r = hypot(a, b);
            w->cs[j] = r > 0.0 ? a / r : 1.0;
            w->sn[j] = r > 0.0 ? b / r : 0.0;
            H[j * JFNK_KRYLOV + j] = r;
            H[(j + 1) * JFNK_KRYLOV + j] = 0.0;
            g[j + 1] = -w->sn[j] * g[j];
            g[j] = w->cs[j] * g[j];
            used = j + 1;
            *rel = fabs(g[j + 1]) / fnorm;
            if (*rel <= eta || !(hn > 0.0))
                break;
        }
        /* y = H^-1 g, dx += M^-1 V y */
        for (int i = used - 1; i >= 0; i--) {
            double s = g[i];
            for (int e = i + 1; e < used; e++)
                s -= H[i * JFNK_KRYLOV + e] * w->y[e];
            double d = H[i * JFNK_KRYLOV + i];
            w->y[i] = d != 0.0 ? s / d : 0.0;
        }
        for (size_t q = 0; q < nu; q++) {
            double s = 0.0;
            for (int i = 0; i < used; i++)
                s += V[(size_t)i * ld + q] * w->y[i];
            w->w[q] = s;
        }
        jfnk_apply_precond(m, w, w->w, w->z);
        for (size_t q = 0; q < nu; q++)
            w->dx[q] += w->z[q];
        if (*rel <= eta || used < JFNK_KRYLOV || total >= JFNK_LINEAR_MAX)
            break;
        /* restart: the true residual -f - J dx */
        jfnk_jv(m, w, w->dx, w->w);
        for (size_t q = 0; q < nu; q++)
            w->w[q] = -w->f[q] - w->w[q];
        beta = sqrt(jfnk_dot(w->w, w->w, nu));
        *rel = beta / fnorm;
        if (!(beta > 0.0) || *rel <= eta)
            break;
        for (size_t q = 0; q < nu; q++)
            V[q] = w->w[q] / beta;
    }
    return total;
}

/* Newton (or Picard) steps until the RMS residual is below jfnk.tol:
 * Picard while the iteration is far (the first JFNK_PICARD steps, and
 * after a Newton step whose line search failed: the VP law is not
 * differentiable where Delta = 0, at rest), Newton otherwise. */
static int jfnk_solve(sph_model *m, void *ws, sph_status *st)
{
    jfnk_work *w = ws;
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    const size_t na = m->nactive, nu = 2 * na;
    const int picard_ok = m->rheo->vp_law; /* the frozen law is the VP one */
    w->fevals = 0;
    w->frozen = 0;
    if (jfnk_pattern(m, w) != 0)
        return sph_status_set(st, SPH_STEP_RECOVERABLE, SPH_FAULT_CAPACITY, -1, "JFNK Jacobian pattern",
                              (double)w->nbb, (double)w->nbb,
                              "has a row with more blocks than the workspace holds (4 x max_neighbours)");
    for (size_t i = 0; i < na; i++) {
        size_t k = (size_t)m->active[i];
        w->x[2 * i] = P->u[k];
        w->x[2 * i + 1] = P->v[k];
    }
    jfnk_residual(m, w, w->x, w->f);
    double fn = jfnk_rms(w->f, nu), fprev = fn, eta = JFNK_ETA_MAX, err = HUGE_VAL;
    int it = 0, need = 1, picard_left = picard_ok ? JFNK_PICARD : 0, newton_fails = 0;
    for (;;) {
        if (!isfinite(fn))
            return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_NONFINITE, -1, "JFNK residual", fn, 0.0,
                                  "is not finite");
        const int picard = picard_left > 0;
        int fresh = 0;
        if (need || picard) { /* the particles hold x's state here */
            fresh = 1;
            jfnk_freeze(m, w);
            if (jfnk_precond(m, w) != 0)
                return sph_status_set(st, SPH_STEP_RECOVERABLE, SPH_FAULT_SOLVER, -1, "JFNK preconditioner",
                                      0.0, 0.0, "has a singular pivot block");
            need = 0;
        }
        /* the velocity error's estimate: the preconditioned residual
         * M^-1 F (M the Picard matrix's ILU; |F| itself is dominated by
         * rigid ice, where dt zeta_max / (M h^2) reaches 1e7-1e8 and a
         * velocity error of 1e-10 m/s leaves a residual of mm/s) */
        jfnk_apply_precond(m, w, w->f, w->z);
        err = jfnk_rms(w->z, nu);
        if (err < p->jfnk_tol) {
            if (fresh) {
                /* the particles back at x (the assembly left a perturbed state) */
                jfnk_residual(m, w, w->x, w->f);
                break;
            }
            /* a stale M can hide the error where the viscosities have
             * changed by orders of magnitude: decided with M at x */
            need = 1;
            continue;
        }
        if (it >= p->jfnk_max_newton) {
            jfnk_residual(m, w, w->x, w->f);
            m->stats.iterations = it;
            m->stats.residual = err;
            return sph_status_set(st, SPH_STEP_RECOVERABLE, SPH_FAULT_SOLVER, -1, "JFNK residual", err,
                                  p->jfnk_tol, "did not reach model.jfnk.tol in model.jfnk.max_newton iterations");
        }
        double rel;
        int lin, h = 0;
        double fnew;
        if (picard) {
            /* A(u*) du = -F(u*): the linear Picard solve, to 1e-2, full step */
            w->assembled = 1;
            lin = jfnk_gmres(m, w, 1e-2, &rel);
            w->assembled = 0;
            for (size_t q = 0; q < nu; q++)
                w->xs[q] = w->x[q] + w->dx[q];
            jfnk_residual(m, w, w->xs, w->fs);
            fnew = jfnk_rms(w->fs, nu);
            picard_left--;
        } else {
            /* Eisenstat-Walker choice 2, safeguarded */
            if (it > 0) {
                double e = JFNK_EW_GAMMA * pow(fn / fprev, JFNK_EW_ALPHA);
                double prev = JFNK_EW_GAMMA * pow(eta, JFNK_EW_ALPHA);
                if (prev > 0.1)
                    e = fmax(e, prev);
                eta = fmin(JFNK_ETA_MAX, fmax(e, JFNK_ETA_MIN));
                eta = fmin(fmax(eta, 0.5 * p->jfnk_tol / err), JFNK_ETA_MAX); /* no further than asked */
            }
            lin = jfnk_gmres(m, w, eta, &rel);
            /* backtracking line search on |F| */
            double lambda = 1.0;
            fnew = HUGE_VAL;
            for (h = 0; h <= JFNK_LS_HALVINGS; h++, lambda *= 0.5) {
                for (size_t q = 0; q < nu; q++)
                    w->xs[q] = w->x[q] + lambda * w->dx[q];
                jfnk_residual(m, w, w->xs, w->fs);
                fnew = jfnk_rms(w->fs, nu);
                if (fnew <= (1.0 - 1e-4 * lambda) * fn)
                    break;
            }
        }
        it++;
        if (!picard && h > JFNK_LS_HALVINGS) {
            /* no descent: Picard steps from x (the particles back at x) */
            if (!picard_ok || ++newton_fails > p->jfnk_max_newton / 4) {
                jfnk_residual(m, w, w->x, w->f);
                m->stats.iterations = it;
                m->stats.residual = err;
                return sph_status_set(st, SPH_STEP_RECOVERABLE, SPH_FAULT_SOLVER, -1, "JFNK residual", err,
                                      p->jfnk_tol, "line search found no descent (Newton stalled)");
            }
            jfnk_residual(m, w, w->x, w->f);
            picard_left = JFNK_PICARD;
            continue;
        }
        double *t = w->x;
        w->x = w->xs;
        w->xs = t;
        t = w->f;
        w->f = w->fs;
        w->fs = t;
        fprev = fn;
        fn = fnew;
        /* a preconditioner that needs many Krylov iterations is stale */
        if (!picard && (lin > JFNK_KRYLOV / 4 || rel > eta))
            need = 1;
    }
    /* the particles hold x's velocities and stress (the last residual) */
    m->stats.iterations = it;
    m->stats.residual = err;
    return SPH_STEP_OK;
}

/* no measured bound: each step is solved to model.jfnk.tol */
const sph_solver_ops sph_solver_jfnk = {
    .name = "jfnk", .create = jfnk_create, .free = jfnk_free, .solve = jfnk_solve, .stable_dt = NULL,
};
