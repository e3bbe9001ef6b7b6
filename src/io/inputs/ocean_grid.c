/* A curvilinear ocean grid from one of the ocean model's files: see
 * io/ocean_grid.h. */
#include "io/ocean_grid.h"

#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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

/* Cell areas of the kept cells. */
static int areas(og_ctx *c, ocean_grid *g)
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

int ocean_grid_read(const char *path, const double box[4], const char *key, ocean_grid **out, sph_error *err)
{
    *out = NULL;
    og_ctx c = {.nc = -1, .path = path, .key = key, .err = err};
    int st = nc_open(path, NC_NOWRITE, &c.nc);
    if (st != NC_NOERR)
        return sph_err_set(err, SPH_ERR_IO, "%s: %s: open: %s", key, path, nc_strerror(st));
    int vlon, vlat, rc = SPH_OK;
    char data[NC_MAX_NAME + 1], why[600];
    double *lon = NULL, *lat = NULL;
    ocean_grid *g = NULL;
    landmask *m = NULL;
    int found = find_centres(c.nc, &vlon, &vlat, data, sizeof data, why, sizeof why);
    if (found) { /* -1: a mapping without coordinates; -2: nothing to read positions from */
        rc = sph_err_set(err, found == -2 ? SPH_ERR_MISSING_VAR : SPH_ERR_CONFIG,
                         "%s: %s: variable %s %s: set %s to \"output\"", key, path,
                         data[0] ? data : "(none with two dimensions)", why, key);
        goto done;
    }
    size_t nx = 0, ny = 0;
    nc_inq_vardimid(c.nc, vlon, c.dims);
    nc_inq_dimlen(c.nc, c.dims[0], &ny);
    nc_inq_dimlen(c.nc, c.dims[1], &nx);
    c.nxf = (int)nx;
    c.nyf = (int)ny;
    g = calloc(1, sizeof *g);
    lon = malloc(nx * ny * sizeof *lon);
    lat = malloc(nx * ny * sizeof *lat);
    if (!g || !lon || !lat) {
        rc = sph_err_set(err, SPH_ERR_NOMEM, "%s: %s: out of memory (%zu x %zu grid)", key, path, nx, ny);
        goto done;
    }
    nc_inq_varname(c.nc, vlon, g->lonvar);
    nc_inq_varname(c.nc, vlat, g->latvar);
    if (nx < 2 || ny < 2) {
        rc = fail(&c, g->lonvar, "has fewer than 2 x 2 cells");
        goto done;
    }
    if (nc_get_var_double(c.nc, vlon, lon) != NC_NOERR || nc_get_var_double(c.nc, vlat, lat) != NC_NOERR) {
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
    int b = corners_from_bounds(&c, vlon, vlat, g);
    if (b < 0) {
        rc = -b;
        goto done;
    }
    if (b == 0 && (rc = corners_from_centres(&c, lon, lat, g)) != SPH_OK)
        goto done;
    for (size_t k = 0; k < 4 * n; k++)
        g->blon[k] = near_lon(g->blon[k], g->lon[k / 4]);
    if ((rc = areas(&c, g)) != SPH_OK)
        goto done;
    /* land: the model's own mask, on the same cells */
    landmask_read_opts o = {NULL, LANDMASK_FROM_AUTO, LANDMASK_POL_AUTO, NAN, 1};
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
    snprintf(g->desc, sizeof g->desc, "curvilinear %.64s/%.64s, cells i %d..%d, j %d..%d of %zu x %zu (%zu land), "
             "corners: %s; areas: %s", g->lonvar, g->latvar, i0, i1, j0, j1, nx, ny, nland,
             b ? g->corners : "midpoints of the centres", g->area_from);
done:
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
