/* Forcing beyond physical bounds is bad input, refused at reading with
 * one line naming the file, the variable and the point (issue 21 item 8):
 * an Inf or an undeclared 1e30 in the wind, an air temperature of 400 K,
 * a current of 15 m/s. The same 1e30 declared as _FillValue is a missing
 * value, and values just inside the bounds (99 m/s, 155 K, 9 m/s) are
 * read. Bounds: docs/forcing.md. */
#include "check.h"
#include "io/forcing.h"
#include "test_forcing_nc.h"

#include <unistd.h>

#define T0 1612137600.0 /* 2021-02-01T00:00Z */

static double bad_value;  /* written at the bad node */
static int bad_which;     /* into this variable */
static size_t bad_k;      /* at this time index */

/* which: 0 u, 1 v (m/s), 2 air temperature (K), 3 u current, 4 v current */
static double field(int which, double lon, double lat, size_t k)
{
    if (which == bad_which && k == bad_k && fabs(lon - 2.0) < 1e-9 && fabs(lat - 64.0) < 1e-9)
        return bad_value;
    static const double base[] = {5.0, -3.0, 263.15, 0.2, -0.1};
    return base[which] + 0.01 * lon + 0.01 * (lat - 60) + 0.1 * (double)k;
}

static char dir[64];

static int try_file(const char *name, forcing_kind kind, int has_fill, double fill,
                    int sample_late, sph_error *e, char *path, size_t plen)
{
    tgrid g = {.nx = 20, .ny = 12, .lon0 = -10, .dlon = 1, .lat0 = 59, .dlat = 1,
               .time_units = "hours since 2021-02-01 00:00:00", .tv0 = 0, .dtv = 1};
    tvar atm[] = {
        {"u10", "eastward_wind", "m s**-1", NC_DOUBLE, 0, 0, has_fill, fill, 0, field, 0},
        {"v10", "northward_wind", "m s**-1", NC_DOUBLE, 0, 0, has_fill, fill, 0, field, 1},
        {"t2m", "air_temperature", "K", NC_DOUBLE, 0, 0, has_fill, fill, 0, field, 2},
    };
    tvar ocn[] = {
        {"uo", "eastward_sea_water_velocity", "m s-1", NC_DOUBLE, 0, 0, has_fill, fill, 0, field, 3},
        {"vo", "northward_sea_water_velocity", "m s-1", NC_DOUBLE, 0, 0, has_fill, fill, 0, field, 4},
    };
    snprintf(path, plen, "%s/%s.nc", dir, name);
    if (kind == FORCING_ATMOSPHERE)
        tnc_write(path, &g, atm, 3, 0, 4, 0);
    else
        tnc_write(path, &g, ocn, 2, 0, 4, 0);
    const char *files[] = {path};
    forcing_source_spec spec = {.name = name, .kind = kind, .files = files, .nfiles = 1,
                                .required = kind == FORCING_ATMOSPHERE ? FQ_WIND | FQ_TAIR
                                                                       : FQ_CURRENT};
    forcing *f = NULL;
    sph_error_clear(e);
    int rc = forcing_open(&f, &spec, 1, T0, T0 + 3 * 3600, -5, 5, 62, 68, e);
    if (rc == 0) {
        double lon[1] = {2.0}, lat[1] = {64.0}, a[1], b[1], c[1];
        forcing_sample s = {.u_east = a, .v_north = b, .tair = c, .uw_east = a, .vw_north = b};
        rc = forcing_sample_at(f, sample_late ? T0 + 2.5 * 3600 : T0, 1, lon, lat, &s, e);
    }
    forcing_close(f);
    return rc;
}

static void refused(const char *what, int rc, const sph_error *e, const char *path,
                    const char *var)
{
    CHECK(rc != 0, "%s: accepted", what);
    CHECK(strchr(e->msg, '\n') == NULL && strstr(e->msg, path) && strstr(e->msg, var) &&
              strstr(e->msg, "lon 2.0000, lat 64.0000") && strstr(e->msg, "physical bounds"),
          "%s: not one line naming file, variable '%s' and point: %s", what, var, e->msg);
}

int main(void)
{
    snprintf(dir, sizeof dir, "/tmp/test_forcing_bounds.%d", (int)getpid());
    char cmd[128], p[160];
    snprintf(cmd, sizeof cmd, "mkdir -p %s", dir);
    if (system(cmd) != 0)
        return 2;
    sph_error e;
    int rc;

    /* bad variable, time index, value, declared fill, refused?, variable named */
    static const struct {
        const char *name;
        forcing_kind kind;
        int which;
        size_t k;
        double value;
        int declared, refused;
        const char *var;
    } cases[] = {
        {"wind_inf", FORCING_ATMOSPHERE, 0, 0, INFINITY, 0, 1, "'u10'"},
        {"wind_1e30", FORCING_ATMOSPHERE, 0, 0, 1e30, 0, 1, "'u10'"},
        /* in a later slice: refused when sampled */
        {"wind_late", FORCING_ATMOSPHERE, 1, 2, -1e30, 0, 1, "'v10'"},
        /* declared: a missing value, filled from the nodes nearby */
        {"wind_fill", FORCING_ATMOSPHERE, 0, 0, 1e30, 1, 0, NULL},
        {"wind_99", FORCING_ATMOSPHERE, 0, 0, 99.0, 0, 0, NULL},
        {"tair_400K", FORCING_ATMOSPHERE, 2, 0, 400.0, 0, 1, "'t2m'"},
        {"tair_140K", FORCING_ATMOSPHERE, 2, 0, 140.0, 0, 1, "'t2m'"},
        {"tair_155K", FORCING_ATMOSPHERE, 2, 0, 155.0, 0, 0, NULL},
        {"current_15", FORCING_OCEAN, 3, 0, 15.0, 0, 1, "'uo'"},
        {"current_9", FORCING_OCEAN, 3, 0, 9.0, 0, 0, NULL},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        bad_which = cases[c].which;
        bad_k = cases[c].k;
        bad_value = cases[c].value;
        rc = try_file(cases[c].name, cases[c].kind, cases[c].declared, cases[c].value,
                      cases[c].k > 0, &e, p, sizeof p);
        if (cases[c].refused)
            refused(cases[c].name, rc, &e, p, cases[c].var);
        else
            CHECK(rc == 0, "%s: %s", cases[c].name, e.msg);
    }

    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", dir);
    return check_summary("test_forcing_bounds");
}
