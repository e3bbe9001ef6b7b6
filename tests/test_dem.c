/* The DEM core against analytic mechanics: the restitution and contact
 * time of a linear spring-dashpot, Coulomb's sliding threshold, a bonded
 * cantilever against Euler-Bernoulli, bond breakage by eq. 9 of the seed
 * (tension and shear), the refused step, ISO 19906's pressure formula
 * written out again, and thread-count determinism. */
#include <math.h>
#include <omp.h>
#include <string.h>

#include "check.h"
#include "core/dem.h"

static void dry_params(dem_params *p)
{
    dem_params_default(p);
    p->water_density = 0.0;
    p->gravity = 0.0;
}

/* Two equal spheres head-on at +-v0: e = v_after / v_before and the
 * contact time pi / (omega_0 sqrt(1 - zeta^2)), omega_0 = sqrt(K / m*). */
static void test_restitution(double e)
{
    dem_params p;
    dry_params(&p);
    p.kn = 1.0e6;
    p.restitution = e;
    p.friction = 0.0;
    dem *d = dem_create(2, 0, &p);
    double r = 0.05, v0 = 0.5;
    dem_add_particle(d, -r - 1e-4, 0, 0, r);
    dem_add_particle(d, r + 1e-4, 0, 0, r);
    dem_set_velocity(d, 0, v0, 0, 0);
    dem_set_velocity(d, 1, -v0, 0, 0);
    double m = d->m[0], me = 0.5 * m;
    double l = log(e), zeta = -l / sqrt(M_PI * M_PI + l * l);
    double e_an = exp(-M_PI * zeta / sqrt(1.0 - zeta * zeta));
    double tc_an = M_PI / (sqrt(p.kn / me) * sqrt(1.0 - zeta * zeta));
    double dt = tc_an / 2000.0;
    sph_status st;
    double t_in = -1, t_out = -1;
    int bad = 0;
    for (int s = 0; s < 20000; s++) {
        bad |= dem_step(d, dt, &st) != SPH_STEP_OK;
        if (d->contacts > 0 && t_in < 0)
            t_in = d->time - dt;
        if (d->contacts == 0 && t_in >= 0 && t_out < 0)
            t_out = d->time - dt;
        if (t_out >= 0)
            break;
    }
    CHECK(!bad, "steps ok");
    double e_got = (d->vx[1] - d->vx[0]) / (2.0 * v0);
    CHECK_CLOSE(e_got, e_an, 0.01, 0.0, "restitution");
    CHECK_CLOSE(t_out - t_in, tc_an, 0.01, 0.0, "contact time");
    /* momentum is conserved exactly by the antisymmetric pair forces */
    CHECK(fabs(d->vx[0] + d->vx[1]) < 1e-12, "momentum %g", d->vx[0] + d->vx[1]);
    printf("restitution e=%.2f: got %.5f analytic %.5f, contact %.4g s (analytic %.4g)\n", e,
           e_got, e_an, t_out - t_in, tc_an);
    dem_free(d);
}

/* A sphere pressed on a fixed one by N, pushed sideways by T (rotation
 * held): it sticks for T < mu N and slides with a = (T - mu N)/m above. */
static void test_coulomb(double ratio)
{
    dem_params p;
    dry_params(&p);
    p.kn = 1.0e6;
    p.friction = 0.3;
    p.restitution = 0.2;
    dem *d = dem_create(2, 0, &p);
    double r = 0.5, N = 100.0, T = ratio * p.friction * N;
    dem_add_particle(d, 0, 0, 0, r);
    dem_add_particle(d, 0, 0, 2 * r - N / p.kn, r); /* at its equilibrium overlap */
    d->flags[0] = DEM_FIX_TRANSLATION | DEM_FIX_ROTATION;
    d->flags[1] = DEM_FIX_ROTATION;
    d->ext[3 * 1 + 0] = T;
    d->ext[3 * 1 + 2] = -N;
    double dt = 0.1 * dem_dt_critical(d);
    sph_status st;
    double tend = 0.2;
    long steps = (long)(tend / dt);
    int bad = 0;
    double v_half = 0.0;
    for (long s = 0; s < steps; s++) {
        bad |= dem_step(d, dt, &st) != SPH_STEP_OK;
        if (s == steps / 2)
            v_half = d->vx[1];
    }
    CHECK(!bad, "steps ok");
    double m = d->m[1];
    if (ratio < 1.0) {
        /* stuck: displacement of the order of T / K_s, far below sliding */
        double ks = p.kn * p.ks_ratio;
        CHECK(fabs(d->x[1]) < 3.0 * T / ks, "stuck: x = %g (T/Ks = %g)", d->x[1], T / ks);
    } else {
        /* acceleration over the second half, once sliding (the first
         * part builds the tangential spring up to mu N) */
        double a = (T - p.friction * N) / m;
        double a_got = (d->vx[1] - v_half) / (dt * (double)(steps - 1 - steps / 2));
        CHECK_CLOSE(a_got, a, 0.01, 0.0, "sliding acceleration");
        printf("coulomb T = %.2f mu N: sliding acceleration %.5g m s-2, (T - mu N)/m %.5g\n",
               ratio, a_got, a);
    }
    dem_free(d);
}

/* A chain of N + 1 bonded particles, the first clamped, a tip load P:
 * deflection P L^3 / (3 E I), I = pi R^4 / 4 (quasi-static with local
 * damping). */
static void test_cantilever(void)
{
    dem_params p;
    dry_params(&p);
    p.local_damping = 0.7;
    p.bond_tensile = 1e12;
    p.bond_shear = 1e12;
    int N = 12;
    double r = 0.05;
    dem *d = dem_create(N + 1, N, &p);
    for (int i = 0; i <= N; i++)
        dem_add_particle(d, 2 * r * i, 0, 0, r);
    for (int i = 0; i < N; i++)
        dem_add_bond(d, i, i + 1);
    d->flags[0] = DEM_FIX_TRANSLATION | DEM_FIX_ROTATION;
    double R = r, I = M_PI * pow(R, 4) / 4.0, L = 2 * r * N, E = p.bond_modulus;
    double P = 1.0;
    d->ext[3 * N + 2] = -P;
    double w_an = P * L * L * L / (3.0 * E * I);
    double dt = 0.5 * p.dt_safety * dem_dt_critical(d);
    sph_status st;
    double prev = 0.0;
    int settled = 0;
    int bad = 0;
    for (long s = 0; s < 400000 && !settled; s++) {
        bad |= dem_step(d, dt, &st) != SPH_STEP_OK;
        if (s % 5000 == 4999) {
            settled = fabs(d->z[N] - prev) < 1e-5 * w_an;
            prev = d->z[N];
        }
    }
    CHECK(!bad && settled, "cantilever settled");
    CHECK_CLOSE(-d->z[N], w_an, 0.05, 0.0, "cantilever tip deflection");
    printf("cantilever N=%d: tip %.6g m, Euler-Bernoulli %.6g m (%.2f %%)\n", N, -d->z[N], w_an,
           100.0 * (-d->z[N] - w_an) / w_an);
    dem_free(d);
}

/* Ramps a load on the last particle of a short clamped chain until a bond
 * breaks; returns the load at breakage and the broken bond's index. */
static double ramp_to_break(dem_params *p, int N, double r, int dir, double Pmax, int *which,
                            int *mode)
{
    dem *d = dem_create(N + 1, N, p);
    for (int i = 0; i <= N; i++)
        dem_add_particle(d, 2 * r * i, 0, 0, r);
    for (int i = 0; i < N; i++)
        dem_add_bond(d, i, i + 1);
    d->flags[0] = DEM_FIX_TRANSLATION | DEM_FIX_ROTATION;
    double dt = 0.5 * p->dt_safety * dem_dt_critical(d);
    long steps = 100000;
    sph_status st;
    double Pb = NAN;
    *which = -1;
    for (long s = 0; s < steps; s++) {
        double P = Pmax * (double)s / (double)steps;
        d->ext[3 * N + dir] = dir == 0 ? P : -P;
        dem_step(d, dt, &st);
        for (size_t b = 0; b < d->nbonds; b++)
            if (d->bonds[b].broken) {
                *which = (int)b;
                *mode = d->bonds[b].broken;
                Pb = P;
                break;
            }
        if (*which >= 0)
            break;
    }
    dem_free(d);
    return Pb;
}

static void test_bond_break(void)
{
    dem_params p;
    dry_params(&p);
    p.local_damping = 0.7;
    double r = 0.05, R = r, A = M_PI * R * R, I = M_PI * pow(R, 4) / 4.0;
    int which, mode;
    /* pure tension on two particles: T / A = sigma_t */
    p.bond_tensile = 0.6e6;
    p.bond_shear = 1e12;
    double Pb = ramp_to_break(&p, 1, r, 0, 2.0 * p.bond_tensile * A, &which, &mode);
    CHECK_CLOSE(Pb, p.bond_tensile * A, 0.02, 0.0, "tensile break load");
    CHECK(mode == 1, "tension mode %d", mode);
    printf("bond tension: broke at %.5g N, eq. 9 %.5g N\n", Pb, p.bond_tensile * A);
    /* bending of a 6-bond cantilever: the root bond, at |M| R / I = sigma_t,
     * M = P (L - r) */
    int N = 6;
    double L = 2 * r * N;
    double Pt = p.bond_tensile * I / (R * (L - r));
    Pb = ramp_to_break(&p, N, r, 2, 2.0 * Pt, &which, &mode);
    CHECK_CLOSE(Pb, Pt, 0.03, 0.0, "bending break load");
    CHECK(which == 0 && mode == 1, "root bond in tension: bond %d mode %d", which, mode);
    printf("bond bending: root bond %d broke at %.5g N, eq. 9 %.5g N\n", which, Pb, Pt);
    /* shear of one bond (transverse load, moment P r): tau = |F_s| / A
     * governs when tau_c < sigma_t / 4 */
    p.bond_tensile = 10e6;
    p.bond_shear = 1e6;
    Pb = ramp_to_break(&p, 1, r, 2, 2.0 * p.bond_shear * A, &which, &mode);
    CHECK_CLOSE(Pb, p.bond_shear * A, 0.03, 0.0, "shear break load");
    CHECK(mode == 2, "shear mode %d", mode);
    printf("bond shear: broke at %.5g N, eq. 9 %.5g N\n", Pb, p.bond_shear * A);
}

static void test_refused_step(void)
{
    dem_params p;
    dry_params(&p);
    dem *d = dem_create(2, 1, &p);
    dem_add_particle(d, 0, 0, 0, 0.05);
    dem_add_particle(d, 0.1, 0, 0, 0.05);
    dem_add_bond(d, 0, 1);
    /* 2 sqrt(m / K) written out for the bond's normal spring */
    double m = p.density * 4.0 / 3.0 * M_PI * pow(0.05, 3);
    double K = p.bond_modulus / 0.1 * M_PI * 0.05 * 0.05;
    CHECK(dem_dt_critical(d) <= 2.0 * sqrt(m / K) * (1 + 1e-12), "dt_crit %g vs %g",
          dem_dt_critical(d), 2.0 * sqrt(m / K));
    double lim = p.dt_safety * dem_dt_critical(d);
    sph_status st;
    CHECK(dem_step(d, 1.01 * lim, &st) == SPH_STEP_RECOVERABLE && st.kind == SPH_FAULT_TIMESTEP,
          "step beyond the limit refused (code %d kind %d)", st.code, st.kind);
    CHECK(d->step == 0, "nothing advanced");
    CHECK(dem_step(d, 0.99 * lim, &st) == SPH_STEP_OK, "step within the limit");
    d->s.kind = DEM_STRUCT_CONE;
    d->s.diameter = 4.0;
    d->s.neck_diameter = 5.0;
    d->s.cone_angle = 60.0;
    CHECK(dem_step(d, 0.5 * lim, &st) == SPH_STEP_FATAL && st.kind == SPH_FAULT_INVALID,
          "a neck wider than the waterline refused");
    dem_free(d);
}

/* ISO 19906 (2010) A.8.2.4.3, written out again: p = C_R (h/h1)^n (w/h)^m. */
static void test_iso(void)
{
    double h = 0.26, w = 1.6, cr = 1.8e6;
    double want = cr * pow(h, -0.5 + h / 5.0) * pow(w / h, -0.16);
    CHECK_CLOSE(dem_iso_pressure(cr, h, w), want, 1e-12, 0.0, "ISO pressure, h < 1 m");
    h = 1.5;
    w = 10.0;
    cr = 2.8e6;
    want = cr * pow(h, -0.3) * pow(w / h, -0.16);
    CHECK_CLOSE(dem_iso_force(cr, h, w), want * w * h, 1e-12, 0.0, "ISO force, h > 1 m");
    /* n is continuous at h = 1 m */
    CHECK_CLOSE(dem_iso_pressure(cr, 1.0 - 1e-9, 5.0), dem_iso_pressure(cr, 1.0, 5.0), 1e-8, 0,
                "continuity at h1");
    CHECK(isnan(dem_iso_pressure(cr, 1.0, 1.5)), "w/h < 2 outside the formula's range");
    printf("ISO 19906: h 0.26 m, w 1.6 m, C_R 1.8 MPa: p_G %.4g MPa, F %.4g kN\n",
           dem_iso_pressure(1.8e6, 0.26, 1.6) / 1e6, dem_iso_force(1.8e6, 0.26, 1.6) / 1e3);
}

/* A small sheet against a cylinder on 1 and 2 threads: bit-identical. */
static void run_small_leg(int threads, double *out_x, double *out_f, int nsteps)
{
    omp_set_num_threads(threads);
    dem_params p;
    dem_params_default(&p);
    dem *d = dem_create(2000, 6000, &p);
    double r = 0.05;
    dem_add_sheet(d, 0.0, -0.6, 16, 12, 2, r, 0.5, 0.0);
    d->s.kind = DEM_STRUCT_CYLINDER;
    d->s.x0 = 1.802;
    d->s.y0 = 0.0;
    d->s.diameter = 0.5;
    d->s.mass = 1000.0;
    d->s.stiffness = 1e6;
    d->s.damping_ratio = 0.03;
    double dt = 0.9 * p.dt_safety * dem_dt_critical(d);
    sph_status st;
    for (int s = 0; s < nsteps; s++) {
        dem_step(d, dt, &st);
        out_f[s] = d->s.fx;
    }
    memcpy(out_x, d->x, d->n * sizeof(double));
    dem_free(d);
}

static void test_threads(void)
{
    enum { NS = 3000, NP = 16 * 12 * 2 };
    static double x1[NP], x2[NP], f1[NS], f2[NS];
    double t0 = omp_get_wtime();
    run_small_leg(1, x1, f1, NS);
    double t1 = omp_get_wtime();
    run_small_leg(2, x2, f2, NS);
    printf("small leg: %.2f s on 1 thread, %.2f s on 2\n", t1 - t0, omp_get_wtime() - t1);
    CHECK(memcmp(x1, x2, sizeof x1) == 0, "positions identical on 1 and 2 threads");
    CHECK(memcmp(f1, f2, sizeof f1) == 0, "load series identical on 1 and 2 threads");
    double fbig = 0;
    for (int s = 0; s < NS; s++)
        fbig = fmax(fbig, fabs(f1[s]));
    CHECK(fbig > 0.0, "the sheet reached the leg (max load %g N)", fbig);
}

/* dt_critical is a bound: a close-packed bonded sheet floating under
 * gravity (the stiffest lattice, 12 bonds per sphere) stays intact and
 * still at dt = dt_critical (measured unstable at 1.12 dt_critical). */
static void test_stability(void)
{
    dem_params p;
    dem_params_default(&p);
    p.dt_safety = 1.0;
    dem *d = dem_create(400, 4000, &p);
    dem_add_sheet_hcp(d, 0, 0, 8, 10, 3, 0.05, 0.0, 0.0);
    double dt = dem_dt_critical(d);
    sph_status st;
    int bad = 0;
    for (int s = 0; s < 4000; s++)
        bad |= dem_step(d, dt, &st) != SPH_STEP_OK;
    double vmax = 0;
    for (size_t i = 0; i < d->n; i++)
        vmax = fmax(vmax, fabs(d->vz[i]) + fabs(d->vx[i]) + fabs(d->vy[i]));
    CHECK(!bad && d->bonds_broken_tension + d->bonds_broken_shear == 0,
          "sheet intact at dt_critical (%ld broken)",
          d->bonds_broken_tension + d->bonds_broken_shear);
    CHECK(vmax < 0.05, "no instability: max speed %g m/s", vmax);
    dem_free(d);
}

/* A sphere driven along a meridian into a fixed upward-breaking cone
 * slides up its surface: the load on the cone, per contact, is the normal
 * force N and the friction mu N up the slope, so
 *   H / V = (sin a + mu cos a) / (cos a - mu sin a)
 * (the cone's friction factor, e.g. Croasdale's xi) once sliding. */
static void test_cone_ratio(double alpha_deg, double mu)
{
    dem_params p;
    dry_params(&p);
    p.friction = mu;
    dem *d = dem_create(1, 0, &p);
    double a = alpha_deg * M_PI / 180.0, r = 0.05, gap = 1e-3, Rw = 2.0;
    dem_add_particle(d, -(Rw + (r + gap) / sin(a)), 0.0, 0.0, r);
    d->flags[0] = DEM_FIX_TRANSLATION | DEM_FIX_ROTATION;
    dem_set_velocity(d, 0, 0.2, 0.0, 0.0);
    d->s.kind = DEM_STRUCT_CONE;
    d->s.diameter = 2 * Rw;
    d->s.neck_diameter = 2.0;
    d->s.cone_angle = alpha_deg;
    d->s.z_waterline = 0.0;
    d->s.mass = 0.0; /* fixed */
    double dt = 0.5 * p.dt_safety * dem_dt_critical(d);
    sph_status st;
    int bad = 0;
    /* 6 mm of horizontal travel past the first touch */
    long steps = (long)((gap / sin(a) + 6e-3) / 0.2 / dt);
    for (long k = 0; k < steps; k++)
        bad |= dem_step(d, dt, &st) != SPH_STEP_OK;
    CHECK(!bad, "steps ok");
    double want = (sin(a) + mu * cos(a)) / (cos(a) - mu * sin(a));
    double got = d->s.fx / -d->s.fz;
    CHECK(d->s.fx > 0.0 && d->s.fz < 0.0, "pushed along the drift and down: %g %g", d->s.fx,
          d->s.fz);
    CHECK_CLOSE(got, want, 0.01, 0.0, "cone H/V");
    CHECK(fabs(d->s.fy) < 1e-9 * fabs(d->s.fx), "no transverse load");
    printf("cone %.0f deg, mu %.2f: H/V %.5f, analytic %.5f\n", alpha_deg, mu, got, want);
    dem_free(d);
}

/* The scene's choice: each threshold alone sends it to the cheap model,
 * all together to the DEM; the forcing keys win; NaN is refused. */
static void test_scene_choice(void)
{
    dem_scene_keys k = {0.5, 0.1, 0.1, DEM_CHOOSE_AUTO};
    const char *why;
    CHECK(dem_scene_choose(&k, 0.9, 0.3, 0.26, &why) == DEM_MODEL_DEM, "all above: %s", why);
    CHECK(dem_scene_choose(&k, 0.3, 0.3, 0.26, &why) == DEM_MODEL_CHEAP &&
              strstr(why, "concentration"), "loose ice: %s", why);
    CHECK(dem_scene_choose(&k, 0.9, 0.05, 0.26, &why) == DEM_MODEL_CHEAP && strstr(why, "speed"),
          "still ice: %s", why);
    CHECK(dem_scene_choose(&k, 0.9, 0.3, 0.05, &why) == DEM_MODEL_CHEAP &&
              strstr(why, "thickness"), "thin ice: %s", why);
    k.force = DEM_CHOOSE_DEM;
    CHECK(dem_scene_choose(&k, 0.0, 0.0, 0.0, &why) == DEM_MODEL_DEM && strstr(why, "forced"),
          "forced DEM: %s", why);
    k.force = DEM_CHOOSE_CHEAP;
    CHECK(dem_scene_choose(&k, 0.9, 0.3, 0.26, &why) == DEM_MODEL_CHEAP && strstr(why, "forced"),
          "forced cheap: %s", why);
    k.force = DEM_CHOOSE_AUTO;
    CHECK(dem_scene_choose(&k, NAN, 0.3, 0.26, &why) == -1, "NaN refused");
    k.min_concentration = 1.5;
    CHECK(dem_scene_choose(&k, 0.9, 0.3, 0.26, &why) == -1, "threshold out of range refused");
}

int main(void)
{
    test_restitution(0.3);
    test_restitution(0.6);
    test_restitution(0.9);
    test_coulomb(0.8);
    test_coulomb(1.5);
    test_cantilever();
    test_bond_break();
    test_refused_step();
    test_cone_ratio(45.0, 0.15);
    test_cone_ratio(60.0, 0.3);
    test_stability();
    test_iso();
    test_scene_choice();
    test_threads();
    return check_summary("test_dem");
}
