/* CICE's box2001 side by side (issue 26): sphice's velocities against CICE
 * 6.6.3's EVP solution at 6 h and 24 h, and the cost of the 10 days at
 * 16 km against CICE's ~40 s of CPU (EVP, same machine kind; the issue's
 * numbers). The case and the scores: tests/box2001.h.
 *
 * One run per invocation, configured by the environment (defaults: the
 * test's configuration):
 *   B01_DT        dynamic step, s (240)
 *   B01_ITERS     evp.iterations (120)
 *   B01_RELTOL    evp.rel_tol (0: off)
 *   B01_TOL       evp.tol, m/s (1e-7)
 *   B01_GC        model.gradient_correction (0)
 *   B01_NOSLIP    model.coast_no_slip (1)
 *   B01_RP        rheology.replacement_pressure (1)
 *   B01_KERNEL    0 gaussian, 1 wendland_c2, 2 cubic_spline (0)
 *   B01_SML       sml_factor (1)
 *   B01_SOLVER    0 explicit, 1 mevp, 2 implicit (1)
 *   B01_ONLY6     1: stop at 6 h (0)
 *   B01_DUMP      path prefix: the gridded fields at each output time, PREFIX-6h.csv ...
 *   B01_DAYS      run length after 24 h for the cost, days (0: stop at 24 h; 10 for the benchmark)
 * Prints bench rows (bench/bench_common.h) on stdout: box2001_6h and
 * box2001_24h with err = relative RMS vector difference over the box, in
 * packed ice, and the mean direction difference; box2001_10d (B01_DAYS=10)
 * with the CPU time against CICE's 40 s. The detail on stderr, one line per
 * output time:
 *   box2001,config,hours,cpu_s,mean_iterations,mean_rel_residual,rel_all,rel_packed,rel_loose,
 *   rel_wall_band,dir_all,dir_packed,speed_ratio_packed,corr_div,corr_shear,rms_div_s,rms_div_c,
 *   rms_shear_s,rms_shear_c */
#include <stdio.h>
#include <stdlib.h>

#include "bench_common.h"
#include "core/model.h"
#include "../tests/box2001.h"

static double env(const char *k, double d)
{
    const char *s = getenv(k);
    return s && *s ? atof(s) : d;
}

/* A row with the run's name, configuration and cost so far. */
static void start_row(bench_row *row, const char *problem, const sph_params *p, const char *cfg, double c0,
                      double w0)
{
    bench_row_init(row, problem);
    snprintf(row->method, sizeof row->method, "%s", p->solver == SPH_SOLVER_MEVP ? "mevp" : "other");
    snprintf(row->config, sizeof row->config, "%s", cfg);
    row->cpu_s = bench_cpu() - c0;
    row->wall_s = bench_wall() - w0;
    row->rss_mb = bench_peak_rss_mb();
}

int main(void)
{
    sph_params p;
    b01_params(&p, env("B01_DT", 240));
    p.evp_iterations = (int)env("B01_ITERS", 120);
    p.evp_rel_tol = env("B01_RELTOL", 0);
    p.evp_tol = env("B01_TOL", 1e-7);
    p.gradient_correction = (int)env("B01_GC", 0);
    p.coast_no_slip = (int)env("B01_NOSLIP", 1);
    p.replacement_pressure = (int)env("B01_RP", 1);
    p.kernel = (sph_kernel_kind)(int)env("B01_KERNEL", 0);
    if (p.kernel != SPH_KERNEL_GAUSSIAN)
        p.kernel_radius = 2;
    p.sml_factor = env("B01_SML", 1);
    p.solver = (sph_solver_kind)(int)env("B01_SOLVER", 1);
    double days = env("B01_DAYS", 0);
    char cfg[150];
    snprintf(cfg, sizeof cfg, "dt%g_it%d_rtol%g_gc%d_ns%d_rp%d_k%d_sml%g_s%d", p.dt, p.evp_iterations,
             p.evp_rel_tol, p.gradient_correction, p.coast_no_slip, p.replacement_pressure, (int)p.kernel,
             p.sml_factor, (int)p.solver);
    b01_case c;
    sph_status st;
    if (b01_create(&c, &p) != 0 || sph_model_init(c.model, &st) != SPH_STEP_OK) {
        fprintf(stderr, "bench_box2001: %s: model refused (%s %g > %g)\n", cfg,
                st.quantity ? st.quantity : "create", st.value, st.limit);
        return 1;
    }
    static b01_fields ref, got;
    double c0 = bench_cpu(), w0 = bench_wall(), iters = 0, res = 0;
    long steps = 0;
    const double hours[2] = {6, 24};
    int nout = env("B01_ONLY6", 0) ? 1 : 2; /* B01_ONLY6=1: stop at 6 h */
    for (int it = 0; it < nout; it++) {
        double t1 = hours[it] * 3600.0;
        while (sph_model_time(c.model) < t1 - 1e-6 * p.dt) {
            b01_forcing(c.model, sph_model_time(c.model));
            if (sph_model_step(c.model, &st) != SPH_STEP_OK) {
                fprintf(stderr, "bench_box2001: %s: step failed (%s %g)\n", cfg, st.quantity, st.value);
                return 1;
            }
            iters += sph_model_stats(c.model)->iterations;
            res += sph_model_stats(c.model)->rel_residual;
            steps++;
        }
        if (b01_read_ref(B01_REF, it, &ref) != 0 || b01_grid(c.model, &got) != 0) {
            fprintf(stderr, "bench_box2001: cannot read %s or grid the particles\n", B01_REF);
            return 1;
        }
        b01_scores s;
        b01_score(&got, &ref, &s);
        const char *dump = getenv("B01_DUMP"); /* a,b,u_s,v_s,u_c,v_c,div_s,div_c per point */
        if (dump && *dump) {
            char fn[512];
            snprintf(fn, sizeof fn, "%s-%gh.csv", dump, hours[it]);
            FILE *f = fopen(fn, "w");
            for (int q = 0; f && q < B01_N * B01_N; q++)
                fprintf(f, "%d,%d,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.4g\n", q % B01_N, q / B01_N, got.u[q], got.v[q],
                        ref.u[q], ref.v[q], got.div[q], ref.div[q], ref.aice[q]);
            if (f)
                fclose(f);
        }
        bench_row row;
        start_row(&row, it == 0 ? "box2001_6h" : "box2001_24h", &p, cfg, c0, w0);
        row.err_name[0] = "rel_rms_whole";
        row.err[0] = s.rel_all;
        row.err_name[1] = "rel_rms_packed";
        row.err[1] = s.rel_packed;
        row.err_name[2] = "direction_deg";
        row.err[2] = s.dir_all;
        bench_row_print(&row);
        fprintf(stderr, "box2001,%s,%g,%.4g,%.1f,%.3g,%.4f,%.4f,%.4f,%.4f,%.2f,%.2f,%.3f,%.3f,%.3f,%.3g,%.3g,%.3g,%.3g\n",
               cfg, hours[it], bench_cpu() - c0, iters / steps, res / steps, s.rel_all, s.rel_packed,
               s.rel_loose, s.rel_wall_band, s.dir_all, s.dir_packed, s.speed_ratio_packed, s.corr_div,
               s.corr_shear, s.rms_div_s, s.rms_div_c, s.rms_shear_s, s.rms_shear_c);
        fflush(stderr);
    }
    if (days > 1) {
        double t1 = days * 86400.0;
        while (sph_model_time(c.model) < t1 - 1e-6 * p.dt) {
            b01_forcing(c.model, sph_model_time(c.model));
            if (sph_model_step(c.model, &st) != SPH_STEP_OK)
                return 1;
            iters += sph_model_stats(c.model)->iterations;
            steps++;
        }
        bench_row row;
        start_row(&row, "box2001_10d", &p, cfg, c0, w0);
        row.err_name[0] = "mean_iterations";
        row.err[0] = iters / steps;
        row.err_name[1] = "cice_cpu_s";
        row.err[1] = 40.0; /* the CICE EVP on this machine kind */
        row.err_name[2] = "cpu_ratio_to_cice";
        row.err[2] = row.cpu_s / 40.0;
        bench_row_print(&row);
    }
    sph_model_free(c.model);
    return 0;
}
