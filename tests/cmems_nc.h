/* The CMEMS global analysis layout (GLOBAL_ANALYSISFORECAST_PHY_001_024:
 * dimensions time, depth, latitude, longitude; float coordinates; float
 * uo/vo with _FillValue, standard names eastward/northward_sea_water_velocity,
 * time in hours since 1950-01-01, depth positive down from 0.494 m), shared
 * by tests/test_forcing_hyperslab.c and bench/bench_hyperslab.c: variables
 * defined from tables of text attributes. */
#ifndef SPHICE_TESTS_CMEMS_NC_H
#define SPHICE_TESTS_CMEMS_NC_H

#include <netcdf.h>
#include "io/forcing.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CMEMS_FILL 1e20f
#define CMEMS_H1970 175320.0 /* 1970-01-01 in hours since 1950-01-01 */
#define CMEMS_DEPTH0 0.494025f /* the product's first level, m */

static inline void cmems_check(int rc, const char *what)
{
    if (rc != NC_NOERR) {
        fprintf(stderr, "cmems_nc: %s: %s\n", what, nc_strerror(rc));
        exit(2);
    }
}

/* Defines a variable and its text attributes (name, value pairs ending in NULL). */
static inline int cmems_var(int nc, const char *name, nc_type type, int nd, const int *dims,
                            const char *const *atts)
{
    int v;
    cmems_check(nc_def_var(nc, name, type, nd, dims, &v), name);
    for (; atts && atts[0]; atts += 2)
        cmems_check(nc_put_att_text(nc, v, atts[0], strlen(atts[1]), atts[1]), atts[0]);
    return v;
}

static const char *const cmems_time_atts[] = {"standard_name", "time", "units", "hours since 1950-01-01",
                                              "calendar", "gregorian", "axis", "T", NULL};
static const char *const cmems_depth_atts[] = {"standard_name", "depth", "units", "m", "positive", "down",
                                               "axis", "Z", NULL};
static const char *const cmems_lat_atts[] = {"standard_name", "latitude", "units", "degrees_north",
                                             "axis", "Y", NULL};
static const char *const cmems_lon_atts[] = {"standard_name", "longitude", "units", "degrees_east",
                                             "axis", "X", NULL};

/* The coordinates of a CMEMS-shaped file: dims time (nt), depth (1), latitude,
 * longitude; ids in d[4] and v[4] in that order. */
static inline void cmems_coords(int nc, size_t nt, size_t nlat, size_t nlon, int d[4], int v[4])
{
    cmems_check(nc_def_dim(nc, "time", nt, &d[0]), "time");
    cmems_check(nc_def_dim(nc, "depth", 1, &d[1]), "depth");
    cmems_check(nc_def_dim(nc, "latitude", nlat, &d[2]), "latitude");
    cmems_check(nc_def_dim(nc, "longitude", nlon, &d[3]), "longitude");
    v[0] = cmems_var(nc, "time", NC_FLOAT, 1, &d[0], cmems_time_atts);
    v[1] = cmems_var(nc, "depth", NC_FLOAT, 1, &d[1], cmems_depth_atts);
    v[2] = cmems_var(nc, "latitude", NC_FLOAT, 1, &d[2], cmems_lat_atts);
    v[3] = cmems_var(nc, "longitude", NC_FLOAT, 1, &d[3], cmems_lon_atts);
}

/* Values of the coordinates (after nc_enddef): times t0_hours + 6 k since 1950,
 * latitude lat0 + j step, longitude lon0 + i step. */
static inline void cmems_coord_values(int nc, const int v[4], size_t nt, double t0_hours, size_t nlat,
                                      double lat0, size_t nlon, double lon0, double step)
{
    size_t n = nt > nlat ? nt : nlat;
    n = n > nlon ? n : nlon;
    float *buf = malloc(n * sizeof *buf), z = CMEMS_DEPTH0;
    if (!buf)
        exit(2);
    for (size_t k = 0; k < nt; k++)
        buf[k] = (float)(t0_hours + 6.0 * (double)k);
    cmems_check(nc_put_var_float(nc, v[0], buf), "time values");
    cmems_check(nc_put_var_float(nc, v[1], &z), "depth values");
    for (size_t j = 0; j < nlat; j++)
        buf[j] = (float)(lat0 + (double)j * step);
    cmems_check(nc_put_var_float(nc, v[2], buf), "latitude values");
    for (size_t i = 0; i < nlon; i++)
        buf[i] = (float)(lon0 + (double)i * step);
    cmems_check(nc_put_var_float(nc, v[3], buf), "longitude values");
    free(buf);
}

/* A float data variable with _FillValue, deflated (level 1, shuffle), chunked
 * as given (NULL: the library's default chunks). */
static inline int cmems_data(int nc, const char *name, int nd, const int *dims, const size_t *chunks,
                             const char *const *atts)
{
    int v = cmems_var(nc, name, NC_FLOAT, nd, dims, atts);
    if (chunks)
        cmems_check(nc_def_var_chunking(nc, v, NC_CHUNKED, chunks), "chunking");
    cmems_check(nc_def_var_deflate(nc, v, 1, 1, 1), "deflate");
    float f = CMEMS_FILL;
    cmems_check(nc_put_att_float(nc, v, "_FillValue", NC_FLOAT, 1, &f), "_FillValue");
    return v;
}

/* An ocean source of one file, with or without a read window. */
static inline forcing_source_spec cmems_spec(const char *const *files, unsigned required, int window,
                                             double margin_km)
{
    forcing_source_spec sp;
    memset(&sp, 0, sizeof sp);
    sp.name = "ocean";
    sp.kind = FORCING_OCEAN;
    sp.files = files;
    sp.nfiles = 1;
    sp.required = required;
    sp.window = window;
    sp.margin_km = margin_km;
    return sp;
}

#endif
