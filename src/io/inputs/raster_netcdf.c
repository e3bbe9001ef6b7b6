/* The NetCDF driver of the initial ice raster (raster_impl.h): CF
 * concentration and thickness on 1-D regular lon/lat coordinates. */
#include "raster_impl.h"
#include "io/nc_guard.h"

#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <ctype.h>

#include "io/cf.h"
#include "io/cf_mapping.h"
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

/* flag_values / flag_meanings of varid: kind[i] 1 for land (a meaning
 * naming land, coast or lake), 2 for "no information" (pole hole,
 * missing, anything else). Returns the count, or -1 (err set) for flag
 * values without meanings. */
static int read_flags(int ncid, int varid, const char *path, const char *label, const char *att,
                      double *values, int *kind, sph_error *err)
{
    size_t n = 0;
    if (!cf_att_num(ncid, varid, att, values, &n, RASTER_MAX_FLAGS))
        return 0;
    char meanings[4096];
    if (!att_text(ncid, varid, "flag_meanings", meanings, sizeof meanings))
        return sph_err_set(err, SPH_ERR_BAD_DATA, "ice raster %s: %s has %s but no flag_meanings",
                           path, label, att), -1;
    return raster_flag_meanings(path, label, att, n, meanings, kind, err);
}

/* The 2-D slab (leading dimensions at index 0) of varid as raw doubles;
 * a NetCDF status. */
static int read_slab(int ncid, int varid, size_t nlat, size_t nlon, double *out)
{
    int ndims;
    nc_inq_varndims(ncid, varid, &ndims);
    size_t start[NC_MAX_VAR_DIMS] = {0}, count[NC_MAX_VAR_DIMS];
    for (int d = 0; d < ndims; d++)
        count[d] = 1;
    count[ndims - 2] = nlat;
    count[ndims - 1] = nlon;
    return nc_get_vara_double(ncid, varid, start, count, out);
}

/* 1 when variable v has (at least) the last two dimensions of vc. */
static int same_grid(int ncid, int v, int vc)
{
    int nd, cnd, d[NC_MAX_VAR_DIMS], cd[NC_MAX_VAR_DIMS];
    nc_inq_varndims(ncid, v, &nd);
    nc_inq_vardimid(ncid, v, d);
    nc_inq_varndims(ncid, vc, &cnd);
    nc_inq_vardimid(ncid, vc, cd);
    return nd >= 2 && cnd >= 2 && d[nd - 1] == cd[cnd - 1] && d[nd - 2] == cd[cnd - 2];
}

static int read_field(int ncid, int varid, const char *path, const char *label, size_t nlat,
                      size_t nlon, double *out, unsigned char *land, double *halfstep,
                      sph_error *err)
{
    int status = read_slab(ncid, varid, nlat, nlon, out);
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
    if (halfstep) {
        nc_type t;
        nc_inq_vartype(ncid, varid, &t);
        /* packed integers: half a packing step, in the field's units */
        *halfstep = t != NC_FLOAT && t != NC_DOUBLE ? 0.5 * fabs(scale) : 0;
    }
    double fv[RASTER_MAX_FLAGS];
    int fk[RASTER_MAX_FLAGS];
    int nflags = read_flags(ncid, varid, path, label, "flag_values", fv, fk, err);
    if (nflags < 0)
        return err->code;
    for (size_t k = 0; k < nlat * nlon; k++) {
        double v = out[k];
        int f = 0;
        while (f < nflags && v != fv[f])
            f++;
        if (f < nflags) { /* flags are raw values, not scaled */
            out[k] = NAN;
            if (land)
                land[k] = fk[f] == 1 ? 1 : 2;
            continue;
        }
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

/* varid: the axis's coordinate variable, or -1 for the one named as the
 * dimension */
static int read_axis(int ncid, int dimid, int varid, const char *path, const char *what,
                     size_t *n, double **values, sph_error *err)
{
    char name[NC_MAX_NAME + 1];
    int status = nc_inq_dim(ncid, dimid, name, n);
    if (status != NC_NOERR)
        return nc_fail(path, status, what, err);
    if (*n < 2)
        return sph_err_set(err, SPH_ERR_BAD_DATA, "ice raster %s: %s axis \"%s\" has %zu value(s)",
                           path, what, name, *n);
    if (varid >= 0)
        nc_inq_varname(ncid, varid, name);
    else if (nc_inq_varid(ncid, name, &varid) != NC_NOERR)
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

/* ------------------------------------------------------------------ grids */

/* The PROJ definition of grid-mapping variable gm (see io/raster.h for
 * the order of the attributes tried; io/cf_mapping.h). */
static int gm_definition(int ncid, int gm, const char *path, const char *var, const char *gmname,
                         char *def, size_t len, sph_error *err)
{
    char why[400];
    if (cf_mapping_proj(ncid, gm, def, len, why, sizeof why) == 0)
        return SPH_OK;
    return sph_err_set(err, SPH_ERR_BAD_DATA, "ice raster %s: variable %s: grid mapping %s%s%s", path,
                       var, gmname, why[0] == ':' ? "" : " ", why);
}

/* Metres per unit of coordinate variable v (0 when its units are no
 * length, -1 when it has none). */
static double length_unit(int ncid, int v, char *units, size_t len)
{
    if (!att_text(ncid, v, "units", units, len) || !units[0])
        return -1;
    cf_units *cu = NULL;
    double a = 0, b = 0;
    if (cf_units_create(&cu, NULL) != SPH_OK)
        return 0;
    if (cf_units_linear(cu, units, "m", &a, &b) != 0 || b != 0 || !(a > 0))
        a = 0;
    cf_units_free(cu);
    return a;
}

/* A 2-D variable on (ydim, xdim) that is a latitude (want 'y') or a
 * longitude (want 'x'): named in `coordinates`, else a usual name. */
static int find_2d(int ncid, int vc, int ydim, int xdim, int want)
{
    static const char *const lat_names[] = {"lat", "latitude", "nav_lat", "TLAT", "lat_rho",
                                            "ULAT", NULL};
    static const char *const lon_names[] = {"lon", "longitude", "nav_lon", "TLON", "lon_rho",
                                            "ULON", NULL};
    char coords[1024], units[64], sname[64];
    int cand[32], nc = 0;
    if (att_text(ncid, vc, "coordinates", coords, sizeof coords))
        for (char *tok = strtok(coords, " "); tok && nc < 16; tok = strtok(NULL, " ")) {
            int v;
            if (nc_inq_varid(ncid, tok, &v) == NC_NOERR)
                cand[nc++] = v;
        }
    for (const char *const *n = want == 'y' ? lat_names : lon_names; *n; n++) {
        int v;
        if (nc_inq_varid(ncid, *n, &v) == NC_NOERR && nc < 32)
            cand[nc++] = v;
    }
    for (int k = 0; k < nc; k++) {
        int nd, d[NC_MAX_VAR_DIMS];
        nc_inq_varndims(ncid, cand[k], &nd);
        if (nd != 2)
            continue;
        nc_inq_vardimid(ncid, cand[k], d);
        if (d[0] != ydim || d[1] != xdim)
            continue;
        int is = 0;
        if (att_text(ncid, cand[k], "standard_name", sname, sizeof sname))
            is = strcmp(sname, want == 'y' ? "latitude" : "longitude") == 0;
        if (!is && att_text(ncid, cand[k], "units", units, sizeof units))
            is = strncasecmp(units, want == 'y' ? "degrees_n" : "degrees_e", 9) == 0 ||
                 strncasecmp(units, want == 'y' ? "degree_n" : "degree_e", 8) == 0;
        if (is)
            return cand[k];
    }
    return -1;
}

/* Which grid the concentration `vc` (named vname) is on. */
/* A 1-D variable on dimension dim with standard_name sname (NSIDC's
 * xgrid(x), ygrid(y)); -1 when none. */
static int find_axis_var(int ncid, int dim, const char *sname)
{
    int nvars = 0;
    nc_inq_nvars(ncid, &nvars);
    char buf[64];
    for (int v = 0; v < nvars; v++) {
        int nd, d;
        if (nc_inq_varndims(ncid, v, &nd) || nd != 1 || nc_inq_vardimid(ncid, v, &d) || d != dim)
            continue;
        if (att_text(ncid, v, "standard_name", buf, sizeof buf) && strcmp(buf, sname) == 0)
            return v;
    }
    return -1;
}

static int classify_grid(int ncid, int vc, const char *vname, int xdim, int ydim,
                         const char *path, int *kind, char *def, size_t dlen, double *xto_m,
                         double *yto_m, int *vlat2, int *vlon2, int *xvar, int *yvar,
                         sph_error *err)
{
    char xname[NC_MAX_NAME + 1], yname[NC_MAX_NAME + 1], gmname[NC_MAX_NAME + 1] = "";
    nc_inq_dimname(ncid, xdim, xname);
    nc_inq_dimname(ncid, ydim, yname);
    int xv = -1, yv = -1, gm = -1, gm_latlon = 0, nd;
    if (nc_inq_varid(ncid, xname, &xv) != NC_NOERR || nc_inq_varndims(ncid, xv, &nd) || nd != 1)
        xv = -1;
    if (nc_inq_varid(ncid, yname, &yv) != NC_NOERR || nc_inq_varndims(ncid, yv, &nd) || nd != 1)
        yv = -1;
    if (xv < 0)
        xv = find_axis_var(ncid, xdim, "projection_x_coordinate");
    if (yv < 0)
        yv = find_axis_var(ncid, ydim, "projection_y_coordinate");
    *xvar = xv;
    *yvar = yv;
    char buf[NC_MAX_NAME + 64];
    if (att_text(ncid, vc, "grid_mapping", buf, sizeof buf)) {
        /* "crs" or the CF 1.7 form "crs: x y" */
        size_t n = strcspn(buf, " :");
        if (n > NC_MAX_NAME)
            n = NC_MAX_NAME;
        memcpy(gmname, buf, n);
        gmname[n] = '\0';
        if (nc_inq_varid(ncid, gmname, &gm) != NC_NOERR)
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ice raster %s: variable %s: its grid_mapping \"%s\" is not a "
                               "variable of the file", path, vname, gmname);
        char gmn[64];
        gm_latlon = att_text(ncid, gm, "grid_mapping_name", gmn, sizeof gmn) &&
                    strcmp(gmn, "latitude_longitude") == 0;
    }
    char xu[64] = "", yu[64] = "";
    double xm = xv >= 0 ? length_unit(ncid, xv, xu, sizeof xu) : -1;
    double ym = yv >= 0 ? length_unit(ncid, yv, yu, sizeof yu) : -1;
    *kind = ICE_RASTER_LONLAT;
    if (xv >= 0 && yv >= 0 && (xm > 0 || ym > 0 || (gm >= 0 && !gm_latlon))) {
        if (!(xm > 0 && ym > 0))
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ice raster %s: variable %s: grid not understood: coordinates %s "
                               "(units \"%s\") and %s (units \"%s\") are not both lengths (m, km)",
                               path, vname, xname, xu, yname, yu);
        if (gm < 0 || gm_latlon)
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ice raster %s: variable %s: grid not understood: x/y in %s but no "
                               "grid_mapping attribute naming the projection", path, vname, xu);
        int rc = gm_definition(ncid, gm, path, vname, gmname, def, dlen, err);
        if (rc != SPH_OK)
            return rc;
        *kind = ICE_RASTER_PROJECTED;
        *xto_m = xm;
        *yto_m = ym;
        return SPH_OK;
    }
    if (xv < 0 || yv < 0) {
        *vlat2 = find_2d(ncid, vc, ydim, xdim, 'y');
        *vlon2 = find_2d(ncid, vc, ydim, xdim, 'x');
        if (*vlat2 >= 0 && *vlon2 >= 0)
            *kind = ICE_RASTER_CURVILINEAR;
        else if (*vlat2 >= 0 || *vlon2 >= 0)
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ice raster %s: variable %s: grid not understood: a 2-D %s but no "
                               "2-D %s on (%s, %s)", path, vname,
                               *vlat2 >= 0 ? "latitude" : "longitude",
                               *vlat2 >= 0 ? "longitude" : "latitude", yname, xname);
    }
    return SPH_OK;
}

/* The file's cell-area variable (cell_measures "area: NAME") in m^2 as
 * [j * nlon + i] in the file's order, or NULL (none; err untouched) */
static int read_cell_area(int ncid, int vc, const char *path, const char *vname, size_t ny,
                          size_t nx, double **out, sph_error *err)
{
    char cm[256], units[64];
    *out = NULL;
    if (!att_text(ncid, vc, "cell_measures", cm, sizeof cm))
        return SPH_OK;
    char *p = strstr(cm, "area:");
    if (!p)
        return SPH_OK;
    p += 5;
    p += strspn(p, " ");
    p[strcspn(p, " ")] = '\0';
    int va;
    if (nc_inq_varid(ncid, p, &va) != NC_NOERR)
        return SPH_OK; /* CF allows it in an external file: compute instead */
    if (!same_grid(ncid, va, vc))
        return sph_err_set(err, SPH_ERR_BAD_DATA,
                           "ice raster %s: variable %s: its cell area %s is not on its grid", path,
                           vname, p);
    double to = 1, b = 0;
    if (att_text(ncid, va, "units", units, sizeof units)) {
        cf_units *cu = NULL;
        int rc = cf_units_create(&cu, err);
        if (rc != SPH_OK)
            return rc;
        int bad = cf_units_linear(cu, units, "m2", &to, &b) != 0 || b != 0 || !(to > 0);
        cf_units_free(cu);
        if (bad)
            return sph_err_set(err, SPH_ERR_UNITS,
                               "ice raster %s: variable %s: cell area %s units \"%s\" are not an "
                               "area", path, vname, p, units);
    }
    double *a = malloc(sizeof(double) * nx * ny);
    if (!a)
        return sph_err_set(err, SPH_ERR_NOMEM, "ice raster %s: out of memory", path);
    int rc = read_field(ncid, va, path, p, ny, nx, a, NULL, NULL, err);
    if (rc != SPH_OK) {
        free(a);
        return rc;
    }
    for (size_t k = 0; k < nx * ny; k++)
        a[k] *= to;
    *out = a;
    return SPH_OK;
}


/* A projected or curvilinear raster's coordinates, cell centres and areas
 * (xs/ys: the 1-D x/y in m as in the file; tmp: nlon * nlat scratch). */
static int set_grid(int ncid, int vc, const char *vname, const char *path, int kind,
                    const char *def, int vlat2, int vlon2, const double *xs, const double *ys,
                    int flip, int flip_lon, ice_raster *r, double *tmp, sph_error *err)
{
    size_t nx = (size_t)r->nlon, ny = (size_t)r->nlat, n = nx * ny;
    free(r->lon);
    free(r->lat);
    r->lon = r->lat = NULL;
    r->kind = kind;
    double *area = NULL;
    int rc = read_cell_area(ncid, vc, path, vname, ny, nx, &area, err);
    if (rc != SPH_OK)
        return rc;
    if (area) {
        memcpy(tmp, area, sizeof(double) * n);
        for (size_t j = 0; j < ny; j++)
            for (size_t i = 0; i < nx; i++)
                area[j * nx + i] = tmp[(flip ? ny - 1 - j : j) * nx + (flip_lon ? nx - 1 - i : i)];
    }
    if (kind == ICE_RASTER_PROJECTED) {
        r->x = malloc(sizeof(double) * nx);
        r->y = malloc(sizeof(double) * ny);
        if (!r->x || !r->y) {
            free(area);
            return sph_err_set(err, SPH_ERR_NOMEM, "ice raster %s: out of memory", path);
        }
        for (size_t j = 0; j < ny; j++)
            r->y[j] = ys[flip ? ny - 1 - j : j];
        for (size_t i = 0; i < nx; i++)
            r->x[i] = xs[flip_lon ? nx - 1 - i : i];
        r->dx = (r->x[nx - 1] - r->x[0]) / (double)(nx - 1);
        r->dy = (r->y[ny - 1] - r->y[0]) / (double)(ny - 1);
        rc = raster_set_projected(r, def, vname, area, err);
        snprintf(r->grid, sizeof r->grid, "projected, %g x %g km cells, %.400s", r->dx / 1000,
                 r->dy / 1000, def);
    } else {
        r->cell_lon = malloc(sizeof(double) * n);
        r->cell_lat = malloc(sizeof(double) * n);
        if (!r->cell_lon || !r->cell_lat)
            rc = sph_err_set(err, SPH_ERR_NOMEM, "ice raster %s: out of memory", path);
        char ln[NC_MAX_NAME + 1], lt[NC_MAX_NAME + 1];
        nc_inq_varname(ncid, vlon2, ln);
        nc_inq_varname(ncid, vlat2, lt);
        if (rc == SPH_OK)
            rc = read_field(ncid, vlon2, path, ln, ny, nx, r->cell_lon, NULL, NULL, err);
        if (rc == SPH_OK)
            rc = read_field(ncid, vlat2, path, lt, ny, nx, r->cell_lat, NULL, NULL, err);
        if (rc == SPH_OK)
            rc = raster_set_curvilinear(r, vname, area, err);
        snprintf(r->grid, sizeof r->grid, "curvilinear, 2-D %s/%s, cell areas %s", lt, ln,
                 area ? "from the file" : "geodesic");
    }
    free(area);
    return rc;
}

/* Land from the concentration's ancillary status flag (ancillary_variables
 * naming a variable on its grid with flag_masks or flag_values whose
 * meanings name land, coast or lake): flags[k] = 1 there. */
static int read_status_land(int ncid, int vc, const char *path, size_t ny, size_t nx,
                            unsigned char *flags, double *tmp, sph_error *err)
{
    char anc[1024];
    if (!att_text(ncid, vc, "ancillary_variables", anc, sizeof anc))
        return SPH_OK;
    for (char *save = NULL, *tok = strtok_r(anc, " ", &save); tok; tok = strtok_r(NULL, " ", &save)) {
        int v;
        if (nc_inq_varid(ncid, tok, &v) != NC_NOERR || !same_grid(ncid, v, vc))
            continue;
        double masks[RASTER_MAX_FLAGS], values[RASTER_MAX_FLAGS];
        int mk[RASTER_MAX_FLAGS], vk[RASTER_MAX_FLAGS];
        int nm = read_flags(ncid, v, path, tok, "flag_masks", masks, mk, err);
        int nv = nm < 0 ? -1 : read_flags(ncid, v, path, tok, "flag_values", values, vk, err);
        if (nm < 0 || nv < 0)
            return err->code;
        if (nm == 0 && nv == 0)
            continue;
        int status = read_slab(ncid, v, ny, nx, tmp);
        if (status != NC_NOERR)
            return sph_err_set(err, SPH_ERR_NETCDF, "ice raster %s: reading %s: %s", path, tok,
                               nc_strerror(status));
        for (size_t k = 0; k < nx * ny; k++) {
            if (!isfinite(tmp[k]) || fabs(tmp[k]) > 9e15)
                continue;
            long long raw = (long long)tmp[k];
            for (int q = 0; q < nm; q++)
                if (mk[q] == 1 && (raw & (long long)masks[q]))
                    flags[k] = 1;
            for (int q = 0; q < nv; q++)
                if (vk[q] == 1 && tmp[k] == values[q])
                    flags[k] = 1;
        }
    }
    return SPH_OK;
}

/* The thickness kind of variable vt (see io/raster.h). */
static int thickness_kind(int ncid, int vt, int want, const char *path, int *kind, char *why,
                          size_t wlen, sph_error *err)
{
    char name[NC_MAX_NAME + 1], label[NC_MAX_NAME + 32], cm[512], ln[512], sn[512];
    nc_inq_varname(ncid, vt, name);
    snprintf(label, sizeof label, "thickness variable %s", name);
    int has_cm = att_text(ncid, vt, "cell_methods", cm, sizeof cm);
    int has_ln = att_text(ncid, vt, "long_name", ln, sizeof ln);
    int has_sn = att_text(ncid, vt, "standard_name", sn, sizeof sn);
    return raster_thickness_kind(path, label, name, has_cm ? cm : NULL, has_ln ? ln : NULL,
                                 has_sn ? sn : NULL, want, kind, why, wlen, err);
}

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
    status = nc_guard_nc_open(path, &ncid);
    if (status != NC_NOERR)
        return sph_err_set(err, SPH_ERR_NETCDF, "ice raster %s: cannot open as NetCDF: %s "
                           "(truncated or corrupt file?)", path, nc_strerror(status));
    ice_raster *r = NULL;
    double *lon = NULL, *lat = NULL, *tmp = NULL;
    size_t nlon = 0, nlat = 0;
    int rc = SPH_OK;
    int vc = find_var(ncid, o->conc_variable, "sea_ice_area_fraction", raster_conc_names);
    int vt = find_var(ncid, o->thick_variable, "sea_ice_thickness", raster_thick_names);
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
    char vname[NC_MAX_NAME + 1] = "";
    char gmdef[4096] = "";
    int kind = ICE_RASTER_LONLAT, vlat2 = -1, vlon2 = -1, xvar = -1, yvar = -1;
    double xto_m = 1, yto_m = 1;
    if (rc == SPH_OK) {
        nc_inq_varname(ncid, vc, vname);
        rc = classify_grid(ncid, vc, vname, dims[ndims - 1], dims[ndims - 2], path, &kind, gmdef,
                           sizeof gmdef, &xto_m, &yto_m, &vlat2, &vlon2, &xvar, &yvar, err);
    }
    if (rc == SPH_OK && kind == ICE_RASTER_CURVILINEAR) {
        nc_inq_dimlen(ncid, dims[ndims - 1], &nlon);
        nc_inq_dimlen(ncid, dims[ndims - 2], &nlat);
    } else {
        int proj = kind == ICE_RASTER_PROJECTED;
        if (rc == SPH_OK)
            rc = read_axis(ncid, dims[ndims - 1], proj ? xvar : -1, path, proj ? "x" : "longitude",
                           &nlon, &lon, err);
        if (rc == SPH_OK)
            rc = read_axis(ncid, dims[ndims - 2], proj ? yvar : -1, path, proj ? "y" : "latitude",
                           &nlat, &lat, err);
        for (size_t i = 0; rc == SPH_OK && proj && i < nlon; i++)
            lon[i] *= xto_m;
        for (size_t j = 0; rc == SPH_OK && proj && j < nlat; j++)
            lat[j] *= yto_m;
    }
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
    unsigned char *flags = NULL;
    if (rc == SPH_OK && !(flags = calloc(nlat * nlon, 1)))
        rc = sph_err_set(err, SPH_ERR_NOMEM, "ice raster %s: out of memory", path);
    if (rc == SPH_OK) {
        char clabel[NC_MAX_NAME + 32];
        snprintf(clabel, sizeof clabel, "concentration %s", vname);
        rc = read_field(ncid, vc, path, clabel, nlat, nlon, tmp, flags, &r->conc_halfstep, err);
        char units[64];
        if (att_text(ncid, vc, "units", units, sizeof units))
            percent = (strcmp(units, "%") == 0 || strcasecmp(units, "percent") == 0) ? 1 : -1;
        if (rc == SPH_OK)
            rc = read_status_land(ncid, vc, path, nlat, nlon, flags, r->thick, err);
    }
    int flip = rc == SPH_OK && lat && lat[1] < lat[0];
    int flip_lon = rc == SPH_OK && lon && lon[1] < lon[0];
    if (rc == SPH_OK) {
        for (size_t j = 0; j < nlat; j++)
            for (size_t i = 0; i < nlon; i++)
                r->conc[j * nlon + i] =
                    tmp[(flip ? nlat - 1 - j : j) * nlon + (flip_lon ? nlon - 1 - i : i)];
        for (size_t k = 0; k < nlat * nlon; k++) {
            r->nland += flags[k] == 1;
            r->nnoinfo += flags[k] == 2;
        }
        if (r->nland || r->nnoinfo) {
            if (!(r->land = malloc(nlat * nlon)))
                rc = sph_err_set(err, SPH_ERR_NOMEM, "ice raster %s: out of memory", path);
            for (size_t j = 0; rc == SPH_OK && j < nlat; j++)
                for (size_t i = 0; i < nlon; i++) {
                    size_t k = j * nlon + i;
                    r->land[k] = flags[(flip ? nlat - 1 - j : j) * nlon + (flip_lon ? nlon - 1 - i : i)];
                    if (r->land[k])
                        r->conc[k] = NAN;
                }
            log_info("ice raster %s: %s flags: %zu land/coast/lake cells, %zu cells without "
                     "information (not open water)", path, vname, r->nland, r->nnoinfo);
        }
        if (vt >= 0) {
            rc = thickness_kind(ncid, vt, o->thickness_kind, path, &r->thickness_kind,
                                r->thickness_why, sizeof r->thickness_why, err);
            if (rc == SPH_OK)
                rc = read_field(ncid, vt, path, "thickness", nlat, nlon, tmp, NULL, NULL, err);
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
    if (rc == SPH_OK && kind != ICE_RASTER_LONLAT)
        rc = set_grid(ncid, vc, vname, path, kind, gmdef, vlat2, vlon2, lon, lat, flip, flip_lon,
                      r, tmp, err);
    if (rc == SPH_OK) {
        if (kind == ICE_RASTER_LONLAT) {
            for (size_t j = 0; j < nlat; j++)
                r->lat[j] = lat[flip ? nlat - 1 - j : j];
            for (size_t i = 0; i < nlon; i++)
                r->lon[i] = lon[flip_lon ? nlon - 1 - i : i];
            r->dlon = (r->lon[nlon - 1] - r->lon[0]) / (double)(nlon - 1);
            r->dlat = (r->lat[nlat - 1] - r->lat[0]) / (double)(nlat - 1);
            snprintf(r->grid, sizeof r->grid, "regular lon/lat, %g x %g degrees", r->dlon, r->dlat);
        }
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
    free(flags);
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
