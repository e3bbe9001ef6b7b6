/* Stability envelope of the stress solvers (issue 7), the plastic wave and
 * the shear-zone (tensile instability) test.
 *
 * envelope: packed ice (A = 1, h = 1 m) in a channel 3 particles wide and
 *   20 spacings long, pushed against the wall by an onshore wind
 *   (tests/scenarios.h), full physics, replacement pressure off (seed), for
 *   6 model hours or until the run's CPU cap. For each solver (explicit,
 *   mEVP with fixed alpha = beta = 300, adaptive aEVP), kernel (Gaussian
 *   R = 3, h = dx; Wendland C2, h = 1.3 dx), time step and particle spacing
 *   (wind 10 m/s), and at 2 km spacing (Gaussian) for winds 5/10/20 m/s.
 *   Outcome (err column "outcome_code"):
 *     0 stable and converged;
 *     1 stable, not converged: normalised principal stresses outside the
 *       yield ellipse by > 1 % of P for > 1 % of the particles at the end;
 *     2 failed: fatal status (blow-up: NaN or speed limit; mass);
 *     3 failed: neighbour overflow (clumping);
 *     4 refused: the explicit solver's own limit (more sub-steps than
 *       max_substeps);
 *     5 unfinished: the CPU cap was reached first (stable so far; err2 is
 *       the model time reached).
 *   err2: model hours reached; err3: fraction of particles outside the
 *   ellipse (code 0/1), or the explicit limit (s, code 4).
 * plastic_wave: linearised uniaxial plastic compression (PHYSICS.md s. 8):
 *   packed ice (A = 1, h = 1 m, P* = 27.5e3, e = 2, C = 20, replacement
 *   pressure, no drag, no wind, no Coriolis), 500 km of a channel 3
 *   particles wide, converging uniformly at 3e-5 s^-1 (v = -eps (y - yc),
 *   so every particle is on the yield curve, stress initialised there;
 *   eps well above the wave's own strain rates, c_p AMP / W = 3e-6 s^-1,
 *   so no part of it unloads) with a 0.5 % Gaussian thickness bump
 *   (width 10 km) at yc. The bump
 *   splits into two waves; the front is the peak of one of them, in
 *   Lagrangian labels (relative to the ice), speed by least squares over
 *   1 to 2.5 h (a 20 km bump gave the same speed within 0.5 %; the
 *   centroid of the anomaly, used first, was biased by the background). err: relative error
 *   against c_p = sqrt(k P* / rho_i), k = (1 + sqrt(1 + e^-2)) / 2; err2:
 *   measured speed (m/s). (Ice at rest ahead of a front is in the viscous
 *   regime, nearly rigid, and decelerates as a whole: no wave there.)
 * shear: packed ice in a channel 10 particles wide with no-slip side walls,
 *   wind 15 m/s along the walls, 12 h, dt 60 s: clumping when the minimum
 *   inter-particle distance falls below 0.3 initial spacings or the
 *   neighbour list overflows. err: min distance / spacing; err2: outcome.
 *
 * Writes CSV rows (bench_common.h); the envelope's rows have problem
 * "stability". Usage: bench_stability [envelope|plastic_wave|shear ...]. */
#include <omp.h>

#include "bench_common.h"
#include "core/model.h"
#include "../tests/lattice.h"
#include "../tests/scenarios.h"

static void set_kernel(sph_params *p, sph_kernel_kind k)
{
    p->kernel = k;
    p->sml_factor = k == SPH_KERNEL_GAUSSIAN ? 1.0 : 1.3;
}

/* Fraction of particles whose stress lies outside the yield ellipse by
 * more than 1 % of P (normalised: ellipse centred at -P/2, semi-axes P/2
 * and P/(2e) in (sigma_I, sigma_II)). */
static double outside_ellipse(const sph_particles *P, const sph_params *p)
{
    size_t out = 0, n = 0;
    for (size_t k = 0; k < P->n; k++) {
        double Pk = P->pres[k];
        if (!(Pk > 0))
            continue;
        n++;
        double sI = 0.5 * (P->s11[k] + P->s22[k]);
        double d = 0.5 * (P->s11[k] - P->s22[k]);
        double sII = sqrt(d * d + P->s12[k] * P->s12[k]);
        double a = (sI + 0.5 * Pk) / (0.5 * Pk), b = sII / (0.5 * Pk / p->ecc);
        out += sqrt(a * a + b * b) > 1.01;
    }
    return n ? (double)out / (double)n : 0.0;
}

typedef struct env_case {
    sph_solver_kind solver;
    int adaptive;
    sph_kernel_kind kernel;
    double dt, dx, wind, hours, cpu_cap;
} env_case;

static void run_envelope(const void *arg, bench_row *r)
{
    const env_case *c = arg;
    sph_params p;
    sph_params_default(&p);
    set_kernel(&p, c->kernel);
    p.physics = SPH_PHYSICS_FULL;
    p.solver = c->solver;
    p.evp_adaptive = c->adaptive;
    p.dt = c->dt;
    coast_case cc;
    coast_setup(&cc, &p, c->dx, 3, 20 * c->dx, 1.0, c->wind);
    sph_status st;
    int init_rc = sph_model_init(cc.model, &st);
    long steps = (long)ceil(c->hours * 3600 / c->dt - 1e-9), s;
    double c0 = bench_cpu(), w0 = bench_wall();
    int code = 0;
    if (init_rc != 0) { /* refused by the measured envelope (or a bad state) */
        code = init_rc > 0 ? 4 : 2;
        snprintf(r->status, sizeof r->status, "%s:envelope", code == 4 ? "refused" : "fatal");
        steps = 0;
    }
    for (s = 0; s < steps; s++) {
        int rc = sph_model_step(cc.model, &st);
        if (rc != 0) {
            if (rc > 0 && st.kind == SPH_FAULT_CLUMPING)
                code = 3;
            else if (rc > 0 && st.kind == SPH_FAULT_SUBSTEPS)
                code = 4;
            else
                code = 2;
            snprintf(r->status, sizeof r->status, "%s:%s",
                     code == 3 ? "clumping" : code == 4 ? "refused" : "fatal",
                     st.quantity[0] ? st.quantity : "unknown");
            break;
        }
        if (bench_cpu() - c0 > c->cpu_cap) {
            s++;
            if (s < steps) {
                code = 5;
                snprintf(r->status, sizeof r->status, "unfinished");
            }
            break;
        }
    }
    r->cpu_s = bench_cpu() - c0;
    r->wall_s = bench_wall() - w0;
    sph_particles *P = sph_model_particles(cc.model);
    double frac = code == 0 || code == 5 ? outside_ellipse(P, sph_model_params(cc.model)) : NAN;
    if (code == 0 && frac > 0.01)
        code = 1;
    r->err_name[0] = "outcome_code";
    r->err[0] = code;
    r->err_name[1] = "model_hours";
    r->err[1] = s * c->dt / 3600.0;
    r->err_name[2] = code == 4 ? "explicit_dt_limit_s" : "frac_outside_ellipse";
    r->err[2] = code == 4 ? st.limit : frac;
    coast_free(&cc);
}

static void envelope(void)
{
    int q = bench_quick();
    const double dts[] = {1, 10, 60, 300, 1800};
    const double dxs[] = {500, 1000, 2000, 5000};
    const double winds[] = {5, 10, 20};
    struct {
        sph_solver_kind s;
        int adaptive;
        const char *name;
    } solvers[] = {{SPH_SOLVER_EXPLICIT, 0, "explicit"},
                   {SPH_SOLVER_MEVP, 0, "mevp_fixed"},
                   {SPH_SOLVER_MEVP, 1, "aevp"}};
    const sph_kernel_kind kernels[] = {SPH_KERNEL_GAUSSIAN, SPH_KERNEL_WENDLAND_C2};
    const char *kname[] = {"gaussian", "wendland"};
    double cap = q ? 0.5 : 3.0;
    for (int s = 0; s < 3; s++)
        for (int k = 0; k < (q ? 1 : 2); k++)
            for (int i = 0; i < 4; i++) {
                if (q && dxs[i] != 2000)
                    continue;
                for (int d = 0; d < 5; d++) {
                    if (q && dts[d] != 60 && dts[d] != 1800)
                        continue;
                    env_case c = {solvers[s].s, solvers[s].adaptive, kernels[k], dts[d], dxs[i],
                                  10, 6, cap};
                    char meth[64], cfg[160];
                    snprintf(meth, sizeof meth, "%s_%s", solvers[s].name, kname[k]);
                    snprintf(cfg, sizeof cfg, "dt=%g;dx=%g;wind=10", dts[d], dxs[i]);
                    bench_run_forked("stability", run_envelope, &c, meth, cfg);
                }
            }
    for (int s = 0; s < 3; s++)
        for (int w = 0; w < 3; w++) {
            if (winds[w] == 10 || (q && winds[w] != 20))
                continue;
            for (int d = 0; d < 5; d++) {
                if (q && dts[d] != 60)
                    continue;
                env_case c = {solvers[s].s, solvers[s].adaptive, SPH_KERNEL_GAUSSIAN, dts[d], 2000,
                              winds[w], 6, cap};
                char meth[64], cfg[160];
                snprintf(meth, sizeof meth, "%s_gaussian", solvers[s].name);
                snprintf(cfg, sizeof cfg, "dt=%g;dx=2000;wind=%g", dts[d], winds[w]);
                bench_run_forked("stability", run_envelope, &c, meth, cfg);
            }
        }
}

/* ---------------------------------------------------------- plastic wave */

typedef struct wave_case {
    sph_kernel_kind kernel;
    double sml_factor, dx;
    int iterations;
} wave_case;

static void run_wave(const void *arg, bench_row *r)
{
    const wave_case *c = arg;
    sph_params p;
    sph_params_default(&p);
    set_kernel(&p, c->kernel);
    p.sml_factor = c->sml_factor;
    p.dt = 15.0; /* plastic-wave Courant number 0.085 at 1 km (envelope 0.15) */
    p.evp_iterations = c->iterations;
    p.max_neighbours = 512; /* wide kernels (h = 2 dx) carry ~100 neighbours */
    double speed = NAN, cp = NAN;
    sph_status st;
    double c0 = bench_cpu(), w0 = bench_wall();
    int rc = plastic_wave_run(&p, c->dx, &speed, &cp, &st);
    r->cpu_s = bench_cpu() - c0;
    r->wall_s = bench_wall() - w0;
    if (rc != 0) {
        snprintf(r->status, sizeof r->status, "%s:%s", rc < 0 ? "fatal" : "refused", st.quantity);
        return;
    }
    r->err_name[0] = "speed_rel_err";
    r->err[0] = fabs(speed - cp) / cp;
    r->err_name[1] = "front_speed_m_s";
    r->err[1] = speed;
    r->err_name[2] = "analytic_c_p_m_s";
    r->err[2] = cp;
}

static void plastic_wave(void)
{
    int q = bench_quick();
    wave_case cases[] = {{SPH_KERNEL_GAUSSIAN, 1.0, 2000, 120}, {SPH_KERNEL_GAUSSIAN, 1.5, 2000, 120},
                         {SPH_KERNEL_GAUSSIAN, 2.0, 2000, 120}, {SPH_KERNEL_WENDLAND_C2, 1.3, 2000, 120},
                         {SPH_KERNEL_WENDLAND_C2, 2.0, 2000, 120}, {SPH_KERNEL_GAUSSIAN, 1.0, 1000, 120},
                         {SPH_KERNEL_GAUSSIAN, 1.0, 2000, 500}};
    int n = q ? 1 : (int)(sizeof cases / sizeof cases[0]);
    for (int i = 0; i < n; i++) {
        char meth[64], cfg[160];
        snprintf(meth, sizeof meth, "aevp_%s",
                 cases[i].kernel == SPH_KERNEL_GAUSSIAN ? "gaussian" : "wendland");
        snprintf(cfg, sizeof cfg, "dx=%g;h=%gdx;dt=15;iter=%d", cases[i].dx, cases[i].sml_factor,
                 cases[i].iterations);
        bench_run_forked("plastic_wave", run_wave, &cases[i], meth, cfg);
    }
}

/* ----------------------------------------------------------------- shear */

typedef struct shear_case {
    sph_kernel_kind kernel;
    int adaptive;
    int summation;
} shear_case;

static void run_shear(const void *arg, bench_row *r)
{
    const shear_case *c = arg;
    sph_params p;
    sph_params_default(&p);
    set_kernel(&p, c->kernel);
    p.physics = SPH_PHYSICS_FULL;
    p.coast_no_slip = 1;
    p.evp_adaptive = c->adaptive;
    p.summation_density = c->summation;
    double dx = 1000;
    coast_case cc;
    coast_setup(&cc, &p, dx, 10, 30 * dx, 1.0, 15.0);
    sph_status st;
    sph_model_init(cc.model, &st);
    sph_particles *P = sph_model_particles(cc.model);
    long steps = 12 * 60;
    double dmin = HUGE_VAL;
    int clump = 0;
    double c0 = bench_cpu(), w0 = bench_wall();
    for (long s = 0; s < steps; s++) {
        int rc = sph_model_step(cc.model, &st);
        if (rc != 0) {
            clump = rc > 0 && st.kind == SPH_FAULT_CLUMPING;
            snprintf(r->status, sizeof r->status, "%s:%s", clump ? "clumping" : "fatal",
                     st.quantity);
            break;
        }
        if (s % 10 == 9)
            for (size_t a = 0; a < P->n; a++)
                for (size_t b = a + 1; b < P->n; b++)
                    dmin = fmin(dmin, hypot(P->x[a] - P->x[b], P->y[a] - P->y[b]));
    }
    r->cpu_s = bench_cpu() - c0;
    r->wall_s = bench_wall() - w0;
    if (dmin / dx < 0.3)
        clump = 1;
    if (clump && strcmp(r->status, "ok") == 0)
        snprintf(r->status, sizeof r->status, "clumping:min_distance");
    r->err_name[0] = "min_dist_over_spacing";
    r->err[0] = dmin / dx;
    r->err_name[1] = "clumping";
    r->err[1] = clump;
    coast_free(&cc);
}

static void shear(void)
{
    shear_case cases[] = {{SPH_KERNEL_GAUSSIAN, 1, 0}, {SPH_KERNEL_WENDLAND_C2, 1, 0},
                          {SPH_KERNEL_GAUSSIAN, 0, 0}, {SPH_KERNEL_GAUSSIAN, 1, 1},
                          {SPH_KERNEL_WENDLAND_C2, 1, 1}};
    int n = bench_quick() ? 1 : 5;
    for (int i = 0; i < n; i++) {
        char meth[64], cfg[160];
        snprintf(meth, sizeof meth, "%s_%s", cases[i].adaptive ? "aevp" : "mevp_fixed",
                 cases[i].kernel == SPH_KERNEL_GAUSSIAN ? "gaussian" : "wendland");
        snprintf(cfg, sizeof cfg, "dx=1000;dt=60;wind=15;density=%s",
                 cases[i].summation ? "summation" : "continuity");
        bench_run_forked("shear", run_shear, &cases[i], meth, cfg);
    }
}

int main(int argc, char **argv)
{
    static const struct {
        const char *name;
        void (*fn)(void);
    } probs[] = {{"plastic_wave", plastic_wave}, {"shear", shear}, {"envelope", envelope}};
    for (size_t i = 0; i < sizeof probs / sizeof probs[0]; i++) {
        int want = argc < 2;
        for (int a = 1; a < argc; a++)
            want |= strcmp(argv[a], probs[i].name) == 0;
        if (want)
            probs[i].fn();
    }
    return 0;
}
