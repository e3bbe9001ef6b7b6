/* Writes small CF NetCDF forcing files for the forcing tests with the
 * netCDF API. Values come from analytic fields given by the test. */
#ifndef SPHICE_TESTS_FORCING_NC_H
#define SPHICE_TESTS_FORCING_NC_H

#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define NCW(call)                                                                   \
    do {                                                                            \
        int rc_ = (call);                                                           \
        if (rc_ != NC_NOERR) {                                                      \
            fprintf(stderr, "%s:%d: %s: %s\n", __FILE__, __LINE__, #call,           \
                    nc_strerror(rc_));                                              \
            exit(2);                                                                \
        }                                                                           \
    } while (0)

typedef struct tgrid {
    size_t nx, ny, nt;
    double lon0, dlon, lat0, dlat; /* regular: node (i, j) = (lon0 + i dlon, lat0 + j dlat) */
    int lon360;                    /* store longitudes in 0..360 */
    int swap;                      /* dimension order (time, lon, lat) instead of (time, lat, lon) */
    int curvilinear;               /* 2-D lat/lon from the rotation below */
    double rot_deg, clat;          /* curvilinear: rotation and centre latitude */
    int angle_var;                 /* write angle(y, x) in radians */
    int depth;                     /* levels of a depth dimension after time (0: none) */
    int zkind;                     /* its coordinate: 0 none, 1 depth positive down from
                                      0.49 m, 2 ROMS s_rho (-1..0, surface last),
                                      3 air pressure in hPa, ascending (surface last) */
    const char *time_units, *calendar;
    double tv0, dtv;               /* time coordinate values tv0 + k dtv */
} tgrid;

/* The level that holds the field; the others hold it + 50. */
static inline int tgrid_surface(const tgrid *g)
{
    return g->zkind == 2 || g->zkind == 3 ? g->depth - 1 : 0;
}

/* Node coordinates. Curvilinear: local east/north offsets (degrees of
 * latitude) rotated by rot_deg; lon = E / cos(clat), lat = clat + N. */
static inline void tgrid_node(const tgrid *g, size_t i, size_t j, double *lon, double *lat)
{
    if (!g->curvilinear) {
        *lon = g->lon0 + (double)i * g->dlon;
        *lat = g->lat0 + (double)j * g->dlat;
        return;
    }
    double a = g->rot_deg * M_PI / 180.0;
    double x = ((double)i - (double)(g->nx - 1) / 2) * g->dlon;
    double y = ((double)j - (double)(g->ny - 1) / 2) * g->dlat;
    double E = x * cos(a) - y * sin(a), N = x * sin(a) + y * cos(a);
    *lon = g->lon0 + E / cos(g->clat * M_PI / 180.0);
    *lat = g->clat + N;
}

typedef struct tvar {
    const char *name, *standard_name, *units;
    nc_type type;          /* NC_FLOAT, NC_DOUBLE or NC_SHORT (packed) */
    double scale, offset;  /* NC_SHORT */
    int has_fill;
    double fill;
    int fill_att_missing;  /* write the fill as missing_value instead of _FillValue */
    /* value in file units at node (lon, lat) and time index k; NAN = missing */
    double (*fn)(int which, double lon, double lat, size_t k);
    int which;
} tvar;

static inline void tnc_write(const char *path, const tgrid *g, const tvar *vars, size_t nvars,
                             size_t kfirst, size_t nt, int fmt)
{
    int nc, dt, dx, dy, dz = -1, vt;
    NCW(nc_create(path, NC_CLOBBER | fmt, &nc));
    NCW(nc_def_dim(nc, "time", NC_UNLIMITED, &dt));
    const char *xn = g->curvilinear ? "x" : "lon", *yn = g->curvilinear ? "y" : "lat";
    NCW(nc_def_dim(nc, xn, g->nx, &dx));
    NCW(nc_def_dim(nc, yn, g->ny, &dy));
    int vz = -1;
    if (g->depth) {
        static const char *zn[] = {"depth", "depth", "s_rho", "plev"};
        NCW(nc_def_dim(nc, zn[g->zkind], (size_t)g->depth, &dz));
        if (g->zkind > 0)
            NCW(nc_def_var(nc, zn[g->zkind], NC_DOUBLE, 1, &dz, &vz));
        if (g->zkind == 1) {
            NCW(nc_put_att_text(nc, vz, "units", 1, "m"));
            NCW(nc_put_att_text(nc, vz, "positive", 4, "down"));
        } else if (g->zkind == 2) {
            NCW(nc_put_att_text(nc, vz, "standard_name", 21, "ocean_s_coordinate_g2"));
            NCW(nc_put_att_text(nc, vz, "positive", 2, "up"));
        } else if (g->zkind == 3) {
            NCW(nc_put_att_text(nc, vz, "units", 3, "hPa"));
        }
    }
    NCW(nc_def_var(nc, "time", NC_DOUBLE, 1, &dt, &vt));
    NCW(nc_put_att_text(nc, vt, "units", strlen(g->time_units), g->time_units));
    if (g->calendar)
        NCW(nc_put_att_text(nc, vt, "calendar", strlen(g->calendar), g->calendar));
    int vlon, vlat, vang = -1;
    int d2[2] = {dy, dx};
    if (g->curvilinear) {
        NCW(nc_def_var(nc, "nav_lon", NC_DOUBLE, 2, d2, &vlon));
        NCW(nc_def_var(nc, "nav_lat", NC_DOUBLE, 2, d2, &vlat));
        if (g->angle_var) {
            NCW(nc_def_var(nc, "angle", NC_DOUBLE, 2, d2, &vang));
            NCW(nc_put_att_text(nc, vang, "units", 7, "radians"));
        }
    } else {
        NCW(nc_def_var(nc, "lon", NC_DOUBLE, 1, &dx, &vlon));
        NCW(nc_def_var(nc, "lat", NC_DOUBLE, 1, &dy, &vlat));
    }
    NCW(nc_put_att_text(nc, vlon, "standard_name", 9, "longitude"));
    NCW(nc_put_att_text(nc, vlon, "units", 12, "degrees_east"));
    NCW(nc_put_att_text(nc, vlat, "standard_name", 8, "latitude"));
    NCW(nc_put_att_text(nc, vlat, "units", 13, "degrees_north"));
    int *ids = calloc(nvars, sizeof *ids);
    for (size_t v = 0; v < nvars; v++) {
        int dims[4], nd = 0;
        dims[nd++] = dt;
        if (g->depth)
            dims[nd++] = dz;
        if (g->swap && !g->curvilinear) {
            dims[nd++] = dx;
            dims[nd++] = dy;
        } else {
            dims[nd++] = dy;
            dims[nd++] = dx;
        }
        NCW(nc_def_var(nc, vars[v].name, vars[v].type, nd, dims, &ids[v]));
        if (vars[v].standard_name)
            NCW(nc_put_att_text(nc, ids[v], "standard_name", strlen(vars[v].standard_name),
                                vars[v].standard_name));
        if (vars[v].units)
            NCW(nc_put_att_text(nc, ids[v], "units", strlen(vars[v].units), vars[v].units));
        if (vars[v].type == NC_SHORT) {
            NCW(nc_put_att_double(nc, ids[v], "scale_factor", NC_DOUBLE, 1, &vars[v].scale));
            NCW(nc_put_att_double(nc, ids[v], "add_offset", NC_DOUBLE, 1, &vars[v].offset));
        }
        if (vars[v].has_fill)
            NCW(nc_put_att_double(nc, ids[v],
                                  vars[v].fill_att_missing ? "missing_value" : "_FillValue",
                                  vars[v].type, 1, &vars[v].fill));
        if (g->curvilinear)
            NCW(nc_put_att_text(nc, ids[v], "coordinates", 15, "nav_lon nav_lat"));
    }
    NCW(nc_enddef(nc));
    if (vz >= 0)
        for (size_t z = 0; z < (size_t)g->depth; z++) {
            double zv = g->zkind == 1   ? 0.494 * pow(3.0, (double)z)
                        : g->zkind == 2 ? -1.0 + ((double)z + 0.5) / g->depth
                                        : 1000.0 - 150.0 * (double)(g->depth - 1 - (int)z);
            NCW(nc_put_var1_double(nc, vz, &z, &zv));
        }
    size_t n = g->nx * g->ny;
    double *lon = malloc(n * sizeof *lon), *lat = malloc(n * sizeof *lat);
    for (size_t j = 0; j < g->ny; j++)
        for (size_t i = 0; i < g->nx; i++)
            tgrid_node(g, i, j, &lon[j * g->nx + i], &lat[j * g->nx + i]);
    if (g->curvilinear) {
        NCW(nc_put_var_double(nc, vlon, lon));
        NCW(nc_put_var_double(nc, vlat, lat));
        if (vang >= 0) {
            double *ang = malloc(n * sizeof *ang);
            for (size_t p = 0; p < n; p++)
                ang[p] = g->rot_deg * M_PI / 180.0;
            NCW(nc_put_var_double(nc, vang, ang));
            free(ang);
        }
    } else {
        double *l1 = malloc(g->nx * sizeof *l1), *b1 = malloc(g->ny * sizeof *b1);
        for (size_t i = 0; i < g->nx; i++) {
            l1[i] = lon[i];
            if (g->lon360 && l1[i] < 0)
                l1[i] += 360.0;
        }
        for (size_t j = 0; j < g->ny; j++)
            b1[j] = lat[j * g->nx];
        NCW(nc_put_var_double(nc, vlon, l1));
        NCW(nc_put_var_double(nc, vlat, b1));
        free(l1);
        free(b1);
    }
    double *buf = malloc(n * sizeof *buf);
    for (size_t k = 0; k < nt; k++) {
        size_t kk = kfirst + k;
        double tv = g->tv0 + (double)kk * g->dtv;
        size_t st1 = k;
        NCW(nc_put_var1_double(nc, vt, &st1, &tv));
        for (size_t v = 0; v < nvars; v++) {
            for (size_t j = 0; j < g->ny; j++)
                for (size_t i = 0; i < g->nx; i++) {
                    double x = vars[v].fn(vars[v].which, lon[j * g->nx + i], lat[j * g->nx + i], kk);
                    if (isnan(x) && vars[v].has_fill)
                        x = vars[v].fill;
                    else if (vars[v].type == NC_SHORT)
                        x = round((x - vars[v].offset) / vars[v].scale);
                    size_t q = g->swap && !g->curvilinear ? i * g->ny + j : j * g->nx + i;
                    buf[q] = x;
                }
            for (int z = 0; z < (g->depth ? g->depth : 1); z++) {
                size_t start[4] = {k, 0, 0, 0}, count[4] = {1, 1, 1, 1};
                int nd = 0;
                start[nd] = k;
                count[nd++] = 1;
                if (g->depth) {
                    start[nd] = (size_t)z;
                    count[nd++] = 1;
                }
                size_t a = g->swap && !g->curvilinear ? g->nx : g->ny;
                size_t b = g->swap && !g->curvilinear ? g->ny : g->nx;
                start[nd] = 0;
                count[nd++] = a;
                start[nd] = 0;
                count[nd++] = b;
                /* levels other than the surface: the field + 50 (packed: 50 / scale) */
                double off = z == tgrid_surface(g) ? 0.0
                             : vars[v].type == NC_SHORT ? 50.0 / vars[v].scale : 50.0;
                int fl = vars[v].has_fill;
                for (size_t q = 0; q < n && off != 0.0; q++)
                    if (!fl || buf[q] != vars[v].fill)
                        buf[q] += off;
                NCW(nc_put_vara_double(nc, ids[v], start, count, buf));
                for (size_t q = 0; q < n && off != 0.0; q++)
                    if (!fl || buf[q] != vars[v].fill)
                        buf[q] -= off;
            }
        }
    }
    free(buf);
    free(lon);
    free(lat);
    free(ids);
    NCW(nc_close(nc));
}

#endif
