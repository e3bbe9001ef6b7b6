/* Viscous-plastic rheology: the analytic steady state against a coast is
 * an equilibrium of the SPH operators; converged stresses lie inside the
 * yield ellipse; the explicit solver refuses the seed's 60 s step while
 * mEVP is stable there; explicit sub-stepping works inside its limit; a
 * wall feeds no kinetic energy into ice that hits it. */
#include <math.h>
#include <string.h>

#include <gsl/gsl_errno.h>

#include <omp.h>

#include "check.h"
#include "core/model.h"
#include "scenarios.h"

/* At rest without replacement pressure the stress is -P/2 I, so in the
 * analytic steady state (PHYSICS.md s. 8) the SPH internal force per area
 * M a_int must cancel the wind stress tau, within 2 % of tau, away from
 * the wall (its reaction acts within the kernel support) and from the
 * pack edge (the kernel is truncated there: within its support). */
static void test_coast_balance(sph_kernel_kind kern, double radius, double hfac)
{
    sph_params p;
    sph_params_default(&p);
    p.physics = SPH_PHYSICS_FULL;
    p.kernel = kern;
    p.kernel_radius = radius;
    p.sml_factor = hfac;
    double wind = 9.0, tau = p.rho_a * p.Ca * wind * wind, h0 = 0.5, dx = 1000;
    coast_analytic a;
    coast_solve(&a, &p, tau, h0, 40e3);
    /* the closed form: the ridged part rises with slope 2 tau / P0 */
    CHECK_CLOSE(coast_hbar(&a, 0) - coast_hbar(&a, 1000), 2 * tau / p.P0 * 1000, 1e-6, 0,
                "analytic slope 2 tau / P0");
    coast_case c;
    CHECK(coast_setup_steady(&c, &p, dx, 6, &a, wind) == 0, "setup");
    sph_status st;
    CHECK(sph_model_init(c.model, &st) == 0, "init");
    CHECK(sph_model_diagnose(c.model, &st) == 0, "diagnose");
    sph_particles *P = sph_model_particles(c.model);
    double worst = 0;
    int n = 0;
    for (size_t k = 0; k < P->n; k++) {
        /* the wall's reaction reaches the particles within the kernel
         * support of the wall (through the mirror ghosts): excluded */
        double y = P->y[k], h = P->sml[k];
        if (y < radius * h || y > a.L - radius * h)
            continue;
        /* internal force per area M a_y must be +A tau (wind is -y) */
        double f = P->dens[k] * P->ay[k], want = tau;
        worst = fmax(worst, fabs(f - want) / tau);
        n++;
    }
    CHECK(n > 50, "interior particles %d", n);
    CHECK(worst < 0.02, "kernel %d: internal force balances the wind within 2 %% of tau: worst %.4f",
          (int)kern, worst);
    coast_free(&c);
}

/* The analytic steady state (no replacement pressure) is held by the
 * dynamic model: 12 h of mEVP at the seed's 60 s step, wind on, starting
 * at rest in the analytic state: the ice stays at rest and its mean
 * thickness matches the analytic profile within 2 % away from one
 * smoothing length of the wall and of the pack edge. */
static void test_coast_steady_state_held(void)
{
    sph_params p;
    sph_params_default(&p);
    p.physics = SPH_PHYSICS_FULL;
    p.dt = 60;
    double wind = 9.0, tau = p.rho_a * p.Ca * wind * wind;
    coast_analytic a;
    coast_solve(&a, &p, tau, 0.5, 40e3);
    coast_case c;
    CHECK(coast_setup_steady(&c, &p, 1000, 4, &a, wind) == 0, "setup");
    sph_status st;
    sph_model_init(c.model, &st);
    int steps = check_quick() ? 60 : 720, ok = 1;
    for (int s = 0; s < steps && ok; s++)
        ok = sph_model_step(c.model, &st) == 0;
    CHECK(ok, "held run: %s %g %s", st.quantity, st.value, st.what);
    sph_particles *P = sph_model_particles(c.model);
    double worst = 0;
    for (size_t k = 0; k < P->n; k++) {
        double y = P->y[k];
        if (y < P->sml[k] || y > a.L - P->sml[k])
            continue;
        double want = coast_hbar(&a, y);
        worst = fmax(worst, fabs(P->dens[k] / p.rho_i - want) / want);
    }
    const sph_budget *b = sph_model_budget(c.model);
    CHECK(worst < 0.02, "thickness profile within 2 %% after 12 h: worst %.4f", worst);
    CHECK(sqrt(2 * b->kinetic_energy / b->mass) < 0.01, "ice at rest: rms speed %g m/s",
          sqrt(2 * b->kinetic_energy / b->mass));
    coast_free(&c);
}

/* Packed ice pushed and sheared against a coast for a few hours with
 * mEVP at 60 s: stable, and the stresses lie inside the yield ellipse
 * ((sI + P/2)/(P/2))^2 + (sII/(P/(2e)))^2 <= 1 (sI, sII: mean and half
 * difference of the principal stresses, P the strength). */
static void test_yield_curve_and_mevp_stable(void)
{
    sph_params p;
    sph_params_default(&p);
    p.physics = SPH_PHYSICS_FULL;
    p.dt = 60;
    coast_case c;
    CHECK(coast_setup(&c, &p, 2000, 8, 40e3, 0.4, 15.0) == 0, "setup");
    sph_particles *P = sph_model_particles(c.model);
    lattice_set_forcing(P, 8.0, -12.0, 0, 0, 0, 0);
    sph_status st;
    sph_model_init(c.model, &st);
    int ok = 1;
    for (int s = 0; s < 240 && ok; s++)
        ok = sph_model_step(c.model, &st) == 0;
    CHECK(ok, "mEVP at 60 s is stable: %s %g %s", st.quantity, st.value, st.what);
    int outside = 0, n = 0;
    double e = p.ecc;
    for (size_t k = 0; k < P->n; k++) {
        if (P->pres[k] <= 0)
            continue;
        double sI = 0.5 * (P->s11[k] + P->s22[k]);
        double sII = sqrt(0.25 * (P->s11[k] - P->s22[k]) * (P->s11[k] - P->s22[k]) +
                          P->s12[k] * P->s12[k]);
        double Pk = P->pres[k];
        double r = pow((sI + Pk / 2) / (Pk / 2), 2) + pow(sII / (Pk / (2 * e)), 2);
        outside += sqrt(r) > 1.01;
        n++;
    }
    CHECK(n > 0 && outside <= 0.01 * n, "%d of %d particles outside the yield ellipse", outside, n);
    coast_free(&c);
}

/* The explicit solver at the seed's 60 s step and 0.02 degree (~2 km)
 * spacing is far beyond its limit dt < M h^2 / (zeta_max (1 + e^-2)):
 * refused (recoverable status naming the time step), never run. */
static void test_explicit_refused_at_60s(void)
{
    sph_params p;
    sph_params_default(&p);
    p.physics = SPH_PHYSICS_FULL;
    p.solver = SPH_SOLVER_EXPLICIT;
    p.dt = 60;
    coast_case c;
    coast_setup(&c, &p, 2000, 6, 20e3, 0.35, 10.0);
    sph_status st;
    sph_model_init(c.model, &st);
    int rc = sph_model_step(c.model, &st);
    double lim = sph_model_explicit_dt_limit(c.model);
    /* the bound from the formula: P = P0 hbar, zeta_max = P / (2 dmin), M = rho hbar */
    double nu = p.P0 / (2 * p.delta_min) * (1 + 1 / (p.ecc * p.ecc)) / p.rho_i;
    CHECK(lim < 1.0 && lim <= 2000.0 * 2000.0 / nu * 1.01, "explicit limit %g s", lim);
    CHECK(rc == SPH_STEP_RECOVERABLE && !strcmp(st.quantity, "time step") && st.limit < 1.0,
          "explicit at 60 s refused: rc %d %s %s", rc, st.quantity, st.what);
    coast_free(&c);
}

/* Inside its limit (a soft rheology: large Delta_min) the explicit solver
 * sub-steps and stays stable. */
static void test_explicit_substeps(void)
{
    sph_params p;
    sph_params_default(&p);
    p.physics = SPH_PHYSICS_FULL;
    p.solver = SPH_SOLVER_EXPLICIT;
    p.delta_min = 1e-4;
    p.dt = 60;
    coast_case c;
    coast_setup(&c, &p, 2000, 6, 20e3, 0.35, 10.0);
    sph_status st;
    sph_model_init(c.model, &st);
    int ok = 1;
    for (int s = 0; s < 30 && ok; s++)
        ok = sph_model_step(c.model, &st) == 0;
    const sph_step_stats *ss = sph_model_stats(c.model);
    CHECK(ok && ss->substeps > 1, "explicit sub-stepped (%d sub-steps): %s %s", ss->substeps,
          st.quantity, st.what);
    CHECK(ss->dt_limit_explicit * ss->substeps >= p.dt * 0.999, "sub-steps cover the step");
    coast_free(&c);
}

/* The implicit Picard + GMRES solver and mEVP iterated to convergence
 * solve the same time-discrete VP equation: at 60 s they agree to 1e-6
 * m/s (Delta_min = 1e-6, where both converge; with 2e-9 Picard converges
 * slowly, docs/dynamics.md). */
static double g_change_tol; /* model.evp.change_tol of run_solver's mEVP runs */
static long g_iterations;   /* their solver iterations, summed */
static double g_delta_min = 1e-6; /* rheology.delta_min of run_solver's runs */
static double g_jfnk_tol = 1e-9;  /* model.jfnk.tol of its jfnk runs */
static int g_expect_fail;         /* 1: run_solver lets a step fail (st kept in g_fail) */
static sph_status g_fail;

static void run_solver(sph_solver_kind solver, int its, int gc, int anderson, double *u, double *v, size_t nmax)
{
    sph_params p;
    sph_params_default(&p);
    p.physics = SPH_PHYSICS_FULL;
    p.gradient_correction = gc;
    p.dt = 60;
    p.solver = solver;
    p.evp_iterations = its;
    p.evp_anderson = anderson;
    p.evp_change_tol = g_change_tol;
    p.evp_tol = 0;
    p.implicit_tol = 1e-9;
    p.implicit_max_picard = 200;
    p.delta_min = g_delta_min;
    p.jfnk_tol = g_jfnk_tol;
    coast_case c;
    coast_setup(&c, &p, 2000, 6, 30e3, 0.4, 12.0);
    sph_particles *P = sph_model_particles(c.model);
    lattice_set_forcing(P, 6.0, -10.0, 0, 0, 0, 0);
    sph_status st;
    sph_model_init(c.model, &st);
    int ok = 1;
    g_iterations = 0;
    for (int s = 0; s < 10 && ok; s++) {
        ok = sph_model_step(c.model, &st) == 0;
        g_iterations += sph_model_stats(c.model)->iterations;
    }
    if (g_expect_fail)
        g_fail = st;
    else
        CHECK(ok, "solver %d: %s %g %s", (int)solver, st.quantity, st.value, st.what);
    for (size_t k = 0; k < P->n && (size_t)P->id[k] < nmax; k++) {
        u[P->id[k]] = P->u[k];
        v[P->id[k]] = P->v[k];
    }
    coast_free(&c);
}

/* model.solver = "jfnk": the same fixed point as converged mEVP (10 steps
 * of the packed channel, velocities within 1e-6 m/s of mEVP run to 3000
 * iterations at Delta_min 1e-6 and 3e-8 and 10000 at the default 2e-9);
 * an unconverged step is a recoverable status naming the residual; 1 and
 * 2 threads bit for bit. */
static void test_jfnk_matches_implicit(void)
{
    static double u1[200], v1[200], u2[200], v2[200], u3[200], v3[200];
    const double dmins[] = {1e-6, 3e-8, 2e-9};
    const int mevp_its[] = {3000, 3000, 10000};
    for (int c = 0; c < 3; c++) {
        g_delta_min = dmins[c];
        run_solver(SPH_SOLVER_MEVP, mevp_its[c], 0, 0, u1, v1, 200);
        run_solver(SPH_SOLVER_JFNK, 1, 0, 0, u2, v2, 200);
        double d = 0, um = 0;
        for (int k = 0; k < 90; k++) {
            d = fmax(d, hypot(u1[k] - u2[k], v1[k] - v2[k]));
            um = fmax(um, hypot(u1[k], v1[k]));
        }
        /* (the implicit solver, 200 Picard iterations per step: 1.1e-9,
         * 5.2e-6, 2.2e-6 m/s from the same mEVP runs; 4.8-22.7 s of CPU,
         * not repeated here; docs/dynamics.md, Session 11) */
        printf("jfnk at Delta_min %g: %ld Newton/Picard iterations in 10 steps, max difference %.3g m/s from "
               "mEVP at %d iterations, speeds up to %.3g\n", dmins[c], g_iterations, d, mevp_its[c], um);
        CHECK(um > 0.01 && d < 1e-6, "Delta_min %g: jfnk vs converged mEVP: max difference %.3g m/s (speeds up to %.3g)",
              dmins[c], d, um);
    }
    /* a step that does not converge is a recoverable failure naming the
     * residual: at most one Newton iteration to a tolerance of 1e-14 m/s */
    {
        sph_params p;
        sph_params_default(&p);
        p.physics = SPH_PHYSICS_FULL;
        p.dt = 60;
        p.solver = SPH_SOLVER_JFNK;
        p.jfnk_tol = 1e-14;
        p.jfnk_max_newton = 1;
        coast_case cc;
        coast_setup(&cc, &p, 2000, 6, 30e3, 0.4, 12.0);
        lattice_set_forcing(sph_model_particles(cc.model), 6.0, -10.0, 0, 0, 0, 0);
        sph_status st;
        sph_model_init(cc.model, &st);
        int rc = sph_model_step(cc.model, &st);
        CHECK(rc == SPH_STEP_RECOVERABLE && strcmp(st.quantity, "JFNK residual") == 0 && st.value > 1e-14 &&
                  st.limit == 1e-14,
              "jfnk unconverged: rc %d, %s %g (limit %g) %s", rc, st.quantity, st.value, st.limit, st.what);
        coast_free(&cc);
    }
    /* threads: the same bits */
    g_delta_min = 1e-6;
    int nt = omp_get_max_threads();
    omp_set_num_threads(1);
    run_solver(SPH_SOLVER_JFNK, 1, 0, 0, u2, v2, 200);
    omp_set_num_threads(2);
    run_solver(SPH_SOLVER_JFNK, 1, 0, 0, u3, v3, 200);
    omp_set_num_threads(nt);
    CHECK(memcmp(u2, u3, sizeof u2) == 0 && memcmp(v2, v3, sizeof v2) == 0, "jfnk: 1 and 2 threads bit-identical");
    g_delta_min = 1e-6;
}

static void test_implicit_matches_mevp(void)
{
    /* also with the kernel gradient correction, which both solvers apply
     * through their own code (the implicit one in its sparse matrices) */
    static double ui0[200], vi0[200]; /* the implicit solution without correction, reused below */
    for (int gc = 0; gc < 2; gc++) {
        static double u1[200], v1[200], u2[200], v2[200];
        run_solver(SPH_SOLVER_IMPLICIT, 1, gc, 0, u1, v1, 200);
        if (gc == 0) {
            memcpy(ui0, u1, sizeof ui0);
            memcpy(vi0, v1, sizeof vi0);
        }
        run_solver(SPH_SOLVER_MEVP, 3000, gc, 0, u2, v2, 200);
        double d = 0, um = 0;
        for (int k = 0; k < 90; k++) {
            d = fmax(d, hypot(u1[k] - u2[k], v1[k] - v2[k]));
            um = fmax(um, hypot(u2[k], v2[k]));
        }
        CHECK(um > 0.01 && d < 1e-6,
              "gradient correction %d: implicit vs converged mEVP: max difference %.3g m/s (speeds up to %.3g)",
              gc, d, um);
    }
    /* model.evp.anderson (issue 22): the accelerated iteration has the
     * same fixed point. Measured (docs/dynamics.md): depth 3 at 300
     * iterations is 1.4e-8 m/s from the implicit solution, plain mEVP
     * 1.9e-8; at 30-150 iterations neither is consistently ahead. */
    {
        static double u2[200], v2[200];
        const double *u1 = ui0, *v1 = vi0;
        run_solver(SPH_SOLVER_MEVP, 300, 0, 3, u2, v2, 200);
        double d = 0, um = 0;
        for (int k = 0; k < 90; k++) {
            d = fmax(d, hypot(u1[k] - u2[k], v1[k] - v2[k]));
            um = fmax(um, hypot(u2[k], v2[k]));
        }
        CHECK(um > 0.01 && d < 1e-6, "Anderson depth 3: implicit vs mEVP: max difference %.3g m/s (speeds up to %.3g)",
              d, um);
    }
    /* model.evp.change_tol (issue 22): the iteration stops once its
     * relative change is below the tolerance, long before the cap, and
     * the velocities are then within 1 % of the maximum speed of the
     * implicit solution (measured 0.12 % at 1e-5, 1.1 % at 1e-4: the
     * error is about 100 times the tolerance here) */
    {
        static double u2[200], v2[200];
        const double *u1 = ui0, *v1 = vi0;
        g_change_tol = 1e-5;
        run_solver(SPH_SOLVER_MEVP, 3000, 0, 0, u2, v2, 200);
        g_change_tol = 0.0;
        double d = 0, um = 0;
        for (int k = 0; k < 90; k++) {
            d = fmax(d, hypot(u1[k] - u2[k], v1[k] - v2[k]));
            um = fmax(um, hypot(u1[k], v1[k]));
        }
        CHECK(g_iterations < 10 * 3000 / 4, "evp.change_tol 1e-5: %ld iterations in 10 steps (cap 3000 each)",
              g_iterations);
        CHECK(um > 0.01 && d < 0.01 * um, "evp.change_tol 1e-5: implicit vs mEVP: max difference %.3g m/s (speeds up to %.3g)",
              d, um);
    }
}


/* Energy: packed ice moving at 0.1 m/s onto a wall with no wind, no water
 * drag and no Coriolis has no energy source, and viscous-plastic stress
 * only dissipates: the kinetic energy must never rise above its start
 * (round-off aside). With coast ghosts that kept pushing ice moving away
 * from the wall, the pack bounced off at up to 1.3 m/s. Both solvers'
 * default, aEVP, with replacement pressure (P* = 27.5e3) and without. */
static void test_wall_feeds_no_energy(int replacement)
{
    sph_params p;
    sph_params_default(&p);
    p.physics = SPH_PHYSICS_FULL;
    p.replacement_pressure = replacement;
    p.P0 = 27.5e3;
    p.Cw = 0.0;
    p.dt = 15.0;
    coast_case c;
    CHECK(coast_setup(&c, &p, 2000, 3, 60e3, 1.0, 0.0) == 0, "setup");
    sph_particles *P = sph_model_particles(c.model);
    for (size_t k = 0; k < P->n; k++)
        P->v[k] = -0.1;
    sph_status st;
    CHECK(sph_model_init(c.model, &st) == 0, "init: %s %s", st.quantity, st.what);
    double ke0 = 0.5 * 0.1 * 0.1, worst = 0.0;
    int steps = check_quick() ? 60 : 480, ok = 1;
    for (int s = 0; s < steps && ok; s++) {
        ok = sph_model_step(c.model, &st) == 0;
        const sph_budget *b = sph_model_budget(c.model);
        worst = fmax(worst, b->kinetic_energy / b->mass);
    }
    CHECK(ok, "run: %s %s", st.quantity, st.what);
    CHECK(worst <= ke0 * (1.0 + 1e-9), "replacement %d: kinetic energy per mass rose to %.3g (start %.3g)",
          replacement, worst, ke0);
    coast_free(&c);
}

int main(void)
{
    gsl_set_error_handler_off();
    test_wall_feeds_no_energy(1);
    test_wall_feeds_no_energy(0);
    test_implicit_matches_mevp();
    test_jfnk_matches_implicit();
    test_coast_balance(SPH_KERNEL_GAUSSIAN, 3.0, 1.0);
    /* compact kernels at h = 1.5 dx: at 1.3 dx their lattice gradient error
     * is 2.6-3 % (test_kernel measures it), above the 2 % asked here */
    test_coast_balance(SPH_KERNEL_WENDLAND_C2, 2.0, 1.5);
    test_coast_balance(SPH_KERNEL_CUBIC_SPLINE, 2.0, 1.5);
    test_coast_steady_state_held();
    test_yield_curve_and_mevp_stable();
    test_explicit_refused_at_60s();
    test_explicit_substeps();
    return check_summary("test_rheology");
}
