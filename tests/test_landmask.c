/* Land mask: GSHHG rasterisation of Liaodong Bay against a table of known
 * places (oilfields and mid-bay at sea, cities on land), a few other known
 * places around the world (including lakes, which count as land, and a
 * region across the dateline), NetCDF masks (ERA5-style lsm fraction with
 * descending latitude, sea_binary_mask, fill pattern), write/read round
 * trip, sampling onto the projected plane. */
#include "io/landmask.h"

#include <netcdf.h>
#include <unistd.h>

#include "check.h"

typedef struct {
    const char *name;
    double lon, lat;
    int land;
} place;

static void check_places(const landmask *m, const place *pl, size_t n, const char *what)
{
    for (size_t k = 0; k < n; k++)
        CHECK(landmask_is_land(m, pl[k].lon, pl[k].lat) == pl[k].land, "%s: %s (%g E, %g N) should be %s",
              what, pl[k].name, pl[k].lon, pl[k].lat, pl[k].land ? "land" : "sea");
}

/* Liaodong Bay. Yingkou lies about 3 cells (0.03 deg) from the Daliao
 * river mouth; the others are 7 or more cells from any coast at 0.01 deg. */
static const place liaodong[] = {
    {"JZ20-2 oilfield", 121.37, 40.47, 0}, {"JZ9-3 oilfield", 121.55, 40.77, 0},
    {"mid-bay", 121.5, 40.3, 0},           {"Yingkou", 122.23, 40.67, 1},
    {"Jinzhou", 121.13, 41.10, 1},         {"Anshan", 122.99, 41.11, 1},
    {"Bohai Strait", 121.0, 38.5, 0},      {"Dalian inland", 121.9, 39.3, 1},
};

static void write_lsm_file(const char *path, int descending, int sea_mask)
{
    /* 0.25 deg grid over 120..122 E, 39..41 N: land in the east half
     * (lon > 121) and as a fraction elsewhere 0.3 (sea). */
    int ncid, d[3], vt, vlat, vlon, v;
    nc_create(path, NC_CLOBBER, &ncid);
    nc_def_dim(ncid, "time", 1, &d[0]);
    nc_def_dim(ncid, "latitude", 9, &d[1]);
    nc_def_dim(ncid, "longitude", 9, &d[2]);
    nc_def_var(ncid, "time", NC_DOUBLE, 1, &d[0], &vt);
    nc_def_var(ncid, "latitude", NC_DOUBLE, 1, &d[1], &vlat);
    nc_def_var(ncid, "longitude", NC_DOUBLE, 1, &d[2], &vlon);
    nc_def_var(ncid, sea_mask ? "sea" : "lsm", NC_SHORT, 3, d, &v);
    if (sea_mask) {
        nc_put_att_text(ncid, v, "standard_name", 15, "sea_binary_mask");
    } else {
        double sf = 1.0 / 1000, off = 0;
        nc_put_att_double(ncid, v, "scale_factor", NC_DOUBLE, 1, &sf);
        nc_put_att_double(ncid, v, "add_offset", NC_DOUBLE, 1, &off);
    }
    nc_enddef(ncid);
    double t = 0, lat[9], lon[9];
    short val[81];
    for (int k = 0; k < 9; k++) {
        lat[k] = descending ? 41 - 0.25 * k : 39 + 0.25 * k;
        lon[k] = 120 + 0.25 * k;
    }
    for (int j = 0; j < 9; j++)
        for (int i = 0; i < 9; i++) {
            int land = lon[i] > 121.1 || (lat[j] > 40.6 && lon[i] < 120.4);
            val[j * 9 + i] = sea_mask ? (short)!land : (short)(land ? 900 : 300);
        }
    nc_put_var_double(ncid, vt, &t);
    nc_put_var_double(ncid, vlat, lat);
    nc_put_var_double(ncid, vlon, lon);
    nc_put_var_short(ncid, v, val);
    nc_close(ncid);
}

static void write_fill_file(const char *path)
{
    int ncid, d[2], vlat, vlon, v;
    nc_create(path, NC_CLOBBER, &ncid);
    nc_def_dim(ncid, "lat", 4, &d[0]);
    nc_def_dim(ncid, "lon", 5, &d[1]);
    nc_def_var(ncid, "lat", NC_FLOAT, 1, &d[0], &vlat);
    nc_def_var(ncid, "lon", NC_FLOAT, 1, &d[1], &vlon);
    nc_def_var(ncid, "sst", NC_FLOAT, 2, d, &v);
    float fill = -999.f;
    nc_put_att_float(ncid, v, "_FillValue", NC_FLOAT, 1, &fill);
    nc_enddef(ncid);
    float lat[4] = {40, 40.5, 41, 41.5}, lon[5] = {120, 120.5, 121, 121.5, 122}, val[20];
    for (int k = 0; k < 20; k++)
        val[k] = (k % 5 == 4 || k >= 15) ? -999.f : 1.5f; /* east column and north row: land */
    val[7] = NAN;                                          /* NaN counts as missing too */
    nc_put_var_float(ncid, vlat, lat);
    nc_put_var_float(ncid, vlon, lon);
    nc_put_var_float(ncid, v, val);
    nc_close(ncid);
}

int main(void)
{
    sph_error err;
    sph_error_clear(&err);
    char dir[] = "/tmp/sphice_landmask_XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    char path[512];

    const char *gshhg = landmask_gshhg_default_path();
    if (!gshhg || access(gshhg, R_OK) != 0) {
        fprintf(stderr, "test_landmask: no GSHHG file (install gmt-gshhg-high): GSHHG cases skipped\n");
    } else {
        landmask_grid g = {119.5, 123.5, 38.0, 41.5, 0.01};
        landmask *m = landmask_create_gshhg(gshhg, &g, &err);
        CHECK(m != NULL, "%s", err.msg);
        int nlon, nlat;
        landmask_get_grid(m, &nlon, &nlat, NULL, NULL, NULL, NULL);
        CHECK(nlon == 400 && nlat == 350, "grid %d x %d", nlon, nlat);
        check_places(m, liaodong, sizeof liaodong / sizeof liaodong[0], "Liaodong Bay 0.01");
        CHECK(landmask_is_land(m, 125.0, 40.0) == -1, "outside the grid is -1");

        /* Write, read back, same cells. */
        snprintf(path, sizeof path, "%s/mask.nc", dir);
        CHECK(landmask_write_netcdf(m, path, "GSHHG test", &err) == SPH_OK, "%s", err.msg);
        landmask *r = landmask_read_netcdf(path, NULL, LANDMASK_NC_AUTO, &err);
        CHECK(r != NULL, "%s", err.msg);
        if (r) {
            int n2, l2;
            double a, b, c, d, a0, b0, c0, d0;
            landmask_get_grid(m, NULL, NULL, &a0, &b0, &c0, &d0);
            landmask_get_grid(r, &n2, &l2, &a, &b, &c, &d);
            CHECK(n2 == nlon && l2 == nlat, "read back size");
            CHECK_CLOSE(a, a0, 0, 1e-9, "lon0");
            CHECK_CLOSE(b, b0, 0, 1e-9, "lat0");
            CHECK_CLOSE(c, c0, 1e-9, 0, "dlon");
            CHECK(memcmp(landmask_data(r), landmask_data(m), (size_t)nlon * nlat) == 0, "cells equal");
            check_places(r, liaodong, sizeof liaodong / sizeof liaodong[0], "read back");
        }
        landmask_free(r);

        /* The model plane: a 2 km aeqd grid centred on the bay. */
        geo_proj *p = geo_proj_create("auto", 121.5, 40.5, &err);
        enum { NX = 150, NY = 150 };
        static unsigned char plane[NX * NY];
        CHECK(landmask_to_plane(m, p, -150e3, -150e3, 2e3, 2e3, NX, NY, plane, &err) == SPH_OK, "%s", err.msg);
        for (size_t k = 0; k < 6; k++) {
            double x, y;
            geo_forward(p, 1, &liaodong[k].lon, &liaodong[k].lat, &x, &y, NULL);
            int i = (int)floor((x + 150e3) / 2e3), j = (int)floor((y + 150e3) / 2e3);
            if (k == 3) /* Yingkou is 3 km from the river mouth: 2 km cells may miss it */
                continue;
            CHECK(i >= 0 && i < NX && j >= 0 && j < NY && plane[j * NX + i] == liaodong[k].land,
                  "plane cell of %s", liaodong[k].name);
        }
        geo_proj_free(p);
        landmask_free(m);

        /* Elsewhere: both sides of 0 E, lakes count as land. */
        landmask_grid g2 = {-6, 3, 35, 52, 0.05};
        m = landmask_create_gshhg(gshhg, &g2, &err);
        CHECK(m != NULL, "%s", err.msg);
        static const place europe[] = {
            {"Alboran Sea", -3.0, 36.3, 0}, {"Andalusia", -4.0, 37.5, 1},
            {"Dover Strait", 1.5, 51.0, 0}, {"Paris", 2.35, 48.85, 1},
            {"Bay of Biscay", -4.0, 45.0, 0}, {"Madrid", -3.7, 40.4, 1},
            {"Balearic Sea", 1.0, 39.5, 0}, {"Majorca", 2.95, 39.6, 1}};
        check_places(m, europe, sizeof europe / sizeof europe[0], "Europe 0.05");
        landmask_free(m);

        landmask_grid g3 = {170, 200, 45, 66, 0.1}; /* across the dateline */
        m = landmask_create_gshhg(gshhg, &g3, &err);
        CHECK(m != NULL, "%s", err.msg);
        static const place bering[] = {
            {"Bering Sea", -178.0, 58.0, 0}, {"Bering Sea (0..360)", 182.0, 58.0, 0},
            {"Chukotka", 175.0, 65.0, 1},    {"Seward Peninsula", -164.5, 65.3, 1},
            {"North Pacific", 175.0, 47.0, 0}, {"St Lawrence Island", -170.0, 63.4, 1}};
        check_places(m, bering, sizeof bering / sizeof bering[0], "Bering 0.1");
        landmask_free(m);

        landmask_grid g4 = {-93, -84, 45, 50, 0.05};
        m = landmask_create_gshhg(gshhg, &g4, &err);
        CHECK(m != NULL, "%s", err.msg);
        CHECK(landmask_is_land(m, -87.5, 47.5) == 1, "Lake Superior is inland water: land");
        landmask_free(m);

        sph_error_clear(&err);
        CHECK(landmask_create_gshhg("/nonexistent/binned_GSHHS_h.nc", &g, &err) == NULL, "missing file");
        CHECK(strstr(err.msg, "/nonexistent/binned_GSHHS_h.nc") != NULL, "message names file: %s", err.msg);
    }

    /* ERA5-style lsm fraction (scale_factor, descending latitude, time). */
    for (int desc = 0; desc <= 1; desc++) {
        for (int sea = 0; sea <= 1; sea++) {
            snprintf(path, sizeof path, "%s/lsm%d%d.nc", dir, desc, sea);
            write_lsm_file(path, desc, sea);
            sph_error_clear(&err);
            landmask *m = landmask_read_netcdf(path, NULL, LANDMASK_NC_AUTO, &err);
            CHECK(m != NULL, "lsm desc=%d sea=%d: %s", desc, sea, err.msg);
            if (!m)
                continue;
            /* grid points are cell centres: 120 .. 122 every 0.25 */
            CHECK(landmask_is_land(m, 121.5, 39.5) == 1, "east half land");
            CHECK(landmask_is_land(m, 120.5, 39.5) == 0, "west sea (lsm 0.3 is sea)");
            CHECK(landmask_is_land(m, 120.0, 41.0) == 1, "north-west corner land");
            CHECK(landmask_is_land(m, 120.0, 39.0) == 0, "south-west corner sea");
            CHECK(landmask_is_land(m, 119.8, 39.0) == -1, "west of the grid");
            landmask_free(m);
        }
    }
    /* Fill pattern of a forcing variable. */
    snprintf(path, sizeof path, "%s/sst.nc", dir);
    write_fill_file(path);
    sph_error_clear(&err);
    landmask *m = landmask_read_netcdf(path, "sst", LANDMASK_NC_FILL, &err);
    CHECK(m != NULL, "%s", err.msg);
    if (m) {
        CHECK(landmask_is_land(m, 122.0, 40.0) == 1, "fill is land");
        CHECK(landmask_is_land(m, 121.0, 40.0) == 0, "value is sea");
        CHECK(landmask_is_land(m, 120.0, 41.5) == 1, "north row fill");
        CHECK(landmask_is_land(m, 121.0, 40.5) == 1, "NaN is land in the fill pattern");
        landmask_free(m);
    }
    sph_error_clear(&err);
    CHECK(landmask_read_netcdf(path, NULL, LANDMASK_NC_AUTO, &err) == NULL, "no mask variable");
    CHECK(err.code == SPH_ERR_MISSING_VAR && strstr(err.msg, path), "message: %s", err.msg);
    sph_error_clear(&err);
    CHECK(landmask_read_netcdf(path, "nope", LANDMASK_NC_FILL, &err) == NULL, "missing named variable");
    CHECK(strstr(err.msg, "nope") && strstr(err.msg, path), "message: %s", err.msg);

    /* Array masks and to_plane outside the grid = sea. */
    unsigned char a[4] = {1, 0, 0, 1};
    m = landmask_create_array(2, 2, 0, 0, 1, 1, a, &err);
    CHECK(landmask_is_land(m, 0.5, 0.5) == 1 && landmask_is_land(m, 1.5, 0.5) == 0 &&
          landmask_is_land(m, 1.5, 1.5) == 1 && landmask_is_land(m, 360.5, 0.5) == 1,
          "array mask lookup (and longitude wrap)");
    landmask_free(m);
    landmask_free(NULL);

    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    CHECK(system(cmd) == 0, "cleanup");
    return check_summary("test_landmask");
}
