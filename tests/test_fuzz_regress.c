/* Inputs the fuzz harnesses (tests/fuzz/) found, replayed in the ordinary
 * build so that the suite keeps them fixed without clang:
 *   fuzz_forcing: a time axis of about -1.1e212 s; the coverage error
 *   formatted it with time_format_iso, whose cast of the day count to long
 *   was undefined. A time that far out (or not finite) is now written as
 *   seconds since 1970, naming the value; one in range keeps ISO 8601.
 *   fuzz_forcing: a regular grid's longitude of -1e300; unwrapping added
 *   360 until it passed its neighbour, for ever (the cycle hung). A
 *   longitude outside -720..720 degrees is now refused naming its value
 *   and index; an alarm turns a hang into a failure.
 *   fuzz_forcing (tests/fuzz/corpus/forcing/regress-classic-ndims): a
 *   classic header declaring 16.7 million dimensions, read as a tide
 *   source; libnetcdf 4.9.0 allocated 890 MB for them and, when that
 *   failed, freed a NULL table (SEGV in NC_hashmapfree under nc_open).
 *   The header is now validated before nc_open (io/nc_guard.h) and
 *   refused naming the count. Replayed here in a child whose address
 *   space is limited to what it uses plus 256 MiB, so that the allocation
 *   fails as under the fuzzer.
 *   fuzz_restart (tests/fuzz/corpus/restart/regress-hdf5-xfree, -2, -3): a
 *   netCDF-4 restart on which HDF5 1.10.8 frees an invalid pointer inside
 *   nc_open (H5MM_xfree under H5Literate, netcdf-c #2667) under ASan.
 *   It is now opened first in a checking child and refused when that
 *   child dies.
 * (fuzz_raster's huge ESRI ncols is checked in test_raster.) */
#include <math.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include "io/forcing.h"
#include "io/restart.h"
#include "util/timeutil.h"

#include "check.h"
#include "test_forcing_nc.h"

static double wind_fn(int which, double lon, double lat, size_t k)
{
    (void)lon; (void)lat; (void)k;
    return which == 0 ? 3.0 : -2.0;
}

static void on_alarm(int sig)
{
    (void)sig;
    static const char msg[] = "FAIL test_fuzz_regress: forcing_open hung on a longitude of -1e300\n"
                              "test_fuzz_regress: 0 passed, 1 failed\n";
    if (write(2, msg, sizeof msg - 1) < 0)
        _exit(1);
    _exit(1);
}

/* A regular grid whose longitudes are lon0 + i * 0.25 with lon0 = -1e300
 * (all the same double) must be refused at opening, promptly. */
static void huge_longitude(void)
{
    char path[] = "/tmp/sphice-fuzz-regress-XXXXXX";
    int fd = mkstemp(path);
    CHECK(fd >= 0, "temporary file");
    if (fd < 0)
        return;
    close(fd);
    tgrid g = {.nx = 4, .ny = 3, .lon0 = -1e300, .dlon = 0.25, .lat0 = 40.0, .dlat = 0.25,
               .time_units = "hours since 1999-02-08 00:00:00", .calendar = "standard", .dtv = 1.0};
    tvar v[2];
    memset(v, 0, sizeof v);
    v[0] = (tvar){"u10", "eastward_wind", "m s-1", NC_FLOAT, 0, 0, 0, 0, 0, wind_fn, 0};
    v[1] = (tvar){"v10", "northward_wind", "m s-1", NC_FLOAT, 0, 0, 0, 0, 0, wind_fn, 1};
    tnc_write(path, &g, v, 2, 0, 3, 0);
    const char *files[1] = {path};
    forcing_source_spec s = {0};
    s.name = "atm";
    s.kind = FORCING_ATMOSPHERE;
    s.files = files;
    s.nfiles = 1;
    s.required = FQ_WIND;
    forcing *f = NULL;
    sph_error err;
    sph_error_clear(&err);
    signal(SIGALRM, on_alarm);
    alarm(20);
    int rc = forcing_open(&f, &s, 1, 918432000.0, 918435600.0, 0, 1, 40, 40.5, &err);
    alarm(0);
    CHECK(rc == SPH_ERR_BAD_DATA && f == NULL, "refused (rc %d): %s", rc, err.msg);
    CHECK(strstr(err.msg, path) && strstr(err.msg, "-1e+300") && strstr(err.msg, "index 0"),
          "names the file, the value and the index: %s", err.msg);
    forcing_close(f);
    unlink(path);
}

/* the bytes of a regression seed */
static unsigned char *read_seed(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    unsigned char *b = malloc(1 << 20);
    *n = f && b ? fread(b, 1, 1 << 20, f) : 0;
    if (f)
        fclose(f);
    return b;
}

static long vm_size_kb(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    long kb = 0;
    while (f && fgets(line, sizeof line, f))
        if (sscanf(line, "VmSize: %ld", &kb) == 1)
            break;
    if (f)
        fclose(f);
    return kb;
}

/* Runs one reader on `file` in a child with the address space limited to
 * what it maps now plus 256 MiB; the child sends back the reader's status
 * and message. Returns the child's wait status. */
static int replay(const char *file, int kind, int *rc, char *msg, size_t msgsz)
{
    int fds[2];
    *rc = -1;
    msg[0] = '\0';
    if (pipe(fds) != 0)
        return -1;
    fflush(NULL);
    pid_t pid = fork();
    if (pid == 0) {
        close(fds[0]);
        struct rlimit rl;
        rl.rlim_cur = rl.rlim_max = (rlim_t)(vm_size_kb() + 256 * 1024) * 1024;
        setrlimit(RLIMIT_AS, &rl);
        sph_error err;
        sph_error_clear(&err);
        int r;
        if (kind >= 0) {
            const char *files[1] = {file};
            forcing_source_spec sp = {0};
            sp.name = "regress";
            sp.kind = (forcing_kind)kind;
            sp.files = files;
            sp.nfiles = 1;
            forcing *f = NULL;
            r = forcing_open(&f, &sp, 1, 918453600.0, 918457200.0, 121.0, 121.5, 40.0, 40.5, &err);
            forcing_close(f);
        } else {
            restart_header h;
            r = restart_read_header(file, &h, &err);
        }
        if (write(fds[1], &r, sizeof r) != (ssize_t)sizeof r ||
            write(fds[1], err.msg, strlen(err.msg) + 1) < 0)
            _exit(2);
        _exit(0);
    }
    close(fds[1]);
    if (read(fds[0], rc, sizeof *rc) == (ssize_t)sizeof *rc) {
        ssize_t n = read(fds[0], msg, msgsz - 1);
        msg[n > 0 ? n : 0] = '\0';
    }
    close(fds[0]);
    int st = 0;
    waitpid(pid, &st, 0);
    return st;
}

static void crash_seeds(void)
{
    char path[] = "/tmp/sphice-fuzz-regress-seed-XXXXXX";
    int fd = mkstemp(path);
    CHECK(fd >= 0, "temporary file");
    if (fd < 0)
        return;
    size_t n;
    unsigned char *b = read_seed("tests/fuzz/corpus/forcing/regress-classic-ndims", &n);
    CHECK(n > 1, "forcing seed read (%zu bytes)", n);
    /* the harness's first byte picks the kind (tests/fuzz/fuzz_forcing.c) */
    CHECK(n > 1 && write(fd, b + 1, n - 1) == (ssize_t)(n - 1), "seed written");
    close(fd);
    int rc;
    char msg[1100];
    int st = n > 1 ? replay(path, b[0] % 3, &rc, msg, sizeof msg) : -1;
    CHECK(WIFEXITED(st) && WEXITSTATUS(st) == 0, "forcing seed: the reader lives (wait status %d)", st);
    CHECK(rc == SPH_ERR_NETCDF && strstr(msg, path) && strstr(msg, "corrupt NetCDF header") &&
              strstr(msg, "16712704") && !strchr(msg, '\n'),
          "forcing seed: refused in one line naming file and count (rc %d): %s", rc, msg);
    free(b);
    const char *rseeds[3] = {"tests/fuzz/corpus/restart/regress-hdf5-xfree",
                             "tests/fuzz/corpus/restart/regress-hdf5-xfree-2",
                             "tests/fuzz/corpus/restart/regress-hdf5-xfree-3"};
    for (int k = 0; k < 3; k++) {
        b = read_seed(rseeds[k], &n);
        CHECK(n > 8 && !memcmp(b, "\211HDF", 4), "restart seed read (%zu bytes)", n);
        fd = open(path, O_WRONLY | O_TRUNC);
        CHECK(fd >= 0 && write(fd, b, n) == (ssize_t)n, "seed written");
        if (fd >= 0)
            close(fd);
        st = replay(path, -1, &rc, msg, sizeof msg);
        CHECK(WIFEXITED(st) && WEXITSTATUS(st) == 0, "restart seed: the reader lives (wait status %d)", st);
        /* Under ASan (make sanitize, the fuzzer) HDF5's free of an
         * uninitialised pointer is caught and the checking child dies: the
         * guard refuses the file. With glibc's allocator the same open ends
         * in HDF5's own error: either way one line naming the file. */
        CHECK(rc == SPH_ERR_NETCDF && strstr(msg, path) && !strchr(msg, '\n') &&
                  (strstr(msg, "refused: the NetCDF/HDF5 library") || strstr(msg, "HDF error")),
              "restart seed: refused in one line naming the file (rc %d): %s", rc, msg);
        free(b);
    }
    unlink(path);
}

int main(void)
{
    huge_longitude();
    crash_seeds();
    char buf[64];
    time_format_iso(-1.12435e212, buf, sizeof buf);
    CHECK(strstr(buf, "-1.12435e+212") && strstr(buf, "since 1970"), "huge time: %s", buf);
    time_format_iso(NAN, buf, sizeof buf);
    CHECK(strstr(buf, "nan") != NULL, "NaN time: %s", buf);
    time_format_iso(INFINITY, buf, sizeof buf);
    CHECK(strstr(buf, "inf") != NULL, "infinite time: %s", buf);
    /* in range: 1999-02-08T06:00:00Z is 918453600 s (10630 days + 6 h) */
    time_format_iso(10630.0 * 86400.0 + 6 * 3600.0, buf, sizeof buf);
    CHECK(strcmp(buf, "1999-02-08T06:00:00Z") == 0, "ISO time: %s", buf);
    /* the edge of the range still formats as a date: 1e15 s is about year 31.7 million */
    time_format_iso(1e15, buf, sizeof buf);
    CHECK(strchr(buf, 'T') && buf[strlen(buf) - 1] == 'Z', "1e15 s: %s", buf);
    return check_summary("test_fuzz_regress");
}
