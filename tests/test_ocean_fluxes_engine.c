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

static const char *model_more = ""; /* more "model" members (the mixed layer) */

static char last_error[1024]; /* run()'s error message, "" when it succeeded */

/* Inserts `add` after the first `key` of text. */
static int insert(char *text, size_t len, const char *key, const char *add)
{
    char tmp[10000];
    char *at = strstr(text, key);
    if (!at)
        return -1;
    size_t pre = (size_t)(at - text) + strlen(key);
    snprintf(tmp, sizeof tmp, "%.*s%s%s", (int)pre, text, add, text + pre);
    snprintf(text, len, "%s", tmp);
    return 0;
}

/* A forecast of 3 h; ocean: "" none, else an ocean source of that file in
 * dir; grid: the output.ocean_fluxes_grid value. */
static int run(int on, const char *grid, const char *ocean, const char *stage_name, char *stage, size_t len,
               forecast_result *res)
{
    char t2[10000], add[1200];
    ec_config_more(t2, sizeof t2, dir, 300, "[\"wind\", \"tair\"]", "ice.nc", "", model_more, "");
    snprintf(add, sizeof add, " \"ocean_fluxes\": %s, \"ocean_fluxes_grid\": \"%s\",", on ? "true" : "false", grid);
    if (insert(t2, sizeof t2, "\"interval_hours\": 1,", add))
        return -1;
    snprintf(add, sizeof add, "}, {\"name\": \"ocean\", \"kind\": \"ocean\", \"urls\": \"%s/%s\", \"required\": [\"current\"]", dir,
             ocean);
    if (ocean[0] && insert(t2, sizeof t2, "\"required\": [\"wind\", \"tair\"]", add))
        return -1;
    struct sph_config *cfg = NULL;
    sph_error err;
    sph_error_clear(&err);
    if (sph_config_parse(t2, "test", &cfg, &err) != SPH_OK) {
        fprintf(stderr, "config: %s\n", err.msg);
        return -1;
    }
    snprintf(stage, len, "%s/%s", dir, stage_name);
    static const char *atm[2], *ocn[2];
    static char atm_path[1024], ocn_path[1024];
    snprintf(atm_path, sizeof atm_path, "%s/atm.nc", dir);
    snprintf(ocn_path, sizeof ocn_path, "%s/%s", dir, ocean);
    atm[0] = atm_path;
    ocn[0] = ocn_path;
    forecast_request req;
    memset(&req, 0, sizeof req);
    req.cycle_time = EC_CYCLE;
    req.hours = 3;
    req.stage_dir = stage;
    req.forcing_files[0] = atm;
    if (ocean[0])
        req.forcing_files[1] = ocn;
    static const char *sums[] = {"atm.nc 0000", NULL};
    req.forcing_sha256[0] = sums[0];
    forecast_progress prog;
    memset((void *)&prog, 0, sizeof prog);
    int rc = forecast_run(cfg, &req, &prog, NULL, res, &err);
    snprintf(last_error, sizeof last_error, "%s", rc ? err.msg : "");
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

/* Opens a fluxes file and reads its lat/lon sizes; -1 when it cannot. */
static int open_lonlat(const char *path, int *nc, size_t *nx, size_t *ny)
{
    int d;
    *nx = *ny = 0;
    if (nc_open(path, NC_NOWRITE, nc) != NC_NOERR)
        return -1;
    nc_inq_dimid(*nc, "lat", &d);
    nc_inq_dimlen(*nc, d, ny);
    nc_inq_dimid(*nc, "lon", &d);
    nc_inq_dimlen(*nc, d, nx);
    return 0;
}

/* sum over the water cells of record r of var x area, and the count of fill cells */
static double cell_sum(const char *path, const char *var, size_t r, size_t *nfill)
{
    int nc;
    size_t ny, nx;
    double s = NAN;
    if (open_lonlat(path, &nc, &nx, &ny))
        return NAN;
    size_t n = nx * ny;
    double *a = get(nc, "areacello", n), *v = malloc(n * sizeof *v);
    int id;
    size_t start[3] = {r, 0, 0}, count[3] = {1, ny, nx};
    if (a && v && nc_inq_varid(nc, var, &id) == NC_NOERR && nc_get_vara_double(nc, id, start, count, v) == NC_NOERR) {
        s = 0.0;
        *nfill = 0;
        for (size_t c = 0; c < n; c++) {
            if (v[c] > 1e19)
                ++*nfill;
            else
                s += v[c] * a[c];
        }
    }
    free(a);
    free(v);
    nc_close(nc);
    return s;
}

static long long lost_in(const char *path, size_t r)
{
    int nc, v;
    long long x = -1;
    if (nc_open(path, NC_NOWRITE, &nc) == NC_NOERR) {
        if (nc_inq_varid(nc, "particles_lost", &v) == NC_NOERR)
            nc_get_var1_longlong(nc, v, &r, &x);
        nc_close(nc);
    }
    return x;
}

static double ocean_open_fn(int which, double lon, double lat, size_t k)
{
    (void)lon; (void)lat; (void)k;
    return which == 0 ? EC_CURRENT_E : 0.0;
}

/* The ocean forcing's grid: with an ocean of water everywhere, the same
 * particle fluxes gridded on it and on the output grid have the same area
 * integrals (both conserve); with the engine case's ocean.nc (no water
 * east of EC_OCEAN_LAND) its land cells are fill; "ocean" without an
 * ocean source is refused with one line naming the key. */
static void ocean_grid(void)
{
    char p[1200];
    snprintf(p, sizeof p, "%s/ocean_open.nc", dir);
    ec_write_ocean_with(p, ocean_open_fn);
    char so[1024], sg[1024];
    forecast_result res;
    CHECK(run(1, "output", "ocean_open.nc", "open-output", so, sizeof so, &res) == 0, "output grid with an ocean");
    CHECK(run(1, "auto", "ocean_open.nc", "open-ocean", sg, sizeof sg, &res) == 0, "auto: the ocean's grid");
    char po[1200], pg[1200];
    snprintf(po, sizeof po, "%s/sphice_ocean_fluxes.nc", so);
    snprintf(pg, sizeof pg, "%s/sphice_ocean_fluxes.nc", sg);
    int nc, d;
    size_t nx = 0, ny = 0;
    double lon[64], lat[64];
    if (nc_open(pg, NC_NOWRITE, &nc) == NC_NOERR) {
        int vl;
        nc_inq_dimid(nc, "lon", &d);
        nc_inq_dimlen(nc, d, &nx);
        nc_inq_dimid(nc, "lat", &d);
        nc_inq_dimlen(nc, d, &ny);
        if (nx <= 64 && ny <= 64) {
            nc_inq_varid(nc, "lon", &vl);
            nc_get_var_double(nc, vl, lon);
            nc_inq_varid(nc, "lat", &vl);
            nc_get_var_double(nc, vl, lat);
        }
        char src[1400] = "";
        size_t al = 0;
        if (nc_inq_attlen(nc, NC_GLOBAL, "grid_source", &al) == NC_NOERR && al < sizeof src)
            nc_get_att_text(nc, NC_GLOBAL, "grid_source", src);
        CHECK(strstr(src, "ocean_open.nc") != NULL, "grid_source names the ocean file: %s", src);
        nc_close(nc);
    }
    /* the ocean's nodes (120.9 + 0.05 i E, 39.9 + 0.05 j N) over the domain
     * 121-122 E, 40-40.6 N and one cell around it */
    int axes = nx >= 21 && nx <= 64 && ny >= 13 && ny <= 64 && lon[0] <= 121.0 && lon[0] >= 120.95 - 1e-9 &&
               lon[nx - 1] >= 122.0 && lat[0] <= 40.0 && lat[ny - 1] >= 40.6;
    for (size_t i = 0; axes && i < nx; i++)
        axes = fabs(lon[i] - (120.9 + 0.05 * round((lon[i] - 120.9) / 0.05))) < 1e-9 &&
               (i == 0 || fabs(lon[i] - lon[i - 1] - 0.05) < 1e-9);
    CHECK(axes, "the file's grid is the ocean's: %zu x %zu from %.4f E %.4f N", nx, ny, lon[0], lat[0]);
    const char *vars[] = {"hfds", "siflfwbot", "siflsaltbot", "tauuo", "tauvo", "sivol"};
    for (size_t r = 0; r < 3; r++) {
        CHECK(lost_in(po, r) == 0 && lost_in(pg, r) == 0, "record %zu: no particle lost (%lld, %lld)", r,
              lost_in(po, r), lost_in(pg, r));
        for (size_t k = 0; k < sizeof vars / sizeof vars[0]; k++) {
            size_t f1, f2;
            double a = cell_sum(po, vars[k], r, &f1), b = cell_sum(pg, vars[k], r, &f2);
            CHECK(fabs(a - b) <= 1e-10 * fabs(a), "record %zu: %s integral %.15g on the output grid, %.15g on the "
                  "ocean's", r, vars[k], a, b);
        }
    }
    /* the engine case's ocean: its land is the file's land */
    CHECK(run(1, "ocean", "ocean.nc", "coast-ocean", sg, sizeof sg, &res) == 0, "ocean grid with a coast");
    snprintf(pg, sizeof pg, "%s/sphice_ocean_fluxes.nc", sg);
    size_t nfill = 0, nlon = 0, nlat = 0;
    if (nc_open(pg, NC_NOWRITE, &nc) == NC_NOERR) {
        nc_inq_dimid(nc, "lon", &d);
        nc_inq_dimlen(nc, d, &nlon);
        nc_inq_dimid(nc, "lat", &d);
        nc_inq_dimlen(nc, d, &nlat);
        double *lo = get(nc, "lon", nlon), *hf = get(nc, "hfds", 3 * nlon * nlat); /* 3 records; the first checked */
        int right = lo && hf;
        for (size_t j = 0; right && j < nlat; j++)
            for (size_t i = 0; i < nlon; i++) {
                int land = lo[i] >= EC_OCEAN_LAND - 1e-9, fill = hf[j * nlon + i] > 1e19;
                right &= land == fill;
                nfill += fill;
            }
        CHECK(right && nfill > 0, "fill exactly where the ocean has no water (%zu cells)", nfill);
        free(lo);
        free(hf);
        nc_close(nc);
    }
    /* a curvilinear ocean (2-D lat/lon, rotated 20 degrees: a ROMS- or
     * NEMO-like grid the forcing reads) is refused with one line naming
     * the file and the key, and nothing is written */
    tgrid cg;
    ec_ocean_grid(&cg);
    cg.curvilinear = 1;
    cg.rot_deg = 20.0;
    cg.clat = 40.3;
    cg.lon0 = 121.5;
    tvar cv[2];
    memset(cv, 0, sizeof cv);
    cv[0] = (tvar){"uo", "eastward_sea_water_velocity", "m s-1", NC_FLOAT, 0, 0, 1, -999.0, 0, ocean_open_fn, 0};
    cv[1] = (tvar){"vo", "northward_sea_water_velocity", "m s-1", NC_FLOAT, 0, 0, 1, -999.0, 0, ocean_open_fn, 1};
    snprintf(p, sizeof p, "%s/ocean_curv.nc", dir);
    tnc_write(p, &cg, cv, 2, 0, 13, ec_ocean_format);
    char stage[1024];
    CHECK(run(1, "output", "ocean_curv.nc", "curv-output", stage, sizeof stage, &res) == 0,
          "a curvilinear ocean with the output grid: %s", last_error);
    int rc = run(1, "ocean", "ocean_curv.nc", "curv-ocean", stage, sizeof stage, &res);
    CHECK(rc == SPH_ERR_CONFIG && strstr(last_error, "output.ocean_fluxes_grid") && strstr(last_error, "ocean_curv.nc") &&
              strstr(last_error, "curvilinear") && !strchr(last_error, '\n'),
          "a curvilinear ocean's grid: one line naming the file and the key: %s", last_error);
    CHECK(ec_count_entries(stage) <= 0, "nothing written");
    rc = run(1, "ocean", "", "no-ocean", stage, sizeof stage, &res);
    CHECK(rc == SPH_ERR_CONFIG && strstr(last_error, "output.ocean_fluxes_grid") && !strchr(last_error, '\n'),
          "\"ocean\" without an ocean source: one line naming the key: %s", last_error);
    CHECK(ec_count_entries(stage) <= 0, "nothing written");
}

/* Sum of siflfwbot x area of record r over the cells west of lon_max, and
 * the count of nonzero ones. */
static double west_water(const char *path, size_t r, double lon_max, size_t *nonzero)
{
    int nc, v;
    size_t ny, nx;
    double s = NAN;
    *nonzero = 0;
    if (open_lonlat(path, &nc, &nx, &ny))
        return NAN;
    double *a = get(nc, "areacello", nx * ny), *lon = get(nc, "lon", nx), *w = malloc(nx * ny * sizeof *w);
    size_t start[3] = {r, 0, 0}, count[3] = {1, ny, nx};
    if (a && lon && w && nc_inq_varid(nc, "siflfwbot", &v) == NC_NOERR &&
        nc_get_vara_double(nc, v, start, count, w) == NC_NOERR) {
        s = 0.0;
        for (size_t c = 0; c < nx * ny; c++)
            if (lon[c % nx] < lon_max && w[c] < 1e19) {
                s += w[c] * a[c];
                *nonzero += w[c] != 0.0;
            }
    }
    free(a);
    free(lon);
    free(w);
    nc_close(nc);
    return s;
}

/* With the mixed layer (no SST: the slab starts at its freezing point in
 * -10 C air) the open water west of the ice (which starts at 121.2 E)
 * forms frazil: it sends fresh water out of the ocean, through the few
 * output cells that hold the centres of the 4-lattice-spacing cells of
 * the mixed layer; without it, nothing there. */
static void mixed_layer_open_water(const char *stage_off)
{
    char stage[1024], path[1200], poff[1200];
    forecast_result res;
    memset(&res, 0, sizeof res);
    model_more = ", \"ocean\": {\"mixed_layer\": true}";
    CHECK(run(1, "output", "", "mixed", stage, sizeof stage, &res) == 0, "forecast with the mixed layer: %s",
          last_error);
    model_more = "";
    snprintf(path, sizeof path, "%s/sphice_ocean_fluxes.nc", stage);
    snprintf(poff, sizeof poff, "%s/sphice_ocean_fluxes.nc", stage_off);
    size_t nz = 0, nz_off = 0;
    double w = west_water(path, 0, 121.15, &nz), w_off = west_water(poff, 0, 121.15, &nz_off);
    printf("mixed layer: fresh water west of the ice %.6g kg/s in %zu cells (without: %g in %zu)\n", w, nz, w_off,
           nz_off);
    CHECK(w < 0.0 && nz > 0 && nz < 100, "the open water's frazil takes fresh water: %g kg/s in %zu cells", w, nz);
    CHECK(w_off == 0.0 && nz_off == 0, "without the mixed layer no flux there: %g", w_off);
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
    CHECK(run(0, "auto", "", "off", stage, sizeof stage, &res) == 0, "forecast, default off");
    snprintf(path, sizeof path, "%s/sphice_ocean_fluxes.nc", stage);
    struct stat sb;
    CHECK(stat(path, &sb) != 0, "off: no ocean fluxes file");

    memset(&res, 0, sizeof res);
    CHECK(run(1, "auto", "", "on", stage, sizeof stage, &res) == 0, "forecast with output.ocean_fluxes");
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
    mixed_layer_open_water(stage);
    ocean_grid();
    char cmd[256];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", dir);
    return check_summary("test_ocean_fluxes_engine");
}
