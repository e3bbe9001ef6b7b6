/* The NetCDF driver of the forcing reader (forcing_impl.h, forcing_driver):
 * CF NetCDF files, local or OPeNDAP. Every nc_* call of the forcing reader
 * is here: variable lists and attributes, the discovery of the spatial
 * dimensions and coordinates of a variable, vertical levels, packing, the
 * raw time coordinate, horizontal slices, and the sphice harmonic tide
 * format ("harmonic-1", docs/forcing.md). */
#include "forcing_impl.h"
#include "io/fetch.h"
#include "io/nc_guard.h"
#include "io/geo.h"
#include "io/cf_mapping.h"

#include <ctype.h>
#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#define DEG (M_PI / 180.0)

/* The driver's file handle: the ncid, boxed. */
static int ncid_of(void *fh)
{
    return *(const int *)fh;
}

/* ---- attributes and coordinates ---- */

static int fnc_text_att(int ncid, int varid, const char *name, char *buf, size_t len)
{
    nc_type type;
    size_t n;
    if (nc_inq_att(ncid, varid, name, &type, &n) != NC_NOERR || type != NC_CHAR || n + 1 > len)
        return -1;
    if (nc_get_att_text(ncid, varid, name, buf) != NC_NOERR)
        return -1;
    buf[n] = '\0';
    while (n > 0 && (buf[n - 1] == '\0' || isspace((unsigned char)buf[n - 1])))
        buf[--n] = '\0';
    return 0;
}

static int units_is(const char *u, const char *const *list)
{
    for (; *list; list++)
        if (strcasecmp(u, *list) == 0)
            return 1;
    return 0;
}

/* A coordinate variable of one axis: by standard_name when it has one,
 * else by its units or its name. */
static int fnc_is_axis(int ncid, int varid, const char *standard_name, const char *const *units,
                       const char *const *names)
{
    char buf[128], name[NC_MAX_NAME + 1];
    if (fnc_text_att(ncid, varid, "standard_name", buf, sizeof buf) == 0)
        return strcmp(buf, standard_name) == 0;
    if (fnc_text_att(ncid, varid, "units", buf, sizeof buf) == 0 && units_is(buf, units))
        return 1;
    if (nc_inq_varname(ncid, varid, name) == NC_NOERR && units_is(name, names))
        return 1;
    return 0;
}

static int fnc_is_lat(int ncid, int varid)
{
    static const char *const units[] = {"degrees_north", "degree_north", "degree_N",
                                        "degrees_N",     "degreeN",      "degreesN", NULL};
    static const char *const names[] = {"lat", "latitude", "nav_lat", "lat_rho", "XLAT", NULL};
    return fnc_is_axis(ncid, varid, "latitude", units, names);
}

static int fnc_is_lon(int ncid, int varid)
{
    static const char *const units[] = {"degrees_east", "degree_east", "degree_E",
                                        "degrees_E",    "degreeE",     "degreesE", NULL};
    static const char *const names[] = {"lon", "longitude", "nav_lon", "lon_rho", "XLONG", NULL};
    return fnc_is_axis(ncid, varid, "longitude", units, names);
}

/* The 1-D coordinate variable of dimension dimid, or -1. */
static int coord_var(int ncid, int dimid)
{
    char name[NC_MAX_NAME + 1];
    int varid, nd, d;
    if (nc_inq_dimname(ncid, dimid, name) != NC_NOERR || nc_inq_varid(ncid, name, &varid) != NC_NOERR)
        return -1;
    if (nc_inq_varndims(ncid, varid, &nd) != NC_NOERR || nd != 1 ||
        nc_inq_vardimid(ncid, varid, &d) != NC_NOERR || d != dimid)
        return -1;
    return varid;
}

static int is_time_dim(int ncid, int dimid)
{
    int unlim = -1;
    nc_inq_unlimdim(ncid, &unlim);
    int cv = coord_var(ncid, dimid);
    char buf[256];
    if (cv >= 0) {
        if (fnc_text_att(ncid, cv, "units", buf, sizeof buf) == 0 && strstr(buf, " since "))
            return 1;
        if (fnc_text_att(ncid, cv, "standard_name", buf, sizeof buf) == 0 &&
            strcmp(buf, "time") == 0)
            return 1;
        if (fnc_text_att(ncid, cv, "axis", buf, sizeof buf) == 0 && strcmp(buf, "T") == 0)
            return 1;
    }
    return dimid == unlim;
}

static int read_2d(int ncid, int varid, int ydim, int xdim, size_t ny, size_t nx, double *out)
{
    int dims[2];
    if (nc_inq_vardimid(ncid, varid, dims) != NC_NOERR)
        return -1;
    if (dims[0] == ydim && dims[1] == xdim)
        return nc_get_var_double(ncid, varid, out) == NC_NOERR ? 0 : -1;
    if (dims[0] != xdim || dims[1] != ydim)
        return -1;
    double *tmp = malloc(nx * ny * sizeof *tmp);
    if (!tmp)
        return -1;
    int rc = nc_get_var_double(ncid, varid, tmp) == NC_NOERR ? 0 : -1;
    for (size_t i = 0; rc == 0 && i < nx; i++)
        for (size_t j = 0; j < ny; j++)
            out[j * nx + i] = tmp[i * ny + j];
    free(tmp);
    return rc;
}

/* ---- grids and levels ---- */

static int is_pressure_units(const char *u)
{
    static const char *const list[] = {"Pa", "hPa", "kPa", "mbar", "millibar", "mb", "bar",
                                       "atm", NULL};
    return units_is(u, list);
}

static int is_vertical(int ncid, int cv)
{
    static const char *const std[] = {
        "depth", "height", "altitude", "air_pressure", "sea_water_pressure",
        "model_level_number", "ocean_s_coordinate", "ocean_s_coordinate_g1",
        "ocean_s_coordinate_g2", "ocean_sigma_coordinate", "ocean_sigma_z_coordinate",
        "ocean_double_sigma_coordinate", "atmosphere_sigma_coordinate",
        "atmosphere_hybrid_sigma_pressure_coordinate", "atmosphere_hybrid_height_coordinate",
        "atmosphere_sleve_coordinate", NULL};
    static const char *const len_units[] = {"m", "meter", "meters", "metre", "metres", "km",
                                            "cm", "dbar", "decibar", NULL};
    char buf[128];
    if (fnc_text_att(ncid, cv, "axis", buf, sizeof buf) == 0)
        return strcasecmp(buf, "Z") == 0;
    if (fnc_text_att(ncid, cv, "positive", buf, sizeof buf) == 0)
        return 1;
    if (fnc_text_att(ncid, cv, "standard_name", buf, sizeof buf) == 0 && units_is(buf, std))
        return 1;
    if (fnc_text_att(ncid, cv, "units", buf, sizeof buf) == 0 &&
        (units_is(buf, len_units) || is_pressure_units(buf)))
        return 1;
    return 0;
}

static int nc_levels(fsource *s, const char *path, void *fh, int varid, fvfile *vf, char *what,
                     size_t len, sph_error *err)
{
    int ncid = ncid_of(fh);
    int dimids[NC_MAX_VAR_DIMS];
    char vname[NC_MAX_NAME + 1] = "?", dname[NC_MAX_NAME + 1] = "?";
    nc_inq_varname(ncid, varid, vname);
    nc_inq_vardimid(ncid, varid, dimids);
    what[0] = '\0';
    for (int d = 0; d < vf->ndims; d++) {
        vf->level[d] = 0;
        if (d == vf->tdim || d == vf->ydim || d == vf->xdim)
            continue;
        size_t n = 0;
        nc_inq_dimlen(ncid, dimids[d], &n);
        nc_inq_dimname(ncid, dimids[d], dname);
        if (n <= 1)
            continue;
        if (strcmp(dname, "expver") == 0) {
            vf->merge_dim = d;
            vf->merge_n = n;
            size_t used = strlen(what);
            snprintf(what + used, len - used,
                     "%sexpver merged (the first valid of its %zu values at each point)",
                     used ? ", " : "", n);
            continue;
        }
        int cv = coord_var(ncid, dimids[d]);
        if (cv < 0 || !is_vertical(ncid, cv))
            return forcing_fail(err, s, path, SPH_ERR_BAD_DATA,
                                "variable '%s': dimension '%s' (%zu values) is neither time, "
                                "latitude, longitude nor a vertical coordinate; give one level",
                                vname, dname, n);
        double *z = malloc(n * sizeof *z);
        if (!z)
            return forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
        if (nc_get_var_double(ncid, cv, z) != NC_NOERR) {
            free(z);
            return forcing_fail(err, s, path, SPH_ERR_NETCDF,
                                "cannot read the vertical coordinate '%s'", dname);
        }
        char units[64] = "", sn[128] = "";
        fnc_text_att(ncid, cv, "units", units, sizeof units);
        fnc_text_att(ncid, cv, "standard_name", sn, sizeof sn);
        int pressure = is_pressure_units(units) || strcmp(sn, "air_pressure") == 0;
        size_t best = n;
        for (size_t k = 0; k < n; k++) {
            if (!isfinite(z[k]))
                continue;
            if (best == n || (pressure ? z[k] > z[best] : fabs(z[k]) < fabs(z[best])))
                best = k;
        }
        if (best == n) {
            free(z);
            return forcing_fail(err, s, path, SPH_ERR_BAD_DATA,
                                "vertical coordinate '%s' has no finite value", dname);
        }
        vf->level[d] = best;
        size_t used = strlen(what);
        snprintf(what + used, len - used,
                 "%sthe level nearest the surface, %s = %g%s%s (index %zu of %zu)",
                 used ? ", " : "", dname, z[best], units[0] ? " " : "", units, best, n);
        free(z);
    }
    return 0;
}

/* ROMS C grid: the angle (eta_rho, xi_rho) at the u points (eta_u =
 * eta_rho, xi_u = xi_rho - 1) or v points (eta_v = eta_rho - 1, xi_v =
 * xi_rho) of an ny x nx grid, as the mean direction of the two rho points
 * each lies between. Returns 2 when done, 0 when the shapes do not fit. */
static int c_grid_angle(int ncid, int id, size_t ny, size_t nx, double fac, double *out)
{
    int dd[2];
    size_t ry, rx;
    if (nc_inq_vardimid(ncid, id, dd) != NC_NOERR || nc_inq_dimlen(ncid, dd[0], &ry) != NC_NOERR ||
        nc_inq_dimlen(ncid, dd[1], &rx) != NC_NOERR)
        return 0;
    int du = ry == ny && rx == nx + 1, dv = ry == ny + 1 && rx == nx;
    if (!du && !dv)
        return 0;
    double *a = malloc(ry * rx * sizeof *a);
    if (!a || nc_get_var_double(ncid, id, a) != NC_NOERR) {
        free(a);
        return 0;
    }
    for (size_t j = 0; j < ny; j++)
        for (size_t i = 0; i < nx; i++) {
            double a0 = a[j * rx + i] * fac, a1 = (du ? a[j * rx + i + 1] : a[(j + 1) * rx + i]) * fac;
            out[j * nx + i] = atan2(sin(a0) + sin(a1), cos(a0) + cos(a1));
        }
    free(a);
    return 2;
}

/* Sizes of the horizontal grid of a variable whose vf->xdim and ydim are
 * known; sets vf->transpose. */
static int grid_shape(fsource *s, const char *path, int ncid, const int *dimids,
                      const char *vname, fvfile *vf, size_t *nx, size_t *ny, sph_error *err)
{
    vf->transpose = vf->xdim < vf->ydim;
    nc_inq_dimlen(ncid, dimids[vf->xdim], nx);
    nc_inq_dimlen(ncid, dimids[vf->ydim], ny);
    if (*nx < 2 || *ny < 2)
        return forcing_fail(err, s, path, SPH_ERR_BAD_DATA,
                            "variable '%s': grid %zux%zu has fewer than 2 points per axis", vname,
                            *nx, *ny);
    return 0;
}

/* Projected grid: 1-D x/y coordinates (projection_x/y_coordinate, m or
 * km) and the variable's CF grid_mapping, without latitude/longitude in
 * the file: node positions by PROJ's inverse, the angle of the x axis by
 * PROJ (geo_grid_angle: the projection's meridian convergence). A CF
 * rotated pole (rotated_latitude_longitude; grid_longitude/grid_latitude
 * in degrees) likewise, by the rotation of the sphere (io/cf_mapping.h).
 * Returns 1 when the variable has no grid_mapping (not this kind of
 * grid). */
static int projected_grid(fsource *s, const char *path, int ncid, int varid, const int *dimids,
                          int ndims, fvfile *vf, fgrid **out, sph_error *err)
{
    char vname[NC_MAX_NAME + 1] = "?", gmname[NC_MAX_NAME + 1], buf[128];
    nc_inq_varname(ncid, varid, vname);
    int gm;
    if (fnc_text_att(ncid, varid, "grid_mapping", gmname, sizeof gmname) != 0 ||
        nc_inq_varid(ncid, gmname, &gm) != NC_NOERR)
        return 1;
    /* a CF rotated pole: grid_longitude / grid_latitude in degrees */
    char gmn[96] = "";
    fnc_text_att(ncid, gm, "grid_mapping_name", gmn, sizeof gmn);
    int rot = strcmp(gmn, "rotated_latitude_longitude") == 0;
    const char *sx = rot ? "grid_longitude" : "projection_x_coordinate";
    const char *sy = rot ? "grid_latitude" : "projection_y_coordinate";
    int xv = -1, yv = -1;
    for (int d = 0; d < ndims; d++) {
        int cv = coord_var(ncid, dimids[d]);
        if (cv < 0 || d == vf->tdim)
            continue;
        int isx = 0, isy = 0;
        if (fnc_text_att(ncid, cv, "standard_name", buf, sizeof buf) == 0) {
            isx = strcmp(buf, sx) == 0;
            isy = strcmp(buf, sy) == 0;
        } else if (fnc_text_att(ncid, cv, "axis", buf, sizeof buf) == 0) {
            isx = strcasecmp(buf, "X") == 0;
            isy = strcasecmp(buf, "Y") == 0;
        }
        if (isx) {
            vf->xdim = d;
            xv = cv;
        } else if (isy) {
            vf->ydim = d;
            yv = cv;
        }
    }
    if (xv < 0 || yv < 0)
        return forcing_fail(err, s, path, SPH_ERR_MISSING_VAR,
                            "variable '%s' has grid_mapping '%s' but no %s/%s dimensions", vname,
                            gmname, sx, sy);
    double fac[2];
    for (int c = 0; c < 2; c++) {
        static const char *const m[] = {"m", "meter", "meters", "metre", "metres", NULL};
        static const char *const km[] = {"km", "kilometer", "kilometers", "kilometre", "kilometres",
                                         NULL};
        char u[64] = "";
        int cv = c ? yv : xv;
        static const char *const deg[] = {"degrees", "degree", NULL};
        fnc_text_att(ncid, cv, "units", u, sizeof u);
        fac[c] = rot ? (units_is(u, deg) ? 1.0 : 0.0) : units_is(u, m) ? 1.0 : units_is(u, km) ? 1000.0 : 0.0;
        if (fac[c] == 0.0) {
            char cn[NC_MAX_NAME + 1] = "?";
            nc_inq_varname(ncid, cv, cn);
            return forcing_fail(err, s, path, SPH_ERR_UNITS,
                                "%s coordinate '%s' of variable '%s' has units '%s' (not %s)",
                                rot ? "rotated-pole" : "projection", cn, vname, u,
                                rot ? "degrees" : "m or km");
        }
    }
    char def[4096], why[400] = "not a projected CRS that PROJ reads";
    cf_rotated_pole rp;
    if (rot ? cf_rotated_pole_read(ncid, gm, &rp, why, sizeof why) != 0
            : cf_mapping_proj(ncid, gm, def, sizeof def, why, sizeof why) != 0 ||
                  cf_mapping_proj_text(def, sizeof def) != 0)
        return forcing_fail(err, s, path, SPH_ERR_BAD_DATA,
                            "grid mapping '%s' of variable '%s' %s", gmname, vname, why);
    size_t nx, ny;
    int src = grid_shape(s, path, ncid, dimids, vname, vf, &nx, &ny, err);
    if (src)
        return src;
    char xn[NC_MAX_NAME + 1], yn[NC_MAX_NAME + 1], key[600];
    nc_inq_varname(ncid, xv, xn);
    nc_inq_varname(ncid, yv, yn);
    snprintf(key, sizeof key, "%.200s/%.200s/%zu/%zu/proj:%.80s", xn, yn, nx, ny, gmname);
    fgrid *g = fgrid_find(s, key);
    if (g) {
        *out = g;
        return 0;
    }
    g = calloc(1, sizeof *g);
    double *X = malloc(nx * ny * sizeof *X), *Y = malloc(nx * ny * sizeof *Y);
    double *x1 = malloc(nx * sizeof *x1), *y1 = malloc(ny * sizeof *y1);
    double *ang = NULL;
    int rc = 0;
    if (!g || !X || !Y || !x1 || !y1 || !(g->lon2 = malloc(nx * ny * sizeof(double))) ||
        !(g->lat2 = malloc(nx * ny * sizeof(double)))) {
        rc = forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
    } else if (nc_get_var_double(ncid, xv, x1) != NC_NOERR ||
               nc_get_var_double(ncid, yv, y1) != NC_NOERR) {
        rc = forcing_fail(err, s, path, SPH_ERR_NETCDF, "cannot read coordinates '%s', '%s'", xn, yn);
    }
    geo_proj *pj = NULL;
    if (!rc && !rot) {
        sph_error e;
        sph_error_clear(&e);
        pj = geo_proj_create(def, 0.0, 0.0, &e);
        if (!pj)
            rc = forcing_fail(err, s, path, SPH_ERR_BAD_DATA,
                              "grid mapping '%s' of variable '%s': PROJ cannot build '%s': %s",
                              gmname, vname, def, e.msg);
    }
    if (!rc) {
        for (size_t j = 0; j < ny; j++)
            for (size_t i = 0; i < nx; i++) {
                X[j * nx + i] = x1[i] * fac[0];
                Y[j * nx + i] = y1[j] * fac[1];
            }
        sph_error e;
        sph_error_clear(&e);
        if (rot)
            for (size_t p = 0; p < nx * ny; p++)
                cf_rotated_to_geo(&rp, X[p], Y[p], &g->lon2[p], &g->lat2[p], NULL);
        else if (geo_inverse(pj, nx * ny, X, Y, g->lon2, g->lat2, &e) != 0)
            rc = forcing_fail(err, s, path, SPH_ERR_BAD_DATA,
                              "grid mapping '%s' of variable '%s': a node does not invert: %s",
                              gmname, vname, e.msg);
    }
    if (!rc) {
        /* the read window first: PROJ's angles only at the nodes kept */
        g->nx = nx;
        g->ny = ny;
        if (fgrid_window(g, s) || !(ang = malloc(g->nx * g->ny * sizeof *ang)) ||
            !(g->cosang = malloc(g->nx * g->ny * sizeof(double))) ||
            !(g->sinang = malloc(g->nx * g->ny * sizeof(double))))
            rc = forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
    }
    for (size_t p = 0; !rc && p < g->nx * g->ny; p++) {
        /* geo_grid_angle: from east to the plane's x axis, anticlockwise */
        ang[p] = rot ? cf_rotated_angle_at(&rp, g->lon2[p], g->lat2[p])
                     : geo_grid_angle(pj, g->lon2[p], g->lat2[p]);
        if (!isfinite(ang[p]))
            rc = forcing_fail(err, s, path, SPH_ERR_BAD_DATA,
                              "grid mapping '%s': no grid angle at node %zu", gmname, p);
    }
    geo_proj_free(pj);
    if (!rc) {
        g->curvilinear = 1;
        snprintf(g->key, sizeof g->key, "%s", key);
        fgrid_angles(g, ang);
        snprintf(g->angle_from, sizeof g->angle_from, rot ? "the grid mapping '%.60s' (the rotated pole's "
                 "meridians)" : "the grid mapping '%.60s' (meridian convergence by PROJ)", gmname);
        snprintf(g->desc, sizeof g->desc, "%s %zux%zu (%.50s)", rot ? "rotated-pole" : "projected", nx, ny,
                 gmname);
        if (g->windowed) {
            size_t used = strlen(g->desc);
            snprintf(g->desc + used, sizeof g->desc - used, ", window %zux%zu", g->nx, g->ny);
        }
    }
    free(X), free(Y), free(x1), free(y1), free(ang);
    if (rc) {
        fgrid_free(g);
        return rc;
    }
    fgrid_add(s, g);
    *out = g;
    return 0;
}

static int grid_read(fsource *s, const char *path, int ncid, int varid, fvfile *vf, fgrid **out,
                     sph_error *err)
{
    int ndims, dimids[NC_MAX_VAR_DIMS];
    char vname[NC_MAX_NAME + 1] = "?";
    nc_inq_varname(ncid, varid, vname);
    if (nc_inq_varndims(ncid, varid, &ndims) != NC_NOERR || ndims > FORCING_MAX_DIMS ||
        nc_inq_vardimid(ncid, varid, dimids) != NC_NOERR)
        return forcing_fail(err, s, path, SPH_ERR_NETCDF,
                            "variable '%s': unsupported dimensions", vname);
    vf->ndims = ndims;
    vf->tdim = vf->ydim = vf->xdim = -1;
    int latv = -1, lonv = -1, curv = 0;
    for (int d = 0; d < ndims; d++) {
        int cv = coord_var(ncid, dimids[d]);
        if (vf->tdim < 0 && is_time_dim(ncid, dimids[d])) {
            vf->tdim = d;
        } else if (cv >= 0 && fnc_is_lat(ncid, cv)) {
            vf->ydim = d;
            latv = cv;
        } else if (cv >= 0 && fnc_is_lon(ncid, cv)) {
            vf->xdim = d;
            lonv = cv;
        }
    }
    if (vf->ydim < 0 || vf->xdim < 0) {
        /* Curvilinear: 2-D latitude/longitude named in "coordinates", or any
         * 2-D latitude/longitude variable over two of this variable's dims. */
        latv = lonv = -1;
        char coords[512];
        if (fnc_text_att(ncid, varid, "coordinates", coords, sizeof coords) == 0) {
            char *save = NULL;
            for (char *tok = strtok_r(coords, " ", &save); tok; tok = strtok_r(NULL, " ", &save)) {
                int id, nd;
                if (nc_inq_varid(ncid, tok, &id) != NC_NOERR ||
                    nc_inq_varndims(ncid, id, &nd) != NC_NOERR || nd != 2)
                    continue;
                if (latv < 0 && fnc_is_lat(ncid, id))
                    latv = id;
                else if (lonv < 0 && fnc_is_lon(ncid, id))
                    lonv = id;
            }
        }
        int nvars = 0;
        nc_inq_nvars(ncid, &nvars);
        for (int id = 0; id < nvars && (latv < 0 || lonv < 0); id++) {
            int nd, dd[2];
            if (nc_inq_varndims(ncid, id, &nd) != NC_NOERR || nd != 2)
                continue;
            nc_inq_vardimid(ncid, id, dd);
            int in0 = 0, in1 = 0;
            for (int d = 0; d < ndims; d++) {
                in0 |= dimids[d] == dd[0];
                in1 |= dimids[d] == dd[1];
            }
            if (!in0 || !in1)
                continue;
            if (latv < 0 && fnc_is_lat(ncid, id))
                latv = id;
            else if (lonv < 0 && fnc_is_lon(ncid, id))
                lonv = id;
        }
        if (latv < 0 || lonv < 0) {
            vf->ydim = vf->xdim = -1;
            int prc = projected_grid(s, path, ncid, varid, dimids, ndims, vf, out, err);
            if (prc != 1)
                return prc;
            return forcing_fail(err, s, path, SPH_ERR_MISSING_VAR,
                                "variable '%s': no latitude/longitude coordinates found", vname);
        }
        int dd[2];
        nc_inq_vardimid(ncid, latv, dd);
        for (int d = 0; d < ndims; d++) {
            if (dimids[d] == dd[0])
                vf->ydim = d;
            if (dimids[d] == dd[1])
                vf->xdim = d;
        }
        if (vf->ydim < 0 || vf->xdim < 0 || vf->ydim == vf->tdim || vf->xdim == vf->tdim)
            return forcing_fail(err, s, path, SPH_ERR_BAD_DATA,
                                "variable '%s': coordinates do not match its dimensions", vname);
        curv = 1;
    }
    size_t nx, ny;
    int src = grid_shape(s, path, ncid, dimids, vname, vf, &nx, &ny, err);
    if (src)
        return src;
    char latname[NC_MAX_NAME + 1], lonname[NC_MAX_NAME + 1];
    nc_inq_varname(ncid, latv, latname);
    nc_inq_varname(ncid, lonv, lonname);
    char key[600];
    snprintf(key, sizeof key, "%s/%s/%zu/%zu/%d", lonname, latname, nx, ny, curv);
    fgrid *g = fgrid_find(s, key);
    if (g) {
        *out = g;
        return 0;
    }
    g = calloc(1, sizeof *g);
    if (!g)
        return forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
    g->curvilinear = curv;
    g->nx = nx;
    g->ny = ny;
    snprintf(g->key, sizeof g->key, "%s", key);
    int rc = 0;
    if (curv && (!(g->lon2 = malloc(nx * ny * sizeof(double))) ||
                 !(g->lat2 = malloc(nx * ny * sizeof(double))))) {
        rc = forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
    } else if (!curv) {
        /* fgrid_setup_regular allocates the node coordinates of the read window */
        g->lon1 = malloc(nx * sizeof(double));
        g->lat1 = malloc(ny * sizeof(double));
        if (!g->lon1 || !g->lat1)
            rc = forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
        else if (nc_get_var_double(ncid, lonv, g->lon1) != NC_NOERR ||
                 nc_get_var_double(ncid, latv, g->lat1) != NC_NOERR)
            rc = forcing_fail(err, s, path, SPH_ERR_NETCDF, "cannot read coordinates '%s', '%s'",
                              lonname, latname);
        else
            rc = fgrid_setup_regular(g, s, path, err);
    } else {
        int dd[2];
        nc_inq_vardimid(ncid, latv, dd);
        if (read_2d(ncid, latv, dd[0], dd[1], ny, nx, g->lat2) ||
            read_2d(ncid, lonv, dd[0], dd[1], ny, nx, g->lon2)) {
            rc = forcing_fail(err, s, path, SPH_ERR_NETCDF,
                              "cannot read 2-D coordinates '%s', '%s'", lonname, latname);
        } else {
            for (size_t p = 0; p < nx * ny; p++) {
                if (!isfinite(g->lon2[p]) || !isfinite(g->lat2[p])) {
                    rc = forcing_fail(err, s, path, SPH_ERR_BAD_DATA,
                                      "2-D coordinates '%s'/'%s' contain missing values", lonname,
                                      latname);
                    break;
                }
                g->lon2[p] = fgrid_wrap180(g->lon2[p]);
            }
            g->cosang = malloc(nx * ny * sizeof(double));
            g->sinang = malloc(nx * ny * sizeof(double));
            double *angle = malloc(nx * ny * sizeof(double));
            if (!rc && (!g->cosang || !g->sinang || !angle))
                rc = forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
            if (!rc) {
                /* An angle-like variable over the same dimensions. */
                int nvars = 0, found = 0;
                nc_inq_nvars(ncid, &nvars);
                for (int id = 0; id < nvars && !found; id++) {
                    char nm[NC_MAX_NAME + 1], sn[128] = "", un[64] = "radian";
                    int nd;
                    nc_inq_varname(ncid, id, nm);
                    nc_inq_varndims(ncid, id, &nd);
                    fnc_text_att(ncid, id, "standard_name", sn, sizeof sn);
                    if (nd != 2 || (strcasecmp(nm, "angle") != 0 &&
                                    strcmp(sn, "angle_of_rotation_from_east_to_x") != 0))
                        continue;
                    fnc_text_att(ncid, id, "units", un, sizeof un);
                    double fac = strncasecmp(un, "deg", 3) == 0 ? DEG : 1.0;
                    if (read_2d(ncid, id, dd[0], dd[1], ny, nx, angle) == 0) {
                        for (size_t p = 0; p < nx * ny; p++)
                            angle[p] *= fac;
                        found = 1;
                    } else {
                        found = c_grid_angle(ncid, id, ny, nx, fac, angle);
                    }
                    if (nd == 2)
                        snprintf(g->angle_var, sizeof g->angle_var, "%.60s", nm);
                    if (found)
                        snprintf(g->angle_from, sizeof g->angle_from,
                                 "the file's angle variable '%.60s'%s", nm,
                                 found == 2 ? " (mean of the two rho points)" : "");
                }
                if (!found)
                    snprintf(g->angle_from, sizeof g->angle_from,
                             "the angle of the grid's x axis from '%.40s'/'%.40s'", lonname,
                             latname);
                fgrid_angles(g, found ? angle : NULL);
            }
            free(angle);
            snprintf(g->desc, sizeof g->desc, "curvilinear %zux%zu", nx, ny);
            if (!rc && fgrid_window(g, s))
                rc = forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
        }
    }
    if (rc) {
        fgrid_free(g);
        return rc;
    }
    fgrid_add(s, g);
    *out = g;
    return 0;
}

/* ---- files ---- */

static int nc_probe(const char *path)
{
    unsigned char m[8] = {0};
    FILE *fp = fopen(path, "rb");
    if (!fp)
        return 0;
    size_t n = fread(m, 1, sizeof m, fp);
    fclose(fp);
    if (n >= 4 && memcmp(m, "CDF", 3) == 0 && (m[3] == 1 || m[3] == 2 || m[3] == 5))
        return 1; /* classic, 64-bit offset, CDF-5 */
    return n == 8 && memcmp(m, "\211HDF\r\n\032\n", 8) == 0; /* netCDF-4 */
}

static int nc_open_file(fsource *s, int file, void **fh, sph_error *err)
{
    /* A classic-format file is checked like a download: one whose header
     * promises more records or bytes than the file holds is refused (the
     * library would read the missing records as fill). */
    unsigned char m[4] = {0};
    FILE *fp = fopen(s->paths[file], "rb");
    size_t got = fp ? fread(m, 1, sizeof m, fp) : 0;
    if (fp)
        fclose(fp);
    if (got == 4) {
        sph_error e;
        sph_error_clear(&e);
        int crc = nc_guard_check(s->paths[file], s->paths[file], &e); /* io/nc_guard.h */
        if (crc)
            return sph_err_set(err, crc, "forcing '%s': %s", s->name, e.msg);
    }
    int *box = malloc(sizeof *box);
    if (!box)
        return forcing_fail(err, s, s->paths[file], SPH_ERR_NOMEM, "out of memory");
    int rc = nc_guard_nc_open(s->paths[file], box);
    if (rc != NC_NOERR) {
        free(box);
        return forcing_fail(err, s, s->paths[file], SPH_ERR_NETCDF, "cannot open: %s",
                            nc_strerror(rc));
    }
    *fh = box;
    return 0;
}

static void nc_close_file(void *fh)
{
    if (!fh)
        return;
    nc_close(ncid_of(fh));
    free(fh);
}

/* ---- variables ---- */

static int nc_variables(void *fh, forcing_varinfo **list, size_t *n)
{
    int ncid = ncid_of(fh), nvars = 0;
    nc_inq_nvars(ncid, &nvars);
    *n = 0;
    *list = calloc(nvars > 0 ? (size_t)nvars : 1, sizeof **list);
    if (!*list)
        return -1;
    for (int id = 0; id < nvars; id++) {
        forcing_varinfo *vi = &(*list)[*n];
        if (nc_inq_varname(ncid, id, vi->name) != NC_NOERR)
            continue;
        if (fnc_text_att(ncid, id, "standard_name", vi->standard_name, sizeof vi->standard_name))
            vi->standard_name[0] = '\0';
        vi->id = id;
        (*n)++;
    }
    return 0;
}

static int nc_grid(fsource *s, const char *path, void *fh, int varid, fvfile *vf, fgrid **grid,
                   sph_error *err)
{
    return grid_read(s, path, ncid_of(fh), varid, vf, grid, err);
}

static double att_double(int ncid, int varid, const char *name, double dflt)
{
    double v;
    size_t len;
    if (nc_inq_attlen(ncid, varid, name, &len) != NC_NOERR || len != 1 ||
        nc_get_att_double(ncid, varid, name, &v) != NC_NOERR)
        return dflt;
    return v;
}

static double default_fill(nc_type t)
{
    switch (t) {
    case NC_SHORT: return NC_FILL_SHORT;
    case NC_INT: return NC_FILL_INT;
    case NC_FLOAT: return NC_FILL_FLOAT;
    case NC_DOUBLE: return NC_FILL_DOUBLE;
    case NC_USHORT: return NC_FILL_USHORT;
    case NC_UINT: return NC_FILL_UINT;
    default: return NAN;
    }
}

/* Packing, missing values and units of one variable in one file. */
static int nc_packing(void *fh, int varid, fvfile *vf)
{
    int ncid = ncid_of(fh);
    nc_type vt;
    nc_inq_vartype(ncid, varid, &vt);
    vf->scale = att_double(ncid, varid, "scale_factor", 1.0);
    vf->offset = att_double(ncid, varid, "add_offset", 0.0);
    size_t len;
    nc_type at;
    vf->has_fill = 1;
    vf->fill = default_fill(vt);
    if (nc_inq_attlen(ncid, varid, "_FillValue", &len) == NC_NOERR)
        nc_get_att_double(ncid, varid, "_FillValue", &vf->fill);
    else if (isnan(vf->fill))
        vf->has_fill = 0;
    vf->nmiss = 0;
    if (nc_inq_attlen(ncid, varid, "missing_value", &len) == NC_NOERR && len >= 1 && len <= 4) {
        nc_inq_atttype(ncid, varid, "missing_value", &at);
        if (at != NC_CHAR && nc_get_att_double(ncid, varid, "missing_value", vf->miss) == NC_NOERR)
            vf->nmiss = (int)len;
    }
    vf->vmin = -INFINITY;
    vf->vmax = INFINITY;
    vf->valid_raw = 1;
    double r[2];
    if (nc_inq_att(ncid, varid, "valid_range", &at, &len) == NC_NOERR && len == 2 &&
        nc_get_att_double(ncid, varid, "valid_range", r) == NC_NOERR) {
        vf->vmin = r[0];
        vf->vmax = r[1];
        vf->valid_raw = at == vt; /* CF: in the packed type when the data are packed */
    } else {
        if (nc_inq_att(ncid, varid, "valid_min", &at, &len) == NC_NOERR) {
            vf->vmin = att_double(ncid, varid, "valid_min", -INFINITY);
            vf->valid_raw = at == vt;
        }
        if (nc_inq_att(ncid, varid, "valid_max", &at, &len) == NC_NOERR) {
            vf->vmax = att_double(ncid, varid, "valid_max", INFINITY);
            vf->valid_raw = at == vt;
        }
    }
    return fnc_text_att(ncid, varid, "units", vf->units, sizeof vf->units) != 0 ? -1 : 0;
}

/* ---- times ---- */

static int nc_times(fsource *s, const char *path, void *fh, int varid, const fvfile *vf,
                    forcing_timeinfo *ti, double *vals, sph_error *err)
{
    int ncid = ncid_of(fh);
    int dimids[NC_MAX_VAR_DIMS];
    nc_inq_vardimid(ncid, varid, dimids);
    char tname[NC_MAX_NAME + 1];
    size_t nt;
    nc_inq_dimname(ncid, dimids[vf->tdim], tname);
    nc_inq_dimlen(ncid, dimids[vf->tdim], &nt);
    int tv;
    if (nc_inq_varid(ncid, tname, &tv) != NC_NOERR)
        return forcing_fail(err, s, path, SPH_ERR_BAD_DATA,
                            "time dimension '%s' has no coordinate variable", tname);
    if (vals) {
        int rc = nc_get_var_double(ncid, tv, vals);
        if (rc != NC_NOERR)
            return forcing_fail(err, s, path, SPH_ERR_NETCDF,
                                "cannot read time variable '%s': %s", tname, nc_strerror(rc));
        return 0;
    }
    snprintf(ti->name, sizeof ti->name, "%s", tname);
    ti->n = nt;
    ti->calendar[0] = '\0';
    if (fnc_text_att(ncid, tv, "units", ti->units, sizeof ti->units) != 0)
        return forcing_fail(err, s, path, SPH_ERR_UNITS, "time variable '%s' has no units", tname);
    fnc_text_att(ncid, tv, "calendar", ti->calendar, sizeof ti->calendar);
    return 0;
}

/* ---- slices ---- */

static int nc_slice(fsource *s, const char *path, void *fh, const fvar *v, const fvfile *vf,
                    size_t k, size_t mi, double *raw, sph_error *err)
{
    size_t start[FORCING_MAX_DIMS], count[FORCING_MAX_DIMS];
    for (int d = 0; d < vf->ndims; d++) {
        start[d] = d == vf->merge_dim ? mi : vf->level[d];
        count[d] = 1;
    }
    if (vf->tdim >= 0)
        start[vf->tdim] = k;
    /* the read window: rows wj0.., columns wi0..; on a global grid a window across
     * the seam is two slabs, the columns up to the last and those from the first */
    const fgrid *g = v->grid;
    size_t n1 = g->wi0 + g->nx > g->fnx ? g->fnx - g->wi0 : g->nx;
    start[vf->ydim] = g->wj0;
    start[vf->xdim] = g->wi0;
    count[vf->ydim] = g->ny;
    count[vf->xdim] = n1;
    int rc;
    if (n1 == g->nx) {
        rc = nc_get_vara_double(ncid_of(fh), vf->varid, start, count, raw);
    } else if (vf->transpose) {
        /* x before y: each slab is a contiguous block of columns */
        rc = nc_get_vara_double(ncid_of(fh), vf->varid, start, count, raw);
        start[vf->xdim] = 0;
        count[vf->xdim] = g->nx - n1;
        if (rc == NC_NOERR)
            rc = nc_get_vara_double(ncid_of(fh), vf->varid, start, count, raw + n1 * g->ny);
    } else {
        double *tmp = malloc(g->nx * g->ny * sizeof *tmp);
        if (!tmp)
            return forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
        size_t n2 = g->nx - n1;
        rc = nc_get_vara_double(ncid_of(fh), vf->varid, start, count, tmp);
        start[vf->xdim] = 0;
        count[vf->xdim] = n2;
        if (rc == NC_NOERR)
            rc = nc_get_vara_double(ncid_of(fh), vf->varid, start, count, tmp + n1 * g->ny);
        for (size_t j = 0; rc == NC_NOERR && j < g->ny; j++) {
            memcpy(raw + j * g->nx, tmp + j * n1, n1 * sizeof *raw);
            memcpy(raw + j * g->nx + n1, tmp + n1 * g->ny + j * n2, n2 * sizeof *raw);
        }
        free(tmp);
    }
    if (rc != NC_NOERR)
        return forcing_fail(err, s, path, SPH_ERR_NETCDF,
                            "cannot read variable '%s' at time index %zu: %s", v->varname, k,
                            nc_strerror(rc));
    return 0;
}

/* ---- harmonic tides ---- */

static const struct {
    fv_slot w;
    const char *amp, *phase, *target;
    const char *std;
} tide_vars[] = {
    {FV_SSH, "h_amp", "h_phase", "m", "sea_surface_height"},
    {FV_UCUR, "u_amp", "u_phase", "m s-1", "eastward_sea_water_velocity"},
    {FV_VCUR, "v_amp", "v_phase", "m s-1", "northward_sea_water_velocity"},
};

/* Reads a (constituent, y, x) variable into [k][j*nx+i], fill -> NaN, with
 * a linear unit conversion. */
static int read_cube(fsource *s, const char *path, int ncid, int varid, const fvfile *vf,
                     size_t nc, size_t ny, size_t nx, double a, double b, double *out,
                     sph_error *err)
{
    char name[NC_MAX_NAME + 1] = "?";
    nc_inq_varname(ncid, varid, name);
    size_t n = nc * nx * ny;
    double *raw = malloc(n * sizeof *raw);
    if (!raw)
        return forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
    int rc = nc_get_var_double(ncid, varid, raw);
    if (rc != NC_NOERR) {
        free(raw);
        return forcing_fail(err, s, path, SPH_ERR_NETCDF, "cannot read '%s': %s", name,
                            nc_strerror(rc));
    }
    double fill = NC_FILL_FLOAT;
    nc_get_att_double(ncid, varid, "_FillValue", &fill);
    for (size_t k = 0; k < nc; k++)
        for (size_t j = 0; j < ny; j++)
            for (size_t i = 0; i < nx; i++) {
                double x = vf->transpose ? raw[(k * nx + i) * ny + j] : raw[(k * ny + j) * nx + i];
                if (x == fill || isnan(x)) {
                    if (isnan(x) && !isnan(fill)) {
                        free(raw);
                        return forcing_fail(err, s, path, SPH_ERR_BAD_DATA,
                                            "NaN in '%s' that is not the declared _FillValue",
                                            name);
                    }
                    x = NAN;
                } else {
                    x = a * x + b;
                }
                out[(k * ny + j) * nx + i] = x;
            }
    free(raw);
    return 0;
}

static int tide_open(fsource *s, int ncid, cf_units *units, double t_ref, int nodal,
                     unsigned required, sph_error *err)
{
    const char *path = s->paths[0];
    int dim, cvar;
    size_t nc, slen;
    if (nc_inq_dimid(ncid, "constituent", &dim) != NC_NOERR || nc_inq_dimlen(ncid, dim, &nc) ||
        nc_inq_varid(ncid, "constituent", &cvar) != NC_NOERR ||
        nc_inq_dimid(ncid, "name_strlen", &dim) != NC_NOERR || nc_inq_dimlen(ncid, dim, &slen))
        return forcing_fail(err, s, path, SPH_ERR_BAD_DATA,
                            "harmonic tide file lacks the 'constituent' variable or dimensions");
    char *names = calloc(nc * slen + 1, 1);
    int *index = malloc((nc ? nc : 1) * sizeof *index);
    double *cube = NULL, *phase = NULL;
    int rc = 0;
    if (!names || !index) {
        rc = forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
        goto done;
    }
    if (nc_get_var_text(ncid, cvar, names) != NC_NOERR) {
        rc = forcing_fail(err, s, path, SPH_ERR_NETCDF, "cannot read constituent names");
        goto done;
    }
    for (size_t k = 0; k < nc; k++) {
        char nm[16] = "";
        size_t l = slen < sizeof nm - 1 ? slen : sizeof nm - 1;
        memcpy(nm, names + k * slen, l);
        nm[l] = '\0';
        for (size_t c = strlen(nm); c > 0 && (nm[c - 1] == ' '); c--)
            nm[c - 1] = '\0';
        index[k] = tide_constituent_index(nm);
        if (index[k] < 0) {
            rc = forcing_fail(err, s, path, SPH_ERR_BAD_DATA, "unknown tidal constituent '%s'", nm);
            goto done;
        }
    }
    tide_args_init(&s->targs, t_ref, nodal);
    for (size_t q = 0; q < sizeof tide_vars / sizeof tide_vars[0]; q++) {
        int av, pv;
        if (nc_inq_varid(ncid, tide_vars[q].amp, &av) != NC_NOERR ||
            nc_inq_varid(ncid, tide_vars[q].phase, &pv) != NC_NOERR) {
            unsigned fl = tide_vars[q].w == FV_SSH ? FQ_SSH : FQ_CURRENT;
            if (required & fl) {
                rc = forcing_fail(err, s, path, SPH_ERR_MISSING_VAR,
                                  "harmonic tide variables '%s'/'%s' not found",
                                  tide_vars[q].amp, tide_vars[q].phase);
                goto done;
            }
            continue;
        }
        fvar *v = calloc(1, sizeof *v);
        if (!v || !(v->vfiles = calloc(1, sizeof *v->vfiles)) ||
            !(v->harm = calloc(1, sizeof *v->harm))) {
            if (v)
                free(v->vfiles);
            free(v);
            rc = forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
            goto done;
        }
        s->vars[tide_vars[q].w] = v;
        v->src = s;
        v->which = tide_vars[q].w;
        v->nvfiles = 1;
        v->vfiles[0].merge_dim = -1;
        v->slot_k[0] = v->slot_k[1] = (size_t)-1;
        snprintf(v->standard_name, sizeof v->standard_name, "%s", tide_vars[q].std);
        snprintf(v->varname, sizeof v->varname, "%s", tide_vars[q].amp);
        snprintf(v->file0, sizeof v->file0, "%s", path);
        if ((rc = grid_read(s, path, ncid, av, &v->vfiles[0], &v->grid, err)))
            goto done;
        v->grid_relative = 0; /* the format stores eastward/northward components */
        if (v->which == FV_UCUR || v->which == FV_VCUR)
            snprintf(v->orient, sizeof v->orient,
                     "earth-relative (a harmonic tide file holds east/north components)");
        char un[64] = "", pun[64] = "degree";
        double a = 1, b = 0, pa = 1, pb = 0;
        if (fnc_text_att(ncid, av, "units", un, sizeof un) != 0 ||
            cf_units_linear(units, un, tide_vars[q].target, &a, &b) != 0) {
            rc = forcing_fail(err, s, path, SPH_ERR_UNITS,
                              "units '%s' of '%s' missing or not convertible to '%s'", un,
                              tide_vars[q].amp, tide_vars[q].target);
            goto done;
        }
        snprintf(v->units, sizeof v->units, "%s", un);
        fnc_text_att(ncid, pv, "units", pun, sizeof pun);
        if (cf_units_linear(units, pun, "degree", &pa, &pb) != 0) {
            rc = forcing_fail(err, s, path, SPH_ERR_UNITS, "units '%s' of '%s' are not an angle",
                              pun, tide_vars[q].phase);
            goto done;
        }
        size_t nx = v->grid->nx, ny = v->grid->ny, nn = nx * ny;
        free(cube);
        free(phase);
        cube = malloc(nc * nn * sizeof *cube);
        phase = malloc(nc * nn * sizeof *phase);
        if (!cube || !phase) {
            rc = forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
            goto done;
        }
        if ((rc = read_cube(s, path, ncid, av, &v->vfiles[0], nc, ny, nx, a, b, cube, err)) ||
            (rc = read_cube(s, path, ncid, pv, &v->vfiles[0], nc, ny, nx, pa, pb, phase, err)))
            goto done;
        if ((rc = ftide_constants(s, v, index, nc, cube, phase, err)))
            goto done;
    }
    if (s->vars[FV_UCUR] && !s->vars[FV_VCUR]) {
        rc = forcing_fail(err, s, path, SPH_ERR_MISSING_VAR, "u_amp found but not v_amp");
        goto done;
    }
done:
    free(names);
    free(index);
    free(cube);
    free(phase);
    return rc;
}

static int nc_tide(fsource *s, int *harmonic, cf_units *units, double t_ref, int nodal,
                   unsigned required, sph_error *err)
{
    *harmonic = 0;
    int ncid;
    sph_error e;
    sph_error_clear(&e);
    if (nc_guard_check(s->paths[0], s->paths[0], &e)) /* io/nc_guard.h */
        return sph_err_set(err, e.code, "forcing '%s': %s", s->name, e.msg);
    int rc = nc_guard_nc_open(s->paths[0], &ncid);
    if (rc != NC_NOERR)
        return forcing_fail(err, s, s->paths[0], SPH_ERR_NETCDF, "cannot open: %s",
                            nc_strerror(rc));
    char fmt[64];
    if (fnc_text_att(ncid, NC_GLOBAL, "sphice_tide_format", fmt, sizeof fmt) == 0) {
        *harmonic = 1;
        if (strcmp(fmt, "harmonic-1") != 0)
            rc = forcing_fail(err, s, s->paths[0], SPH_ERR_BAD_DATA,
                              "unknown sphice_tide_format '%s' (expected 'harmonic-1')", fmt);
        else
            rc = tide_open(s, ncid, units, t_ref, nodal, required, err);
    }
    nc_close(ncid);
    return rc;
}

const forcing_driver forcing_driver_netcdf = {
    .name = "netcdf",
    .probe = nc_probe,
    .open = nc_open_file,
    .close = nc_close_file,
    .variables = nc_variables,
    .grid = nc_grid,
    .levels = nc_levels,
    .packing = nc_packing,
    .times = nc_times,
    .slice = nc_slice,
    .tide = nc_tide,
};
