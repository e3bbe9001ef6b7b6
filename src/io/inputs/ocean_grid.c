/* A curvilinear ocean grid from one of the ocean model's files: see
 * io/ocean_grid.h. */
#include "io/ocean_grid.h"

#include <math.h>
#include <netcdf.h>
#include <proj.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "io/cf_mapping.h"
#include "io/geo.h"
#include "io/landmask.h"

#define OG_R 6371000.0
#define OG_D2R (M_PI / 180.0)

void ocean_grid_free(ocean_grid *g)
{
    if (g) {
        void *owned[] = {g->lon, g->lat, g->blon, g->blat, g->area, g->land, g};
        for (size_t k = 0; k < sizeof owned / sizeof owned[0]; k++)
            free(owned[k]);
    }
}

/* The text attribute `name` of variable v into buf; 1 when it is there. */
static int og_att(int nc, int v, const char *name, char *buf, size_t cap)
{
    size_t len = 0;
    nc_type t;
    buf[0] = '\0';
    if (nc_inq_att(nc, v, name, &t, &len) != NC_NOERR || t != NC_CHAR || len + 1 > cap ||
        nc_get_att_text(nc, v, name, buf) != NC_NOERR)
        return 0;
    buf[len] = '\0';
    return 1;
}

/* 1 longitude, 2 latitude, 0 neither: standard_name, else units. */
static int og_kind(int nc, int v)
{
    char s[80];
    if (og_att(nc, v, "standard_name", s, sizeof s) && s[0])
        return !strcmp(s, "longitude") ? 1 : !strcmp(s, "latitude") ? 2 : 0;
    if (!og_att(nc, v, "units", s, sizeof s))
        return 0;
    if (!strncmp(s, "degree", 6) && (strchr(s + 6, 'E') || strstr(s + 6, "east")))
        return 1;
    if (!strncmp(s, "degree", 6) && (strchr(s + 6, 'N') || strstr(s + 6, "north")))
        return 2;
    return 0;
}

/* Variable `name` when it has two dimensions (into d[2]), else -1. */
static int og_2d(int nc, const char *name, int d[2])
{
    int v, nd = 0;
    if (nc_inq_varid(nc, name, &v) != NC_NOERR || nc_inq_varndims(nc, v, &nd) != NC_NOERR || nd != 2)
        return -1;
    nc_inq_vardimid(nc, v, d);
    return v;
}

/* The 2-D centres: *vlon, *vlat; data: the variable that led there (or the
 * first with two or more dimensions, for messages). 0 found. */
static int find_centres(int nc, int *vlon, int *vlat, char *data, size_t dlen, char *why, size_t wlen)
{
    int d1[2], d2[2], nvars = 0;
    data[0] = '\0';
    nc_inq_nvars(nc, &nvars);
    if ((*vlon = og_2d(nc, "lon_rho", d1)) >= 0 && (*vlat = og_2d(nc, "lat_rho", d2)) >= 0 && d1[0] == d2[0] &&
        d1[1] == d2[1]) {
        snprintf(data, dlen, "lon_rho");
        return 0;
    }
    for (int v = 0; v < nvars; v++) {
        char co[1024], *save = NULL, name[NC_MAX_NAME + 1];
        if (!og_att(nc, v, "coordinates", co, sizeof co))
            continue;
        *vlon = *vlat = -1;
        for (char *t = strtok_r(co, " ", &save); t; t = strtok_r(NULL, " ", &save)) {
            int d[2], w = og_2d(nc, t, d), k = w >= 0 ? og_kind(nc, w) : 0;
            if (k == 1)
                *vlon = w, d1[0] = d[0], d1[1] = d[1];
            else if (k == 2)
                *vlat = w, d2[0] = d[0], d2[1] = d[1];
        }
        if (*vlon >= 0 && *vlat >= 0 && d1[0] == d2[0] && d1[1] == d2[1]) {
            nc_inq_varname(nc, v, name);
            snprintf(data, dlen, "%s", name);
            return 0;
        }
    }
    if ((*vlon = og_2d(nc, "nav_lon", d1)) >= 0 && (*vlat = og_2d(nc, "nav_lat", d2)) >= 0 && d1[0] == d2[0] &&
        d1[1] == d2[1]) {
        snprintf(data, dlen, "nav_lon");
        return 0;
    }
    /* not understood: say why, naming a variable */
    for (int v = 0; v < nvars; v++) {
        char gm[NC_MAX_NAME + 1], gmn[128] = "", name[NC_MAX_NAME + 1];
        int g, nd = 0;
        nc_inq_varndims(nc, v, &nd);
        if (nd < 2)
            continue;
        nc_inq_varname(nc, v, name);
        if (!data[0])
            snprintf(data, dlen, "%s", name);
        if (!og_att(nc, v, "grid_mapping", gm, sizeof gm))
            continue;
        snprintf(data, dlen, "%s", name);
        if (nc_inq_varid(nc, gm, &g) == NC_NOERR)
            og_att(nc, g, "grid_mapping_name", gmn, sizeof gmn);
        snprintf(why, wlen, "has grid_mapping \"%.64s\" (grid_mapping_name \"%.64s\") but no 2-D latitude/longitude "
                 "that its coordinates attribute names: the cells' positions are not read from a mapping alone",
                 gm, gmn[0] ? gmn : "none");
        return -1;
    }
    snprintf(why, wlen, "has no coordinates attribute naming 2-D latitude/longitude, and the file has no "
             "lon_rho/lat_rho or nav_lon/nav_lat and no grid_mapping");
    return -2;
}

/* A grid given by its mapping alone: 1-D x/y coordinates and the data
 * variable's CF grid_mapping. kind 1: a projection (PROJ definition; x/y
 * in metres times fac); kind 2: a rotated pole (rotated_latitude_longitude;
 * grid_longitude/grid_latitude in degrees), turned by hand: a rotation of
 * the sphere. */
typedef struct og_map {
    int kind;
    geo_proj *p;
    double fac;             /* metres per unit of x/y (projection) */
    cf_rotated_pole rp;     /* rotated pole */
    double *x, *y;          /* [nx], [ny] the centres' coordinates, file units */
    char def[4096];         /* the PROJ definition (projection) */
    char xvar[64], yvar[64], gmvar[64], gmname[64];
} og_map;

static void unit(double lon, double lat, double *u)
{
    u[0] = cos(lat * OG_D2R) * cos(lon * OG_D2R);
    u[1] = cos(lat * OG_D2R) * sin(lon * OG_D2R);
    u[2] = sin(lat * OG_D2R);
}

static double near_lon(double lon, double ref)
{
    return lon - 360.0 * round((lon - ref) / 360.0);
}

/* Spherical excess of the triangle a, b, c (unit vectors). */
static double excess(const double *a, const double *b, const double *c)
{
    double bc[3] = {b[1] * c[2] - b[2] * c[1], b[2] * c[0] - b[0] * c[2], b[0] * c[1] - b[1] * c[0]};
    double t = a[0] * bc[0] + a[1] * bc[1] + a[2] * bc[2];
    double d = 1.0 + (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) + (b[0] * c[0] + b[1] * c[1] + b[2] * c[2]) +
               (c[0] * a[0] + c[1] * a[1] + c[2] * a[2]);
    return 2.0 * atan2(fabs(t), d);
}

/* Reads the (ny x nx) rectangle at (j0, i0) of a 2-D variable into out. */
static int get_rect(int nc, int v, int j0, int i0, int ny, int nx, double *out)
{
    size_t st[2] = {(size_t)j0, (size_t)i0}, ct[2] = {(size_t)ny, (size_t)nx};
    return nc_get_vara_double(nc, v, st, ct, out);
}

typedef struct {
    int nc, nxf, nyf, dims[2];
    const char *path, *key;
    sph_error *err;
} og_ctx;

static int fail(og_ctx *c, const char *var, const char *what)
{
    return sph_err_set(c->err, SPH_ERR_BAD_DATA, "%s: %s: variable %s %s: set %s to \"output\"", c->key, c->path,
                       var, what, c->key);
}

/* The corners of the kept cells from CF bounds: 1 done, 0 no bounds, < 0 error. */
static int corners_from_bounds(og_ctx *c, int vlon, int vlat, ocean_grid *g)
{
    char bl[NC_MAX_NAME + 1], bt[NC_MAX_NAME + 1];
    int hl = og_att(c->nc, vlon, "bounds", bl, sizeof bl), ht = og_att(c->nc, vlat, "bounds", bt, sizeof bt);
    if (!hl && !ht)
        return 0;
    char ln[NC_MAX_NAME + 1];
    nc_inq_varname(c->nc, hl ? vlat : vlon, ln);
    if (!hl || !ht)
        return -fail(c, ln, "has no bounds attribute while the other coordinate has one");
    int v[2], nd, d[3];
    const char *bn[2] = {bl, bt};
    for (int k = 0; k < 2; k++) {
        size_t four = 0;
        if (nc_inq_varid(c->nc, bn[k], &v[k]) != NC_NOERR || nc_inq_varndims(c->nc, v[k], &nd) != NC_NOERR ||
            nd != 3 || nc_inq_vardimid(c->nc, v[k], d) != NC_NOERR || d[0] != c->dims[0] || d[1] != c->dims[1] ||
            nc_inq_dimlen(c->nc, d[2], &four) != NC_NOERR || four != 4)
            return -fail(c, bn[k], "(the bounds of the cell centres) is missing or not (y, x, 4)");
        size_t st[3] = {(size_t)g->j0, (size_t)g->i0, 0}, ct[3] = {(size_t)g->ny, (size_t)g->nx, 4};
        if (nc_get_vara_double(c->nc, v[k], st, ct, k ? g->blat : g->blon) != NC_NOERR)
            return -fail(c, bn[k], "cannot be read");
    }
    snprintf(g->corners, sizeof g->corners, "CF bounds %.64s / %.64s", bl, bt);
    return 1;
}

/* Corners at the midpoints of the four surrounding centres (on the
 * sphere), from the kept rectangle and one ring of neighbours; the file's
 * edge extrapolated by half a cell. lon/lat: the whole file's centres. */
static int corners_from_centres(og_ctx *c, const double *lon, const double *lat, ocean_grid *g)
{
    int a0 = g->i0 > 0 ? g->i0 - 1 : 0, b0 = g->j0 > 0 ? g->j0 - 1 : 0;
    int a1 = g->i0 + g->nx < c->nxf ? g->i0 + g->nx : c->nxf - 1, b1 = g->j0 + g->ny < c->nyf ? g->j0 + g->ny : c->nyf - 1;
    int ex = a1 - a0 + 3, ey = b1 - b0 + 3; /* the ring plus extrapolated edges */
    double *E = malloc((size_t)ex * (size_t)ey * 3 * sizeof *E);
    if (!E)
        return sph_err_set(c->err, SPH_ERR_NOMEM, "%s: %s: out of memory (grid corners)", c->key, c->path);
#define EP(j, i) (E + 3 * ((size_t)(j) * (size_t)ex + (size_t)(i)))
    for (int j = b0; j <= b1; j++)
        for (int i = a0; i <= a1; i++) {
            size_t f = (size_t)j * c->nxf + i;
            unit(lon[f], lat[f], EP(j - b0 + 1, i - a0 + 1));
        }
    for (int j = 1; j < ey - 1; j++) /* the west and east edges */
        for (int q = 0; q < 3; q++) {
            EP(j, 0)[q] = 2.0 * EP(j, 1)[q] - EP(j, 2)[q];
            EP(j, ex - 1)[q] = 2.0 * EP(j, ex - 2)[q] - EP(j, ex - 3)[q];
        }
    for (int i = 0; i < ex; i++) /* south and north, corners included */
        for (int q = 0; q < 3; q++) {
            EP(0, i)[q] = 2.0 * EP(1, i)[q] - EP(2, i)[q];
            EP(ey - 1, i)[q] = 2.0 * EP(ey - 2, i)[q] - EP(ey - 3, i)[q];
        }
    static const int off[4][2] = {{0, 0}, {0, 1}, {1, 1}, {1, 0}}; /* (dj, di) of the corner's upper-right centre */
    for (int j = 0; j < g->ny; j++)
        for (int i = 0; i < g->nx; i++) {
            size_t k = (size_t)j * g->nx + i;
            int je = g->j0 + j - b0 + 1, ie = g->i0 + i - a0 + 1; /* the cell in E */
            for (int v = 0; v < 4; v++) {
                int jj = je + off[v][0], ii = ie + off[v][1]; /* corner between (jj-1..jj, ii-1..ii) */
                double s[3];
                for (int q = 0; q < 3; q++)
                    s[q] = EP(jj - 1, ii - 1)[q] + EP(jj - 1, ii)[q] + EP(jj, ii - 1)[q] + EP(jj, ii)[q];
                g->blat[4 * k + v] = atan2(s[2], hypot(s[0], s[1])) / OG_D2R;
                g->blon[4 * k + v] = atan2(s[1], s[0]) / OG_D2R;
            }
        }
#undef EP
    free(E);
    snprintf(g->corners, sizeof g->corners, "midpoints of the four surrounding cell centres (the file has no "
             "bounds), half a cell beyond the outer centres at the grid's edge");
    return SPH_OK;
}

static int mapped_areas(og_ctx *c, const og_map *m, ocean_grid *g);
/* Cell areas of the kept cells (m: the mapping of a mapped grid, else NULL). */
static int areas(og_ctx *c, ocean_grid *g, const og_map *m)
{
    static const char *const pairs[][2] = {{"pm", "pn"}, {"e1t", "e2t"}};
    size_t n = (size_t)g->nx * g->ny;
    double *b = malloc(n * sizeof *b);
    if (!b)
        return sph_err_set(c->err, SPH_ERR_NOMEM, "%s: %s: out of memory", c->key, c->path);
    int done = 0, rc = SPH_OK;
    for (int p = 0; p < 2 && !done; p++) {
        int d1[2], d2[2], v1 = og_2d(c->nc, pairs[p][0], d1), v2 = og_2d(c->nc, pairs[p][1], d2);
        if (v1 < 0 || v2 < 0 || d1[0] != c->dims[0] || d1[1] != c->dims[1] || d2[0] != c->dims[0] ||
            d2[1] != c->dims[1])
            continue;
        if (get_rect(c->nc, v1, g->j0, g->i0, g->ny, g->nx, g->area) != NC_NOERR ||
            get_rect(c->nc, v2, g->j0, g->i0, g->ny, g->nx, b) != NC_NOERR) {
            rc = fail(c, pairs[p][0], "cannot be read");
            break;
        }
        for (size_t k = 0; k < n; k++)
            g->area[k] = p == 0 ? 1.0 / (g->area[k] * b[k]) : g->area[k] * b[k];
        snprintf(g->area_from, sizeof g->area_from, p == 0 ? "1 / (pm pn)" : "e1t e2t");
        done = 1;
    }
    int nvars = 0;
    nc_inq_nvars(c->nc, &nvars);
    for (int v = 0; v < nvars && !done && rc == SPH_OK; v++) {
        char s[64], name[NC_MAX_NAME + 1];
        int nd = 0, d[2];
        if (!og_att(c->nc, v, "standard_name", s, sizeof s) || strcmp(s, "cell_area") ||
            nc_inq_varndims(c->nc, v, &nd) != NC_NOERR || nd != 2)
            continue;
        nc_inq_vardimid(c->nc, v, d);
        if (d[0] != c->dims[0] || d[1] != c->dims[1])
            continue;
        nc_inq_varname(c->nc, v, name);
        if (get_rect(c->nc, v, g->j0, g->i0, g->ny, g->nx, g->area) != NC_NOERR)
            rc = fail(c, name, "cannot be read");
        snprintf(g->area_from, sizeof g->area_from, "%.64s (cell_area)", name);
        done = 1;
    }
    if (!done && rc == SPH_OK && m) {
        rc = mapped_areas(c, m, g);
        done = 1;
    }
    if (!done && rc == SPH_OK) {
        for (size_t k = 0; k < n; k++) {
            double u[4][3];
            for (int v = 0; v < 4; v++)
                unit(g->blon[4 * k + v], g->blat[4 * k + v], u[v]);
            g->area[k] = OG_R * OG_R * (excess(u[0], u[1], u[2]) + excess(u[0], u[2], u[3]));
        }
        snprintf(g->area_from, sizeof g->area_from, "the corner polygon on the sphere of radius 6371 km");
    }
    for (size_t k = 0; k < n && rc == SPH_OK; k++)
        if (!(g->area[k] > 0.0) || !isfinite(g->area[k])) {
            char what[160];
            snprintf(what, sizeof what, "gives cell (i %d, j %d) the area %g m2", g->i0 + (int)(k % g->nx),
                     g->j0 + (int)(k / g->nx), g->area[k]);
            rc = fail(c, g->area_from, what);
        }
    free(b);
    return rc;
}


static void map_free(og_map *m)
{
    geo_proj_free(m->p);
    free(m->x);
    free(m->y);
}

/* 1-D coordinate variable of dimension dim (the variable named as it) with
 * standard_name sn, else axis ax; -1 none. */
static int og_axis(int nc, int dim, const char *sn, const char *ax)
{
    char dn[NC_MAX_NAME + 1], buf[80];
    int v, nd = 0;
    if (nc_inq_dimname(nc, dim, dn) != NC_NOERR || nc_inq_varid(nc, dn, &v) != NC_NOERR ||
        nc_inq_varndims(nc, v, &nd) != NC_NOERR || nd != 1)
        return -1;
    if (og_att(nc, v, "standard_name", buf, sizeof buf) && buf[0])
        return strcmp(buf, sn) == 0 ? v : -1;
    return og_att(nc, v, "axis", buf, sizeof buf) && strcmp(buf, ax) == 0 ? v : -1;
}

/* (x, y) in the file's units to longitude/latitude, n points. */
static int map_to_lonlat(const og_map *m, size_t n, const double *x, const double *y, double *lon, double *lat,
                         sph_error *err)
{
    if (m->kind == 1) {
        double *X = malloc(2 * n * sizeof *X);
        if (!X)
            return sph_err_set(err, SPH_ERR_NOMEM, "out of memory");
        for (size_t k = 0; k < n; k++) {
            X[k] = x[k] * m->fac;
            X[n + k] = y[k] * m->fac;
        }
        sph_error local;
        sph_error_clear(&local);
        geo_inverse(m->p, n, X, X + n, lon, lat, &local);
        free(X);
        return SPH_OK; /* points that do not unproject stay NaN and are refused by the caller */
    }
    for (size_t k = 0; k < n; k++)
        cf_rotated_to_geo(&m->rp, x[k], y[k], &lon[k], &lat[k], NULL);
    return SPH_OK;
}

/* The mapping of data variable v (named data) with grid_mapping gm: the
 * centres of all cells (lon, lat [ny x nx], allocated), the dimensions
 * (dims: y, x). 0; else an error naming the file, the variable and key. */
static int mapped_centres(og_ctx *c, int v, const char *data, og_map *m, double **lon, double **lat, size_t *nx,
                          size_t *ny)
{
    char gm[NC_MAX_NAME + 1], why[480];
    int g, nd = 0, d[NC_MAX_VAR_DIMS];
    og_att(c->nc, v, "grid_mapping", gm, sizeof gm);
    snprintf(m->gmvar, sizeof m->gmvar, "%.63s", gm);
    if (nc_inq_varid(c->nc, gm, &g) != NC_NOERR)
        return sph_err_set(c->err, SPH_ERR_BAD_DATA, "%s: %s: variable %s: its grid_mapping \"%s\" is not a variable "
                           "of the file: set %s to \"output\"", c->key, c->path, data, gm, c->key);
    og_att(c->nc, g, "grid_mapping_name", m->gmname, sizeof m->gmname);
    nc_inq_varndims(c->nc, v, &nd);
    nc_inq_vardimid(c->nc, v, d);
    int rot = strcmp(m->gmname, "rotated_latitude_longitude") == 0;
    const char *sx = rot ? "grid_longitude" : "projection_x_coordinate";
    const char *sy = rot ? "grid_latitude" : "projection_y_coordinate";
    int xv = nd >= 2 ? og_axis(c->nc, d[nd - 1], sx, "X") : -1, yv = nd >= 2 ? og_axis(c->nc, d[nd - 2], sy, "Y") : -1;
    if (xv < 0 || yv < 0)
        return sph_err_set(c->err, SPH_ERR_BAD_DATA, "%s: %s: variable %s: grid_mapping \"%s\" (%s) but its last two "
                           "dimensions (y, x) have no 1-D coordinates with standard_name %s and %s: set %s to "
                           "\"output\"", c->key, c->path, data, gm, m->gmname[0] ? m->gmname : "no grid_mapping_name",
                           sy, sx, c->key);
    nc_inq_varname(c->nc, xv, m->xvar);
    nc_inq_varname(c->nc, yv, m->yvar);
    c->dims[0] = d[nd - 2];
    c->dims[1] = d[nd - 1];
    nc_inq_dimlen(c->nc, c->dims[1], nx);
    nc_inq_dimlen(c->nc, c->dims[0], ny);
    if (rot) {
        m->kind = 2;
        m->fac = 1.0;
        if (cf_rotated_pole_read(c->nc, g, &m->rp, why, sizeof why) != 0)
            return sph_err_set(c->err, SPH_ERR_BAD_DATA, "%s: %s: variable %s: grid mapping %s %s: set %s to "
                               "\"output\"", c->key, c->path, data, gm, why, c->key);
    } else {
        char *def = m->def, u[64] = "";
        if (cf_mapping_proj(c->nc, g, def, sizeof m->def, why, sizeof why) != 0)
            return sph_err_set(c->err, SPH_ERR_BAD_DATA, "%s: %s: variable %s: grid mapping %s%s%s: set %s to "
                               "\"output\"", c->key, c->path, data, gm, why[0] == ':' ? "" : " ", why, c->key);
        og_att(c->nc, xv, "units", u, sizeof u);
        char uy[64] = "";
        og_att(c->nc, yv, "units", uy, sizeof uy);
        m->fac = !strcmp(u, "m") || !strcmp(u, "meter") || !strcmp(u, "metre") || !strcmp(u, "meters") ||
                         !strcmp(u, "metres") ? 1.0
                 : !strcmp(u, "km") || !strcmp(u, "kilometer") || !strcmp(u, "kilometre") ||
                         !strcmp(u, "kilometers") || !strcmp(u, "kilometres") ? 1000.0 : 0.0;
        if (!(m->fac > 0.0) || strcmp(u, uy) != 0)
            return sph_err_set(c->err, SPH_ERR_UNITS, "%s: %s: variable %s: projection coordinates %s/%s have units "
                               "\"%s\"/\"%s\" (m or km, the same for both): set %s to \"output\"", c->key, c->path,
                               m->xvar, m->xvar, m->yvar, u, uy, c->key);
        sph_error pe;
        sph_error_clear(&pe);
        m->kind = 1;
        m->p = cf_mapping_proj_text(def, sizeof m->def) == 0 ? geo_proj_create(def, 0.0, 0.0, &pe) : NULL;
        if (!m->p)
            return sph_err_set(c->err, SPH_ERR_BAD_DATA, "%s: %s: variable %s: grid mapping %s is not a projected "
                               "CRS that PROJ understands%s%.200s%s: set %s to \"output\"", c->key, c->path, data, gm,
                               pe.msg[0] ? " (" : "", pe.msg, pe.msg[0] ? ")" : "", c->key);
    }
    m->x = malloc(*nx * sizeof *m->x);
    m->y = malloc(*ny * sizeof *m->y);
    *lon = malloc(*nx * *ny * sizeof **lon);
    *lat = malloc(*nx * *ny * sizeof **lat);
    double *xx = malloc(*nx * *ny * sizeof *xx), *yy = malloc(*nx * *ny * sizeof *yy);
    int rc = SPH_OK;
    if (!m->x || !m->y || !*lon || !*lat || !xx || !yy)
        rc = sph_err_set(c->err, SPH_ERR_NOMEM, "%s: %s: out of memory (%zu x %zu grid)", c->key, c->path, *nx, *ny);
    else if (nc_get_var_double(c->nc, xv, m->x) != NC_NOERR || nc_get_var_double(c->nc, yv, m->y) != NC_NOERR)
        rc = fail(c, m->xvar, "cannot be read with its y coordinate");
    for (size_t j = 0; rc == SPH_OK && j < *ny; j++)
        for (size_t i = 0; i < *nx; i++) {
            xx[j * *nx + i] = m->x[i];
            yy[j * *nx + i] = m->y[j];
        }
    if (rc == SPH_OK)
        rc = map_to_lonlat(m, *nx * *ny, xx, yy, *lon, *lat, c->err);
    free(xx);
    free(yy);
    return rc;
}

/* Edge e (0..n) of a mapped grid's axis a[n]: half-way between the
 * centres e-1 and e, half a cell beyond the outer ones. */
static double map_edge(const double *a, int n, int e)
{
    return e == 0 ? 1.5 * a[0] - 0.5 * a[1] : e == n ? 1.5 * a[n - 1] - 0.5 * a[n - 2] : 0.5 * (a[e - 1] + a[e]);
}

/* The areas of the kept cells of a mapped grid: a rotated pole's cell is a
 * rectangle of the rotated sphere, R^2 dlambda (sin phi_n - sin phi_s); a
 * projection's, its rectangle on the plane divided by the projection's
 * areal scale at the centre (PROJ's proj_factors, on the mapping's own
 * ellipsoid). */
static int mapped_areas(og_ctx *c, const og_map *m, ocean_grid *g)
{
    PJ_CONTEXT *ctx = NULL;
    PJ *P = NULL;
    if (m->kind == 1) {
        ctx = proj_context_create();
        P = ctx ? proj_create(ctx, m->def) : NULL;
        if (!P) {
            proj_context_destroy(ctx);
            return fail(c, m->gmvar, "gives a definition that PROJ cannot compute scale factors of");
        }
    }
    int rc = SPH_OK;
    for (int j = 0; j < g->ny && rc == SPH_OK; j++)
        for (int i = 0; i < g->nx && rc == SPH_OK; i++) {
            int fi = g->i0 + i, fj = g->j0 + j;
            double dx = fabs(map_edge(m->x, c->nxf, fi + 1) - map_edge(m->x, c->nxf, fi));
            double y0 = map_edge(m->y, c->nyf, fj), y1 = map_edge(m->y, c->nyf, fj + 1);
            size_t k = (size_t)j * g->nx + i;
            if (m->kind == 2) {
                g->area[k] = OG_R * OG_R * dx * OG_D2R * fabs(sin(y1 * OG_D2R) - sin(y0 * OG_D2R));
                continue;
            }
            PJ_COORD lp = proj_coord(g->lon[k] * OG_D2R, g->lat[k] * OG_D2R, 0, 0);
            PJ_FACTORS f = proj_factors(P, lp);
            if (proj_errno(P) || !(f.areal_scale > 0.0) || !isfinite(f.areal_scale)) {
                char what[200];
                snprintf(what, sizeof what, "gives no areal scale factor at cell (i %d, j %d) (%.4f E, %.4f N)", fi,
                         fj, g->lon[k], g->lat[k]);
                rc = fail(c, m->gmvar, what);
                break;
            }
            g->area[k] = dx * fabs(y1 - y0) * m->fac * m->fac / f.areal_scale;
        }
    proj_destroy(P);
    proj_context_destroy(ctx);
    if (rc == SPH_OK)
        snprintf(g->area_from, sizeof g->area_from, m->kind == 2 ? "the rotated sphere's cell of radius 6371 km"
                 : "the plane's cell over the mapping's areal scale (PROJ)");
    return rc;
}

/* The corners of the kept cells of a mapped grid: half-way between the
 * centres' coordinates (half a cell beyond the outer ones), mapped to
 * longitude/latitude: the cell is the rectangle of the grid's own
 * coordinates. */
static int corners_from_mapping(og_ctx *c, const og_map *m, ocean_grid *g)
{
    size_t n = (size_t)g->nx * g->ny;
    double *X = malloc(4 * n * sizeof *X), *Y = malloc(4 * n * sizeof *Y);
    if (!X || !Y) {
        free(X);
        free(Y);
        return sph_err_set(c->err, SPH_ERR_NOMEM, "%s: %s: out of memory (grid corners)", c->key, c->path);
    }
    static const int off[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}}; /* (di, dj): (i-, j-), (i+, j-), (i+, j+), (i-, j+) */
    for (int j = 0; j < g->ny; j++)
        for (int i = 0; i < g->nx; i++)
            for (int v = 0; v < 4; v++) {
                int fi = g->i0 + i, fj = g->j0 + j, ei = fi + off[v][0], ej = fj + off[v][1];
                /* edge e lies between centres e-1 and e */
                size_t k = 4 * ((size_t)j * g->nx + i) + v;
                X[k] = map_edge(m->x, c->nxf, ei);
                Y[k] = map_edge(m->y, c->nyf, ej);
            }
    int rc = map_to_lonlat(m, 4 * n, X, Y, g->blon, g->blat, c->err);
    free(X);
    free(Y);
    for (size_t k = 0; rc == SPH_OK && k < 4 * n; k++)
        if (!isfinite(g->blon[k]) || !isfinite(g->blat[k]))
            rc = fail(c, m->xvar, "gives a cell corner that does not map to a longitude and latitude");
    snprintf(g->corners, sizeof g->corners, "half-way between the %.24s/%.24s centres, through mapping %.24s",
             m->xvar, m->yvar, m->gmvar);
    return rc;
}

int ocean_grid_read(const char *path, const double box[4], const char *key, ocean_grid **out, sph_error *err)
{
    *out = NULL;
    og_ctx c = {.nc = -1, .path = path, .key = key, .err = err};
    int st = nc_open(path, NC_NOWRITE, &c.nc);
    if (st != NC_NOERR)
        return sph_err_set(err, SPH_ERR_IO, "%s: %s: open: %s", key, path, nc_strerror(st));
    int vlon = -1, vlat = -1, rc = SPH_OK;
    char data[NC_MAX_NAME + 1], why[600];
    double *lon = NULL, *lat = NULL;
    ocean_grid *g = NULL;
    landmask *m = NULL;
    og_map map;
    memset(&map, 0, sizeof map);
    size_t nx = 0, ny = 0;
    int found = find_centres(c.nc, &vlon, &vlat, data, sizeof data, why, sizeof why), dv = -1;
    if (found == -1 && nc_inq_varid(c.nc, data, &dv) == NC_NOERR) { /* a mapping without coordinates */
        if ((rc = mapped_centres(&c, dv, data, &map, &lon, &lat, &nx, &ny)) != SPH_OK)
            goto done;
    } else if (found) { /* -2: nothing to read positions from */
        rc = sph_err_set(err, found == -2 ? SPH_ERR_MISSING_VAR : SPH_ERR_CONFIG,
                         "%s: %s: variable %s %s: set %s to \"output\"", key, path,
                         data[0] ? data : "(none with two dimensions)", why, key);
        goto done;
    } else {
        nc_inq_vardimid(c.nc, vlon, c.dims);
        nc_inq_dimlen(c.nc, c.dims[0], &ny);
        nc_inq_dimlen(c.nc, c.dims[1], &nx);
        lon = malloc(nx * ny * sizeof *lon);
        lat = malloc(nx * ny * sizeof *lat);
    }
    c.nxf = (int)nx;
    c.nyf = (int)ny;
    g = calloc(1, sizeof *g);
    if (!g || !lon || !lat) {
        rc = sph_err_set(err, SPH_ERR_NOMEM, "%s: %s: out of memory (%zu x %zu grid)", key, path, nx, ny);
        goto done;
    }
    if (map.kind) {
        snprintf(g->lonvar, sizeof g->lonvar, "%s", map.xvar);
        snprintf(g->latvar, sizeof g->latvar, "%s", map.yvar);
    } else {
        nc_inq_varname(c.nc, vlon, g->lonvar);
        nc_inq_varname(c.nc, vlat, g->latvar);
    }
    if (nx < 2 || ny < 2) {
        rc = fail(&c, g->lonvar, "has fewer than 2 x 2 cells");
        goto done;
    }
    if (!map.kind &&
        (nc_get_var_double(c.nc, vlon, lon) != NC_NOERR || nc_get_var_double(c.nc, vlat, lat) != NC_NOERR)) {
        rc = fail(&c, g->lonvar, "cannot be read with its latitude");
        goto done;
    }
    double lonc = 0.5 * (box[0] + box[1]);
    int i0 = (int)nx, i1 = -1, j0 = (int)ny, j1 = -1;
    for (size_t j = 0; j < ny; j++)
        for (size_t i = 0; i < nx; i++) {
            size_t f = j * nx + i;
            if (!isfinite(lon[f]) || !isfinite(lat[f]) || fabs(lat[f]) > 90.0) {
                char what[160];
                snprintf(what, sizeof what, "is %g, %g at cell (i %zu, j %zu): not a position", lon[f], lat[f], i, j);
                rc = fail(&c, g->lonvar, what);
                goto done;
            }
            lon[f] = near_lon(lon[f], lonc);
        }
    for (size_t j = 0; j < ny; j++)
        for (size_t i = 0; i < nx; i++) {
            size_t f = j * nx + i;
            double d = 0.0; /* reach: the farthest neighbouring centre, degrees */
            if (i > 0)
                d = fmax(d, fmax(fabs(near_lon(lon[f - 1], lon[f]) - lon[f]), fabs(lat[f - 1] - lat[f])));
            if (i + 1 < nx)
                d = fmax(d, fmax(fabs(near_lon(lon[f + 1], lon[f]) - lon[f]), fabs(lat[f + 1] - lat[f])));
            if (j > 0)
                d = fmax(d, fmax(fabs(near_lon(lon[f - nx], lon[f]) - lon[f]), fabs(lat[f - nx] - lat[f])));
            if (j + 1 < ny)
                d = fmax(d, fmax(fabs(near_lon(lon[f + nx], lon[f]) - lon[f]), fabs(lat[f + nx] - lat[f])));
            if (lon[f] >= box[0] - d && lon[f] <= box[1] + d && lat[f] >= box[2] - d && lat[f] <= box[3] + d) {
                i0 = (int)i < i0 ? (int)i : i0;
                i1 = (int)i > i1 ? (int)i : i1;
                j0 = (int)j < j0 ? (int)j : j0;
                j1 = (int)j > j1 ? (int)j : j1;
            }
        }
    if (i1 < 0) {
        rc = fail(&c, g->lonvar, "has no cell over the domain");
        goto done;
    }
    g->i0 = i0;
    g->j0 = j0;
    g->nx = i1 - i0 + 1;
    g->ny = j1 - j0 + 1;
    size_t n = (size_t)g->nx * g->ny;
    g->lon = malloc(n * sizeof(double));
    g->lat = malloc(n * sizeof(double));
    g->blon = malloc(4 * n * sizeof(double));
    g->blat = malloc(4 * n * sizeof(double));
    g->area = malloc(n * sizeof(double));
    g->land = malloc(n);
    if (!g->lon || !g->lat || !g->blon || !g->blat || !g->area || !g->land) {
        rc = sph_err_set(err, SPH_ERR_NOMEM, "%s: %s: out of memory (%zu cells)", key, path, n);
        goto done;
    }
    for (int j = 0; j < g->ny; j++)
        for (int i = 0; i < g->nx; i++) {
            size_t f = (size_t)(j0 + j) * nx + (size_t)(i0 + i), k = (size_t)j * g->nx + i;
            g->lon[k] = lon[f];
            g->lat[k] = lat[f];
        }
    int b = map.kind ? 1 : corners_from_bounds(&c, vlon, vlat, g);
    if (b < 0) {
        rc = -b;
        goto done;
    }
    if (map.kind && (rc = corners_from_mapping(&c, &map, g)) != SPH_OK)
        goto done;
    if (b == 0 && (rc = corners_from_centres(&c, lon, lat, g)) != SPH_OK)
        goto done;
    for (size_t k = 0; k < 4 * n; k++)
        g->blon[k] = near_lon(g->blon[k], g->lon[k / 4]);
    if ((rc = areas(&c, g, map.kind ? &map : NULL)) != SPH_OK)
        goto done;
    /* land: the model's own mask, on the same cells */
    landmask_read_opts o = {NULL, LANDMASK_FROM_AUTO, LANDMASK_POL_AUTO, NAN, 1, NULL, NULL, 0, 0};
    if (map.kind) { /* the file has no positions of its own: the mapping's */
        o.cell_lon = lon;
        o.cell_lat = lat;
        o.cell_nx = nx;
        o.cell_ny = ny;
    }
    sph_error le;
    sph_error_clear(&le);
    m = landmask_read_model(path, &o, &le);
    int mx = 0, my = 0;
    double d0, d1, d2, d3;
    if (m)
        landmask_get_grid(m, &mx, &my, &d0, &d1, &d2, &d3);
    if (!m || !landmask_is_native(m) || mx != (int)nx || my != (int)ny) {
        rc = sph_err_set(err, SPH_ERR_BAD_DATA, "%s: %s: the land of the grid %s/%s (%zu x %zu) %s%s: set %s to "
                         "\"output\"", key, path, g->lonvar, g->latvar, nx, ny,
                         m ? "is not on its cells in the file's mask or current" : "cannot be read: ",
                         m ? "" : le.msg, key);
        goto done;
    }
    const unsigned char *ml = landmask_data(m);
    size_t nland = 0;
    for (int j = 0; j < g->ny; j++)
        for (int i = 0; i < g->nx; i++) {
            size_t k = (size_t)j * g->nx + i;
            g->land[k] = ml[(size_t)(j0 + j) * nx + (size_t)(i0 + i)] ? 1 : 0;
            nland += g->land[k];
        }
    char kind[200];
    if (map.kind)
        snprintf(kind, sizeof kind, "%s %.40s/%.40s through grid mapping %.40s (%.40s)",
                 map.kind == 2 ? "rotated-pole" : "projected", map.xvar, map.yvar, map.gmvar, map.gmname);
    else
        snprintf(kind, sizeof kind, "curvilinear %.64s/%.64s", g->lonvar, g->latvar);
    snprintf(g->desc, sizeof g->desc, "%s, cells i %d..%d, j %d..%d of %zu x %zu (%zu land), "
             "corners: %s; areas: %s", kind, i0, i1, j0, j1, nx, ny, nland,
             b ? g->corners : "midpoints of the centres", g->area_from);
done:
    map_free(&map);
    landmask_free(m);
    free(lon);
    free(lat);
    nc_close(c.nc);
    if (rc) {
        ocean_grid_free(g);
        return rc;
    }
    *out = g;
    return SPH_OK;
}
