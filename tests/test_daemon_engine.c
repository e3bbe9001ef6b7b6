/* The real engine behind the service commands, on the small synthetic case
 * (tests/engine_case.h): `sphice run CONFIG --cycle ... --hours 3 --out DIR`
 * exits 0 and publishes DIR/<cycle>/ and DIR/latest; `sphice hindcast` of
 * the same cycle writes identical NetCDF data variables (determinism: no
 * wall clock, no uninitialised memory in what the engine writes). */
#include <fcntl.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "check.h"
#include "engine_case.h"
#include "service/cycle.h"
#include "util/fileio.h"

static char dir[] = "/tmp/sphice-daemon-engine-XXXXXX";
static char exe[512];

static int run_cmd(char *const argv[], const char *log)
{
    pid_t pid = fork();
    if (pid == 0) {
        unsetenv("SPHICE_TEST_ENGINE");
        int fd = open(log, O_CREAT | O_WRONLY | O_APPEND, 0644);
        if (fd >= 0) {
            dup2(fd, 1);
            dup2(fd, 2);
        }
        execv(exe, argv);
        _exit(127);
    }
    int st;
    if (waitpid(pid, &st, 0) != pid)
        return -1;
    return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

static void show_log(const char *log)
{
    char *text = NULL;
    size_t len;
    sph_error e;
    sph_error_clear(&e);
    if (read_file(log, &text, &len, &e) == SPH_OK)
        fprintf(stderr, "--- %s\n%s---\n", log, text);
    free(text);
}

/* Compares every variable's values (not attributes: they carry the git
 * revision and file names). Returns the number of differing variables. */
static int compare_data(const char *a, const char *b, int *nvars_out)
{
    int na, nb, diff = 0;
    *nvars_out = 0;
    if (nc_open(a, NC_NOWRITE, &na) != NC_NOERR)
        return 1000;
    if (nc_open(b, NC_NOWRITE, &nb) != NC_NOERR) {
        nc_close(na);
        return 1000;
    }
    int nvars = 0, nvb = 0;
    nc_inq_nvars(na, &nvars);
    nc_inq_nvars(nb, &nvb);
    if (nvars != nvb)
        diff++;
    for (int v = 0; v < nvars; v++) {
        char name[NC_MAX_NAME + 1];
        nc_type type;
        int ndims, dims[NC_MAX_VAR_DIMS], vb;
        nc_inq_var(na, v, name, &type, &ndims, dims, NULL);
        if (nc_inq_varid(nb, name, &vb) != NC_NOERR) {
            fprintf(stderr, "variable %s missing in %s\n", name, b);
            diff++;
            continue;
        }
        size_t count = 1, len;
        for (int d = 0; d < ndims; d++) {
            nc_inq_dimlen(na, dims[d], &len);
            count *= len;
        }
        int ndb, dimsb[NC_MAX_VAR_DIMS];
        size_t countb = 1;
        nc_inq_varndims(nb, vb, &ndb);
        nc_inq_vardimid(nb, vb, dimsb);
        for (int d = 0; d < ndb; d++) {
            nc_inq_dimlen(nb, dimsb[d], &len);
            countb *= len;
        }
        if (count != countb) {
            fprintf(stderr, "variable %s: %zu vs %zu values\n", name, count, countb);
            diff++;
            continue;
        }
        (*nvars_out)++;
        if (count == 0)
            continue;
        if (type == NC_STRING) {
            char **sa = calloc(count, sizeof *sa), **sb = calloc(count, sizeof *sb);
            nc_get_var_string(na, v, sa);
            nc_get_var_string(nb, vb, sb);
            for (size_t k = 0; k < count; k++)
                if (strcmp(sa[k] ? sa[k] : "", sb[k] ? sb[k] : "")) {
                    diff++;
                    fprintf(stderr, "variable %s differs\n", name);
                    break;
                }
            nc_free_string(count, sa);
            nc_free_string(count, sb);
            free(sa);
            free(sb);
            continue;
        }
        size_t size;
        if (nc_inq_type(na, type, NULL, &size) != NC_NOERR || type > NC_MAX_ATOMIC_TYPE)
            continue;
        char *ba = malloc(count * size), *bb = malloc(count * size);
        int ok = ba && bb && nc_get_var(na, v, ba) == NC_NOERR && nc_get_var(nb, vb, bb) == NC_NOERR &&
                 memcmp(ba, bb, count * size) == 0;
        if (!ok) {
            fprintf(stderr, "variable %s differs\n", name);
            diff++;
        }
        free(ba);
        free(bb);
    }
    nc_close(na);
    nc_close(nb);
    return diff;
}

int main(int argc, char **argv)
{
    (void)argc;
    ec_passive_openmp(argv);
    const char *build = getenv("BUILD") ? getenv("BUILD") : "build";
    char cwd[256];
    if (!getcwd(cwd, sizeof cwd))
        return 1;
    snprintf(exe, sizeof exe, "%s/%s/sphice", cwd, build);
    if (access(exe, X_OK) != 0) {
        fprintf(stderr, "%s: not built\n", exe);
        return 1;
    }
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    ec_write_inputs(dir);
    char text[8192], config[1024], log[1024], out_run[1024], out_hc[1024];
    ec_config(text, sizeof text, dir, 300, "[\"wind\", \"tair\"]", "ice.nc", "\"log_level\": \"warn\",");
    /* hindcast has no --hours: the configuration says 3 h as `run --hours 3` */
    char *fh = strstr(text, "\"forecast_hours\": 6");
    CHECK(fh != NULL, "config text");
    if (fh)
        fh[18] = '3';
    snprintf(config, sizeof config, "%s/sphice.json", dir);
    snprintf(log, sizeof log, "%s/log.txt", dir);
    snprintf(out_run, sizeof out_run, "%s/run", dir);
    snprintf(out_hc, sizeof out_hc, "%s/hc", dir);
    sph_error e;
    sph_error_clear(&e);
    CHECK(atomic_write_file(config, text, strlen(text), &e) == SPH_OK, "%s", e.msg);

    char *run_argv[] = {exe, "run", config, "--cycle", "1999-02-08T06:00Z", "--hours", "3", "--out", out_run,
                        NULL};
    int rc = run_cmd(run_argv, log);
    CHECK(rc == 0, "sphice run exits 0 (got %d)", rc);
    char p[2048], q[2048], target[256];
    snprintf(p, sizeof p, "%s/19990208T06Z/sphice_fields.nc", out_run);
    CHECK(access(p, R_OK) == 0, "published %s", p);
    snprintf(p, sizeof p, "%s/19990208T06Z/cycle.json", out_run);
    CHECK(access(p, R_OK) == 0, "published %s", p);
    snprintf(p, sizeof p, "%s/19990208T06Z/restart-19990208T12Z.nc", out_run);
    CHECK(access(p, R_OK) == 0, "restart file for the next cycle %s", p);
    snprintf(p, sizeof p, "%s/latest", out_run);
    ssize_t n = readlink(p, target, sizeof target - 1);
    if (n > 0)
        target[n] = 0;
    CHECK(n > 0 && strcmp(target, "19990208T06Z") == 0, "latest -> %s", n > 0 ? target : "(none)");

    char *hc_argv[] = {exe, "hindcast", config, "--from", "1999-02-08T06:00Z", "--to", "1999-02-08T06:00Z",
                       "--out", out_hc, NULL};
    rc = run_cmd(hc_argv, log);
    CHECK(rc == 0, "sphice hindcast exits 0 (got %d)", rc);
    static const char *const files[] = {"sphice_fields.nc", "sphice_particles.nc", "sphice_stations.nc",
                                        "restart-19990208T12Z.nc"};
    for (size_t f = 0; f < sizeof files / sizeof files[0]; f++) {
        snprintf(p, sizeof p, "%s/19990208T06Z/%s", out_run, files[f]);
        snprintf(q, sizeof q, "%s/19990208T06Z/%s", out_hc, files[f]);
        int nv = 0, d = compare_data(p, q, &nv);
        CHECK(d == 0 && nv > 0, "run and hindcast %s: %d of %d variables differ", files[f], d, nv);
        printf("  %s: %d data variables identical in run and hindcast\n", files[f], d == 0 ? nv : 0);
    }
    if (check_failed_)
        show_log(log);
    else
        cycle_remove_tree(dir);
    return check_summary("test_daemon_engine");
}
