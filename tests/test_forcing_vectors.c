/* Vector orientation of forcing files in three providers' shapes (issue 19
 * item 5): grid-relative components are rotated to east/north as a hand
 * rotation computed here from the projection's own formula (not from
 * sphice), within 0.5 degrees; ambiguous or contradicting files are
 * refused with one line naming the file, the variables and the key
 * forcing[].vectors.
 *
 *  - met.no Arctic ocean model (NorKyst800 / Barents-2.5 on
 *    thredds.met.no): u, v with standard_name x_sea_water_velocity /
 *    y_sea_water_velocity, packed shorts, a depth axis, grid_mapping
 *    polar_stereographic, 2-D lon/lat, zeta as sea_surface_elevation.
 *  - a CF rotated pole (COSMO/CORDEX style: rlon/rlat in degrees, x_wind
 *    and y_wind along the rotated grid, no 2-D lon/lat): rotated by the
 *    angle PROJ's ob_tran gives; a grid mapping without the figure of the
 *    earth is refused in one line.
 *  - Lambert-conformal wind (met.no MEPS, NCEP NAM on THREDDS):
 *    x_wind_10m / y_wind_10m (standard_name x_wind, y_wind) on
 *    (time, height, y, x), grid_mapping lambert_conformal_conic, 2-D
 *    latitude/longitude.
 *  - ROMS history file: u(ocean_time, s_rho, eta_u, xi_u) and
 *    v(ocean_time, s_rho, eta_v, xi_v) without standard_name, own
 *    coordinates lon_u/lat_u, lon_v/lat_v, angle(eta_rho, xi_rho)
 *    "angle between XI-axis and EAST" in radians, mask_rho, s_rho
 *    (ocean_s_coordinate_g2, surface last).
 */
#include "check.h"
#include "io/forcing.h"
#include "service/check.h"
#include "service/config.h"
#include "test_forcing_nc.h"
#include "util/err.h"

#include <math.h>
#include <proj.h>
#include <netcdf.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define DEG (M_PI / 180.0)
#define R_EARTH 6371000.0
#define T0 1700000000.0 /* 2023-11-14T22:13:20Z: file times T0, T0 + 3600 */

static void att(int nc, int v, const char *name, const char *text)
{
    NCW(nc_put_att_text(nc, v, name, strlen(text), text));
}

/* Defines a variable with text attributes given as name, value pairs
 * ending with NULL. */
static int defv(int nc, const char *name, nc_type type, int nd, const int *dims, ...)
{
    int v;
    NCW(nc_def_var(nc, name, type, nd, dims, &v));
    va_list ap;
    va_start(ap, dims);
    for (const char *k = va_arg(ap, const char *); k; k = va_arg(ap, const char *))
        att(nc, v, k, va_arg(ap, const char *));
    va_end(ap);
    return v;
}

static void attd(int nc, int v, const char *name, double x)
{
    NCW(nc_put_att_double(nc, v, name, NC_DOUBLE, 1, &x));
}

/* A new netCDF-4 file with dimensions time (nt, or NC_UNLIMITED), a
 * vertical one (name[0], nz), y (name[1], ny) and x (name[2], nx). */
static int create4(const char *path, size_t nt, const char *const name[3], size_t nz, size_t ny,
                   size_t nx, int *dt, int *dz, int *dy, int *dx)
{
    int nc;
    NCW(nc_create(path, NC_CLOBBER | NC_NETCDF4, &nc));
    NCW(nc_def_dim(nc, "time", nt, dt));
    NCW(nc_def_dim(nc, name[0], nz, dz));
    NCW(nc_def_dim(nc, name[1], ny, dy));
    NCW(nc_def_dim(nc, name[2], nx, dx));
    return nc;
}

/* A CF lambert_conformal_conic grid mapping with one standard parallel. */
static int def_lcc(int nc, const char *name, double lat0, double lon0, double radius)
{
    int v = defv(nc, name, NC_INT, 0, NULL, "grid_mapping_name", "lambert_conformal_conic", NULL);
    attd(nc, v, "standard_parallel", lat0);
    attd(nc, v, "longitude_of_central_meridian", lon0);
    attd(nc, v, "latitude_of_projection_origin", lat0);
    if (radius > 0)
        attd(nc, v, "earth_radius", radius);
    return v;
}

/* Units, grid mapping, coordinates and _FillValue of a wind pair. */
static void wind_atts(int nc, int vu, int vv, const char *gm, const char *coords, float fill)
{
    for (int c = 0; c < 2; c++) {
        int v = c ? vv : vu;
        att(nc, v, "units", "m/s");
        att(nc, v, "grid_mapping", gm);
        att(nc, v, "coordinates", coords);
        NCW(nc_put_att_float(nc, v, "_FillValue", NC_FLOAT, 1, &fill));
    }
}

/* ---- projections, spherical (the angle of the grid axes does not depend
 * on the ellipsoid for these two conformal projections) ---- */

/* North polar stereographic, true at 60 N, central meridian lon0. */
#define PS_LON0 70.0
#define PS_K0 ((1 + sin(60 * DEG)) / 2)
static void ps_inverse(double x, double y, double *lon, double *lat)
{
    double rho = hypot(x, y);
    *lon = PS_LON0 + atan2(x, -y) / DEG;
    *lat = 90.0 - 2 * atan(rho / (2 * R_EARTH * PS_K0)) / DEG;
}
static void ps_forward(double lon, double lat, double *x, double *y)
{
    double rho = 2 * R_EARTH * PS_K0 * tan((45.0 - lat / 2) * DEG);
    *x = rho * sin((lon - PS_LON0) * DEG);
    *y = -rho * cos((lon - PS_LON0) * DEG);
}
/* Angle (counter-clockwise) from east to the projection's x axis: east is
 * d(x, y)/d lon, along (cos(lon - lon0), sin(lon - lon0)). */
static double ps_alpha(double lon) { return -(lon - PS_LON0) * DEG; }

/* Grid-relative components written everywhere (the velocity along x and
 * along y of the grid). */
#define UX 0.6
#define UY -0.3

/* Lambert conformal conic, one standard parallel (tangent cone); MEPS's
 * parameters by default, NCEP NAM's for the NAM file. */
static double LCC_LON0 = 15.0, LCC_LAT0 = 63.3, LCC_R = R_EARTH;
static double lcc_n(void) { return sin(LCC_LAT0 * DEG); }
static double lcc_F(void)
{
    double n = lcc_n();
    return cos(LCC_LAT0 * DEG) * pow(tan(M_PI / 4 + LCC_LAT0 * DEG / 2), n) / n;
}
static double lcc_rho(double lat)
{
    return LCC_R * lcc_F() / pow(tan(M_PI / 4 + lat * DEG / 2), lcc_n());
}
static void lcc_inverse(double x, double y, double *lon, double *lat)
{
    double n = lcc_n(), r0 = lcc_rho(LCC_LAT0);
    double rho = hypot(x, r0 - y), th = atan2(x, r0 - y);
    *lon = LCC_LON0 + th / n / DEG;
    *lat = (2 * atan(pow(LCC_R * lcc_F() / rho, 1 / n)) - M_PI / 2) / DEG;
}
static void lcc_forward(double lon, double lat, double *x, double *y)
{
    double n = lcc_n(), r0 = lcc_rho(LCC_LAT0), r = lcc_rho(lat);
    *x = r * sin(n * (lon - LCC_LON0) * DEG);
    *y = r0 - r * cos(n * (lon - LCC_LON0) * DEG);
}
/* x = rho sin(n dlon), y = rho0 - rho cos(n dlon): east is along
 * (cos(n dlon), sin(n dlon)), so the x axis is at -n dlon from east. */
static double lcc_alpha(double lon) { return -lcc_n() * remainder(lon - LCC_LON0, 360.0) * DEG; }

/* The grid-relative wind 10 (UX, UY) at all n values of u and v. */
static void put_wind(int nc, int vu, int vv, size_t n)
{
    float *w = malloc(n * sizeof *w);
    for (int c = 0; c < 2; c++) {
        for (size_t p = 0; p < n; p++)
            w[p] = (float)(c ? 10 * UY : 10 * UX);
        NCW(nc_put_var_float(nc, c ? vv : vu, w));
    }
    free(w);
}

/* The NAM grid's angle, with NAM's cone (the MEPS one is restored after
 * the files are written). */
static double nam_alpha(double lon)
{
    double keep[3] = {LCC_LON0, LCC_LAT0, LCC_R};
    LCC_LON0 = 265.0, LCC_LAT0 = 25.0, LCC_R = 6371229.0;
    double a = lcc_alpha(lon);
    LCC_LON0 = keep[0], LCC_LAT0 = keep[1], LCC_R = keep[2];
    return a;
}

/* NCEP NAM 12 km (grid 218) as THREDDS NetCDF Subset Service writes it:
 * x, y in km, LambertConformal_Projection, no latitude/longitude, GRIB
 * names without standard_name; NCEP's winds on this grid are grid-relative
 * (GRIB2 resolution and component flags), so the source says
 * forcing[].vectors "grid". */
static double nam_radius = 6371229.0; /* 0: a mapping without the figure of the earth */
static void write_nam(const char *path)
{
    const size_t nx = 40, ny = 30, nt = 2;
    LCC_LON0 = 265.0, LCC_LAT0 = 25.0, LCC_R = 6371229.0;
    static const char *const dn[3] = {"height_above_ground1", "y", "x"};
    int dt, dh, dy, dx, nc = create4(path, nt, dn, 1, ny, nx, &dt, &dh, &dy, &dx);
    int vt, vh, vy, vx, vu, vv;
    vt = defv(nc, "time", NC_DOUBLE, 1, &dt, "units", "Hour since 2023-11-14T22:00:00Z",
              "standard_name", "time", NULL);
    vh = defv(nc, "height_above_ground1", NC_FLOAT, 1, &dh, "units", "m", "positive", "up", NULL);
    vy = defv(nc, "y", NC_FLOAT, 1, &dy, "standard_name", "projection_y_coordinate", "units", "km",
              NULL);
    vx = defv(nc, "x", NC_FLOAT, 1, &dx, "standard_name", "projection_x_coordinate", "units", "km",
              NULL);
    def_lcc(nc, "LambertConformal_Projection", 25.0, 265.0, nam_radius);
    int d4[4] = {dt, dh, dy, dx};
    vu = defv(nc, "u-component_of_wind_height_above_ground", NC_FLOAT, 4, d4, "long_name",
              "u-component of wind @ Specified height level above ground", NULL);
    vv = defv(nc, "v-component_of_wind_height_above_ground", NC_FLOAT, 4, d4, "long_name",
              "v-component of wind @ Specified height level above ground", NULL);
    wind_atts(nc, vu, vv, "LambertConformal_Projection", "reftime time height_above_ground1 y x ",
              NAN);
    NCW(nc_enddef(nc));
    /* hours since 2023-11-14T22:00Z: T0 is 22:13:20, so 0.2222 h and 1.2222 h */
    double tv[2] = {(T0 - 1699999200.0) / 3600.0, (T0 - 1699999200.0) / 3600.0 + 1};
    float hv = 10.0f;
    NCW(nc_put_var_double(nc, vt, tv));
    NCW(nc_put_var_float(nc, vh, &hv));
    double xc, yc;
    lcc_forward(-75.0, 42.0, &xc, &yc);
    float X[40], Y[30];
    for (size_t i = 0; i < nx; i++)
        X[i] = (float)((xc + ((double)i - 19.5) * 36000.0) / 1000.0);
    for (size_t j = 0; j < ny; j++)
        Y[j] = (float)((yc + ((double)j - 14.5) * 36000.0) / 1000.0);
    NCW(nc_put_var_float(nc, vx, X));
    NCW(nc_put_var_float(nc, vy, Y));
    put_wind(nc, vu, vv, nt * nx * ny);
    NCW(nc_close(nc));
}

/* ---- the files ---- */

/* The centred x/y axes (spacing d, m) and their longitude/latitude by
 * the projection's inverse inv, into the variables of def_projected. */
static void put_projected(int nc, const int ids[6], size_t nx, size_t ny, double xc, double yc,
                          double d, void (*inv)(double x, double y, double *lon, double *lat))
{
    double *X = malloc(nx * sizeof *X), *Y = malloc(ny * sizeof *Y);
    double *lon = malloc(nx * ny * sizeof *lon), *lat = malloc(nx * ny * sizeof *lat);
    for (size_t i = 0; i < nx; i++)
        X[i] = xc + ((double)i - (double)(nx - 1) / 2) * d;
    for (size_t j = 0; j < ny; j++)
        Y[j] = yc + ((double)j - (double)(ny - 1) / 2) * d;
    for (size_t j = 0; j < ny; j++)
        for (size_t i = 0; i < nx; i++)
            inv(X[i], Y[j], &lon[j * nx + i], &lat[j * nx + i]);
    NCW(nc_put_var_double(nc, ids[3], X));
    NCW(nc_put_var_double(nc, ids[2], Y));
    NCW(nc_put_var_double(nc, ids[4], lon));
    NCW(nc_put_var_double(nc, ids[5], lat));
    free(X), free(Y), free(lon), free(lat);
}

/* Time, a vertical coordinate (dims dz, standard name zstd, positive
 * zpos, in m), y, x (m) and 2-D longitude/latitude (units deg + "east" /
 * "north") named nm[0..5]: ids in the same order. */
static void def_projected(int nc, const int dims[4], const char *const nm[6], const char *tunits,
                          const char *zstd, const char *zpos, const char *deg, int ids[6])
{
    char ue[32], un[32];
    snprintf(ue, sizeof ue, "%seast", deg);
    snprintf(un, sizeof un, "%snorth", deg);
    int d2[2] = {dims[2], dims[3]};
    ids[0] =
        defv(nc, nm[0], NC_DOUBLE, 1, &dims[0], "standard_name", "time", "units", tunits, NULL);
    ids[1] = defv(nc, nm[1], NC_DOUBLE, 1, &dims[1], "standard_name", zstd, "units", "m",
                  "positive", zpos, NULL);
    ids[2] = defv(nc, nm[2], NC_DOUBLE, 1, &dims[2], "standard_name", "projection_y_coordinate",
                  "units", "m", NULL);
    ids[3] = defv(nc, nm[3], NC_DOUBLE, 1, &dims[3], "standard_name", "projection_x_coordinate",
                  "units", "m", NULL);
    ids[4] = defv(nc, nm[4], NC_DOUBLE, 2, d2, "standard_name", "longitude", "units", ue, NULL);
    ids[5] = defv(nc, nm[5], NC_DOUBLE, 2, d2, "standard_name", "latitude", "units", un, NULL);
}

/* met.no ocean model on polar stereographic; names_std 0: u, v without
 * standard_name (to be mapped by name). */
static void write_metno(const char *path, int names_std)
{
    const size_t nx = 50, ny = 50, nz = 3, nt = 2;
    int nc, dt, dz, dy, dx;
    static const char *const dn[3] = {"depth", "Y", "X"};
    nc = create4(path, NC_UNLIMITED, dn, nz, ny, nx, &dt, &dz, &dy, &dx);
    int vt, vz, vproj, vu, vv, vzeta;
    static const char *const nm[6] = {"time", "depth", "Y", "X", "lon", "lat"};
    int ids5[6], d4[4] = {dt, dz, dy, dx};
    def_projected(nc, d4, nm, "seconds since 1970-01-01 00:00:00", "depth", "down", "degree_",
                  ids5);
    vt = ids5[0], vz = ids5[1];
    vproj = defv(nc, "projection_stere", NC_INT, 0, NULL, "grid_mapping_name",
                 "polar_stereographic", NULL);
    attd(nc, vproj, "straight_vertical_longitude_from_pole", PS_LON0);
    attd(nc, vproj, "latitude_of_projection_origin", 90.0);
    attd(nc, vproj, "standard_parallel", 60.0);
    attd(nc, vproj, "earth_radius", R_EARTH);
    int d3[3] = {dt, dy, dx};
    const char *names[2] = {"u", "v"};
    const char *stds[2] = {"x_sea_water_velocity", "y_sea_water_velocity"};
    int *ids[2] = {&vu, &vv};
    for (int c = 0; c < 2; c++) {
        NCW(nc_def_var(nc, names[c], NC_SHORT, 4, d4, ids[c]));
        if (names_std)
            att(nc, *ids[c], "standard_name", stds[c]);
        att(nc, *ids[c], "long_name",
            c ? "velocity component in y direction" : "velocity component in x direction");
        att(nc, *ids[c], "units", "m s-1");
        att(nc, *ids[c], "grid_mapping", "projection_stere");
        att(nc, *ids[c], "coordinates", "lon lat");
        short fill = -32767;
        NCW(nc_put_att_short(nc, *ids[c], "_FillValue", NC_SHORT, 1, &fill));
        attd(nc, *ids[c], "scale_factor", 0.001);
        attd(nc, *ids[c], "add_offset", 0.0);
    }
    vzeta = defv(nc, "zeta", NC_FLOAT, 3, d3, "standard_name", "sea_surface_elevation", "long_name",
                 "Sea surface elevation", "units", "meter", "grid_mapping", "projection_stere",
                 "coordinates", "lon lat", NULL);
    NCW(nc_enddef(nc));
    double tv[2] = {T0, T0 + 3600}, zv[3] = {0, 10, 50};
    NCW(nc_put_var_double(nc, vz, zv));
    size_t s0 = 0, ntv = nt;
    NCW(nc_put_vara_double(nc, vt, &s0, &ntv, tv));
    /* grid centred on 20 E 75 N, 25 km spacing */
    double xc, yc;
    ps_forward(20.0, 75.0, &xc, &yc);
    put_projected(nc, ids5, nx, ny, xc, yc, 25000.0, ps_inverse);
    short *q = malloc(nt * nz * nx * ny * sizeof *q);
    float *z = malloc(nt * nx * ny * sizeof *z);
    for (int c = 0; c < 2; c++) {
        for (size_t k = 0; k < nt * nz; k++)
            for (size_t p = 0; p < nx * ny; p++) /* surface: the field; below: other values */
                q[k * nx * ny + p] = (short)lround(((c ? UY : UX) + (k % nz ? 0.5 : 0)) / 0.001);
        NCW(nc_put_var_short(nc, *ids[c], q));
    }
    for (size_t p = 0; p < nt * nx * ny; p++)
        z[p] = 0.25f;
    NCW(nc_put_var_float(nc, vzeta, z));
    NCW(nc_close(nc));
    free(q), free(z);
}

/* MEPS-style Lambert wind. */
static void write_lambert(const char *path)
{
    const size_t nx = 50, ny = 50, nt = 2;
    static const char *const dn[3] = {"height7", "y", "x"};
    int dt, dh, dy, dx, nc = create4(path, NC_UNLIMITED, dn, 1, ny, nx, &dt, &dh, &dy, &dx);
    int vt, vh, vu, vv;
    static const char *const nm[6] = {"time", "height7", "y", "x", "longitude", "latitude"};
    int ids5[6], d4[4] = {dt, dh, dy, dx};
    def_projected(nc, d4, nm, "seconds since 1970-01-01 00:00:00 +00:00", "height", "up",
                  "degrees_", ids5);
    vt = ids5[0], vh = ids5[1];
    def_lcc(nc, "projection_lambert", LCC_LAT0, LCC_LON0, R_EARTH);
    vu = defv(nc, "x_wind_10m", NC_FLOAT, 4, d4, "standard_name", "x_wind", NULL);
    vv = defv(nc, "y_wind_10m", NC_FLOAT, 4, d4, "standard_name", "y_wind", NULL);
    wind_atts(nc, vu, vv, "projection_lambert", "longitude latitude", 9.96921e36f);
    NCW(nc_enddef(nc));
    double tv[2] = {T0, T0 + 3600}, hv = 10.0;
    size_t s0 = 0, ntv = nt;
    NCW(nc_put_vara_double(nc, vt, &s0, &ntv, tv));
    NCW(nc_put_var_double(nc, vh, &hv));
    /* 2.5 km spacing in MEPS, here every 25 km, around 20 E 75 N (the x
     * axis turns from 0 to 10 degrees off east over the domain) */
    double r0 = lcc_rho(LCC_LAT0), n = lcc_n(), rc = lcc_rho(75.0);
    double xc = rc * sin(n * (20.0 - LCC_LON0) * DEG),
           yc = r0 - rc * cos(n * (20.0 - LCC_LON0) * DEG);
    put_projected(nc, ids5, nx, ny, xc, yc, 25000.0, lcc_inverse);
    put_wind(nc, vu, vv, nt * nx * ny);
    NCW(nc_close(nc));
}

/* A rotated-pole wind (COSMO/CORDEX-style CF: rlon, rlat 1-D in degrees,
 * grid_mapping rotated_latitude_longitude, x_wind / y_wind along the
 * rotated grid), without 2-D latitude/longitude: the rotated origin at
 * (20 E, 75 N), i.e. grid_north_pole_longitude -160, latitude 15. */
#define NP 5 /* sample points per case */
#define ROT_PLON (-160.0)
#define ROT_PLAT 15.0
static void write_rotpole(const char *path)
{
    const size_t nx = 41, ny = 41, nt = 2;
    static const char *const dn[3] = {"height", "rlat", "rlon"};
    int dt, dh, dy, dx, nc = create4(path, NC_UNLIMITED, dn, 1, ny, nx, &dt, &dh, &dy, &dx);
    int vt = defv(nc, "time", NC_DOUBLE, 1, &dt, "standard_name", "time", "units",
                  "seconds since 1970-01-01 00:00:00", NULL);
    int vh = defv(nc, "height", NC_DOUBLE, 1, &dh, "standard_name", "height", "units", "m", "positive",
                  "up", NULL);
    int vy = defv(nc, "rlat", NC_DOUBLE, 1, &dy, "standard_name", "grid_latitude", "units", "degrees", NULL);
    int vx = defv(nc, "rlon", NC_DOUBLE, 1, &dx, "standard_name", "grid_longitude", "units", "degrees", NULL);
    int vp = defv(nc, "rotated_pole", NC_CHAR, 0, NULL, "grid_mapping_name", "rotated_latitude_longitude", NULL);
    attd(nc, vp, "grid_north_pole_latitude", ROT_PLAT);
    attd(nc, vp, "grid_north_pole_longitude", ROT_PLON);
    int d4[4] = {dt, dh, dy, dx};
    int vu = defv(nc, "U_10M", NC_FLOAT, 4, d4, "standard_name", "x_wind", NULL);
    int vv = defv(nc, "V_10M", NC_FLOAT, 4, d4, "standard_name", "y_wind", NULL);
    for (int c = 0; c < 2; c++) {
        att(nc, c ? vv : vu, "units", "m s-1");
        att(nc, c ? vv : vu, "grid_mapping", "rotated_pole");
    }
    NCW(nc_enddef(nc));
    double tv[2] = {T0, T0 + 3600}, hv = 10.0, a[41];
    size_t s0 = 0, ntv = nt;
    NCW(nc_put_vara_double(nc, vt, &s0, &ntv, tv));
    NCW(nc_put_var_double(nc, vh, &hv));
    for (size_t k = 0; k < 41; k++)
        a[k] = -5.0 + 0.25 * (double)k;
    NCW(nc_put_var_double(nc, vx, a));
    NCW(nc_put_var_double(nc, vy, a));
    put_wind(nc, vu, vv, nt * nx * ny);
    NCW(nc_close(nc));
}

/* The angle from east to the rotated grid's x axis at a sample point, by
 * PROJ's general oblique transformation (ob_tran: o_lat_p = the pole's
 * latitude, lon_0 = 180 + its longitude): the rotated coordinates of the
 * point and of a point 1e-4 degree east of it, the step's direction on
 * the rotated sphere (cos(rlat) drlon, drlat) is east's angle from x. */
static const double *rot_lon, *rot_lat;
static double rot_alpha(double lon)
{
    double lat = NAN;
    for (int p = 0; p < NP; p++)
        if (rot_lon[p] == lon)
            lat = rot_lat[p];
    PJ_CONTEXT *ctx = proj_context_create();
    char def[200];
    snprintf(def, sizeof def, "+proj=ob_tran +o_proj=longlat +o_lat_p=%g +o_lon_p=0 +lon_0=%g +R=6371000 +no_defs",
             ROT_PLAT, 180.0 + ROT_PLON);
    PJ *P = proj_create(ctx, def);
    PJ_COORD a = proj_trans(P, PJ_FWD, proj_coord(lon * DEG, lat * DEG, 0, 0));
    PJ_COORD b = proj_trans(P, PJ_FWD, proj_coord((lon + 1e-4) * DEG, lat * DEG, 0, 0));
    double east = atan2(b.lp.phi - a.lp.phi, cos(a.lp.phi) * remainder(b.lp.lam - a.lp.lam, 2 * M_PI));
    proj_destroy(P);
    proj_context_destroy(ctx);
    return -east;
}

/* ROMS grid: rho points on the polar stereographic plane above, the xi
 * axis turned by BETA from the plane's x axis. */
#define ROMS_BETA (25.0 * DEG)
#define ROMS_NX 40 /* xi_rho */
#define ROMS_NY 36 /* eta_rho */
static double roms_x0, roms_y0;
static void roms_point(double i, double j, double *lon, double *lat)
{
    const double d = 20000.0;
    double x = roms_x0 + (i * cos(ROMS_BETA) - j * sin(ROMS_BETA)) * d;
    double y = roms_y0 + (i * sin(ROMS_BETA) + j * cos(ROMS_BETA)) * d;
    ps_inverse(x, y, lon, lat);
}

static void write_roms(const char *path, int with_angle)
{
    const size_t nr = 4, nt = 2;
    ps_forward(20.0, 75.0, &roms_x0, &roms_y0);
    roms_x0 -= (ROMS_NX / 2.0 * cos(ROMS_BETA) - ROMS_NY / 2.0 * sin(ROMS_BETA)) * 20000.0;
    roms_y0 -= (ROMS_NX / 2.0 * sin(ROMS_BETA) + ROMS_NY / 2.0 * cos(ROMS_BETA)) * 20000.0;
    int nc, dxr, der, dxu, deu, dxv, dev, ds, dt;
    NCW(nc_create(path, NC_CLOBBER | NC_64BIT_OFFSET, &nc));
    NCW(nc_def_dim(nc, "xi_rho", ROMS_NX, &dxr));
    NCW(nc_def_dim(nc, "xi_u", ROMS_NX - 1, &dxu));
    NCW(nc_def_dim(nc, "xi_v", ROMS_NX, &dxv));
    NCW(nc_def_dim(nc, "eta_rho", ROMS_NY, &der));
    NCW(nc_def_dim(nc, "eta_u", ROMS_NY, &deu));
    NCW(nc_def_dim(nc, "eta_v", ROMS_NY - 1, &dev));
    NCW(nc_def_dim(nc, "s_rho", nr, &ds));
    NCW(nc_def_dim(nc, "ocean_time", NC_UNLIMITED, &dt));
    int vs, vt, vang = -1, vmask, vu, vv;
    vs = defv(nc, "s_rho", NC_DOUBLE, 1, &ds, "long_name", "S-coordinate at RHO-points", NULL);
    attd(nc, vs, "valid_min", -1.0);
    attd(nc, vs, "valid_max", 0.0);
    att(nc, vs, "positive", "up");
    att(nc, vs, "standard_name", "ocean_s_coordinate_g2");
    att(nc, vs, "formula_terms", "s: s_rho C: Cs_r eta: zeta depth: h depth_c: hc");
    vt = defv(nc, "ocean_time", NC_DOUBLE, 1, &dt, "long_name", "time since initialization",
              "units", "seconds since 1970-01-01 00:00:00", "calendar", "gregorian", NULL);
    static const char *pts[3] = {"rho", "u", "v"};
    int dims[3][2] = {{der, dxr}, {deu, dxu}, {dev, dxv}}, vll[2][3];
    static const char *const axis[2] = {"longitude", "latitude"};
    static const char *const unit[2] = {"degree_east", "degree_north"};
    for (int k = 0; k < 3; k++)
        for (int c = 0; c < 2; c++) {
            char nm[16], ln[64];
            snprintf(nm, sizeof nm, "%.3s_%s", axis[c], pts[k]);
            snprintf(ln, sizeof ln, "%s of %s-points", axis[c],
                     k == 0   ? "RHO"
                     : k == 1 ? "U"
                              : "V");
            vll[c][k] = defv(nc, nm, NC_DOUBLE, 2, dims[k], "long_name", ln, "units", unit[c],
                             "standard_name", axis[c], NULL);
        }
    int *vlon = vll[0], *vlat = vll[1];
    if (with_angle) {
        vang =
            defv(nc, "angle", NC_DOUBLE, 2, dims[0], "long_name", "angle between XI-axis and EAST",
                 "units", "radians", "coordinates", "lon_rho lat_rho", NULL);
    }
    vmask = defv(nc, "mask_rho", NC_DOUBLE, 2, dims[0], "long_name", "mask on RHO-points", NULL);
    double fv[2] = {0, 1};
    NCW(nc_put_att_double(nc, vmask, "flag_values", NC_DOUBLE, 2, fv));
    att(nc, vmask, "flag_meanings", "land water");
    att(nc, vmask, "coordinates", "lon_rho lat_rho");
    int du[4] = {dt, ds, deu, dxu}, dv[4] = {dt, ds, dev, dxv};
    vu = defv(nc, "u", NC_FLOAT, 4, du, "long_name", "u-momentum component", "coordinates",
              "lon_u lat_u s_rho ocean_time", NULL);
    vv = defv(nc, "v", NC_FLOAT, 4, dv, "long_name", "v-momentum component", "coordinates",
              "lon_v lat_v s_rho ocean_time", NULL);
    for (int c = 0; c < 2; c++) {
        int v = c ? vv : vu;
        att(nc, v, "units", "meter second-1");
        att(nc, v, "time", "ocean_time");
        att(nc, v, "field", c ? "v-velocity, scalar, series" : "u-velocity, scalar, series");
        float fill = 1e37f;
        NCW(nc_put_att_float(nc, v, "_FillValue", NC_FLOAT, 1, &fill));
    }
    NCW(nc_enddef(nc));
    double sv[4] = {-0.875, -0.625, -0.375, -0.125}, tv[2] = {T0, T0 + 3600};
    NCW(nc_put_var_double(nc, vs, sv));
    size_t s0 = 0, ntv = nt;
    NCW(nc_put_vara_double(nc, vt, &s0, &ntv, tv));
    size_t nxs[3] = {ROMS_NX, ROMS_NX - 1, ROMS_NX}, nys[3] = {ROMS_NY, ROMS_NY, ROMS_NY - 1};
    double off[3][2] = {{0, 0}, {0.5, 0}, {0, 0.5}};
    double *lon = malloc(ROMS_NX * ROMS_NY * sizeof *lon),
           *lat = malloc(ROMS_NX * ROMS_NY * sizeof *lat);
    double *ang = malloc(ROMS_NX * ROMS_NY * sizeof *ang);
    for (int k = 0; k < 3; k++) {
        for (size_t j = 0; j < nys[k]; j++)
            for (size_t i = 0; i < nxs[k]; i++) {
                size_t p = j * nxs[k] + i;
                roms_point((double)i + off[k][0], (double)j + off[k][1], &lon[p], &lat[p]);
                /* the xi axis: BETA from the plane's x axis, which is
                 * ps_alpha from east */
                if (k == 0)
                    ang[p] = ROMS_BETA + ps_alpha(lon[p]);
            }
        NCW(nc_put_var_double(nc, vlon[k], lon));
        NCW(nc_put_var_double(nc, vlat[k], lat));
    }
    if (with_angle)
        NCW(nc_put_var_double(nc, vang, ang));
    for (size_t p = 0; p < ROMS_NX * ROMS_NY; p++)
        ang[p] = 1.0;
    NCW(nc_put_var_double(nc, vmask, ang));
    float *w = malloc(nt * nr * ROMS_NX * ROMS_NY * sizeof *w);
    for (int c = 0; c < 2; c++) {
        size_t n2 = nxs[c + 1] * nys[c + 1];
        for (size_t k = 0; k < nt * nr; k++)
            for (size_t p = 0; p < n2; p++) /* surface: the last s_rho */
                w[k * n2 + p] = (float)((c ? UY : UX) + (k % nr == nr - 1 ? 0 : 0.4));
        NCW(nc_put_var_float(nc, c ? vv : vu, w));
    }
    NCW(nc_close(nc));
    free(lon), free(lat), free(ang), free(w);
}

/* ---- checks ---- */


static double ps_alpha_ll(double lon) { return ps_alpha(lon); }
static double roms_alpha_ll(double lon) { return ROMS_BETA + ps_alpha(lon); }
static double zero_ll(double lon)
{
    (void)lon;
    return 0.0;
}

/* One case: a file opened as one source, then either refused (one line
 * naming the file, var1 and var2, and the key) or sampled at NP points and
 * compared with the hand rotation of the grid components (UX, UY) x scale
 * by alpha(lon) at each point: direction within 0.5 degrees, speed within
 * 1 %; and what forcing_describe says about the orientation. */
typedef struct vcase {
    const char *what, *file, *source;
    forcing_kind kind;
    unsigned req;
    const forcing_name_map *map;
    size_t nmap;
    int vectors;
    const char *var1, *var2; /* refused: the variables named; NULL: accepted */
    double scale;            /* UX, UY times this */
    double (*alpha)(double lon);
    const char *orient, *why; /* orientation starts with orient and contains why */
    const double *lon, *lat;  /* sample points */
    double box[4];            /* domain lon_min, lon_max, lat_min, lat_max */
} vcase;

static void check_orientation(forcing *f, const char *want, const char *why, const char *what)
{
    forcing_var_info info[16];
    size_t n = forcing_describe(f, info, 16), seen = 0;
    for (size_t i = 0; i < n && i < 16; i++) {
        if (!info[i].orientation[0])
            continue;
        seen++;
        CHECK(strncmp(info[i].orientation, want, strlen(want)) == 0 &&
                  strstr(info[i].orientation, why),
              "%s: orientation of %s is '%s', want '%s...' with '%s'", what, info[i].variable,
              info[i].orientation, want, why);
    }
    CHECK(seen == 2, "%s: %zu vector components described, want 2", what, seen);
}

static void run_case(const vcase *c)
{
    const char *files[1] = {c->file};
    forcing_source_spec sp = {.name = c->source,
                              .kind = c->kind,
                              .files = files,
                              .nfiles = 1,
                              .map = c->map,
                              .nmap = c->nmap,
                              .required = c->req,
                              .vectors = c->vectors};
    forcing *f = NULL;
    sph_error e;
    sph_error_clear(&e);
    int rc =
        forcing_open(&f, &sp, 1, T0, T0 + 3600, c->box[0], c->box[1], c->box[2], c->box[3], &e);
    if (c->var1) {
        CHECK(rc != 0, "%s: accepted", c->what);
        CHECK(strchr(e.msg, '\n') == NULL, "%s: more than one line: %s", c->what, e.msg);
        CHECK(strstr(e.msg, c->file) != NULL, "%s: file not named: %s", c->what, e.msg);
        CHECK(strstr(e.msg, c->var1) != NULL && (!c->var2 || strstr(e.msg, c->var2) != NULL),
              "%s: variables not named: %s", c->what, e.msg);
        CHECK(strstr(e.msg, "forcing[].vectors") != NULL, "%s: key not named: %s", c->what, e.msg);
        forcing_close(f);
        return;
    }
    CHECK(rc == 0, "%s: open: %s", c->what, e.msg);
    if (rc) {
        forcing_close(f);
        return;
    }
    double ue[NP], vn[NP], ssh[NP];
    int wind = c->kind == FORCING_ATMOSPHERE;
    forcing_sample s = {.u_east = wind ? ue : NULL,
                        .v_north = wind ? vn : NULL,
                        .uw_east = wind ? NULL : ue,
                        .vw_north = wind ? NULL : vn,
                        .ssh = (c->req & FQ_SSH) ? ssh : NULL};
    rc = forcing_sample_at(f, T0 + 1800, NP, c->lon, c->lat, &s, &e);
    CHECK(rc == 0, "%s: sample: %s", c->what, e.msg);
    double ux = c->scale * UX, uy = c->scale * UY;
    for (int p = 0; p < NP && rc == 0; p++) {
        double a = c->alpha(c->lon[p]);
        double we = ux * cos(a) - uy * sin(a), wn = ux * sin(a) + uy * cos(a);
        double d = remainder(atan2(vn[p], ue[p]) - atan2(wn, we), 2 * M_PI) / DEG;
        CHECK(fabs(d) < 0.5,
              "%s: point %d direction off by %.3f deg (got %.4f, %.4f, want %.4f, "
              "%.4f; grid angle %.2f deg)",
              c->what, p, d, ue[p], vn[p], we, wn, a / DEG);
        CHECK(fabs(hypot(ue[p], vn[p]) - hypot(ux, uy)) < 0.01 * hypot(ux, uy),
              "%s: point %d speed %.4f want %.4f", c->what, p, hypot(ue[p], vn[p]), hypot(ux, uy));
    }
    if (rc == 0 && (c->req & FQ_SSH)) {
        CHECK(s.provided & FQ_SSH, "%s: no sea-surface height", c->what);
        CHECK_CLOSE(ssh[2], 0.25, 1e-6, 1e-6, "zeta as sea_surface_elevation");
    }
    check_orientation(f, c->orient, c->why, c->what);
    forcing_close(f);
}

int main(void)
{
    char dir[] = "/tmp/test_forcing_vectors.XXXXXX";
    if (!mkdtemp(dir))
        return 2;
    enum { METNO, METNO_PLAIN, MEPS, ROMS, ROMS_PLAIN, NAM, ROTPOLE, NFILES };
    static const char *const fname[NFILES] = {"norkyst800_his.nc", "norkyst800_plain.nc",
                                              "meps_det_2_5km.nc", "roms_his_0001.nc",
                                              "roms_noangle.nc",   "nam_218_conus.nc",
                                              "cosmo_rotpole.nc"};
    char path[NFILES][300];
    for (int k = 0; k < NFILES; k++)
        snprintf(path[k], sizeof path[k], "%s/%s", dir, fname[k]);
    const char *metno = path[METNO], *metno_plain = path[METNO_PLAIN], *lam = path[MEPS];
    const char *roms = path[ROMS], *roms_plain = path[ROMS_PLAIN], *nam = path[NAM];
    write_metno(metno, 1);
    write_metno(metno_plain, 0);
    write_lambert(lam);
    write_roms(roms, 1);
    write_roms(roms_plain, 0);
    write_nam(nam);
    write_rotpole(path[ROTPOLE]);
    LCC_LON0 = 15.0, LCC_LAT0 = 63.3, LCC_R = R_EARTH; /* MEPS again */
    const forcing_name_map cur_map[] = {{"eastward_sea_water_velocity", "u"},
                                        {"northward_sea_water_velocity", "v"}};
    const forcing_name_map wmap[] = {{"eastward_wind", "u-component_of_wind_height_above_ground"},
                                     {"northward_wind", "v-component_of_wind_height_above_ground"}};
    static const double plon[NP] = {15.0, 20.0, 25.0, 18.0, 23.0};
    static const double plat[NP] = {74.0, 75.0, 76.0, 75.5, 74.5};
    static const double nlon[NP] = {-80.0, -75.0, -71.0, -78.0, -72.5};
    static const double nlat[NP] = {40.0, 42.0, 44.0, 43.5, 40.5};
    rot_lon = plon;
    rot_lat = plat;
#define ARCTIC                                                                                     \
    plon, plat, { 14, 26, 73.5, 76.5 }
#define CONUS                                                                                      \
    nlon, nlat, { -80, -70, 40, 44 }
    const char *u = "'u'", *v = "'v'";
    const char *nu = "'u-component_of_wind_height_above_ground'";
    const char *nv = "'v-component_of_wind_height_above_ground'";
    const vcase cases[] = {
        /* met.no: grid-relative from the standard name, rotated by the
         * angle of the 2-D lon/lat; SSH under sea_surface_elevation */
        {"met.no x_sea_water_velocity", metno, "norkyst", FORCING_OCEAN, FQ_CURRENT | FQ_SSH, NULL,
         0, FORCING_VECTORS_AUTO, NULL, NULL, 1, ps_alpha_ll, "grid-relative",
         "x_sea_water_velocity", ARCTIC},
        /* an explicit key that agrees */
        {"met.no, vectors grid", metno, "norkyst", FORCING_OCEAN, FQ_CURRENT, NULL, 0,
         FORCING_VECTORS_GRID, NULL, NULL, 1, ps_alpha_ll, "grid-relative", "x_sea_water_velocity",
         ARCTIC},
        /* one that contradicts the standard name: refused */
        {"met.no, vectors earth against x_sea_water_velocity", metno, "norkyst", FORCING_OCEAN,
         FQ_CURRENT, NULL, 0, FORCING_VECTORS_EARTH, u, NULL, 0, NULL, NULL, NULL, ARCTIC},
        /* without standard names, mapped by name: auto cannot tell */
        {"met.no mapped by name, auto", metno_plain, "norkyst", FORCING_OCEAN, FQ_CURRENT, cur_map,
         2, FORCING_VECTORS_AUTO, u, v, 0, NULL, NULL, NULL, ARCTIC},
        /* ... "grid" rotates them as the standard name did */
        {"met.no mapped, vectors grid", metno_plain, "norkyst", FORCING_OCEAN, FQ_CURRENT, cur_map,
         2, FORCING_VECTORS_GRID, NULL, NULL, 1, ps_alpha_ll, "grid-relative",
         "forcing[].vectors \"grid\"", ARCTIC},
        /* ... "earth" takes them as they are */
        {"met.no mapped, vectors earth", metno_plain, "norkyst", FORCING_OCEAN, FQ_CURRENT, cur_map,
         2, FORCING_VECTORS_EARTH, NULL, NULL, 1, zero_ll, "earth-relative",
         "forcing[].vectors \"earth\"", ARCTIC},
        /* Lambert-conformal wind: x_wind / y_wind */
        {"MEPS x_wind", lam, "meps", FORCING_ATMOSPHERE, FQ_WIND, NULL, 0, FORCING_VECTORS_AUTO,
         NULL, NULL, 10, lcc_alpha, "grid-relative", "x_wind", ARCTIC},
        /* ROMS: u, v by name; the angle variable says grid-relative (and
         * gives the angle, on the rho points), u and v on their own
         * C-grid points */
        {"ROMS angle", roms, "roms", FORCING_OCEAN, FQ_CURRENT, cur_map, 2, FORCING_VECTORS_AUTO,
         NULL, NULL, 1, roms_alpha_ll, "grid-relative",
         "angle'), rotated by the file's angle variable 'angle'", ARCTIC},
        /* ROMS without the angle: staggered u and v say grid-relative; the
         * angle from lon_u/lat_u */
        {"ROMS staggered", roms_plain, "roms", FORCING_OCEAN, FQ_CURRENT, cur_map, 2,
         FORCING_VECTORS_AUTO, NULL, NULL, 1, roms_alpha_ll, "grid-relative", "staggered C-grid",
         ARCTIC},
        /* NAM on its Lambert grid without latitude/longitude: the grid from
         * the grid mapping, the rotation from the projection's convergence;
         * GRIB names without standard_name */
        {"NAM mapped, auto", nam, "nam", FORCING_ATMOSPHERE, FQ_WIND, wmap, 2, FORCING_VECTORS_AUTO,
         nu, nv, 0, NULL, NULL, NULL, CONUS},
        {"NAM, vectors grid", nam, "nam", FORCING_ATMOSPHERE, FQ_WIND, wmap, 2,
         FORCING_VECTORS_GRID, NULL, NULL, 10, nam_alpha, "grid-relative",
         "grid mapping 'LambertConformal_Projection'", CONUS},
        /* a rotated pole without latitude/longitude: nodes and angle from
         * the rotation, checked against PROJ's ob_tran */
        {"rotated pole x_wind", path[ROTPOLE], "cosmo", FORCING_ATMOSPHERE, FQ_WIND, NULL, 0,
         FORCING_VECTORS_AUTO, NULL, NULL, 10, rot_alpha, "grid-relative", "rotated pole", ARCTIC},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++)
        run_case(&cases[k]);
    sph_error e;
    int rc;

    /* a grid mapping without the figure of the earth: refused, not taken
     * as WGS84 */
    {
        char noearth[320];
        snprintf(noearth, sizeof noearth, "%s/nam_noearth.nc", dir);
        nam_radius = 0.0;
        write_nam(noearth);
        const char *files[1] = {noearth};
        forcing_source_spec sp = {.name = "nam", .kind = FORCING_ATMOSPHERE, .files = files, .nfiles = 1,
                                  .map = wmap, .nmap = 2, .required = FQ_WIND, .vectors = FORCING_VECTORS_GRID};
        forcing *f = NULL;
        sph_error_clear(&e);
        rc = forcing_open(&f, &sp, 1, T0, T0 + 3600, -80, -70, 40, 44, &e);
        CHECK(rc != 0 && strstr(e.msg, noearth) && strstr(e.msg, "LambertConformal_Projection") &&
                  strstr(e.msg, "ellipsoid") && !strchr(e.msg, '\n'),
              "a mapping without the earth's figure refused in one line: %s", e.msg);
        forcing_close(f);
        unlink(noearth);
    }

    /* sphice check: one line per vector quantity, earth or grid and why;
     * with "auto" the refusal names the key */
    for (int k = 0; k < 2; k++) {
        char text[2048], *out = NULL;
        size_t outlen = 0;
        snprintf(text, sizeof text,
                 "{\"domain\": {\"lon_min\": 14, \"lon_max\": 26, \"lat_min\": 73.5, "
                 "\"lat_max\": 76.5}, \"schedule\": {\"forecast_hours\": 1},"
                 " \"forcing\": [{\"name\": \"norkyst\", \"kind\": \"ocean\", \"urls\": "
                 "\"%s\","
                 " \"required\": [\"current\"], \"vectors\": \"%s\", \"variables\": "
                 "{\"eastward_sea_water_velocity\": \"u\", "
                 "\"northward_sea_water_velocity\": \"v\"}}],"
                 " \"output\": {\"dir\": \"%s/out\"}}",
                 metno_plain, k ? "auto" : "grid", dir);
        struct sph_config *cfg = NULL;
        sph_error_clear(&e);
        rc = sph_config_parse(text, "vectors.json", &cfg, &e);
        CHECK(rc == 0, "config with forcing[].vectors: %s", e.msg);
        if (rc)
            continue;
        FILE *mf = open_memstream(&out, &outlen);
        service_check(cfg, T0, 0, mf);
        fclose(mf);
        if (k == 0)
            CHECK(strstr(out, "vectors      norkyst    current") &&
                      strstr(out, "grid-relative (forcing[].vectors \"grid\"), "
                                  "rotated by the angle "
                                  "of the grid's x axis from 'lon'/'lat'"),
                  "check does not say grid-relative and why:\n%s", out);
        else
            CHECK(strstr(out, "PROBLEM") && strstr(out, "forcing[].vectors") &&
                      strstr(out, metno_plain),
                  "check does not report the undecidable pair:\n%s", out);
        free(out);
        sph_config_free(cfg);
    }

    for (int k = 0; k < NFILES; k++)
        unlink(path[k]);
    CHECK(rmdir(dir) == 0, "the test's folder %s is left", dir);
    return check_summary("test_forcing_vectors");
}
