/* Ensemble members over MPI ranks (issue 24): `sphice run` of a perturbed
 * 3-member ensemble on the small engine case (tests/engine_case.h), once
 * serially (build/sphice) and under `mpirun --oversubscribe -np 2` and
 * `-np 4` (build-mpi/sphice, make MPI=1): the ensemble products and the
 * control's fields must be identical bit for bit. Skipped with one line
 * when mpirun or the MPI build is absent (sh tools/install-deps.sh --mpi;
 * make check builds build-mpi/sphice when mpicc is installed). */
#include <netcdf.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "check.h"
#include "engine_case.h"
#include "service/cycle.h"

static char dir[] = "/tmp/sphice-ensmpi-XXXXXX";

static int run(const char *cmd)
{
    int rc = system(cmd);
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

static int same_var(const char *a, const char *b, const char *var, size_t n)
{
    float *x = malloc(n * sizeof *x), *y = malloc(n * sizeof *y);
    int na, nb, va, vb, ok = x && y;
    ok = ok && nc_open(a, NC_NOWRITE, &na) == NC_NOERR;
    ok = ok && nc_open(b, NC_NOWRITE, &nb) == NC_NOERR;
    ok = ok && nc_inq_varid(na, var, &va) == NC_NOERR && nc_inq_varid(nb, var, &vb) == NC_NOERR;
    ok = ok && nc_get_var_float(na, va, x) == NC_NOERR && nc_get_var_float(nb, vb, y) == NC_NOERR;
    ok = ok && memcmp(x, y, n * sizeof *x) == 0;
    nc_close(na);
    nc_close(nb);
    free(x);
    free(y);
    return ok;
}

int main(int argc, char **argv)
{
    (void)argc;
    ec_passive_openmp(argv);
    char mpi_bin[512], ser_bin[512];
    ec_sphice_bins(ser_bin, mpi_bin, sizeof ser_bin);
    if (run("command -v mpirun >/dev/null 2>&1") != 0 || access(mpi_bin, X_OK) != 0) {
        printf("test_ensemble_mpi: skipped: needs mpirun and build-mpi/sphice (sh tools/install-deps.sh --mpi; "
               "make MPI=1)\n");
        return check_summary("test_ensemble_mpi");
    }
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    ec_write_inputs(dir);
    char text[8192], path[1200], cmd[4096];
    ec_config(text, sizeof text, dir, 300, "[\"wind\", \"tair\"]", "ice.nc",
              "\"ensemble\": {\"members\": 3, \"seed\": 9, \"wind\": {\"sigma\": 3, \"length_km\": 30},"
              " \"initial\": {\"thick_sigma\": 0.2}},");
    snprintf(path, sizeof path, "%s/cfg.json", dir);
    FILE *f = fopen(path, "w");
    CHECK(f && fputs(text, f) >= 0, "write config");
    if (f)
        fclose(f);
    const char *mpirun = "mpirun --oversubscribe -x OMP_NUM_THREADS=1 -x OMP_WAIT_POLICY=passive";
    const char *root = geteuid() == 0 ? "--allow-run-as-root" : "";
    snprintf(cmd, sizeof cmd, "OMP_NUM_THREADS=1 %s run %s --cycle 1999-02-08T06:00Z --hours 2 --out %s/serial "
             "--force >%s/serial.log 2>&1", ser_bin, path, dir, dir);
    CHECK(run(cmd) == 0, "serial run (%s/serial.log)", dir);
    const int np[2] = {2, 4};
    for (int i = 0; i < 2; i++) {
        snprintf(cmd, sizeof cmd, "%s %s -np %d %s run %s --cycle 1999-02-08T06:00Z --hours 2 --out %s/np%d "
                 "--force >%s/np%d.log 2>&1", mpirun, root, np[i], mpi_bin, path, dir, np[i], dir, np[i]);
        int rc = run(cmd);
        CHECK(rc == 0, "mpirun -np %d: rc %d (%s/np%d.log)", np[i], rc, dir, np[i]);
        const char *files[2] = {"sphice_ensemble.nc", "sphice_fields.nc"};
        const char *vars[2][3] = {{"siconc_mean", "siconc_spread", "sivol_spread"}, {"siconc", "sivol", "siu"}};
        for (int k = 0; k < 2; k++)
            for (int v = 0; v < 3; v++) {
                char a[1400], b[1400];
                snprintf(a, sizeof a, "%s/serial/19990208T06Z/%s", dir, files[k]);
                snprintf(b, sizeof b, "%s/np%d/19990208T06Z/%s", dir, np[i], files[k]);
                CHECK(same_var(a, b, vars[k][v], (size_t)3 * 61 * 101), "-np %d: %s %s identical to the serial run",
                      np[i], files[k], vars[k][v]);
            }
    }
    if (!getenv("SPHICE_KEEP") && !check_failed_)
        cycle_remove_tree(dir);
    return check_summary("test_ensemble_mpi");
}
