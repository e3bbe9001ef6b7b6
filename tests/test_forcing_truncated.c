/* Local forcing files are checked like downloads (issue 19 item 8): a
 * classic-format (netCDF-3) file whose header promises more records or
 * bytes than the file holds is refused at open with one line naming it,
 * in every classic variant (CDF-1 classic, CDF-2 64-bit offset, CDF-5);
 * the same file complete is read. The expected length is the netCDF
 * classic format specification's: the begin offset of the last record
 * variable plus (numrecs - 1) record sizes plus its own size. */
#include "check.h"
#include "io/forcing.h"
#include "test_forcing_nc.h"

#include <unistd.h>

#define T0 1612137600.0 /* 2021-02-01T00:00Z */

static double field(int which, double lon, double lat, size_t k)
{
    return which == 0 ? 3.0 + 0.1 * lon : which == 1 ? -1.0 + 0.05 * lat : 263.15 + (double)k;
}

int main(void)
{
    char dir[64];
    snprintf(dir, sizeof dir, "/tmp/test_forcing_truncated.%d", (int)getpid());
    char cmd[128];
    snprintf(cmd, sizeof cmd, "mkdir -p %s", dir);
    if (system(cmd) != 0)
        return 2;
    static const int fmts[] = {0, NC_64BIT_OFFSET, NC_64BIT_DATA};
    static const char *names[] = {"classic", "64bit_offset", "cdf5"};
    for (int v = 0; v < 3; v++) {
        tgrid g = {.nx = 20, .ny = 12, .nt = 4, .lon0 = -10, .dlon = 1, .lat0 = 59, .dlat = 1,
                   .time_units = "hours since 2021-02-01 00:00:00", .tv0 = 0, .dtv = 1};
        tvar vars[] = {
            {"u10", "eastward_wind", "m s-1", NC_FLOAT, 0, 0, 0, 0, 0, field, 0},
            {"v10", "northward_wind", "m s-1", NC_FLOAT, 0, 0, 0, 0, 0, field, 1},
            {"t2m", "air_temperature", "K", NC_FLOAT, 0, 0, 0, 0, 0, field, 2},
        };
        char p[160];
        snprintf(p, sizeof p, "%s/atm_%s.nc", dir, names[v]);
        tnc_write(p, &g, vars, 3, 0, 4, fmts[v]);
        const char *files[] = {p};
        forcing_source_spec spec = {.name = "atm", .kind = FORCING_ATMOSPHERE, .files = files,
                                    .nfiles = 1, .required = FQ_WIND | FQ_TAIR};
        forcing *f = NULL;
        sph_error e;
        sph_error_clear(&e);
        int rc = forcing_open(&f, &spec, 1, T0, T0 + 3 * 3600, -5, 5, 62, 68, &e);
        CHECK(rc == 0, "%s complete: %s", names[v], e.msg);
        forcing_close(f);
        f = NULL;
        /* cut half of the last record away: the header still says 4 records */
        FILE *fp = fopen(p, "rb");
        fseek(fp, 0, SEEK_END);
        long len = ftell(fp);
        fclose(fp);
        long rec = 3L * (long)(g.nx * g.ny) * 4 + 8; /* three floats and the time per record */
        CHECK(truncate(p, len - rec / 2) == 0, "truncate");
        sph_error_clear(&e);
        rc = forcing_open(&f, &spec, 1, T0, T0 + 3 * 3600, -5, 5, 62, 68, &e);
        CHECK(rc != 0, "%s truncated by %ld of %ld bytes: accepted", names[v], rec / 2, len);
        CHECK(strstr(e.msg, p) != NULL && strstr(e.msg, "truncated") != NULL &&
                  strchr(e.msg, '\n') == NULL,
              "%s truncated: not one line naming the file and the problem: %s", names[v], e.msg);
        forcing_close(f);
        /* a header cut short is refused too */
        CHECK(truncate(p, 40) == 0, "truncate header");
        sph_error_clear(&e);
        f = NULL;
        rc = forcing_open(&f, &spec, 1, T0, T0 + 3 * 3600, -5, 5, 62, 68, &e);
        CHECK(rc != 0 && strstr(e.msg, p) != NULL && strchr(e.msg, '\n') == NULL,
              "%s header cut: %s", names[v], rc ? e.msg : "accepted");
        forcing_close(f);
    }
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", dir);
    return check_summary("test_forcing_truncated");
}
