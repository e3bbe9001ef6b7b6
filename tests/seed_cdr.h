/* An NSIDC-CDR-shaped initial raster over the engine test case's box
 * (tests/engine_case.h), shared by test_seed_cells and test_seed_check:
 * cdr_seaice_conc ubyte (tdim, y, x), scale_factor 0.01, valid_range
 * 0..100, _FillValue 255, flag_values 251..255 "pole_hole_mask lakes
 * coastal land_mask missing_data", grid_mapping crs polar_stereographic
 * (Hughes 1980 ellipsoid, true scale at 70 N, -45 E), xgrid/ygrid in
 * metres with rows from north to south (NSIDC G02202 user guide); 2 km
 * cells instead of 25 km so that the small box holds a coast. */
#ifndef SPHICE_TESTS_SEED_CDR_H
#define SPHICE_TESTS_SEED_CDR_H

#include "raster_provider.h"

/* 2 km cells (the CDR's shape, a finer grid) over the engine test case's
 * Liaodong box; rows stored north to south as the CDR does. */
/* A 1-D coordinate variable with its standard name and units. */
static inline int sc_axis(int nc, const char *name, int dim, const char *standard_name, const char *units)
{
    int v;
    nc_def_var(nc, name, NC_DOUBLE, 1, &dim, &v);
    rp_text(nc, v, "standard_name", standard_name);
    rp_text(nc, v, "units", units);
    return v;
}

/* A CF polar_stereographic grid mapping north (true scale at 70 N, -45 E)
 * on the ellipsoid of semi-major axis a and minor_att (semi_minor_axis or
 * inverse_flattening) = minor. */
static inline void sc_ps_crs(int nc, const char *name, double a, const char *minor_att, double minor)
{
    int crs;
    nc_def_var(nc, name, NC_INT, 0, NULL, &crs);
    rp_text(nc, crs, "grid_mapping_name", "polar_stereographic");
    rp_num(nc, crs, "straight_vertical_longitude_from_pole", -45);
    rp_num(nc, crs, "latitude_of_projection_origin", 90);
    rp_num(nc, crs, "standard_parallel", 70);
    rp_num(nc, crs, "false_easting", 0);
    rp_num(nc, crs, "false_northing", 0);
    rp_num(nc, crs, "semi_major_axis", a);
    rp_num(nc, crs, minor_att, minor);
}

enum { CX = 40, CY = 34 };
static const double HA = 6378273.0, HB = 6356889.449, CD = 2000.0;
static double cx0, cytop; /* first column's x, first (northern) row's y, m */

/* raw byte at (i, jn), jn from the north: a land strip and its coast in
 * the west, a lake, ice 0.8 next to the coast */
static inline int cdr_raw(int i, int jn)
{
    if (i < 4)
        return 254;                     /* land_mask */
    if (i == 4)
        return 253;                     /* coastal */
    if (i == 20 && jn == 17)
        return 252;                     /* lakes */
    if (jn == 2 && i == 30)
        return 255;                     /* missing_data */
    return i < 28 ? 80 : 0;
}

static inline void write_cdr(const char *path)
{
    double x, y, k;
    rp_ps_forward(HA, HB, 70, -45, 121.5, 40.3, &x, &y, &k);
    cx0 = round(x / CD) * CD - CX / 2 * CD;
    cytop = round(y / CD) * CD + CY / 2 * CD;
    int nc, d[3], vx, vy, vt, vc;
    CHECK(nc_create(path, NC_CLOBBER | NC_NETCDF4, &nc) == NC_NOERR, "create %s", path);
    nc_def_dim(nc, "tdim", 1, &d[0]);
    nc_def_dim(nc, "y", CY, &d[1]);
    nc_def_dim(nc, "x", CX, &d[2]);
    nc_def_var(nc, "time", NC_DOUBLE, 1, &d[0], &vt);
    rp_text(nc, vt, "units", "days since 1601-01-01 00:00:00");
    rp_text(nc, vt, "calendar", "gregorian");
    vx = sc_axis(nc, "xgrid", d[2], "projection_x_coordinate", "meters");
    rp_text(nc, vx, "axis", "X");
    vy = sc_axis(nc, "ygrid", d[1], "projection_y_coordinate", "meters");
    rp_text(nc, vy, "axis", "Y");
    sc_ps_crs(nc, "crs", HA, "semi_minor_axis", HB);
    nc_def_var(nc, "cdr_seaice_conc", NC_UBYTE, 3, d, &vc);
    rp_text(nc, vc, "standard_name", "sea_ice_area_fraction");
    rp_text(nc, vc, "units", "1");
    rp_text(nc, vc, "grid_mapping", "crs");
    rp_num(nc, vc, "scale_factor", 0.01);
    unsigned char fill = 255, vr[2] = {0, 100}, fv[5] = {251, 252, 253, 254, 255};
    nc_put_att_uchar(nc, vc, "_FillValue", NC_UBYTE, 1, &fill);
    nc_put_att_uchar(nc, vc, "valid_range", NC_UBYTE, 2, vr);
    nc_put_att_uchar(nc, vc, "flag_values", NC_UBYTE, 5, fv);
    rp_text(nc, vc, "flag_meanings", "pole_hole_mask lakes coastal land_mask missing_data");
    nc_enddef(nc);
    double t = 145000, xs[CX], ys[CY];
    static unsigned char c[CY * CX];
    for (int i = 0; i < CX; i++)
        xs[i] = cx0 + i * CD;
    for (int jn = 0; jn < CY; jn++)
        ys[jn] = cytop - jn * CD;
    for (int jn = 0; jn < CY; jn++)
        for (int i = 0; i < CX; i++)
            c[jn * CX + i] = (unsigned char)cdr_raw(i, jn);
    nc_put_var_double(nc, vt, &t);
    nc_put_var_double(nc, vx, xs);
    nc_put_var_double(nc, vy, ys);
    nc_put_var_uchar(nc, vc, c);
    nc_close(nc);
}

/* The CDR cell (i, jn) of a lon/lat point, from Snyder's forward formula. */
static inline void cdr_cell(double lon, double lat, int *i, int *jn)
{
    double x, y, k;
    rp_ps_forward(HA, HB, 70, -45, lon, lat, &x, &y, &k);
    *i = (int)floor((x - cx0) / CD + 0.5);
    *jn = (int)floor((cytop - y) / CD + 0.5);
}

#endif
