/* Any georeferenced GeoTIFF band as the initial raster, through GDAL
 * (issue 19 item 2), written here with GDAL's C API as GDAL documents a
 * GeoTIFF's georeferencing and band metadata: geotransform, CRS (NSIDC's
 * polar stereographic north on WGS 84, true scale at 70 N, -45 E, as
 * EPSG:3413), nodata, scale/offset, unit type, description and metadata
 * items (standard_name, cell_methods, flag_values/flag_meanings as GDAL's
 * netCDF driver exposes CF attributes). Asserts: cell centres within 1e-6
 * degrees of Snyder's inverse formula, areas dx dy / k^2, land where the
 * flags say land, the concentration in percent packed by scale 0.01, the
 * thickness in cm packed by 0.1, seeded ice area and volume within 1 % of
 * the raster's; and that every refusal (a band whose role is unknown, no
 * CRS, a CRS not on the earth, a band or unit no key and no metadata give,
 * an undecidable thickness kind, a truncated file) is one line naming the
 * file and the key, with no raster. */
#include <gdal.h>
#include <ogr_srs_api.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include "raster_provider.h"

enum { NX = 48, NY = 40 };
static const double WA = 6378137.0, WRF = 298.257223563, D = 10000.0;
static const double XL = 200e3, YT = -800e3; /* left and top edges */
static const char *PS3413 = "+proj=stere +lat_0=90 +lat_ts=70 +lon_0=-45 +k=1 +x_0=0 +y_0=0 "
                            "+datum=WGS84 +units=m +no_defs";
enum { LAND_RAW = 30000, NODATA_RAW = -1 };

static double wb(void) { return WA * (1 - 1 / WRF); }

/* raw Int16 of band 1 (percent x 100) and band 2 (mm), file row rt from the top */
static int raw_conc(int i, int rt)
{
    if (i < 6) return LAND_RAW;
    if (i == 30 && rt == 5) return NODATA_RAW;
    double u = (i - 28.0) / 9, v = (rt - 20.0) / 10;
    int c = (int)lround(10000 * exp(-u * u - v * v));
    return c < 1000 ? 0 : c;
}
static int raw_thick(int i, int rt) { return 500 + 20 * i + 3 * rt; }

typedef struct {
    int nbands, with_srs, local_cs, meta2, thick_name_only, conc_meta, geographic;
} tif_opts;

static void write_tif(const char *path, tif_opts t)
{
    GDALAllRegister();
    GDALDriverH drv = GDALGetDriverByName("GTiff");
    GDALDatasetH ds = drv ? GDALCreate(drv, path, NX, NY, t.nbands, GDT_Int16, NULL) : NULL;
    CHECK(ds != NULL, "create %s", path);
    if (!ds)
        return;
    double gt[6] = {XL, D, 0, YT, 0, -D}, gg[6] = {10, 0.5, 0, 80, 0, -0.25};
    GDALSetGeoTransform(ds, t.geographic ? gg : gt);
    if (t.with_srs) {
        OGRSpatialReferenceH srs = OSRNewSpatialReference(NULL);
        if (t.geographic)
            OSRImportFromEPSG(srs, 4326);
        else if (t.local_cs)
            OSRSetLocalCS(srs, "plant grid");
        else
            OSRImportFromProj4(srs, PS3413);
        GDALSetSpatialRef(ds, srs);
        OSRDestroySpatialReference(srs);
    }
    GDALRasterBandH b1 = GDALGetRasterBand(ds, 1);
    if (t.conc_meta) {
        GDALSetDescription(b1, "siconc");
        GDALSetMetadataItem(b1, "standard_name", "sea_ice_area_fraction", NULL);
        GDALSetRasterUnitType(b1, "%");
    }
    GDALSetRasterScale(b1, 0.01);
    GDALSetRasterOffset(b1, 0);
    GDALSetRasterNoDataValue(b1, NODATA_RAW);
    GDALSetMetadataItem(b1, "flag_values", "30000", NULL);
    GDALSetMetadataItem(b1, "flag_meanings", "land", NULL);
    short buf[NX * NY];
    for (int rt = 0; rt < NY; rt++)
        for (int i = 0; i < NX; i++)
            buf[rt * NX + i] = (short)raw_conc(i, rt);
    CHECK(GDALRasterIO(b1, GF_Write, 0, 0, NX, NY, buf, NX, NY, GDT_Int16, 0, 0) == CE_None,
          "write band 1");
    if (t.nbands > 1) {
        GDALRasterBandH b2 = GDALGetRasterBand(ds, 2);
        if (t.meta2) {
            GDALSetDescription(b2, t.thick_name_only ? "thick" : "sithick");
            if (!t.thick_name_only) {
                GDALSetMetadataItem(b2, "standard_name", "sea_ice_thickness", NULL);
                GDALSetMetadataItem(b2, "cell_methods", "area: mean where sea_ice", NULL);
            }
            GDALSetRasterUnitType(b2, "cm");
        }
        GDALSetRasterScale(b2, 0.1);
        for (int rt = 0; rt < NY; rt++)
            for (int i = 0; i < NX; i++)
                buf[rt * NX + i] = (short)raw_thick(i, rt);
        CHECK(GDALRasterIO(b2, GF_Write, 0, 0, NX, NY, buf, NX, NY, GDT_Int16, 0, 0) == CE_None,
              "write band 2");
    }
    GDALClose(ds);
}

static void check_good(const char *path)
{
    ice_raster *r = rp_read("GeoTIFF", path, NULL);
    if (!r)
        return;
    CHECK(r->kind == ICE_RASTER_PROJECTED && r->nlon == NX && r->nlat == NY, "kind %d, %d x %d",
          r->kind, r->nlon, r->nlat);
    double worst = 0, worst_area = 0, want_area = 0, want_vol = 0;
    size_t bad = 0, nland = 0;
    for (int j = 0; j < NY; j++) /* j from the south: file row rt = NY - 1 - j */
        for (int i = 0; i < NX; i++) {
            int rt = NY - 1 - j, c = raw_conc(i, rt);
            double x = XL + (i + 0.5) * D, y = YT - (rt + 0.5) * D, lon, lat, rlon, rlat, fx, fy, k;
            rp_ps_inverse(WA, wb(), 70, -45, x, y, &lon, &lat);
            ice_raster_cell_lonlat(r, i, j, &rlon, &rlat);
            worst = fmax(worst, fmax(fabs(remainder(rlon - lon, 360)), fabs(rlat - lat)));
            rp_ps_forward(WA, wb(), 70, -45, lon, lat, &fx, &fy, &k);
            double area = D * D / (k * k);
            worst_area = fmax(worst_area, fabs(ice_raster_area(r, i, j) / area - 1));
            size_t q = (size_t)j * NX + i;
            int flag = r->land ? r->land[q] : 0;
            if (c == LAND_RAW) {
                nland++;
                bad += flag != 1 || !isnan(r->conc[q]);
                continue;
            }
            if (c == NODATA_RAW) {
                bad += flag != 0 || !isnan(r->conc[q]);
                continue;
            }
            double a = c * 0.01 / 100, h = raw_thick(i, rt) * 0.1 / 100;
            bad += flag != 0 || fabs(r->conc[q] - a) > 1e-12 || (a > 0 && fabs(r->thick[q] - h) > 1e-9);
            if (a > 0.15) {
                want_area += a * area;
                want_vol += a * h * area;
            }
        }
    CHECK(worst < 1e-6, "cell centres off Snyder's inverse by %g degrees", worst);
    CHECK(worst_area < 1e-6, "cell areas off dx dy / k^2 by %g", worst_area);
    CHECK(bad == 0 && r->nland == nland && nland > 0, "%zu cells wrong; land %zu (want %zu)", bad,
          r->nland, nland);
    CHECK(r->thickness_kind == ICE_THICK_ICE && strstr(r->thickness_why, "cell_methods"),
          "thickness kind from \"%s\"", r->thickness_why);
    rp_check_seeded("GeoTIFF", r, want_area, want_vol, 0.15);
    ice_raster_free(r);
}

static void rp_ok(const char *what, const char *path, const ice_raster_options *o)
{
    ice_raster_free(rp_read(what, path, o));
}

/* the cases, in a file of dir */
static void run(const char *dir)
{
    char path[512];
    snprintf(path, sizeof path, "%s/sic_sit_3413.tif", dir);
    write_tif(path, (tif_opts){2, 1, 0, 1, 0, 1, 0});
    check_good(path);

    ice_raster_options o;
    ice_raster_options_default(&o);
    /* band 2 without metadata: its role is unknown */
    write_tif(path, (tif_opts){2, 1, 0, 0, 0, 1, 0});
    rp_refused("unknown band role", path, &o, "band 2 (\"\") has a role");
    rp_refused("unknown band role (key)", path, &o, "initial.gdal.thick_band");
    o.gdal_thick_band = -1;
    rp_ok("band 2 declared none", path, &o);
    o.gdal_thick_band = 0;
    /* a thickness band named, but nothing says per ice area or cell mean */
    write_tif(path, (tif_opts){2, 1, 0, 1, 1, 1, 0});
    rp_refused("thickness kind", path, &o, "initial.thickness_kind");
    o.thickness_kind = ICE_THICK_CELL_MEAN;
    rp_ok("thickness kind from the key", path, &o);
    o.thickness_kind = ICE_THICK_AUTO;
    /* no CRS; a CRS not on the earth */
    write_tif(path, (tif_opts){1, 0, 0, 0, 0, 1, 0});
    rp_refused("no CRS", path, &o, "no CRS");
    write_tif(path, (tif_opts){1, 1, 1, 0, 0, 1, 0});
    rp_refused("local CRS", path, &o, "neither geographic nor projected");
    /* one band without metadata: the keys say which band and which unit */
    write_tif(path, (tif_opts){1, 1, 0, 0, 0, 0, 0});
    rp_refused("no concentration band", path, &o, "initial.gdal.conc_band");
    o.gdal_conc_band = 1;
    rp_refused("no concentration unit", path, &o, "initial.gdal.conc_units");
    o.gdal_conc_band = 2;
    rp_refused("band beyond the file", path, &o, "initial.gdal.conc_band 2 does not exist");
    o.gdal_conc_band = 1;
    o.gdal_conc_units = ICE_CONC_UNITS_PERCENT;
    rp_ok("band and unit from the keys", path, &o);
    ice_raster_options_default(&o);
    /* on longitude/latitude (EPSG:4326): a regular lon/lat raster */
    write_tif(path, (tif_opts){1, 1, 0, 0, 0, 1, 1});
    ice_raster *r = rp_read("EPSG:4326", path, &o);
    if (r) {
        int i = 28, rt = 20, j = NY - 1 - rt;
        CHECK(r->kind == ICE_RASTER_LONLAT && fabs(r->lon[0] - 10.25) < 1e-12 &&
                  fabs(r->lat[0] - (80 - NY * 0.25 + 0.125)) < 1e-12 && fabs(r->dlat - 0.25) < 1e-12 &&
                  fabs(r->conc[(size_t)j * NX + i] - raw_conc(i, rt) * 1e-4) < 1e-12,
              "EPSG:4326: kind %d, lon0 %g, lat0 %g, dlat %g", r->kind, r->lon[0], r->lat[0], r->dlat);
    }
    ice_raster_free(r);
    /* a truncated file */
    write_tif(path, (tif_opts){2, 1, 0, 1, 0, 1, 0});
    FILE *f = fopen(path, "rb");
    fseek(f, 0, SEEK_END);
    long len = ftell(f);
    fclose(f);
    CHECK(truncate(path, len / 2) == 0, "truncate");
    rp_refused("truncated GeoTIFF", path, &o, "truncated or corrupt");
    unlink(path);
}

int main(void)
{
    char dir[] = "/tmp/sphice-test-raster-geotiff-XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    run(dir);
    rmdir(dir);
    return check_summary("test_raster_geotiff");
}
