/* The machine's own 2-thread ceiling for loops shaped like a free-drift
 * step (issue 22, docs/bench.md "Session 12"): NA arrays of N doubles, and
 * per step NR parallel loops (a step's regions) over the particles, each
 * reading five arrays and writing one. No sphice code: what the OpenMP
 * runtime and the machine give such loops, to compare with a whole run's
 * speed-up under the same OMP_WAIT_POLICY.
 * Usage: bench_omp_regions [N [STEPS [STATIC]]] (1e5, 576, 0: dynamic
 * chunks of 1024; 1: static). Prints wall and CPU seconds. */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/resource.h>

#define NA 40
#define NR 21

static double cpu_seconds(void)
{
    struct rusage r;
    getrusage(RUSAGE_SELF, &r);
    return (double)(r.ru_utime.tv_sec + r.ru_stime.tv_sec) + 1e-6 * (double)(r.ru_utime.tv_usec + r.ru_stime.tv_usec);
}

int main(int argc, char **argv)
{
    double nd = argc > 1 ? atof(argv[1]) : 1e5;
    int steps = argc > 2 ? atoi(argv[2]) : 576;
    int stat = argc > 3 ? atoi(argv[3]) : 0;
    if (!(nd >= 1.0 && nd <= 1e8) || steps < 1) {
        fprintf(stderr, "bench_omp_regions: N in [1, 1e8] and STEPS >= 1, got \"%s\" and %d\n",
                argc > 1 ? argv[1] : "", steps);
        return 2;
    }
    size_t n = (size_t)nd;
    double *a[NA];
    for (int k = 0; k < NA; k++) {
        a[k] = malloc(n * sizeof(double));
        if (!a[k]) {
            fprintf(stderr, "bench_omp_regions: out of memory (%zu doubles)\n", n);
            return 1;
        }
        for (size_t i = 0; i < n; i++)
            a[k][i] = 1.0 + 1e-3 * (double)((i * 7 + (size_t)k) % 97);
    }
    double w0 = omp_get_wtime(), c0 = cpu_seconds();
    for (int s = 0; s < steps; s++)
        for (int r = 0; r < NR; r++) {
            const double *x = a[(r * 3) % NA], *y = a[(r * 3 + 1) % NA], *z = a[(r * 3 + 2) % NA];
            const double *u = a[(r * 5 + 7) % NA], *v = a[(r * 5 + 11) % NA];
            double *o = a[(r * 7 + 13) % NA];
            if (stat) {
#pragma omp parallel for schedule(static)
                for (size_t i = 0; i < n; i++) {
                    double t = x[i] * y[i] + z[i];
                    o[i] = 0.5 * o[i] + 1e-9 * sqrt(t * t + u[i] * u[i]) + 1e-12 * v[i];
                }
            } else {
#pragma omp parallel for schedule(dynamic, 1024)
                for (size_t i = 0; i < n; i++) {
                    double t = x[i] * y[i] + z[i];
                    o[i] = 0.5 * o[i] + 1e-9 * sqrt(t * t + u[i] * u[i]) + 1e-12 * v[i];
                }
            }
        }
    double wall = omp_get_wtime() - w0, cpu = cpu_seconds() - c0, sum = 0.0;
    for (int k = 0; k < NA; k++) {
        sum += a[k][n / 2];
        free(a[k]);
    }
    printf("n %zu threads %d sched %s: wall %.3f s cpu %.3f s (checksum %g)\n", n, omp_get_max_threads(),
           stat ? "static" : "dynamic", wall, cpu, sum);
    return 0;
}
