/* Grids of the initial ice raster beyond regular lon/lat (io/raster.h):
 * projected x/y through PROJ (cell centres unprojected, true cell areas
 * from PROJ's scale factors) and curvilinear 2-D lat/lon (geodesic cell
 * areas). Format-free: the drivers hand over the CRS definition and the
 * coordinates. */
#include "raster_impl.h"

#include <geodesic.h>
#include <math.h>
#include <proj.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct raster_crs {
    PJ_CONTEXT *ctx;
    PJ *crs;      /* the projected CRS */
    PJ *fwd;      /* its geodetic CRS (lon, lat degrees) -> x/y in the CRS's unit */
    PJ *fac;      /* its projection alone, for proj_factors (fast; on the CRS
                   * itself it re-derives the operation at every call and is
                   * wrong for units other than metres) */
    double unit;  /* metres per CRS unit along x/y */
};

void raster_crs_free(struct raster_crs *c)
{
    if (!c)
        return;
    proj_destroy(c->fwd);
    proj_destroy(c->fac);
    proj_destroy(c->crs);
    proj_context_destroy(c->ctx);
    free(c);
}

static int crs_fail(struct raster_crs *c, const char *path, const char *var, const char *def,
                    const char *what, sph_error *err)
{
    int e = c->ctx ? proj_context_errno(c->ctx) : 0;
    char why[256];
    snprintf(why, sizeof why, "%s%s%s", what, e ? ": " : "",
             e ? proj_context_errno_string(c->ctx, e) : "");
    raster_crs_free(c);
    return sph_err_set(err, SPH_ERR_BAD_DATA,
                       "ice raster %s: variable %s: projection \"%.300s\": %s", path, var, def,
                       why);
}

static struct raster_crs *crs_build(const char *path, const char *var, const char *def,
                                    sph_error *err)
{
    struct raster_crs *c = calloc(1, sizeof *c);
    if (!c) {
        sph_err_set(err, SPH_ERR_NOMEM, "ice raster %s: out of memory", path);
        return NULL;
    }
    c->ctx = proj_context_create();
    if (!c->ctx) {
        crs_fail(c, path, var, def, "PROJ context not created", err);
        return NULL;
    }
    proj_log_level(c->ctx, PJ_LOG_NONE);
    char buf[4200];
    /* a bare "+proj=..." string is a CRS for PROJ only with +type=crs */
    if (strstr(def, "+proj=") && !strstr(def, "+type=crs"))
        snprintf(buf, sizeof buf, "%s +type=crs", def);
    else
        snprintf(buf, sizeof buf, "%s", def);
    c->crs = proj_create(c->ctx, buf);
    if (!c->crs) {
        crs_fail(c, path, var, def, "PROJ cannot build it", err);
        return NULL;
    }
    if (proj_get_type(c->crs) == PJ_TYPE_BOUND_CRS) {
        PJ *base = proj_get_source_crs(c->ctx, c->crs);
        proj_destroy(c->crs);
        c->crs = base;
    }
    if (!c->crs || proj_get_type(c->crs) != PJ_TYPE_PROJECTED_CRS) {
        crs_fail(c, path, var, def, "not a projected CRS", err);
        return NULL;
    }
    PJ *cs = proj_crs_get_coordinate_system(c->ctx, c->crs);
    double f = 0;
    if (!cs || !proj_cs_get_axis_info(c->ctx, cs, 0, NULL, NULL, NULL, &f, NULL, NULL, NULL) ||
        !(f > 0)) {
        proj_destroy(cs);
        crs_fail(c, path, var, def, "no linear unit on its axes", err);
        return NULL;
    }
    proj_destroy(cs);
    c->unit = f;
    PJ *geod = proj_crs_get_geodetic_crs(c->ctx, c->crs);
    PJ *raw = geod ? proj_create_crs_to_crs_from_pj(c->ctx, geod, c->crs, NULL, NULL) : NULL;
    proj_destroy(geod);
    if (raw) {
        c->fwd = proj_normalize_for_visualization(c->ctx, raw);
        proj_destroy(raw);
    }
    const char *ps = proj_as_proj_string(c->ctx, c->crs, PJ_PROJ_5, NULL);
    if (ps) {
        char pbuf[2048];
        snprintf(pbuf, sizeof pbuf, "%s", ps);
        char *t = strstr(pbuf, "+type=crs");
        if (t)
            *t = '\0';
        c->fac = proj_create(c->ctx, pbuf);
    }
    if (!c->fac) {
        crs_fail(c, path, var, def, "not expressible as a PROJ projection (cell areas)", err);
        return NULL;
    }
    if (!c->fwd) {
        crs_fail(c, path, var, def, "no conversion from its geodetic CRS", err);
        return NULL;
    }
    return c;
}

int raster_crs_forward(const struct raster_crs *c, double lon, double lat, double *x, double *y)
{
    PJ_COORD in = proj_coord(lon, lat, 0, HUGE_VAL);
    PJ_COORD out = proj_trans(c->fwd, PJ_FWD, in);
    if (!isfinite(out.xy.x) || !isfinite(out.xy.y) || out.xy.x == HUGE_VAL) {
        proj_errno_reset(c->fwd);
        *x = *y = NAN;
        return 0;
    }
    *x = out.xy.x * c->unit;
    *y = out.xy.y * c->unit;
    return 1;
}

int raster_crs_inverse(const struct raster_crs *c, double x, double y, double *lon, double *lat)
{
    PJ_COORD ll = proj_trans(c->fwd, PJ_INV, proj_coord(x / c->unit, y / c->unit, 0, HUGE_VAL));
    if (!isfinite(ll.lp.lam) || !isfinite(ll.lp.phi) || ll.lp.lam == HUGE_VAL) {
        proj_errno_reset(c->fwd);
        *lon = *lat = NAN;
        return 0;
    }
    *lon = remainder(ll.lp.lam, 360.0);
    *lat = ll.lp.phi;
    return 1;
}

int raster_set_projected(ice_raster *r, const char *def, const char *var,
                         const double *cell_area, sph_error *err)
{
    struct raster_crs *c = crs_build(r->path, var, def, err);
    if (!c)
        return err->code ? err->code : SPH_ERR_BAD_DATA;
    size_t n = (size_t)r->nlon * r->nlat;
    r->cell_lon = malloc(sizeof(double) * n);
    r->cell_lat = malloc(sizeof(double) * n);
    r->area = malloc(sizeof(double) * n);
    r->crs = c;
    if (!r->cell_lon || !r->cell_lat || !r->area)
        return sph_err_set(err, SPH_ERR_NOMEM, "ice raster %s: out of memory", r->path);
    size_t bad = 0, first = 0;
    for (int j = 0; j < r->nlat; j++)
        for (int i = 0; i < r->nlon; i++) {
            size_t k = (size_t)j * r->nlon + i;
            PJ_COORD in = proj_coord(r->x[i] / c->unit, r->y[j] / c->unit, 0, HUGE_VAL);
            PJ_COORD ll = proj_trans(c->fwd, PJ_INV, in);
            double lon = ll.lp.lam, lat = ll.lp.phi, a = NAN;
            if (isfinite(lon) && isfinite(lat) && lon != HUGE_VAL) {
                if (cell_area) {
                    a = cell_area[k];
                } else {
                    PJ_FACTORS fa = proj_factors(c->fac, proj_coord(proj_torad(lon),
                                                                    proj_torad(lat), 0, 0));
                    a = r->dx * r->dy / fa.areal_scale;
                }
            }
            if (!(isfinite(a) && a > 0)) {
                if (!bad++)
                    first = k;
                proj_errno_reset(c->fwd);
                proj_errno_reset(c->fac);
            }
            r->cell_lon[k] = remainder(lon, 360.0);
            r->cell_lat[k] = lat;
            r->area[k] = a;
        }
    if (bad)
        return sph_err_set(err, SPH_ERR_BAD_DATA,
                           "ice raster %s: variable %s: %zu of %zu cells have no position or "
                           "area in projection \"%.300s\" (first: x %g m, y %g m)", r->path, var,
                           bad, n, def, r->x[first % r->nlon], r->y[first / r->nlon]);
    return SPH_OK;
}

int raster_set_regular_projected(ice_raster *r, const char *def, const char *var, double x0,
                                 double dx, double y0, double dy, sph_error *err)
{
    free(r->lon);
    free(r->lat);
    r->lon = r->lat = NULL;
    r->kind = ICE_RASTER_PROJECTED;
    r->x = malloc(sizeof(double) * (size_t)r->nlon);
    r->y = malloc(sizeof(double) * (size_t)r->nlat);
    if (!r->x || !r->y)
        return sph_err_set(err, SPH_ERR_NOMEM, "ice raster %s: out of memory", r->path);
    for (int i = 0; i < r->nlon; i++)
        r->x[i] = x0 + i * dx;
    for (int j = 0; j < r->nlat; j++)
        r->y[j] = y0 + j * dy;
    r->dx = dx;
    r->dy = dy;
    return raster_set_projected(r, def, var, NULL, err);
}

int raster_window(const char *path, const char *def, double x0, double dx, int nx, double y0,
                  double dy, int ny, const ice_raster_options *o, int margin, int win[4],
                  sph_error *err)
{
    win[0] = 0, win[1] = nx - 1, win[2] = 0, win[3] = ny - 1;
    const double *b = o->bbox;
    if (isnan(b[0]) || isnan(b[1]) || isnan(b[2]) || isnan(b[3]))
        return SPH_OK;
    struct raster_crs *c = crs_build(path, "grid", def, err);
    if (!c)
        return err->code ? err->code : SPH_ERR_BAD_DATA;
    /* the box's extent in x/y from a lattice over it (the extremes of a
     * polar projection may lie inside the box, at the pole); the margin
     * covers what falls between the lattice's points */
    enum { N = 128 };
    double xmin = HUGE_VAL, xmax = -HUGE_VAL, ymin = HUGE_VAL, ymax = -HUGE_VAL;
    double la0 = fmax(-90, b[2]), la1 = fmin(90, b[3]);
    for (int q = 0; q <= N; q++)
        for (int p = 0; p <= N; p++) {
            double x, y, lon = b[0] + (b[1] - b[0]) * p / N, lat = la0 + (la1 - la0) * q / N;
            if (!raster_crs_forward(c, lon, lat, &x, &y))
                continue;
            xmin = fmin(xmin, x), xmax = fmax(xmax, x);
            ymin = fmin(ymin, y), ymax = fmax(ymax, y);
        }
    raster_crs_free(c);
    double i0 = floor((xmin - x0) / dx) - margin, i1 = ceil((xmax - x0) / dx) + margin;
    double j0 = floor((ymin - y0) / dy) - margin, j1 = ceil((ymax - y0) / dy) + margin;
    if (!(xmin <= xmax) || i1 < 0 || j1 < 0 || i0 > nx - 1 || j0 > ny - 1)
        return sph_err_set(err, SPH_ERR_BAD_DATA,
                           "ice raster %s: the domain (%g..%g E, %g..%g N) covers no cell of the "
                           "raster", path, b[0], b[1], b[2], b[3]);
    win[0] = i0 < 0 ? 0 : (int)i0;
    win[1] = i1 > nx - 1 ? nx - 1 : (int)i1;
    win[2] = j0 < 0 ? 0 : (int)j0;
    win[3] = j1 > ny - 1 ? ny - 1 : (int)j1;
    /* two cells each way at least (sampling is bilinear) */
    if (win[1] == win[0]) {
        if (win[1] < nx - 1)
            win[1]++;
        else
            win[0]--;
    }
    if (win[3] == win[2]) {
        if (win[3] < ny - 1)
            win[3]++;
        else
            win[2]--;
    }
    return SPH_OK;
}

int raster_set_curvilinear(ice_raster *r, const char *var, const double *cell_area,
                           sph_error *err)
{
    int nx = r->nlon, ny = r->nlat;
    size_t n = (size_t)nx * ny;
    r->area = malloc(sizeof(double) * n);
    if (!r->area)
        return sph_err_set(err, SPH_ERR_NOMEM, "ice raster %s: out of memory", r->path);
    for (size_t k = 0; k < n; k++)
        if (!(isfinite(r->cell_lon[k]) && isfinite(r->cell_lat[k]) &&
              fabs(r->cell_lat[k]) <= 90))
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ice raster %s: variable %s: 2-D latitude/longitude invalid at "
                               "row %zu, column %zu (%g E, %g N)", r->path, var, k / nx, k % nx,
                               r->cell_lon[k], r->cell_lat[k]);
    if (cell_area) {
        memcpy(r->area, cell_area, sizeof(double) * n);
        return SPH_OK;
    }
    /* corners: the mean of the four surrounding centres, with the centres
     * extended linearly by one cell past the edges; longitudes unwrapped
     * around the cell's own */
    struct geod_geodesic g;
    geod_init(&g, 6378137.0, 1 / 298.257223563);
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++) {
            double clon[4], clat[4], lon0 = r->cell_lon[(size_t)j * nx + i];
            static const int ci[4] = {0, 1, 1, 0}, cj[4] = {0, 0, 1, 1};
            for (int q = 0; q < 4; q++) {
                double sl = 0, sp = 0;
                for (int dj = -1; dj <= 0; dj++)
                    for (int di = -1; di <= 0; di++) {
                        int ii = i + ci[q] + di, jj = j + cj[q] + dj;
                        /* extend past the edge: 2 p(edge) - p(inner) */
                        int ia = ii < 0 ? 0 : ii >= nx ? nx - 1 : ii;
                        int ja = jj < 0 ? 0 : jj >= ny ? ny - 1 : jj;
                        int ib = ii < 0 ? 1 : ii >= nx ? nx - 2 : ii;
                        int jb = jj < 0 ? 1 : jj >= ny ? ny - 2 : jj;
                        if (nx < 2) ib = ia;
                        if (ny < 2) jb = ja;
                        size_t ka = (size_t)ja * nx + ia, kb = (size_t)jb * nx + ib;
                        double la = lon0 + remainder(r->cell_lon[ka] - lon0, 360.0);
                        double lb = lon0 + remainder(r->cell_lon[kb] - lon0, 360.0);
                        int ext = ia != ii || ja != jj;
                        sl += ext ? 2 * la - lb : la;
                        sp += ext ? 2 * r->cell_lat[ka] - r->cell_lat[kb] : r->cell_lat[ka];
                    }
                clon[q] = sl / 4;
                clat[q] = fmax(-90, fmin(90, sp / 4));
            }
            double a = 0;
            geod_polygonarea(&g, clat, clon, 4, &a, NULL);
            r->area[(size_t)j * nx + i] = fabs(a);
        }
    return SPH_OK;
}
