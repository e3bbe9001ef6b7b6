/* The plain half of an MPI identity test (test_mpi_dd, test_mpi_season):
 * the plain build writes the serial reference, then runs the MPI build's
 * copy of the same test under mpirun for each rank and thread count; the
 * MPI copy compares and exits non-zero on a difference. */
#ifndef SPHICE_TESTS_MPI_LAUNCH_H
#define SPHICE_TESTS_MPI_LAUNCH_H

#include <stdio.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "check.h"

static inline int mpi_launch_run(const char *cmd)
{
    int rc = system(cmd);
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

/* Runs build-mpi/tests/NAME (or the binary in $binenv) on dir with np[i]
 * ranks and nt[i] threads per rank for i < nrun; one check per run, or one
 * line saying why the runs were skipped (no mpirun, no MPI build). */
static inline void mpi_launch(const char *name, const char *binenv, const char *dir, const int *np, const int *nt,
                       int nrun)
{
    const char *build = getenv("BUILD") ? getenv("BUILD") : "build";
    char bin[600], cmd[1400];
    snprintf(bin, sizeof bin, "%s/../build-mpi/tests/%s", build, name);
    if (getenv(binenv)) /* another MPI build's copy (e.g. a sanitizer build) */
        snprintf(bin, sizeof bin, "%s", getenv(binenv));
    if (mpi_launch_run("command -v mpirun >/dev/null 2>&1") != 0 || access(bin, X_OK) != 0) {
        printf("%s: skipped the MPI runs: needs mpirun and build-mpi/tests/%s "
               "(sh tools/install-deps.sh --mpi; make mpi-build)\n", name, name);
        return;
    }
    for (int i = 0; i < nrun; i++) {
        struct timespec t0, t1;
        clock_gettime(CLOCK_MONOTONIC, &t0);
        snprintf(cmd, sizeof cmd, "OMP_NUM_THREADS=%d OMP_WAIT_POLICY=passive mpirun %s --oversubscribe -np %d %s %s",
                 nt[i], geteuid() == 0 ? "--allow-run-as-root" : "", np[i], bin, dir);
        int rc = mpi_launch_run(cmd);
        clock_gettime(CLOCK_MONOTONIC, &t1);
        double wall = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
        CHECK(rc == 0, "mpirun -np %d, %d threads: the decomposed run equals the serial one (exit %d)", np[i], nt[i],
              rc);
        printf("  -np %d, %d threads: %.2f s wall\n", np[i], nt[i], wall);
    }
}

#endif
