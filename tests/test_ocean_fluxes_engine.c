/* output.ocean_fluxes through the forecast engine on the small synthetic
 * case (tests/engine_case.h: ice of concentration 0.5 in -10 C air, wind
 * 10 m/s from the south, no ocean forcing, so the ocean heat flux is the
 * default thermo.fw_default = 2 W/m^2 and the leads are at the freezing
 * point): the file is in the stage directory and the manifest, one record
 * per output hour with contiguous time bounds from the cycle time; the
 * freezing leads send no heat, so hfds = hfsithermds and
 * sum(hfds area) = -2 W/m^2 x the ice area (within the change of the ice
 * area over the hour); the stress pairs are opposite; the wind pushes the
 * ocean north through the ice. Default off: no file. */
#include <math.h>
#include <netcdf.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "check.h"
#include "engine_case.h"
#include "service/config.h"
#include "service/forecast.h"
#include "util/log.h"

static char dir[] = "/tmp/sphice-ofxe-XXXXXX";

static int run(int on, const char *stage_name, char *stage, size_t len, forecast_result *res)
{
    char text[8192], t2[8400];
    ec_config(text, sizeof text, dir, 300, "[\"wind\", \"tair\"]", "ice.nc", "");
    const char *key = "\"interval_hours\": 1,";
    char *at = strstr(text, key);
    if (!at)
        return -1;
    size_t pre = (size_t)(at - text) + strlen(key);
    snprintf(t2, sizeof t2, "%.*s \"ocean_fluxes\": %s,%s", (int)pre, text, on ? "true" : "false", text + pre);
    struct sph_config *cfg = NULL;
    sph_error err;
    sph_error_clear(&err);
    if (sph_config_parse(t2, "test", &cfg, &err) != SPH_OK) {
        fprintf(stderr, "config: %s\n", err.msg);
        return -1;
    }
    snprintf(stage, len, "%s/%s", dir, stage_name);
    static const char *atm[2];
    static char atm_path[1024];
    snprintf(atm_path, sizeof atm_path, "%s/atm.nc", dir);
    atm[0] = atm_path;
    forecast_request req;
    memset(&req, 0, sizeof req);
    req.cycle_time = EC_CYCLE;
    req.hours = 3;
    req.stage_dir = stage;
    req.forcing_files[0] = atm;
    static const char *sums[] = {"atm.nc 0000", NULL};
    req.forcing_sha256[0] = sums[0];
    forecast_progress prog;
    memset((void *)&prog, 0, sizeof prog);
    int rc = forecast_run(cfg, &req, &prog, NULL, res, &err);
    if (rc)
        fprintf(stderr, "forecast: %s\n", err.msg);
    sph_config_free(cfg);
    return rc;
}

static double *get(int nc, const char *name, size_t n)
{
    int v;
    double *a = malloc(n * sizeof *a);
    if (!a || nc_inq_varid(nc, name, &v) != NC_NOERR || nc_get_var_double(nc, v, a) != NC_NOERR) {
        free(a);
        return NULL;
    }
    return a;
}

int main(int argc, char **argv)
{
    (void)argc;
    ec_passive_openmp(argv);
    sph_log_level = LOG_LVL_WARN;
    if (!mkdtemp(dir)) {
        perror("mkdtemp");
        return 1;
    }
    ec_write_inputs(dir);
    char stage[1024], path[1200];
    forecast_result res;
    memset(&res, 0, sizeof res);
    CHECK(run(0, "off", stage, sizeof stage, &res) == 0, "forecast, default off");
    snprintf(path, sizeof path, "%s/sphice_ocean_fluxes.nc", stage);
    struct stat sb;
    CHECK(stat(path, &sb) != 0, "off: no ocean fluxes file");

    memset(&res, 0, sizeof res);
    CHECK(run(1, "on", stage, sizeof stage, &res) == 0, "forecast with output.ocean_fluxes");
    snprintf(path, sizeof path, "%s/sphice_ocean_fluxes.nc", stage);
    int listed = 0;
    for (int k = 0; k < res.nproducts; k++)
        listed |= !strcmp(res.products[k], "sphice_ocean_fluxes.nc");
    CHECK(listed, "the file is among the products");
    char mpath[1200];
    snprintf(mpath, sizeof mpath, "%s/manifest.json", stage);
    FILE *f = fopen(mpath, "r");
    char buf[65536];
    size_t got = f ? fread(buf, 1, sizeof buf - 1, f) : 0;
    buf[got] = '\0';
    if (f)
        fclose(f);
    CHECK(strstr(buf, "\"sphice_ocean_fluxes.nc\"") != NULL, "manifest.json lists it");

    int nc;
    CHECK(nc_open(path, NC_NOWRITE, &nc) == NC_NOERR, "open %s", path);
    int d;
    size_t nt = 0, ny = 0, nx = 0;
    nc_inq_dimid(nc, "time", &d);
    nc_inq_dimlen(nc, d, &nt);
    nc_inq_dimid(nc, "lat", &d);
    nc_inq_dimlen(nc, d, &ny);
    nc_inq_dimid(nc, "lon", &d);
    nc_inq_dimlen(nc, d, &nx);
    CHECK(nt == 3 && ny == 61 && nx == 101, "3 hourly records on the 101 x 61 output grid (%zu, %zu, %zu)", nt, ny,
          nx);
    size_t nc2 = nx * ny, n3 = nt * nc2;
    double *tb = get(nc, "time_bnds", 2 * nt), *area = get(nc, "areacello", nc2), *hf = get(nc, "hfds", n3),
           *hi = get(nc, "hfsithermds", n3), *ci = get(nc, "siconc", n3), *tu = get(nc, "tauuo", n3),
           *tv = get(nc, "tauvo", n3), *sx = get(nc, "sistrxubot", n3), *sy = get(nc, "sistryubot", n3);
    nc_close(nc);
    CHECK(tb && area && hf && hi && ci && tu && tv && sx && sy, "variables read");
    if (tb && area && hf && hi && ci && tu && tv && sx && sy && nt == 3) {
        int contiguous = tb[0] == EC_CYCLE;
        for (size_t r = 0; r < nt; r++)
            contiguous &= tb[2 * r + 1] == EC_CYCLE + 3600.0 * (double)(r + 1) && (r == 0 || tb[2 * r] == tb[2 * r - 1]);
        CHECK(contiguous, "time_bnds: [cycle + r h, cycle + (r+1) h]");
        for (size_t r = 0; r < nt; r++) {
            double sh = 0, sa = 0, sv = 0;
            int same = 1, opposite = 1;
            for (size_t c = 0; c < nc2; c++) {
                size_t q = r * nc2 + c;
                if (hf[q] > 1e19)
                    continue;
                same &= hf[q] == hi[q];
                opposite &= sx[q] == -tu[q] && sy[q] == -tv[q];
                sh += hf[q] * area[c];
                sa += ci[q] * area[c];
                sv += tv[q] * area[c];
            }
            CHECK(same, "record %zu: freezing leads send no heat: hfds = hfsithermds", r);
            CHECK(opposite, "record %zu: sistrxubot = -tauuo, sistryubot = -tauvo", r);
            CHECK(sa > 1e8, "record %zu: ice area %.4g km2", r, sa / 1e6);
            CHECK(fabs(sh / sa + 2.0) < 0.1, "record %zu: mean heat into the ocean per ice area %.4f W/m2 (-2)", r,
                  sh / sa);
            CHECK(sv > 0.0, "record %zu: the southerly wind pushes the ocean north (%.4g N)", r, sv);
        }
    }
    free(tb);
    free(area);
    free(hf);
    free(hi);
    free(ci);
    free(tu);
    free(tv);
    free(sx);
    free(sy);
    char cmd[256];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", dir);
    return check_summary("test_ocean_fluxes_engine");
}
