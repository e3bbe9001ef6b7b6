/* The particle count over a 90-day season with and without merging
 * (issue 20, "Speed and memory"): one synthetic season from open water,
 * run twice in one invocation, model.new_ice.merge on and off, everything
 * else equal. A synthetic case, not the freeze-up scene
 * (etc/liaodong-season.json): that scene's forcing covers 30 days
 * (tools/gen_season.c writes at most 60) and one 30-day run of it takes
 * about 6 minutes on the shared two-core machine (docs/season.md), so two
 * 90-day runs would take over half an hour. This case: both runs in
 * about 13 minutes there (docs/ocean.md, Cost).
 *
 * Case: a closed box of 32 x 20 km of sea, lattice 1 km (the seeding
 * lattice of new particles: 640 points; capacity 2560), mixed layer on
 * cells of 4 km, 30 psu, +1 C at the start, the depth growing from 5 m at
 * the west wall to 30 m at the east one (shallow water freezes first),
 * the salinity restored to 30 psu in 10 days. Air temperature over the
 * season T(d) = -2 - 12 sin(pi d / 70) for days 0-70 (coldest -14 C on
 * day 35), then +1 C per day up to +18 C on day 90; a diurnal +-2 C;
 * dark, longwave 0.75 sigma T^4, specific humidity 2e-3 (1e-3 below
 * -5 C); wind 2 m/s from the west, turning to the west-north-west every
 * ten days for three days at 5 m/s: the ice is pushed against the east
 * wall, open water opens in the west and freezes again, so new particles
 * keep being created next to older ones. Dynamics every 900 s (mEVP;
 * kernel radius 2 h as the scene, P0 2.75e4 N/m^2, up to 192
 * neighbours), thermodynamics every 3600 s, mass per area by summation.
 *
 * Why summation: with continuity density (BENCH_SEASON_DENSITY=continuity)
 * the footprints m / M of the particles grew until the leads over a
 * western cell covered 76-86 times its area and a slab was drained (day
 * 55 with merging, 51 without). The cause was the smoothing length
 * h = h0 sqrt(M0 / M): M grew with the ice while the reference M0 stayed,
 * so new particles' h fell to the floor and the kernel lost its
 * neighbours. Since M0 follows the mass under the mixed layer (model.c;
 * tests/test_ocean_sml_growth.c) the run without merging reaches day 90
 * and the one with merging stops on day 71.5 in a corner the wind pulls
 * open (docs/ocean.md, Cost). The salinity restoring is there for the
 * drain of the shallow western slabs (without it: day 34, before the
 * footprint spread).
 *
 * Measured: the particle count every 12 h (written to
 * $BENCH_OUT/season_counts.dat: day, count with merging, without), its
 * peak and the day of the peak, particles created, merged and melted out,
 * the smoothing lengths at the peak and at the end (min, 10th, 50th,
 * 90th percentile, max, in lattice spacings), the largest smoothing
 * length and the saltiest cell over the whole season, and the cost: CPU and wall
 * time of each run, CPU per step, and the ratio of CPU per step with /
 * without merging measured in the same invocation (the two runs one
 * after the other in this process; peak_rss_mb is the process's peak so
 * far). Rows of bench/out/results.csv:
 * problem season, method merge / nomerge, err = the peak count, err2 =
 * the count at the end, err3 = the cost ratio merge / nomerge (CPU per
 * step); status fatal with the day and reason on stderr when a run stops.
 * Usage: bench_season [days] (default 90; BENCH_QUICK=1: 30).
 * BENCH_SEASON_DENSITY=continuity: the scene's continuity density instead
 * of summation; BENCH_SEASON_REINIT=N: model.density_reinit_steps N (with
 * continuity: the density re-initialised by summation every N steps,
 * docs/ocean.md); BENCH_SEASON_ONLY=merge (nomerge): that run alone. The
 * report's last line per run: the largest sum of the footprints m / M over
 * the box's sea and the largest single footprint over the season.
 * Run: BENCH_ONLY=season sh bench/run.sh (not in the default list). */
#include "bench_common.h"
#include "core/model.h"
#include "core/ocean.h"
#include "../tests/ocean_column.h" /* oc_fill_atm: the atmosphere over particles and cells */

#define DS 1000.0 /* lattice spacing, m */
#define NXL 32
#define NYL 20
#define CELL 4000.0
#define SIGMA 5.670374419e-8

typedef struct season_arg {
    int merge;
    double days;
    const char *series; /* file for the counts every 12 h */
} season_arg;

typedef struct season_result {
    double peak, peak_day, end, created, merged, removed, steps, wall, cpu;
    double sml_peak[5], sml_end[5];
    double sal_max, sal_max_day, sml_max, sml_max_day; /* over the season: the saltiest cell, the largest h / DS */
    double foot_max, foot_max_day; /* over the season: the sum of the footprints m / M over the box's sea */
    double foot1_max;              /* over the season: the largest footprint / a lattice cell */
} season_result;

static season_result *shared_res; /* one per run: [0] without merging, [1] with */

static double air_temp(double day)
{
    double t = day <= 70.0 ? -2.0 - 12.0 * sin(M_PI * day / 70.0) : -2.0 + (day - 70.0);
    return t + 2.0 * sin(2.0 * M_PI * (day - 0.375)); /* warmest at 15 h */
}

/* The atmosphere of day `day` over every particle and cell. */
static void forcing(sph_model *m, double day)
{
    sph_particles *P = sph_model_particles(m);
    double ta = air_temp(day), tk = ta + 273.15;
    double ph = fmod(day, 10.0), ws = ph >= 7.0 ? 5.0 : 2.0, dir = ph >= 7.0 ? -M_PI / 6.0 : 0.0;
    oc_fill_atm(m, ta, ta < -5.0 ? 1e-3 : 2e-3, ws * cos(dir), ws * sin(dir), 0.0, 0.75 * SIGMA * tk * tk * tk * tk,
                40.0);
    for (size_t k = 0; k < P->n; k++)
        P->uw[k] = P->vw[k] = P->sshx[k] = P->sshy[k] = 0.0;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* min, 10th, 50th, 90th percentile, max of the smoothing lengths / DS. */
static void sml_stats(const sph_particles *P, double *buf, double out[5])
{
    for (int i = 0; i < 5; i++)
        out[i] = NAN;
    if (P->n == 0)
        return;
    for (size_t k = 0; k < P->n; k++)
        buf[k] = P->sml[k] / DS;
    qsort(buf, P->n, sizeof(double), cmp_double);
    const double q[5] = {0.0, 0.1, 0.5, 0.9, 1.0};
    for (int i = 0; i < 5; i++)
        out[i] = buf[(size_t)lround(q[i] * (double)(P->n - 1))];
}

static void run_season(const void *argp, bench_row *row)
{
    const season_arg *a = argp;
    season_result *r = &shared_res[a->merge];
    memset(r, 0, sizeof *r);
    sph_params p;
    sph_params_default(&p);
    p.dt = 900.0;
    p.thermo_dt = 3600.0;
    p.kernel_radius = 2.0; /* as the freeze-up scene (etc/liaodong-season.json) */
    p.P0 = 2.75e4;         /* Hibler's P*: thin new ice pushed into a closed box must hold */
    p.max_neighbours = 192;
    p.summation_density = 1; /* a lonely particle at a wall keeps a bounded footprint (above) */
    const char *dens = getenv("BENCH_SEASON_DENSITY"); /* "continuity": the scene's default instead */
    if (dens && strcmp(dens, "continuity") == 0)
        p.summation_density = 0;
    const char *reinit = getenv("BENCH_SEASON_REINIT"); /* N: model.density_reinit_steps (continuity) */
    if (reinit)
        p.density_reinit_steps = atoi(reinit);
    p.ocean.mixed_layer = 1;
    p.ocean.create = 1;
    p.ocean.merge = a->merge;
    p.ocean.restore_days = 10.0;
    size_t cap = 4 * (size_t)NXL * NYL; /* compacted ice frees lattice points: room to show it */
    static unsigned char land[NXL * NYL]; /* all sea; closed box */
    sph_landmask mk = {NXL, NYL, 0.0, 0.0, DS, DS, land, 1};
    sph_model *m = sph_model_create(&p, cap, &mk);
    sph_ocean_grid g = {(int)(NXL * DS / CELL), (int)(NYL * DS / CELL), 0.0, 0.0, CELL, CELL, 0.5 * DS, 0.5 * DS, DS};
    if (!m || sph_model_ocean_create(m, &g) != SPH_STEP_OK) {
        snprintf(row->status, sizeof row->status, "setup");
        return;
    }
    sph_ocean *o = sph_model_ocean(m);
    for (size_t c = 0; c < o->ncell; c++) {
        double xc = ((double)(c % (size_t)g.nx) + 0.5) * CELL;
        sph_ocean_set_cell(o, c, 5.0 + 25.0 * xc / (NXL * DS), 30.0, 1.0);
        o->sss_restore[c] = 30.0; /* the exchange with the sea outside the slab (no SST restoring) */
    }
    forcing(m, 0.0);
    sph_status st;
    double *buf = malloc(cap * sizeof(double));
    FILE *f = fopen(a->series, "w");
    if (!buf || !f || sph_model_init(m, &st) != SPH_STEP_OK) {
        snprintf(row->status, sizeof row->status, "init");
        free(buf);
        if (f)
            fclose(f);
        sph_model_free(m);
        return;
    }
    long nstep = lround(a->days * 86400.0 / p.dt), every = lround(43200.0 / p.dt);
    double c0 = bench_cpu(), w0 = bench_wall();
    fprintf(f, "%.2f %zu\n", 0.0, sph_model_particles(m)->n);
    for (long s = 1; s <= nstep; s++) {
        forcing(m, (double)(s - 1) * p.dt / 86400.0);
        if (sph_model_step(m, &st) != SPH_STEP_OK) {
            fprintf(stderr, "bench_season: merge %d: step %ld (day %.2f): %s %s\n", a->merge, s,
                    s * p.dt / 86400.0, st.quantity, st.what);
            snprintf(row->status, sizeof row->status, "fatal");
            size_t cm = 0; /* the coldest cell says why */
            for (size_t c = 1; c < o->ncell; c++)
                if (o->temp[c] < o->temp[cm])
                    cm = c;
            fprintf(stderr, "bench_season: coldest cell %zu: %.3f C, %.2f psu, depth %.1f m, water %.3f of its start, "
                    "ice footprint %.2f of the cell\n", cm, o->temp[cm], o->sal[cm], o->depth[cm],
                    o->water[cm] / (SPH_OCEAN_RHO_WATER * o->depth[cm] * CELL * CELL), o->cfoot[cm] / (CELL * CELL));
            break;
        }
        const sph_particles *P = sph_model_particles(m);
        for (size_t c = 0; c < o->ncell; c++)
            if (o->sal[c] > r->sal_max) {
                r->sal_max = o->sal[c];
                r->sal_max_day = s * p.dt / 86400.0;
            }
        for (size_t k = 0; k < P->n; k++)
            if (P->sml[k] / DS > r->sml_max) {
                r->sml_max = P->sml[k] / DS;
                r->sml_max_day = s * p.dt / 86400.0;
            }
        double foot = 0.0;
        for (size_t k = 0; k < P->n; k++) {
            double ak = P->mass[k] / P->dens[k];
            foot += ak;
            r->foot1_max = fmax(r->foot1_max, ak / (DS * DS));
        }
        if (foot / (NXL * NYL * DS * DS) > r->foot_max) {
            r->foot_max = foot / (NXL * NYL * DS * DS);
            r->foot_max_day = s * p.dt / 86400.0;
        }
        if ((double)P->n > r->peak) {
            r->peak = (double)P->n;
            r->peak_day = s * p.dt / 86400.0;
            sml_stats(P, buf, r->sml_peak);
        }
        if (s % every == 0)
            fprintf(f, "%.2f %zu\n", s * p.dt / 86400.0, P->n);
        r->steps = (double)s;
    }
    row->cpu_s = bench_cpu() - c0;
    row->wall_s = bench_wall() - w0;
    r->wall = row->wall_s;
    r->cpu = row->cpu_s;
    const sph_budget *b = sph_model_budget(m);
    r->end = (double)sph_model_particles(m)->n;
    r->created = (double)b->created_particles;
    r->merged = (double)b->merged_particles;
    r->removed = (double)b->removed_particles;
    sml_stats(sph_model_particles(m), buf, r->sml_end);
    row->err_name[0] = "peak_particles";
    row->err[0] = r->peak;
    row->err_name[1] = "particles_end";
    row->err[1] = r->end;
    fclose(f);
    free(buf);
    sph_model_free(m);
}

int main(int argc, char **argv)
{
    double days = argc > 1 ? atof(argv[1]) : bench_quick() ? 30.0 : 90.0;
    if (!(days > 0.0 && days <= 90.0)) {
        fprintf(stderr, "bench_season: days %s: expected 0 < days <= 90 (the season's forcing)\n", argv[1]);
        return 2;
    }
    const char *dir = getenv("BENCH_OUT") ? getenv("BENCH_OUT") : "bench/out";
    static season_result res[2];
    shared_res = res;
    char series[2][4200] = {"", ""}, config[64];
    snprintf(config, sizeof config, "%gd_lattice%d", days, NXL * NYL);
    bench_row rows[2];
    const char *only = getenv("BENCH_SEASON_ONLY"); /* "merge" or "nomerge": that run alone */
    for (int merge = 1; merge >= 0; merge--) { /* one after the other, in this process */
        if (only && strcmp(only, merge ? "merge" : "nomerge") != 0) {
            bench_row_init(&rows[merge], "season");
            snprintf(rows[merge].status, sizeof rows[merge].status, "skipped");
            continue;
        }
        snprintf(series[merge], sizeof series[merge], "%s/season_counts_%s.tmp", dir, merge ? "merge" : "nomerge");
        season_arg a = {merge, days, series[merge]};
        bench_row_init(&rows[merge], "season");
        snprintf(rows[merge].method, sizeof rows[merge].method, "%s", merge ? "merge" : "nomerge");
        snprintf(rows[merge].config, sizeof rows[merge].config, "%s", config);
        run_season(&a, &rows[merge]);
        rows[merge].rss_mb = bench_peak_rss_mb();
    }
    /* CPU time per step: the wall time of a shared machine moves with its
     * load, and a run that stops early has fewer steps */
    double cps[2];
    for (int i = 0; i < 2; i++)
        cps[i] = shared_res[i].steps > 0.0 ? shared_res[i].cpu / shared_res[i].steps : NAN;
    double ratio = cps[0] > 0.0 ? cps[1] / cps[0] : NAN;
    for (int merge = 1; merge >= 0; merge--) {
        rows[merge].err_name[2] = "cpu_per_step_ratio_merge_over_nomerge";
        rows[merge].err[2] = ratio;
        bench_row_print(&rows[merge]);
    }
    /* the counts side by side */
    char path[4200];
    snprintf(path, sizeof path, "%s/season_counts.dat", dir);
    FILE *in[2] = {series[1][0] ? fopen(series[1], "r") : NULL, series[0][0] ? fopen(series[0], "r") : NULL};
    FILE *out = in[0] && in[1] ? fopen(path, "w") : NULL;
    if (in[0] && in[1] && out) {
        fprintf(out, "# day particles_with_merging particles_without (bench/bench_season.c)\n");
        double d0, d1;
        long n0, n1;
        fprintf(stderr, "season: day  with merging  without\n");
        while (fscanf(in[0], "%lf %ld", &d0, &n0) == 2 && fscanf(in[1], "%lf %ld", &d1, &n1) == 2) {
            fprintf(out, "%.2f %ld %ld\n", d0, n0, n1);
            if (fmod(d0 + 1e-9, 10.0) < 1e-6)
                fprintf(stderr, "season: %4.0f  %12ld  %7ld\n", d0, n0, n1);
        }
    }
    for (int i = 0; i < 2; i++)
        if (in[i])
            fclose(in[i]);
    if (out)
        fclose(out);
    if (!only) { /* one run alone keeps its series file */
        remove(series[0]);
        remove(series[1]);
    }
    for (int merge = 1; merge >= 0; merge--) {
        const season_result *r = &shared_res[merge];
        if (strcmp(rows[merge].status, "skipped") == 0)
            continue;
        fprintf(stderr,
                "season %s: peak %.0f particles on day %.2f, %.0f at the end; created %.0f, merged %.0f, "
                "melted out %.0f; %.0f steps in %.1f s wall, %.1f s CPU (%.2f ms CPU/step)\n"
                "season %s: smoothing length / lattice spacing at the peak: min %.2f p10 %.2f median %.2f "
                "p90 %.2f max %.2f; at the end: %.2f %.2f %.2f %.2f %.2f\n"
                "season %s: over the season: largest smoothing length %.2f lattice spacings (day %.2f), "
                "saltiest cell %.3f psu (day %.2f)\n"
                "season %s: over the season: the footprints m / M summed over the box %.3f of its sea (day %.2f), "
                "the largest footprint %.2f lattice cells\n",
                merge ? "merge" : "nomerge", r->peak, r->peak_day, r->end, r->created, r->merged, r->created - r->merged - r->end,
                r->steps, r->wall, r->cpu, r->steps > 0 ? 1e3 * r->cpu / r->steps : NAN, merge ? "merge" : "nomerge",
                r->sml_peak[0], r->sml_peak[1], r->sml_peak[2], r->sml_peak[3], r->sml_peak[4], r->sml_end[0],
                r->sml_end[1], r->sml_end[2], r->sml_end[3], r->sml_end[4], merge ? "merge" : "nomerge",
                r->sml_max, r->sml_max_day, r->sal_max, r->sal_max_day, merge ? "merge" : "nomerge", r->foot_max,
                r->foot_max_day, r->foot1_max);
    }
    fprintf(stderr, "season: cost with / without merging (CPU per step) %.3f; counts in %s\n", ratio, path);
    return 0;
}
