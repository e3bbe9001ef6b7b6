/* NSIDC sea-ice concentration products as the initial raster (issue 19
 * item 2), written here in the shape of their user guides:
 *  - NOAA/NSIDC Climate Data Record (G02202 version 4): cdr_seaice_conc,
 *    ubyte (tdim, y, x), scale_factor 0.01, valid_range 0..100, flag_values
 *    251..255 "pole_hole_mask lakes coastal land_mask missing_data",
 *    _FillValue 255, grid_mapping "crs" (NSIDC polar stereographic north,
 *    EPSG:3411: Hughes 1980 ellipsoid, true scale at 70 N, -45 E), 25 km,
 *    coordinates xgrid(x) and ygrid(y) in metres (ygrid from north to
 *    south), 2-D latitude/longitude beside them;
 *  - NSIDC-0051 style bytes: 0..250 = fraction x 250 (scale_factor
 *    0.004), 251 pole hole, 252 unused, 253 coast, 254 land, 255 missing.
 * Asserts: cell positions on the Snyder polar-stereographic formula with
 * the file's ellipsoid (within 0.01 m), cell areas dx dy / k^2, land /
 * coast / lake flagged as land, pole hole / missing / unused as "no
 * information" (never open water), seeded ice area and volume within 1 %
 * of sum A x area and A h x area over the sea cells; flags without
 * meanings refused in one line. */
#include <unistd.h>

#include "raster_provider.h"

enum { NX = 40, NY = 36 };
static const double HA = 6378273.0, HB = 6356889.449, D = 25000.0;
static const double X0 = -1200e3 + 12500, YTOP = 1500e3 - 12500; /* first centres */

/* the raw byte of cell (i, jn), jn counted from the north as the file stores it */
static int raw_cdr(int i, int jn)
{
    if (i < 3) return 254;                 /* land strip */
    if (i == 3) return 253;                /* its coast */
    if (i == 20 && jn == 10) return 252;   /* a lake */
    if (i >= 18 && i <= 21 && jn >= 16 && jn <= 19 && !(i == 20 && jn == 10)) return 251; /* pole hole */
    if (i == 30 && jn == 30) return 255;   /* missing */
    double u = (i - 25.0) / 10, v = (jn - 18.0) / 12;
    int c = (int)lround(100 * exp(-u * u - v * v));
    return c < 10 ? 0 : c;
}
/* 0051 bytes: 0..250 */
static int raw_0051(int i, int jn)
{
    int c = raw_cdr(i, jn);
    if (c > 100) return c == 252 ? 252 : c; /* same flags; 252 is "unused" there */
    return (int)lround(c * 2.5);
}

static void write_file(const char *path, int nsidc0051, int with_meanings)
{
    int ncid, d[3], vx, vy, vt, vc, crs, vlat, vlon;
    CHECK(nc_create(path, NC_CLOBBER | NC_NETCDF4, &ncid) == NC_NOERR, "create %s", path);
    nc_def_dim(ncid, "tdim", 1, &d[0]);
    nc_def_dim(ncid, "y", NY, &d[1]);
    nc_def_dim(ncid, "x", NX, &d[2]);
    nc_def_var(ncid, "time", NC_DOUBLE, 1, &d[0], &vt);
    rp_text(ncid, vt, "units", "days since 1601-01-01 00:00:00");
    rp_text(ncid, vt, "calendar", "gregorian");
    nc_def_var(ncid, "xgrid", NC_DOUBLE, 1, &d[2], &vx);
    rp_text(ncid, vx, "standard_name", "projection_x_coordinate");
    rp_text(ncid, vx, "units", "meters");
    rp_text(ncid, vx, "axis", "X");
    nc_def_var(ncid, "ygrid", NC_DOUBLE, 1, &d[1], &vy);
    rp_text(ncid, vy, "standard_name", "projection_y_coordinate");
    rp_text(ncid, vy, "units", "meters");
    rp_text(ncid, vy, "axis", "Y");
    nc_def_var(ncid, "latitude", NC_DOUBLE, 2, &d[1], &vlat);
    rp_text(ncid, vlat, "standard_name", "latitude");
    rp_text(ncid, vlat, "units", "degrees_north");
    nc_def_var(ncid, "longitude", NC_DOUBLE, 2, &d[1], &vlon);
    rp_text(ncid, vlon, "standard_name", "longitude");
    rp_text(ncid, vlon, "units", "degrees_east");
    nc_def_var(ncid, "crs", NC_INT, 0, NULL, &crs);
    rp_text(ncid, crs, "grid_mapping_name", "polar_stereographic");
    rp_num(ncid, crs, "straight_vertical_longitude_from_pole", -45);
    rp_num(ncid, crs, "latitude_of_projection_origin", 90);
    rp_num(ncid, crs, "standard_parallel", 70);
    rp_num(ncid, crs, "false_easting", 0);
    rp_num(ncid, crs, "false_northing", 0);
    rp_num(ncid, crs, "semi_major_axis", HA);
    rp_num(ncid, crs, "semi_minor_axis", HB);
    rp_text(ncid, crs, "srid", "urn:ogc:def:crs:EPSG::3411");
    rp_text(ncid, crs, "proj4text", "+proj=stere +lat_0=90 +lat_ts=70 +lon_0=-45 +k=1 +x_0=0 "
                                    "+y_0=0 +a=6378273 +b=6356889.449 +units=m +no_defs");
    nc_def_var(ncid, nsidc0051 ? "F17_ICECON" : "cdr_seaice_conc", NC_UBYTE, 3, d, &vc);
    rp_text(ncid, vc, "standard_name", "sea_ice_area_fraction");
    rp_text(ncid, vc, "units", "1");
    rp_text(ncid, vc, "grid_mapping", "crs");
    rp_text(ncid, vc, "coordinates", "time latitude longitude");
    rp_num(ncid, vc, "scale_factor", nsidc0051 ? 0.004 : 0.01);
    unsigned char fill = 255, vr[2] = {0, nsidc0051 ? 250 : 100}, fv[5] = {251, 252, 253, 254, 255};
    nc_put_att_uchar(ncid, vc, "_FillValue", NC_UBYTE, 1, &fill);
    nc_put_att_uchar(ncid, vc, "valid_range", NC_UBYTE, 2, vr);
    nc_put_att_uchar(ncid, vc, "flag_values", NC_UBYTE, 5, fv);
    if (with_meanings)
        rp_text(ncid, vc, "flag_meanings", nsidc0051
                                               ? "pole_hole unused coastline land_mask missing_data"
                                               : "pole_hole_mask lakes coastal land_mask missing_data");
    nc_enddef(ncid);
    double t = 153000;
    nc_put_var_double(ncid, vt, &t);
    double xs[NX], ys[NY];
    static double la[NY * NX], lo[NY * NX];
    static unsigned char c[NY * NX];
    for (int i = 0; i < NX; i++)
        xs[i] = X0 + i * D;
    for (int jn = 0; jn < NY; jn++)
        ys[jn] = YTOP - jn * D;
    for (int jn = 0; jn < NY; jn++)
        for (int i = 0; i < NX; i++) {
            /* the 2-D lat/lon: rough placeholders (a reader must use the projection) */
            la[jn * NX + i] = 70;
            lo[jn * NX + i] = -45;
            c[jn * NX + i] = (unsigned char)(nsidc0051 ? raw_0051(i, jn) : raw_cdr(i, jn));
        }
    nc_put_var_double(ncid, vx, xs);
    nc_put_var_double(ncid, vy, ys);
    nc_put_var_double(ncid, vlat, la);
    nc_put_var_double(ncid, vlon, lo);
    nc_put_var_uchar(ncid, vc, c);
    nc_close(ncid);
}

static void check_file(const char *what, const char *path, int nsidc0051)
{
    ice_raster_options o;
    ice_raster_options_default(&o);
    o.default_thickness = 0.8;
    ice_raster *r = NULL;
    sph_error err;
    sph_error_clear(&err);
    CHECK(ice_raster_read(path, &o, &r, &err) == SPH_OK && r, "%s: %s", what, err.msg);
    if (!r)
        return;
    CHECK(r->kind == ICE_RASTER_PROJECTED && r->nlon == NX && r->nlat == NY, "%s: kind %d", what,
          r->kind);
    double worst = 0, worst_area = 0, want_area = 0, want_vol = 0;
    int bad_flags = 0;
    size_t nland = 0, nnoinfo = 0;
    for (int j = 0; j < NY; j++) /* j from the south: row jn = NY - 1 - j of the file */
        for (int i = 0; i < NX; i++) {
            int jn = NY - 1 - j, raw = nsidc0051 ? raw_0051(i, jn) : raw_cdr(i, jn);
            double lon, lat, x, y, k;
            ice_raster_cell_lonlat(r, i, j, &lon, &lat);
            rp_ps_forward(HA, HB, 70, -45, lon, lat, &x, &y, &k);
            worst = fmax(worst, fmax(fabs(x - (X0 + i * D)), fabs(y - (YTOP - jn * D))));
            double area = D * D / (k * k);
            worst_area = fmax(worst_area, fabs(ice_raster_area(r, i, j) / area - 1));
            size_t q = (size_t)j * NX + i;
            int want_flag = raw == 254 || raw == 253 || (raw == 252 && !nsidc0051) ? 1
                          : raw == 251 || raw == 255 || raw == 252 ? 2 : 0;
            nland += want_flag == 1;
            nnoinfo += want_flag == 2;
            int got_flag = r->land ? r->land[q] : 0;
            if (got_flag != want_flag || (want_flag && !isnan(r->conc[q])))
                bad_flags++;
            if (want_flag)
                continue;
            double c = nsidc0051 ? raw / 250.0 : raw / 100.0;
            if (c > 0.15) {
                want_area += c * area;
                want_vol += c * 0.8 * area;
            }
        }
    CHECK(worst < 0.01, "%s: cell centres off Snyder's formula by %g m", what, worst);
    CHECK(worst_area < 1e-6, "%s: cell areas off dx dy / k^2 by %g", what, worst_area);
    CHECK(bad_flags == 0 && r->nland == nland && r->nnoinfo == nnoinfo,
          "%s: %d cells with the wrong flag; land %zu (want %zu), no information %zu (want %zu)",
          what, bad_flags, r->nland, nland, r->nnoinfo, nnoinfo);
    rp_check_seeded(what, r, want_area, want_vol, 0.15);
    ice_raster_free(r);
}

int main(void)
{
    char dir[] = "/tmp/sphice-test-raster-nsidc-XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    char path[512];
    snprintf(path, sizeof path, "%s/seaice_conc_daily_nh_19990208_f13_v04r00.nc", dir);
    write_file(path, 0, 1);
    check_file("NOAA/NSIDC CDR v4", path, 0);
    unlink(path);
    snprintf(path, sizeof path, "%s/NSIDC0051_SEAICE_PS_N25km_19990208_v2.0.nc", dir);
    write_file(path, 1, 1);
    check_file("NSIDC-0051 bytes", path, 1);
    unlink(path);
    /* flag values without meanings: one line naming file and variable */
    snprintf(path, sizeof path, "%s/nomeanings.nc", dir);
    write_file(path, 0, 0);
    ice_raster *r = NULL;
    sph_error err;
    sph_error_clear(&err);
    CHECK(ice_raster_read(path, NULL, &r, &err) != SPH_OK && !r && strstr(err.msg, path) &&
              strstr(err.msg, "flag_meanings") && !strchr(err.msg, '\n'),
          "flags without meanings: \"%s\"", err.msg);
    unlink(path);
    rmdir(dir);
    return check_summary("test_raster_nsidc");
}
