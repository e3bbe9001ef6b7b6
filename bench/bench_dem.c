/* DEM throughput (issue 25): contact and bond updates per second of the
 * DEM core on 1 and 2 threads at 1e4 and 1e5 particles: a bonded level
 * sheet (cubic lattice, three layers of 0.1 m spheres, 3 bonds per
 * sphere) driven at 0.5 m/s into a 1.6 m leg, gravity and water on.
 * An update is one intact bond or one touching pair evaluated in a step.
 *
 * Anchor: LAMMPS's granular chute benchmark (pair gran/hooke/history,
 * 32 000 spheres, 115 133 neighbour pairs, 100 steps) ran in 0.2928 s on
 * one core (lammps/lammps bench/POTENTIALS/log.16Mar18.granular.1):
 * 3.93e7 pair updates/s, 1.09e7 particle-steps/s. The rows give the
 * ratio to that (different machines: an order of magnitude, not a race).
 * Wall-clock rates on a loaded machine include the neighbours' load; the
 * config column adds updates per CPU second.
 *
 * Output: CSV rows of bench/out/results.csv (bench/bench_common.h). */
#include <omp.h>

#include "bench_common.h"
#include "core/dem.h"

#define LAMMPS_CHUTE_PAIRS_PER_S (115133.0 * 100.0 / 0.292816)

static double run(long n_target, int threads, int steps, double *pps, double *upd)
{
    omp_set_num_threads(threads);
    dem_params p;
    dem_params_default(&p);
    int nz = 3;
    int nx = (int)sqrt((double)n_target / nz), ny = (int)(n_target / nz / nx);
    size_t np = (size_t)nx * ny * nz;
    dem *d = dem_create(np, 3 * np, &p);
    double r = 0.05;
    dem_add_sheet(d, 0.0, 0.0, nx, ny, nz, r, 0.5, 0.0);
    d->s.kind = DEM_STRUCT_CYLINDER;
    d->s.diameter = 1.6;
    d->s.x0 = 2 * r * (nx - 1) + r + 0.8 - 0.02; /* 2 cm into the sheet: contacts from the start */
    d->s.y0 = r * (ny - 1);
    d->s.mass = 300e3;
    d->s.stiffness = 5e8;
    d->s.damping_ratio = 0.03;
    double dt = 0.5 * p.dt_safety * dem_dt_critical(d);
    sph_status st;
    double updates = 0.0;
    double t0 = bench_wall();
    for (int s = 0; s < steps; s++) {
        dem_step(d, dt, &st);
        updates += (double)d->bonds_intact + 0.5 * (double)d->contacts;
    }
    double wall = bench_wall() - t0;
    *pps = (double)np * steps / wall;
    *upd = updates;
    dem_free(d);
    return updates / wall;
}

int main(void)
{
    long sizes[2] = {10000, 100000};
    int steps[2] = {200, 30};
    if (bench_quick()) {
        steps[0] = 40;
        steps[1] = 6;
    }
    printf(BENCH_CSV_HEADER "\n");
    for (int k = 0; k < 2; k++) {
        double base = 0.0;
        for (int th = 1; th <= 2; th++) {
            bench_row row;
            bench_row_init(&row, "dem_throughput");
            double pps, upd, c0 = bench_cpu(), w0 = bench_wall();
            double ups = run(sizes[k], th, steps[k], &pps, &upd);
            row.cpu_s = bench_cpu() - c0;
            row.wall_s = bench_wall() - w0;
            row.rss_mb = bench_peak_rss_mb();
            if (th == 1)
                base = ups;
            snprintf(row.method, sizeof row.method, "dem threads=%d", th);
            /* per CPU second too: on a shared machine the wall clock
             * measures the neighbours' load as well */
            snprintf(row.config, sizeof row.config,
                     "n=%ld steps=%d particle_steps_per_wall_s=%.4g updates_per_cpu_s=%.4g",
                     sizes[k], steps[k], pps, upd / row.cpu_s);
            row.err_name[0] = "updates_per_s";
            row.err[0] = ups;
            row.err_name[1] = "speedup_vs_1_thread";
            row.err[1] = ups / base;
            row.err_name[2] = "ratio_vs_lammps_chute";
            row.err[2] = ups / LAMMPS_CHUTE_PAIRS_PER_S;
            bench_row_print(&row);
        }
    }
    return 0;
}
