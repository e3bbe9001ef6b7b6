/* A small ERA5-style NetCDF file for download tests, written into dir tmp
 * and returned as bytes (the caller frees). */
#ifndef SPHICE_TESTS_ERA5_FILE_H
#define SPHICE_TESTS_ERA5_FILE_H

#include <netcdf.h>
#include <stdio.h>
#include <string.h>

#include "util/fileio.h"

/* ERA5 single-level style (CDS NetCDF: dims time, latitude, longitude;
 * u10/v10 "10 metre U/V wind component" in m s**-1). */
static char *era5_wind_file(const char *tmp, const char *name, int with_v10, size_t *len)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", tmp, name);
    int id, dims[3], vt, vlat, vlon, vu, vv;
    nc_create(path, NC_CLOBBER, &id);
    nc_def_dim(id, "time", 2, &dims[0]);
    nc_def_dim(id, "latitude", 3, &dims[1]);
    nc_def_dim(id, "longitude", 4, &dims[2]);
    nc_def_var(id, "time", NC_INT, 1, &dims[0], &vt);
    nc_put_att_text(id, vt, "units", strlen("hours since 1900-01-01 00:00:00.0"), "hours since 1900-01-01 00:00:00.0");
    nc_def_var(id, "latitude", NC_FLOAT, 1, &dims[1], &vlat);
    nc_put_att_text(id, vlat, "units", strlen("degrees_north"), "degrees_north");
    nc_def_var(id, "longitude", NC_FLOAT, 1, &dims[2], &vlon);
    nc_put_att_text(id, vlon, "units", strlen("degrees_east"), "degrees_east");
    nc_def_var(id, "u10", NC_FLOAT, 3, dims, &vu);
    nc_put_att_text(id, vu, "units", strlen("m s**-1"), "m s**-1");
    nc_put_att_text(id, vu, "long_name", strlen("10 metre U wind component"), "10 metre U wind component");
    if (with_v10) {
        nc_def_var(id, "v10", NC_FLOAT, 3, dims, &vv);
        nc_put_att_text(id, vv, "units", strlen("m s**-1"), "m s**-1");
        nc_put_att_text(id, vv, "long_name", strlen("10 metre V wind component"), "10 metre V wind component");
    }
    nc_enddef(id);
    int t[2] = {1087872, 1087873}; /* 2024-02-08T00Z and 01Z */
    float lat[3] = {41, 40, 39}, lon[4] = {119, 120, 121, 122}, w[24];
    for (int k = 0; k < 24; k++)
        w[k] = 0.5f * (float)k;
    nc_put_var_int(id, vt, t);
    nc_put_var_float(id, vlat, lat);
    nc_put_var_float(id, vlon, lon);
    nc_put_var_float(id, vu, w);
    if (with_v10)
        nc_put_var_float(id, vv, w);
    nc_close(id);
    char *bytes = NULL;
    read_file(path, &bytes, len, NULL);
    return bytes;
}

#endif
