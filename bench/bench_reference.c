/* Reference problems with known answers (issue 7), one CSV row per run
 * (bench_common.h): error against the analytic / closed-form answer and
 * the CPU time it cost.
 *
 *  free_drift  one particle, 10 m/s wind, 0.2 m ice, 40.6 N, 24 h; closed
 *              form of PHYSICS.md s. 8 (quartic in the speed). err: relative
 *              speed error; err2: turning-angle error (deg). vs dt, theta_w.
 *  coast       1-D ice against a coast (tests/scenarios.h), seed pressure
 *              P0 = 1e4 with replacement pressure, 10 m/s onshore wind, 1 m
 *              ice filling 100 km, 4 model days. err: the largest relative
 *              error of edge position, ridged-zone length and wall
 *              thickness (the R300 measures of tests/test_r300.c); err2:
 *              edge position error (m); err3: kinetic energy per mass at the end
 *              (m^2/s^2, how far from rest). vs spacing, kernel, solver,
 *              iterations, dt.
 *  stefan      thermo column, fresh ice 0.1 m, Ts = -20 +- 10 C, 30 days,
 *              100 identical columns (CPU measurable). err: relative error
 *              vs Stefan's law (multi-layer with c0 = 1, Stefan's own
 *              assumption; the zero-layer is Stefan exactly); err2:
 *              multi-layer with physical c0 vs the quasi-steady law with
 *              heat capacity. vs model, layers, dt.
 *  disc        ice disc (R 20 km, A 0.9, h 0.5 m) carried by a solid-body
 *              rotating current (one revolution in 96 h, rotation centre
 *              60 km from the disc centre), Ca = 0, Cw = 0.1 (ice follows
 *              the water), no Coriolis, the sea surface tilted in
 *              cyclostrophic balance with the current (the water's own
 *              centripetal pressure gradient), 96 h; SPH (free drift) and the grid
 *              baseline (upwind, van Leer, superbee). err: 10-90 % edge
 *              width (m) from area-equivalent radii of c >= 0.09 and
 *              c >= 0.81 on the output grid; err2: centre position error
 *              (m); err3: IIEE (km^2) against the analytic disc
 *              (verify_compute, 15 %). Then "disc_equal_cpu" rows: the
 *              upwind grid's width at each SPH run's CPU time (log-log
 *              interpolation between grid runs) over the SPH width.
 *
 * Usage: bench_reference [problem...] (default all; BENCH_QUICK=1 shrinks). */
#include <omp.h>

#include "bench_common.h"
#include "core/model.h"
#include "core/thermo.h"
#include "io/edge.h"
#include "io/verify.h"
#include "../tests/lattice.h"
#include "../tests/scenarios.h"
#include "grid_baseline.c"

#define OMEGA_E 7.292e-5

/* ------------------------------------------------------------ free drift */

typedef struct drift_case {
    double dt, theta_w;
} drift_case;

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

static void run_drift(const void *arg, bench_row *r)
{
    const drift_case *c = arg;
    sph_params p;
    sph_params_default(&p);
    p.rho_i = 917.0;
    p.turn_water = c->theta_w;
    p.physics = SPH_PHYSICS_FREE_DRIFT;
    p.thermo_dt = 0;
    p.dt = c->dt;
    double lat = 40.6, h = 0.2, wind = 10.0;
    sph_model *m = sph_model_create(&p, 1, NULL);
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, &p, 1, 1, 0, 0, 2000.0, h, 1.0, lat);
    lattice_set_forcing(P, wind * cos(0.3), wind * sin(0.3), 0, 0, 0, 0);
    sph_status st;
    sph_model_init(m, &st);
    long steps = (long)ceil(24 * 3600.0 / c->dt);
    double c0 = bench_cpu(), w0 = bench_wall();
    for (long s = 0; s < steps; s++)
        if (sph_model_step(m, &st) != 0) {
            snprintf(r->status, sizeof r->status, "fatal:%s", st.quantity);
            break;
        }
    r->cpu_s = bench_cpu() - c0;
    r->wall_s = bench_wall() - w0;
    double rw = p.rho_w * p.Cw, mf = p.rho_i * h * 2 * OMEGA_E * sin(lat * M_PI / 180);
    double tau = p.rho_a * p.Ca * wind * wind, th = c->theta_w * M_PI / 180;
    double s = drift_speed(rw, mf, th, tau);
    double ang = -atan2(rw * s * sin(th) + mf, rw * s * cos(th)) * 180 / M_PI;
    double speed = hypot(P->u[0], P->v[0]);
    double got = (atan2(P->v[0], P->u[0]) - 0.3) * 180 / M_PI;
    r->err_name[0] = "speed_rel_err";
    r->err[0] = fabs(speed - s) / s;
    r->err_name[1] = "angle_err_deg";
    r->err[1] = fabs(got - ang);
    sph_model_free(m);
}

static void problem_drift(void)
{
    const double dts[] = {1, 10, 60, 300, 1800, 3600};
    for (int a = 0; a < 2; a++)
        for (int i = 0; i < 6; i++) {
            drift_case c = {dts[i], a ? 25.0 : 0.0};
            char cfg[160];
            snprintf(cfg, sizeof cfg, "dt=%g;theta_w=%g", c.dt, c.theta_w);
            bench_run_forked("free_drift", run_drift, &c, "sph_single_particle", cfg);
        }
}

/* ----------------------------------------------------------------- coast */

typedef struct coast_cfg {
    double dx, dt, days;
    sph_kernel_kind kernel;
    sph_solver_kind solver;
    int iterations, adaptive;
    int gc; /* model.gradient_correction */
} coast_cfg;

static void run_coast(const void *arg, bench_row *r)
{
    const coast_cfg *c = arg;
    sph_params p;
    sph_params_default(&p);
    p.replacement_pressure = 1;
    p.physics = SPH_PHYSICS_FULL;
    p.dt = c->dt;
    p.kernel = c->kernel;
    p.sml_factor = c->kernel == SPH_KERNEL_GAUSSIAN ? 1.0 : 1.3;
    p.solver = c->solver;
    p.evp_iterations = c->iterations;
    p.evp_adaptive = c->adaptive;
    p.gradient_correction = c->gc;
    double L0 = 100e3, h0 = 1.0, wind = 10.0;
    coast_case cc;
    if (coast_setup(&cc, &p, c->dx, 5, L0, h0, wind) != 0) {
        snprintf(r->status, sizeof r->status, "setup_failed");
        return;
    }
    coast_analytic a;
    coast_solve(&a, &p, cc.tau, h0, L0);
    sph_status st;
    if (sph_model_init(cc.model, &st) != 0) { /* outside the measured envelope */
        snprintf(r->status, sizeof r->status, "refused:%s", st.quantity);
        coast_free(&cc);
        return;
    }
    long steps = (long)ceil(c->days * 86400.0 / c->dt);
    double c0 = bench_cpu(), w0 = bench_wall();
    long done = coast_run(&cc, steps, 0.0, &st);
    r->cpu_s = bench_cpu() - c0;
    r->wall_s = bench_wall() - w0;
    r->err_name[0] = "steady_max_rel_err";
    r->err_name[1] = "edge_err_m";
    r->err_name[2] = "ke_per_mass";
    if (done < 0) {
        snprintf(r->status, sizeof r->status, "%s:%s", st.code < 0 ? "fatal" : "recoverable",
                 st.quantity);
        if (st.code > 0 && strstr(st.what, "explicit")) {
            r->err[1] = st.limit;
            r->err_name[1] = "explicit_dt_limit_s";
        }
        coast_free(&cc);
        return;
    }
    /* The R300 measures (tests/scenarios.h, coast_measure_ridged): edge,
     * ridged-zone length and wall thickness from a line through the
     * ridged particles outside the wall's kernel support. */
    coast_measured ms;
    coast_measure_ridged(&cc, &p, c->dx * p.sml_factor, &ms);
    double hwall = a.h0 + a.tau / (a.k * a.P0) * a.Lr;
    double e_edge = fabs(ms.edge - a.L) / a.L, e_lr = fabs(ms.Lr - a.Lr) / a.Lr,
           e_hw = fabs(ms.hwall - hwall) / hwall;
    r->err[0] = isfinite(e_lr) && isfinite(e_hw) ? fmax(e_edge, fmax(e_lr, e_hw)) : NAN;
    r->err[1] = fabs(ms.edge - a.L);
    const sph_budget *b = sph_model_budget(cc.model);
    r->err[2] = b->kinetic_energy / b->mass;
    coast_free(&cc);
}

static void problem_coast(void)
{
    int q = bench_quick();
    double days = q ? 2 : 4;
    /* dt inside the replacement-pressure envelope (plastic-wave Courant
     * number <= 0.15: 87 s at 2 km for P0 = 1e4) unless marked outside */
    coast_cfg base = {2000, 60, days, SPH_KERNEL_GAUSSIAN, SPH_SOLVER_MEVP, 120, 1, 0};
    coast_cfg list[20];
    int n = 0;
    list[n++] = base;
    coast_cfg c = base;
    c.dx = 4000, c.dt = 120;
    list[n++] = c;
    if (!q) {
        c = base, c.dx = 1000, c.dt = 30, list[n++] = c;
        c = base, c.kernel = SPH_KERNEL_WENDLAND_C2, list[n++] = c;
        c = base, c.iterations = 50, list[n++] = c;
        c = base, c.iterations = 300, list[n++] = c;
        c = base, c.dt = 30, list[n++] = c;
        c = base, c.dt = 120, list[n++] = c; /* outside: refused */
        c = base, c.dt = 300, list[n++] = c; /* outside: refused */
        c = base, c.adaptive = 0, list[n++] = c;
        c = base, c.adaptive = 0, c.iterations = 300, list[n++] = c;
        c = base, c.solver = SPH_SOLVER_EXPLICIT, list[n++] = c;
        /* the kernel gradient correction (method suffix _gc) */
        c = base, c.gc = 1, list[n++] = c;
        c = base, c.gc = 1, c.iterations = 300, list[n++] = c;
        c = base, c.gc = 1, c.dx = 4000, c.dt = 120, list[n++] = c;
        c = base, c.gc = 1, c.kernel = SPH_KERNEL_WENDLAND_C2, list[n++] = c;
    }
    for (int i = 0; i < n; i++) {
        char cfg[160], meth[64];
        c = list[i];
        snprintf(meth, sizeof meth, "sph_%s_%s%s",
                 c.solver == SPH_SOLVER_EXPLICIT ? "explicit" : c.adaptive ? "aevp" : "mevp",
                 c.kernel == SPH_KERNEL_GAUSSIAN ? "gaussian" : "wendland", c.gc ? "_gc" : "");
        snprintf(cfg, sizeof cfg, "dx=%g;dt=%g;iter=%d;days=%g", c.dx, c.dt, c.iterations, c.days);
        bench_run_forked("coast", run_coast, &c, meth, cfg);
    }
}

/* ---------------------------------------------------------------- stefan */

typedef struct stefan_cfg {
    int multi, layers;
    double dt;
} stefan_cfg;

static void run_stefan(const void *arg, bench_row *r)
{
    const stefan_cfg *c = arg;
    sph_thermo_params p, pc;
    sph_thermo_params_default(&p);
    p.salinity_max = 0.0;
    p.ocean_salinity = 0.0;
    p.nlayers = c->layers;
    pc = p;
    pc.c0 = 1.0; /* Stefan's assumption: no heat capacity */
    sph_column_solver *s = sph_column_solver_create();
    sph_column_forcing f;
    sph_column_forcing_default(&f);
    f.fw = 0.0;
    const double h0 = 0.1, k = 2.03, rho = 917.0, L = 3.34e5, c0 = 2106.0;
    const double Ste = c0 * 20.0 / L;
    enum { NCOL = 100 };
    static sph_column col[NCOL], colc[NCOL];
    for (int i = 0; i < NCOL; i++) {
        sph_column_init(&p, &col[i], h0, 0.0, -20.0);
        sph_column_init(&pc, &colc[i], h0, 0.0, -20.0);
    }
    double integral = 0.0, t = 0.0, T = 30 * 86400.0;
    sph_column_result res;
    double cpu = 0, wall = 0;
    while (t < T - 1e-6) {
        double Ts = -20.0 + 10.0 * sin(2 * M_PI * t / (240.0 * 3600.0));
        f.tsurf_prescribed = Ts;
        double c1 = bench_cpu(), w1 = bench_wall();
        for (int i = 0; i < NCOL; i++) {
            if (c->multi) {
                sph_column_step_multi_layer(&p, &col[i], &f, c->dt, s, &res);
                sph_column_step_multi_layer(&pc, &colc[i], &f, c->dt, s, &res);
            } else {
                sph_column_step_zero_layer(&p, &col[i], &f, c->dt, s, &res);
            }
        }
        cpu += bench_cpu() - c1;
        wall += bench_wall() - w1;
        integral += (0.0 - Ts) * c->dt;
        t += c->dt;
    }
    r->cpu_s = cpu;
    r->wall_s = wall;
    double hs = sqrt(h0 * h0 + 2 * k * integral / (rho * L));
    double hq = sqrt(h0 * h0 + 2 * k * integral / (rho * L * (1 + Ste / 2)));
    r->err_name[0] = "rel_err_vs_stefan";
    r->err[0] = fabs((c->multi ? colc[0].thick : col[0].thick) - hs) / hs;
    r->err_name[1] = "rel_err_vs_heatcap_law";
    r->err[1] = c->multi ? fabs(col[0].thick - hq) / hq : NAN;
    r->err_name[2] = "thickness_m";
    r->err[2] = col[0].thick;
    sph_column_solver_free(s);
}

static void problem_stefan(void)
{
    const double dts[] = {600, 3600, 21600};
    const int layers[] = {2, 4, 7, 10};
    for (int d = 0; d < 3; d++) {
        stefan_cfg z = {0, 1, dts[d]};
        char cfg[160];
        snprintf(cfg, sizeof cfg, "layers=0;dt=%g", dts[d]);
        bench_run_forked("stefan", run_stefan, &z, "zero_layer", cfg);
        for (int l = 0; l < 4; l++) {
            if (bench_quick() && layers[l] != 7)
                continue;
            stefan_cfg c = {1, layers[l], dts[d]};
            snprintf(cfg, sizeof cfg, "layers=%d;dt=%g", layers[l], dts[d]);
            bench_run_forked("stefan", run_stefan, &c, "multi_layer", cfg);
        }
    }
}

/* ------------------------------------------------------------------ disc */

#define DISC_R 20e3
#define DISC_XC 60e3 /* disc centre; rotation centre at the origin */
#define DISC_A 0.9
#define DISC_H 0.5
#define DISC_T (96 * 3600.0)
static const double disc_omega = 2 * M_PI / (96 * 3600.0);

static void rot_velocity(double x, double y, double t, void *ctx, double *u, double *v)
{
    (void)t, (void)ctx;
    *u = -disc_omega * y;
    *v = disc_omega * x;
}

/* Measurement grid: 250 m over the analytic final disc +- 40 km. */
#define MG_DX 250.0
#define MG_N 320
static void disc_final_centre(double *xc, double *yc)
{
    *xc = DISC_XC * cos(disc_omega * DISC_T);
    *yc = DISC_XC * sin(disc_omega * DISC_T);
}

/* Width, centre error and IIEE from a concentration field on a square grid
 * (n x n, spacing dx, cell (0,0) centred at (x0 + dx/2, y0 + dx/2)). */
static void disc_measure(const double *conc, int n, double x0, double y0, double dx, bench_row *r)
{
    double a10 = 0, a90 = 0, mx = 0, my = 0, ms = 0;
    double xc, yc;
    disc_final_centre(&xc, &yc);
    double *obs = malloc(sizeof(double) * n * n);
    double *fc = malloc(sizeof(double) * n * n);
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            double c = conc[j * n + i];
            if (!isfinite(c))
                c = 0;
            double x = x0 + (i + 0.5) * dx, y = y0 + (j + 0.5) * dx;
            a10 += c >= 0.1 * DISC_A;
            a90 += c >= 0.9 * DISC_A;
            mx += c * x;
            my += c * y;
            ms += c;
            obs[j * n + i] = hypot(x - xc, y - yc) <= DISC_R ? DISC_A : 0.0;
            fc[j * n + i] = c;
        }
    double area = dx * dx;
    r->err_name[0] = "edge_width_10_90_m";
    r->err[0] = sqrt(a10 * area / M_PI) - sqrt(a90 * area / M_PI);
    r->err_name[1] = "centre_err_m";
    r->err[1] = hypot(mx / ms - xc, my / ms - yc);
    /* IIEE with the products' verify_compute: the plane mapped onto a
     * lon/lat grid at the equator (x = R lon, y = R lat; the cell areas
     * differ from dx^2 by cos(lat) < 1e-4 relative here) */
    prod_grid g;
    double deg = 180.0 / (M_PI * PROD_EARTH_RADIUS_M);
    g.nlon = g.nlat = n;
    g.dlon = g.dlat = dx * deg;
    g.lon0 = (x0 + 0.5 * dx) * deg;
    g.lat0 = (y0 - yc + 0.5 * dx) * deg; /* centred on the equator */
    verify_scores vs;
    sph_error err;
    memset(&err, 0, sizeof err);
    r->err_name[2] = "iiee_km2";
    if (verify_compute(&g, fc, obs, NULL, NULL, 0.15, &vs, &err) == 0)
        r->err[2] = vs.iiee_km2;
    free(obs);
    free(fc);
}

typedef struct disc_cfg {
    int grid;          /* 0 SPH, 1 grid baseline */
    double dx, dt;     /* spacing; dt (SPH) or CFL number (grid) */
    sph_kernel_kind kernel;
    grid_scheme scheme;
} disc_cfg;

static void run_disc_sph(const disc_cfg *c, bench_row *r)
{
    sph_params p;
    sph_params_default(&p);
    p.physics = SPH_PHYSICS_FREE_DRIFT;
    p.Ca = 0.0;
    p.Cw = 0.1;
    p.coriolis = 0;
    p.thermo_dt = 0;
    p.dt = c->dt;
    p.kernel = c->kernel;
    p.sml_factor = c->kernel == SPH_KERNEL_GAUSSIAN ? 1.0 : 1.3;
    int side = (int)ceil(2 * DISC_R / c->dx) + 2;
    sph_model *m = sph_model_create(&p, (size_t)side * side, NULL);
    sph_particles *P = sph_model_particles(m);
    size_t n = 0;
    for (int j = 0; j < side; j++)
        for (int i = 0; i < side; i++) {
            double x = DISC_XC + (i - (side - 1) / 2.0) * c->dx;
            double y = (j - (side - 1) / 2.0) * c->dx;
            if (hypot(x - DISC_XC, y) > DISC_R - 1e-9)
                continue;
            size_t k0 = P->n;
            lattice_fill(P, &p, 1, 1, x, y, c->dx, DISC_H, DISC_A, 40.0);
            rot_velocity(x, y, 0, NULL, &P->u[k0], &P->v[k0]);
            n++;
        }
    sph_status st;
    sph_model_init(m, &st);
    long steps = (long)ceil(DISC_T / c->dt - 1e-9);
    double c0 = bench_cpu(), w0 = bench_wall();
    for (long s = 0; s < steps; s++) {
        for (size_t k = 0; k < P->n; k++) {
            rot_velocity(P->x[k], P->y[k], s * c->dt, NULL, &P->uw[k], &P->vw[k]);
            /* cyclostrophic tilt: the pressure gradient that holds the water
             * in solid-body rotation, -g grad(xi) = -omega^2 r; without it
             * the ice (with inertia) centrifuges out of the water */
            P->sshx[k] = disc_omega * disc_omega * P->x[k] / p.gravity;
            P->sshy[k] = disc_omega * disc_omega * P->y[k] / p.gravity;
        }
        if (sph_model_step(m, &st) != 0) {
            snprintf(r->status, sizeof r->status, "fatal:%s", st.quantity);
            break;
        }
    }
    r->cpu_s = bench_cpu() - c0;
    r->wall_s = bench_wall() - w0;
    /* concentration on the measurement grid, as the engine does */
    double xc, yc;
    disc_final_centre(&xc, &yc);
    double x0 = xc - MG_N * MG_DX / 2, y0 = yc - MG_N * MG_DX / 2;
    size_t np = (size_t)MG_N * MG_N;
    double *px = malloc(np * sizeof(double)), *py = malloc(np * sizeof(double));
    double *th = malloc(np * sizeof(double)), *dn = malloc(np * sizeof(double));
    for (int j = 0; j < MG_N; j++)
        for (int i = 0; i < MG_N; i++) {
            px[j * MG_N + i] = x0 + (i + 0.5) * MG_DX;
            py[j * MG_N + i] = y0 + (j + 0.5) * MG_DX;
        }
    const double *fields[1] = {P->thick};
    double *outs[1] = {th};
    sph_model_interpolate(m, np, px, py, 1, fields, outs, dn);
    for (size_t q = 0; q < np; q++)
        th[q] = isfinite(th[q]) && th[q] > 0 ? fmin(1.0, dn[q] / (p.rho_i * th[q])) : 0.0;
    disc_measure(th, MG_N, x0, y0, MG_DX, r);
    free(px);
    free(py);
    free(th);
    free(dn);
    sph_model_free(m);
}

static void run_disc_grid(const disc_cfg *c, bench_row *r)
{
    double half = DISC_XC + DISC_R + 6e3; /* the orbit plus a margin */
    int n = (int)ceil(2 * half / c->dx);
    grid_adv *g = grid_adv_create(n, n, 2, -n * c->dx / 2, -n * c->dx / 2, c->dx);
    double *A = grid_adv_field(g, 0), *H = grid_adv_field(g, 1);
    for (int j = 0; j < n; j++) /* cell averages of the disc, 8 x 8 sub-samples */
        for (int i = 0; i < n; i++) {
            int in = 0;
            for (int b = 0; b < 8; b++)
                for (int a = 0; a < 8; a++) {
                    double x = g->x0 + (i + (a + 0.5) / 8) * c->dx;
                    double y = g->y0 + (j + (b + 0.5) / 8) * c->dx;
                    in += hypot(x - DISC_XC, y) <= DISC_R;
                }
            A[j * n + i] = DISC_A * in / 64.0;
            H[j * n + i] = DISC_A * DISC_H * in / 64.0;
        }
    double c0 = bench_cpu(), w0 = bench_wall();
    double dt = grid_adv_max_dt(g, rot_velocity, NULL, 0, c->dt);
    long steps = (long)ceil(DISC_T / dt);
    dt = DISC_T / steps;
    for (long s = 0; s < steps; s++)
        grid_adv_step(g, c->scheme, rot_velocity, NULL, s * dt, dt);
    r->cpu_s = bench_cpu() - c0;
    r->wall_s = bench_wall() - w0;
    /* concentration as the engine would diagnose it: A (cell mean), capped */
    for (long k = 0; k < (long)n * n; k++)
        A[k] = fmin(1.0, fmax(0.0, A[k]));
    disc_measure(A, n, g->x0, g->y0, c->dx, r);
    grid_adv_free(g);
}

static void run_disc(const void *arg, bench_row *r)
{
    const disc_cfg *c = arg;
    omp_set_num_threads(1); /* CPU time comparable with the serial grid */
    if (c->grid)
        run_disc_grid(c, r);
    else
        run_disc_sph(c, r);
}

static void problem_disc(void)
{
    int q = bench_quick();
    bench_row rows[64];
    disc_cfg cfgs[64];
    int n = 0;
    const double sph_dx[] = {2000, 1000, 500};
    const double sph_dt[] = {600, 120, 60};
    for (int d = 0; d < (q ? 1 : 3); d++)
        for (int t = 0; t < 3; t++)
            cfgs[n++] = (disc_cfg){0, sph_dx[d], sph_dt[t], SPH_KERNEL_GAUSSIAN, GRID_UPWIND};
    cfgs[n++] = (disc_cfg){0, q ? 2000 : 1000, 60, SPH_KERNEL_WENDLAND_C2, GRID_UPWIND};
    const double grid_dx[] = {4000, 2000, 1000, 500, 250};
    const grid_scheme schemes[] = {GRID_UPWIND, GRID_VANLEER, GRID_SUPERBEE};
    for (int s = 0; s < 3; s++)
        for (int d = 0; d < (q ? 3 : 5); d++)
            cfgs[n++] = (disc_cfg){1, grid_dx[d], 0.9, SPH_KERNEL_GAUSSIAN, schemes[s]};
    static const char *sname[] = {"upwind", "minmod", "vanleer", "superbee"};
    for (int i = 0; i < n; i++) {
        char meth[64], cfg[160];
        if (cfgs[i].grid) {
            snprintf(meth, sizeof meth, "grid_%s", sname[cfgs[i].scheme]);
            snprintf(cfg, sizeof cfg, "dx=%g;cfl=%g", cfgs[i].dx, cfgs[i].dt);
        } else {
            snprintf(meth, sizeof meth, "sph_%s",
                     cfgs[i].kernel == SPH_KERNEL_GAUSSIAN ? "gaussian" : "wendland");
            snprintf(cfg, sizeof cfg, "dx=%g;dt=%g", cfgs[i].dx, cfgs[i].dt);
        }
        bench_run_forked_row("disc", run_disc, &cfgs[i], meth, cfg, &rows[i]);
    }
    /* equal CPU time: upwind width interpolated (log-log) at each SPH run's CPU */
    for (int i = 0; i < n; i++) {
        if (cfgs[i].grid || strcmp(rows[i].status, "ok") != 0)
            continue;
        double cpu = rows[i].cpu_s, best = NAN;
        int lo = -1, hi = -1;
        for (int j = 0; j < n; j++) {
            if (!cfgs[j].grid || cfgs[j].scheme != GRID_UPWIND)
                continue;
            if (rows[j].cpu_s <= cpu && (lo < 0 || rows[j].cpu_s > rows[lo].cpu_s))
                lo = j;
            if (rows[j].cpu_s >= cpu && (hi < 0 || rows[j].cpu_s < rows[hi].cpu_s))
                hi = j;
        }
        const char *how = "interpolated";
        if (lo >= 0 && hi >= 0 && hi != lo) {
            double f = log(cpu / rows[lo].cpu_s) / log(rows[hi].cpu_s / rows[lo].cpu_s);
            best = exp(log(rows[lo].err[0]) + f * (log(rows[hi].err[0]) - log(rows[lo].err[0])));
        } else if (lo >= 0) { /* SPH costs more than the finest grid run: its width
                                 is an upper bound of the grid's at equal CPU */
            best = rows[lo].err[0];
            how = "finest_grid_cheaper";
        } else if (hi >= 0) {
            best = rows[hi].err[0];
            how = "coarsest_grid_dearer";
        }
        bench_row e;
        bench_row_init(&e, "disc_equal_cpu");
        snprintf(e.method, sizeof e.method, "%s_vs_grid_upwind", rows[i].method);
        snprintf(e.config, sizeof e.config, "%s;%s", rows[i].config, how);
        e.cpu_s = rows[i].cpu_s;
        e.wall_s = rows[i].wall_s;
        e.rss_mb = rows[i].rss_mb;
        e.err_name[0] = "grid_width_over_sph_width";
        e.err[0] = best / rows[i].err[0];
        e.err_name[1] = "sph_width_m";
        e.err[1] = rows[i].err[0];
        e.err_name[2] = "grid_upwind_width_m";
        e.err[2] = best;
        bench_row_print(&e);
    }
}

int main(int argc, char **argv)
{
    static const struct {
        const char *name;
        void (*fn)(void);
    } probs[] = {{"free_drift", problem_drift},
                 {"stefan", problem_stefan},
                 {"disc", problem_disc},
                 {"coast", problem_coast}};
    for (size_t i = 0; i < sizeof probs / sizeof probs[0]; i++) {
        int want = argc < 2;
        for (int a = 1; a < argc; a++)
            want |= strcmp(argv[a], probs[i].name) == 0;
        if (want)
            probs[i].fn();
    }
    return 0;
}
