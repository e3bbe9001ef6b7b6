/* The NetCDF driver of the initial ice raster (raster_impl.h): CF
 * concentration and thickness on 1-D regular lon/lat coordinates. */
#include "raster_impl.h"

#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "io/cf.h"
#include "io/fetch.h"
#include "util/log.h"
#include "util/timeutil.h"

static int nc_fail(const char *path, int status, const char *what, sph_error *err)
{
    return sph_err_set(err, SPH_ERR_NETCDF, "ice raster %s: %s: %s", path, what,
                       nc_strerror(status));
}

static int att_text(int ncid, int varid, const char *att, char *buf, size_t len)
{
    size_t n;
    if (nc_inq_attlen(ncid, varid, att, &n) != NC_NOERR || n >= len)
        return 0;
    if (nc_get_att_text(ncid, varid, att, buf) != NC_NOERR)
        return 0;
    buf[n] = '\0';
    return 1;
}

static int find_var(int ncid, const char *override, const char *standard_name,
                    const char *const *names)
{
    int varid;
    if (override && *override)
        return nc_inq_varid(ncid, override, &varid) == NC_NOERR ? varid : -1;
    int nvars = 0;
    nc_inq_nvars(ncid, &nvars);
    char buf[256];
    for (int v = 0; v < nvars; v++)
        if (att_text(ncid, v, "standard_name", buf, sizeof buf) && strcmp(buf, standard_name) == 0)
            return v;
    for (; *names; names++)
        if (nc_inq_varid(ncid, *names, &varid) == NC_NOERR)
            return varid;
    return -1;
}

/* Reads one 2-D slab (leading dimensions at index 0) as double, with
 * scale/offset applied and declared missing values turned into NaN.
 * Undeclared NaN is an error. */
static int read_field(int ncid, int varid, const char *path, const char *label, size_t nlat,
                      size_t nlon, double *out, sph_error *err)
{
    int ndims;
    nc_inq_varndims(ncid, varid, &ndims);
    size_t start[NC_MAX_VAR_DIMS] = {0}, count[NC_MAX_VAR_DIMS];
    for (int d = 0; d < ndims; d++)
        count[d] = 1;
    count[ndims - 2] = nlat;
    count[ndims - 1] = nlon;
    int status = nc_get_vara_double(ncid, varid, start, count, out);
    if (status != NC_NOERR)
        return sph_err_set(err, SPH_ERR_NETCDF, "ice raster %s: reading %s: %s (truncated file?)",
                           path, label, nc_strerror(status));
    double fill = NAN, missing = NAN, scale = 1, offset = 0;
    int has_fill = nc_get_att_double(ncid, varid, "_FillValue", &fill) == NC_NOERR;
    int has_missing = nc_get_att_double(ncid, varid, "missing_value", &missing) == NC_NOERR;
    if (!has_fill) {
        nc_type t;
        nc_inq_vartype(ncid, varid, &t);
        fill = t == NC_FLOAT ? NC_FILL_FLOAT : t == NC_DOUBLE ? NC_FILL_DOUBLE
             : t == NC_SHORT ? NC_FILL_SHORT : t == NC_INT ? NC_FILL_INT : NAN;
        has_fill = isfinite(fill); /* unwritten values carry the default fill */
    }
    int nan_declared = (has_fill && isnan(fill)) || (has_missing && isnan(missing));
    nc_get_att_double(ncid, varid, "scale_factor", &scale);
    nc_get_att_double(ncid, varid, "add_offset", &offset);
    for (size_t k = 0; k < nlat * nlon; k++) {
        double v = out[k];
        if (isnan(v) && !nan_declared)
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ice raster %s: %s is NaN at index %zu (row %zu, column %zu) "
                               "and NaN is not its _FillValue", path, label, k, k / nlon, k % nlon);
        if (isnan(v) || (has_fill && v == fill) || (has_missing && v == missing))
            out[k] = NAN;
        else
            out[k] = v * scale + offset;
    }
    return SPH_OK;
}

static int read_axis(int ncid, int dimid, const char *path, const char *what, size_t *n,
                     double **values, sph_error *err)
{
    char name[NC_MAX_NAME + 1];
    int varid, status = nc_inq_dim(ncid, dimid, name, n);
    if (status != NC_NOERR)
        return nc_fail(path, status, what, err);
    if (*n < 2)
        return sph_err_set(err, SPH_ERR_BAD_DATA, "ice raster %s: %s axis \"%s\" has %zu value(s)",
                           path, what, name, *n);
    if (nc_inq_varid(ncid, name, &varid) != NC_NOERR)
        return sph_err_set(err, SPH_ERR_MISSING_VAR,
                           "ice raster %s: no coordinate variable for %s dimension \"%s\"", path,
                           what, name);
    *values = malloc(sizeof(double) * *n);
    if (!*values)
        return sph_err_set(err, SPH_ERR_NOMEM, "ice raster %s: out of memory", path);
    status = nc_get_var_double(ncid, varid, *values);
    if (status != NC_NOERR)
        return sph_err_set(err, SPH_ERR_NETCDF, "ice raster %s: reading %s: %s (truncated file?)",
                           path, name, nc_strerror(status));
    double step = ((*values)[*n - 1] - (*values)[0]) / (double)(*n - 1);
    for (size_t k = 1; k < *n; k++)
        if (!(fabs((*values)[k] - (*values)[k - 1] - step) <= 1e-3 * fabs(step)) || step == 0)
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ice raster %s: %s axis \"%s\" is not regular at index %zu", path,
                               what, name, k);
    return SPH_OK;
}

/* "hours since 1999-02-08 06:00:00" -> seconds per unit and epoch. */
static int parse_time_units(const char *units, double *per_unit, double *epoch)
{
    char unit[32];
    const char *since = strstr(units, " since ");
    if (!since || (size_t)(since - units) >= sizeof unit)
        return -1;
    memcpy(unit, units, (size_t)(since - units));
    unit[since - units] = '\0';
    if (strncasecmp(unit, "second", 6) == 0 || strcmp(unit, "s") == 0)
        *per_unit = 1;
    else if (strncasecmp(unit, "minute", 6) == 0)
        *per_unit = 60;
    else if (strncasecmp(unit, "hour", 4) == 0 || strcmp(unit, "h") == 0)
        *per_unit = 3600;
    else if (strncasecmp(unit, "day", 3) == 0)
        *per_unit = 86400;
    else
        return -1;
    char date[64];
    snprintf(date, sizeof date, "%s", since + 7);
    size_t len = strlen(date);
    while (len && (date[len - 1] == ' ' || date[len - 1] == 'Z'))
        date[--len] = '\0';
    if (len > 4 && strcmp(date + len - 4, " UTC") == 0)
        date[len - 4] = '\0';
    return time_parse_iso(date, epoch);
}

static const char *const conc_names[] = {"siconc", "ice_conc", "sic", "aice", "SIC", "conc", NULL};
static const char *const thick_names[] = {"sithick", "hi", "sit", "ice_thickness", "thick", NULL};

static int read_netcdf(const char *path, const ice_raster_options *o, ice_raster **out,
                       sph_error *err)
{
    /* nc_open accepts a classic file cut short (reading fill values past
     * the end): check the length the header promises first. */
    char label[4200];
    snprintf(label, sizeof label, "ice raster %s", path);
    int ncid, status = fetch_check_netcdf(path, label, NULL, 0, err);
    if (status != SPH_OK)
        return status;
    status = nc_open(path, NC_NOWRITE, &ncid);
    if (status != NC_NOERR)
        return sph_err_set(err, SPH_ERR_NETCDF, "ice raster %s: cannot open as NetCDF: %s "
                           "(truncated or corrupt file?)", path, nc_strerror(status));
    ice_raster *r = NULL;
    double *lon = NULL, *lat = NULL, *tmp = NULL;
    size_t nlon = 0, nlat = 0;
    int rc = SPH_OK;
    int vc = find_var(ncid, o->conc_variable, "sea_ice_area_fraction", conc_names);
    int vt = find_var(ncid, o->thick_variable, "sea_ice_thickness", thick_names);
    int ndims = 0, dims[NC_MAX_VAR_DIMS];
    if (vc < 0)
        rc = sph_err_set(err, SPH_ERR_MISSING_VAR,
                         "ice raster %s: missing variable: no %s%s (standard_name "
                         "sea_ice_area_fraction, or siconc/ice_conc/sic/aice)", path,
                         o->conc_variable ? "variable " : "concentration",
                         o->conc_variable ? o->conc_variable : "");
    else if (o->thick_variable && *o->thick_variable && vt < 0)
        rc = sph_err_set(err, SPH_ERR_MISSING_VAR, "ice raster %s: missing variable %s", path,
                         o->thick_variable);
    if (rc == SPH_OK) {
        nc_inq_varndims(ncid, vc, &ndims);
        nc_inq_vardimid(ncid, vc, dims);
        if (ndims < 2)
            rc = sph_err_set(err, SPH_ERR_BAD_DATA,
                             "ice raster %s: concentration has %d dimension(s), need (lat, lon)",
                             path, ndims);
    }
    if (rc == SPH_OK)
        rc = read_axis(ncid, dims[ndims - 1], path, "longitude", &nlon, &lon, err);
    if (rc == SPH_OK)
        rc = read_axis(ncid, dims[ndims - 2], path, "latitude", &nlat, &lat, err);
    if (rc == SPH_OK && vt >= 0) {
        int tnd, tdims[NC_MAX_VAR_DIMS];
        nc_inq_varndims(ncid, vt, &tnd);
        nc_inq_vardimid(ncid, vt, tdims);
        if (tnd < 2 || tdims[tnd - 1] != dims[ndims - 1] || tdims[tnd - 2] != dims[ndims - 2])
            rc = sph_err_set(err, SPH_ERR_BAD_DATA,
                             "ice raster %s: thickness is not on the concentration's grid", path);
    }
    if (rc == SPH_OK) {
        r = raster_alloc(path, (int)nlon, (int)nlat, err);
        tmp = malloc(sizeof(double) * nlon * nlat);
        if (!r || !tmp)
            rc = sph_err_set(err, SPH_ERR_NOMEM, "ice raster %s: out of memory", path);
    }
    int percent = -1;
    if (rc == SPH_OK) {
        rc = read_field(ncid, vc, path, "concentration", nlat, nlon, tmp, err);
        char units[64];
        if (att_text(ncid, vc, "units", units, sizeof units))
            percent = (strcmp(units, "%") == 0 || strcasecmp(units, "percent") == 0) ? 1 : -1;
    }
    int flip = rc == SPH_OK && lat[1] < lat[0];
    int flip_lon = rc == SPH_OK && lon[1] < lon[0];
    if (rc == SPH_OK) {
        for (size_t j = 0; j < nlat; j++)
            for (size_t i = 0; i < nlon; i++)
                r->conc[j * nlon + i] =
                    tmp[(flip ? nlat - 1 - j : j) * nlon + (flip_lon ? nlon - 1 - i : i)];
        if (vt >= 0) {
            rc = read_field(ncid, vt, path, "thickness", nlat, nlon, tmp, err);
            double to_m = 1;
            char units[64];
            /* any length unit (udunits2: cm, mm, inch, ...); none means m */
            if (rc == SPH_OK && att_text(ncid, vt, "units", units, sizeof units) &&
                strcmp(units, "m") != 0) {
                cf_units *cu = NULL;
                double a = 1, b = 0;
                rc = cf_units_create(&cu, err);
                if (rc == SPH_OK && (cf_units_linear(cu, units, "m", &a, &b) != 0 || b != 0.0 ||
                                     !(a > 0.0)))
                    rc = sph_err_set(err, SPH_ERR_UNITS,
                                     "ice raster %s: thickness units '%s' are not a length", path,
                                     units);
                cf_units_free(cu);
                to_m = a;
            }
            for (size_t j = 0; rc == SPH_OK && j < nlat; j++)
                for (size_t i = 0; i < nlon; i++)
                    r->thick[j * nlon + i] =
                        to_m * tmp[(flip ? nlat - 1 - j : j) * nlon + (flip_lon ? nlon - 1 - i : i)];
        } else {
            log_info("ice raster %s: no thickness variable, using %g m", path, o->default_thickness);
            for (size_t k = 0; k < nlat * nlon; k++)
                r->thick[k] = NAN;
        }
    }
    if (rc == SPH_OK) {
        for (size_t j = 0; j < nlat; j++)
            r->lat[j] = lat[flip ? nlat - 1 - j : j];
        for (size_t i = 0; i < nlon; i++)
            r->lon[i] = lon[flip_lon ? nlon - 1 - i : i];
        r->dlon = (r->lon[nlon - 1] - r->lon[0]) / (double)(nlon - 1);
        r->dlat = (r->lat[nlat - 1] - r->lat[0]) / (double)(nlat - 1);
        int vtime;
        char units[128];
        double t0, per_unit, epoch;
        r->valid_time = o->valid_time;
        if (nc_inq_varid(ncid, "time", &vtime) == NC_NOERR &&
            att_text(ncid, vtime, "units", units, sizeof units)) {
            size_t zero = 0;
            if (parse_time_units(units, &per_unit, &epoch) == 0 &&
                nc_get_var1_double(ncid, vtime, &zero, &t0) == NC_NOERR)
                r->valid_time = epoch + t0 * per_unit;
            else
                log_warn("ice raster %s: time units \"%s\" not understood; valid time unknown",
                         path, units);
        }
        rc = raster_finish(r, percent, o, err);
    }
    nc_close(ncid);
    free(lon);
    free(lat);
    free(tmp);
    if (rc != SPH_OK) {
        ice_raster_free(r);
        return rc;
    }
    *out = r;
    return SPH_OK;
}


static int probe_netcdf(const unsigned char *head, size_t got)
{
    return got >= 4 && (memcmp(head, "CDF", 3) == 0 || memcmp(head, "\x89HDF", 4) == 0);
}

const raster_driver raster_driver_netcdf = {"netcdf", probe_netcdf, read_netcdf};
