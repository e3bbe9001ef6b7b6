/* R300 from rest to its steady state (tests/test_r300's case, PHYSICS.md
 * section 8), solver variants against today's settings in one run
 * (issue 22 item 2: packed ice in fewer iterations).
 *
 * Each argument is one run,
 * "GC:PHYSICS:ITERATIONS:REL_TOL:ANDERSON:DT[:CHANGE_TOL[:SOLVER[:JFNK_TOL]]]"
 * (model.gradient_correction 0/1, full or auto, model.evp.iterations,
 * model.evp.rel_tol, model.evp.anderson, model.dt in s,
 * model.evp.change_tol, model.solver (default mevp), model.jfnk.tol);
 * without
 * arguments: test_r300's three runs (gradient correction, plain, plain
 * auto) and the same with evp.rel_tol 1e-3. Prints CSV rows
 * (bench/bench_common.h): err = largest of |edge|, |ridged zone| and
 * |wall thickness| error against the analytic state (%), err2 = mean
 * iterations per step, err3 = model hours to the steady state (kinetic
 * energy per mass below 1e-6 m^2/s^2 after at least 24 h; 144 h at most).
 * Progress (one line per run, on stderr). One thread. */
#include "bench_common.h"
#include "../tests/scenarios.h"
#include "core/registry.h"

#define DX 5000.0
#define NCROSS 6
#define WIND 9.0
#define L0 300e3
#define H0 1.0

static void run(const char *spec)
{
    sph_params p;
    r300_params(&p, 60.0);
    char phys[16] = "full";
    int gc = 0, iter = 250, aa = 0;
    double rel = 0.0, dt = 60.0, chg = 0.0;
    char solver[16] = "mevp";
    double jtol = p.jfnk_tol;
    int nf = sscanf(spec, "%d:%15[a-z]:%d:%lf:%d:%lf:%lf:%15[a-z]:%lf", &gc, phys, &iter, &rel, &aa, &dt, &chg, solver,
                    &jtol);
    if (nf < 6 || nf > 9 || sph_solver_lookup(solver) < 0) {
        fprintf(stderr,
                "bench_r300: \"%s\": expected GC:PHYSICS:ITERATIONS:REL_TOL:ANDERSON:DT[:CHANGE_TOL[:SOLVER[:JFNK_TOL]]]\n",
                spec);
        exit(2);
    }
    p.gradient_correction = gc;
    p.physics = strcmp(phys, "auto") == 0 ? SPH_PHYSICS_AUTO : SPH_PHYSICS_FULL;
    p.evp_iterations = iter;
    p.evp_rel_tol = rel;
    p.evp_anderson = aa;
    p.evp_change_tol = chg;
    p.dt = dt;
    p.solver = (sph_solver_kind)sph_solver_lookup(solver);
    p.jfnk_tol = jtol;
    double tau = p.rho_a * p.Ca * WIND * WIND;
    coast_analytic a;
    coast_solve(&a, &p, tau, H0, L0);
    bench_row r;
    bench_row_init(&r, "r300");
    snprintf(r.method, sizeof r.method, "%s_%s%s", solver, phys, gc ? "_gc" : "");
    snprintf(r.config, sizeof r.config,
             "gc=%d;physics=%s;iterations=%d;rel_tol=%g;anderson=%d;dt=%g;change_tol=%g;solver=%s;jfnk_tol=%g", gc, phys,
             iter, rel, aa, dt, chg, solver, jtol);
    sph_status st;
    coast_case c;
    double c0 = bench_cpu(), w0 = bench_wall();
    if (coast_setup(&c, &p, DX, NCROSS, L0, H0, WIND) != 0 || sph_model_init(c.model, &st) != 0) {
        snprintf(r.status, sizeof r.status, "setup");
        bench_row_print(&r);
        return;
    }
    long maxsteps = (long)(144 * 3600.0 / p.dt), s, iters = 0;
    double ke = HUGE_VAL;
    for (s = 1; s <= maxsteps; s++) {
        if (sph_model_step(c.model, &st) != 0) {
            snprintf(r.status, sizeof r.status, "failed");
            fprintf(stderr, "bench_r300: %s: step %ld failed: %s %g %s\n", spec, s, st.quantity ? st.quantity : "",
                    st.value, st.what ? st.what : "");
            break;
        }
        iters += sph_model_stats(c.model)->iterations;
        const sph_budget *b = sph_model_budget(c.model);
        ke = b->kinetic_energy / b->mass;
        if (s * p.dt >= 24 * 3600.0 && ke < 1e-6)
            break;
    }
    long done = s > maxsteps ? maxsteps : s;
    r.cpu_s = bench_cpu() - c0;
    r.wall_s = bench_wall() - w0;
    r.rss_mb = bench_peak_rss_mb();
    if (!(ke < 1e-6) && !strcmp(r.status, "ok"))
        snprintf(r.status, sizeof r.status, "not_steady");
    coast_measured ms;
    coast_measure_ridged(&c, &p, DX * p.sml_factor, &ms);
    double hwall = a.h0 + a.tau / (a.k * a.P0) * a.Lr;
    double e1 = 100.0 * (ms.edge - a.L) / a.L, e2 = 100.0 * (ms.Lr - a.Lr) / a.Lr,
           e3 = 100.0 * (ms.hwall - hwall) / hwall;
    fprintf(stderr, "bench_r300: %s: edge %+.2f %%, ridged zone %+.2f %%, wall %+.2f %%, %.1f iterations per step, "
                    "%.1f h, CPU %.1f s\n",
            r.config, e1, e2, e3, (double)iters / (double)done, done * p.dt / 3600.0, r.cpu_s);
    r.err_name[0] = "worst_pct";
    r.err[0] = fmax(fabs(e1), fmax(fabs(e2), fabs(e3)));
    r.err_name[1] = "iterations";
    r.err[1] = (double)iters / (double)done;
    r.err_name[2] = "hours";
    r.err[2] = done * p.dt / 3600.0;
    bench_row_print(&r);
    coast_free(&c);
}

int main(int argc, char **argv)
{
    static const char *const defaults[] = {"1:full:250:0:0:60",    "0:full:250:0:0:60",
                                           "0:auto:250:0:0:60",    "1:full:250:1e-3:0:60",
                                           "0:full:250:1e-3:0:60", "0:auto:250:1e-3:0:60"};
    if (argc > 1)
        for (int i = 1; i < argc; i++)
            run(argv[i]);
    else
        for (size_t i = 0; i < sizeof defaults / sizeof defaults[0]; i++)
            run(defaults[i]);
    return 0;
}
