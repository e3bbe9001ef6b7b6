/* Marching squares for the ice edge (see io/edge.h for the rules). */
#include "io/edge.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define DEG2RAD (M_PI / 180.0)
#define EDGE_CLAMP 1e-6 /* crossings stay this fraction of a cell off nodes */

int prod_grid_check(const prod_grid *g, sph_error *err)
{
    if (!g || g->nlon < 2 || g->nlat < 2)
        return sph_err_set(err, SPH_ERR_PARAM, "output grid: need at least 2x2 cells");
    if (!(g->dlon > 0) || !(g->dlat > 0) || !isfinite(g->lon0) || !isfinite(g->lat0))
        return sph_err_set(err, SPH_ERR_PARAM,
                           "output grid: dlon and dlat must be > 0 (south to north)");
    if ((long)g->nlon * g->nlat > 100000000L)
        return sph_err_set(err, SPH_ERR_PARAM, "output grid: %d x %d cells is too large",
                           g->nlon, g->nlat);
    double top = g->lat0 + (g->nlat - 1) * g->dlat;
    if (g->lat0 < -90 || top > 90)
        return sph_err_set(err, SPH_ERR_PARAM, "output grid: latitudes %g..%g outside -90..90",
                           g->lat0, top);
    return SPH_OK;
}

double prod_grid_cell_area_m2(const prod_grid *g, int j)
{
    double latc = g->lat0 + j * g->dlat;
    double s = fmax(latc - 0.5 * g->dlat, -90.0), n = fmin(latc + 0.5 * g->dlat, 90.0);
    return PROD_EARTH_RADIUS_M * PROD_EARTH_RADIUS_M * g->dlon * DEG2RAD *
           fabs(sin(n * DEG2RAD) - sin(s * DEG2RAD));
}

double prod_gc_distance_m(double lon1, double lat1, double lon2, double lat2)
{
    double p1 = lat1 * DEG2RAD, p2 = lat2 * DEG2RAD;
    double dp = p2 - p1, dl = (lon2 - lon1) * DEG2RAD;
    double a = sin(dp / 2) * sin(dp / 2) + cos(p1) * cos(p2) * sin(dl / 2) * sin(dl / 2);
    if (a > 1)
        a = 1;
    return 2 * PROD_EARTH_RADIUS_M * asin(sqrt(a));
}

void edge_set_free(edge_set *s)
{
    if (!s)
        return;
    for (size_t k = 0; k < s->nlines; k++) {
        free(s->lines[k].lon);
        free(s->lines[k].lat);
    }
    free(s->lines);
    memset(s, 0, sizeof *s);
}

/* Grid-edge ids: horizontal edge from node (i,j) to (i+1,j) is 2*(j*nlon+i),
 * vertical edge from (i,j) to (i,j+1) is 2*(j*nlon+i)+1. */
typedef struct {
    const prod_grid *g;
    const double *val; /* node values with NaN-sea as 0, land as NaN */
    double thr;
} ms_ctx;

static void edge_point(const ms_ctx *c, long id, double *lon, double *lat)
{
    int nlon = c->g->nlon;
    long node = id / 2;
    int i = (int)(node % nlon), j = (int)(node / nlon);
    int vertical = (int)(id & 1);
    long other = vertical ? node + nlon : node + 1;
    double a = c->val[node], b = c->val[other];
    /* t measured from node (i,j) toward the other node */
    double t = (c->thr - a) / (b - a);
    if (!(t >= EDGE_CLAMP))
        t = EDGE_CLAMP;
    if (t > 1 - EDGE_CLAMP)
        t = 1 - EDGE_CLAMP;
    double x = i + (vertical ? 0 : t), y = j + (vertical ? t : 0);
    *lon = c->g->lon0 + x * c->g->dlon;
    *lat = c->g->lat0 + y * c->g->dlat;
}

int edge_line_push(edge_line *l, size_t *cap, double lon, double lat)
{
    if (l->npts == *cap) {
        size_t nc = *cap ? 2 * *cap : 64;
        double *a = realloc(l->lon, nc * sizeof *a);
        if (!a)
            return -1;
        l->lon = a;
        double *b = realloc(l->lat, nc * sizeof *b);
        if (!b)
            return -1;
        l->lat = b;
        *cap = nc;
    }
    l->lon[l->npts] = lon;
    l->lat[l->npts] = lat;
    l->npts++;
    return 0;
}

static int set_push(edge_set *s, size_t *cap)
{
    if (s->nlines == *cap) {
        size_t nc = *cap ? 2 * *cap : 16;
        edge_line *l = realloc(s->lines, nc * sizeof *l);
        if (!l)
            return -1;
        s->lines = l;
        *cap = nc;
    }
    memset(&s->lines[s->nlines], 0, sizeof s->lines[0]);
    s->nlines++;
    return 0;
}

int edge_extract(const prod_grid *g, const double *conc, const unsigned char *land,
                 double threshold, edge_set *out, sph_error *err)
{
    memset(out, 0, sizeof *out);
    if (prod_grid_check(g, err) != SPH_OK)
        return err ? err->code : SPH_ERR_PARAM;
    if (!conc || !isfinite(threshold))
        return sph_err_set(err, SPH_ERR_PARAM, "ice edge: no concentration or bad threshold");
    int nlon = g->nlon, nlat = g->nlat;
    size_t nn = (size_t)nlon * nlat, nedges = 2 * nn;
    size_t maxseg = 2 * (size_t)(nlon - 1) * (nlat - 1);
    double *val = malloc(nn * sizeof *val);
    unsigned char *ice = malloc(nn);
    long *start_at = malloc(nedges * sizeof *start_at);
    long *end_at = malloc(nedges * sizeof *end_at);
    long *seg_from = malloc(maxseg * sizeof *seg_from);
    long *seg_to = malloc(maxseg * sizeof *seg_to);
    unsigned char *used = calloc(maxseg ? maxseg : 1, 1);
    int rc = SPH_OK;
    if (!val || !ice || !start_at || !end_at || !seg_from || !seg_to || !used) {
        rc = sph_err_set(err, SPH_ERR_NOMEM, "ice edge: out of memory (%d x %d grid)", nlon, nlat);
        goto done;
    }
    for (size_t k = 0; k < nn; k++) {
        if (land && land[k]) {
            val[k] = NAN;
            ice[k] = 0;
        } else {
            val[k] = isfinite(conc[k]) ? conc[k] : 0.0;
            ice[k] = val[k] >= threshold;
        }
    }
    for (size_t k = 0; k < nedges; k++)
        start_at[k] = end_at[k] = -1;

    ms_ctx ctx = { g, val, threshold };
    long nseg = 0;
    for (int j = 0; j + 1 < nlat; j++) {
        for (int i = 0; i + 1 < nlon; i++) {
            long n0 = (long)j * nlon + i;
            long node[4] = { n0, n0 + 1, n0 + nlon + 1, n0 + nlon }; /* bl br tr tl (CCW) */
            int skip = 0, nice = 0;
            double mean = 0;
            for (int c = 0; c < 4; c++) {
                if (isnan(val[node[c]]))
                    skip = 1;
                nice += ice[node[c]];
                mean += 0.25 * val[node[c]];
            }
            if (skip || nice == 0 || nice == 4)
                continue;
            /* grid edges walked CCW: bottom, right, top, left */
            long eid[4] = { 2 * n0, 2 * (n0 + 1) + 1, 2 * (n0 + nlon), 2 * n0 + 1 };
            long cross_e[4];
            int cross_exit[4], nc = 0;
            for (int c = 0; c < 4; c++) {
                int a = ice[node[c]], b = ice[node[(c + 1) & 3]];
                if (a != b) {
                    cross_e[nc] = eid[c];
                    cross_exit[nc] = a; /* ice -> water along the CCW walk */
                    nc++;
                }
            }
            /* nc is 2 or 4. An exit crossing joins the next crossing CCW
             * (cutting off water) or the previous one (cutting off ice);
             * with two crossings both are the same. Either way the segment
             * runs from the exit to an entry with ice on its left. */
            int join_next = nc == 2 || mean >= threshold;
            for (int q = 0; q < nc; q++) {
                if (!cross_exit[q])
                    continue;
                int r = join_next ? (q + 1) % nc : (q + nc - 1) % nc;
                seg_from[nseg] = cross_e[q];
                seg_to[nseg] = cross_e[r];
                start_at[cross_e[q]] = nseg;
                end_at[cross_e[r]] = nseg;
                nseg++;
            }
        }
    }

    size_t lcap = 0;
    /* Open lines first (their first segment has no predecessor), then
     * the rings that remain. */
    for (int pass = 0; pass < 2; pass++) {
        for (long s0 = 0; s0 < nseg; s0++) {
            if (used[s0] || (pass == 0 && end_at[seg_from[s0]] >= 0))
                continue;
            if (set_push(out, &lcap) != 0)
                goto nomem;
            edge_line *l = &out->lines[out->nlines - 1];
            size_t pcap = 0;
            double lon, lat;
            edge_point(&ctx, seg_from[s0], &lon, &lat);
            if (edge_line_push(l, &pcap, lon, lat) != 0)
                goto nomem;
            long s = s0;
            while (s >= 0 && !used[s]) {
                used[s] = 1;
                edge_point(&ctx, seg_to[s], &lon, &lat);
                if (edge_line_push(l, &pcap, lon, lat) != 0)
                    goto nomem;
                s = start_at[seg_to[s]];
            }
            l->closed = s == s0;
            out->npts_total += l->npts;
        }
    }
    goto done;
nomem:
    rc = sph_err_set(err, SPH_ERR_NOMEM, "ice edge: out of memory");
    edge_set_free(out);
done:
    free(val);
    free(ice);
    free(start_at);
    free(end_at);
    free(seg_from);
    free(seg_to);
    free(used);
    return rc;
}

double edge_length_km(const edge_set *s)
{
    double sum = 0;
    for (size_t k = 0; k < s->nlines; k++) {
        const edge_line *l = &s->lines[k];
        for (size_t p = 1; p < l->npts; p++)
            sum += prod_gc_distance_m(l->lon[p - 1], l->lat[p - 1], l->lon[p], l->lat[p]);
    }
    return sum / 1000.0;
}

double edge_max_distance_nm(const edge_set *s, double ref_lon, double ref_lat)
{
    double best = NAN;
    for (size_t k = 0; k < s->nlines; k++) {
        const edge_line *l = &s->lines[k];
        for (size_t p = 0; p < l->npts; p++) {
            double d = prod_gc_distance_m(ref_lon, ref_lat, l->lon[p], l->lat[p]);
            if (!(d <= best))
                best = d;
        }
    }
    return best / PROD_NAUTICAL_MILE_M;
}
