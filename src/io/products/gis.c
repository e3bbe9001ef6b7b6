/* GIS products: class polygons, GeoJSON, GeoPackage, COG (see io/gis.h). */
#include "io/gis.h"

#include <cjson/cJSON.h>
#include <cpl_conv.h>
#include <cpl_error.h>
#include <gdal.h>
#include <math.h>
#include <ogr_api.h>
#include <ogr_srs_api.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "util/fileio.h"
#include "util/timeutil.h"

const gis_class gis_classes[GIS_NCLASSES] = {
    { "<1/10", 0.0, 0.1, 150, 200, 255 },   { "1-3/10", 0.1, 0.4, 140, 255, 160 },
    { "4-6/10", 0.4, 0.7, 255, 255, 0 },    { "7-8/10", 0.7, 0.9, 255, 125, 7 },
    { "9-10/10", 0.9, 0.995, 255, 0, 0 },   { "10/10", 0.995, INFINITY, 145, 0, 0 },
};

int gis_class_of(double c)
{
    if (isnan(c) || c < gis_classes[1].lo)
        return 0;
    for (int k = GIS_NCLASSES - 1; k > 0; k--)
        if (c >= gis_classes[k].lo)
            return k;
    return 0;
}

static void polygon_free(gis_polygon *pg)
{
    for (gis_ring *r = pg->rings; r && r < pg->rings + pg->nrings; r++) {
        free(r->lon);
        free(r->lat);
    }
    free(pg->rings);
}

void gis_multipolygon_free(gis_multipolygon *m)
{
    if (!m)
        return;
    for (gis_polygon *pg = m->polys; pg && pg < m->polys + m->npolys; pg++)
        polygon_free(pg);
    free(m->polys);
    memset(m, 0, sizeof *m);
}

/* ---- tracing ---- */

typedef struct trace_edge { long from, to; int dir; } trace_edge; /* dir 0 E, 1 N, 2 W, 3 S */

static const int DX[4] = { 1, 0, -1, 0 }, DY[4] = { 0, 1, 0, -1 };

/* a ring under construction: an edge_line and its capacity */
typedef struct ring_buf { edge_line l; size_t cap; } ring_buf;

static int rb_push(ring_buf *b, double x, double y)
{
    return edge_line_push(&b->l, &b->cap, x, y);
}

static double ring_area2(const double *x, const double *y, size_t n) /* twice the signed area */
{
    double a = 0;
    for (size_t k = 0; k + 1 < n; k++)
        a += x[k] * y[k + 1] - x[k + 1] * y[k];
    return a;
}

static int point_in_ring(const gis_ring *r, double x, double y)
{
    int in = 0;
    for (size_t k = 0; k + 1 < r->n; k++) {
        double x1 = r->lon[k], y1 = r->lat[k], x2 = r->lon[k + 1], y2 = r->lat[k + 1];
        if ((y1 > y) != (y2 > y) && x < x1 + (y - y1) * (x2 - x1) / (y2 - y1))
            in = !in;
    }
    return in;
}

static int add_ring(gis_polygon *p, ring_buf *b)
{
    gis_ring *nr = realloc(p->rings, (p->nrings + 1) * sizeof *nr);
    if (!nr)
        return -1;
    p->rings = nr;
    p->rings[p->nrings].n = b->l.npts;
    p->rings[p->nrings].lon = b->l.lon;
    p->rings[p->nrings].lat = b->l.lat;
    p->nrings++;
    memset(b, 0, sizeof *b);
    return 0;
}

int gis_class_polygons(const prod_grid *g, const double *conc, const unsigned char *land,
                       double lo, double hi, gis_multipolygon *out, sph_error *err)
{
    memset(out, 0, sizeof *out);
    if (prod_grid_check(g, err) != SPH_OK)
        return err ? err->code : SPH_ERR_PARAM;
    int nx = g->nlon, ny = g->nlat;
    size_t nc = (size_t)nx * ny, nv = (size_t)(nx + 1) * (ny + 1);
    unsigned char *in = malloc(nc);
    long *out_e = malloc(2 * nv * sizeof *out_e);
    trace_edge *edges = malloc(4 * nc * sizeof *edges);
    unsigned char *used = NULL;
    ring_buf rb = { 0 };
    gis_polygon *holes = NULL;
    size_t nholes = 0, ne = 0;
    int rc = SPH_OK;
    if (!in || !out_e || !edges)
        goto nomem;
    for (size_t k = 0; k < nc; k++) {
        double c = isnan(conc[k]) ? 0.0 : conc[k];
        in[k] = !(land && land[k]) && c >= lo && c < hi;
        if (in[k])
            out->cell_area_km2 += prod_grid_cell_area_m2(g, (int)(k / (size_t)nx)) * 1e-6;
    }
    for (size_t v = 0; v < 2 * nv; v++)
        out_e[v] = -1;
#define IN(i, j) ((i) >= 0 && (i) < nx && (j) >= 0 && (j) < ny && in[(size_t)(j) * nx + (i)])
#define VID(i, j) ((long)(j) * (nx + 1) + (i))
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++) {
            if (!IN(i, j))
                continue;
            /* sides counter-clockwise: bottom (E), right (N), top (W), left (S) */
            long c4[4] = { VID(i, j), VID(i + 1, j), VID(i + 1, j + 1), VID(i, j + 1) };
            int nb[4] = { IN(i, j - 1), IN(i + 1, j), IN(i, j + 1), IN(i - 1, j) };
            for (int s = 0; s < 4; s++) {
                if (nb[s])
                    continue;
                trace_edge e = { c4[s], c4[(s + 1) & 3], s };
                long slot = 2 * e.from + (out_e[2 * e.from] >= 0);
                out_e[slot] = (long)ne;
                edges[ne++] = e;
            }
        }
    used = calloc(ne ? ne : 1, 1);
    if (!used)
        goto nomem;
    double e = GIS_CORNER_CUT;
    for (size_t s0 = 0; s0 < ne; s0++) {
        if (used[s0])
            continue;
        /* follow the ring: at a vertex with two exits (cells meeting at a
         * corner) turn left, staying with the cell of the incoming side */
        size_t cur = s0, prev = s0;
        /* find the edge arriving at s0's start: walk the ring once first */
        long nring = 0;
        do {
            used[cur] = 1;
            long v = edges[cur].to, a = out_e[2 * v], b = out_e[2 * v + 1];
            long nxt = a;
            if (b >= 0 && edges[b].dir == (edges[cur].dir + 1) % 4)
                nxt = b;
            prev = cur;
            cur = (size_t)nxt;
            nring++;
        } while (cur != s0 && nring <= (long)ne);
        /* prev is the edge before s0; walk again emitting points */
        cur = s0;
        do {
            const trace_edge *te = &edges[cur], *tp = &edges[prev];
            long v = te->from;
            double vx = (double)(v % (nx + 1)), vy = (double)(v / (nx + 1));
            int saddle = out_e[2 * v + 1] >= 0, ok = 0;
            if (saddle)
                ok = rb_push(&rb, vx - e * DX[tp->dir], vy - e * DY[tp->dir]) ||
                     rb_push(&rb, vx + e * DX[te->dir], vy + e * DY[te->dir]);
            else if (te->dir != tp->dir || te->dir == 0 || te->dir == 2)
                ok = rb_push(&rb, vx, vy);
            if (ok)
                goto nomem;
            long w = te->to, a = out_e[2 * w], b = out_e[2 * w + 1];
            long nxt = a;
            if (b >= 0 && edges[b].dir == (te->dir + 1) % 4)
                nxt = b;
            prev = cur;
            cur = (size_t)nxt;
        } while (cur != s0);
        if (rb_push(&rb, rb.l.lon[0], rb.l.lat[0]))
            goto nomem;
        for (size_t q = 0; q < rb.l.npts; q++) { /* corner indices -> degrees */
            rb.l.lon[q] = g->lon0 + (rb.l.lon[q] - 0.5) * g->dlon;
            rb.l.lat[q] = g->lat0 + (rb.l.lat[q] - 0.5) * g->dlat;
        }
        int is_hole = ring_area2(rb.l.lon, rb.l.lat, rb.l.npts) < 0;
        if (is_hole) {
            gis_polygon *nh = realloc(holes, (nholes + 1) * sizeof *nh);
            if (!nh)
                goto nomem;
            holes = nh;
            memset(&holes[nholes], 0, sizeof holes[0]);
            if (add_ring(&holes[nholes++], &rb))
                goto nomem;
        } else {
            gis_polygon *np = realloc(out->polys, (out->npolys + 1) * sizeof *np);
            if (!np)
                goto nomem;
            out->polys = np;
            memset(&out->polys[out->npolys], 0, sizeof out->polys[0]);
            if (add_ring(&out->polys[out->npolys++], &rb))
                goto nomem;
        }
    }
    /* each hole into the smallest exterior that holds it */
    for (size_t h = 0; h < nholes; h++) {
        gis_ring *hr = &holes[h].rings[0];
        long best = -1;
        double best_a = INFINITY;
        for (size_t p = 0; p < out->npolys; p++) {
            gis_ring *er = &out->polys[p].rings[0];
            if (!point_in_ring(er, hr->lon[0], hr->lat[0]))
                continue;
            double a = ring_area2(er->lon, er->lat, er->n);
            if (a < best_a) {
                best_a = a;
                best = (long)p;
            }
        }
        if (best < 0) { /* cannot happen for a closed class region */
            rc = sph_err_set(err, SPH_ERR_INTERNAL, "class polygons: a hole outside every ring");
            goto done;
        }
        ring_buf tmp = { { hr->n, 1, hr->lon, hr->lat }, hr->n };
        if (add_ring(&out->polys[best], &tmp))
            goto nomem;
        holes[h].nrings = 0;
    }
    goto done;
#undef IN
#undef VID
nomem:
    rc = sph_err_set(err, SPH_ERR_NOMEM, "class polygons: out of memory (%d x %d grid)", nx, ny);
done:
    if (rc != SPH_OK)
        gis_multipolygon_free(out);
    for (size_t h = 0; h < nholes; h++)
        polygon_free(&holes[h]);
    free(holes);
    free(rb.l.lon);
    free(rb.l.lat);
    free(used);
    free(edges);
    free(out_e);
    free(in);
    return rc;
}

/* ---- store ---- */

typedef struct gis_entry {
    double t, threshold, edge_km;
    gis_multipolygon cls[GIS_NCLASSES];
    edge_set edge;
} gis_entry;

struct gis_store {
    size_t n, cap;
    gis_entry *e;
};

gis_store *gis_store_new(void)
{
    return calloc(1, sizeof(gis_store));
}

void gis_store_free(gis_store *s)
{
    if (!s)
        return;
    for (size_t k = 0; k < s->n; k++) {
        for (int c = 0; c < GIS_NCLASSES; c++)
            gis_multipolygon_free(&s->e[k].cls[c]);
        edge_set_free(&s->e[k].edge);
    }
    free(s->e);
    free(s);
}

static int edge_copy(const edge_set *a, edge_set *b)
{
    memset(b, 0, sizeof *b);
    if (!a || a->nlines == 0)
        return 0;
    if (!(b->lines = calloc(a->nlines, sizeof *b->lines)))
        return -1;
    b->nlines = a->nlines;
    b->npts_total = a->npts_total;
    for (size_t l = 0; l < a->nlines; l++) {
        size_t n = a->lines[l].npts;
        b->lines[l].npts = n;
        b->lines[l].closed = a->lines[l].closed;
        b->lines[l].lon = malloc((n ? n : 1) * sizeof(double));
        b->lines[l].lat = malloc((n ? n : 1) * sizeof(double));
        if (!b->lines[l].lon || !b->lines[l].lat)
            return -1;
        memcpy(b->lines[l].lon, a->lines[l].lon, n * sizeof(double));
        memcpy(b->lines[l].lat, a->lines[l].lat, n * sizeof(double));
    }
    return 0;
}

int gis_store_add(gis_store *s, const prod_grid *g, const double *conc, const unsigned char *land,
                  const edge_set *edge, double threshold, double valid_time, sph_error *err)
{
    if (s->n == s->cap) {
        size_t nc = s->cap ? 2 * s->cap : 8;
        gis_entry *ne = realloc(s->e, nc * sizeof *ne);
        if (!ne)
            return sph_err_set(err, SPH_ERR_NOMEM, "GIS products: out of memory");
        s->e = ne;
        s->cap = nc;
    }
    gis_entry *en = &s->e[s->n];
    memset(en, 0, sizeof *en);
    s->n++; /* freed with the store from here on */
    en->t = valid_time;
    en->threshold = threshold;
    en->edge_km = edge ? edge_length_km(edge) : 0;
    for (int c = 0; c < GIS_NCLASSES; c++) {
        int rc = gis_class_polygons(g, conc, land, gis_classes[c].lo, gis_classes[c].hi, &en->cls[c], err);
        if (rc != SPH_OK)
            return rc;
    }
    if (edge_copy(edge, &en->edge))
        return sph_err_set(err, SPH_ERR_NOMEM, "GIS products: out of memory");
    return SPH_OK;
}

/* ---- GeoJSON ---- */

cJSON *gis_geojson_collection(cJSON **feats)
{
    cJSON *fc = cJSON_CreateObject();
    *feats = cJSON_CreateArray();
    if (!fc || !*feats) {
        cJSON_Delete(fc);
        cJSON_Delete(*feats);
        return NULL;
    }
    cJSON_AddStringToObject(fc, "type", "FeatureCollection");
    cJSON_AddItemToObject(fc, "features", *feats);
    return fc;
}

int gis_geojson_write(cJSON *fc, const char *path, sph_error *err)
{
    char *text = cJSON_PrintUnformatted(fc);
    cJSON_Delete(fc);
    if (!text)
        return sph_err_set(err, SPH_ERR_NOMEM, "write %s: out of memory", path);
    int rc = atomic_write_file(path, text, strlen(text), err);
    free(text);
    return rc;
}

cJSON *gis_geojson_feature(cJSON *feats, const char *type, cJSON **coords)
{
    cJSON *f = cJSON_CreateObject(), *geom = cJSON_CreateObject(), *props = cJSON_CreateObject();
    *coords = cJSON_CreateArray();
    cJSON_AddItemToArray(feats, f);
    cJSON_AddStringToObject(f, "type", "Feature");
    cJSON_AddItemToObject(f, "geometry", geom);
    cJSON_AddItemToObject(f, "properties", props);
    cJSON_AddStringToObject(geom, "type", type);
    cJSON_AddItemToObject(geom, "coordinates", *coords);
    return props;
}

static double r7(double v)
{
    return round(v * 1e7) / 1e7;
}

static void colour_hex(int c, char *buf, size_t len)
{
    snprintf(buf, len, "#%02X%02X%02X", gis_classes[c].r, gis_classes[c].g, gis_classes[c].b);
}

int gis_write_classes_geojson(const gis_store *s, const char *path, sph_error *err)
{
    cJSON *feats, *fc = gis_geojson_collection(&feats);
    if (!fc)
        return sph_err_set(err, SPH_ERR_NOMEM, "write %s: out of memory", path);
    char iso[32], hex[16];
    for (size_t k = 0; k < s->n; k++) {
        time_format_iso(s->e[k].t, iso, sizeof iso);
        for (int c = 0; c < GIS_NCLASSES; c++) {
            const gis_multipolygon *m = &s->e[k].cls[c];
            cJSON *polys, *props = gis_geojson_feature(feats, "MultiPolygon", &polys);
            for (size_t p = 0; p < m->npolys; p++) {
                cJSON *poly = cJSON_CreateArray();
                cJSON_AddItemToArray(polys, poly);
                for (size_t r = 0; r < m->polys[p].nrings; r++) {
                    const gis_ring *rg = &m->polys[p].rings[r];
                    cJSON *ring = cJSON_CreateArray();
                    cJSON_AddItemToArray(poly, ring);
                    for (size_t q = 0; q < rg->n; q++) {
                        double xy[2] = { r7(rg->lon[q]), r7(rg->lat[q]) }; /* lon, lat */
                        cJSON_AddItemToArray(ring, cJSON_CreateDoubleArray(xy, 2));
                    }
                }
            }
            cJSON_AddStringToObject(props, "valid_time", iso);
            cJSON_AddStringToObject(props, "class", gis_classes[c].name);
            cJSON_AddNumberToObject(props, "conc_min", gis_classes[c].lo);
            if (isfinite(gis_classes[c].hi))
                cJSON_AddNumberToObject(props, "conc_max", gis_classes[c].hi);
            else
                cJSON_AddNumberToObject(props, "conc_max", 1.0);
            cJSON_AddNumberToObject(props, "area_km2", round(m->cell_area_km2 * 1000) / 1000);
            colour_hex(c, hex, sizeof hex);
            cJSON_AddStringToObject(props, "colour", hex);
        }
    }
    return gis_geojson_write(fc, path, err);
}

/* ---- GDAL / OGR ---- */

static OGRSpatialReferenceH wgs84(void)
{
    OGRSpatialReferenceH srs = OSRNewSpatialReference(NULL);
    if (srs && OSRImportFromEPSG(srs, 4326) != OGRERR_NONE) {
        OSRDestroySpatialReference(srs);
        return NULL;
    }
    if (srs)
        OSRSetAxisMappingStrategy(srs, OAMS_TRADITIONAL_GIS_ORDER); /* lon, lat */
    return srs;
}

static int gdal_fail(const char *what, const char *path, sph_error *err)
{
    const char *m = CPLGetLastErrorMsg();
    return sph_err_set(err, SPH_ERR_IO, "%s %s: %s", what, path, m && m[0] ? m : "GDAL error");
}

static void gdal_close(GDALDatasetH a, GDALDatasetH b, OGRSpatialReferenceH srs)
{
    if (a)
        GDALClose(a);
    if (b)
        GDALClose(b);
    if (srs)
        OSRDestroySpatialReference(srs);
}

/* restores GDAL's error handler; commits tmp to path, or removes it */
static int gdal_finish(int rc, const char *tmp, const char *path, sph_error *err)
{
    CPLPopErrorHandler();
    if (rc == SPH_OK)
        return atomic_commit(tmp, path, err);
    unlink(tmp);
    return rc;
}

static void add_field(OGRLayerH l, const char *name, OGRFieldType t)
{
    OGRFieldDefnH f = OGR_Fld_Create(name, t);
    OGR_L_CreateField(l, f, TRUE);
    OGR_Fld_Destroy(f);
}

int gis_write_gpkg(const gis_store *s, const char *path, double cycle_time, sph_error *err)
{
    char tmp[4200], date[40], iso[32];
    snprintf(tmp, sizeof tmp, "%s.tmp%ld.gpkg", path, (long)getpid());
    unlink(tmp);
    GDALAllRegister();
    CPLPushErrorHandler(CPLQuietErrorHandler);
    CPLErrorReset();
    /* the GeoPackage's timestamps: the cycle time, so a rerun is identical */
    time_format_iso(cycle_time, iso, sizeof iso);
    snprintf(date, sizeof date, "%.19s.000Z", iso);
    CPLSetThreadLocalConfigOption("OGR_CURRENT_DATE", date);
    int rc = SPH_OK;
    OGRSpatialReferenceH srs = wgs84();
    GDALDriverH drv = GDALGetDriverByName("GPKG");
    GDALDatasetH ds = drv && srs ? GDALCreate(drv, tmp, 0, 0, 0, GDT_Unknown, NULL) : NULL;
    OGRLayerH lc = ds ? GDALDatasetCreateLayer(ds, "ice_classes", srs, wkbMultiPolygon, NULL) : NULL;
    OGRLayerH le = ds ? GDALDatasetCreateLayer(ds, "ice_edge", srs, wkbMultiLineString, NULL) : NULL;
    if (!lc || !le) {
        rc = gdal_fail("create GeoPackage", tmp, err);
        goto done;
    }
    add_field(lc, "valid_time", OFTString);
    add_field(lc, "class", OFTString);
    add_field(lc, "conc_min", OFTReal);
    add_field(lc, "conc_max", OFTReal);
    add_field(lc, "area_km2", OFTReal);
    add_field(lc, "colour", OFTString);
    add_field(le, "valid_time", OFTString);
    add_field(le, "threshold", OFTReal);
    add_field(le, "length_km", OFTReal);
    GDALDatasetStartTransaction(ds, FALSE);
    for (size_t k = 0; k < s->n && rc == SPH_OK; k++) {
        const gis_entry *en = &s->e[k];
        time_format_iso(en->t, iso, sizeof iso);
        for (int c = 0; c < GIS_NCLASSES && rc == SPH_OK; c++) {
            const gis_multipolygon *m = &en->cls[c];
            OGRFeatureH f = OGR_F_Create(OGR_L_GetLayerDefn(lc));
            char hex[16];
            colour_hex(c, hex, sizeof hex);
            OGR_F_SetFieldString(f, 0, iso);
            OGR_F_SetFieldString(f, 1, gis_classes[c].name);
            OGR_F_SetFieldDouble(f, 2, gis_classes[c].lo);
            OGR_F_SetFieldDouble(f, 3, isfinite(gis_classes[c].hi) ? gis_classes[c].hi : 1.0);
            OGR_F_SetFieldDouble(f, 4, m->cell_area_km2);
            OGR_F_SetFieldString(f, 5, hex);
            OGRGeometryH mp = OGR_G_CreateGeometry(wkbMultiPolygon);
            for (size_t p = 0; p < m->npolys; p++) {
                OGRGeometryH poly = OGR_G_CreateGeometry(wkbPolygon);
                for (size_t r = 0; r < m->polys[p].nrings; r++) {
                    OGRGeometryH ring = OGR_G_CreateGeometry(wkbLinearRing);
                    const gis_ring *rg = &m->polys[p].rings[r];
                    for (size_t q = 0; q < rg->n; q++)
                        OGR_G_AddPoint_2D(ring, rg->lon[q], rg->lat[q]);
                    OGR_G_AddGeometryDirectly(poly, ring);
                }
                OGR_G_AddGeometryDirectly(mp, poly);
            }
            OGR_F_SetGeometryDirectly(f, mp);
            if (OGR_L_CreateFeature(lc, f) != OGRERR_NONE)
                rc = gdal_fail("write GeoPackage", tmp, err);
            OGR_F_Destroy(f);
        }
        OGRFeatureH f = OGR_F_Create(OGR_L_GetLayerDefn(le));
        OGR_F_SetFieldString(f, 0, iso);
        OGR_F_SetFieldDouble(f, 1, en->threshold);
        OGR_F_SetFieldDouble(f, 2, en->edge_km);
        OGRGeometryH ml = OGR_G_CreateGeometry(wkbMultiLineString);
        for (size_t l = 0; l < en->edge.nlines; l++) {
            OGRGeometryH ln = OGR_G_CreateGeometry(wkbLineString);
            for (size_t q = 0; q < en->edge.lines[l].npts; q++)
                OGR_G_AddPoint_2D(ln, en->edge.lines[l].lon[q], en->edge.lines[l].lat[q]);
            OGR_G_AddGeometryDirectly(ml, ln);
        }
        OGR_F_SetGeometryDirectly(f, ml);
        if (rc == SPH_OK && OGR_L_CreateFeature(le, f) != OGRERR_NONE)
            rc = gdal_fail("write GeoPackage", tmp, err);
        OGR_F_Destroy(f);
    }
    if (GDALDatasetCommitTransaction(ds) != OGRERR_NONE && rc == SPH_OK)
        rc = gdal_fail("write GeoPackage", tmp, err);
done:
    gdal_close(ds, NULL, srs);
    CPLSetThreadLocalConfigOption("OGR_CURRENT_DATE", NULL);
    return gdal_finish(rc, tmp, path, err);
}

int gis_write_cog(const char *path, const prod_grid *g, int nb, const double *const *bands,
                  const char *const *names, const char *const *units, sph_error *err)
{
    if (prod_grid_check(g, err) != SPH_OK)
        return err ? err->code : SPH_ERR_PARAM;
    char tmp[4200];
    snprintf(tmp, sizeof tmp, "%s.tmp%ld.tif", path, (long)getpid());
    GDALAllRegister();
    CPLPushErrorHandler(CPLQuietErrorHandler);
    CPLErrorReset();
    int rc = SPH_OK, nx = g->nlon, ny = g->nlat;
    float *row = malloc((size_t)nx * sizeof *row);
    OGRSpatialReferenceH srs = wgs84();
    GDALDriverH mem = GDALGetDriverByName("MEM"), cog = GDALGetDriverByName("COG");
    GDALDatasetH ds = mem && row ? GDALCreate(mem, "", nx, ny, nb, GDT_Float32, NULL) : NULL;
    GDALDatasetH out = NULL;
    if (!ds || !cog || !srs) {
        rc = ds || !row ? gdal_fail("create GeoTIFF", tmp, err)
                        : sph_err_set(err, SPH_ERR_IO, "create GeoTIFF %s: GDAL has no COG or MEM driver", tmp);
        goto done;
    }
    /* north-up: row 0 is the northern row; pixel edges half a cell off
     * the cell centres */
    double gt[6] = { g->lon0 - 0.5 * g->dlon, g->dlon, 0, g->lat0 + (ny - 0.5) * g->dlat, 0, -g->dlat };
    GDALSetGeoTransform(ds, gt);
    GDALSetSpatialRef(ds, srs);
    for (int b = 0; b < nb && rc == SPH_OK; b++) {
        GDALRasterBandH band = GDALGetRasterBand(ds, b + 1);
        GDALSetRasterNoDataValue(band, (double)1.0e20f);
        GDALSetDescription(band, names[b]);
        if (units && units[b])
            GDALSetRasterUnitType(band, units[b]);
        for (int j = 0; j < ny && rc == SPH_OK; j++) {
            const double *src = bands[b] ? bands[b] + (size_t)(ny - 1 - j) * nx : NULL;
            for (int i = 0; i < nx; i++)
                row[i] = src && isfinite(src[i]) ? (float)src[i] : 1.0e20f;
            if (GDALRasterIO(band, GF_Write, 0, j, nx, 1, row, nx, 1, GDT_Float32, 0, 0) != CE_None)
                rc = gdal_fail("write GeoTIFF", tmp, err);
        }
    }
    if (rc == SPH_OK) {
        char *opts[] = { "COMPRESS=DEFLATE", "PREDICTOR=YES", "OVERVIEWS=AUTO", NULL };
        out = GDALCreateCopy(cog, tmp, ds, FALSE, opts, NULL, NULL);
        if (!out)
            rc = gdal_fail("write GeoTIFF", tmp, err);
    }
done:
    gdal_close(out, ds, srs);
    free(row);
    return gdal_finish(rc, tmp, path, err);
}

void gis_release_caches(void)
{
    GDALDestroyDriverManager();
    OSRCleanup();

}
