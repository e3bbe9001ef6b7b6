/* Bad forcing input: each case fails with one message naming the source,
 * the file and the problem, and a non-zero return. */
#include "check.h"
#include "io/forcing.h"
#include "test_forcing_nc.h"
#include "util/timeutil.h"

#include <fcntl.h>
#include <unistd.h>

static char dir[64];
static double T0;

static double field(int which, double lon, double lat, size_t k)
{
    (void)lat;
    if (which == 9 && k == 1 && lon > 0 && lon < 1.5)
        return NAN; /* NaN without a declared fill value */
    if (which == 8 && lon > -100)
        return NAN; /* everything is land */
    return 1.0 + 0.1 * lon + (double)k;
}

static tgrid grid(void)
{
    tgrid g = {.nx = 25, .ny = 15, .lon0 = -12, .dlon = 1, .lat0 = 58, .dlat = 1,
               .time_units = "hours since 2021-02-01", .calendar = "standard", .tv0 = 0,
               .dtv = 1.0};
    return g;
}

static void write_atm(const char *p, const char *uname, const char *uunits, int nanfield)
{
    tgrid g = grid();
    tvar v[] = {
        {uname, NULL, uunits, NC_DOUBLE, 0, 0, 0, 0, 0, field, nanfield},
        {"v10", NULL, "m s-1", NC_DOUBLE, 0, 0, 0, 0, 0, field, 0},
    };
    tnc_write(p, &g, v, 2, 0, 4, 0);
}

/* Opens one atmosphere source; returns the rc and leaves the message in err. */
static int try_open(const char *p, double t1, double lon0, double lon1, sph_error *err,
                    forcing **fo)
{
    const char *files[] = {p};
    static const forcing_name_map map[] = {{"eastward_wind", "u10"}, {"northward_wind", "v10"}};
    forcing_source_spec spec = {.name = "era5", .kind = FORCING_ATMOSPHERE, .files = files,
                                .nfiles = 1, .map = map, .nmap = 2, .required = FQ_WIND};
    forcing *f = NULL;
    sph_error_clear(err);
    int rc = forcing_open(&f, &spec, 1, T0, t1, lon0, lon1, 60, 70, err);
    if (fo)
        *fo = f;
    else
        forcing_close(f);
    return rc;
}

#define EXPECT(rc, err, p, what)                                                         \
    if (getenv("SHOW")) fprintf(stderr, "%s\n", (err).msg);                              \
    do {                                                                                 \
        CHECK((rc) != 0, "%s: expected failure", what);                                  \
        CHECK(strstr((err).msg, "forcing 'era5'") != NULL, "%s: names source: %s", what, \
              (err).msg);                                                                \
        CHECK(strstr((err).msg, p) != NULL, "%s: names file: %s", what, (err).msg);      \
        CHECK(strchr((err).msg, '\n') == NULL, "%s: one line", what);                    \
    } while (0)

int main(void)
{
    time_parse_iso("2021-02-01T00:00:00Z", &T0);
    snprintf(dir, sizeof dir, "/tmp/sphice-ferr-XXXXXX");
    if (!mkdtemp(dir))
        return 2;
    char p[128];
    sph_error err;
    int rc;

    snprintf(p, sizeof p, "%s/nou.nc", dir);
    write_atm(p, "wind_u", "m s-1", 0);
    rc = try_open(p, T0 + 3600, -10, 9, &err, NULL);
    EXPECT(rc, err, p, "missing variable");
    CHECK(strstr(err.msg, "variable for eastward_wind not found") && strstr(err.msg, "'u10'"),
          "missing variable message: %s", err.msg);
    CHECK(err.code == SPH_ERR_MISSING_VAR, "code %d", err.code);
    unlink(p);

    snprintf(p, sizeof p, "%s/units.nc", dir);
    write_atm(p, "u10", "bananas per hour", 0);
    rc = try_open(p, T0 + 3600, -10, 9, &err, NULL);
    EXPECT(rc, err, p, "unknown unit");
    CHECK(strstr(err.msg, "unknown units 'bananas per hour'") != NULL, "%s", err.msg);
    write_atm(p, "u10", "K", 0);
    rc = try_open(p, T0 + 3600, -10, 9, &err, NULL);
    EXPECT(rc, err, p, "incompatible unit");
    CHECK(strstr(err.msg, "cannot be converted to 'm s-1'") != NULL, "%s", err.msg);
    unlink(p);

    /* several levels along a dimension that has no vertical coordinate
     * (an ensemble member, say): which one is meant cannot be told */
    snprintf(p, sizeof p, "%s/levels.nc", dir);
    {
        tgrid g = grid();
        g.depth = 3;
        tvar v[] = {
            {"u10", NULL, "m s-1", NC_DOUBLE, 0, 0, 0, 0, 0, field, 0},
            {"v10", NULL, "m s-1", NC_DOUBLE, 0, 0, 0, 0, 0, field, 0},
        };
        tnc_write(p, &g, v, 2, 0, 4, 0);
    }
    rc = try_open(p, T0 + 3600, -10, 9, &err, NULL);
    EXPECT(rc, err, p, "levels without a vertical coordinate");
    CHECK(strstr(err.msg, "dimension 'depth' (3 values) is neither time") != NULL, "%s", err.msg);
    unlink(p);

    snprintf(p, sizeof p, "%s/short.nc", dir);
    write_atm(p, "u10", "m s-1", 0);
    rc = try_open(p, T0 + 10 * 3600, -10, 9, &err, NULL);
    EXPECT(rc, err, p, "time coverage");
    CHECK(strstr(err.msg, "does not cover the period") != NULL, "%s", err.msg);
    CHECK(err.code == SPH_ERR_COVERAGE, "code %d", err.code);
    rc = try_open(p, T0 + 3600, -20, 9, &err, NULL);
    EXPECT(rc, err, p, "space coverage");
    CHECK(strstr(err.msg, "does not cover the domain box") != NULL, "%s", err.msg);
    /* Sampling outside the time axis or the grid after a good open. */
    forcing *f = NULL;
    rc = try_open(p, T0 + 3600, -10, 9, &err, &f);
    CHECK(rc == 0 && f, "good open: %s", err.msg);
    if (f) {
        double lon = 0, lat = 65, u, v;
        forcing_sample s = {.u_east = &u, .v_north = &v};
        sph_error_clear(&err);
        CHECK(forcing_sample_at(f, T0 + 5 * 3600, 1, &lon, &lat, &s, &err) != 0, "late time");
        CHECK(strstr(err.msg, p) && strstr(err.msg, "outside the time axis"), "%s", err.msg);
        lon = 40;
        sph_error_clear(&err);
        CHECK(forcing_sample_at(f, T0, 1, &lon, &lat, &s, &err) != 0, "point outside");
        CHECK(strstr(err.msg, p) && strstr(err.msg, "point (40, 65) is outside"), "%s", err.msg);
        forcing_close(f);
    }
    unlink(p);

    /* All land: no valid value within one cell of the point. */
    snprintf(p, sizeof p, "%s/land.nc", dir);
    {
        tgrid g = grid();
        tvar v[] = {
            {"u10", NULL, "m s-1", NC_DOUBLE, 0, 0, 1, 1e20, 0, field, 8},
            {"v10", NULL, "m s-1", NC_DOUBLE, 0, 0, 1, 1e20, 0, field, 8},
        };
        tnc_write(p, &g, v, 2, 0, 4, 0);
        rc = try_open(p, T0 + 3600, -10, 9, &err, &f);
        CHECK(rc == 0, "all-land open: %s", err.msg);
        if (f) {
            double lon = 0.5, lat = 65.5, u, vv;
            forcing_sample s = {.u_east = &u, .v_north = &vv};
            sph_error_clear(&err);
            CHECK(forcing_sample_at(f, T0, 1, &lon, &lat, &s, &err) != 0, "all land");
            CHECK(strstr(err.msg, p) && strstr(err.msg, "within one grid cell of point (0.5, 65.5)"),
                  "%s", err.msg);
            forcing_close(f);
        }
    }
    unlink(p);

    /* A NaN that is not a declared fill value (in the second slice). */
    snprintf(p, sizeof p, "%s/nan.nc", dir);
    write_atm(p, "u10", "m s-1", 9);
    rc = try_open(p, T0 + 3 * 3600, -10, 9, &err, &f);
    CHECK(rc == 0, "NaN only later: open ok: %s", err.msg);
    if (f) {
        double lon = 0, lat = 65, u, vv;
        forcing_sample s = {.u_east = &u, .v_north = &vv};
        sph_error_clear(&err);
        CHECK(forcing_sample_at(f, T0 + 1800, 1, &lon, &lat, &s, &err) != 0, "NaN at sample");
        EXPECT(1, err, p, "NaN");
        CHECK(strstr(err.msg, "NaN in variable 'u10' at 2021-02-01T01:00:00Z") != NULL, "%s",
              err.msg);
        CHECK(err.code == SPH_ERR_BAD_DATA, "code %d", err.code);
        forcing_close(f);
    }
    unlink(p);

    /* Not a NetCDF file, and a truncated one. */
    snprintf(p, sizeof p, "%s/garbage.nc", dir);
    FILE *fp = fopen(p, "w");
    fputs("this is not a netcdf file\n", fp);
    fclose(fp);
    rc = try_open(p, T0 + 3600, -10, 9, &err, NULL);
    EXPECT(rc, err, p, "corrupt");
    CHECK(strstr(err.msg, "cannot open") != NULL, "%s", err.msg);
    unlink(p);
    for (int fmt = 0; fmt < 2; fmt++) {
        snprintf(p, sizeof p, "%s/trunc%d.nc", dir, fmt);
        tgrid g = grid();
        tvar v[] = {
            {"u10", NULL, "m s-1", NC_DOUBLE, 0, 0, 0, 0, 0, field, 0},
            {"v10", NULL, "m s-1", NC_DOUBLE, 0, 0, 0, 0, 0, field, 0},
        };
        tnc_write(p, &g, v, 2, 0, 4, fmt ? NC_NETCDF4 : 0);
        off_t size;
        int fd = open(p, O_RDWR);
        size = lseek(fd, 0, SEEK_END);
        CHECK(ftruncate(fd, size / 2) == 0, "truncate");
        close(fd);
        rc = try_open(p, T0 + 3 * 3600, -10, 9, &err, &f);
        if (rc == 0 && f) {
            /* The header survived: the data read must fail. */
            double lon = 0, lat = 65, u, vv;
            forcing_sample s = {.u_east = &u, .v_north = &vv};
            sph_error_clear(&err);
            rc = forcing_sample_at(f, T0 + 3 * 3600, 1, &lon, &lat, &s, &err);
            forcing_close(f);
        }
        EXPECT(rc, err, p, fmt ? "truncated netcdf4" : "truncated classic");
        unlink(p);
    }

    rmdir(dir);
    return check_summary("test_forcing_errors");
}
