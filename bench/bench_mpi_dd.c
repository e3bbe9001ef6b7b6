/* Domain decomposition within a member (issue 24 item 2; docs/domain.md):
 * strong and weak scaling of service/domain_mpi.c and the halo it moves.
 *
 *   mpirun -np P build-mpi/bench/bench_mpi_dd N STEPS ITERS [csv]
 *
 * A synthetic basin of N particles at 3 km spacing (a square lattice):
 * the western 60 % packed ice (A = 1, 1.5 m), the rest loose (A = 0.4),
 * auto physics, mEVP with ITERS iterations, dt 300 s, a 10 m/s wind
 * across the packed/loose boundary. Rank 0 initialises the serial model
 * and scatters it; then STEPS decomposed steps. One CSV row: ranks, N,
 * steps, wall s per step, the largest rank CPU s per step, the summed CPU
 * s per step, halo copies per step as a fraction of the owned particles,
 * halo bytes per step (copies + every iteration's refresh) and per
 * particle-step, migration bytes per step, the largest rank's share of
 * the particles (balance), the largest and smallest rank's wall s per step
 * completing the halo refreshes (MPI_Waitall) in the old order (STEPS
 * steps run first with the refresh completed right after the norms'
 * reduction; BENCH_MPI_DD_NO_OLD=1 skips them) and with the interior-first
 * overlap (the timed steps), the largest rank's wall s per step in the
 * norms' reduction (MPI_Allreduce) in each order, and the largest rank's peak resident memory
 * (VmHWM, MB; rank 0 also held the serial model it initialised).
 * bench/bench_mpi_dd.sh runs the series. Not an
 * MPI build: says so and exits 0. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#ifndef SPHICE_MPI
int main(void)
{
    printf("bench_mpi_dd: needs the MPI build (make MPI=1 BUILD=build-mpi build-mpi/bench/bench_mpi_dd)\n");
    return 0;
}
#else
#include <mpi.h>

#include "core/dd.h"
#include "core/model.h"
#include "service/domain_mpi.h"

static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* This process's peak resident memory (VmHWM), MB; 0 if unreadable. */
static double peak_rss_mb(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    double kb = 0;
    while (f && fgets(line, sizeof line, f))
        if (sscanf(line, "VmHWM: %lf", &kb) == 1)
            break;
    if (f)
        fclose(f);
    return kb / 1024.0;
}

static void params(sph_params *p, int iters)
{
    sph_params_default(p);
    p->thermo_dt = 0;
    p->dt = 300.0;
    p->physics = SPH_PHYSICS_AUTO;
    p->solver = SPH_SOLVER_MEVP;
    p->evp_iterations = iters;
}

int main(int argc, char **argv)
{
    MPI_Init(&argc, &argv);
    int rank, size;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    long N = argc > 1 ? atol(argv[1]) : 20000;
    int steps = argc > 2 ? atoi(argv[2]) : 5, iters = argc > 3 ? atoi(argv[3]) : 30;
    const char *csv = argc > 4 ? argv[4] : NULL;
    int side = (int)ceil(sqrt((double)N));
    N = (long)side * side;
    const double D = 3000.0;
    sph_params p;
    params(&p, iters);
    sph_status st;
    sph_model *root = NULL;
    sph_model_clock clk;
    const sph_particles *all = NULL;
    double t_init = MPI_Wtime();
    if (rank == 0) {
        root = sph_model_create(&p, (size_t)N, NULL);
        if (!root || sph_model_set_canonical(root, 1))
            MPI_Abort(MPI_COMM_WORLD, 2);
        sph_particles *P = sph_model_particles(root);
        for (int j = 0; j < side; j++)
            for (int i = 0; i < side; i++) {
                size_t k = P->n++;
                int packed = i < (int)(0.6 * side);
                double A = packed ? 1.0 : 0.4, h = packed ? 1.5 : 0.5;
                P->x[k] = (i + 0.5) * D;
                P->y[k] = (j + 0.5) * D;
                P->thick[k] = h;
                P->conc[k] = A;
                P->mass[k] = p.rho_i * A * h * D * D;
                P->sml[k] = P->sml0[k] = p.sml_factor * D;
                P->lat[k] = 80.0;
                P->id[k] = (long)k;
                P->ua[k] = 8.0;
                P->va[k] = 6.0 * sin(2 * M_PI * j / side);
                P->uw[k] = P->vw[k] = 0.0;
            }
        if (sph_model_init(root, &st) != SPH_STEP_OK) {
            fprintf(stderr, "bench_mpi_dd: init: %s %s\n", st.quantity ? st.quantity : "", st.what ? st.what : "");
            MPI_Abort(MPI_COMM_WORLD, 2);
        }
        sph_model_get_clock(root, &clk);
        all = P;
    }
    /* capacity: the share, its halo (3 supports of 3 h around a piece of
     * the curve) and room for imbalance */
    size_t share = (size_t)(N / size);
    size_t cap = size == 1 ? (size_t)N : (size_t)(1.6 * (double)share + 40.0 * side * 9);
    if (cap > (size_t)N * 2)
        cap = (size_t)N * 2;
    sph_model *m = sph_model_create(&p, cap, NULL);
    dd_options o = {0, 0, side * D, side * D, 3 * D * 3, 10};
    dd_ctx *d = m ? dd_create(MPI_COMM_WORLD, m, &o) : NULL;
    if (!d)
        MPI_Abort(MPI_COMM_WORLD, 2);
    if (dd_scatter(d, all, &clk, &st) != SPH_STEP_OK)
        MPI_Abort(MPI_COMM_WORLD, 2);
    sph_model_free(root);
    t_init = MPI_Wtime() - t_init;
    /* the old order first (the refresh completed right after the norms'
     * reduction), STEPS steps, for its wait time; then the timed STEPS
     * with the interior-first overlap */
    double wait_old = 0, wait_old_min = 0, red_old = 0;
    if (size > 1 && !getenv("BENCH_MPI_DD_NO_OLD")) {
        dd_set_overlap(d, 0);
        dd_reset_stats(d);
        MPI_Barrier(MPI_COMM_WORLD);
        for (int s = 0; s < steps; s++)
            if (dd_step(d, &st) != SPH_STEP_OK)
                MPI_Abort(MPI_COMM_WORLD, 2);
        dd_stats ws;
        dd_run_stats(d, &ws);
        wait_old = ws.wait_s;
        wait_old_min = ws.wait_min_s;
        red_old = ws.reduce_s;
        dd_set_overlap(d, 1);
        dd_reset_stats(d);
    }
    MPI_Barrier(MPI_COMM_WORLD);
    double w0 = MPI_Wtime(), c0 = cpu_now();
    for (int s = 0; s < steps; s++)
        if (dd_step(d, &st) != SPH_STEP_OK) {
            if (rank == 0)
                fprintf(stderr, "bench_mpi_dd: step %d: %s %s\n", s, st.quantity ? st.quantity : "",
                        st.what ? st.what : "");
            break;
        }
    double wall = MPI_Wtime() - w0, cpu = cpu_now() - c0, cmax = cpu, csum = cpu;
    MPI_Allreduce(MPI_IN_PLACE, &cmax, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    MPI_Allreduce(MPI_IN_PLACE, &csum, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    MPI_Allreduce(MPI_IN_PLACE, &wall, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    dd_stats ds;
    dd_run_stats(d, &ds);
    double rss = peak_rss_mb(), rss_max = rss;
    MPI_Allreduce(MPI_IN_PLACE, &rss_max, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    dd_budget b;
    dd_budget_global(d, &b);
    if (rank == 0) {
        double ps = (double)N * steps;
        char row[768];
        snprintf(row, sizeof row, "%d,%ld,%d,%d,%.4f,%.4f,%.4f,%.4f,%.1f,%.2f,%.1f,%.3f,%.1f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.1f",
                 size, N, steps, iters, wall / steps, cmax / steps, csum / steps, (double)ds.halo / ps,
                 ds.halo_bytes / steps, ds.halo_bytes / ps, ds.migrate_bytes / steps,
                 (double)ds.owned_max * size / (double)ds.owned, t_init, wait_old / steps, wait_old_min / steps,
                 red_old / steps, ds.wait_s / steps, ds.wait_min_s / steps, ds.reduce_s / steps, rss_max);
        printf("ranks,N,steps,iters,wall_step_s,cpu_max_step_s,cpu_sum_step_s,halo_frac,halo_bytes_step,"
               "halo_bytes_per_particle_step,migrate_bytes_step,imbalance,init_s,wait_old_max_step_s,"
               "wait_old_min_step_s,reduce_old_step_s,wait_max_step_s,wait_min_step_s,reduce_step_s,rss_max_mb\n%s\n", row);
        if (csv) {
            FILE *f = fopen(csv, "a");
            if (f) {
                fprintf(f, "%s\n", row);
                fclose(f);
            }
        }
        printf("  mass %.6g kg, rms speed %.3f m/s\n", b.mass, sqrt(2 * b.kinetic_energy / b.mass));
    }
    dd_free(d);
    sph_model_free(m);
    MPI_Finalize();
    return 0;
}
#endif
