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
#include "util/err.h"

#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define NCW(call)                                                                   \
    do {                                                                            \
        int rc_ = (call);                                                           \
        if (rc_ != NC_NOERR) {                                                      \
            fprintf(stderr, "%s:%d: %s: %s\n", __FILE__, __LINE__, #call,           \
                    nc_strerror(rc_));                                              \
            exit(2);                                                                \
        }                                                                           \
    } while (0)

#define DEG (M_PI / 180.0)
#define R_EARTH 6371000.0
#define T0 1700000000.0 /* 2023-11-14T22:13:20Z: file times T0, T0 + 3600 */

static char dir[256];

static void att(int nc, int v, const char *name, const char *text)
{
    NCW(nc_put_att_text(nc, v, name, strlen(text), text));
}

static void attd(int nc, int v, const char *name, double x)
{
    NCW(nc_put_att_double(nc, v, name, NC_DOUBLE, 1, &x));
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
static double ps_alpha(double lon)
{
    return -(lon - PS_LON0) * DEG;
}

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
static double lcc_alpha(double lon)
{
    return -lcc_n() * remainder(lon - LCC_LON0, 360.0) * DEG;
}

/* NCEP NAM 12 km (grid 218) as THREDDS NetCDF Subset Service writes it:
 * x, y in km, LambertConformal_Projection, no latitude/longitude, GRIB
 * names without standard_name; NCEP's winds on this grid are grid-relative
 * (GRIB2 resolution and component flags), so the source says
 * forcing[].vectors "grid". */
static void write_nam(const char *path)
{
    const size_t nx = 40, ny = 30, nt = 2;
    LCC_LON0 = 265.0, LCC_LAT0 = 25.0, LCC_R = 6371229.0;
    int nc, dt, dh, dy, dx;
    NCW(nc_create(path, NC_CLOBBER | NC_NETCDF4, &nc));
    NCW(nc_def_dim(nc, "time", nt, &dt));
    NCW(nc_def_dim(nc, "height_above_ground1", 1, &dh));
    NCW(nc_def_dim(nc, "y", ny, &dy));
    NCW(nc_def_dim(nc, "x", nx, &dx));
    int vt, vh, vy, vx, vproj, vu, vv;
    NCW(nc_def_var(nc, "time", NC_DOUBLE, 1, &dt, &vt));
    att(nc, vt, "units", "Hour since 2023-11-14T22:00:00Z");
    att(nc, vt, "standard_name", "time");
    NCW(nc_def_var(nc, "height_above_ground1", NC_FLOAT, 1, &dh, &vh));
    att(nc, vh, "units", "m");
    att(nc, vh, "positive", "up");
    NCW(nc_def_var(nc, "y", NC_FLOAT, 1, &dy, &vy));
    att(nc, vy, "standard_name", "projection_y_coordinate");
    att(nc, vy, "units", "km");
    NCW(nc_def_var(nc, "x", NC_FLOAT, 1, &dx, &vx));
    att(nc, vx, "standard_name", "projection_x_coordinate");
    att(nc, vx, "units", "km");
    NCW(nc_def_var(nc, "LambertConformal_Projection", NC_INT, 0, NULL, &vproj));
    att(nc, vproj, "grid_mapping_name", "lambert_conformal_conic");
    attd(nc, vproj, "latitude_of_projection_origin", 25.0);
    attd(nc, vproj, "longitude_of_central_meridian", 265.0);
    attd(nc, vproj, "standard_parallel", 25.0);
    attd(nc, vproj, "earth_radius", 6371229.0);
    int d4[4] = {dt, dh, dy, dx};
    NCW(nc_def_var(nc, "u-component_of_wind_height_above_ground", NC_FLOAT, 4, d4, &vu));
    att(nc, vu, "long_name", "u-component of wind @ Specified height level above ground");
    NCW(nc_def_var(nc, "v-component_of_wind_height_above_ground", NC_FLOAT, 4, d4, &vv));
    att(nc, vv, "long_name", "v-component of wind @ Specified height level above ground");
    for (int c = 0; c < 2; c++) {
        int v = c ? vv : vu;
        att(nc, v, "units", "m/s");
        att(nc, v, "grid_mapping", "LambertConformal_Projection");
        att(nc, v, "coordinates", "reftime time height_above_ground1 y x ");
        float fill = NAN;
        NCW(nc_put_att_float(nc, v, "_FillValue", NC_FLOAT, 1, &fill));
    }
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
    float *w = malloc(nt * nx * ny * sizeof *w);
    for (int c = 0; c < 2; c++) {
        for (size_t p = 0; p < nt * nx * ny; p++)
            w[p] = (float)(c ? 10 * UY : 10 * UX);
        NCW(nc_put_var_float(nc, c ? vv : vu, w));
    }
    NCW(nc_close(nc));
    free(w);
}

/* ---- the files ---- */


/* met.no ocean model on polar stereographic; names_std 0: u, v without
 * standard_name (to be mapped by name). */
static void write_metno(const char *path, int names_std)
{
    const size_t nx = 50, ny = 50, nz = 3, nt = 2;
    int nc, dt, dz, dy, dx;
    NCW(nc_create(path, NC_CLOBBER | NC_NETCDF4, &nc));
    NCW(nc_def_dim(nc, "time", NC_UNLIMITED, &dt));
    NCW(nc_def_dim(nc, "depth", nz, &dz));
    NCW(nc_def_dim(nc, "Y", ny, &dy));
    NCW(nc_def_dim(nc, "X", nx, &dx));
    int vt, vz, vy, vx, vlon, vlat, vproj, vu, vv, vzeta;
    NCW(nc_def_var(nc, "time", NC_DOUBLE, 1, &dt, &vt));
    att(nc, vt, "standard_name", "time");
    att(nc, vt, "units", "seconds since 1970-01-01 00:00:00");
    NCW(nc_def_var(nc, "depth", NC_DOUBLE, 1, &dz, &vz));
    att(nc, vz, "standard_name", "depth");
    att(nc, vz, "units", "m");
    att(nc, vz, "positive", "down");
    NCW(nc_def_var(nc, "Y", NC_DOUBLE, 1, &dy, &vy));
    att(nc, vy, "standard_name", "projection_y_coordinate");
    att(nc, vy, "units", "m");
    NCW(nc_def_var(nc, "X", NC_DOUBLE, 1, &dx, &vx));
    att(nc, vx, "standard_name", "projection_x_coordinate");
    att(nc, vx, "units", "m");
    int d2[2] = {dy, dx};
    NCW(nc_def_var(nc, "lon", NC_DOUBLE, 2, d2, &vlon));
    att(nc, vlon, "standard_name", "longitude");
    att(nc, vlon, "units", "degree_east");
    NCW(nc_def_var(nc, "lat", NC_DOUBLE, 2, d2, &vlat));
    att(nc, vlat, "standard_name", "latitude");
    att(nc, vlat, "units", "degree_north");
    NCW(nc_def_var(nc, "projection_stere", NC_INT, 0, NULL, &vproj));
    att(nc, vproj, "grid_mapping_name", "polar_stereographic");
    attd(nc, vproj, "straight_vertical_longitude_from_pole", PS_LON0);
    attd(nc, vproj, "latitude_of_projection_origin", 90.0);
    attd(nc, vproj, "standard_parallel", 60.0);
    attd(nc, vproj, "earth_radius", R_EARTH);
    int d4[4] = {dt, dz, dy, dx}, d3[3] = {dt, dy, dx};
    const char *names[2] = {"u", "v"};
    const char *stds[2] = {"x_sea_water_velocity", "y_sea_water_velocity"};
    int *ids[2] = {&vu, &vv};
    for (int c = 0; c < 2; c++) {
        NCW(nc_def_var(nc, names[c], NC_SHORT, 4, d4, ids[c]));
        if (names_std)
            att(nc, *ids[c], "standard_name", stds[c]);
        att(nc, *ids[c], "long_name", c ? "velocity component in y direction"
                                        : "velocity component in x direction");
        att(nc, *ids[c], "units", "m s-1");
        att(nc, *ids[c], "grid_mapping", "projection_stere");
        att(nc, *ids[c], "coordinates", "lon lat");
        short fill = -32767;
        NCW(nc_put_att_short(nc, *ids[c], "_FillValue", NC_SHORT, 1, &fill));
        attd(nc, *ids[c], "scale_factor", 0.001);
        attd(nc, *ids[c], "add_offset", 0.0);
    }
    NCW(nc_def_var(nc, "zeta", NC_FLOAT, 3, d3, &vzeta));
    att(nc, vzeta, "standard_name", "sea_surface_elevation");
    att(nc, vzeta, "long_name", "Sea surface elevation");
    att(nc, vzeta, "units", "meter");
    att(nc, vzeta, "grid_mapping", "projection_stere");
    att(nc, vzeta, "coordinates", "lon lat");
    NCW(nc_enddef(nc));
    double tv[2] = {T0, T0 + 3600}, zv[3] = {0, 10, 50};
    NCW(nc_put_var_double(nc, vz, zv));
    size_t s0 = 0, ntv = nt;
    NCW(nc_put_vara_double(nc, vt, &s0, &ntv, tv));
    /* grid centred on 20 E 75 N, 25 km spacing */
    double xc, yc;
    ps_forward(20.0, 75.0, &xc, &yc);
    double *X = malloc(nx * sizeof *X), *Y = malloc(ny * sizeof *Y);
    double *lon = malloc(nx * ny * sizeof *lon), *lat = malloc(nx * ny * sizeof *lat);
    for (size_t i = 0; i < nx; i++)
        X[i] = xc + ((double)i - (double)(nx - 1) / 2) * 25000.0;
    for (size_t j = 0; j < ny; j++)
        Y[j] = yc + ((double)j - (double)(ny - 1) / 2) * 25000.0;
    for (size_t j = 0; j < ny; j++)
        for (size_t i = 0; i < nx; i++)
            ps_inverse(X[i], Y[j], &lon[j * nx + i], &lat[j * nx + i]);
    NCW(nc_put_var_double(nc, vx, X));
    NCW(nc_put_var_double(nc, vy, Y));
    NCW(nc_put_var_double(nc, vlon, lon));
    NCW(nc_put_var_double(nc, vlat, lat));
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
    free(X), free(Y), free(lon), free(lat), free(q), free(z);
}

/* MEPS-style Lambert wind. */
static void write_lambert(const char *path)
{
    const size_t nx = 50, ny = 50, nt = 2;
    int nc, dt, dh, dy, dx;
    NCW(nc_create(path, NC_CLOBBER | NC_NETCDF4, &nc));
    NCW(nc_def_dim(nc, "time", NC_UNLIMITED, &dt));
    NCW(nc_def_dim(nc, "height7", 1, &dh));
    NCW(nc_def_dim(nc, "y", ny, &dy));
    NCW(nc_def_dim(nc, "x", nx, &dx));
    int vt, vh, vy, vx, vlon, vlat, vproj, vu, vv;
    NCW(nc_def_var(nc, "time", NC_DOUBLE, 1, &dt, &vt));
    att(nc, vt, "standard_name", "time");
    att(nc, vt, "units", "seconds since 1970-01-01 00:00:00 +00:00");
    NCW(nc_def_var(nc, "height7", NC_DOUBLE, 1, &dh, &vh));
    att(nc, vh, "standard_name", "height");
    att(nc, vh, "units", "m");
    att(nc, vh, "positive", "up");
    NCW(nc_def_var(nc, "y", NC_DOUBLE, 1, &dy, &vy));
    att(nc, vy, "standard_name", "projection_y_coordinate");
    att(nc, vy, "units", "m");
    NCW(nc_def_var(nc, "x", NC_DOUBLE, 1, &dx, &vx));
    att(nc, vx, "standard_name", "projection_x_coordinate");
    att(nc, vx, "units", "m");
    int d2[2] = {dy, dx};
    NCW(nc_def_var(nc, "longitude", NC_DOUBLE, 2, d2, &vlon));
    att(nc, vlon, "standard_name", "longitude");
    att(nc, vlon, "units", "degrees_east");
    NCW(nc_def_var(nc, "latitude", NC_DOUBLE, 2, d2, &vlat));
    att(nc, vlat, "standard_name", "latitude");
    att(nc, vlat, "units", "degrees_north");
    NCW(nc_def_var(nc, "projection_lambert", NC_INT, 0, NULL, &vproj));
    att(nc, vproj, "grid_mapping_name", "lambert_conformal_conic");
    attd(nc, vproj, "standard_parallel", LCC_LAT0);
    attd(nc, vproj, "longitude_of_central_meridian", LCC_LON0);
    attd(nc, vproj, "latitude_of_projection_origin", LCC_LAT0);
    attd(nc, vproj, "earth_radius", R_EARTH);
    int d4[4] = {dt, dh, dy, dx};
    NCW(nc_def_var(nc, "x_wind_10m", NC_FLOAT, 4, d4, &vu));
    att(nc, vu, "standard_name", "x_wind");
    NCW(nc_def_var(nc, "y_wind_10m", NC_FLOAT, 4, d4, &vv));
    att(nc, vv, "standard_name", "y_wind");
    for (int c = 0; c < 2; c++) {
        int v = c ? vv : vu;
        att(nc, v, "units", "m/s");
        att(nc, v, "grid_mapping", "projection_lambert");
        att(nc, v, "coordinates", "longitude latitude");
        float fill = 9.96921e36f;
        NCW(nc_put_att_float(nc, v, "_FillValue", NC_FLOAT, 1, &fill));
    }
    NCW(nc_enddef(nc));
    double tv[2] = {T0, T0 + 3600}, hv = 10.0;
    size_t s0 = 0, ntv = nt;
    NCW(nc_put_vara_double(nc, vt, &s0, &ntv, tv));
    NCW(nc_put_var_double(nc, vh, &hv));
    /* 2.5 km spacing in MEPS, here every 25 km, around 20 E 75 N (the x
     * axis turns from 0 to 10 degrees off east over the domain) */
    double r0 = lcc_rho(LCC_LAT0), n = lcc_n(), rc = lcc_rho(75.0);
    double xc = rc * sin(n * (20.0 - LCC_LON0) * DEG), yc = r0 - rc * cos(n * (20.0 - LCC_LON0) * DEG);
    double X[50], Y[50], *lon = malloc(nx * ny * sizeof *lon), *lat = malloc(nx * ny * sizeof *lat);
    for (size_t i = 0; i < nx; i++)
        X[i] = xc + ((double)i - 24.5) * 25000.0;
    for (size_t j = 0; j < ny; j++)
        Y[j] = yc + ((double)j - 24.5) * 25000.0;
    for (size_t j = 0; j < ny; j++)
        for (size_t i = 0; i < nx; i++)
            lcc_inverse(X[i], Y[j], &lon[j * nx + i], &lat[j * nx + i]);
    NCW(nc_put_var_double(nc, vx, X));
    NCW(nc_put_var_double(nc, vy, Y));
    NCW(nc_put_var_double(nc, vlon, lon));
    NCW(nc_put_var_double(nc, vlat, lat));
    float *w = malloc(nt * nx * ny * sizeof *w);
    for (int c = 0; c < 2; c++) {
        for (size_t p = 0; p < nt * nx * ny; p++)
            w[p] = (float)(c ? 10 * UY : 10 * UX);
        NCW(nc_put_var_float(nc, c ? vv : vu, w));
    }
    NCW(nc_close(nc));
    free(lon), free(lat), free(w);
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
    int vs, vt, vang, vmask, vu, vv;
    NCW(nc_def_var(nc, "s_rho", NC_DOUBLE, 1, &ds, &vs));
    att(nc, vs, "long_name", "S-coordinate at RHO-points");
    attd(nc, vs, "valid_min", -1.0);
    attd(nc, vs, "valid_max", 0.0);
    att(nc, vs, "positive", "up");
    att(nc, vs, "standard_name", "ocean_s_coordinate_g2");
    att(nc, vs, "formula_terms", "s: s_rho C: Cs_r eta: zeta depth: h depth_c: hc");
    NCW(nc_def_var(nc, "ocean_time", NC_DOUBLE, 1, &dt, &vt));
    att(nc, vt, "long_name", "time since initialization");
    att(nc, vt, "units", "seconds since 1970-01-01 00:00:00");
    att(nc, vt, "calendar", "gregorian");
    static const char *pts[3] = {"rho", "u", "v"};
    int dims[3][2] = {{der, dxr}, {deu, dxu}, {dev, dxv}}, vlon[3], vlat[3];
    for (int k = 0; k < 3; k++) {
        char nm[16], ln[64];
        snprintf(nm, sizeof nm, "lon_%s", pts[k]);
        NCW(nc_def_var(nc, nm, NC_DOUBLE, 2, dims[k], &vlon[k]));
        snprintf(ln, sizeof ln, "longitude of %s-points", k == 0 ? "RHO" : k == 1 ? "U" : "V");
        att(nc, vlon[k], "long_name", ln);
        att(nc, vlon[k], "units", "degree_east");
        att(nc, vlon[k], "standard_name", "longitude");
        snprintf(nm, sizeof nm, "lat_%s", pts[k]);
        NCW(nc_def_var(nc, nm, NC_DOUBLE, 2, dims[k], &vlat[k]));
        snprintf(ln, sizeof ln, "latitude of %s-points", k == 0 ? "RHO" : k == 1 ? "U" : "V");
        att(nc, vlat[k], "long_name", ln);
        att(nc, vlat[k], "units", "degree_north");
        att(nc, vlat[k], "standard_name", "latitude");
    }
    if (with_angle) {
        NCW(nc_def_var(nc, "angle", NC_DOUBLE, 2, dims[0], &vang));
        att(nc, vang, "long_name", "angle between XI-axis and EAST");
        att(nc, vang, "units", "radians");
        att(nc, vang, "coordinates", "lon_rho lat_rho");
    }
    NCW(nc_def_var(nc, "mask_rho", NC_DOUBLE, 2, dims[0], &vmask));
    att(nc, vmask, "long_name", "mask on RHO-points");
    double fv[2] = {0, 1};
    NCW(nc_put_att_double(nc, vmask, "flag_values", NC_DOUBLE, 2, fv));
    att(nc, vmask, "flag_meanings", "land water");
    att(nc, vmask, "coordinates", "lon_rho lat_rho");
    int du[4] = {dt, ds, deu, dxu}, dv[4] = {dt, ds, dev, dxv};
    NCW(nc_def_var(nc, "u", NC_FLOAT, 4, du, &vu));
    att(nc, vu, "long_name", "u-momentum component");
    att(nc, vu, "coordinates", "lon_u lat_u s_rho ocean_time");
    NCW(nc_def_var(nc, "v", NC_FLOAT, 4, dv, &vv));
    att(nc, vv, "long_name", "v-momentum component");
    att(nc, vv, "coordinates", "lon_v lat_v s_rho ocean_time");
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
    double *lon = malloc(ROMS_NX * ROMS_NY * sizeof *lon), *lat = malloc(ROMS_NX * ROMS_NY * sizeof *lat);
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

static const double plon[] = {15.0, 20.0, 25.0, 18.0, 23.0};
static const double plat[] = {74.0, 75.0, 76.0, 75.5, 74.5};
#define NP 5

static int open1(forcing **f, const char *path, const char *name, forcing_kind kind,
                 unsigned req, const forcing_name_map *map, size_t nmap, int vectors,
                 sph_error *e)
{
    const char *files[1] = {path};
    forcing_source_spec sp = {.name = name, .kind = kind, .files = files, .nfiles = 1,
                              .map = map, .nmap = nmap, .required = req, .vectors = vectors};
    sph_error_clear(e);
    return forcing_open(f, &sp, 1, T0, T0 + 3600, 14, 26, 73.5, 76.5, e);
}

/* The sampled (east, north) against the hand rotation of (ux, uy) by alpha
 * at each point: direction within 0.5 degrees, speed within 1 %. */
static void check_rotated(forcing *f, int wind, double ux, double uy,
                          double (*alpha_at)(double lon, double lat), const char *what)
{
    double ue[NP], vn[NP];
    forcing_sample s = {0};
    if (wind) {
        s.u_east = ue;
        s.v_north = vn;
    } else {
        s.uw_east = ue;
        s.vw_north = vn;
    }
    sph_error e;
    sph_error_clear(&e);
    int rc = forcing_sample_at(f, T0 + 1800, NP, plon, plat, &s, &e);
    CHECK(rc == 0, "%s: sample: %s", what, e.msg);
    for (int p = 0; p < NP && rc == 0; p++) {
        double a = alpha_at(plon[p], plat[p]);
        double we = ux * cos(a) - uy * sin(a), wn = ux * sin(a) + uy * cos(a);
        double d = remainder(atan2(vn[p], ue[p]) - atan2(wn, we), 2 * M_PI) / DEG;
        CHECK(fabs(d) < 0.5, "%s: point %d direction off by %.3f deg (got %.4f, %.4f, want %.4f, "
              "%.4f; grid angle %.2f deg)", what, p, d, ue[p], vn[p], we, wn, a / DEG);
        CHECK(fabs(hypot(ue[p], vn[p]) - hypot(ux, uy)) < 0.01 * hypot(ux, uy),
              "%s: point %d speed %.4f want %.4f", what, p, hypot(ue[p], vn[p]), hypot(ux, uy));
    }
}

static double ps_alpha_ll(double lon, double lat) { (void)lat; return ps_alpha(lon); }
static double lcc_alpha_ll(double lon, double lat) { (void)lat; return lcc_alpha(lon); }
static double roms_alpha_ll(double lon, double lat) { (void)lat; return ROMS_BETA + ps_alpha(lon); }
static double zero_ll(double lon, double lat) { (void)lon; (void)lat; return 0.0; }

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

/* One line naming the file, the variables (or variable) and the key. */
static void check_refusal(int rc, const sph_error *e, const char *path, const char *var1,
                          const char *var2, const char *what)
{
    CHECK(rc != 0, "%s: accepted", what);
    CHECK(strchr(e->msg, '\n') == NULL, "%s: more than one line: %s", what, e->msg);
    CHECK(strstr(e->msg, path) != NULL, "%s: file not named: %s", what, e->msg);
    CHECK(strstr(e->msg, var1) != NULL && (!var2 || strstr(e->msg, var2) != NULL),
          "%s: variables not named: %s", what, e->msg);
    CHECK(strstr(e->msg, "forcing[].vectors") != NULL, "%s: key not named: %s", what, e->msg);
}

int main(void)
{
    snprintf(dir, sizeof dir, "/tmp/test_forcing_vectors.%d", (int)getpid());
    char cmd[300];
    snprintf(cmd, sizeof cmd, "mkdir -p %s", dir);
    if (system(cmd) != 0)
        return 2;
    char metno[300], metno_plain[300], lam[300], roms[300], roms_plain[300];
    snprintf(metno, sizeof metno, "%s/norkyst800_his.nc", dir);
    snprintf(metno_plain, sizeof metno_plain, "%s/norkyst800_plain.nc", dir);
    snprintf(lam, sizeof lam, "%s/meps_det_2_5km.nc", dir);
    snprintf(roms, sizeof roms, "%s/roms_his_0001.nc", dir);
    snprintf(roms_plain, sizeof roms_plain, "%s/roms_noangle.nc", dir);
    write_metno(metno, 1);
    write_metno(metno_plain, 0);
    write_lambert(lam);
    write_roms(roms, 1);
    write_roms(roms_plain, 0);
    forcing *f = NULL;
    sph_error e;
    const forcing_name_map cur_map[] = {{"eastward_sea_water_velocity", "u"},
                                        {"northward_sea_water_velocity", "v"}};

    /* met.no: grid-relative from the standard name, rotated by the angle
     * of the 2-D lon/lat; SSH under sea_surface_elevation. */
    int rc = open1(&f, metno, "norkyst", FORCING_OCEAN, FQ_CURRENT | FQ_SSH, NULL, 0,
                   FORCING_VECTORS_AUTO, &e);
    CHECK(rc == 0, "met.no: open: %s", e.msg);
    if (rc == 0) {
        check_rotated(f, 0, UX, UY, ps_alpha_ll, "met.no x_sea_water_velocity");
        check_orientation(f, "grid-relative", "x_sea_water_velocity", "met.no");
        double ssh[NP];
        forcing_sample s = {.ssh = ssh};
        CHECK(forcing_sample_at(f, T0, NP, plon, plat, &s, &e) == 0 && (s.provided & FQ_SSH),
              "met.no: no sea_surface_elevation: %s", e.msg);
        CHECK_CLOSE(ssh[2], 0.25, 1e-6, 1e-6, "met.no: zeta as sea_surface_elevation");
    }
    forcing_close(f);
    /* the same with an explicit key that agrees */
    rc = open1(&f, metno, "norkyst", FORCING_OCEAN, FQ_CURRENT, NULL, 0, FORCING_VECTORS_GRID, &e);
    CHECK(rc == 0, "met.no, vectors grid: open: %s", e.msg);
    forcing_close(f);
    /* and one that contradicts the standard name: refused */
    rc = open1(&f, metno, "norkyst", FORCING_OCEAN, FQ_CURRENT, NULL, 0, FORCING_VECTORS_EARTH,
               &e);
    check_refusal(rc, &e, metno, "'u'", NULL, "met.no, vectors earth against x_sea_water_velocity");
    forcing_close(f);

    /* met.no without standard names, mapped by name: auto cannot tell */
    rc = open1(&f, metno_plain, "norkyst", FORCING_OCEAN, FQ_CURRENT, cur_map, 2,
               FORCING_VECTORS_AUTO, &e);
    check_refusal(rc, &e, metno_plain, "'u'", "'v'", "met.no mapped by name, auto");
    forcing_close(f);
    /* ... "grid" rotates them as the standard name did */
    rc = open1(&f, metno_plain, "norkyst", FORCING_OCEAN, FQ_CURRENT, cur_map, 2,
               FORCING_VECTORS_GRID, &e);
    CHECK(rc == 0, "met.no mapped, vectors grid: open: %s", e.msg);
    if (rc == 0) {
        check_rotated(f, 0, UX, UY, ps_alpha_ll, "met.no mapped, vectors grid");
        check_orientation(f, "grid-relative", "forcing[].vectors \"grid\"", "met.no mapped grid");
    }
    forcing_close(f);
    /* ... "earth" takes them as they are */
    rc = open1(&f, metno_plain, "norkyst", FORCING_OCEAN, FQ_CURRENT, cur_map, 2,
               FORCING_VECTORS_EARTH, &e);
    CHECK(rc == 0, "met.no mapped, vectors earth: open: %s", e.msg);
    if (rc == 0) {
        check_rotated(f, 0, UX, UY, zero_ll, "met.no mapped, vectors earth");
        check_orientation(f, "earth-relative", "forcing[].vectors \"earth\"", "met.no mapped earth");
    }
    forcing_close(f);

    /* Lambert-conformal wind: x_wind / y_wind */
    rc = open1(&f, lam, "meps", FORCING_ATMOSPHERE, FQ_WIND, NULL, 0, FORCING_VECTORS_AUTO, &e);
    CHECK(rc == 0, "lambert: open: %s", e.msg);
    if (rc == 0) {
        check_rotated(f, 1, 10 * UX, 10 * UY, lcc_alpha_ll, "lambert x_wind");
        check_orientation(f, "grid-relative", "x_wind", "lambert");
    }
    forcing_close(f);

    /* NAM on its Lambert grid without latitude/longitude: the grid from
     * the grid mapping, the rotation from the projection's convergence. */
    {
        char nam[300];
        snprintf(nam, sizeof nam, "%s/nam_218_conus.nc", dir);
        write_nam(nam);
        const forcing_name_map wmap[] = {
            {"eastward_wind", "u-component_of_wind_height_above_ground"},
            {"northward_wind", "v-component_of_wind_height_above_ground"}};
        static const double nlon[] = {-80.0, -75.0, -71.0, -78.0, -72.5};
        static const double nlat[] = {40.0, 42.0, 44.0, 43.5, 40.5};
        const char *files[1] = {nam};
        forcing_source_spec sp = {.name = "nam", .kind = FORCING_ATMOSPHERE, .files = files,
                                  .nfiles = 1, .map = wmap, .nmap = 2, .required = FQ_WIND,
                                  .vectors = FORCING_VECTORS_AUTO};
        sph_error_clear(&e);
        rc = forcing_open(&f, &sp, 1, T0, T0 + 3600, -80, -70, 40, 44, &e);
        check_refusal(rc, &e, nam, "'u-component_of_wind_height_above_ground'",
                      "'v-component_of_wind_height_above_ground'", "nam mapped, auto");
        forcing_close(f);
        f = NULL;
        sp.vectors = FORCING_VECTORS_GRID;
        sph_error_clear(&e);
        rc = forcing_open(&f, &sp, 1, T0, T0 + 3600, -80, -70, 40, 44, &e);
        CHECK(rc == 0, "nam, vectors grid: open: %s", e.msg);
        if (rc == 0) {
            double ue[NP], vn[NP];
            forcing_sample s = {.u_east = ue, .v_north = vn};
            rc = forcing_sample_at(f, T0 + 1800, NP, nlon, nlat, &s, &e);
            CHECK(rc == 0, "nam: sample: %s", e.msg);
            for (int p = 0; p < NP && rc == 0; p++) {
                double a = lcc_alpha(nlon[p]);
                double we = 10 * (UX * cos(a) - UY * sin(a)), wn = 10 * (UX * sin(a) + UY * cos(a));
                double d = remainder(atan2(vn[p], ue[p]) - atan2(wn, we), 2 * M_PI) / DEG;
                CHECK(fabs(d) < 0.5, "nam: point %d direction off by %.3f deg (grid angle %.2f)",
                      p, d, a / DEG);
                CHECK(fabs(hypot(ue[p], vn[p]) - 10 * hypot(UX, UY)) < 0.1 * hypot(UX, UY),
                      "nam: point %d speed %.4f", p, hypot(ue[p], vn[p]));
            }
            check_orientation(f, "grid-relative", "grid mapping 'LambertConformal_Projection'",
                              "nam");
        }
        forcing_close(f);
        f = NULL;
        LCC_LON0 = 15.0, LCC_LAT0 = 63.3, LCC_R = R_EARTH;
    }

    /* ROMS: u, v by name; the angle variable says grid-relative (and gives
     * the angle, on the rho points), u and v on their own C-grid points. */
    rc = open1(&f, roms, "roms", FORCING_OCEAN, FQ_CURRENT, cur_map, 2, FORCING_VECTORS_AUTO, &e);
    CHECK(rc == 0, "roms: open: %s", e.msg);
    if (rc == 0) {
        check_rotated(f, 0, UX, UY, roms_alpha_ll, "roms angle");
        check_orientation(f, "grid-relative", "angle", "roms");
        check_orientation(f, "grid-relative", "rotated by the file's angle variable 'angle'",
                          "roms rotation");
    }
    forcing_close(f);
    /* ROMS without the angle: staggered u and v say grid-relative; the
     * angle from lon_u/lat_u */
    rc = open1(&f, roms_plain, "roms", FORCING_OCEAN, FQ_CURRENT, cur_map, 2,
               FORCING_VECTORS_AUTO, &e);
    CHECK(rc == 0, "roms without angle: open: %s", e.msg);
    if (rc == 0) {
        check_rotated(f, 0, UX, UY, roms_alpha_ll, "roms staggered, angle from lon_u/lat_u");
        check_orientation(f, "grid-relative", "staggered C-grid", "roms staggered");
    }
    forcing_close(f);

    /* sphice check: one line per vector quantity, earth or grid and why;
     * with "auto" the refusal names the key */
    for (int k = 0; k < 2; k++) {
        char text[2048], *out = NULL;
        size_t outlen = 0;
        snprintf(text, sizeof text,
                 "{\"domain\": {\"lon_min\": 14, \"lon_max\": 26, \"lat_min\": 73.5, "
                 "\"lat_max\": 76.5}, \"schedule\": {\"forecast_hours\": 1},"
                 " \"forcing\": [{\"name\": \"norkyst\", \"kind\": \"ocean\", \"urls\": \"%s\","
                 " \"required\": [\"current\"], \"vectors\": \"%s\", \"variables\": "
                 "{\"eastward_sea_water_velocity\": \"u\", \"northward_sea_water_velocity\": \"v\"}}],"
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
                      strstr(out, "grid-relative (forcing[].vectors \"grid\"), rotated by the angle "
                                  "of the grid's x axis from 'lon'/'lat'"),
                  "check does not say grid-relative and why:\n%s", out);
        else
            CHECK(strstr(out, "PROBLEM") && strstr(out, "forcing[].vectors") &&
                      strstr(out, metno_plain),
                  "check does not report the undecidable pair:\n%s", out);
        free(out);
        sph_config_free(cfg);
    }

    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", dir);
    return check_summary("test_forcing_vectors");
}
