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
 * (fuzz_raster's huge ESRI ncols is checked in test_raster.) */
#include <math.h>
#include <signal.h>
#include <unistd.h>

#include "io/forcing.h"
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

int main(void)
{
    huge_longitude();
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
