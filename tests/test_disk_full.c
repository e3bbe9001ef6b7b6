/* A full disk while the products are written (issue 21, item 2).
 *
 * The disk is "full" for a child process through RLIMIT_FSIZE with SIGXFSZ
 * ignored: every write past the limit fails with EFBIG, as a write to a
 * full file system fails with ENOSPC, and HDF5 can then neither flush nor
 * close the product it was writing. `sphice run` and `sphice hindcast` of
 * the small real case (tests/engine_case.h) must then exit 1 with one
 * error line -- not die with SIGSEGV (139) in HDF5's exit handler -- and
 * leave the published cycle and `latest` exactly as they were. */
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "check.h"
#include "engine_case.h"
#include "service/cycle.h"
#include "util/fileio.h"

static char dir[] = "/tmp/sphice-disk-full-XXXXXX";
static char exe[512];

/* Runs exe with argv; fsize > 0: with that file-size limit (bytes) and
 * SIGXFSZ ignored. Returns the exit status, 128 + signal when killed. */
static int run_cmd(char *const argv[], const char *log, rlim_t fsize)
{
    pid_t pid = fork();
    if (pid == 0) {
        unsetenv("SPHICE_TEST_ENGINE");
        int fd = open(log, O_CREAT | O_WRONLY | O_TRUNC, 0644);
        if (fd >= 0) {
            dup2(fd, 1);
            dup2(fd, 2);
        }
        if (fsize > 0) {
            signal(SIGXFSZ, SIG_IGN); /* kept across exec */
            struct rlimit rl = {fsize, fsize};
            if (setrlimit(RLIMIT_FSIZE, &rl) != 0)
                _exit(126);
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

/* Lines of the log that say "error" (the one error line and the program's
 * own line repeating it are both allowed: at most 2). */
static int error_lines(const char *log)
{
    char *text = NULL;
    size_t len;
    sph_error e;
    sph_error_clear(&e);
    if (read_file(log, &text, &len, &e) != SPH_OK)
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
    char text[8192], config[1024], log[1024], out[1024], hc[1024];
    ec_config(text, sizeof text, dir, 300, "[\"wind\", \"tair\"]", "ice.nc", "\"log_level\": \"warn\",");
    char *fh = strstr(text, "\"forecast_hours\": 6"); /* hindcast: 3 h as run --hours 3 */
    CHECK(fh != NULL, "config text");
    if (fh)
        fh[18] = '3';
    snprintf(config, sizeof config, "%s/sphice.json", dir);
    snprintf(log, sizeof log, "%s/log.txt", dir);
    snprintf(out, sizeof out, "%s/run", dir);
    snprintf(hc, sizeof hc, "%s/hc", dir);
    sph_error e;
    sph_error_clear(&e);
    CHECK(atomic_write_file(config, text, strlen(text), &e) == SPH_OK, "%s", e.msg);

    /* a good cycle first: what must stay */
    char *good[] = {exe, "run", config, "--cycle", "1999-02-08T06:00Z", "--hours", "3", "--out", out, NULL};
    int rc = run_cmd(good, log, 0);
    CHECK(rc == 0, "the good cycle exits 0 (got %d)", rc);
    if (rc)
        show_log(log);
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
        rc = run_cmd(full, log, limits[k]);
        CHECK(rc == 1, "limit %ld: run on a full disk exits 1, not %d (139: SIGSEGV at exit)", (long)limits[k], rc);
        int nerr = error_lines(log);
        CHECK(nerr >= 1 && nerr <= 2, "limit %ld: run on a full disk: one error line (%d)", (long)limits[k], nerr);
        if (rc != 1 || nerr < 1 || nerr > 2)
            show_log(log);
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

        char *hfull[] = {exe, "hindcast", config, "--from", "1999-02-08T12:00Z", "--to", "1999-02-08T12:00Z",
                         "--out", hc, "--force", NULL};
        rc = run_cmd(hfull, log, limits[k]);
        CHECK(rc == 1, "limit %ld: hindcast on a full disk exits 1, not %d (139: SIGSEGV at exit)",
              (long)limits[k], rc);
        if (rc != 1)
            show_log(log);
        snprintf(p, sizeof p, "%s/19990208T12Z", hc);
        CHECK(access(p, F_OK) != 0, "nothing published by the failed hindcast (%s)", p);
    }

    if (!check_failed_)
        cycle_remove_tree(dir);
    return check_summary("test_disk_full");
}
