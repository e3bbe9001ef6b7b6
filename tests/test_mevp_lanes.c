/* mEVP's sweep (src/core/solver/mevp.c) runs the VP law, the stress
 * relaxation and the velocity update two particles at a time in
 * two-double lanes, with the step's air stress over M computed once per
 * step (issue 22, item 3). The results must be, bit for bit, one sweep as
 * documented, evaluated particle by particle (Kimmritz et al. 2016: aEVP's
 * alpha = beta = max(2 sqrt(gamma), 10), gamma = 1.25 zeta (1 + e^-2) dt /
 * (M h^2); s += (sigma(e) - s) / alpha; the momentum's 2x2 solve,
 * sph_momentum in src/core/model_impl.h), with the model's strain and
 * divergence passes (checked against their own sums by
 * test_operators_lanes). The test runs that reference sweep itself on one
 * model and the solver on an identical one, then compares the bits of
 * u, v, s11, s22, s12 and zeta over the active set: an odd particle count
 * (the lone last particle), loose particles among packed ones (auto
 * physics: the scalar pairs), aEVP and fixed alpha, 1 and 2 threads above
 * the threading threshold; all of it with two lanes and, where the CPU
 * has AVX2, again with the four-lane velocity update, VP law and
 * relaxation (sph_model.lanes4: quads of contiguous and of gathered
 * particles, quads holding a loose particle, the pairs and the lone
 * particle after the last quad). The solver's sweeps after the first read
 * the divergence's 1 / M^2 per slot from the solve's first, and the
 * strain pass reads 1 / M per particle computed before the first sweep
 * (M is constant within a solve); the reference computes both in every
 * sweep. The solve's relative momentum residual (its statistics) is the
 * documented one of its last sweep, bit for bit, where it runs all its
 * sweeps and where the tolerance stops it after one (its sums then taken
 * at the stop). */
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "lattice.h"
#include "../src/core/lanes.h"
#include "../src/core/model_impl.h"
#include "core/rheology.h"

#define SWEEPS 5

static unsigned rng;
static double urand(void)
{
    rng = rng * 1103515245u + 12345u;
    return (double)(rng >> 8 & 0xffff) / 65535.0 - 0.5;
}

/* A jittered lattice, its first third diluted to A = 0.3 (loose under
 * auto; the active set takes its edge), random velocities, wind, current and
 * sea-surface slope; lists, density, strength and active set from
 * sph_model_diagnose, then the step's start (un, vn, Coriolis, no
 * acceleration). The same seed gives the same model. */
static sph_model *scene(int nx, int ny, int adaptive, unsigned seed)
{
    sph_params p;
    sph_params_default(&p);
    p.kernel = SPH_KERNEL_GAUSSIAN;
    p.kernel_radius = 2.0;
    p.physics = SPH_PHYSICS_AUTO;
    p.thermo_dt = 0;
    p.dt = 60.0;
    p.evp_adaptive = adaptive;
    p.evp_iterations = SWEEPS;
    p.evp_tol = 0.0;
    p.evp_stall_window = 0;
    const double dx = 1000.0;
    sph_model *m = sph_model_create(&p, (size_t)nx * (size_t)ny, NULL);
    if (!m)
        return NULL;
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, &p, nx, ny, 0, 0, dx, 1.0, 1.0, 40.6);
    rng = seed;
    for (size_t k = 0; k < P->n; k++) {
        P->x[k] += 0.3 * dx * urand();
        P->y[k] += 0.3 * dx * urand();
        P->u[k] = 0.05 * urand();
        P->v[k] = 0.05 * urand();
        P->ua[k] = 8.0 + 4.0 * urand();
        P->va[k] = -3.0 + 4.0 * urand();
        P->uw[k] = 0.1 * urand();
        P->vw[k] = 0.1 * urand();
        P->sshx[k] = 1e-7 * urand();
        P->sshy[k] = 1e-7 * urand();
        if (P->x[k] < nx * dx / 3.0) { /* a diluted strip: A = 0.3 */
            P->mass[k] *= 0.3;
            P->conc[k] = 0.3;
        }
    }
    sph_status st;
    if (sph_model_init(m, &st) != 0 || sph_model_diagnose(m, &st) != 0) {
        CHECK(0, "scene: %s %s", st.quantity, st.what);
        sph_model_free(m);
        return NULL;
    }
    for (size_t k = 0; k < P->n; k++) {
        m->un[k] = P->u[k];
        m->vn[k] = P->v[k];
        P->ax[k] = P->ay[k] = 0.0;
        m->fcor[k] = 2.0 * OMEGA_EARTH * sin(P->lat[k] * DEG2RAD);
    }
    return m;
}

/* One sweep, particle by particle, as documented. */
static void ref_sweep(sph_model *m)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    const double dt = p->dt;
    sph_ghost_velocity(m, P->u, P->v, 1);
    sph_strain_pass(m, m->active, m->nactive);
    for (size_t i = 0; i < m->nactive; i++) {
        size_t k = (size_t)m->active[i];
        double t11 = 0.0, t22 = 0.0, t12 = 0.0, z = 0.0;
        if (!m->loose[k])
            z = sph_vp_stress(p, P->pres[k], P->e11[k], P->e22[k], P->e12[k], &t11, &t22, &t12);
        m->zeta[k] = z;
        double alpha = p->evp_alpha;
        if (p->evp_adaptive) {
            double gam = SPH_VISCOUS_EIG * z * (1.0 + 1.0 / (p->ecc * p->ecc)) * dt /
                         (P->dens[k] * P->sml[k] * P->sml[k]);
            double a2 = 2.0 * sqrt(gam);
            alpha = a2 > 10.0 ? a2 : 10.0;
        }
        m->scratch[k] = alpha;
        double ia = 1.0 / alpha;
        P->s11[k] += (t11 - P->s11[k]) * ia;
        P->s22[k] += (t22 - P->s22[k]) * ia;
        P->s12[k] += (t12 - P->s12[k]) * ia;
    }
    sph_ghost_stress(m);
    sph_divergence_pass(m, m->active, m->nactive);
    for (size_t i = 0; i < m->nactive; i++) {
        size_t k = (size_t)m->active[i];
        double beta = p->evp_adaptive ? m->scratch[k] : p->evp_beta, u, v;
        sph_momentum(m, k, beta, P->u[k], P->v[k], m->un[k], m->vn[k], dt, &u, &v);
        P->u[k] = u;
        P->v[k] = v;
    }
}

static int same_bits(const double *a, const double *b, const int *act, size_t na)
{
    for (size_t i = 0; i < na; i++)
        if (memcmp(&a[act[i]], &b[act[i]], sizeof(double)) != 0)
            return 0;
    return 1;
}

/* The relative momentum residual of the last sweep as documented
 * (include/core/model.h rel_residual): sqrt(mean (beta |u' - u|)^2) over
 * the RMS speed floored at 1e-4 m/s (mevp.c SPH_MEVP_SPEED_FLOOR), sums
 * in the active set's order; u0, v0: the velocities before that sweep. */
static double ref_rel(const sph_model *m, const double *u0, const double *v0)
{
    const sph_particles *P = m->P;
    double q2 = 0.0, u2 = 0.0, nna = (double)m->nactive;
    for (size_t i = 0; i < m->nactive; i++) {
        size_t k = (size_t)m->active[i];
        double beta = m->prm.evp_adaptive ? m->scratch[k] : m->prm.evp_beta;
        double bu = beta * (P->u[k] - u0[k]), bv = beta * (P->v[k] - v0[k]);
        q2 += bu * bu + bv * bv;
        u2 += P->u[k] * P->u[k] + P->v[k] * P->v[k];
    }
    return sqrt(q2 / nna) / fmax(sqrt(u2 / nna), 1e-4);
}

/* sweeps: the reference's (the solver stops there: its iteration count
 * with evp_tol 0, or at the first with a tolerance every sweep meets) */
static void check_case_n(int nx, int ny, int adaptive, int threads, int lanes4, int sweeps)
{
    sph_model *a = scene(nx, ny, adaptive, 77u), *b = scene(nx, ny, adaptive, 77u);
    CHECK(a && b, "scenes");
    if (!a || !b) {
        sph_model_free(a);
        sph_model_free(b);
        return;
    }
    b->lanes4 = lanes4;
    if (sweeps < SWEEPS) /* the first sweep's largest change is below it */
        b->prm.evp_tol = 1e30;
    if (lanes4) { /* both kinds of quad in the active set: contiguous and gathered */
        size_t contig = 0, nq = a->nactive / 4;
        for (size_t i = 0; i < nq; i++)
            contig += a->active[4 * i + 3] == a->active[4 * i] + 3;
        CHECK(contig > 0 && contig < nq, "%dx%d: %zu contiguous quads of %zu", nx, ny, contig, nq);
    }
    size_t loose = 0;
    for (size_t i = 0; i < a->nactive; i++)
        loose += a->loose[a->active[i]];
    CHECK(loose > 0 && loose < a->nactive, "%dx%d: %zu loose particles among %zu active", nx, ny,
          loose, a->nactive);
    omp_set_num_threads(1);
    double *u0 = malloc(a->P->n * sizeof(double)), *v0 = malloc(a->P->n * sizeof(double));
    CHECK(u0 && v0, "memory");
    if (!u0 || !v0) {
        free(u0);
        free(v0);
        sph_model_free(a);
        sph_model_free(b);
        return;
    }
    for (int it = 0; it < sweeps; it++) {
        memcpy(u0, a->P->u, a->P->n * sizeof(double));
        memcpy(v0, a->P->v, a->P->n * sizeof(double));
        ref_sweep(a);
    }
    const double rel = ref_rel(a, u0, v0);
    free(u0);
    free(v0);
    omp_set_num_threads(threads);
    sph_status st;
    sph_status_clear(&st);
    CHECK(b->solver->solve(b, b->solver_ws, &st) == SPH_STEP_OK, "solve");
    CHECK(b->stats.iterations == sweeps, "%d sweeps (%d)", sweeps, b->stats.iterations);
    CHECK(memcmp(&b->stats.rel_residual, &rel, sizeof rel) == 0 && rel > 0.0,
          "%d sweep(s): relative residual %.17g bit for bit the documented %.17g", sweeps,
          b->stats.rel_residual, rel);
    /* the solve's 1 / M^2 per slot (sweeps 2 on read it) is its own:
     * a divergence pass after it computes afresh */
    CHECK(b->div_imd2 == NULL && b->div_imd2_ready == 0, "the solve's 1 / M^2 cache released");
    CHECK(b->strain_im == NULL && b->pass_pairs_on == 0,
          "the solve's 1 / M and pair-count caches released");
    omp_set_num_threads(1);
    const sph_particles *A = a->P, *B = b->P;
    const int *act = a->active;
    size_t na = a->nactive;
    CHECK(na == b->nactive && memcmp(act, b->active, na * sizeof(int)) == 0, "same active set");
    int ok = same_bits(A->u, B->u, act, na) && same_bits(A->v, B->v, act, na);
    CHECK(ok, "%dx%d, %s, %d thread(s), %d lanes: velocities bit for bit the documented sweep's",
          nx, ny, adaptive ? "aEVP" : "fixed alpha", threads, lanes4 ? 4 : 2);
    ok = same_bits(A->s11, B->s11, act, na) && same_bits(A->s22, B->s22, act, na) &&
         same_bits(A->s12, B->s12, act, na) && same_bits(a->zeta, b->zeta, act, na);
    CHECK(ok, "%dx%d, %s, %d thread(s), %d lanes: stresses and zeta bit for bit", nx, ny,
          adaptive ? "aEVP" : "fixed alpha", threads, lanes4 ? 4 : 2);
    double umax = 0.0;
    for (size_t i = 0; i < na; i++)
        umax = fmax(umax, fabs(B->u[act[i]] - b->un[act[i]]));
    CHECK(umax > 1e-6, "the sweeps moved the ice (max |u - u_n| %g m/s)", umax);
    sph_model_free(a);
    sph_model_free(b);
}

static void check_case(int nx, int ny, int adaptive, int threads, int lanes4)
{
    check_case_n(nx, ny, adaptive, threads, lanes4, SWEEPS);
}

int main(void)
{
    /* two lanes, then four where the CPU has them (AVX2: sph_model.lanes4) */
    const int nl = sph_lanes4_supported() ? 2 : 1;
    if (nl == 1)
        printf("test_mevp_lanes: no AVX2 on this CPU: the four-lane path is not run\n");
    for (int l4 = 0; l4 < nl; l4++) {
        check_case(23, 19, 1, 1, l4); /* 437 particles: odd */
        check_case(23, 19, 0, 1, l4);
        check_case(71, 67, 1, 1, l4); /* 4757: above SPH_OMP_WORTH */
        check_case(71, 67, 1, 2, l4);
        /* stopped by the tolerance after one sweep: the residual's sums
         * then come from the solve's stop, not from its sweep */
        check_case_n(23, 19, 1, 1, l4, 1);
    }
    return check_summary("test_mevp_lanes");
}
