/* Ocean grids given by their CF grid mapping alone (io/ocean_grid.h;
 * issue 20 item 4, the ocean-fluxes file on the ocean's grid): 1-D
 * coordinates and a grid_mapping, no 2-D latitude/longitude.
 *  - polar stereographic north on WGS84 as NSIDC defines EPSG:3413
 *    (straight_vertical_longitude_from_pole -45, standard_parallel 70;
 *    CF appendix F attribute names), 10 km cells over the Barents Sea
 *    (40 E, 75 N), x/y in metres and again in km, the mapping by its CF
 *    parameters, by its crs_wkt alone (PROJ's WKT2 of EPSG:3413) and by
 *    its epsg_code alone: the centres and
 *    corners equal Snyder's (1987) inverse formulas (eq. 21-39, 7-9)
 *    within 1e-9 degree; the areas equal dx dy / k^2 with Snyder's point
 *    scale k (eq. 21-32; conformal, so the areal scale is k^2) within
 *    1e-8; land where zos is fill;
 *  - a CF rotated pole (the conventions' example: grid_north_pole_latitude
 *    39.25, grid_north_pole_longitude -162) with 1-D rlon/rlat: the
 *    centres equal PROJ's general oblique transformation (ob_tran, with
 *    o_lat_p = 39.25, o_lon_p = 0, lon_0 = 180 - 162) within 1e-9 degree,
 *    and so are the corners; the areas R^2 dlambda (sin phi_n - sin phi_s)
 *    of the rotated sphere (a rotation keeps areas) equal the polygon of
 *    PROJ's corners joined by great circles within 1e-4 (the rotated
 *    parallels are small circles);
 *  - refused in one line naming the file, the variable and the key: a
 *    mapping without the figure of the earth, projection coordinates in
 *    degrees, a rotated pole without its pole. */
#include <dirent.h>
#include <math.h>
#include <netcdf.h>
#include <proj.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "tmpdir.h"
#include "io/ocean_grid.h"
#include "raster_provider.h"

enum { NX = 8, NY = 6 };
static char dir[] = "/tmp/sphice-ogmap-XXXXXX";
static const double WA = 6378137.0, WRF = 298.257223563, CELL = 10000.0;
static const char *const KEY = "output.ocean_fluxes_grid";

static double wgs_b(void) { return WA * (1.0 - 1.0 / WRF); }

/* The centre of the grid: (40 E, 75 N) in EPSG:3413 metres. */
static void ps_centre(double *xc, double *yc)
{
    double k;
    rp_ps_forward(WA, wgs_b(), 70.0, -45.0, 40.0, 75.0, xc, yc, &k);
}

/* A polar-stereographic file: x, y (units `unit`, scale metres per unit),
 * zos(time, y, x) with fill east of i = 5; what: 0 complete, 1 no
 * ellipsoid, 2 x/y in degrees. */
static void ps_file(const char *path, const char *unit, double scale, int what)
{
    int nc, dx, dy, dt, vx, vy, vc, vz, vt;
    nc_create(path, NC_NETCDF4 | NC_CLOBBER, &nc);
    nc_def_dim(nc, "time", NC_UNLIMITED, &dt);
    nc_def_dim(nc, "y", NY, &dy);
    nc_def_dim(nc, "x", NX, &dx);
    nc_def_var(nc, "time", NC_DOUBLE, 1, &dt, &vt);
    rp_text(nc, vt, "units", "hours since 2026-01-01 00:00:00");
    nc_def_var(nc, "x", NC_DOUBLE, 1, &dx, &vx);
    rp_text(nc, vx, "standard_name", "projection_x_coordinate");
    rp_text(nc, vx, "units", what == 2 ? "degrees" : unit);
    nc_def_var(nc, "y", NC_DOUBLE, 1, &dy, &vy);
    rp_text(nc, vy, "standard_name", "projection_y_coordinate");
    rp_text(nc, vy, "units", what == 2 ? "degrees" : unit);
    nc_def_var(nc, "crs", NC_INT, 0, NULL, &vc);
    rp_text(nc, vc, "grid_mapping_name", "polar_stereographic");
    if (what == 3 || what == 4) { /* the CRS by itself: its WKT (as PROJ writes EPSG:3413's), or its code */
        if (what == 4) {
            rp_text(nc, vc, "epsg_code", "EPSG:3413");
        } else {
            PJ_CONTEXT *ctx = proj_context_create();
            PJ *P = proj_create(ctx, "EPSG:3413");
            const char *wkt = P ? proj_as_wkt(ctx, P, PJ_WKT2_2019, NULL) : NULL;
            CHECK(wkt != NULL, "PROJ's WKT of EPSG:3413");
            if (wkt)
                rp_text(nc, vc, "crs_wkt", wkt);
            proj_destroy(P);
            proj_context_destroy(ctx);
        }
    }
    if (what < 3) {
        rp_num(nc, vc, "straight_vertical_longitude_from_pole", -45.0);
        rp_num(nc, vc, "latitude_of_projection_origin", 90.0);
        rp_num(nc, vc, "standard_parallel", 70.0);
        rp_num(nc, vc, "false_easting", 0.0);
        rp_num(nc, vc, "false_northing", 0.0);
    }
    if (what != 1 && what < 3) {
        rp_num(nc, vc, "semi_major_axis", WA);
        rp_num(nc, vc, "inverse_flattening", WRF);
    }
    int d3[3] = {dt, dy, dx};
    nc_def_var(nc, "zos", NC_FLOAT, 3, d3, &vz);
    rp_text(nc, vz, "standard_name", "sea_surface_height_above_geoid");
    rp_text(nc, vz, "units", "m");
    rp_text(nc, vz, "grid_mapping", "crs");
    float fv = 1e20f;
    nc_put_att_float(nc, vz, "_FillValue", NC_FLOAT, 1, &fv);
    nc_enddef(nc);
    double xc, yc, x[NX], y[NY], t = 0.0;
    ps_centre(&xc, &yc);
    for (int i = 0; i < NX; i++)
        x[i] = (xc + (i - 3.5) * CELL) / scale;
    for (int j = 0; j < NY; j++)
        y[j] = (yc + (j - 2.5) * CELL) / scale;
    float z[NY * NX];
    for (int c = 0; c < NX * NY; c++)
        z[c] = c % NX >= 6 ? 1e20f : 0.1f;
    size_t st[3] = {0, 0, 0}, ct[3] = {1, NY, NX}, t0 = 0;
    nc_put_var_double(nc, vx, x);
    nc_put_var_double(nc, vy, y);
    nc_put_var1_double(nc, vt, &t0, &t);
    nc_put_vara_float(nc, vz, st, ct, z);
    nc_close(nc);
}

static void projected(const char *unit, double scale, int what)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/ps_%s_%d.nc", dir, unit, what);
    ps_file(path, unit, scale, what);
    const double box[4] = {30.0, 50.0, 72.0, 78.0};
    ocean_grid *g = NULL;
    sph_error err;
    sph_error_clear(&err);
    int rc = ocean_grid_read(path, box, KEY, &g, &err);
    CHECK(rc == SPH_OK && g && g->nx == NX && g->ny == NY, "polar stereographic (%s) read: %s", unit, err.msg);
    if (rc != SPH_OK || !g)
        return;
    double xc, yc, wc = 0.0, wk = 0.0, wa = 0.0;
    int land = 1;
    ps_centre(&xc, &yc);
    static const double off[4][2] = {{-0.5, -0.5}, {0.5, -0.5}, {0.5, 0.5}, {-0.5, 0.5}};
    for (int c = 0; c < NX * NY; c++) {
        double x = xc + (c % NX - 3.5) * CELL, y = yc + (c / NX - 2.5) * CELL, lon, lat, xx, yy, k;
        rp_ps_inverse(WA, wgs_b(), 70.0, -45.0, x, y, &lon, &lat);
        wc = fmax(wc, fmax(fabs(remainder(g->lon[c] - lon, 360.0)), fabs(g->lat[c] - lat)));
        for (int v = 0; v < 4; v++) {
            rp_ps_inverse(WA, wgs_b(), 70.0, -45.0, x + off[v][0] * CELL, y + off[v][1] * CELL, &lon, &lat);
            wk = fmax(wk, fmax(fabs(remainder(g->blon[4 * c + v] - lon, 360.0)), fabs(g->blat[4 * c + v] - lat)));
        }
        rp_ps_forward(WA, wgs_b(), 70.0, -45.0, g->lon[c], g->lat[c], &xx, &yy, &k);
        double want = CELL * CELL / (k * k);
        wa = fmax(wa, fabs(g->area[c] - want) / want);
        land &= g->land[c] == (c % NX >= 6);
    }
    static const char *const how[5] = {"parameters", "", "", "crs_wkt", "epsg_code"};
    printf("  %s, %s: centres %.3g deg, corners %.3g deg from Snyder; areas %.3g relative to dx dy / k^2 (%s)\n",
           unit, how[what], wc, wk, wa, g->area_from);
    CHECK(wc <= 1e-9, "centres: Snyder's inverse within 1e-9 degree (%.3g)", wc);
    CHECK(wk <= 1e-9, "corners: Snyder's inverse of the edges within 1e-9 degree (%.3g)", wk);
    CHECK(wa <= 1e-8, "areas: dx dy / k^2 within 1e-8 (%.3g)", wa);
    CHECK(land, "land where zos is fill");
    CHECK(strstr(g->desc, "projected x/y through grid mapping crs (polar_stereographic)") != NULL, "described: %s",
          g->desc);
    ocean_grid_free(g);
}

/* A rotated-pole file (the CF conventions' example pole): rlon, rlat
 * 1-D, uo(rlat, rlon); what 1: the pole's latitude missing. */
static void rot_file(const char *path, int what)
{
    int nc, dx, dy, vx, vy, vg, vu;
    nc_create(path, NC_NETCDF4 | NC_CLOBBER, &nc);
    nc_def_dim(nc, "rlat", NY, &dy);
    nc_def_dim(nc, "rlon", NX, &dx);
    nc_def_var(nc, "rlon", NC_DOUBLE, 1, &dx, &vx);
    rp_text(nc, vx, "standard_name", "grid_longitude");
    rp_text(nc, vx, "units", "degrees");
    nc_def_var(nc, "rlat", NC_DOUBLE, 1, &dy, &vy);
    rp_text(nc, vy, "standard_name", "grid_latitude");
    rp_text(nc, vy, "units", "degrees");
    nc_def_var(nc, "rotated_pole", NC_CHAR, 0, NULL, &vg);
    rp_text(nc, vg, "grid_mapping_name", "rotated_latitude_longitude");
    if (what != 1)
        rp_num(nc, vg, "grid_north_pole_latitude", 39.25);
    rp_num(nc, vg, "grid_north_pole_longitude", -162.0);
    int d2[2] = {dy, dx};
    nc_def_var(nc, "uo", NC_FLOAT, 2, d2, &vu);
    rp_text(nc, vu, "standard_name", "sea_water_x_velocity");
    rp_text(nc, vu, "units", "m s-1");
    rp_text(nc, vu, "grid_mapping", "rotated_pole");
    float fv = 1e20f;
    nc_put_att_float(nc, vu, "_FillValue", NC_FLOAT, 1, &fv);
    nc_enddef(nc);
    double a[NX], b[NY];
    for (int i = 0; i < NX; i++)
        a[i] = -1.0 + 0.44 * i;
    for (int j = 0; j < NY; j++)
        b[j] = -1.5 + 0.44 * j;
    float u[NX * NY];
    for (int k = 0; k < NX * NY; k++)
        u[k] = k / NX == 0 ? 1e20f : 0.1f;
    nc_put_var_double(nc, vx, a);
    nc_put_var_double(nc, vy, b);
    nc_put_var_float(nc, vu, u);
    nc_close(nc);
}

static void rotated(void)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/rotpole.nc", dir);
    rot_file(path, 0);
    const double box[4] = {10.0, 26.0, 45.0, 56.0};
    ocean_grid *g = NULL;
    sph_error err;
    sph_error_clear(&err);
    int rc = ocean_grid_read(path, box, KEY, &g, &err);
    CHECK(rc == SPH_OK && g && g->nx == NX && g->ny == NY, "rotated pole read: %s", err.msg);
    if (rc != SPH_OK || !g)
        return;
    PJ_CONTEXT *ctx = proj_context_create();
    PJ *P = proj_create(ctx, "+proj=ob_tran +o_proj=longlat +o_lat_p=39.25 +o_lon_p=0 +lon_0=18 +R=6371000 "
                             "+no_defs");
    CHECK(P != NULL, "PROJ's ob_tran");
    double wc = 0.0, wk = 0.0, wa = 0.0;
    int land = 1;
    static const double off[4][2] = {{-0.22, -0.22}, {0.22, -0.22}, {0.22, 0.22}, {-0.22, 0.22}};
    for (int c = 0; P && c < NX * NY; c++) {
        double rl = -1.0 + 0.44 * (c % NX), rp = -1.5 + 0.44 * (c / NX), u[4][3];
        PJ_COORD q = proj_trans(P, PJ_INV, proj_coord(rl * RP_DEG, rp * RP_DEG, 0, 0));
        wc = fmax(wc, fmax(fabs(remainder(g->lon[c] - q.lp.lam / RP_DEG, 360.0)), fabs(g->lat[c] - q.lp.phi / RP_DEG)));
        for (int v = 0; v < 4; v++) {
            q = proj_trans(P, PJ_INV, proj_coord((rl + off[v][0]) * RP_DEG, (rp + off[v][1]) * RP_DEG, 0, 0));
            wk = fmax(wk, fmax(fabs(remainder(g->blon[4 * c + v] - q.lp.lam / RP_DEG, 360.0)),
                               fabs(g->blat[4 * c + v] - q.lp.phi / RP_DEG)));
            u[v][0] = cos(q.lp.phi) * cos(q.lp.lam);
            u[v][1] = cos(q.lp.phi) * sin(q.lp.lam);
            u[v][2] = sin(q.lp.phi);
        }
        /* the polygon of PROJ's corners joined by great circles (two
         * triangles, Eriksson's excess): the rotated parallels are small
         * circles, which bulge by about L tan(phi') / (12 R) of the area */
        double want = 0.0;
        for (int t = 0; t < 2; t++) {
            const double *a = u[0], *b = u[1 + t], *d = u[2 + t];
            double bc[3] = {b[1] * d[2] - b[2] * d[1], b[2] * d[0] - b[0] * d[2], b[0] * d[1] - b[1] * d[0]};
            double tr = a[0] * bc[0] + a[1] * bc[1] + a[2] * bc[2];
            double den = 1.0 + (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) + (b[0] * d[0] + b[1] * d[1] + b[2] * d[2]) +
                         (d[0] * a[0] + d[1] * a[1] + d[2] * a[2]);
            want += 2.0 * atan2(fabs(tr), den) * 6371000.0 * 6371000.0;
        }
        wa = fmax(wa, fabs(g->area[c] - want) / want);
        land &= g->land[c] == (c / NX == 0);
    }
    printf("  rotated pole: centres %.3g deg, corners %.3g deg from PROJ ob_tran; areas %.3g from the great-circle "
           "polygon (%s)\n", wc, wk, wa, g->area_from);
    CHECK(wc <= 1e-9, "centres: PROJ's ob_tran within 1e-9 degree (%.3g)", wc);
    CHECK(wk <= 1e-9, "corners: PROJ's ob_tran within 1e-9 degree (%.3g)", wk);
    CHECK(wa <= 1e-4, "areas: the corners' great-circle polygon within 1e-4 (%.3g)", wa);
    CHECK(land, "land where uo is fill");
    proj_destroy(P);
    proj_context_destroy(ctx);
    ocean_grid_free(g);
}

static void refused(void)
{
    static const char *const names[3] = {"noellps.nc", "degrees.nc", "nopole.nc"};
    static const char *const words[3] = {"ellipsoid", "units", "grid_north_pole_latitude"};
    const double box[4] = {0.0, 60.0, 40.0, 80.0};
    for (int k = 0; k < 3; k++) {
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", dir, names[k]);
        if (k < 2)
            ps_file(path, "m", 1.0, k + 1);
        else
            rot_file(path, 1);
        ocean_grid *g = NULL;
        sph_error err;
        sph_error_clear(&err);
        int rc = ocean_grid_read(path, box, KEY, &g, &err);
        CHECK(rc != SPH_OK && !g && strstr(err.msg, path) && strstr(err.msg, "variable ") && strstr(err.msg, KEY) &&
                  strstr(err.msg, words[k]) && !strchr(err.msg, '\n'),
              "%s refused in one line naming the file, the variable, %s and the key: %s", names[k], words[k], err.msg);
        printf("  %s: %s\n", names[k], err.msg);
        ocean_grid_free(g);
    }
}

int main(void)
{
    int made = mkdtemp(dir) != NULL;
    CHECK(made, "a temporary directory");
    if (made) {
        projected("m", 1.0, 0);
        projected("km", 1000.0, 0);
        projected("m", 1.0, 3);
        projected("m", 1.0, 4);
        rotated();
        refused();
    }
    if (made)
        tmpdir_remove(dir);
    return check_summary("test_ocean_grid_mapped");
}
