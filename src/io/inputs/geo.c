/* PROJ wrapper: see io/geo.h. */
#include "io/geo.h"

#include <math.h>
#include <proj.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

/* Up to GEO_MAX_TEAM OpenMP threads share a long transform (at least
 * GEO_OMP_MIN points), each through its own PJ (thread 0 the object's
 * own, the others copies built from the same definition on first use):
 * every point is transformed alone, so the values are the same whatever
 * the thread count. */
#define GEO_MAX_TEAM 64
#define GEO_OMP_MIN 512

struct geo_proj {
    PJ_CONTEXT *ctx;     /* one per object: PJ objects are not thread-safe */
    PJ *pj;              /* geographic (lon, lat degrees) -> plane (x, y metres) */
    pthread_mutex_t lock; /* serialises proj_trans on this object */
    int nteam;                          /* copies built for threads 1 .. nteam */
    PJ_CONTEXT *team_ctx[GEO_MAX_TEAM]; /* [t - 1]: thread t's context and PJ */
    PJ *team_pj[GEO_MAX_TEAM];
    double lon0, lat0;
    char definition[512];
};

/* The geographic side: WGS84 longitude/latitude in degrees, spelled out so
 * that no proj.db lookup is needed. */
static const char geographic_crs[] = "+proj=longlat +datum=WGS84 +no_defs +type=crs";

static int build_definition(const char *kind, double lon0, double lat0, char *def, size_t len,
                            sph_error *err)
{
    if (!kind || !*kind)
        kind = "auto";
    if (!isfinite(lon0) || !isfinite(lat0) || lat0 < -90 || lat0 > 90)
        return sph_err_set(err, SPH_ERR_PARAM,
                           "projection: centre (%g E, %g N) is not a valid position", lon0, lat0);
    if (strcmp(kind, "auto") == 0)
        kind = fabs(lat0) < 60 ? "aeqd" : "polar";
    if (strcmp(kind, "aeqd") == 0) {
        snprintf(def, len, "+proj=aeqd +lat_0=%.10g +lon_0=%.10g +x_0=0 +y_0=0 +ellps=WGS84 "
                 "+units=m +no_defs +type=crs", lat0, lon0);
    } else if (strcmp(kind, "stere") == 0) {
        snprintf(def, len, "+proj=stere +lat_0=%.10g +lon_0=%.10g +k=1 +x_0=0 +y_0=0 "
                 "+ellps=WGS84 +units=m +no_defs +type=crs", lat0, lon0);
    } else if (strcmp(kind, "polar") == 0) {
        double pole = lat0 >= 0 ? 90.0 : -90.0;
        snprintf(def, len, "+proj=stere +lat_0=%g +lat_ts=%g +lon_0=%.10g +x_0=0 +y_0=0 "
                 "+ellps=WGS84 +units=m +no_defs +type=crs", pole, pole > 0 ? 70.0 : -70.0,
                 lon0);
    } else if (strstr(kind, "+proj=") && !strstr(kind, "+type=crs")) {
        snprintf(def, len, "%s +type=crs", kind);
    } else if (strstr(kind, "+proj=") || strncmp(kind, "EPSG:", 5) == 0 ||
               strncmp(kind, "epsg:", 5) == 0) {
        snprintf(def, len, "%s", kind);
    } else {
        return sph_err_set(err, SPH_ERR_CONFIG,
                           "projection: unknown kind \"%s\" (auto, aeqd, stere, polar, or a "
                           "PROJ definition with +proj=)", kind);
    }
    return SPH_OK;
}

static geo_proj *create_from_definition(const char *def, double lon0, double lat0,
                                        sph_error *err)
{
    geo_proj *p = calloc(1, sizeof *p);
    if (!p) {
        sph_err_set(err, SPH_ERR_NOMEM, "projection: out of memory");
        return NULL;
    }
    snprintf(p->definition, sizeof p->definition, "%s", def);
    p->lon0 = lon0;
    p->lat0 = lat0;
    p->ctx = proj_context_create();
    if (!p->ctx) {
        free(p);
        sph_err_set(err, SPH_ERR_NOMEM, "projection: proj_context_create failed");
        return NULL;
    }
    proj_log_level(p->ctx, PJ_LOG_NONE);
    PJ *raw = proj_create_crs_to_crs(p->ctx, geographic_crs, def, NULL);
    if (raw) {
        p->pj = proj_normalize_for_visualization(p->ctx, raw);
        proj_destroy(raw);
    }
    if (!p->pj) {
        int e = proj_context_errno(p->ctx);
        sph_err_set(err, SPH_ERR_CONFIG, "projection \"%s\": %s", def,
                    e ? proj_context_errno_string(p->ctx, e) : "cannot create");
        proj_context_destroy(p->ctx);
        free(p);
        return NULL;
    }
    pthread_mutex_init(&p->lock, NULL);
    return p;
}

geo_proj *geo_proj_create(const char *kind, double lon0, double lat0, sph_error *err)
{
    char def[512];
    if (build_definition(kind, lon0, lat0, def, sizeof def, err) != SPH_OK)
        return NULL;
    return create_from_definition(def, lon0, lat0, err);
}

geo_proj *geo_proj_clone(const geo_proj *p, sph_error *err)
{
    if (!p) {
        sph_err_set(err, SPH_ERR_PARAM, "projection: clone of NULL");
        return NULL;
    }
    return create_from_definition(p->definition, p->lon0, p->lat0, err);
}

void geo_proj_free(geo_proj *p)
{
    if (!p)
        return;
    for (int t = 0; t < p->nteam; t++) {
        proj_destroy(p->team_pj[t]);
        proj_context_destroy(p->team_ctx[t]);
    }
    proj_destroy(p->pj);
    proj_context_destroy(p->ctx);
    pthread_mutex_destroy(&p->lock);
    free(p);
}

const char *geo_proj_definition(const geo_proj *p) { return p ? p->definition : ""; }

void geo_proj_centre(const geo_proj *p, double *lon0, double *lat0)
{
    if (lon0)
        *lon0 = p->lon0;
    if (lat0)
        *lat0 = p->lat0;
}

/* The PJs of threads 1 .. want - 1 (caller holds the lock): how many
 * threads can take part (1 where a copy cannot be built: the transform is
 * then serial, the same values). */
static int team_reserve(geo_proj *p, int want)
{
    if (want > GEO_MAX_TEAM + 1)
        want = GEO_MAX_TEAM + 1;
    while (p->nteam < want - 1) {
        PJ_CONTEXT *ctx = proj_context_create();
        if (!ctx)
            break;
        proj_log_level(ctx, PJ_LOG_NONE);
        PJ *raw = proj_create_crs_to_crs(ctx, geographic_crs, p->definition, NULL), *pj = NULL;
        if (raw) {
            pj = proj_normalize_for_visualization(ctx, raw);
            proj_destroy(raw);
        }
        if (!pj) {
            proj_context_destroy(ctx);
            break;
        }
        p->team_ctx[p->nteam] = ctx;
        p->team_pj[p->nteam] = pj;
        p->nteam++;
    }
    return p->nteam + 1 < want ? p->nteam + 1 : want;
}

static int trans_one(PJ *pj, PJ_DIRECTION dir, double a, double b, double *outa, double *outb)
{
    PJ_COORD r = proj_trans(pj, dir, proj_coord(a, b, 0, HUGE_VAL));
    if (!isfinite(a) || !isfinite(b) || !isfinite(r.xy.x) || !isfinite(r.xy.y) || r.xy.x == HUGE_VAL) {
        *outa = *outb = NAN;
        proj_errno_reset(pj);
        return 1;
    }
    /* unprojected longitudes in -180..180 */
    *outa = dir == PJ_INV ? remainder(r.xy.x, 360.0) : r.xy.x;
    *outb = r.xy.y;
    return 0;
}

/* One direction for n points. The mutex is logically mutable state of a
 * const object: it only serialises use of the PJs. */
static int transform(const geo_proj *cp, PJ_DIRECTION dir, size_t n, const double *a,
                     const double *b, double *outa, double *outb, sph_error *err)
{
    geo_proj *p = (geo_proj *)cp;
    size_t bad = 0, first_bad = n;
    pthread_mutex_lock(&p->lock);
    int team = 1;
#ifdef _OPENMP
    if (n >= GEO_OMP_MIN && omp_get_max_threads() > 1 && !omp_in_parallel())
        team = team_reserve(p, omp_get_max_threads());
#endif
    if (team > 1) {
#pragma omp parallel num_threads(team) reduction(+ : bad) reduction(min : first_bad)
        {
#ifdef _OPENMP
            int t = omp_get_thread_num();
#else
            int t = 0;
#endif
            PJ *pj = t == 0 ? p->pj : p->team_pj[t - 1];
#pragma omp for schedule(static)
            for (size_t i = 0; i < n; i++)
                if (trans_one(pj, dir, a[i], b[i], outa + i, outb + i)) {
                    bad++;
                    if (i < first_bad)
                        first_bad = i;
                }
        }
    } else {
        for (size_t i = 0; i < n; i++)
            if (trans_one(p->pj, dir, a[i], b[i], outa + i, outb + i) && !bad++)
                first_bad = i;
    }
    pthread_mutex_unlock(&p->lock);
    if (bad)
        return sph_err_set(err, SPH_ERR_PARAM,
                           "projection %s: %zu of %zu points do not %s (first: %g, %g)",
                           p->definition, bad, n, dir == PJ_FWD ? "project" : "unproject",
                           a[first_bad], b[first_bad]);
    return SPH_OK;
}

int geo_forward(const geo_proj *p, size_t n, const double *lon, const double *lat, double *x,
                double *y, sph_error *err)
{
    return transform(p, PJ_FWD, n, lon, lat, x, y, err);
}

int geo_inverse(const geo_proj *p, size_t n, const double *x, const double *y, double *lon,
                double *lat, sph_error *err)
{
    return transform(p, PJ_INV, n, x, y, lon, lat, err); /* longitudes -180..180 */
}

double geo_grid_angle(const geo_proj *p, double lon, double lat)
{
    /* 1e-4 degree (about 10 m) steps along the parallel: the truncation
     * error of the centred difference is ~1e-9 rad, far below float noise. */
    const double d = 1e-4;
    double lons[2] = {lon - d, lon + d}, lats[2] = {lat, lat}, x[2], y[2];
    if (fabs(lat) > 90 - 1e-6 || geo_forward(p, 2, lons, lats, x, y, NULL) != SPH_OK)
        return NAN;
    /* East points at atan2(dy, dx) from the x axis; x is at minus that from east. */
    return -atan2(y[1] - y[0], x[1] - x[0]);
}

int geo_rotate_to_plane(const geo_proj *p, size_t n, const double *lon, const double *lat,
                        const double *ue, const double *vn, double *ux, double *uy,
                        sph_error *err)
{
    for (size_t i = 0; i < n; i++) {
        double a = geo_grid_angle(p, lon[i], lat[i]);
        if (!isfinite(a))
            return sph_err_set(err, SPH_ERR_PARAM,
                               "projection %s: no grid angle at (%g E, %g N)", p->definition,
                               lon[i], lat[i]);
        double e = ue[i], nn = vn[i], c = cos(a), s = sin(a);
        ux[i] = e * c + nn * s;
        uy[i] = -e * s + nn * c;
    }
    return SPH_OK;
}

/* ------------------------------------------------------------------ */
/* plane tables (domain.plane_tables)                                  */

struct geo_plane_table {
    const geo_proj *proj; /* for points outside the table */
    double x0, y0, step, inv;
    int nx, ny;           /* nodes */
    double lon0;          /* longitudes stored relative to it (no wrap inside) */
    double *node;         /* [4 * nx * ny]: lon - lon0, lat, cos, sin of the grid angle */
};

geo_plane_table *geo_plane_table_create(const geo_proj *p, double x0, double x1, double y0, double y1,
                                        double step, sph_error *err)
{
    if (!p || !(x1 > x0) || !(y1 > y0) || !(step > 0.0)) {
        sph_err_set(err, SPH_ERR_PARAM, "projection tables: empty box or step");
        return NULL;
    }
    double fx = ceil((x1 - x0) / step) + 1.0, fy = ceil((y1 - y0) / step) + 1.0;
    if (fx * fy > 4e7) {
        sph_err_set(err, SPH_ERR_PARAM,
                    "projection tables: %.0f x %.0f nodes at %g m over the domain is too many "
                    "(set domain.plane_tables false)", fx, fy, step);
        return NULL;
    }
    geo_plane_table *t = calloc(1, sizeof *t);
    size_t nn = (size_t)fx * (size_t)fy;
    double *xs = t ? malloc(2 * nn * sizeof *xs) : NULL;
    double *ll = xs ? malloc(2 * nn * sizeof *ll) : NULL;
    if (t)
        t->node = malloc(4 * nn * sizeof *t->node);
    if (!t || !xs || !ll || !t->node) {
        free(xs);
        free(ll);
        geo_plane_table_free(t);
        sph_err_set(err, SPH_ERR_NOMEM, "projection tables: out of memory");
        return NULL;
    }
    t->proj = p;
    t->x0 = x0;
    t->y0 = y0;
    t->step = step;
    t->inv = 1.0 / step;
    t->nx = (int)fx;
    t->ny = (int)fy;
    t->lon0 = p->lon0;
    double *ys = xs + nn, *lon = ll, *lat = ll + nn;
    for (int j = 0; j < t->ny; j++)
        for (int i = 0; i < t->nx; i++) {
            xs[(size_t)j * t->nx + i] = x0 + i * step;
            ys[(size_t)j * t->nx + i] = y0 + j * step;
        }
    /* nodes that do not unproject stay NaN: cells touching them use PROJ */
    (void)geo_inverse(p, nn, xs, ys, lon, lat, NULL);
    int polar = 0;
    for (size_t q = 0; q < nn; q++) {
        double *nd = t->node + 4 * q;
        double a = isfinite(lon[q]) ? geo_grid_angle(p, lon[q], lat[q]) : NAN;
        nd[0] = isfinite(a) ? remainder(lon[q] - t->lon0, 360.0) : NAN;
        nd[1] = isfinite(a) ? lat[q] : NAN;
        nd[2] = isfinite(a) ? cos(a) : NAN;
        nd[3] = isfinite(a) ? sin(a) : NAN;
        polar |= isfinite(a) && fabs(lat[q]) > 88.0;
    }
    free(xs);
    free(ll);
    if (polar) {
        /* longitude is singular at the pole: no bilinear table there */
        geo_plane_table_free(t);
        sph_err_set(err, SPH_ERR_CONFIG,
                    "projection tables: the domain reaches within 2 degrees of a pole, where "
                    "longitude is singular (set domain.plane_tables false)");
        return NULL;
    }
    return t;
}

geo_plane_table *geo_plane_table_auto(const geo_proj *p, double x0, double x1, double y0, double y1,
                                      double step, char *why, size_t whylen, sph_error *err)
{
    if (whylen)
        why[0] = '\0';
    geo_plane_table *t = geo_plane_table_create(p, x0, x1, y0, y1, step, err);
    if (!t && (err->code == SPH_ERR_CONFIG || err->code == SPH_ERR_PARAM)) {
        snprintf(why, whylen, "%s", err->msg);
        sph_error_clear(err);
    }
    return t;
}

void geo_plane_table_free(geo_plane_table *t)
{
    if (!t)
        return;
    free(t->node);
    free(t);
}

/* remainder(x, 360): x itself within [-180, 180], x -/+ 360 (exact by
 * Sterbenz's lemma) within one more turn, remainder() beyond that and for
 * a zero result (whose sign remainder takes from x) or NaN: the same bits
 * as remainder() everywhere, without its cost on the per-step path. */
static inline double wrap180(double x)
{
    if (x >= -180.0 && x <= 180.0)
        return x;
    double r = x > 180.0 && x < 540.0 ? x - 360.0 : x < -180.0 && x > -540.0 ? x + 360.0 : 0.0;
    return r != 0.0 ? r : remainder(x, 360.0);
}

/* One point from the table; 0 outside it (or on a node without values). */
static int plane_point(const geo_plane_table *t, double x, double y, double *lon, double *lat,
                       double *cs, double *sn)
{
    double fx = (x - t->x0) * t->inv, fy = (y - t->y0) * t->inv;
    if (!(fx >= 0.0 && fy >= 0.0 && fx < t->nx - 1 && fy < t->ny - 1))
        return 0;
    int i = (int)fx, j = (int)fy;
    double wx = fx - i, wy = fy - j;
    const double *a = t->node + 4 * ((size_t)j * t->nx + i), *b = a + 4;
    const double *c = a + 4 * (size_t)t->nx, *d = c + 4;
    double w00 = (1 - wx) * (1 - wy), w10 = wx * (1 - wy), w01 = (1 - wx) * wy, w11 = wx * wy;
    double v[4];
    for (int f = 0; f < 4; f++)
        v[f] = w00 * a[f] + w10 * b[f] + w01 * c[f] + w11 * d[f];
    if (!(isfinite(v[0]) && isfinite(v[2])))
        return 0;
    /* bilinear cos and sin: normalised back onto the circle */
    double r = 1.0 / sqrt(v[2] * v[2] + v[3] * v[3]);
    *lon = wrap180(v[0] + t->lon0);
    *lat = v[1];
    *cs = v[2] * r;
    *sn = v[3] * r;
    return 1;
}

int geo_plane_lookup(const geo_plane_table *t, size_t n, const double *x, const double *y,
                     double *lon, double *lat, double *cs, double *sn, sph_error *err)
{
    /* the table on the OpenMP threads (per-point writes: the same values with
     * any thread count); points outside it go to PROJ, serially (one context) */
    size_t nmiss = 0;
#pragma omp parallel for schedule(dynamic, 2048) reduction(+ : nmiss) if (n >= 4096) /* as FORCING_OMP_GRAB */
    for (size_t k = 0; k < n; k++)
        nmiss += !plane_point(t, x[k], y[k], lon + k, lat + k, cs + k, sn + k);
    if (nmiss == 0)
        return SPH_OK;
    size_t nout = 0;
    for (size_t k = 0; k < n; k++) {
        if (plane_point(t, x[k], y[k], lon + k, lat + k, cs + k, sn + k))
            continue;
        /* outside the table: PROJ, as without it */
        if (geo_inverse(t->proj, 1, x + k, y + k, lon + k, lat + k, NULL) != SPH_OK)
            nout++;
        double a = isfinite(lon[k]) ? geo_grid_angle(t->proj, lon[k], lat[k]) : NAN;
        if (!isfinite(a))
            a = 0.0;
        cs[k] = cos(a);
        sn[k] = sin(a);
    }
    if (nout)
        return sph_err_set(err, SPH_ERR_PARAM, "projection %s: %zu of %zu points do not unproject",
                           t->proj->definition, nout, n);
    return SPH_OK;
}
