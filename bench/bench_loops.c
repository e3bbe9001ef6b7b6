/* The cost of one packed-ice rheology iteration (issue 22, item 3).
 *
 * A packed lattice (A = 1, h_i = 1 m, 1 km spacing, small random
 * velocities so that every strain rate is non-zero, a 10 m/s wind;
 * physics = full so every particle is in the rheology), mEVP with a
 * fixed 50 iterations per step (evp_tol = 0), one thread, the demo's
 * kernel (Gaussian truncated at 2 h, h = dx) and Wendland C2 (h = 1.3 dx),
 * at the demo's size (36 x 36 = 1296 particles: the lists fit the caches)
 * and at 1e4 / 1e5 particles; at the demo's size also with the kernel
 * gradient correction and with the collision rheology (the passes' other
 * instantiations: their checksums compare them between builds).
 *
 * Prints one CSV row per case (bench_common.h): CPU seconds of the timed
 * steps, ns of CPU per particle-iteration, interactions (pairs visited,
 * self included: two passes per iteration) per CPU second, and a checksum
 * of the final state (x, y, u, v bit patterns), so that two builds of the
 * same source tree (bench/bench_loops.sh: this tree against a baseline
 * tree, alternating, in one run) can be compared for speed and for bit
 * identity at once.
 * Usage: bench_loops [max_N]   (default 1e5; BENCH_QUICK=1: 1e4) */
#include <omp.h>
#include <stdint.h>

#include "bench_common.h"
#include "core/model.h"
#include "../tests/lattice.h"

typedef struct loops_case {
    int side;
    sph_kernel_kind kernel;
    int variant; /* 0 plain, 1 gradient correction, 2 collision rheology */
} loops_case;

static uint64_t mix_bits(uint64_t h, const double *a, size_t n)
{
    for (size_t k = 0; k < n; k++) {
        uint64_t b;
        memcpy(&b, &a[k], sizeof b);
        h = (h ^ b) * 1099511628211ull;
    }
    return h;
}

/* The row's numbers from the final state: CPU per particle-iteration,
 * interactions per CPU second, the checksum in the status. */
static void loops_row(bench_row *r, sph_model *m, const sph_params *p, size_t n, double iters,
                      double visits)
{
    const sph_particles *P = sph_model_particles(m);
    /* neighbours per particle from the public state: the model's lists
     * are private; the lattice's count is that of the pairs within the
     * support, counted here directly (small cases) */
    double R = p->kernel_radius * p->sml_factor * 1000.0;
    long pairs = 0;
    int ri = (int)(R / 1000.0) + 1;
    for (int dy = -ri; dy <= ri; dy++)
        for (int dx = -ri; dx <= ri; dx++)
            pairs += (double)(dx * dx + dy * dy) * 1e6 < R * R;
    uint64_t h = 1469598103934665603ull;
    h = mix_bits(h, P->x, n);
    h = mix_bits(h, P->y, n);
    h = mix_bits(h, P->u, n);
    h = mix_bits(h, P->v, n);
    snprintf(r->status, sizeof r->status, "ok_%016llx", (unsigned long long)h);
    r->err_name[0] = "ns_per_particle_iteration";
    r->err[0] = 1e9 * r->cpu_s / (iters * (double)n);
    r->err_name[1] = "interactions_per_cpu_s";
    r->err[1] = visits * (double)pairs * (double)n / r->cpu_s;
    r->err_name[2] = "interior_neighbours";
    r->err[2] = (double)pairs;
}

static void run_loops(const void *arg, bench_row *r)
{
    const loops_case *c = arg;
    omp_set_num_threads(1);
    sph_params p;
    sph_params_default(&p);
    p.kernel = c->kernel;
    p.kernel_radius = 2.0;
    p.sml_factor = c->kernel == SPH_KERNEL_GAUSSIAN ? 1.0 : 1.3;
    p.physics = SPH_PHYSICS_FULL;
    p.thermo_dt = 0;
    p.evp_tol = 0;
    p.evp_rel_tol = 0;
    p.evp_iterations = 50;
    p.gradient_correction = c->variant == 1;
    if (c->variant == 2)
        p.rheology = SPH_RHEOLOGY_COLLISION;
    size_t n0 = (size_t)c->side * (size_t)c->side;
    sph_model *m = sph_model_create(&p, n0, NULL);
    sph_status st;
    if (!m) {
        snprintf(r->status, sizeof r->status, "create_failed");
        return;
    }
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, &p, c->side, c->side, 0, 0, 1000.0, 1.0, 1.0, 40.6);
    lattice_random_velocities(P, 12345u, 0.02);
    if (sph_model_init(m, &st) != 0) {
        snprintf(r->status, sizeof r->status, "init_failed");
        sph_model_free(m);
        return;
    }
    size_t n = P->n;
    int steps = n <= 2000 ? 40 : n <= 20000 ? 6 : 1;
    int rc = sph_model_step(m, &st); /* untimed warm-up: page faults of the lists */
    double iters = 0;
    double c0 = bench_cpu(), w0 = bench_wall();
    for (int i = 0; i < steps && rc == 0; i++) {
        rc = sph_model_step(m, &st);
        iters += sph_model_stats(m)->iterations;
    }
    double visits = 2.0 * iters + steps; /* two passes per iteration, the final strain rates */
    r->cpu_s = bench_cpu() - c0;
    r->wall_s = bench_wall() - w0;
    if (rc == 0) {
        loops_row(r, m, &p, n, iters, visits);
    } else {
        snprintf(r->status, sizeof r->status, "step_failed");
    }
    sph_model_free(m);
}

/* side, kernel, variant: the demo's size in every variant, then plain */
static const loops_case cases[] = {
    {36, SPH_KERNEL_GAUSSIAN, 0},     {36, SPH_KERNEL_WENDLAND_C2, 0},
    {36, SPH_KERNEL_GAUSSIAN, 1},     {36, SPH_KERNEL_WENDLAND_C2, 1},
    {36, SPH_KERNEL_GAUSSIAN, 2},     {36, SPH_KERNEL_WENDLAND_C2, 2},
    {100, SPH_KERNEL_GAUSSIAN, 0},    {100, SPH_KERNEL_WENDLAND_C2, 0},
    {316, SPH_KERNEL_GAUSSIAN, 0},    {316, SPH_KERNEL_WENDLAND_C2, 0},
};

int main(int argc, char **argv)
{
    long maxn = argc > 1 ? strtol(argv[1], NULL, 10) : bench_quick() ? 10000 : 100000;
    const char *vname[] = {"plain", "gradient_correction", "collision"};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        const loops_case *c = &cases[i];
        if ((long)c->side * c->side > maxn)
            continue;
        char cfg[128];
        snprintf(cfg, sizeof cfg, "N=%d;threads=1;mevp_iterations=50;%s", c->side * c->side,
                 vname[c->variant]);
        bench_run_forked_row("loops", run_loops, c,
                             c->kernel == SPH_KERNEL_GAUSSIAN ? "gaussian_R2" : "wendland_c2", cfg,
                             NULL);
    }
    return 0;
}
