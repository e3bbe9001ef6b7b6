/* Momentum: free drift, geostrophic current, inertial oscillation,
 * conservation of momentum and mass, determinism, parameter checks.
 * Expected values come from the closed-form solutions (PHYSICS.md s. 8). */
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "core/model.h"
#include "lattice.h"

#define OMEGA 7.292e-5

static double coriolis(double lat) { return 2 * OMEGA * sin(lat * M_PI / 180); }

/* Root of (rw)^2 s^4 + 2 rw mf sin(t) s^3 + (mf)^2 s^2 - tau^2 = 0 by bisection. */
static double drift_speed(double rw, double mf, double th, double tau)
{
    double lo = 0, hi = 10;
    for (int i = 0; i < 200; i++) {
        double s = 0.5 * (lo + hi);
        double g = rw * rw * s * s * s * s + 2 * rw * mf * sin(th) * s * s * s + mf * mf * s * s -
                   tau * tau;
        if (g > 0)
            hi = s;
        else
            lo = s;
    }
    return 0.5 * (lo + hi);
}

static sph_model *single(sph_params *p, double thick, double lat)
{
    p->physics = SPH_PHYSICS_FREE_DRIFT;
    p->thermo_dt = 0;
    sph_model *m = sph_model_create(p, 1, NULL);
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, p, 1, 1, 0, 0, 2000.0, thick, 1.0, lat);
    return m;
}

static void test_free_drift(void)
{
    const double thetas[] = {0.0, 25.0};
    const double thicks[] = {0.1, 0.2, 0.5, 1.0, 2.0};
    for (int a = 0; a < 2; a++)
        for (int b = 0; b < 5; b++) {
            sph_params p;
            sph_params_default(&p);
            p.rho_i = 917.0;
            p.turn_water = thetas[a];
            double lat = 40.6, h = thicks[b];
            sph_model *m = single(&p, h, lat);
            sph_particles *P = sph_model_particles(m);
            double wind = 10.0; /* towards north-east */
            double ua = wind * cos(0.3), va = wind * sin(0.3);
            lattice_set_forcing(P, ua, va, 0, 0, 0, 0);
            sph_status st;
            CHECK(sph_model_init(m, &st) == 0, "init");
            int ok = 1;
            for (int s = 0; s < 4000 && ok; s++)
                ok = sph_model_step(m, &st) == 0;
            CHECK(ok, "step %ld: %s %s", st.step, st.quantity, st.what);
            double rw = p.rho_w * p.Cw, mf = p.rho_i * h * coriolis(lat);
            double tau = p.rho_a * p.Ca * wind * wind;
            double th = thetas[a] * M_PI / 180;
            double s = drift_speed(rw, mf, th, tau);
            /* u_r = tau / (rw s e^{i th} + i m f): angle relative to the wind */
            double dre = rw * s * cos(th), dim = rw * s * sin(th) + mf;
            double ang = -atan2(dim, dre) * 180 / M_PI;
            double speed = hypot(P->u[0], P->v[0]);
            double got_ang = (atan2(P->v[0], P->u[0]) - 0.3) * 180 / M_PI;
            CHECK_CLOSE(speed, s, 1e-3, 0, "free drift speed");
            CHECK_CLOSE(got_ang, ang, 0, 0.05, "free drift turning angle (deg)");
            if (a == 0 && b == 1) /* PHYSICS.md cross-check: 0.1663 m/s, 1.06 deg right */
                CHECK(fabs(s - 0.1663) < 2e-4 && fabs(ang + 1.06) < 0.01,
                      "cross-check s=%g ang=%g", s, ang);
            if (a == 1 && b == 1)
                CHECK(fabs(s - 0.1656) < 2e-4 && fabs(ang + 25.96) < 0.01,
                      "cross-check s=%g ang=%g", s, ang);
            sph_model_free(m);
        }
}

/* With the tilt balancing the current geostrophically, the relative
 * velocity u_r = u - U_w obeys du_r/dt = -f k x u_r - c |u_r| u_r, so
 * |u_r| = s0 / (1 + c s0 t) exactly, c = rho_w C_w / (rho_i h); and
 * ice moving with the water stays with it. */
static void test_geostrophic_current(void)
{
    double lat = 40.6, f = coriolis(lat), uw = 0.3, vw = -0.2, h = 0.5;
    for (int start_with_water = 0; start_with_water < 2; start_with_water++) {
        sph_params p;
        sph_params_default(&p);
        sph_model *m = single(&p, h, lat);
        sph_particles *P = sph_model_particles(m);
        lattice_set_forcing(P, 0, 0, uw, vw, f * vw / p.gravity, -f * uw / p.gravity);
        if (start_with_water) {
            P->u[0] = uw;
            P->v[0] = vw;
        }
        sph_status st;
        sph_model_init(m, &st);
        int steps = 96 * 60;
        for (int s = 0; s < steps; s++)
            sph_model_step(m, &st);
        if (start_with_water) {
            CHECK_CLOSE(P->u[0], uw, 1e-6, 0, "ice moves with the water (u)");
            CHECK_CLOSE(P->v[0], vw, 1e-6, 0, "ice moves with the water (v)");
        } else {
            double c = p.rho_w * p.Cw / (p.rho_i * h), s0 = hypot(uw, vw);
            double t = steps * p.dt, want = s0 / (1 + c * s0 * t);
            CHECK_CLOSE(hypot(P->u[0] - uw, P->v[0] - vw), want, 0.02, 0,
                        "relative speed decays as s0/(1 + c s0 t)");
        }
        sph_model_free(m);
    }
}

static void test_inertial(void)
{
    sph_params p;
    sph_params_default(&p);
    p.Ca = p.Cw = 0.0;
    p.dt = 60.0;
    double lat = 40.6, f = coriolis(lat);
    sph_model *m = single(&p, 1.0, lat);
    sph_particles *P = sph_model_particles(m);
    P->u[0] = 0.1;
    sph_status st;
    sph_model_init(m, &st);
    double prev = P->u[0], t = 0, first = -1, last = -1, maxdev = 0;
    int crossings = 0;
    for (int s = 0; s < 96 * 60; s++) {
        sph_model_step(m, &st);
        t += p.dt;
        double u = P->u[0];
        if (prev > 0 && u <= 0) {
            double tc = t - p.dt * u / (u - prev);
            if (first < 0)
                first = tc;
            else
                crossings++;
            last = tc;
        }
        prev = u;
        maxdev = fmax(maxdev, fabs(hypot(P->u[0], P->v[0]) - 0.1) / 0.1);
    }
    double period = (last - first) / crossings;
    CHECK_CLOSE(period, 2 * M_PI / f, 1e-4, 0, "inertial period");
    CHECK_CLOSE(2 * M_PI / f / 3600, 18.39, 0, 0.01, "inertial period at 40.6 N (h)");
    CHECK(maxdev < 1e-6, "speed conserved over 96 h: max relative change %g", maxdev);
    sph_model_free(m);
}

static sph_model *packed(sph_params *p, int nx, double dx)
{
    p->thermo_dt = 0;
    sph_model *m = sph_model_create(p, (size_t)(nx * nx), NULL);
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, p, nx, nx, 0, 0, dx, 1.0, 1.0, 40.6);
    srand(3);
    for (size_t k = 0; k < P->n; k++) {
        P->x[k] += 0.1 * dx * (rand() / (double)RAND_MAX - 0.5);
        P->y[k] += 0.1 * dx * (rand() / (double)RAND_MAX - 0.5);
        P->u[k] = 0.05 * (rand() / (double)RAND_MAX - 0.5);
        P->v[k] = 0.05 * (rand() / (double)RAND_MAX - 0.5);
    }
    return m;
}

static void test_conservation(int gradient_correction)
{
    sph_params p;
    sph_params_default(&p);
    p.physics = SPH_PHYSICS_FULL;
    p.gradient_correction = gradient_correction;
    sph_model *m = packed(&p, 15, 2000);
    sph_particles *P = sph_model_particles(m);
    sph_status st;
    CHECK(sph_model_init(m, &st) == 0, "init");
    CHECK(sph_model_diagnose(m, &st) == 0, "diagnose");
    double sx = 0, sy = 0, ax = 0, ay = 0;
    for (size_t k = 0; k < P->n; k++) {
        sx += P->mass[k] * P->ax[k];
        sy += P->mass[k] * P->ay[k];
        ax += fabs(P->mass[k] * P->ax[k]);
        ay += fabs(P->mass[k] * P->ay[k]);
    }
    CHECK(ax > 0 && fabs(sx) < 1e-12 * ax, "internal forces sum to zero (x): %g of %g", sx, ax);
    CHECK(ay > 0 && fabs(sy) < 1e-12 * ay, "internal forces sum to zero (y): %g of %g", sy, ay);
    /* mass is conserved exactly by the dynamics */
    lattice_set_forcing(P, 0, -10, 0.1, 0, 0, 0);
    double m0 = 0;
    for (size_t k = 0; k < P->n; k++)
        m0 += P->mass[k];
    int ok = 1;
    for (int s = 0; s < 30 && ok; s++)
        ok = sph_model_step(m, &st) == 0;
    CHECK(ok, "step: %s %s", st.quantity, st.what);
    double m1 = 0;
    for (size_t k = 0; k < P->n; k++)
        m1 += P->mass[k];
    CHECK_CLOSE(m1, m0, 1e-14, 0, "mass conserved");
    sph_model_free(m);
}

static void run_threads(int threads, sph_particles *out)
{
    omp_set_num_threads(threads);
    sph_params p;
    sph_params_default(&p);
    p.physics = SPH_PHYSICS_FULL;
    p.evp_iterations = 20;
    /* above the model's threading threshold (4096 particles) */
    sph_model *m = packed(&p, 66, 2000);
    sph_particles *P = sph_model_particles(m);
    lattice_set_forcing(P, 3, -9, 0.05, 0.1, 0, 0);
    sph_status st;
    sph_model_init(m, &st);
    for (int s = 0; s < 100; s++)
        sph_model_step(m, &st);
    out->n = P->n;
    memcpy(out->x, P->x, P->n * sizeof(double));
    memcpy(out->y, P->y, P->n * sizeof(double));
    memcpy(out->u, P->u, P->n * sizeof(double));
    memcpy(out->v, P->v, P->n * sizeof(double));
    memcpy(out->thick, P->thick, P->n * sizeof(double));
    sph_model_free(m);
}

static void test_determinism(void)
{
    sph_particles *a = sph_particles_create(66 * 66, 1), *b = sph_particles_create(66 * 66, 1);
    run_threads(1, a);
    run_threads(2, b);
    size_t n = a->n;
    CHECK(a->n == b->n, "same count");
    int same = !memcmp(a->x, b->x, n * 8) && !memcmp(a->y, b->y, n * 8) &&
               !memcmp(a->u, b->u, n * 8) && !memcmp(a->v, b->v, n * 8) &&
               !memcmp(a->thick, b->thick, n * 8);
    CHECK(same, "1 and 2 threads give bit-identical states after 100 steps");
    sph_particles_free(a);
    sph_particles_free(b);
}

/* Auto time stepping: the chosen step divides the interval it must divide,
 * is no longer than 0.6 of the measured stable step (half with
 * replacement pressure; docs/bench.md: the
 * adaptive-EVP bound 0.2 s/m of spacing, the plastic-wave Courant number
 * 0.15 with replacement pressure) and than f dt = 0.1 at the poles, and is
 * the largest such step; the model accepts it and refuses a step beyond
 * the stable one. */
static void test_auto_dt(void)
{
    const double two_omega = 2.0 * 7.292e-5;
    const double spacings[] = {500.0, 1000.0, 2224.0, 5000.0, 20000.0};
    const double bases[] = {600.0, 3600.0, 900.0};
    for (int form = 0; form < 3; form++)
        for (size_t i = 0; i < sizeof spacings / sizeof spacings[0]; i++)
            for (size_t j = 0; j < sizeof bases / sizeof bases[0]; j++) {
                sph_params p;
                sph_params_default(&p);
                double stable;
                if (form == 0) { /* adaptive EVP, seed pressure */
                    stable = 0.2 * spacings[i];
                } else if (form == 1) { /* replacement pressure, Hibler's P* */
                    p.pressure_form = SPH_PRESSURE_HIBLER;
                    p.P0 = 27.5e3;
                    p.replacement_pressure = 1;
                    double k = 0.5 * (1.0 + sqrt(1.0 + 1.0 / (p.ecc * p.ecc)));
                    stable = fmin(0.2 * spacings[i], 0.15 * spacings[i] / sqrt(k * p.P0 / p.rho_i));
                } else { /* free drift: only the Coriolis bound */
                    p.physics = SPH_PHYSICS_FREE_DRIFT;
                    stable = HUGE_VAL;
                }
                double got_stable = sph_params_stable_dt(&p, spacings[i], NULL);
                CHECK(isinf(stable) ? isinf(got_stable) : fabs(got_stable - stable) < 1e-9 * stable,
                      "stable step form %d, %g m: %g (want %g)", form, spacings[i], got_stable, stable);
                double bound = fmin((form == 1 ? 0.5 : 0.6) * stable, 0.1 / two_omega);
                double dt = sph_params_auto_dt(&p, spacings[i], bases[j], NULL);
                double n = bases[j] / dt;
                CHECK(fabs(n - round(n)) < 1e-9 && n >= 1.0, "auto dt %g divides %g", dt, bases[j]);
                CHECK(dt <= bound * (1 + 1e-12), "auto dt %g <= bound %g (form %d, %g m)", dt, bound, form,
                      spacings[i]);
                CHECK(round(n) == 1.0 || bases[j] / (round(n) - 1.0) > bound,
                      "auto dt %g is the largest divisor of %g under %g", dt, bases[j], bound);
            }
    /* the model takes the auto step and refuses a step beyond the stable one */
    sph_params p;
    sph_params_default(&p);
    p.thermo_dt = 0;
    p.physics = SPH_PHYSICS_FULL;
    for (int beyond = 0; beyond < 2; beyond++) {
        p.dt = beyond ? 1.05 * 0.2 * 1000.0 : sph_params_auto_dt(&p, 1000.0, 600.0, NULL);
        sph_model *m = sph_model_create(&p, 16, NULL);
        sph_particles *P = sph_model_particles(m);
        lattice_fill(P, &p, 4, 4, 0, 0, 1000, 0.9, 1.0, 40);
        sph_status st;
        int rc = sph_model_init(m, &st);
        if (beyond)
            CHECK(rc == SPH_STEP_RECOVERABLE && !strcmp(st.quantity, "time step"),
                  "dt %g s beyond the stable 200 s refused (rc %d)", p.dt, rc);
        else
            CHECK(rc == SPH_STEP_OK && fabs(p.dt - 120.0) < 1e-9, "auto dt %g s (want 120: 600 / 5) accepted (rc %d)",
                  p.dt, rc);
        CHECK(fabs(sph_model_spacing(m) - 1000.0) < 1e-6, "spacing %g m", sph_model_spacing(m));
        sph_model_free(m);
    }
}

static void test_bad_parameters(void)
{
    sph_params p;
    sph_params_default(&p);
    const char *name;
    double lo, hi;
    CHECK(sph_params_check(&p, &name, &lo, &hi) == 0, "defaults valid");
    p.dt = -1;
    CHECK(sph_params_check(&p, &name, &lo, &hi) != 0 && !strcmp(name, "dt") && lo > 0,
          "negative dt rejected naming dt");
    sph_params_default(&p);
    p.thermo_dt = 0;
    sph_model *m = sph_model_create(&p, 4, NULL);
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, &p, 2, 2, 0, 0, 1000, 0.5, 1.0, 40);
    P->conc[2] = 1.5;
    sph_status st;
    CHECK(sph_model_init(m, &st) == SPH_STEP_FATAL && !strcmp(st.quantity, "concentration"),
          "concentration 1.5 rejected");
    P->conc[2] = 0.5;
    P->thick[1] = -0.1;
    CHECK(sph_model_init(m, &st) == SPH_STEP_FATAL && !strcmp(st.quantity, "thickness"),
          "negative thickness rejected");
    P->thick[1] = 0.5;
    P->sml[0] = 0;
    P->sml0[0] = 0;
    CHECK(sph_model_init(m, &st) == SPH_STEP_FATAL && !strcmp(st.quantity, "smoothing length"),
          "zero smoothing length rejected");
    sph_model_free(m);
}

int main(void)
{
    test_auto_dt();
    test_free_drift();
    test_geostrophic_current();
    test_inertial();
    test_conservation(0);
    test_conservation(1); /* the corrected gradient stays antisymmetric */
    test_determinism();
    test_bad_parameters();
    return check_summary("test_dynamics");
}
