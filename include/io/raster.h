/* Initial ice field: concentration and thickness on a regular lon/lat grid.
 *
 * Formats (chosen by content, not by name):
 *  - NetCDF: concentration by standard_name sea_ice_area_fraction (or
 *    variable siconc, ice_conc, sic, aice), thickness by sea_ice_thickness
 *    (or sithick, hi, sit); 1-D regular lon/lat coordinates (either
 *    direction); further leading dimensions (time) take index 0;
 *    scale_factor/add_offset/_FillValue/missing_value honoured. If a
 *    `time` coordinate with CF units "<unit> since <date>" exists, its
 *    first value is the valid time.
 *  - ESRI ASCII grid: header keys ncols, nrows, xllcorner|xllcenter,
 *    yllcorner|yllcenter, cellsize, NODATA_value (any order, any case),
 *    then nrows rows from north to south. One file holds concentration;
 *    thickness comes from a second grid of the same geometry
 *    (ice_raster_options.thickness_path) or from the default.
 * Concentration is percent when the units are "%"/"percent" or any value
 * exceeds 1.5, else a fraction; stored as a fraction 0..1. Thickness in
 * any length unit udunits2 knows (cm, mm, inch; none means m); a unit
 * that is not a length is an error naming the file.
 *
 * Missing values (fill / NODATA) mean "no information" (usually land) and
 * are stored as NaN in conc; missing or absent thickness where there is
 * ice takes options.default_thickness. A literal NaN that the file does
 * not declare as its fill value, concentration outside 0..100 %, or
 * negative thickness is an error naming the file, the cell and the value.
 */
#ifndef SPHICE_IO_RASTER_H
#define SPHICE_IO_RASTER_H

#include <stddef.h>
#include "util/err.h"

typedef struct ice_raster {
    int nlon, nlat;
    double *lon, *lat;     /* cell centres, degrees, both ascending */
    double dlon, dlat;     /* spacing, degrees (> 0) */
    double *conc;          /* [j * nlon + i], fraction 0..1; NaN = missing */
    double *thick;         /* [j * nlon + i], ice thickness, m (>= 0) */
    double valid_time;     /* seconds since 1970Z; NaN if the file has none */
    char path[4096];
} ice_raster;

typedef struct ice_raster_options {
    const char *thickness_path;   /* ESRI thickness grid; NULL: none */
    const char *conc_variable;    /* NetCDF overrides; NULL: search */
    const char *thick_variable;
    double default_thickness;     /* m, where thickness is missing (default 0.1) */
    double valid_time;            /* for ESRI grids (NaN: unknown) */
} ice_raster_options;

void ice_raster_options_default(ice_raster_options *o);

/* Reads `path` (NetCDF or ESRI ASCII). opt may be NULL (defaults). */
int ice_raster_read(const char *path, const ice_raster_options *opt, ice_raster **out,
                    sph_error *err);
void ice_raster_free(ice_raster *r); /* NULL does nothing */

/* Area of cell (i, j) on the sphere of radius ICE_RASTER_EARTH_RADIUS:
 * R^2 dlon (sin(lat_n) - sin(lat_s)), m^2. */
#define ICE_RASTER_EARTH_RADIUS 6371000.0
double ice_raster_cell_area(const ice_raster *r, int j);

/* Bilinear sample at (lon, lat) over the cell centres; missing corners
 * are left out and the weights renormalised; returns 0 and NaNs when all
 * four are missing or the point is outside the centres' hull. */
int ice_raster_sample(const ice_raster *r, double lon, double lat, double *conc, double *thick);

#endif
