/* GIS products (io/gis.h): class polygons against the gridded class area
 * (geodesic area on the WGS84 ellipsoid by PROJ's geodesic routines, the
 * grid's cells by the spherical zone formula written here), rings checked
 * by an independent routine (closed, orientation by the right-hand rule,
 * no self-intersection, no two rings crossing or touching), the GeoJSON
 * file read back, the Cloud-Optimised GeoTIFF's georeferencing read back
 * through GDAL, and the GeoPackage's layers through OGR. */
#include <cjson/cJSON.h>
#include <gdal.h>
#include <geodesic.h>
#include <math.h>
#include <ogr_api.h>
#include <ogr_srs_api.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "io/gis.h"
#include "util/fileio.h"

/* ---- independent geometry ---- */

static double shoelace(const double *x, const double *y, size_t n)
{
    double a = 0;
    for (size_t k = 0; k + 1 < n; k++)
        a += (x[k] * y[k + 1] - x[k + 1] * y[k]) / 2;
    return a;
}

static double orient(double ax, double ay, double bx, double by, double cx, double cy)
{
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
}

static int on_seg(double ax, double ay, double bx, double by, double px, double py)
{
    return fmin(ax, bx) <= px && px <= fmax(ax, bx) && fmin(ay, by) <= py && py <= fmax(ay, by);
}

/* do closed segments ab and cd share any point (touching counts) */
static int segs_meet(double ax, double ay, double bx, double by, double cx, double cy, double dx, double dy)
{
    double d1 = orient(cx, cy, dx, dy, ax, ay), d2 = orient(cx, cy, dx, dy, bx, by);
    double d3 = orient(ax, ay, bx, by, cx, cy), d4 = orient(ax, ay, bx, by, dx, dy);
    if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0)))
        return 1;
    if (d1 == 0 && on_seg(cx, cy, dx, dy, ax, ay))
        return 1;
    if (d2 == 0 && on_seg(cx, cy, dx, dy, bx, by))
        return 1;
    if (d3 == 0 && on_seg(ax, ay, bx, by, cx, cy))
        return 1;
    if (d4 == 0 && on_seg(ax, ay, bx, by, dx, dy))
        return 1;
    return 0;
}

typedef struct ring_view { size_t n; const double *x, *y; } ring_view;

/* a ring is simple: no two non-adjacent edges meet */
static int ring_simple(ring_view r)
{
    size_t m = r.n - 1; /* edges */
    for (size_t a = 0; a < m; a++)
        for (size_t b = a + 1; b < m; b++) {
            if (b == a + 1 || (a == 0 && b == m - 1))
                continue;
            if (segs_meet(r.x[a], r.y[a], r.x[a + 1], r.y[a + 1], r.x[b], r.y[b], r.x[b + 1], r.y[b + 1]))
                return 0;
        }
    return 1;
}

static int rings_apart(ring_view r, ring_view s)
{
    for (size_t a = 0; a + 1 < r.n; a++)
        for (size_t b = 0; b + 1 < s.n; b++)
            if (segs_meet(r.x[a], r.y[a], r.x[a + 1], r.y[a + 1], s.x[b], s.y[b], s.x[b + 1], s.y[b + 1]))
                return 0;
    return 1;
}

static int inside(ring_view r, double px, double py)
{
    int in = 0;
    for (size_t k = 0; k + 1 < r.n; k++)
        if ((r.y[k] > py) != (r.y[k + 1] > py) &&
            px < r.x[k] + (py - r.y[k]) * (r.x[k + 1] - r.x[k]) / (r.y[k + 1] - r.y[k]))
            in = !in;
    return in;
}

/* geodesic area of a ring on WGS84, m^2 (counter-clockwise positive) */
static double geod_area(const struct geod_geodesic *gd, ring_view r)
{
    double *la = malloc(r.n * sizeof *la), *lo = malloc(r.n * sizeof *lo), A = 0, P = 0;
    for (size_t k = 0; k + 1 < r.n; k++) {
        la[k] = r.y[k];
        lo[k] = r.x[k];
    }
    geod_polygonarea(gd, la, lo, (int)r.n - 1, &A, &P);
    free(la);
    free(lo);
    return A;
}

/* ---- fields ---- */

static unsigned long rng = 12345;
static double urand(void)
{
    rng = rng * 6364136223846793005UL + 1442695040888963407UL;
    return (double)(rng >> 11) / 9007199254740992.0;
}

/* the demo's output grid; concentration: a dome with rough noise (many
 * saddles and holes), a lake of land in the middle */
#define NX 131
#define NY 106
static const prod_grid G = { NX, NY, 121.0, 40.0, 0.01, 0.01 };

static void make_field(double *c, unsigned char *land)
{
    for (int j = 0; j < NY; j++)
        for (int i = 0; i < NX; i++) {
            size_t k = (size_t)j * NX + i;
            double x = (i - 65.0) / 50.0, y = (j - 53.0) / 40.0, r2 = x * x + y * y;
            double v = 1.15 * (1 - r2) + 0.25 * (urand() - 0.5);
            c[k] = v < 0 ? 0 : v > 1 ? 1 : v;
            if ((i + j) % 37 == 0)
                c[k] = NAN; /* undefined sea counts as 0 */
            land[k] = (i > 120 && j > 80) || (hypot(i - 40.0, j - 60.0) < 5);
        }
    /* a checkerboard patch: corners touching diagonally */
    for (int j = 10; j < 16; j++)
        for (int i = 10; i < 16; i++)
            c[(size_t)j * NX + i] = ((i + j) & 1) ? 0.5 : 0.05;
}

static double grid_class_area_km2(const double *c, const unsigned char *land, double lo, double hi)
{
    double R = 6371000.0, a = 0, d2r = M_PI / 180;
    for (int j = 0; j < NY; j++)
        for (int i = 0; i < NX; i++) {
            size_t k = (size_t)j * NX + i;
            double v = isnan(c[k]) ? 0 : c[k];
            if (land[k] || !(v >= lo && v < hi))
                continue;
            double s = G.lat0 + (j - 0.5) * G.dlat, n = s + G.dlat;
            a += R * R * G.dlon * d2r * (sin(n * d2r) - sin(s * d2r));
        }
    return a * 1e-6;
}

static void test_polygons(const double *c, const unsigned char *land)
{
    struct geod_geodesic gd;
    geod_init(&gd, 6378137.0, 1 / 298.257223563);
    const double bounds[GIS_NCLASSES + 1] = { 0, 0.1, 0.4, 0.7, 0.9, 0.995, INFINITY };
    for (int cl = 0; cl < GIS_NCLASSES; cl++) {
        CHECK(gis_classes[cl].lo == bounds[cl] && gis_classes[cl].hi == bounds[cl + 1], "class %d bounds", cl);
        gis_multipolygon m;
        sph_error err;
        sph_error_clear(&err);
        CHECK(gis_class_polygons(&G, c, land, bounds[cl], bounds[cl + 1], &m, &err) == SPH_OK, "%s", err.msg);
        double want = grid_class_area_km2(c, land, bounds[cl], bounds[cl + 1]);
        double area = 0;
        int bad_close = 0, bad_orient = 0, bad_simple = 0, bad_apart = 0, bad_hole = 0;
        size_t nrings = 0, nholes = 0;
        ring_view all[4096];
        size_t nall = 0;
        for (size_t p = 0; p < m.npolys; p++) {
            const gis_polygon *pg = &m.polys[p];
            for (size_t r = 0; r < pg->nrings; r++) {
                ring_view v = { pg->rings[r].n, pg->rings[r].lon, pg->rings[r].lat };
                nrings++;
                nholes += r > 0;
                if (v.n < 4 || v.x[0] != v.x[v.n - 1] || v.y[0] != v.y[v.n - 1]) {
                    bad_close++;
                    continue;
                }
                double s = shoelace(v.x, v.y, v.n);
                bad_orient += r == 0 ? !(s > 0) : !(s < 0);
                bad_simple += !ring_simple(v);
                if (r > 0) { /* a hole lies inside its exterior */
                    ring_view e = { pg->rings[0].n, pg->rings[0].lon, pg->rings[0].lat };
                    bad_hole += !inside(e, v.x[0], v.y[0]);
                }
                double ga = geod_area(&gd, v);
                area += ga * 1e-6; /* holes come out negative */
                if (nall < sizeof all / sizeof all[0])
                    all[nall++] = v;
            }
        }
        for (size_t a = 0; a < nall; a++)
            for (size_t b = a + 1; b < nall; b++)
                bad_apart += !rings_apart(all[a], all[b]);
        CHECK(bad_close == 0, "class %s: %d rings not closed", gis_classes[cl].name, bad_close);
        CHECK(bad_orient == 0, "class %s: %d rings against the right-hand rule", gis_classes[cl].name, bad_orient);
        CHECK(bad_simple == 0, "class %s: %d self-intersecting rings", gis_classes[cl].name, bad_simple);
        CHECK(bad_apart == 0, "class %s: %d ring pairs meet", gis_classes[cl].name, bad_apart);
        CHECK(bad_hole == 0, "class %s: %d holes outside their exterior", gis_classes[cl].name, bad_hole);
        if (want > 0)
            CHECK(fabs(area - want) <= 0.02 * want, "class %s: polygons %.3f km2 (WGS84 geodesic), cells %.3f km2",
                  gis_classes[cl].name, area, want);
        else
            CHECK(m.npolys == 0 && fabs(area) < 1e-9, "class %s: no cells, no polygon", gis_classes[cl].name);
        CHECK(fabs(m.cell_area_km2 - want) <= 1e-6 * want + 1e-9, "class %s: reported cell area %.6f vs %.6f",
              gis_classes[cl].name, m.cell_area_km2, want);
        printf("class %-8s polygons %3zu rings %4zu holes %3zu  area %9.3f km2 (cells %9.3f)\n",
               gis_classes[cl].name, m.npolys, nrings, nholes, area, want);
        if (cl == 0)
            CHECK(nholes > 0, "open water surrounds the ice: holes (%zu)", nholes);
        gis_multipolygon_free(&m);
    }
}

static void test_files(const char *dir, const double *c, const unsigned char *land)
{
    gis_store *st = gis_store_new();
    sph_error err;
    sph_error_clear(&err);
    edge_set e;
    CHECK(edge_extract(&G, c, land, 0.15, &e, &err) == SPH_OK, "%s", err.msg);
    CHECK(gis_store_add(st, &G, c, land, &e, 0.15, 918424800.0, &err) == SPH_OK, "%s", err.msg);
    char path[600];
    snprintf(path, sizeof path, "%s/c.geojson", dir);
    CHECK(gis_write_classes_geojson(st, path, &err) == SPH_OK, "%s", err.msg);
    /* GeoJSON read back: 6 features, [lon, lat], exterior CCW, holes CW */
    size_t len = 0;
    char *text = NULL;
    FILE *f = fopen(path, "rb");
    if (f) {
        fseek(f, 0, SEEK_END);
        len = (size_t)ftell(f);
        fseek(f, 0, SEEK_SET);
        text = malloc(len + 1);
        if (text && fread(text, 1, len, f) == len)
            text[len] = 0;
        fclose(f);
    }
    cJSON *j = text ? cJSON_Parse(text) : NULL;
    CHECK(j != NULL, "GeoJSON parses");
    cJSON *feats = cJSON_GetObjectItem(j, "features");
    CHECK(cJSON_GetArraySize(feats) == GIS_NCLASSES, "%d features", cJSON_GetArraySize(feats));
    int bad = 0, rings = 0;
    cJSON *ft;
    cJSON_ArrayForEach(ft, feats)
    {
        cJSON *geom = cJSON_GetObjectItem(ft, "geometry"), *polys = cJSON_GetObjectItem(geom, "coordinates"), *poly;
        CHECK(!strcmp(cJSON_GetObjectItem(geom, "type")->valuestring, "MultiPolygon"), "MultiPolygon");
        cJSON_ArrayForEach(poly, polys)
        {
            int r = 0;
            cJSON *ring;
            cJSON_ArrayForEach(ring, poly)
            {
                int n = cJSON_GetArraySize(ring);
                double *x = malloc((size_t)n * sizeof *x), *y = malloc((size_t)n * sizeof *y);
                for (int q = 0; q < n; q++) {
                    cJSON *pt = cJSON_GetArrayItem(ring, q);
                    x[q] = cJSON_GetArrayItem(pt, 0)->valuedouble;
                    y[q] = cJSON_GetArrayItem(pt, 1)->valuedouble;
                    bad += !(x[q] > 120.9 && x[q] < 122.4 && y[q] > 39.9 && y[q] < 41.1); /* lon, lat */
                }
                double s = shoelace(x, y, (size_t)n);
                bad += r == 0 ? !(s > 0) : !(s < 0);
                bad += x[0] != x[n - 1] || y[0] != y[n - 1];
                free(x);
                free(y);
                r++;
                rings++;
            }
        }
    }
    CHECK(bad == 0 && rings > 10, "GeoJSON rings: %d faults in %d rings", bad, rings);
    cJSON_Delete(j);
    free(text);

    /* GeoPackage through OGR */
    snprintf(path, sizeof path, "%s/g.gpkg", dir);
    CHECK(gis_write_gpkg(st, path, 918424800.0, &err) == SPH_OK, "%s", err.msg);
    GDALAllRegister();
    GDALDatasetH ds = GDALOpenEx(path, GDAL_OF_VECTOR | GDAL_OF_READONLY, NULL, NULL, NULL);
    CHECK(ds != NULL, "GeoPackage opens");
    if (ds) {
        OGRLayerH lc = GDALDatasetGetLayerByName(ds, "ice_classes"), le = GDALDatasetGetLayerByName(ds, "ice_edge");
        CHECK(lc && OGR_L_GetFeatureCount(lc, 1) == GIS_NCLASSES, "ice_classes layer with 6 features");
        CHECK(le && OGR_L_GetFeatureCount(le, 1) == 1, "ice_edge layer with 1 feature");
        if (lc) {
            OGRSpatialReferenceH srs = OGR_L_GetSpatialRef(lc);
            const char *code = srs ? OSRGetAuthorityCode(srs, NULL) : NULL;
            CHECK(code && !strcmp(code, "4326"), "GeoPackage CRS EPSG:%s", code ? code : "?");
            OGRFeatureH fe;
            OGR_L_ResetReading(lc);
            int k = 0;
            while ((fe = OGR_L_GetNextFeature(lc))) {
                double want = grid_class_area_km2(c, land, gis_classes[k].lo, gis_classes[k].hi);
                CHECK(fabs(OGR_F_GetFieldAsDouble(fe, OGR_F_GetFieldIndex(fe, "area_km2")) - want) <= 1e-6 * want + 1e-9,
                      "GeoPackage area_km2 of %s", gis_classes[k].name);
                OGR_F_Destroy(fe);
                k++;
            }
        }
        GDALClose(ds);
    }
    gis_store_free(st);
    edge_set_free(&e);

    /* COG: georeferencing and a pixel read back */
    snprintf(path, sizeof path, "%s/f.tif", dir);
    double *h = malloc(sizeof(double) * NX * NY);
    for (size_t k = 0; k < (size_t)NX * NY; k++)
        h[k] = land[k] ? NAN : 0.01 * (double)(k % 97);
    const double *bands[2] = { c, h };
    const char *names[2] = { "siconc", "sithick" }, *units[2] = { "1", "m" };
    CHECK(gis_write_cog(path, &G, 2, bands, names, units, &err) == SPH_OK, "%s", err.msg);
    ds = GDALOpen(path, GA_ReadOnly);
    CHECK(ds != NULL, "GeoTIFF opens");
    if (ds) {
        double gt[6];
        CHECK(GDALGetGeoTransform(ds, gt) == CE_None, "geotransform");
        /* outer edge of the cells: centre of cell (0, NY-1) minus half a cell */
        CHECK(fabs(gt[0] - 120.995) < 1e-9 && fabs(gt[1] - 0.01) < 1e-12 && gt[2] == 0 &&
                  fabs(gt[3] - (40.0 + 105 * 0.01 + 0.005)) < 1e-9 && gt[4] == 0 && fabs(gt[5] + 0.01) < 1e-12,
              "geotransform %.6f %.6f %g %.6f %g %.6f", gt[0], gt[1], gt[2], gt[3], gt[4], gt[5]);
        CHECK(GDALGetRasterXSize(ds) == NX && GDALGetRasterYSize(ds) == NY && GDALGetRasterCount(ds) == 2,
              "size %d x %d x %d", GDALGetRasterXSize(ds), GDALGetRasterYSize(ds), GDALGetRasterCount(ds));
        OGRSpatialReferenceH srs = GDALGetSpatialRef(ds);
        const char *code = srs ? OSRGetAuthorityCode(srs, NULL) : NULL;
        CHECK(code && !strcmp(code, "4326"), "GeoTIFF CRS EPSG:%s", code ? code : "?");
        const char *layout = GDALGetMetadataItem(ds, "LAYOUT", "IMAGE_STRUCTURE");
        CHECK(layout && !strcmp(layout, "COG"), "LAYOUT=%s", layout ? layout : "(none)");
        /* the pixel holding (121.37 E, 40.47 N) is the grid cell there */
        int i = 37, jj = 47, px = (int)floor((121.37 - gt[0]) / gt[1]), py = (int)floor((40.47 - gt[3]) / gt[5]);
        float v = 0;
        GDALRasterBandH b2 = GDALGetRasterBand(ds, 2);
        CHECK(GDALRasterIO(b2, GF_Read, px, py, 1, 1, &v, 1, 1, GDT_Float32, 0, 0) == CE_None, "read pixel");
        size_t k = (size_t)jj * NX + i;
        CHECK(fabs(v - h[k]) < 1e-6, "pixel (%d,%d) = %g, cell (%d,%d) = %g", px, py, v, i, jj, h[k]);
        CHECK(!strcmp(GDALGetDescription(b2), "sithick"), "band description %s", GDALGetDescription(b2));
        int has = 0;
        double nd = GDALGetRasterNoDataValue(b2, &has);
        CHECK(has && nd == (double)1.0e20f, "nodata %g", nd);
        GDALClose(ds);
    }
    free(h);
}

int main(void)
{
    double *c = malloc(sizeof(double) * NX * NY);
    unsigned char *land = malloc((size_t)NX * NY);
    make_field(c, land);
    test_polygons(c, land);
    char dir[] = "/tmp/sphice-gis-XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    test_files(dir, c, land);
    const char *files[] = { "c.geojson", "g.gpkg", "f.tif" };
    for (size_t k = 0; k < 3; k++) {
        char p[600];
        snprintf(p, sizeof p, "%s/%s", dir, files[k]);
        unlink(p);
    }
    rmdir(dir);
    free(c);
    free(land);
    gis_release_caches();
    return check_summary("test_gis");
}
