/* Performance of the SPH passes (issue 2).
 *
 * Packed lattice (A = 1, h = 1 m, 1 km spacing, small random velocities so
 * that every strain rate is non-zero; physics = full so every particle is
 * in the rheology), for N = 1e4, 1e5, 1e6 particles, both kernels and 1 and
 * 2 OpenMP threads:
 *   - "diagnose": sph_model_diagnose (neighbour build, strain-rate pass,
 *     stress, stress-divergence pass) on all particles;
 *   - "step": whole sph_model_step (mEVP, 20 iterations, each a strain
 *     and a divergence pass over the packed particles; 20 rather than the
 *     default 120 so that 1e6 particles fit the time budget: the cost per
 *     iteration is what scales).
 * Interactions are neighbour pairs visited (self included): diagnose visits
 * the lists twice; a step 2 * iterations + 1 times.
 * Then the seed's O(N^2) sph_nbr_build_brute against sph_nbr_build at 1e4
 * and 3e4 particles (same lists; ratio of times).
 *
 * Every configuration runs in its own child process (peak RSS per run);
 * ns_per_particle_step is the median repetition's wall time (the passes
 * are repeated 200 / 20 / 4 times for diagnose and 25 / 5 / 3 for steps at
 * 1e4 / 1e5 / 1e6); interactions_per_s uses the same median.
 * Output: CSV rows (see bench_common.h) with
 *   perf,<kernel>,N=..;threads=..;pass=.., cpu_s, wall_s, rss, ok,
 *   ns_per_particle_step, interactions_per_s, neighbours_per_particle.
 * Usage: bench_neighbours [max_N] (BENCH_QUICK=1: up to 1e4). */
#include <omp.h>

#include "bench_common.h"
#include "core/kernel.h"
#include "core/model.h"
#include "core/neighbours.h"
#include "../tests/lattice.h"

typedef struct perf_case {
    int side;
    sph_kernel_kind kernel;
    int threads;
    int pass; /* 0 diagnose, 1 step */
} perf_case;

static sph_model *packed_lattice(const sph_params *p, int side, double dx)
{
    sph_model *m = sph_model_create(p, (size_t)side * (size_t)side, NULL);
    if (!m)
        return NULL;
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, p, side, side, 0, 0, dx, 1.0, 1.0, 40.6);
    lattice_random_velocities(P, 12345u, 0.02);
    return m;
}

static void set_kernel(sph_params *p, sph_kernel_kind k)
{
    p->kernel = k;
    p->kernel_radius = 3.0;
    p->sml_factor = k == SPH_KERNEL_GAUSSIAN ? 1.0 : 1.3;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static void run_perf(const void *arg, bench_row *r)
{
    const perf_case *c = arg;
    omp_set_num_threads(c->threads);
    sph_params p;
    sph_params_default(&p);
    set_kernel(&p, c->kernel);
    p.physics = SPH_PHYSICS_FULL;
    p.thermo_dt = 0;
    p.evp_tol = 0; /* always the full iteration count: a fixed amount of work */
    p.evp_iterations = 20;
    sph_model *m = packed_lattice(&p, c->side, 1000.0);
    sph_status st;
    if (!m || sph_model_init(m, &st) != 0) {
        snprintf(r->status, sizeof r->status, "init_failed");
        return;
    }
    size_t n = sph_model_particles(m)->n;
    int reps;
    if (c->pass == 0)
        reps = n <= 20000 ? 200 : n <= 200000 ? 20 : 4;
    else
        reps = n <= 20000 ? 25 : n <= 200000 ? 5 : 3;
    /* one untimed warm-up (page faults of the lists) */
    int rc = c->pass == 0 ? sph_model_diagnose(m, &st) : sph_model_step(m, &st);
    double c0 = bench_cpu(), w0 = bench_wall();
    double visits = 0;
    long pairs = 0;
    double rep_wall[256];
    for (int i = 0; i < reps && rc == 0; i++) {
        double t0 = bench_wall();
        rc = c->pass == 0 ? sph_model_diagnose(m, &st) : sph_model_step(m, &st);
        rep_wall[i] = bench_wall() - t0;
        /* the pairs are recorded in the model's neighbour lists; count them
         * from the public particle state: sum of list lengths = pairs */
        const sph_step_stats *ss = sph_model_stats(m);
        visits += c->pass == 0 ? 2.0 : 2.0 * ss->iterations + 1.0;
    }
    r->cpu_s = bench_cpu() - c0;
    r->wall_s = bench_wall() - w0;
    if (rc != 0) {
        snprintf(r->status, sizeof r->status, "step_failed");
        sph_model_free(m);
        return;
    }
    /* pairs of the last build: rebuild lists once outside the timing */
    {
        sph_particles *P = sph_model_particles(m);
        sph_kernel k;
        sph_kernel_init(&k, p.kernel, p.kernel_radius);
        sph_nbr *nb = sph_nbr_create(n, n, p.max_neighbours);
        double hmax = 0;
        for (size_t q = 0; q < n; q++)
            hmax = fmax(hmax, P->sml[q]);
        sph_nbr_grid(nb, n, P->x, P->y, k.radius * hmax);
        long over;
        sph_nbr_build(nb, &k, n, P->x, P->y, P->sml, &over);
        pairs = nb->pairs;
        sph_nbr_free(nb);
    }
    /* the median repetition: a shared machine's interruptions hit single
     * repetitions of the small cases (the mean of 40 diagnose passes at
     * 1e4 varied by 30 % between runs) */
    qsort(rep_wall, (size_t)reps, sizeof rep_wall[0], cmp_double);
    double wall_per = reps % 2 ? rep_wall[reps / 2] : 0.5 * (rep_wall[reps / 2 - 1] + rep_wall[reps / 2]);
    r->err_name[0] = "ns_per_particle_step";
    r->err[0] = 1e9 * wall_per / (double)n;
    r->err_name[1] = "interactions_per_s";
    r->err[1] = visits / reps * (double)pairs / wall_per;
    r->err_name[2] = "neighbours_per_particle";
    r->err[2] = (double)pairs / (double)n;
    sph_model_free(m);
}

typedef struct brute_case {
    int side;
    sph_kernel_kind kernel;
} brute_case;

static void run_brute(const void *arg, bench_row *r)
{
    const brute_case *c = arg;
    omp_set_num_threads(2);
    sph_params p;
    sph_params_default(&p);
    set_kernel(&p, c->kernel);
    sph_particles *P = sph_particles_create((size_t)c->side * c->side, 1);
    lattice_fill(P, &p, c->side, c->side, 0, 0, 1000.0, 1.0, 1.0, 40.6);
    size_t n = P->n;
    sph_kernel k;
    sph_kernel_init(&k, p.kernel, p.kernel_radius);
    sph_nbr *a = sph_nbr_create(n, n, p.max_neighbours), *b = sph_nbr_create(n, n, p.max_neighbours);
    long over;
    int reps = 5;
    double w0 = bench_wall();
    for (int i = 0; i < reps; i++) {
        sph_nbr_grid(a, n, P->x, P->y, k.radius * P->sml[0]);
        sph_nbr_build(a, &k, n, P->x, P->y, P->sml, &over);
    }
    double t_grid = (bench_wall() - w0) / reps;
    w0 = bench_wall();
    double c0 = bench_cpu();
    sph_nbr_build_brute(b, &k, n, n, P->x, P->y, P->sml, &over);
    double t_brute = bench_wall() - w0;
    r->cpu_s = bench_cpu() - c0;
    r->wall_s = t_brute;
    int same = a->pairs == b->pairs;
    for (size_t q = 0; q < n && same; q++)
        same = a->count[q] == b->count[q];
    if (!same)
        snprintf(r->status, sizeof r->status, "lists_differ");
    r->err_name[0] = "brute_over_grid";
    r->err[0] = t_brute / t_grid;
    r->err_name[1] = "grid_build_s";
    r->err[1] = t_grid;
    r->err_name[2] = "brute_build_s";
    r->err[2] = t_brute;
    sph_nbr_free(a);
    sph_nbr_free(b);
    sph_particles_free(P);
}

int main(int argc, char **argv)
{
    long maxn = bench_quick() ? 10000 : 1000000;
    if (argc > 1)
        maxn = strtol(argv[1], NULL, 10);
    const int sides[] = {100, 316, 1000};
    const sph_kernel_kind kernels[] = {SPH_KERNEL_GAUSSIAN, SPH_KERNEL_WENDLAND_C2};
    const char *kname[] = {"gaussian_R3", "wendland_c2"};
    for (int s = 0; s < 3; s++) {
        if ((long)sides[s] * sides[s] > maxn)
            continue;
        for (int kk = 0; kk < 2; kk++)
            for (int pass = 0; pass < 2; pass++)
                for (int t = 1; t <= 2; t++) {
                    perf_case c = {sides[s], kernels[kk], t, pass};
                    char cfg[160];
                    snprintf(cfg, sizeof cfg, "N=%d;threads=%d;pass=%s", sides[s] * sides[s], t,
                             pass ? "step_mevp20" : "diagnose");
                    bench_run_forked("perf", run_perf, &c, kname[kk], cfg);
                }
    }
    const int bsides[] = {100, 173};
    for (int s = 0; s < (bench_quick() ? 1 : 2); s++)
        for (int kk = 0; kk < 2; kk++) {
            brute_case c = {bsides[s], kernels[kk]};
            char cfg[160];
            snprintf(cfg, sizeof cfg, "N=%d;threads=2;pass=nbr_build_brute_vs_grid",
                     bsides[s] * bsides[s]);
            bench_run_forked("perf_brute", run_brute, &c, kname[kk], cfg);
        }
    return 0;
}
