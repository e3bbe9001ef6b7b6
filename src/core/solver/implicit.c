/* The implicit stress solver: Picard iterations on the viscosities, each
 * a sparse linear solve with GSL's GMRES. Its workspace holds the sparse
 * matrices (GSL grows them to their high-water mark on the first steps,
 * then reuses them) and the ghosts' linear maps. No measured step bound. */
#include "../model_impl.h"

#include <math.h>
#include <stdlib.h>

#include <gsl/gsl_errno.h>
#include <gsl/gsl_spblas.h>
#include <gsl/gsl_splinalg.h>
#include <gsl/gsl_spmatrix.h>
#include <gsl/gsl_vector.h>

/* ------------------------------------------------------------------ */
/* Implicit solver: Picard iterations on the viscosities, each a sparse  */
/* linear solve with GSL's GMRES.                                        */
/*                                                                       */
/* With zeta, eta and the replacement pressure frozen at the current     */
/* velocities, the SPH stress divergence is linear in the velocities:    */
/*   a_int = D (C B u + S0),                                             */
/* B the strain-rate operator (seed eq. 15), C the per-particle 3x3      */
/* viscosity block, S0 = -P_r/2 (1, 1, 0), D the symmetric divergence    */
/* (seed eq. 13); mirror particles enter B and D through their linear    */
/* maps to their sources. Each Picard iteration solves                   */
/*   (I + dt (c R_w + f/2 J) - dt D C B) u = u_n + dt (tau_a/M           */
/*      + c R_w U_w - g grad xi - f/2 J u_n + D S0)                      */
/* (the same time discretisation as the mEVP fixed point).               */

#define SPH_GMRES_KRYLOV 200

typedef struct implicit_work {
    gsl_spmatrix *Bt, *Ct, *Dt, *Kt, *B, *Cm, *D, *K, *T, *L, *A;
    gsl_vector *xv, *bv, *dv;
    gsl_splinalg_itersolve *gmres;
    double *ghost_G; /* per ghost: 2x2 velocity map and 3x3 stress map */
} implicit_work;

static void implicit_free(void *ws)
{
    implicit_work *w = ws;
    if (!w)
        return;
    gsl_spmatrix *mats[] = {w->Bt, w->Ct, w->Dt, w->Kt, w->B, w->Cm, w->D, w->K, w->T, w->L, w->A};
    for (size_t i = 0; i < sizeof mats / sizeof mats[0]; i++)
        if (mats[i])
            gsl_spmatrix_free(mats[i]);
    if (w->xv)
        gsl_vector_free(w->xv);
    if (w->bv)
        gsl_vector_free(w->bv);
    if (w->dv)
        gsl_vector_free(w->dv);
    if (w->gmres)
        gsl_splinalg_itersolve_free(w->gmres);
    free(w->ghost_G);
    free(w);
}

static int implicit_create(const sph_model *m, void **ws)
{
    implicit_work *w = calloc(1, sizeof *w);
    *ws = w;
    if (!w)
        return -1;
    size_t n2 = 2 * m->cap, n3 = 3 * m->cap, nb = (size_t)m->prm.max_neighbours;
    size_t nzB = m->cap * (6 * nb + 6), nzD = m->cap * (6 * nb + 6);
    w->Bt = gsl_spmatrix_alloc_nzmax(n3, n2, nzB, GSL_SPMATRIX_COO);
    w->Ct = gsl_spmatrix_alloc_nzmax(n3, n3, 5 * m->cap + 1, GSL_SPMATRIX_COO);
    w->Dt = gsl_spmatrix_alloc_nzmax(n2, n3, nzD, GSL_SPMATRIX_COO);
    w->Kt = gsl_spmatrix_alloc_nzmax(n2, n2, 4 * m->cap + 1, GSL_SPMATRIX_COO);
    w->B = gsl_spmatrix_alloc_nzmax(n3, n2, nzB, GSL_SPMATRIX_CSC);
    w->Cm = gsl_spmatrix_alloc_nzmax(n3, n3, 5 * m->cap + 1, GSL_SPMATRIX_CSC);
    w->D = gsl_spmatrix_alloc_nzmax(n2, n3, nzD, GSL_SPMATRIX_CSC);
    w->K = gsl_spmatrix_alloc_nzmax(n2, n2, 4 * m->cap + 1, GSL_SPMATRIX_CSC);
    w->T = gsl_spmatrix_alloc_nzmax(n3, n2, nzB, GSL_SPMATRIX_CSC);
    w->L = gsl_spmatrix_alloc_nzmax(n2, n2, nzB * 4, GSL_SPMATRIX_CSC);
    w->A = gsl_spmatrix_alloc_nzmax(n2, n2, nzB * 4, GSL_SPMATRIX_CSC);
    w->xv = gsl_vector_alloc(n2);
    w->bv = gsl_vector_alloc(n2);
    w->dv = gsl_vector_alloc(n2);
    /* restart length: the viscous operator is stiff (dt lambda_max up to
     * 1e4-1e5), short restarts stall */
    w->gmres = gsl_splinalg_itersolve_alloc(gsl_splinalg_itersolve_gmres, n2,
                                            n2 < SPH_GMRES_KRYLOV ? n2 : SPH_GMRES_KRYLOV);
    w->ghost_G = calloc(m->P->cap * 13 + 1, sizeof(double));
    if (w->Bt && w->Ct && w->Dt && w->Kt && w->B && w->Cm && w->D && w->K && w->T && w->L &&
        w->A && w->xv && w->bv && w->dv && w->gmres && w->ghost_G)
        return 0;
    implicit_free(w);
    *ws = NULL;
    return -1;
}

/* a += v at (i, j) of a COO matrix */
static inline void coo_add(gsl_spmatrix *a, size_t i, size_t j, double v)
{
    if (v == 0.0)
        return;
    double *p = gsl_spmatrix_ptr(a, i, j);
    if (p)
        *p += v;
    else
        gsl_spmatrix_set(a, i, j, v);
}

/* Linear maps of each mirror particle from its source, frozen for this
 * Picard iteration: G (2x2) for velocity (the push-but-never-pull rule
 * decided at the current velocity) and Q (3x3) for (S11, S22, S12). */
static void ghost_maps(sph_model *m, implicit_work *w)
{
    for (size_t g = 0; g < m->ng; g++) {
        double *G = w->ghost_G + 13 * g, *Q = G + 4;
        /* velocity: apply the rule to the unit vectors, with the rule's
         * branch fixed by the source's current velocity */
        double nx1 = m->ghost_nx[g], ny1 = m->ghost_ny[g];
        double nx2 = m->ghost_n2x[g], ny2 = m->ghost_n2y[g];
        /* the rheology's ghosts are true mirrors (ghost_velocity, mirror = 1) */
        int toward1 = 1;
        int toward2 = nx2 != 0.0 || ny2 != 0.0;
        for (int c = 0; c < 2; c++) {
            double a = c == 0, b = c == 1;
            double rounds[2][3] = {{nx1, ny1, (double)toward1}, {nx2, ny2, (double)toward2}};
            for (int r = 0; r < 2; r++) {
                double nx = rounds[r][0], ny = rounds[r][1];
                if (nx == 0.0 && ny == 0.0)
                    continue;
                double un = a * nx + b * ny;
                double tx = a - un * nx, ty = b - un * ny;
                if (m->prm.coast_no_slip) {
                    tx = -tx;
                    ty = -ty;
                }
                double gn = rounds[r][2] != 0.0 ? -un : un;
                a = tx + gn * nx;
                b = ty + gn * ny;
            }
            G[0 * 2 + c] = a; /* column c: image of unit vector c */
            G[1 * 2 + c] = b;
        }
        for (int c = 0; c < 3; c++) {
            double a = c == 0, b2 = c == 2, cc = c == 1; /* (S11, S12, S22) */
            sph_ghost_stress_image(m->prm.coast_no_slip, nx1, ny1, nx2, ny2, &a, &b2, &cc);
            Q[0 * 3 + c] = a;  /* S11 */
            Q[1 * 3 + c] = cc; /* S22 */
            Q[2 * 3 + c] = b2; /* S12 */
        }
    }
}

static int implicit_solve(sph_model *m, void *ws, sph_status *st)
{
    implicit_work *iw = ws;
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    const sph_nbr *nb = m->nb;
    size_t n = P->n, n2 = 2 * m->cap, n3 = 3 * m->cap;
    double dt = p->dt;
    double ie2 = 1.0 / (p->ecc * p->ecc);
    int it;
    double change = 0.0;
    for (it = 0; it < p->implicit_max_picard; it++) {
        sph_ghost_velocity(m, P->u, P->v, 1);
        sph_strain_pass(m, NULL, n);
        ghost_maps(m, iw);
        gsl_spmatrix_set_zero(iw->Bt);
        gsl_spmatrix_set_zero(iw->Ct);
        gsl_spmatrix_set_zero(iw->Dt);
        gsl_spmatrix_set_zero(iw->Kt);
        /* S0 (frozen pressure part) is kept in s11/s22/s12 for D S0 */
        for (size_t k = 0; k < n; k++) {
            double zeta = 0, eta = 0, Pr = 0;
            if (!m->loose[k]) {
                double e11 = P->e11[k], e22 = P->e22[k], e12 = P->e12[k];
                double eI = e11 + e22, d = e11 - e22;
                double Delta = sqrt(eI * eI + (d * d + 4 * e12 * e12) * ie2);
                double Dreg = Delta > p->delta_min ? Delta : p->delta_min;
                zeta = fmin(P->pres[k] / (2.0 * Dreg), p->zeta_max_factor * P->pres[k]);
                eta = zeta * ie2;
                Pr = p->replacement_pressure ? 2.0 * zeta * Delta : P->pres[k];
            }
            m->zeta[k] = zeta;
            P->s11[k] = P->s22[k] = -0.5 * Pr;
            P->s12[k] = 0.0;
            coo_add(iw->Ct, 3 * k, 3 * k, zeta + eta);
            coo_add(iw->Ct, 3 * k, 3 * k + 1, zeta - eta);
            coo_add(iw->Ct, 3 * k + 1, 3 * k, zeta - eta);
            coo_add(iw->Ct, 3 * k + 1, 3 * k + 1, zeta + eta);
            coo_add(iw->Ct, 3 * k + 2, 3 * k + 2, 2.0 * eta);
        }
        sph_ghost_stress(m);
        for (size_t q = n; q < m->cap; q++) /* unused rows: identity, zero strain */
            coo_add(iw->Kt, 2 * q, 2 * q, 1.0), coo_add(iw->Kt, 2 * q + 1, 2 * q + 1, 1.0);
        for (size_t k = 0; k < n; k++) {
            const size_t base = nb->off[k];
            double iMk = 1.0 / P->dens[k], iMk2 = iMk * iMk;
            for (int s = 0; s < nb->count[k]; s++) {
                size_t sl = base + (size_t)s;
                size_t j = (size_t)nb->idx[sl];
                /* strain: B_k^-1 grad W; divergence: (B_k^-1 + B_j^-1)/2 grad W */
                const double *bs = m->binv + 6 * k, *bk = bs + 3, *bj = m->binv + 6 * j + 3;
                double gx0, gy0;
                sph_nbr_grad(nb, k, j, sl, &gx0, &gy0);
                double gx = bs[0] * gx0 + bs[1] * gy0, gy = bs[1] * gx0 + bs[2] * gy0;
                double hx = 0.5 * ((bk[0] + bj[0]) * gx0 + (bk[1] + bj[1]) * gy0);
                double hy = 0.5 * ((bk[1] + bj[1]) * gx0 + (bk[2] + bj[2]) * gy0);
                double w = P->mass[j] * iMk;
                /* strain rows of k: coefficients on (u_j, v_j) and (u_k, v_k) */
                double c[3][2] = {{w * gx, 0.0}, {0.0, w * gy}, {0.5 * w * gy, 0.5 * w * gx}};
                size_t src = j;
                const double *G = NULL, *Q = NULL;
                if (j >= n) {
                    size_t g = j - n;
                    src = (size_t)m->ghost_src[g];
                    G = iw->ghost_G + 13 * g;
                    Q = G + 4;
                }
                for (int r = 0; r < 3; r++) {
                    double cu = c[r][0], cv = c[r][1];
                    if (G) {
                        coo_add(iw->Bt, 3 * k + r, 2 * src, cu * G[0] + cv * G[2]);
                        coo_add(iw->Bt, 3 * k + r, 2 * src + 1, cu * G[1] + cv * G[3]);
                    } else {
                        coo_add(iw->Bt, 3 * k + r, 2 * j, cu);
                        coo_add(iw->Bt, 3 * k + r, 2 * j + 1, cv);
                    }
                    coo_add(iw->Bt, 3 * k + r, 2 * k, -cu);
                    coo_add(iw->Bt, 3 * k + r, 2 * k + 1, -cv);
                }
                /* divergence rows of k: on S_j (through Q for mirrors) and S_k */
                double mj = P->mass[j], iMj2 = 1.0 / (P->dens[j] * P->dens[j]);
                double dj[2][3] = {{mj * hx * iMj2, 0.0, mj * hy * iMj2},
                                   {0.0, mj * hy * iMj2, mj * hx * iMj2}};
                double dk[2][3] = {{mj * hx * iMk2, 0.0, mj * hy * iMk2},
                                   {0.0, mj * hy * iMk2, mj * hx * iMk2}};
                for (int r = 0; r < 2; r++)
                    for (int cc = 0; cc < 3; cc++) {
                        if (Q) {
                            for (int t = 0; t < 3; t++)
                                coo_add(iw->Dt, 2 * k + r, 3 * src + t, dj[r][cc] * Q[cc * 3 + t]);
                        } else {
                            coo_add(iw->Dt, 2 * k + r, 3 * j + cc, dj[r][cc]);
                        }
                        coo_add(iw->Dt, 2 * k + r, 3 * k + cc, dk[r][cc]);
                    }
            }
        }
        /* constant part D S0 (the frozen pressure) and the divergence of it */
        sph_divergence_pass(m, NULL, n);
        /* diagonal blocks and right-hand side */
        double cw = m->cos_water, sw = m->sin_water;
        for (size_t k = 0; k < n; k++) {
            double rho_h = P->dens[k];
            double ua = P->ua[k], va = P->va[k], sa = hypot(ua, va);
            double dA = sph_drag_factor(m, k); /* model.momentum.drag_scaling */
            double tax = dA * p->rho_a * p->Ca * sa * (ua * m->cos_air - va * m->sin_air);
            double tay = dA * p->rho_a * p->Ca * sa * (ua * m->sin_air + va * m->cos_air);
            double uw = P->uw[k], vw = P->vw[k];
            double c = dA * p->rho_w * p->Cw * hypot(uw - P->u[k], vw - P->v[k]) / rho_h;
            double f = m->fcor[k], un = m->un[k], vn = m->vn[k];
            coo_add(iw->Kt, 2 * k, 2 * k, 1.0 + dt * c * cw);
            coo_add(iw->Kt, 2 * k, 2 * k + 1, -dt * (c * sw + 0.5 * f));
            coo_add(iw->Kt, 2 * k + 1, 2 * k, dt * (c * sw + 0.5 * f));
            coo_add(iw->Kt, 2 * k + 1, 2 * k + 1, 1.0 + dt * c * cw);
            gsl_vector_set(iw->bv, 2 * k,
                           un + dt * (P->ax[k] + tax / rho_h + c * (cw * uw - sw * vw) -
                                      p->gravity * P->sshx[k] + 0.5 * f * vn));
            gsl_vector_set(iw->bv, 2 * k + 1,
                           vn + dt * (P->ay[k] + tay / rho_h + c * (sw * uw + cw * vw) -
                                      p->gravity * P->sshy[k] - 0.5 * f * un));
            gsl_vector_set(iw->xv, 2 * k, P->u[k]);
            gsl_vector_set(iw->xv, 2 * k + 1, P->v[k]);
        }
        for (size_t q = 2 * n; q < n2; q++) {
            gsl_vector_set(iw->bv, q, 0.0);
            gsl_vector_set(iw->xv, q, 0.0);
        }
        /* A = K - dt D C B */
        if (gsl_spmatrix_csc(iw->B, iw->Bt) || gsl_spmatrix_csc(iw->Cm, iw->Ct) ||
            gsl_spmatrix_csc(iw->D, iw->Dt) || gsl_spmatrix_csc(iw->K, iw->Kt) ||
            gsl_spblas_dgemm(1.0, iw->Cm, iw->B, iw->T) || gsl_spblas_dgemm(-dt, iw->D, iw->T, iw->L) ||
            gsl_spmatrix_add(iw->A, iw->K, iw->L))
            return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_SOLVER, -1, "implicit matrix", (double)n3, 0.0,
                                  "could not be assembled (GSL sparse)");
        /* Jacobi (row) scaling: diag(A)^-1 A u = diag(A)^-1 b */
        for (size_t q = 0; q < n2; q++) {
            double d = gsl_spmatrix_get(iw->A, q, q);
            gsl_vector_set(iw->dv, q, d != 0.0 ? 1.0 / d : 1.0);
        }
        gsl_spmatrix_scale_rows(iw->A, iw->dv);
        gsl_vector_mul(iw->bv, iw->dv);
        int status = GSL_CONTINUE;
        size_t iter = 0;
        while (status == GSL_CONTINUE && iter++ < 500)
            status = gsl_splinalg_itersolve_iterate(iw->A, iw->bv, p->implicit_tol, iw->xv, iw->gmres);
        if (status != GSL_SUCCESS)
            return sph_status_set(st, SPH_STEP_RECOVERABLE, SPH_FAULT_SOLVER, -1, "GMRES residual",
                                  gsl_splinalg_itersolve_normr(iw->gmres), p->implicit_tol,
                                  "did not converge in 500 restarts (implicit solver)");
        change = 0.0;
        double umax = 0.0;
        for (size_t k = 0; k < n; k++) {
            double u = gsl_vector_get(iw->xv, 2 * k), v = gsl_vector_get(iw->xv, 2 * k + 1);
            if (!isfinite(u) || !isfinite(v))
                return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_NONFINITE, P->id[k], "implicit velocity", u, 0.0,
                                      "is not finite");
            change = fmax(change, fmax(fabs(u - P->u[k]), fabs(v - P->v[k])));
            umax = fmax(umax, hypot(u, v));
            P->u[k] = u;
            P->v[k] = v;
        }
        if (change <= p->implicit_tol * (umax + 1e-3)) {
            it++;
            break;
        }
    }
    /* the stress of the final velocities, kept for output and diagnosis */
    sph_ghost_velocity(m, P->u, P->v, 1);
    sph_strain_pass(m, NULL, n);
    m->rheo->stress(m, NULL, n, P->s11, P->s22, P->s12);
    m->stats.iterations = it;
    m->stats.residual = change;
    return SPH_STEP_OK;
}

/* no measured bound */
const sph_solver_ops sph_solver_implicit = {
    .name = "implicit", .create = implicit_create, .free = implicit_free,
    .solve = implicit_solve, .stable_dt = NULL, .binv_always = 1,
};
