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

/* sum over the water cells of record r of var x area on a curvilinear file (y, x) */
static double curv_sum(const char *path, const char *var, size_t r)
{
    int nc, d, id;
    size_t ny = 0, nx = 0;
    double s = NAN;
    if (nc_open(path, NC_NOWRITE, &nc) != NC_NOERR)
        return NAN;
    nc_inq_dimid(nc, "y", &d);
    nc_inq_dimlen(nc, d, &ny);
    nc_inq_dimid(nc, "x", &d);
    nc_inq_dimlen(nc, d, &nx);
    double *a = get(nc, "areacello", nx * ny), *v = malloc(nx * ny * sizeof *v);
    size_t st[3] = {r, 0, 0}, ct[3] = {1, ny, nx};
    if (a && v && nc_inq_varid(nc, var, &id) == NC_NOERR && nc_get_vara_double(nc, id, st, ct, v) == NC_NOERR) {
        s = 0.0;
        for (size_t c = 0; c < nx * ny; c++)
            if (v[c] < 1e19)
                s += v[c] * a[c];
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

/* A ROMS history file on a bent grid, written from ROMS's documentation
 * (myroms.org wiki and varinfo: lon_rho/lat_rho "longitude/latitude of
 * RHO-points" in degree_east/north, mask_rho "mask on RHO-points" with
 * flag_values 0, 1 and flag_meanings "land water", angle "angle between
 * XI-axis and EAST" in radians, counterclockwise, pm/pn "curvilinear
 * coordinate metric in XI/ETA" in meter-1, u_eastward/v_northward at
 * RHO-points with coordinates "lon_rho lat_rho s_rho ocean_time",
 * _FillValue 1e37 on land, s_rho with standard_name ocean_s_coordinate_g2).
 * The grid: a sector of a circle centred at (121.5 E, 39.0 N) on a local
 * equirectangular map, XI along the radius from 100 km (3 km steps), ETA
 * along the arc from 45 up to 135 degrees (right-handed, as ROMS wants;
 * the XI axis turns from north-east to north-west across the domain),
 * land where the centre lies east of RM_LAND. */
#define RM_NX 36
#define RM_NY 40
#define RM_LAND 121.85
#define RM_R 6371000.0
static void rm_lonlat(double r, double th, double *lon, double *lat)
{
    double x = r * cos(th), y = r * sin(th);
    *lon = 121.5 + x / (RM_R * cos(39.0 * M_PI / 180.0)) * 180.0 / M_PI;
    *lat = 39.0 + y / RM_R * 180.0 / M_PI;
}
static double rm_r(double i) { return 100000.0 + 3000.0 * i; }
static double rm_th(double j) { return (45.0 + 2.3 * j) * M_PI / 180.0; }
/* ROMS's angle at a rho point: the XI direction (the radius) against the
 * local east, from the map's exact derivative (dlon, dlat) = (cos th /
 * (R cos 39), sin th / R): east N cos(lat) dlon, north M dlat, on the WGS84
 * ellipsoid of the model's plane (M / N = (1 - e^2) / (1 - e^2 sin^2 lat);
 * ROMS's own sphere, M = N, differs by up to e^2 cos^2(lat) / 2 = 2e-3 rad
 * here) */
static double rm_angle(int i, int j)
{
    double lon, lat, th = rm_th(j), e2 = 0.00669437999014;
    rm_lonlat(rm_r(i), th, &lon, &lat);
    double s = sin(lat * M_PI / 180.0);
    return atan2(sin(th) * (1.0 - e2) / (1.0 - e2 * s * s), cos(th) * cos(lat * M_PI / 180.0) / cos(39.0 * M_PI / 180.0));
}
static void roms_file(const char *path)
{
    int nc, de, dx, ds, dt, v[12];
    nc_create(path, NC_NETCDF4 | NC_CLOBBER, &nc);
    nc_def_dim(nc, "xi_rho", RM_NX, &dx);
    nc_def_dim(nc, "eta_rho", RM_NY, &de);
    nc_def_dim(nc, "s_rho", 1, &ds);
    nc_def_dim(nc, "ocean_time", NC_UNLIMITED, &dt);
    int d2[2] = {de, dx}, d4[4] = {dt, ds, de, dx};
    nc_def_var(nc, "ocean_time", NC_DOUBLE, 1, &dt, &v[0]);
    nc_put_att_text(nc, v[0], "long_name", 25, "time since initialization");
    nc_put_att_text(nc, v[0], "units", 33, "seconds since 1999-02-08 00:00:00");
    nc_put_att_text(nc, v[0], "calendar", 19, "proleptic_gregorian");
    nc_def_var(nc, "s_rho", NC_DOUBLE, 1, &ds, &v[1]);
    nc_put_att_text(nc, v[1], "long_name", 20, "S-coordinate at RHO-points");
    nc_put_att_text(nc, v[1], "positive", 2, "up");
    nc_put_att_text(nc, v[1], "standard_name", 21, "ocean_s_coordinate_g2");
    const char *names[] = {"lon_rho", "lat_rho", "mask_rho", "angle", "pm", "pn"};
    const char *lnames[] = {"longitude of RHO-points", "latitude of RHO-points", "mask on RHO-points",
                            "angle between XI-axis and EAST", "curvilinear coordinate metric in XI",
                            "curvilinear coordinate metric in ETA"};
    const char *units[] = {"degree_east", "degree_north", NULL, "radians", "meter-1", "meter-1"};
    for (int k = 0; k < 6; k++) {
        nc_def_var(nc, names[k], NC_DOUBLE, 2, d2, &v[2 + k]);
        nc_put_att_text(nc, v[2 + k], "long_name", strlen(lnames[k]), lnames[k]);
        if (units[k])
            nc_put_att_text(nc, v[2 + k], "units", strlen(units[k]), units[k]);
    }
    nc_put_att_text(nc, v[2], "standard_name", 9, "longitude");
    nc_put_att_text(nc, v[3], "standard_name", 8, "latitude");
    double fv[2] = {0.0, 1.0};
    nc_put_att_double(nc, v[4], "flag_values", NC_DOUBLE, 2, fv);
    nc_put_att_text(nc, v[4], "flag_meanings", 10, "land water");
    nc_put_att_text(nc, v[4], "coordinates", 15, "lon_rho lat_rho");
    const char *un[2] = {"u_eastward", "v_northward"}, *sn[2] = {"eastward_sea_water_velocity",
                                                                 "northward_sea_water_velocity"};
    for (int k = 0; k < 2; k++) {
        nc_def_var(nc, un[k], NC_FLOAT, 4, d4, &v[8 + k]);
        nc_put_att_text(nc, v[8 + k], "long_name", 11, k ? "northward momentum component at RHO-points"
                                                          : "eastward momentum component at RHO-points");
        nc_put_att_text(nc, v[8 + k], "units", 14, "meter second-1");
        nc_put_att_text(nc, v[8 + k], "standard_name", strlen(sn[k]), sn[k]);
        nc_put_att_text(nc, v[8 + k], "coordinates", 32, "lon_rho lat_rho s_rho ocean_time");
        float f = 1e37f;
        nc_put_att_float(nc, v[8 + k], "_FillValue", NC_FLOAT, 1, &f);
    }
    nc_enddef(nc);
    static double lon[RM_NY * RM_NX], lat[RM_NY * RM_NX], mask[RM_NY * RM_NX], ang[RM_NY * RM_NX],
        pm[RM_NY * RM_NX], pn[RM_NY * RM_NX];
    static float u[RM_NY * RM_NX], w[RM_NY * RM_NX];
    for (int j = 0; j < RM_NY; j++)
        for (int i = 0; i < RM_NX; i++) {
            int c = j * RM_NX + i;
            rm_lonlat(rm_r(i), rm_th(j), &lon[c], &lat[c]);
            mask[c] = lon[c] < RM_LAND;
            ang[c] = rm_angle(i, j);
            pm[c] = 1.0 / 3000.0;                          /* 1 / the radial step */
            pn[c] = 1.0 / (rm_r(i) * 2.3 * M_PI / 180.0); /* 1 / the arc step */
            u[c] = mask[c] ? (float)EC_CURRENT_E : 1e37f;
            w[c] = mask[c] ? 0.0f : 1e37f;
        }
    double *fields[6] = {lon, lat, mask, ang, pm, pn};
    for (int k = 0; k < 6; k++)
        nc_put_var_double(nc, v[2 + k], fields[k]);
    double zero = -0.0125;
    nc_put_var_double(nc, v[1], &zero);
    for (size_t t = 0; t < 25; t++) {
        double tv = 3600.0 * (double)t;
        size_t st1 = t, st[4] = {t, 0, 0, 0}, ct[4] = {1, 1, RM_NY, RM_NX};
        nc_put_var1_double(nc, v[0], &st1, &tv);
        nc_put_vara_float(nc, v[8], st, ct, u);
        nc_put_vara_float(nc, v[9], st, ct, w);
    }
    nc_close(nc);
}

/* The forecast on the ROMS grid and on the output grid: the same area
 * integrals (both conserve the particles' sums) within 1e-10, the stress
 * turned back to east/north with the file's angle within 4e-4 (the angle
 * of the model's plane is taken at the particles on one grid, at the cell
 * centres on the other); the file's cells are ROMS's (lon/lat, 1/(pm pn),
 * mask_rho's land as fill), its angle ROMS's within 3e-4 rad, corners
 * from the centres' midpoints as its attribute says. */
static void roms_case(void)
{
    char p[1200], so[1024], sg[1024];
    snprintf(p, sizeof p, "%s/roms_his.nc", dir);
    roms_file(p);
    forecast_result res;
    CHECK(run(1, "output", "roms_his.nc", "roms-output", so, sizeof so, &res) == 0, "ROMS ocean, output grid: %s",
          last_error);
    CHECK(run(1, "ocean", "roms_his.nc", "roms-ocean", sg, sizeof sg, &res) == 0, "ROMS ocean, its own grid: %s",
          last_error);
    char po[1200], pg[1200];
    snprintf(po, sizeof po, "%s/sphice_ocean_fluxes.nc", so);
    snprintf(pg, sizeof pg, "%s/sphice_ocean_fluxes.nc", sg);
    int nc, d;
    size_t nx = 0, ny = 0;
    if (nc_open(pg, NC_NOWRITE, &nc) != NC_NOERR) {
        CHECK(0, "open %s", pg);
        return;
    }
    nc_inq_dimid(nc, "x", &d);
    nc_inq_dimlen(nc, d, &nx);
    nc_inq_dimid(nc, "y", &d);
    nc_inq_dimlen(nc, d, &ny);
    size_t n = nx * ny;
    double *lo = get(nc, "lon", n), *la = get(nc, "lat", n), *ar = get(nc, "areacello", n), *an = get(nc, "angle", n),
           *hf = get(nc, "hfds", 3 * n), *tu = get(nc, "tauuo", 3 * n), *tv = get(nc, "tauvo", 3 * n);
    char corners[400] = "", orient[400] = "";
    size_t al = 0;
    if (nc_inq_attlen(nc, NC_GLOBAL, "cell_corners", &al) == NC_NOERR && al < sizeof corners)
        nc_get_att_text(nc, NC_GLOBAL, "cell_corners", corners);
    if (nc_inq_attlen(nc, NC_GLOBAL, "stress_orientation", &al) == NC_NOERR && al < sizeof orient)
        nc_get_att_text(nc, NC_GLOBAL, "stress_orientation", orient);
    nc_close(nc);
    CHECK(lo && la && ar && an && hf && tu && tv && n > 0 && nx <= RM_NX && ny <= RM_NY,
          "a %zu x %zu curvilinear file", nx, ny);
    if (!(lo && la && ar && an && hf && tu && tv && n > 0 && nx <= RM_NX && ny <= RM_NY))
        return;
    CHECK(strstr(corners, "midpoints") != NULL, "corners from the centres' midpoints, said: %s", corners);
    CHECK(strstr(orient, "grid") && strstr(orient, "angle"), "the stress orientation is said: %s", orient);
    /* the file's first cell is some ROMS cell (i0, j0): find it, then all match (record 0) */
    int i0 = -1, j0 = -1;
    for (int j = 0; j < RM_NY && i0 < 0; j++)
        for (int i = 0; i < RM_NX; i++) {
            double rl, rb;
            rm_lonlat(rm_r(i), rm_th(j), &rl, &rb);
            if (fabs(rl - lo[0]) < 1e-9 && fabs(rb - la[0]) < 1e-9) {
                i0 = i;
                j0 = j;
                break;
            }
        }
    int same = i0 >= 0, fill = 1;
    double worst_area = 0.0, worst_angle = 0.0;
    for (size_t c = 0; same && c < n; c++) {
        int i = i0 + (int)(c % nx), j = j0 + (int)(c / nx);
        double rl, rb;
        rm_lonlat(rm_r(i), rm_th(j), &rl, &rb);
        same &= fabs(rl - lo[c]) < 1e-9 && fabs(rb - la[c]) < 1e-9;
        worst_area = fmax(worst_area, fabs(ar[c] - 3000.0 * rm_r(i) * 2.3 * M_PI / 180.0) / ar[c]);
        worst_angle = fmax(worst_angle, fabs(remainder(an[c] - rm_angle(i, j), 2.0 * M_PI)));
        fill &= (rl >= RM_LAND) == (hf[c] > 1e19);
    }
    printf("ROMS grid: %zu x %zu cells from (i %d, j %d); worst areacello vs 1/(pm pn) %.3g, angle vs ROMS's %.3g rad\n",
           nx, ny, i0, j0, worst_area, worst_angle);
    CHECK(same, "the file's cells are ROMS's rho points (from i %d, j %d)", i0, j0);
    CHECK(worst_area <= 1e-12, "areacello = 1 / (pm pn) (worst %.3g)", worst_area);
    /* the file's angle: centred differences of the centres over two cells
     * (the grid lines curve: their tangent and chord differ by ~1e-4 rad) */
    CHECK(worst_angle <= 3e-4, "angle = ROMS's angle between XI and east within 3e-4 rad (worst %.3g)", worst_angle);
    CHECK(fill, "fill exactly on mask_rho's land");
    const char *vars[] = {"hfds", "hfsithermds", "siflfwbot", "siflsaltbot", "sivol"}; /* no sunlight: no siflswdbot */
    for (size_t r = 0; r < 3; r++) {
        CHECK(lost_in(po, r) == 0 && lost_in(pg, r) == 0, "ROMS record %zu: no particle lost (%lld, %lld)", r,
              lost_in(po, r), lost_in(pg, r));
        for (size_t k = 0; k < sizeof vars / sizeof vars[0]; k++) {
            size_t f1;
            double a = cell_sum(po, vars[k], r, &f1), b = curv_sum(pg, vars[k], r);
            CHECK(fabs(a - b) <= 1e-10 * fabs(a) && a != 0.0, "ROMS record %zu: %s integral %.15g on the output "
                  "grid, %.15g on ROMS's", r, vars[k], a, b);
        }
        /* the stress, turned from XI/ETA to east/north with ROMS's rule */
        double se = 0.0, sn = 0.0;
        for (size_t c = 0; c < n; c++) {
            double x = tu[r * n + c], y = tv[r * n + c];
            if (x > 1e19)
                continue;
            se += (x * cos(an[c]) - y * sin(an[c])) * ar[c];
            sn += (x * sin(an[c]) + y * cos(an[c])) * ar[c];
        }
        size_t f;
        double oe = cell_sum(po, "tauuo", r, &f), on = cell_sum(po, "tauvo", r, &f);
        /* the plane's angle from east changes by sin(lat) / (R cos(lat)) =
         * 1.1e-7 rad/m in the transverse Mercator plane: over the few km
         * between a particle and its cells, up to 4e-4 rad */
        CHECK(fabs(se - oe) <= 4e-4 * hypot(oe, on) && fabs(sn - on) <= 4e-4 * hypot(oe, on),
              "ROMS record %zu: the stress turned back to east/north (%.10g, %.10g) N = the output grid's "
              "(%.10g, %.10g) N", r, se, sn, oe, on);
    }
    free(lo);
    free(la);
    free(ar);
    free(an);
    free(hf);
    free(tu);
    free(tv);
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
    /* a curvilinear ocean: a bent ROMS grid (roms_file), the fluxes on its
     * own cells (issue 20 item 4) */
    roms_case();
    char stage[1024];
    int rc = run(1, "ocean", "", "no-ocean", stage, sizeof stage, &res);
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
