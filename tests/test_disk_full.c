/* A full disk while the products are written (issue 21, item 2).
 *
 * The disk is "full" for a child process through RLIMIT_FSIZE with SIGXFSZ
 * ignored: every write past the limit fails with EFBIG, as a write to a
 * full file system fails with ENOSPC, and HDF5 can then neither flush nor
 * close the product it was writing. `sphice run` and `sphice hindcast` of
 * the small real case (tests/engine_case.h) must then exit 1 with one
 * error line -- not die with SIGSEGV (139) in HDF5's exit handler -- and
 * leave the published cycle and `latest` exactly as they were. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include "check.h"
#include "engine_case.h"
#include "exec_case.h"
#include "service/cycle.h"
#include "util/fileio.h"

static char dir[] = "/tmp/sphice-disk-full-XXXXXX";
static char exe[512];

/* Lines of the log that say "error" (the one error line and the program's
 * own line repeating it are both allowed: at most 2). */
static int error_lines(const char *log)
{
    char *text = xc_slurp(log);
    if (!text)
        return -1;
    int n = 0;
    for (char *line = text; line && *line;) {
        char *nl = strchr(line, '\n');
        if (nl)
            *nl = 0;
        if (strstr(line, " error: ") || !strncmp(line, "sphice run: ", 12) || !strncmp(line, "sphice hindcast: ", 17))
            n++;
        line = nl ? nl + 1 : NULL;
    }
    free(text);
    return n;
}

static long file_size(const char *p)
{
    struct stat st;
    return stat(p, &st) == 0 ? (long)st.st_size : -1;
}

int main(int argc, char **argv)
{
    (void)argc;
    ec_passive_openmp(argv);
    if (xc_find_sphice(exe, sizeof exe))
        return 1;
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    ec_write_inputs(dir);
    /* run: cycles 06Z and 12Z for 3 h; hindcast: 06Z for the configured
     * 6 h (the forcing ends at 15Z) */
    char text[8192], config[1024], log[1024], out[1024], hc[1024];
    ec_config(text, sizeof text, dir, 300, "[\"wind\", \"tair\"]", "ice.nc", "\"log_level\": \"warn\",");
    const struct { char *buf; const char *name; } paths[] = {
        {config, "sphice.json"}, {log, "log.txt"}, {out, "run"}, {hc, "hc"}};
    for (size_t k = 0; k < sizeof paths / sizeof paths[0]; k++)
        snprintf(paths[k].buf, 1024, "%s/%s", dir, paths[k].name);
    sph_error e;
    sph_error_clear(&e);
    CHECK(atomic_write_file(config, text, strlen(text), &e) == SPH_OK, "%s", e.msg);

    /* a good cycle first: what must stay */
    char *good[] = {exe, "run", config, "--cycle", "1999-02-08T06:00Z", "--hours", "3", "--out", out, NULL};
    int rc = xc_run(good, log, NULL);
    CHECK(rc == 0, "the good cycle exits 0 (got %d)", rc);
    if (rc)
        xc_show_log(log);
    char fields[2048], sum_before[65] = "", sum_after[65] = "";
    snprintf(fields, sizeof fields, "%s/19990208T06Z/sphice_fields.nc", out);
    long size = file_size(fields);
    CHECK(size > 4096, "%s: %ld bytes", fields, size);
    CHECK(sha256_file(fields, sum_before, &e) == SPH_OK, "%s", e.msg);

    /* Two limits: below the restart file (the first NetCDF file written
     * fails), and between the restart file and the smaller of the fields
     * and particles files (the restart file fits, the products do not).
     * Small files -- the history, the manifests, the log -- fit in both. */
    char restart[2048], particles[2048];
    snprintf(restart, sizeof restart, "%s/19990208T06Z/restart-19990208T12Z.nc", out);
    snprintf(particles, sizeof particles, "%s/19990208T06Z/sphice_particles.nc", out);
    long rsize = file_size(restart), psize = file_size(particles);
    long products = psize < size ? psize : size;
    CHECK(rsize > 4096 && products > rsize, "sizes: restart %ld, products %ld bytes", rsize, products);
    rlim_t limits[2] = {(rlim_t)(rsize > 8192 ? rsize / 2 : 4096), (rlim_t)((rsize + products) / 2)};
    for (int k = 0; k < 2; k++) {
        char *full[] = {exe, "run", config, "--cycle", "1999-02-08T12:00Z", "--hours", "3", "--out", out, NULL};
        xc_opts full_disk = {NULL, (long)limits[k]};
        rc = xc_run(full, log, &full_disk);
        CHECK(rc == 1, "limit %ld: run on a full disk exits 1, not %d (139: SIGSEGV at exit)", (long)limits[k], rc);
        int nerr = error_lines(log);
        CHECK(nerr >= 1 && nerr <= 2, "limit %ld: run on a full disk: one error line (%d)", (long)limits[k], nerr);
        if (rc != 1 || nerr < 1 || nerr > 2)
            xc_show_log(log);
        char p[2048], target[256];
        snprintf(p, sizeof p, "%s/latest", out);
        ssize_t n = readlink(p, target, sizeof target - 1);
        if (n > 0)
            target[n] = 0;
        CHECK(n > 0 && strcmp(target, "19990208T06Z") == 0, "latest still -> 19990208T06Z (%s)",
              n > 0 ? target : "none");
        CHECK(sha256_file(fields, sum_after, &e) == SPH_OK && strcmp(sum_before, sum_after) == 0,
              "the published fields file is unchanged");
        snprintf(p, sizeof p, "%s/19990208T12Z", out);
        CHECK(access(p, F_OK) != 0, "nothing published for the failed cycle (%s)", p);
        CHECK(ec_count_entries(out) == 2, "only the good cycle and latest in %s (%d entries)", out,
              ec_count_entries(out));

        char *hfull[] = {exe, "hindcast", config, "--from", "1999-02-08T06:00Z", "--to", "1999-02-08T06:00Z",
                         "--out", hc, "--force", NULL};
        rc = xc_run(hfull, log, &full_disk);
        CHECK(rc == 1, "limit %ld: hindcast on a full disk exits 1, not %d (139: SIGSEGV at exit)",
              (long)limits[k], rc);
        if (rc != 1)
            xc_show_log(log);
        snprintf(p, sizeof p, "%s/19990208T06Z", hc);
        CHECK(access(p, F_OK) != 0, "nothing published by the failed hindcast (%s)", p);
    }

    if (!check_failed_)
        cycle_remove_tree(dir);
    return check_summary("test_disk_full");
}
