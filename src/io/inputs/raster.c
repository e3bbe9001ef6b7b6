/* Initial ice field reader: see io/raster.h. */
#include "io/raster.h"

#include <ctype.h>
#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "io/cf.h"
#include "io/fetch.h"
#include "util/fileio.h"
#include "util/log.h"
#include "util/timeutil.h"

void ice_raster_options_default(ice_raster_options *o)
{
    memset(o, 0, sizeof *o);
    o->default_thickness = 0.1;
    o->valid_time = NAN;
}

void ice_raster_free(ice_raster *r)
{
    if (!r)
        return;
    free(r->lon);
    free(r->lat);
    free(r->conc);
    free(r->thick);
    free(r);
}

static ice_raster *raster_alloc(const char *path, int nlon, int nlat, sph_error *err)
{
    ice_raster *r = calloc(1, sizeof *r);
    size_t n = (size_t)nlon * (size_t)nlat;
    if (r) {
        r->lon = malloc(sizeof(double) * (size_t)nlon);
        r->lat = malloc(sizeof(double) * (size_t)nlat);
        r->conc = malloc(sizeof(double) * n);
        r->thick = malloc(sizeof(double) * n);
    }
    if (!r || !r->lon || !r->lat || !r->conc || !r->thick) {
        ice_raster_free(r);
        sph_err_set(err, SPH_ERR_NOMEM, "ice raster %s: out of memory for %d x %d cells", path,
                    nlon, nlat);
        return NULL;
    }
    r->nlon = nlon;
    r->nlat = nlat;
    r->valid_time = NAN;
    snprintf(r->path, sizeof r->path, "%s", path);
    return r;
}

double ice_raster_cell_area(const ice_raster *r, int j)
{
    const double deg = M_PI / 180.0, R = ICE_RASTER_EARTH_RADIUS;
    double s = r->lat[j] - r->dlat / 2, n = r->lat[j] + r->dlat / 2;
    if (s < -90) s = -90;
    if (n > 90) n = 90;
    return R * R * r->dlon * deg * (sin(n * deg) - sin(s * deg));
}

/* Concentration to fraction and the checks every format shares. `percent`
 * < 0 means decide from the values. Thickness NaN where ice = default. */
static int finish_raster(ice_raster *r, int percent, const ice_raster_options *o, sph_error *err)
{
    size_t n = (size_t)r->nlon * r->nlat;
    if (percent < 0) {
        percent = 0;
        for (size_t k = 0; k < n; k++)
            if (r->conc[k] > 1.5)
                percent = 1;
    }
    for (size_t k = 0; k < n; k++) {
        double c = r->conc[k];
        int i = (int)(k % r->nlon), j = (int)(k / r->nlon);
        if (isnan(c)) {
            r->thick[k] = NAN;
            continue;
        }
        if (c < -1e-6 || c > (percent ? 100.0 + 1e-4 : 1.0 + 1e-6))
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ice raster %s: concentration %g %s at (%g E, %g N) outside 0..%s",
                               r->path, c, percent ? "%" : "(fraction)", r->lon[i], r->lat[j],
                               percent ? "100 %" : "1");
        c = percent ? c / 100.0 : c;
        r->conc[k] = c < 0 ? 0 : c > 1 ? 1 : c;
        double h = r->thick[k];
        if (h < 0)
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ice raster %s: negative thickness %g m at (%g E, %g N)", r->path, h,
                               r->lon[i], r->lat[j]);
        if (isnan(h) || (h == 0 && r->conc[k] > 0))
            r->thick[k] = o->default_thickness;
    }
    return SPH_OK;
}

/* ------------------------------------------------------------- NetCDF */

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
        rc = finish_raster(r, percent, o, err);
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

/* ---------------------------------------------------------- ESRI ASCII */

typedef struct {
    long ncols, nrows;
    double x, y, cellsize, nodata;
    int x_is_centre, y_is_centre, has_nodata;
    const char *data; /* first value */
} esri_header;

static int parse_esri_header(const char *path, const char *text, esri_header *h, sph_error *err)
{
    memset(h, 0, sizeof *h);
    h->nodata = NAN;
    int seen = 0; /* bits: ncols nrows x y cellsize */
    const char *p = text;
    for (;;) {
        while (isspace((unsigned char)*p))
            p++;
        if (!isalpha((unsigned char)*p))
            break;
        char key[32];
        size_t n = 0;
        while (isalpha((unsigned char)*p) || *p == '_') {
            if (n < sizeof key - 1)
                key[n++] = (char)tolower((unsigned char)*p);
            p++;
        }
        key[n] = '\0';
        char *end;
        double v = strtod(p, &end);
        if (end == p)
            return sph_err_set(err, SPH_ERR_BAD_DATA, "ice raster %s: header key %s has no number",
                               path, key);
        p = end;
        if (strcmp(key, "ncols") == 0) h->ncols = (long)v, seen |= 1;
        else if (strcmp(key, "nrows") == 0) h->nrows = (long)v, seen |= 2;
        else if (strcmp(key, "xllcorner") == 0) h->x = v, seen |= 4;
        else if (strcmp(key, "xllcenter") == 0) h->x = v, h->x_is_centre = 1, seen |= 4;
        else if (strcmp(key, "yllcorner") == 0) h->y = v, seen |= 8;
        else if (strcmp(key, "yllcenter") == 0) h->y = v, h->y_is_centre = 1, seen |= 8;
        else if (strcmp(key, "cellsize") == 0) h->cellsize = v, seen |= 16;
        else if (strcmp(key, "nodata_value") == 0) h->nodata = v, h->has_nodata = 1;
        else
            return sph_err_set(err, SPH_ERR_BAD_DATA, "ice raster %s: unknown header key \"%s\"",
                               path, key);
    }
    if (seen != 31)
        return sph_err_set(err, SPH_ERR_BAD_DATA,
                           "ice raster %s: ESRI header lacks %s", path,
                           !(seen & 1) ? "ncols" : !(seen & 2) ? "nrows" : !(seen & 4) ? "xllcorner"
                           : !(seen & 8) ? "yllcorner" : "cellsize");
    if (h->ncols < 2 || h->nrows < 2 || h->ncols > 100000 || h->nrows > 100000 ||
        !(h->cellsize > 0))
        return sph_err_set(err, SPH_ERR_BAD_DATA,
                           "ice raster %s: bad ESRI geometry %ld x %ld cells of %g", path,
                           h->ncols, h->nrows, h->cellsize);
    h->data = p;
    return SPH_OK;
}

/* Reads the values into out[j * ncols + i] with j counted from the south. */
static int parse_esri_values(const char *path, const esri_header *h, double *out, sph_error *err)
{
    const char *p = h->data;
    size_t total = (size_t)h->ncols * h->nrows;
    for (size_t k = 0; k < total; k++) {
        while (isspace((unsigned char)*p))
            p++;
        long row = (long)(k / h->ncols), col = (long)(k % h->ncols);
        if (!*p)
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ice raster %s: truncated: %zu of %zu values (%ld rows x %ld "
                               "columns)", path, k, total, h->nrows, h->ncols);
        char *end;
        double v = strtod(p, &end);
        if (end == p || (*end && !isspace((unsigned char)*end)))
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ice raster %s: bad value \"%.20s\" at row %ld column %ld", path, p,
                               row + 1, col + 1);
        p = end;
        int missing = h->has_nodata && (v == h->nodata || (isnan(v) && isnan(h->nodata)));
        if (isnan(v) && !missing)
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ice raster %s: NaN at row %ld column %ld (not the NODATA_value)",
                               path, row + 1, col + 1);
        out[(size_t)(h->nrows - 1 - row) * h->ncols + col] = missing ? NAN : v;
    }
    while (isspace((unsigned char)*p))
        p++;
    if (*p)
        return sph_err_set(err, SPH_ERR_BAD_DATA,
                           "ice raster %s: more values than %ld rows x %ld columns", path, h->nrows,
                           h->ncols);
    return SPH_OK;
}

static int read_esri(const char *path, const char *text, const ice_raster_options *o,
                     ice_raster **out, sph_error *err)
{
    esri_header h;
    int rc = parse_esri_header(path, text, &h, err);
    if (rc != SPH_OK)
        return rc;
    ice_raster *r = raster_alloc(path, (int)h.ncols, (int)h.nrows, err);
    if (!r)
        return err ? err->code : SPH_ERR_NOMEM;
    double x0 = h.x + (h.x_is_centre ? 0 : h.cellsize / 2);
    double y0 = h.y + (h.y_is_centre ? 0 : h.cellsize / 2);
    for (int i = 0; i < r->nlon; i++)
        r->lon[i] = x0 + i * h.cellsize;
    for (int j = 0; j < r->nlat; j++)
        r->lat[j] = y0 + j * h.cellsize;
    r->dlon = r->dlat = h.cellsize;
    r->valid_time = o->valid_time;
    rc = parse_esri_values(path, &h, r->conc, err);
    size_t n = (size_t)r->nlon * r->nlat;
    for (size_t k = 0; k < n; k++)
        r->thick[k] = NAN;
    if (rc == SPH_OK && o->thickness_path && *o->thickness_path) {
        char *ttext = NULL;
        esri_header th;
        rc = read_file(o->thickness_path, &ttext, NULL, err);
        if (rc == SPH_OK)
            rc = parse_esri_header(o->thickness_path, ttext, &th, err);
        if (rc == SPH_OK &&
            (th.ncols != h.ncols || th.nrows != h.nrows ||
             fabs(th.x + (th.x_is_centre ? 0 : th.cellsize / 2) - x0) > 1e-6 * h.cellsize ||
             fabs(th.y + (th.y_is_centre ? 0 : th.cellsize / 2) - y0) > 1e-6 * h.cellsize ||
             fabs(th.cellsize - h.cellsize) > 1e-9 * h.cellsize))
            rc = sph_err_set(err, SPH_ERR_BAD_DATA,
                             "ice raster %s: thickness grid does not match concentration grid %s",
                             o->thickness_path, path);
        if (rc == SPH_OK)
            rc = parse_esri_values(o->thickness_path, &th, r->thick, err);
        for (size_t k = 0; rc == SPH_OK && k < n; k++)
            if (r->thick[k] < 0)
                rc = sph_err_set(err, SPH_ERR_BAD_DATA,
                                 "ice raster %s: negative thickness %g m at (%g E, %g N)",
                                 o->thickness_path, r->thick[k], r->lon[k % r->nlon],
                                 r->lat[k / r->nlon]);
        free(ttext);
    }
    if (rc == SPH_OK)
        rc = finish_raster(r, -1, o, err);
    if (rc != SPH_OK) {
        ice_raster_free(r);
        return rc;
    }
    *out = r;
    return SPH_OK;
}

int ice_raster_read(const char *path, const ice_raster_options *opt, ice_raster **out,
                    sph_error *err)
{
    ice_raster_options defaults;
    if (!opt) {
        ice_raster_options_default(&defaults);
        opt = &defaults;
    }
    *out = NULL;
    if (!(opt->default_thickness > 0))
        return sph_err_set(err, SPH_ERR_CONFIG, "ice raster %s: default thickness %g m must be > 0",
                           path, opt->default_thickness);
    FILE *f = fopen(path, "rb");
    if (!f)
        return sph_err_set(err, SPH_ERR_IO, "ice raster %s: cannot open: %m", path);
    unsigned char magic[8] = {0};
    size_t got = fread(magic, 1, sizeof magic, f);
    fclose(f);
    int is_netcdf = got >= 4 && (memcmp(magic, "CDF", 3) == 0 || memcmp(magic, "\x89HDF", 4) == 0);
    if (is_netcdf)
        return read_netcdf(path, opt, out, err);
    char *text = NULL;
    int rc = read_file(path, &text, NULL, err);
    if (rc != SPH_OK)
        return rc;
    const char *p = text;
    while (isspace((unsigned char)*p))
        p++;
    if (strncasecmp(p, "ncols", 5) == 0 || strncasecmp(p, "nrows", 5) == 0)
        rc = read_esri(path, text, opt, out, err);
    else
        rc = sph_err_set(err, SPH_ERR_BAD_DATA,
                         "ice raster %s: neither NetCDF nor an ESRI ASCII grid (%zu bytes)", path,
                         got);
    free(text);
    return rc;
}

int ice_raster_sample(const ice_raster *r, double lon, double lat, double *conc, double *thick)
{
    *conc = *thick = NAN;
    double fi = (lon - r->lon[0]) / r->dlon, fj = (lat - r->lat[0]) / r->dlat;
    if (!(fi >= 0 && fj >= 0 && fi <= r->nlon - 1 && fj <= r->nlat - 1))
        return 0;
    int i = (int)fi, j = (int)fj;
    if (i > r->nlon - 2) i = r->nlon - 2;
    if (j > r->nlat - 2) j = r->nlat - 2;
    double a = fi - i, b = fj - j, sw = 0, sc = 0, st = 0;
    for (int dj = 0; dj <= 1; dj++)
        for (int di = 0; di <= 1; di++) {
            double w = (di ? a : 1 - a) * (dj ? b : 1 - b);
            size_t k = (size_t)(j + dj) * r->nlon + (i + di);
            if (w <= 0 || isnan(r->conc[k]))
                continue;
            sw += w;
            sc += w * r->conc[k];
            st += w * r->thick[k];
        }
    if (sw <= 0)
        return 0;
    *conc = sc / sw;
    *thick = st / sw;
    return 1;
}
