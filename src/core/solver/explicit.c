/* The explicit stress solver: forward in time, sub-stepped to its own
 * viscous stability limit (or refused beyond it, model.unstable). It has
 * no measured step bound and no workspace of its own. */
#include "../model_impl.h"

#include <math.h>

/* Explicit viscous step limit. Forward Euler on the viscous operator is
 * stable for dt < 2 / lambda_max = 2 h^2 / (SPH_VISCOUS_EIG nu), nu =
 * zeta_max (1 + e^-2) / M; the limit used is safety * h^2 / nu (default
 * safety 1, inside the bound 1.6). zeta_max is the rheology's bound
 * (into the scratch array). */
double sph_explicit_limit(sph_model *m)
{
    const sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    double *zmax = m->scratch;
    m->rheo->zeta_bound(m, m->active, m->nactive, zmax);
    double lim = HUGE_VAL;
    for (size_t i = 0; i < m->nactive; i++) {
        size_t k = (size_t)m->active[i];
        double nu = zmax[k] * (1.0 + 1.0 / (p->ecc * p->ecc)) / P->dens[k];
        if (nu > 0.0)
            lim = fmin(lim, p->explicit_safety * P->sml[k] * P->sml[k] / nu);
    }
    return lim;
}

double sph_model_explicit_dt_limit(sph_model *m) { return sph_explicit_limit(m); }

static int explicit_solve(sph_model *m, void *ws, sph_status *st)
{
    sph_particles *P = m->P;
    double dt = m->prm.dt;
    double lim = sph_explicit_limit(m);
    m->stats.dt_limit_explicit = lim;
    int nsub = 1;
    if (dt > lim) {
        double want = ceil(dt / lim);
        if (m->prm.unstable == SPH_UNSTABLE_REFUSE || want > m->prm.max_substeps)
            return sph_status_set(st, SPH_STEP_RECOVERABLE, SPH_FAULT_SUBSTEPS, -1, "time step", dt, lim,
                                  "exceeds the explicit solver's stability limit");
        nsub = (int)want;
    }
    double dts = dt / nsub;
    const int *act = m->active;
    size_t na = m->nactive;
    for (int s = 0; s < nsub; s++) {
        sph_ghost_velocity(m, P->u, P->v, 1);
        sph_strain_pass(m, act, na);
        m->rheo->stress(m, act, na, P->s11, P->s22, P->s12);
        sph_ghost_stress(m);
        sph_divergence_pass(m, act, na);
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(na))
        for (size_t i = 0; i < na; i++) {
            size_t k = (size_t)act[i];
            double u = P->u[k], v = P->v[k];
            sph_momentum(m, k, 0.0, u, v, u, v, dts, &P->u[k], &P->v[k]);
        }
    }
    m->stats.substeps = nsub;
    return SPH_STEP_OK;
}

/* no workspace; no measured bound: it sub-steps to its own limit */
const sph_solver_ops sph_solver_explicit = {
    .name = "explicit", .create = NULL, .free = NULL, .solve = explicit_solve, .stable_dt = NULL,
};
