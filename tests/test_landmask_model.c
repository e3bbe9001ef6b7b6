/* Land from the ocean model's own file, on its native grid (issue 19,
 * item 6).
 *
 * Files written here in the shape their models document:
 *  - ROMS (history file of an Arctic application on a polar-stereographic
 *    grid, x/y in km): dimensions xi_rho/eta_rho, xi_u/eta_u, xi_v/eta_v,
 *    s_rho, ocean_time (unlimited); lon_rho/lat_rho ("degree_east" /
 *    "degree_north", standard names longitude/latitude), h, angle ("angle
 *    between XI-axis and EAST", radians), mask_rho ("mask on RHO-points",
 *    flag_values 0, 1, flag_meanings "land water": ROMS masks are 1 water,
 *    0 land), s_rho (ocean_s_coordinate_g2, positive "up", -1..0, surface
 *    last), u/v on their own C-grid points with lon_u/lat_u, lon_v/lat_v and
 *    _FillValue 1e37 on land;
 *  - met.no (Barents/NorKyst-style ocean forecast): dimensions time, depth,
 *    Y, X; X/Y projection coordinates in m with a polar_stereographic
 *    grid mapping, lon(Y, X)/lat(Y, X), u_eastward(time, depth, Y, X)
 *    (eastward_sea_water_velocity, _FillValue, coordinates "lon lat"),
 *    depth positive "down" from 0 m; the deeper levels are fill on the
 *    shelf as well as on land (z-levels), so only the level nearest the
 *    surface gives the coast.
 * Both grids come from the spherical polar stereographic projection
 * (Snyder 1987, eqs. 21-33 with k0 from the latitude of true scale),
 * computed here. Each has an island and a coast.
 *
 * Asserts: land exactly where the file says land, at every native cell
 * centre and inside each cell; the polarity rules (flag meanings in any
 * order, standard names land_binary_mask / sea_binary_mask, ROMS mask_rho,
 * landmask.land_value, landmask.polarity); refusals of a 0/1 mask that does
 * not say which value is land, of flags without meanings, of a depth axis
 * without a direction, of a grid without lon/lat: one line naming the
 * file, the variable and the key; and a 48 h forecast on the ROMS coast
 * with the wind toward the island and the coast leaves fewer than 0.5 % of
 * the particles on land (the native cell nearest each particle, found by
 * brute force here). */
#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "engine_case.h"
#include "io/landmask.h"
#include "io/products.h"
#include "service/check.h"
#include "service/config.h"
#include "service/forecast.h"
#include "util/log.h"

static char dir[] = "/tmp/sphice-lmodel-XXXXXX";

/* ---------------------------------------------------------------- grid */

#define R_EARTH 6371000.0
#define D2R (M_PI / 180.0)
#define PS_LON0 (-45.0)  /* straight vertical longitude from the pole */
#define PS_LATTS 70.0    /* latitude of true scale */
#define NX 100           /* rho points */
#define NY 90
#define DXKM 2.0         /* cell size, km */
#define CEN_LON 15.0     /* grid centre */
#define CEN_LAT 76.5
#define ISLAND_LON 14.6
#define ISLAND_LAT 76.45
#define ISLAND_KM 7.0
#define COAST_LON 16.3   /* land east of it */

static double ps_k0(void) { return (1 + sin(PS_LATTS * D2R)) / 2; }

static void ps_forward(double lon, double lat, double *x, double *y)
{
    double rho = 2 * R_EARTH * ps_k0() * tan(M_PI / 4 - lat * D2R / 2);
    *x = rho * sin((lon - PS_LON0) * D2R);
    *y = -rho * cos((lon - PS_LON0) * D2R);
}

static void ps_inverse(double x, double y, double *lon, double *lat)
{
    double rho = hypot(x, y);
    *lat = (M_PI / 2 - 2 * atan(rho / (2 * R_EARTH * ps_k0()))) / D2R;
    *lon = PS_LON0 + atan2(x, -y) / D2R;
    if (*lon > 180) *lon -= 360;
    if (*lon < -180) *lon += 360;
}

static double x_origin, y_origin; /* plane coordinates of rho point (0, 0), m */

/* rho point (i, j) at (x0 + i dx, y0 + j dy); u points half a cell east, v north */
static void rho_xy(double i, double j, double *x, double *y)
{
    *x = x_origin + i * DXKM * 1000;
    *y = y_origin + j * DXKM * 1000;
}

static double gc_km(double lon1, double lat1, double lon2, double lat2)
{
    double a = sin((lat2 - lat1) * D2R / 2), b = sin((lon2 - lon1) * D2R / 2);
    double h = a * a + cos(lat1 * D2R) * cos(lat2 * D2R) * b * b;
    return 2 * R_EARTH / 1000 * asin(sqrt(h));
}

/* The scene's land at a point: the island and the coast. */
static int scene_land(double lon, double lat)
{
    return lon > COAST_LON || gc_km(lon, lat, ISLAND_LON, ISLAND_LAT) < ISLAND_KM;
}

static double rlon[NY * NX], rlat[NY * NX];
static unsigned char rland[NY * NX]; /* the file's land at rho points */

static void make_grid(void)
{
    double cx, cy;
    ps_forward(CEN_LON, CEN_LAT, &cx, &cy);
    x_origin = cx - (NX - 1) / 2.0 * DXKM * 1000;
    y_origin = cy - (NY - 1) / 2.0 * DXKM * 1000;
    for (int j = 0; j < NY; j++)
        for (int i = 0; i < NX; i++) {
            double x, y;
            rho_xy(i, j, &x, &y);
            ps_inverse(x, y, &rlon[j * NX + i], &rlat[j * NX + i]);
            rland[j * NX + i] = (unsigned char)scene_land(rlon[j * NX + i], rlat[j * NX + i]);
        }
}

/* Index of the rho point nearest (lon, lat) by brute force. */
static int nearest_rho(double lon, double lat)
{
    int best = -1;
    double bd = INFINITY;
    for (int k = 0; k < NX * NY; k++) {
        double d = gc_km(lon, lat, rlon[k], rlat[k]);
        if (d < bd) {
            bd = d;
            best = k;
        }
    }
    return best;
}

static void put_text(int nc, int v, const char *att, const char *text)
{
    NCW(nc_put_att_text(nc, v, att, strlen(text), text));
}

/* ---------------------------------------------------------------- ROMS */

enum { MASK_FLAGS, MASK_BARE_RHO, MASK_OPTIONS };

/* mask_style: MASK_FLAGS (flag_values/flag_meanings "land water"),
 * MASK_BARE_RHO (mask_rho with only its long_name), MASK_OPTIONS (the
 * older option_0 = "land", option_1 = "water"). */
static void write_roms(const char *path, int mask_style)
{
    enum { NS = 4 };
    int nc, d_xr, d_er, d_xu, d_eu, d_xv, d_ev, d_s, d_t;
    NCW(nc_create(path, NC_CLOBBER | NC_NETCDF4, &nc));
    NCW(nc_def_dim(nc, "xi_rho", NX, &d_xr));
    NCW(nc_def_dim(nc, "eta_rho", NY, &d_er));
    NCW(nc_def_dim(nc, "xi_u", NX - 1, &d_xu));
    NCW(nc_def_dim(nc, "eta_u", NY, &d_eu));
    NCW(nc_def_dim(nc, "xi_v", NX, &d_xv));
    NCW(nc_def_dim(nc, "eta_v", NY - 1, &d_ev));
    NCW(nc_def_dim(nc, "s_rho", NS, &d_s));
    NCW(nc_def_dim(nc, "ocean_time", NC_UNLIMITED, &d_t));
    int r2[2] = {d_er, d_xr}, u2[2] = {d_eu, d_xu}, v2[2] = {d_ev, d_xv};
    int vlon, vlat, vlonu, vlatu, vlonv, vlatv, vh, vang, vmask, vs, vt, vu, vv, vxr, vyr;
    NCW(nc_def_var(nc, "s_rho", NC_DOUBLE, 1, &d_s, &vs));
    put_text(nc, vs, "long_name", "S-coordinate at RHO-points");
    double vmin = -1, vmax = 0;
    NCW(nc_put_att_double(nc, vs, "valid_min", NC_DOUBLE, 1, &vmin));
    NCW(nc_put_att_double(nc, vs, "valid_max", NC_DOUBLE, 1, &vmax));
    put_text(nc, vs, "positive", "up");
    put_text(nc, vs, "standard_name", "ocean_s_coordinate_g2");
    put_text(nc, vs, "formula_terms", "s: s_rho C: Cs_r eta: zeta depth: h depth_c: hc");
    NCW(nc_def_var(nc, "ocean_time", NC_DOUBLE, 1, &d_t, &vt));
    put_text(nc, vt, "long_name", "time since initialization");
    put_text(nc, vt, "units", "seconds since 1970-01-01 00:00:00");
    put_text(nc, vt, "calendar", "proleptic_gregorian");
    struct { const char *name, *lname, *units, *sname; int *dims, *id; } c2[] = {
        {"x_rho", "x-locations of RHO-points", "meter", NULL, r2, &vxr},
        {"y_rho", "y-locations of RHO-points", "meter", NULL, r2, &vyr},
        {"lon_rho", "longitude of RHO-points", "degree_east", "longitude", r2, &vlon},
        {"lat_rho", "latitude of RHO-points", "degree_north", "latitude", r2, &vlat},
        {"lon_u", "longitude of U-points", "degree_east", "longitude", u2, &vlonu},
        {"lat_u", "latitude of U-points", "degree_north", "latitude", u2, &vlatu},
        {"lon_v", "longitude of V-points", "degree_east", "longitude", v2, &vlonv},
        {"lat_v", "latitude of V-points", "degree_north", "latitude", v2, &vlatv},
        {"h", "bathymetry at RHO-points", "meter", "sea_floor_depth_below_geoid", r2, &vh},
        {"angle", "angle between XI-axis and EAST", "radians", NULL, r2, &vang}};
    for (size_t k = 0; k < sizeof c2 / sizeof c2[0]; k++) {
        NCW(nc_def_var(nc, c2[k].name, NC_DOUBLE, 2, c2[k].dims, c2[k].id));
        put_text(nc, *c2[k].id, "long_name", c2[k].lname);
        put_text(nc, *c2[k].id, "units", c2[k].units);
        if (c2[k].sname)
            put_text(nc, *c2[k].id, "standard_name", c2[k].sname);
    }
    put_text(nc, vh, "coordinates", "lon_rho lat_rho");
    put_text(nc, vang, "coordinates", "lon_rho lat_rho");
    NCW(nc_def_var(nc, "mask_rho", NC_DOUBLE, 2, r2, &vmask));
    put_text(nc, vmask, "long_name", "mask on RHO-points");
    if (mask_style == MASK_FLAGS) {
        double fv[2] = {0, 1};
        NCW(nc_put_att_double(nc, vmask, "flag_values", NC_DOUBLE, 2, fv));
        put_text(nc, vmask, "flag_meanings", "land water");
        put_text(nc, vmask, "coordinates", "lon_rho lat_rho");
    } else if (mask_style == MASK_OPTIONS) {
        put_text(nc, vmask, "option_0", "land");
        put_text(nc, vmask, "option_1", "water");
    }
    int u4[4] = {d_t, d_s, d_eu, d_xu}, v4[4] = {d_t, d_s, d_ev, d_xv};
    float fill = 1e37f;
    NCW(nc_def_var(nc, "u", NC_FLOAT, 4, u4, &vu));
    put_text(nc, vu, "long_name", "u-momentum component");
    put_text(nc, vu, "units", "meter second-1");
    put_text(nc, vu, "time", "ocean_time");
    put_text(nc, vu, "coordinates", "lon_u lat_u s_rho ocean_time");
    put_text(nc, vu, "field", "u-velocity, scalar, series");
    NCW(nc_put_att_float(nc, vu, "_FillValue", NC_FLOAT, 1, &fill));
    NCW(nc_def_var(nc, "v", NC_FLOAT, 4, v4, &vv));
    put_text(nc, vv, "long_name", "v-momentum component");
    put_text(nc, vv, "units", "meter second-1");
    put_text(nc, vv, "time", "ocean_time");
    put_text(nc, vv, "coordinates", "lon_v lat_v s_rho ocean_time");
    NCW(nc_put_att_float(nc, vv, "_FillValue", NC_FLOAT, 1, &fill));
    put_text(nc, NC_GLOBAL, "type", "ROMS/TOMS history file");
    put_text(nc, NC_GLOBAL, "Conventions", "CF-1.4, SGRID-0.3");
    NCW(nc_enddef(nc));

    double s[NS];
    for (int k = 0; k < NS; k++)
        s[k] = -1 + (k + 0.5) / NS; /* -0.875 .. -0.125 */
    NCW(nc_put_var_double(nc, vs, s));
    static double xr[NY * NX], yr[NY * NX], m[NY * NX], h[NY * NX], ang[NY * NX];
    static double lu[NY * NX], au[NY * NX], lv[NY * NX], av[NY * NX];
    for (int j = 0; j < NY; j++)
        for (int i = 0; i < NX; i++) {
            int k = j * NX + i;
            rho_xy(i, j, &xr[k], &yr[k]);
            m[k] = rland[k] ? 0 : 1;
            h[k] = rland[k] ? 10 : 200;
            /* the xi axis is the plane's x; east at (lon) is the direction
             * (cos(lon - lon0), sin(lon - lon0)) in the plane */
            ang[k] = -(rlon[k] - PS_LON0) * D2R;
        }
    NCW(nc_put_var_double(nc, vxr, xr));
    NCW(nc_put_var_double(nc, vyr, yr));
    NCW(nc_put_var_double(nc, vlon, rlon));
    NCW(nc_put_var_double(nc, vlat, rlat));
    NCW(nc_put_var_double(nc, vmask, m));
    NCW(nc_put_var_double(nc, vh, h));
    NCW(nc_put_var_double(nc, vang, ang));
    for (int j = 0; j < NY; j++)
        for (int i = 0; i < NX - 1; i++) {
            double x, y;
            rho_xy(i + 0.5, j, &x, &y);
            ps_inverse(x, y, &lu[j * (NX - 1) + i], &au[j * (NX - 1) + i]);
        }
    for (int j = 0; j < NY - 1; j++)
        for (int i = 0; i < NX; i++) {
            double x, y;
            rho_xy(i, j + 0.5, &x, &y);
            ps_inverse(x, y, &lv[j * NX + i], &av[j * NX + i]);
        }
    NCW(nc_put_var_double(nc, vlonu, lu));
    NCW(nc_put_var_double(nc, vlatu, au));
    NCW(nc_put_var_double(nc, vlonv, lv));
    NCW(nc_put_var_double(nc, vlatv, av));
    /* currents: 0.05 m/s along xi on water; land (ROMS: a u point is
     * water where both rho neighbours are) is fill */
    static float u[NS * NY * (NX - 1)], v[NS * (NY - 1) * NX];
    for (int k = 0; k < NS; k++) {
        for (int j = 0; j < NY; j++)
            for (int i = 0; i < NX - 1; i++)
                u[(k * NY + j) * (NX - 1) + i] =
                    rland[j * NX + i] || rland[j * NX + i + 1] ? fill : 0.05f;
        for (int j = 0; j < NY - 1; j++)
            for (int i = 0; i < NX; i++)
                v[(k * (NY - 1) + j) * NX + i] = rland[j * NX + i] || rland[(j + 1) * NX + i] ? fill : 0.0f;
    }
    size_t st[4] = {0, 0, 0, 0}, cu[4] = {1, NS, NY, NX - 1}, cv[4] = {1, NS, NY - 1, NX};
    double t0 = EC_CYCLE;
    size_t one = 1, zero = 0;
    NCW(nc_put_vara_double(nc, vt, &zero, &one, &t0));
    NCW(nc_put_vara_float(nc, vu, st, cu, u));
    NCW(nc_put_vara_float(nc, vv, st, cv, v));
    NCW(nc_close(nc));
}

/* ------------------------------------------------------------- met.no */

#define MNX 80
#define MNY 70
#define MDX 2500.0 /* m */
#define MNZ 4
static const double mdepth[MNZ] = {0, 3, 10, 25};
static double mlon[MNY * MNX], mlat[MNY * MNX], mx0, my0;
static unsigned char mland[MNY * MNX]; /* surface fill */

/* Deeper than 5 m, the shallow shelf next to the coast is fill too. */
static int metno_fill(double lon, double lat, int level)
{
    if (scene_land(lon, lat))
        return 1;
    return mdepth[level] > 5 && lon > COAST_LON - 0.25;
}

enum { MET_PLAIN, MET_SEA_MASK, MET_LAND_MASK, MET_BARE_MASK, MET_NO_POSITIVE,
       MET_FLAGS_NO_MEANINGS, MET_SEA_LAND, MET_THREE_FLAGS, MET_NO_LONLAT };

/* style: what else the file has (see the enum). */
static void write_metno(const char *path, int style)
{
    int nc, dx, dy, dz, dt, vx, vy, vz, vt, vlon, vlat, vu, vgm, vm = -1;
    NCW(nc_create(path, NC_CLOBBER | NC_NETCDF4, &nc));
    NCW(nc_def_dim(nc, "time", NC_UNLIMITED, &dt));
    NCW(nc_def_dim(nc, "depth", MNZ, &dz));
    NCW(nc_def_dim(nc, "Y", MNY, &dy));
    NCW(nc_def_dim(nc, "X", MNX, &dx));
    NCW(nc_def_var(nc, "time", NC_DOUBLE, 1, &dt, &vt));
    put_text(nc, vt, "standard_name", "time");
    put_text(nc, vt, "units", "seconds since 1970-01-01 00:00:00");
    NCW(nc_def_var(nc, "depth", NC_DOUBLE, 1, &dz, &vz));
    put_text(nc, vz, "units", "m");
    if (style != MET_NO_POSITIVE) {
        put_text(nc, vz, "standard_name", "depth");
        put_text(nc, vz, "positive", "down");
    }
    NCW(nc_def_var(nc, "X", NC_DOUBLE, 1, &dx, &vx));
    put_text(nc, vx, "standard_name", "projection_x_coordinate");
    put_text(nc, vx, "units", "m");
    NCW(nc_def_var(nc, "Y", NC_DOUBLE, 1, &dy, &vy));
    put_text(nc, vy, "standard_name", "projection_y_coordinate");
    put_text(nc, vy, "units", "m");
    NCW(nc_def_var(nc, "projection_stere", NC_INT, 0, NULL, &vgm));
    put_text(nc, vgm, "grid_mapping_name", "polar_stereographic");
    double a = PS_LON0, b = 90, c = PS_LATTS, r = R_EARTH;
    NCW(nc_put_att_double(nc, vgm, "straight_vertical_longitude_from_pole", NC_DOUBLE, 1, &a));
    NCW(nc_put_att_double(nc, vgm, "latitude_of_projection_origin", NC_DOUBLE, 1, &b));
    NCW(nc_put_att_double(nc, vgm, "standard_parallel", NC_DOUBLE, 1, &c));
    NCW(nc_put_att_double(nc, vgm, "earth_radius", NC_DOUBLE, 1, &r));
    int d2[2] = {dy, dx}, d4[4] = {dt, dz, dy, dx};
    if (style != MET_NO_LONLAT) {
        NCW(nc_def_var(nc, "lon", NC_DOUBLE, 2, d2, &vlon));
        put_text(nc, vlon, "standard_name", "longitude");
        put_text(nc, vlon, "units", "degrees_east");
        NCW(nc_def_var(nc, "lat", NC_DOUBLE, 2, d2, &vlat));
        put_text(nc, vlat, "standard_name", "latitude");
        put_text(nc, vlat, "units", "degrees_north");
    }
    float fill = 1e37f;
    NCW(nc_def_var(nc, "u_eastward", NC_FLOAT, 4, d4, &vu));
    put_text(nc, vu, "standard_name", "eastward_sea_water_velocity");
    put_text(nc, vu, "units", "m s-1");
    put_text(nc, vu, "grid_mapping", "projection_stere");
    if (style != MET_NO_LONLAT)
        put_text(nc, vu, "coordinates", "lon lat");
    NCW(nc_put_att_float(nc, vu, "_FillValue", NC_FLOAT, 1, &fill));
    if (style == MET_SEA_MASK || style == MET_LAND_MASK || style == MET_BARE_MASK ||
        style == MET_FLAGS_NO_MEANINGS || style == MET_SEA_LAND || style == MET_THREE_FLAGS) {
        NCW(nc_def_var(nc, "mask", NC_BYTE, 2, d2, &vm));
        put_text(nc, vm, "coordinates", "lon lat");
        put_text(nc, vm, "grid_mapping", "projection_stere");
        if (style == MET_SEA_MASK)
            put_text(nc, vm, "standard_name", "sea_binary_mask");
        if (style == MET_LAND_MASK)
            put_text(nc, vm, "standard_name", "land_binary_mask");
        if (style == MET_FLAGS_NO_MEANINGS || style == MET_SEA_LAND || style == MET_THREE_FLAGS) {
            signed char fv[3] = {0, 1, 2};
            NCW(nc_put_att_schar(nc, vm, "flag_values", NC_BYTE, style == MET_THREE_FLAGS ? 3 : 2, fv));
            if (style == MET_SEA_LAND)
                put_text(nc, vm, "flag_meanings", "sea land");
            if (style == MET_THREE_FLAGS)
                put_text(nc, vm, "flag_meanings", "ocean land lake");
        }
    }
    NCW(nc_enddef(nc));
    double xs[MNX], ys[MNY];
    for (int i = 0; i < MNX; i++)
        xs[i] = mx0 + i * MDX;
    for (int j = 0; j < MNY; j++)
        ys[j] = my0 + j * MDX;
    NCW(nc_put_var_double(nc, vx, xs));
    NCW(nc_put_var_double(nc, vy, ys));
    NCW(nc_put_var_double(nc, vz, mdepth));
    if (style != MET_NO_LONLAT) {
        NCW(nc_put_var_double(nc, vlon, mlon));
        NCW(nc_put_var_double(nc, vlat, mlat));
    }
    static float u[MNZ * MNY * MNX];
    for (int k = 0; k < MNZ; k++)
        for (int q = 0; q < MNY * MNX; q++)
            u[k * MNY * MNX + q] = metno_fill(mlon[q], mlat[q], k) ? fill : 0.1f;
    size_t st[4] = {0, 0, 0, 0}, cn[4] = {1, MNZ, MNY, MNX}, zero = 0, one = 1;
    double t0 = EC_CYCLE;
    NCW(nc_put_vara_double(nc, vt, &zero, &one, &t0));
    NCW(nc_put_vara_float(nc, vu, st, cn, u));
    if (vm >= 0) {
        static signed char m[MNY * MNX];
        for (int q = 0; q < MNY * MNX; q++) {
            int land = mland[q];
            switch (style) {
            case MET_SEA_MASK: m[q] = (signed char)!land; break;        /* 1 = sea */
            case MET_SEA_LAND: m[q] = (signed char)land; break;         /* 0 sea, 1 land */
            case MET_THREE_FLAGS:                                       /* 0 ocean, 1 land, 2 lake */
                m[q] = (signed char)(land ? (mlat[q] > CEN_LAT + 0.2 ? 2 : 1) : 0);
                break;
            default: m[q] = (signed char)land; break;                   /* 1 = land */
            }
        }
        NCW(nc_put_var_schar(nc, vm, m));
    }
    NCW(nc_close(nc));
}

static void make_metno_grid(void)
{
    double cx, cy;
    ps_forward(CEN_LON, CEN_LAT, &cx, &cy);
    mx0 = cx - (MNX - 1) / 2.0 * MDX;
    my0 = cy - (MNY - 1) / 2.0 * MDX;
    for (int j = 0; j < MNY; j++)
        for (int i = 0; i < MNX; i++) {
            int q = j * MNX + i;
            ps_inverse(mx0 + i * MDX, my0 + j * MDX, &mlon[q], &mlat[q]);
            mland[q] = (unsigned char)scene_land(mlon[q], mlat[q]);
        }
}

/* ------------------------------------------------------------ checks */

/* Land exactly at every native centre, and at points inside each cell
 * (a third of the way to each neighbour). */
static void check_native(const landmask *m, const double *lon, const double *lat,
                         const unsigned char *land, int nx, int ny, const char *what)
{
    size_t bad = 0, bad_inside = 0, nl = 0;
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++) {
            int k = j * nx + i;
            nl += land[k];
            if (landmask_is_land(m, lon[k], lat[k]) != land[k])
                bad++;
            const int di[4] = {1, -1, 0, 0}, dj[4] = {0, 0, 1, -1};
            for (int q = 0; q < 4; q++) {
                int ii = i + di[q], jj = j + dj[q];
                if (ii < 0 || jj < 0 || ii >= nx || jj >= ny)
                    continue;
                int n = jj * nx + ii;
                double plon = lon[k] + (lon[n] - lon[k]) / 3, plat = lat[k] + (lat[n] - lat[k]) / 3;
                if (landmask_is_land(m, plon, plat) != land[k])
                    bad_inside++;
            }
        }
    CHECK(nl > 0 && nl < (size_t)nx * ny, "%s: the scene has land and water (%zu land cells)", what, nl);
    CHECK(bad == 0, "%s: land at every native centre as the file says (%zu wrong of %d)", what, bad,
          nx * ny);
    CHECK(bad_inside == 0, "%s: land inside every native cell as the file says (%zu wrong)", what,
          bad_inside);
    printf("  %s: %zu of %d cells land, all centres and cell interiors right\n", what, nl, nx * ny);
}

static void check_refused(landmask *m, const sph_error *err, const char *path, const char *var,
                          const char *key, const char *what)
{
    CHECK(m == NULL, "%s: refused", what);
    landmask_free(m);
    CHECK(strstr(err->msg, path) != NULL, "%s: names the file: %s", what, err->msg);
    CHECK(strstr(err->msg, var) != NULL, "%s: names the variable %s: %s", what, var, err->msg);
    CHECK(strstr(err->msg, key) != NULL, "%s: names the key %s: %s", what, key, err->msg);
    CHECK(strchr(err->msg, '\n') == NULL, "%s: one line", what);
    printf("  %s -> %s\n", what, err->msg);
}

static landmask *read_opts(const char *path, const char *var, landmask_from from,
                           landmask_polarity pol, double land_value, int fallback, sph_error *err)
{
    landmask_read_opts o = {var, from, pol, land_value, fallback, NULL, NULL, 0, 0};
    sph_error_clear(err);
    return landmask_read_model(path, &o, err);
}

/* Reads with these options and checks the result against truth. */
static void expect_native(const char *path, const char *var, landmask_from from, landmask_polarity pol,
                          double land_value, const double *lon, const double *lat,
                          const unsigned char *truth, int nx, int ny, const char *what)
{
    sph_error err;
    landmask *m = read_opts(path, var, from, pol, land_value, 1, &err);
    CHECK(m != NULL, "%s: %s", what, err.msg);
    if (m)
        check_native(m, lon, lat, truth, nx, ny, what);
    landmask_free(m);
}

/* ------------------------------------------------------------ engine */

static double atm_fn(int which, double lon, double lat, size_t k)
{
    (void)lon; (void)lat; (void)k;
    return which == 0 ? 10.0 : which == 1 ? 0.0 : 263.15; /* wind from the west, toward the land */
}

/* The default max_neighbours (96): the island of the rotated native grid
 * is a stair-step disc smaller than the kernel support, whose mirror
 * ghosts pile up (the run used to stop at once, "particle clumping",
 * until max_neighbours was raised to 160); the crowded ghosts are merged
 * now (core/coast.c, test_coast_ghosts). */
static struct sph_config *engine_config(const char *landmask_json)
{
    char text[8192];
    snprintf(text, sizeof text,
             "{ \"log_level\": \"warn\",\n"
             "  \"domain\": {\"name\": \"arctic\", \"lon_min\": 13.0, \"lon_max\": 17.0,"
             " \"lat_min\": 76.1, \"lat_max\": 76.9},\n"
             "  \"model\": {\"dt\": 300, \"thermo\": {\"dt\": 1800}},\n"
             "  \"forcing\": [{\"name\": \"atmosphere\", \"kind\": \"atmosphere\","
             " \"urls\": \"%s/atm.nc\", \"required\": [\"wind\", \"tair\"]}],\n"
             "  \"initial\": {\"path\": \"%s/ice.nc\", \"spacing\": 0.03, \"threshold\": 0.15},\n"
             "  \"landmask\": %s,\n"
             "  \"output\": {\"dir\": \"%s/out\", \"interval_hours\": 12,"
             " \"grid\": {\"lon0\": 13.0, \"lat0\": 76.1, \"dlon\": 0.04, \"dlat\": 0.01,"
             " \"nlon\": 101, \"nlat\": 81},"
             " \"edge_reference\": {\"lon\": 15.0, \"lat\": 76.9, \"name\": \"north\"}},\n"
             "  \"stations\": [{\"name\": \"centre\", \"lon\": 15.0, \"lat\": 76.5}],\n"
             "  \"schedule\": {\"every_hours\": 24, \"forecast_hours\": 48,"
             " \"late_data\": {\"wait_minutes\": 0}},\n"
             "  \"status\": {\"enabled\": false},\n"
             "  \"paths\": {\"state_dir\": \"%s/state\", \"cache_dir\": \"%s/cache\"}\n"
             "}\n",
             dir, dir, landmask_json, dir, dir, dir);
    struct sph_config *cfg = NULL;
    sph_error err;
    sph_error_clear(&err);
    int rc = sph_config_parse(text, "test", &cfg, &err);
    CHECK(rc == SPH_OK, "config: %s", err.msg);
    return rc == SPH_OK ? cfg : NULL;
}

static void engine_on_the_coast(const char *roms)
{
    char p[2048], lm[1200];
    snprintf(p, sizeof p, "%s/atm.nc", dir);
    ec_write_atm_at(p, 48, 11.5, 75.0, 29, 13, atm_fn);
    static char atm[1024];
    snprintf(atm, sizeof atm, "%s/atm.nc", dir);
    snprintf(p, sizeof p, "%s/ice.nc", dir);
    /* ice: A = 0.9, h = 0.5 m on a 0.02 x 0.01 deg raster, 13.5-16.0 E, 76.2-76.8 N */
    ec_write_ice_at(p, 126, 61, 13.5, 76.2, 0.02, 0.01, 0.9, 0.5, -1);
    snprintf(lm, sizeof lm, "{\"source\": \"netcdf\", \"path\": \"%s\"}", roms);
    struct sph_config *cfg = engine_config(lm);
    if (!cfg)
        return;
    const char *atm_files[2] = {atm, NULL};
    char stage[1024];
    snprintf(stage, sizeof stage, "%s/stage", dir);
    forecast_request req;
    memset(&req, 0, sizeof req);
    req.cycle_time = EC_CYCLE;
    req.hours = 48;
    req.stage_dir = stage;
    req.forcing_files[0] = atm_files;
    static const char *sums[] = {"atm.nc 0000", NULL};
    req.forcing_sha256[0] = sums[0];
    forecast_progress prog;
    memset((void *)&prog, 0, sizeof prog);
    forecast_result res;
    sph_error err;
    sph_error_clear(&err);
    int rc = forecast_run(cfg, &req, &prog, NULL, &res, &err);
    CHECK(rc == SPH_OK, "48 h forecast on the ROMS coast: %s", err.msg);
    if (rc == SPH_OK) {
        snprintf(p, sizeof p, "%s/sphice_particles.nc", stage);
        prod_particles p0, p48;
        memset(&p0, 0, sizeof p0);
        memset(&p48, 0, sizeof p48);
        int r0 = products_read_particles(p, EC_CYCLE, &p0, &err);
        int r48 = products_read_particles(p, EC_CYCLE + 48 * 3600.0, &p48, &err);
        CHECK(r0 == SPH_OK && r48 == SPH_OK, "read particles: %s", err.msg);
        if (r0 == SPH_OK && r48 == SPH_OK) {
            size_t land0 = 0, land48 = 0, east = 0;
            double mean_dlon = 0;
            for (size_t k = 0; k < p0.n; k++)
                land0 += rland[nearest_rho(p0.lon[k], p0.lat[k])];
            for (size_t k = 0; k < p48.n; k++) {
                land48 += rland[nearest_rho(p48.lon[k], p48.lat[k])];
                east += p48.lon[k] > COAST_LON - 0.15;
            }
            for (size_t k = 0; k < p48.n; k++)
                for (size_t q = 0; q < p0.n; q++)
                    if (p0.id[q] == p48.id[k]) {
                        mean_dlon += (p48.lon[k] - p0.lon[q]) / (double)p48.n;
                        break;
                    }
            printf("  48 h on the coast: %zu particles, %zu on land at 0 h, %zu on land at 48 h "
                   "(%.2f %%), %zu within 0.15 deg of the coast, mean eastward drift %.3f deg\n",
                   p48.n, land0, land48, 100.0 * (double)land48 / (double)(p48.n ? p48.n : 1), east,
                   mean_dlon);
            CHECK(p0.n > 300, "enough particles seeded (%zu)", p0.n);
            CHECK(land0 == 0, "no particle seeded on land (%zu)", land0);
            /* the wind drove the ice onto the coast: the case tests the coast */
            CHECK(east > p48.n / 20 && mean_dlon > 0.1, "the ice reached the coast (%zu, %.3f deg)",
                  east, mean_dlon);
            CHECK((double)land48 < 0.005 * (double)p48.n, "fewer than 0.5 %% on land after 48 h "
                  "(%zu of %zu)", land48, p48.n);
        }
        prod_particles_free(&p0);
        prod_particles_free(&p48);
    }
    sph_config_free(cfg);
}

/* ------------------------------------------------------------ main */

int main(int argc, char **argv)
{
    (void)argc;
    ec_passive_openmp(argv);
    sph_log_level = LOG_LVL_WARN;
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    make_grid();
    make_metno_grid();
    sph_error err;
    char roms[1024], path[1024];

    /* ROMS: mask_rho with flag meanings, then bare (ROMS convention), then option_N */
    snprintf(roms, sizeof roms, "%s/roms_his.nc", dir);
    write_roms(roms, MASK_FLAGS);
    landmask *m = read_opts(roms, NULL, LANDMASK_FROM_AUTO, LANDMASK_POL_AUTO, NAN, 1, &err);
    CHECK(m != NULL, "ROMS mask_rho: %s", err.msg);
    if (m) {
        CHECK(landmask_is_native(m), "ROMS: kept on its native grid");
        CHECK_CLOSE(landmask_native_spacing_m(m), DXKM * 1000 / (ps_k0() * 2 /
                    (1 + sin(CEN_LAT * D2R))), 0.02, 0, "native spacing (the projection's scale)");
        check_native(m, rlon, rlat, rland, NX, NY, "ROMS mask_rho (flag_meanings land water)");
        CHECK(landmask_is_land(m, 40.0, 76.5) == -1 && landmask_is_land(m, CEN_LON, 70.0) == -1,
              "outside the native grid is -1");
        landmask_free(m);
    }
    snprintf(path, sizeof path, "%s/roms_bare.nc", dir);
    write_roms(path, MASK_BARE_RHO);
    expect_native(path, NULL, LANDMASK_FROM_AUTO, LANDMASK_POL_AUTO, NAN, rlon, rlat, rland,
                  NX, NY, "ROMS mask_rho (ROMS convention 0 land)");
    snprintf(path, sizeof path, "%s/roms_opt.nc", dir);
    write_roms(path, MASK_OPTIONS);
    expect_native(path, "mask_rho", LANDMASK_FROM_AUTO, LANDMASK_POL_AUTO, NAN, rlon, rlat, rland,
                  NX, NY, "ROMS mask_rho (option_0 land, option_1 water)");

    /* ROMS: the fill pattern of u on its own u points (surface level) */
    m = read_opts(roms, "u", LANDMASK_FROM_FILL, LANDMASK_POL_AUTO, NAN, 1, &err);
    CHECK(m != NULL, "ROMS u fill: %s", err.msg);
    if (m) {
        static double lu[NY * (NX - 1)], au[NY * (NX - 1)];
        static unsigned char uland[NY * (NX - 1)];
        for (int j = 0; j < NY; j++)
            for (int i = 0; i < NX - 1; i++) {
                double x, y;
                int k = j * (NX - 1) + i;
                rho_xy(i + 0.5, j, &x, &y);
                ps_inverse(x, y, &lu[k], &au[k]);
                uland[k] = rland[j * NX + i] || rland[j * NX + i + 1];
            }
        check_native(m, lu, au, uland, NX - 1, NY, "ROMS u _FillValue on u points");
        landmask_free(m);
    }

    /* met.no: fill of the current at the level nearest the surface */
    snprintf(path, sizeof path, "%s/metno.nc", dir);
    write_metno(path, MET_PLAIN);
    expect_native(path, NULL, LANDMASK_FROM_AUTO, LANDMASK_POL_AUTO, NAN, mlon, mlat, mland,
                  MNX, MNY, "met.no u_eastward fill at 0 m");
    /* a mask file only (source netcdf): no mask variable is refused */
    m = read_opts(path, NULL, LANDMASK_FROM_MASK, LANDMASK_POL_AUTO, NAN, 0, &err);
    CHECK(m == NULL && strstr(err.msg, path) && strstr(err.msg, "landmask.variable"),
          "no mask variable (mask only): %s", err.msg);
    landmask_free(m);

    /* standard names, flag meanings in any order */
    static const struct { int style; const char *what; } ok[] = {
        {MET_SEA_MASK, "sea_binary_mask (1 = sea)"},
        {MET_LAND_MASK, "land_binary_mask (1 = land)"},
        {MET_SEA_LAND, "flag_meanings \"sea land\""},
        {MET_THREE_FLAGS, "flag_meanings \"ocean land lake\""}};
    for (size_t k = 0; k < sizeof ok / sizeof ok[0]; k++) {
        snprintf(path, sizeof path, "%s/metno_%zu.nc", dir, k);
        write_metno(path, ok[k].style);
        expect_native(path, NULL, LANDMASK_FROM_AUTO, LANDMASK_POL_AUTO, NAN, mlon, mlat, mland, MNX,
                      MNY, ok[k].what);
    }

    /* a 0/1 mask that does not say which value is land: refused, unless a key says */
    snprintf(path, sizeof path, "%s/metno_bare.nc", dir);
    write_metno(path, MET_BARE_MASK);
    m = read_opts(path, NULL, LANDMASK_FROM_AUTO, LANDMASK_POL_AUTO, NAN, 1, &err);
    check_refused(m, &err, path, "mask", "landmask.polarity", "0/1 mask without meanings");
    CHECK(strstr(err.msg, "landmask.land_value") != NULL, "names landmask.land_value too");
    m = read_opts(path, "mask", LANDMASK_FROM_AUTO, LANDMASK_POL_AUTO, NAN, 1, &err);
    check_refused(m, &err, path, "mask", "landmask.polarity", "named 0/1 mask without meanings");
    expect_native(path, "mask", LANDMASK_FROM_AUTO, LANDMASK_POL_LAND_IS_1, NAN, mlon, mlat, mland,
                  MNX, MNY, "landmask.polarity land_is_1");
    expect_native(path, "mask", LANDMASK_FROM_AUTO, LANDMASK_POL_AUTO, 1.0, mlon, mlat, mland,
                  MNX, MNY, "landmask.land_value 1");
    m = read_opts(path, "mask", LANDMASK_FROM_AUTO, LANDMASK_POL_WATER_IS_1, NAN, 1, &err);
    CHECK(m != NULL, "polarity water_is_1: %s", err.msg);
    if (m) {
        static unsigned char inv[MNY * MNX];
        for (int q = 0; q < MNX * MNY; q++)
            inv[q] = !mland[q];
        check_native(m, mlon, mlat, inv, MNX, MNY, "landmask.polarity water_is_1 (inverted file)");
    }
    landmask_free(m);
    m = read_opts(path, "mask", LANDMASK_FROM_AUTO, LANDMASK_POL_AUTO, 0.0, 1, &err);
    CHECK(m != NULL && landmask_is_land(m, mlon[0], mlat[0]) == !mland[0],
          "land_value 0 inverts: %s", err.msg);
    landmask_free(m);

    snprintf(path, sizeof path, "%s/metno_nomean.nc", dir);
    write_metno(path, MET_FLAGS_NO_MEANINGS);
    m = read_opts(path, NULL, LANDMASK_FROM_AUTO, LANDMASK_POL_AUTO, NAN, 1, &err);
    check_refused(m, &err, path, "mask", "landmask.land_value", "flag_values without flag_meanings");

    snprintf(path, sizeof path, "%s/metno_nopos.nc", dir);
    write_metno(path, MET_NO_POSITIVE);
    m = read_opts(path, NULL, LANDMASK_FROM_AUTO, LANDMASK_POL_AUTO, NAN, 1, &err);
    check_refused(m, &err, path, "u_eastward", "landmask.variable", "depth without a direction");
    CHECK(strstr(err.msg, "depth") != NULL, "names the dimension: %s", err.msg);

    snprintf(path, sizeof path, "%s/metno_nolonlat.nc", dir);
    write_metno(path, MET_NO_LONLAT);
    m = read_opts(path, NULL, LANDMASK_FROM_AUTO, LANDMASK_POL_AUTO, NAN, 1, &err);
    check_refused(m, &err, path, "u_eastward", "landmask.variable", "no lon/lat for the grid");

    m = read_opts(roms, "nope", LANDMASK_FROM_AUTO, LANDMASK_POL_AUTO, NAN, 1, &err);
    check_refused(m, &err, roms, "nope", "landmask.variable", "a missing variable");

    /* the service's reading: source forcing, the keys */
    {
        char text[4096];
        snprintf(path, sizeof path, "%s/metno_bare.nc", dir);
        static const struct { const char *keys; int ok; const char *needle; } cases[] = {
            {"\"source\": \"forcing\"", 0, "landmask.polarity"},
            {"\"source\": \"forcing\", \"polarity\": \"land_is_1\"", 1, NULL},
            {"\"source\": \"forcing\", \"land_value\": \"1\"", 1, NULL},
            {"\"source\": \"forcing\", \"land_value\": \"one\"", 0, "landmask.land_value"},
            {"\"source\": \"forcing\", \"from\": \"fill\", \"variable\": \"u_eastward\"", 1, NULL},
            {"\"source\": \"netcdf\", \"from\": \"fill\"", 1, NULL}};
        for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
            snprintf(text, sizeof text,
                     "{\"domain\": {\"name\": \"a\", \"lon_min\": 13, \"lon_max\": 17, \"lat_min\": 76.1,"
                     " \"lat_max\": 76.9}, \"forcing\": [{\"name\": \"atmosphere\", \"kind\":"
                     " \"atmosphere\", \"urls\": \"%s/atm.nc\"}], \"initial\": {\"path\": \"x\"},"
                     " \"landmask\": {%s, \"path\": \"%s\"}, \"output\": {\"dir\": \"%s/o\","
                     " \"grid\": {\"lon0\": 13, \"lat0\": 76, \"dlon\": 0.1, \"dlat\": 0.1, \"nlon\": 10,"
                     " \"nlat\": 10}}, \"status\": {\"enabled\": false}, \"paths\": {\"state_dir\":"
                     " \"%s/s\", \"cache_dir\": \"%s/c\"}}",
                     dir, cases[k].keys, path, dir, dir, dir);
            struct sph_config *cfg = NULL;
            sph_error_clear(&err);
            int rc = sph_config_parse(text, "test", &cfg, &err);
            CHECK(rc == SPH_OK, "config %zu: %s", k, err.msg);
            if (rc)
                continue;
            landmask *lm = NULL;
            char why[512] = "";
            sph_error_clear(&err);
            rc = forecast_landmask_read(cfg, path, &lm, why, sizeof why, &err);
            if (cases[k].ok) {
                CHECK(rc == SPH_OK && lm, "landmask {%s}: %s", cases[k].keys, err.msg);
                if (lm)
                    check_native(lm, mlon, mlat, mland, MNX, MNY, cases[k].keys);
            } else {
                CHECK(rc != SPH_OK && !lm && strstr(err.msg, cases[k].needle) &&
                          !strchr(err.msg, '\n'),
                      "landmask {%s} refused naming %s: %s", cases[k].keys, cases[k].needle, err.msg);
                printf("  {%s} -> %s\n", cases[k].keys, err.msg);
            }
            landmask_free(lm);
            /* sphice check reads it the same way and lists the problem */
            if (k <= 1) {
                char *buf = NULL;
                size_t len = 0;
                FILE *f = open_memstream(&buf, &len);
                int crc = service_check(cfg, EC_CYCLE, 0, f);
                fclose(f);
                if (k == 0)
                    CHECK(crc != 0 && buf && strstr(buf, "PROBLEM") && strstr(buf, "landmask.polarity") &&
                              strstr(buf, path),
                          "check lists the refused mask: %s", buf ? buf : "");
                else
                    CHECK(buf && strstr(buf, "landmask ") && strstr(buf, "1616 of 5600 cells land on its "
                                                                         "native grid"),
                          "check describes the mask: %s", buf ? buf : "");
                free(buf);
            }
            sph_config_free(cfg);
        }
    }

    /* 48 h forecast on the ROMS coast */
    engine_on_the_coast(roms);

    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    CHECK(system(cmd) == 0, "cleanup");
    return check_summary("test_landmask_model");
}
