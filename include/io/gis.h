/* GIS products: concentration-class polygons (WMO sea-ice nomenclature
 * intervals of total concentration), the ice edge and the gridded fields
 * for GIS software.
 *
 * Classes (total concentration c as a fraction, in tenths of WMO-No. 259):
 *   0 "<1/10"  open water   0     <= c < 0.1
 *   1 "1-3/10"              0.1   <= c < 0.4
 *   2 "4-6/10"              0.4   <= c < 0.7
 *   3 "7-8/10"              0.7   <= c < 0.9
 *   4 "9-10/10" (9+/10)     0.9   <= c < 0.995
 *   5 "10/10"   compact     0.995 <= c      (rounds to 10 tenths)
 * A sea cell whose concentration is undefined counts as 0 (as in the
 * gridded products); land cells belong to no class.
 *
 * Polygons follow the grid's cell boundaries (the area of a class polygon
 * is the area of its cells): each class's cells are traced into rings with
 * the class on the left, so exterior rings run counter-clockwise and holes
 * clockwise (RFC 7946's right-hand rule) in lon/lat. Cells of a class that
 * touch only at a corner belong to different polygons, and at such a
 * corner each ring is cut by 1e-3 of a cell, so that no ring touches
 * itself or another: rings are simple and disjoint. Vertices are kept at
 * every cell corner along parallels (a parallel is not a geodesic) and
 * only at the ends of straight runs along meridians.
 *
 * Files (written atomically; docs/products.md):
 *   <prefix>_ice_classes.geojson  RFC 7946 FeatureCollection: one
 *       MultiPolygon per (valid time, class) with properties valid_time,
 *       class, conc_min, conc_max, area_km2 (cells), colour.
 *   <prefix>_gis.gpkg   OGC GeoPackage (GDAL/OGR), EPSG:4326: layer
 *       ice_classes (as the GeoJSON) and layer ice_edge (MultiLineString
 *       per valid time: valid_time, threshold, length_km).
 *   <prefix>_fields_<YYYYMMDDTHHMMZ>.tif  Cloud-Optimised GeoTIFF (GDAL
 *       COG driver, DEFLATE), EPSG:4326, north-up, pixel = output cell;
 *       Float32 bands siconc (1), sithick (m), sivol (m), siu, siv (m/s);
 *       nodata 1e20 (as the NetCDF _FillValue).
 */
#ifndef SPHICE_IO_GIS_H
#define SPHICE_IO_GIS_H

#include <stddef.h>
#include "io/edge.h"
#include "util/err.h"

#define GIS_NCLASSES 6
#define GIS_CORNER_CUT 1e-3 /* cells */

typedef struct gis_class {
    const char *name;
    double lo, hi;          /* lo <= c < hi */
    unsigned char r, g, b;  /* WMO colour code (io/quicklook.h) */
} gis_class;

extern const gis_class gis_classes[GIS_NCLASSES];

/* Class index of a concentration (NaN counts as 0). */
int gis_class_of(double c);

typedef struct gis_ring {
    size_t n;           /* points, the first repeated at the end */
    double *lon, *lat;
} gis_ring;

typedef struct gis_polygon {
    size_t nrings;      /* ring 0 exterior (CCW), the others holes (CW) */
    gis_ring *rings;
} gis_polygon;

typedef struct gis_multipolygon {
    size_t npolys;
    gis_polygon *polys;
    double cell_area_km2;   /* sum of the class's cell areas (sphere) */
} gis_multipolygon;

/* Polygons of the cells with lo <= c < hi (sea cells only). */
int gis_class_polygons(const prod_grid *g, const double *conc, const unsigned char *land,
                       double lo, double hi, gis_multipolygon *out, sph_error *err);
void gis_multipolygon_free(gis_multipolygon *m); /* NULL-safe */

/* Appends a GeoJSON Feature {"type", "geometry": {type, coordinates},
 * "properties"} to the array feats; *coords is the (empty) coordinates
 * array to fill; returns the properties object. */
typedef struct cJSON cJSON;
/* A FeatureCollection with its (empty) features array in *feats; NULL
 * when out of memory. */
cJSON *gis_geojson_collection(cJSON **feats);
/* Writes fc (unformatted) atomically to path and deletes it. */
int gis_geojson_write(cJSON *fc, const char *path, sph_error *err);
cJSON *gis_geojson_feature(cJSON *feats, const char *type, cJSON **coords);

/* Writer state kept by the products writer between output times. */
typedef struct gis_store gis_store;

gis_store *gis_store_new(void);
void gis_store_free(gis_store *s); /* NULL-safe */
/* Adds the class polygons and the edge of one valid time. */
int gis_store_add(gis_store *s, const prod_grid *g, const double *conc, const unsigned char *land,
                  const edge_set *edge, double threshold, double valid_time, sph_error *err);
/* Writes the GeoJSON and GeoPackage files. */
int gis_write_classes_geojson(const gis_store *s, const char *path, sph_error *err);
int gis_write_gpkg(const gis_store *s, const char *path, double cycle_time, sph_error *err);

/* Cloud-Optimised GeoTIFF of nb Float32 bands (nlat*nlon each, south to
 * north as the products, NaN = nodata), names as band descriptions. */
int gis_write_cog(const char *path, const prod_grid *g, int nb, const double *const *bands,
                  const char *const *names, const char *const *units, sph_error *err);

/* Frees GDAL's driver manager and PROJ/OSR caches (for leak checkers);
 * call once at program exit. */
void gis_release_caches(void);

#endif
