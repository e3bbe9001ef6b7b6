/* The mixed layer's replicated step under the domain decomposition
 * (docs/domain.md "The ocean's replicated step"): every rank gathers every
 * particle twice per thermodynamic step and steps the ocean over all of
 * them (core/ocean/ocean_dd.c), so its share of a rank's step grows with
 * the rank count while the rest of the step is divided.
 *
 *   mpirun -np P build-mpi/bench/bench_mpi_ocean [N] [STEPS] [ITERS]
 *
 * The case of bench/bench_new_ice.c (docs/ocean.md "Cost"): N particles
 * on a 1 km lattice (0.4 m ice, concentration 0.9) over the west four
 * fifths of a closed box, open water in the east fifth where new particles
 * are created, merging on; -15 C, dark, wind 6 m/s; mEVP with ITERS
 * iterations (default: the model's) and no early stop, thermodynamics
 * every step (dt 150 s). Rank 0 initialises the serial canonical model and
 * scatters it; one warm-up step, then STEPS timed steps. Prints, per rank,
 * the wall and CPU seconds per step and the particles it owns, and the
 * global particle and created counts. The ocean's share is read from a
 * profile of each rank (perf, the command in docs/domain.md): the inclusive
 * samples of sph_dd_ocean_before + sph_dd_ocean_after + sph_dd_ice_totals
 * over dd_step's. Not an MPI build: says so and exits 0. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#ifndef SPHICE_MPI
int main(void)
{
    printf("bench_mpi_ocean: needs the MPI build (make MPI=1 BUILD=build-mpi build-mpi/bench/bench_mpi_ocean)\n");
    return 0;
}
#else
#include <mpi.h>

#include "core/dd.h"
#include "core/model.h"
#include "core/ocean.h"
#include "core/thermo.h"
#include "service/domain_mpi.h"

#include "new_ice_forcing.h"

#define DS 1000.0 /* lattice spacing, m */

static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}


static unsigned char *land;

/* The box's model (mixed layer with creation and merging), cap slots, no
 * particles; the lattice's side in *side. */
static sph_model *make(long n, int iters, size_t cap, int *side_out, int *nx_out)
{
    sph_params p;
    sph_params_default(&p);
    p.dt = 150.0;
    p.thermo_dt = 150.0;
    p.ocean.mixed_layer = 1;
    p.ocean.create = 1;
    p.ocean.merge = 1;
    p.ocean.new_thickness = 0.001;
    p.evp_tol = 0.0;
    p.evp_stall_window = 0;
    if (iters > 0)
        p.evp_iterations = iters;
    int side = (int)ceil(sqrt((double)n));
    int nx = side + (side + 3) / 4, ny = side;
    if (!land)
        land = calloc((size_t)nx * ny, 1); /* all sea; closed box */
    sph_landmask mk = {nx, ny, 0.0, 0.0, DS, DS, land, 1};
    sph_model *m = land ? sph_model_create(&p, cap, &mk) : NULL;
    sph_ocean_grid g = {(nx + 3) / 4, (ny + 3) / 4, 0.0, 0.0, 4 * DS, 4 * DS, 0.5 * DS, 0.5 * DS, DS};
    if (!m || sph_model_set_canonical(m, 1) || sph_model_ocean_create(m, &g) != SPH_STEP_OK) {
        sph_model_free(m);
        return NULL;
    }
    *side_out = side;
    *nx_out = nx;
    return m;
}

int main(int argc, char **argv)
{
    MPI_Init(&argc, &argv);
    int rank, size;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    long N = argc > 1 ? atol(argv[1]) : 100000;
    int steps = argc > 2 ? atoi(argv[2]) : 3, iters = argc > 3 ? atoi(argv[3]) : 0;
    int side = 0, nx = 0;
    /* every slot a lattice point of the box can take (new particles), on
     * every rank: the view holds them all */
    long sd = (long)ceil(sqrt((double)N));
    size_t cap = (size_t)(sd + (sd + 3) / 4) * (size_t)sd + 16;
    sph_status st;
    sph_model *root = NULL;
    sph_model_clock clk;
    const sph_particles *all = NULL;
    if (rank == 0) {
        root = make(N, iters, cap, &side, &nx);
        if (!root)
            MPI_Abort(MPI_COMM_WORLD, 2);
        const sph_params *p = sph_model_params(root);
        sph_particles *P = sph_model_particles(root);
        size_t k = 0;
        for (int j = 0; j < side; j++)
            for (int i = 0; i < side && k < (size_t)N; i++, k++) {
                P->x[k] = (i + 0.5) * DS;
                P->y[k] = (j + 0.5) * DS;
                P->thick[k] = 0.4;
                P->conc[k] = 0.9;
                P->mass[k] = p->thermo.rho_i * 0.9 * 0.4 * DS * DS;
                P->sml[k] = DS;
                P->id[k] = (long)k;
            }
        P->n = k;
        new_ice_forcing(root);
        for (size_t q = 0; q < P->n; q++)
            sph_thermo_init_particle(&p->thermo, P, q, -15.0);
        if (sph_model_init(root, &st) != SPH_STEP_OK) {
            fprintf(stderr, "bench_mpi_ocean: init: %s %s\n", st.quantity ? st.quantity : "", st.what ? st.what : "");
            MPI_Abort(MPI_COMM_WORLD, 2);
        }
        sph_model_get_clock(root, &clk);
        all = P;
    }
    sph_model *m = make(N, iters, cap, &side, &nx);
    dd_options o = {0.0, 0.0, nx * DS, side * DS, 3 * DS, 10};
    dd_ctx *d = m ? dd_create(MPI_COMM_WORLD, m, &o) : NULL;
    if (!d)
        MPI_Abort(MPI_COMM_WORLD, 2);
    new_ice_forcing(m);
    if (dd_scatter(d, all, &clk, &st) != SPH_STEP_OK)
        MPI_Abort(MPI_COMM_WORLD, 2);
    sph_model_free(root);
    int ok = 1;
    for (int s = 0; s < 1 + steps && ok; s++) {
        if (s == 1) {
            MPI_Barrier(MPI_COMM_WORLD);
            dd_reset_stats(d);
        }
        static double w0, c0;
        if (s == 1) {
            w0 = MPI_Wtime();
            c0 = cpu_now();
        }
        new_ice_forcing(m);
        if (dd_step(d, &st) != SPH_STEP_OK) {
            if (rank == 0)
                fprintf(stderr, "bench_mpi_ocean: step %d: %s %s\n", s, st.quantity ? st.quantity : "",
                        st.what ? st.what : "");
            ok = 0;
        }
        if (s == steps) {
            double wall = (MPI_Wtime() - w0) / steps, cpu = (cpu_now() - c0) / steps;
            size_t own = sph_model_particles(m)->n;
            printf("bench_mpi_ocean rank %d of %d: %.3f s wall, %.3f s CPU per step, %zu particles owned\n", rank,
                   size, wall, cpu, own);
        }
    }
    long count = (long)sph_model_particles(m)->n;
    MPI_Allreduce(MPI_IN_PLACE, &count, 1, MPI_LONG, MPI_SUM, MPI_COMM_WORLD);
    const sph_budget *ob = sph_model_budget(m);
    if (rank == 0)
        printf("bench_mpi_ocean: %d ranks, N %ld, %d timed steps: %ld particles, %ld created, %ld merged%s\n", size,
               N, steps, count, ob->created_particles, ob->merged_particles, ok ? "" : " (a step failed)");
    dd_free(d);
    sph_model_free(m);
    free(land);
    MPI_Finalize();
    return ok ? 0 : 1;
}
#endif
