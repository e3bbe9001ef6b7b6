/* The NOAA IMS daily Northern Hemisphere snow and ice analysis (NSIDC
 * G02156) as the initial raster (issue 19 item 2), written here as its
 * documentation describes it:
 *  - ASCII: 30 lines of header text, then the grid as one character per
 *    cell ("I1"), one row per line, (1,1) at the lower left corner (the
 *    first row the grid's bottom, South America's side); values 0 outside
 *    the Northern Hemisphere, 1 sea, 2 land, 3 sea ice, 4 snow; the 24 km
 *    grid 1024 x 1024 cells of 23684.977 m from (-12126597, -12126480) m,
 *    the 4 km grid 6144 x 6144 cells of 4000 m from (-12288000, -12288000)
 *    (NSIDC's user guide, Table 4, as its ArcGIS import note gives it);
 *  - GeoTIFF (4 km): the same grid as a byte band, top row first, with the
 *    IMS files' own projection: polar stereographic, true scale at 60 N,
 *    80 W down from the pole, a = 6378137 m, b = 6356257 m.
 * Asserts: cell centres within 1e-6 degrees of Snyder's inverse
 * polar-stereographic formula with that ellipsoid, cell areas dx dy / k^2,
 * land (2, 4) flagged land, outside (0) "no information" (never open
 * water), ice cells at the configured concentration and thickness, seeded
 * ice area and volume within 1 % of the raster's; a domain box reads only
 * the cells that cover it; refusals (missing key, truncated file, a class
 * the documentation does not list) are one line with no raster. */
#include <gdal.h>
#include <ogr_srs_api.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include "ims_file.h"

static const char *IMS_PROJ = "+proj=stere +lat_0=90 +lat_ts=60 +lon_0=-80 +k=1 +x_0=0 +y_0=0 "
                              "+a=6378137 +b=6356257 +units=m +no_defs";
static const double ICE_A = 0.9, ICE_H = 1.2;
typedef ims_grid grid;

static double rho_equator(void)
{
    double x, y, k;
    rp_ps_forward(IA, IB, 60, -80, -80, 0, &x, &y, &k);
    return hypot(x, y);
}

/* The scene, by map position: outside the hemisphere beyond the equator's
 * circle, a snow-covered and a bare land block (Alaska and Yukon), sea ice
 * within 1500 km of the pole, open water elsewhere. */
static int scene(double x, double y, double rho_eq)
{
    double rho = hypot(x, y);
    if (rho > rho_eq)
        return 0;
    if (x > -3000e3 && x < -1000e3 && y > -2500e3 && y < -500e3)
        return x < -2000e3 ? 4 : 2;
    if (rho < 1500e3)
        return 3;
    return 1;
}

static int scene_cls(double x, double y, const void *ctx)
{
    return scene(x, y, *(const double *)ctx);
}

static void write_ascii(const char *path, const grid *g, int rows)
{
    double re = rho_equator();
    ims_write_ascii(path, g, rows, scene_cls, &re);
}

static void write_geotiff(const char *path, const grid *g)
{
    GDALAllRegister();
    GDALDriverH drv = GDALGetDriverByName("GTiff");
    char *opts[] = {"COMPRESS=DEFLATE", "TILED=YES", NULL};
    GDALDatasetH ds = drv ? GDALCreate(drv, path, g->n, g->n, 1, GDT_Byte, opts) : NULL;
    CHECK(ds != NULL, "create GeoTIFF %s", path);
    if (!ds)
        return;
    double gt[6] = {g->xll, g->cell, 0, g->yll + g->n * g->cell, 0, -g->cell};
    GDALSetGeoTransform(ds, gt);
    OGRSpatialReferenceH srs = OSRNewSpatialReference(NULL);
    OSRImportFromProj4(srs, IMS_PROJ);
    GDALSetSpatialRef(ds, srs);
    OSRDestroySpatialReference(srs);
    GDALRasterBandH b = GDALGetRasterBand(ds, 1);
    double re = rho_equator();
    unsigned char *row = malloc((size_t)g->n);
    int failed = 0;
    for (int r = 0; r < g->n; r++) { /* top row first */
        int j = g->n - 1 - r;
        for (int i = 0; i < g->n; i++)
            row[i] = (unsigned char)scene(cx(g, i), cy(g, j), re);
        failed += GDALRasterIO(b, GF_Write, 0, r, g->n, 1, row, g->n, 1, GDT_Byte, 0, 0) != CE_None;
    }
    CHECK(failed == 0, "%d rows not written", failed);
    free(row);
    GDALClose(ds);
}

static void check_raster(const char *what, const char *path, const grid *g, const double *bbox)
{
    ice_raster_options o;
    ice_raster_options_default(&o);
    o.ims_ice_conc = ICE_A;
    o.ims_ice_thick = ICE_H;
    if (bbox)
        for (int k = 0; k < 4; k++)
            o.bbox[k] = bbox[k];
    ice_raster *r = rp_read(what, path, &o);
    if (!r)
        return;
    CHECK(r->kind == ICE_RASTER_PROJECTED, "%s: kind %d", what, r->kind);
    /* where the window starts, on the documented grid */
    int i0 = (int)lround((r->x[0] - cx(g, 0)) / g->cell), j0 = (int)lround((r->y[0] - cy(g, 0)) / g->cell);
    CHECK(fabs(r->x[0] - cx(g, i0)) < 1e-6 && fabs(r->y[0] - cy(g, j0)) < 1e-6 &&
              fabs(r->dx - g->cell) < 1e-9 && fabs(r->dy - g->cell) < 1e-9,
          "%s: first centre (%.3f, %.3f) m, spacing %g m: not on the IMS grid", what, r->x[0],
          r->y[0], r->dx);
    if (!bbox)
        CHECK(r->nlon == g->n && r->nlat == g->n && i0 == 0 && j0 == 0, "%s: %d x %d cells", what,
              r->nlon, r->nlat);
    else {
        CHECK(r->nlon < g->n / 4 && r->nlat < g->n / 4, "%s: window of %d x %d cells for the box",
              what, r->nlon, r->nlat);
        /* the box lies inside the window */
        int outside = 0;
        for (int q = 0; q <= 8; q++)
            for (int p = 0; p <= 8; p++) {
                double x, y, k;
                rp_ps_forward(IA, IB, 60, -80, bbox[0] + (bbox[1] - bbox[0]) * p / 8,
                              bbox[2] + (bbox[3] - bbox[2]) * q / 8, &x, &y, &k);
                outside += x < r->x[0] || x > r->x[r->nlon - 1] || y < r->y[0] ||
                           y > r->y[r->nlat - 1];
            }
        CHECK(outside == 0, "%s: %d points of the box outside the window", what, outside);
    }
    double re = rho_equator(), worst = 0, worst_area = 0, want_area = 0, want_vol = 0;
    size_t nland = 0, nnoinfo = 0, bad = 0;
    for (int j = 0; j < r->nlat; j++)
        for (int i = 0; i < r->nlon; i++) {
            double x = cx(g, i0 + i), y = cy(g, j0 + j), lon, lat, rlon, rlat, fx, fy, k;
            rp_ps_inverse(IA, IB, 60, -80, x, y, &lon, &lat);
            ice_raster_cell_lonlat(r, i, j, &rlon, &rlat);
            worst = fmax(worst, fmax(fabs(remainder(rlon - lon, 360)), fabs(rlat - lat)));
            rp_ps_forward(IA, IB, 60, -80, lon, lat, &fx, &fy, &k);
            double area = g->cell * g->cell / (k * k);
            worst_area = fmax(worst_area, fabs(ice_raster_area(r, i, j) / area - 1));
            size_t q = (size_t)j * r->nlon + i;
            int c = scene(x, y, re), flag = r->land ? r->land[q] : 0;
            int want_flag = c == 2 || c == 4 ? 1 : c == 0 ? 2 : 0;
            nland += want_flag == 1;
            nnoinfo += want_flag == 2;
            if (flag != want_flag || (want_flag && !isnan(r->conc[q])) ||
                (c == 1 && r->conc[q] != 0) ||
                (c == 3 && (r->conc[q] != ICE_A || r->thick[q] != ICE_H)))
                bad++;
            if (c == 3) {
                want_area += ICE_A * area;
                want_vol += ICE_A * ICE_H * area;
            }
        }
    CHECK(worst < 1e-6, "%s: cell centres off Snyder's inverse by %g degrees", what, worst);
    CHECK(worst_area < 1e-6, "%s: cell areas off dx dy / k^2 by %g", what, worst_area);
    CHECK(bad == 0 && r->nland == nland && r->nnoinfo == nnoinfo,
          "%s: %zu cells wrong; land %zu (want %zu), no information %zu (want %zu)", what, bad,
          r->nland, nland, r->nnoinfo, nnoinfo);
    CHECK(want_area > 0 && nland > 0 && (bbox || nnoinfo > 0), "%s: the scene lacks a class",
          what);
    CHECK(r->thickness_kind == ICE_THICK_ICE && strstr(r->thickness_why, "initial.ims.ice_thickness"),
          "%s: thickness kind from \"%s\"", what, r->thickness_why);
    CHECK(strstr(r->grid, "IMS") != NULL, "%s: grid \"%s\"", what, r->grid);
    rp_check_seeded(what, r, want_area, want_vol, 0.15);
    ice_raster_free(r);
}

static void expect_refusal(const char *what, const char *path, double conc, double thick,
                           const char *needle)
{
    ice_raster_options o;
    ice_raster_options_default(&o);
    o.ims_ice_conc = conc;
    o.ims_ice_thick = thick;
    rp_refused(what, path, &o, needle);
}

int main(void)
{
    char dir[] = "/tmp/sphice-test-raster-ims-XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    char p24[512], p4[512], ptif[512], pbad[512];
    snprintf(p24, sizeof p24, "%s/ims1999038_00UTC_24km_v1.1.asc", dir);
    snprintf(p4, sizeof p4, "%s/ims2024038_00UTC_4km_v1.3.asc", dir);
    snprintf(ptif, sizeof ptif, "%s/ims2024038_4km_GIS_v1.3.tif", dir);
    snprintf(pbad, sizeof pbad, "%s/ims2024039_00UTC_24km_v1.3.asc", dir);
    /* the whole 24 km hemisphere */
    write_ascii(p24, &G24, G24.n);
    check_raster("IMS 24 km ASCII", p24, &G24, NULL);
    /* a 4 km file read over a domain (Beaufort Sea and the Yukon) */
    double box[4] = {-150, -110, 65, 85};
    write_ascii(p4, &G4, G4.n);
    check_raster("IMS 4 km ASCII, domain", p4, &G4, box);
    unlink(p4);
    write_geotiff(ptif, &G4);
    check_raster("IMS 4 km GeoTIFF, domain", ptif, &G4, box);
    /* refusals: the keys that say what an ice cell is */
    expect_refusal("ASCII without initial.ims.ice_concentration", p24, NAN, ICE_H,
                   "initial.ims.ice_concentration");
    expect_refusal("ASCII without initial.ims.ice_thickness", p24, ICE_A, NAN,
                   "initial.ims.ice_thickness");
    expect_refusal("GeoTIFF without initial.ims.ice_concentration", ptif, NAN, ICE_H,
                   "initial.ims.ice_concentration");
    unlink(ptif);
    /* a truncated file: 1000 of its 1024 rows */
    write_ascii(pbad, &G24, 1000);
    expect_refusal("truncated ASCII", pbad, ICE_A, ICE_H, "truncated IMS 24 km file: 1000 of 1024 rows");
    /* a row cut short */
    FILE *f = fopen(pbad, "a");
    fprintf(f, "1111\n");
    fclose(f);
    expect_refusal("short row", pbad, ICE_A, ICE_H, "has 4 cells, not 1024");
    /* a class the documentation does not list */
    write_ascii(pbad, &G24, G24.n);
    f = fopen(pbad, "r+");
    fseek(f, -3, SEEK_END);
    fputc('7', f);
    fclose(f);
    expect_refusal("class 7", pbad, ICE_A, ICE_H, "class '7' is not one of the documented");
    unlink(pbad);
    unlink(p24);
    rmdir(dir);
    return check_summary("test_raster_ims");
}
