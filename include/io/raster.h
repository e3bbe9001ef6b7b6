/* Initial ice field: concentration and thickness on a regular lon/lat
 * grid, a projected grid (CF grid_mapping) or a curvilinear grid.
 *
 * Formats (chosen by content, not by name):
 *  - NetCDF: concentration by standard_name sea_ice_area_fraction (or
 *    variable siconc, ice_conc, sic, aice), thickness by sea_ice_thickness
 *    (or sithick, hi, sit). Grids: 1-D regular lon/lat coordinates (either
 *    direction); 1-D regular projected x/y (units any length udunits2
 *    knows: m, km) with the variable's grid_mapping, built by PROJ from,
 *    in this order, its crs_wkt / spatial_ref (WKT), proj4 / proj4text /
 *    proj4_params, an EPSG code (epsg_code, EPSG, srid), or the CF
 *    attributes of polar_stereographic, stereographic,
 *    lambert_conformal_conic, lambert_azimuthal_equal_area,
 *    transverse_mercator (ellipsoid from semi_major_axis with
 *    semi_minor_axis or inverse_flattening, or earth_radius: required);
 *    2-D latitude/longitude (the variable's coordinates attribute, or
 *    lat/lon, latitude/longitude, nav_lat/nav_lon, TLAT/TLON) when there
 *    is no projection. A grid not understood, or a projection PROJ cannot
 *    build, is one error line naming file, variable and problem. Further leading dimensions (time) take index 0;
 *    scale_factor/add_offset/_FillValue/missing_value honoured. If a
 *    `time` coordinate with CF units "<unit> since <date>" exists, its
 *    first value is the valid time.
 *  - NOAA IMS daily snow and ice analysis (NSIDC G02156) ASCII, 24, 4 or
 *    1 km: its text header, then one character per cell, rows from the
 *    grid's bottom (y = yll) up; classes 0 outside the hemisphere (no
 *    information), 1 open water, 2 land, 3 sea or lake ice, 4 snow-covered
 *    land (land). Ice cells take options.ims_ice_conc / ims_ice_thick
 *    (required: the product says ice or no ice only).
 *  - GeoTIFF through GDAL: the CRS, geotransform, nodata, scale/offset and
 *    band metadata of the file; band roles, concentration unit and thickness
 *    kind from the metadata, else options.gdal_*; an IMS GeoTIFF (a byte
 *    band on one of the IMS grids) as IMS classes.
 *  - ESRI ASCII grid: header keys ncols, nrows, xllcorner|xllcenter,
 *    yllcorner|yllcenter, cellsize, NODATA_value (any order, any case),
 *    then nrows rows from north to south. One file holds concentration;
 *    thickness comes from a second grid of the same geometry
 *    (ice_raster_options.thickness_path) or from the default.
 * Thickness kind (options.thickness_kind AUTO): from the variable's
 * cell_methods ("area: mean where sea_ice": per ice area; "area: mean" or
 * "area: mean where sea": cell mean), else its long_name ("in cell",
 * "cell mean", "per unit area", "volume per": cell mean; "ice-covered",
 * "floe", "actual": per ice area), else its name (sivol, vice: cell mean;
 * sithick: per ice area), else standard_name sea_ice_thickness (per ice
 * area). Undecided (and any ESRI thickness grid): an error naming
 * initial.thickness_kind. A cell mean is divided by the concentration
 * where it is > 0, so thick is always per ice area.
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

/* The raster's grid kind. */
enum {
    ICE_RASTER_LONLAT = 0,    /* regular 1-D lon/lat (lon, lat, dlon, dlat) */
    ICE_RASTER_PROJECTED,     /* regular 1-D x/y of a CF grid_mapping (x, y, dx, dy) */
    ICE_RASTER_CURVILINEAR    /* 2-D lat/lon per cell, no map projection */
};

/* What a thickness field means (initial.thickness_kind). */
enum {
    ICE_THICK_AUTO = 0,   /* from the file's metadata; an error where it does not say */
    ICE_THICK_ICE,        /* per ice-covered area (the ice itself) */
    ICE_THICK_CELL_MEAN   /* volume per cell area: divided by the concentration where > 0 */
};

struct raster_crs; /* PROJ objects of a projected raster (private) */

typedef struct ice_raster {
    int nlon, nlat;        /* columns (x or lon), rows (y or lat) */
    int kind;              /* ICE_RASTER_* */
    double *lon, *lat;     /* LONLAT: cell centres, degrees, both ascending; else NULL */
    double dlon, dlat;     /* LONLAT: spacing, degrees (> 0) */
    double *x, *y;         /* PROJECTED: cell centres in the raster's CRS, m, ascending */
    double dx, dy;         /* PROJECTED: spacing, m (> 0) */
    /* PROJECTED, CURVILINEAR: per cell [j * nlon + i] centre (degrees, on
     * the raster's own geodetic datum) and true area (m^2); NULL for LONLAT */
    double *cell_lon, *cell_lat, *area;
    struct raster_crs *crs; /* PROJECTED only */
    char grid[600];        /* how the grid was understood, one phrase (for logs, check) */
    double *conc;          /* [j * nlon + i], fraction 0..1; NaN = missing */
    /* [j * nlon + i] from the file's flags (flag_values / flag_meanings of
     * the concentration, flag_masks or flag_values of its ancillary
     * status_flag): 0 data, 1 land (land, coast, lake), 2 no information
     * (pole hole, missing, ...); conc is NaN at 1 and 2. NULL: no flags. */
    unsigned char *land;
    size_t nland, nnoinfo;  /* cells flagged 1 and 2 */
    double conc_halfstep;  /* half the packing step of a packed concentration (its units), else 0 */
    double *thick;         /* [j * nlon + i], ice thickness, m (>= 0) */
    double valid_time;     /* seconds since 1970Z; NaN if the file has none */
    int thickness_kind;    /* ICE_THICK_ICE or _CELL_MEAN as read (thick is per ice area either way) */
    char thickness_why[160]; /* what decided it */
    /* what the reader took from configuration instead of the file (IMS's
     * ice cell, a GeoTIFF's band roles or unit); "" none */
    char assumed[256];
    char path[4096];
} ice_raster;

typedef struct ice_raster_options {
    const char *thickness_path;   /* ESRI thickness grid; NULL: none */
    const char *conc_variable;    /* NetCDF overrides; NULL: search */
    const char *thick_variable;
    double default_thickness;     /* m, where thickness is missing (default 0.1) */
    double valid_time;            /* for ESRI grids (NaN: unknown) */
    int thickness_kind;           /* ICE_THICK_* (default AUTO) */
    /* IMS classes: concentration (0..1] and thickness (m) of an ice cell;
     * NaN (default): unset, an IMS raster is refused naming the key */
    double ims_ice_conc, ims_ice_thick;
    /* GDAL: 1-based band of concentration and of thickness; 0 (default):
     * from the band metadata; gdal_thick_band -1: no thickness band */
    int gdal_conc_band, gdal_thick_band;
    int gdal_conc_units;          /* ICE_CONC_UNITS_* (default AUTO: from the metadata) */
    /* lon_min, lon_max, lat_min, lat_max, degrees: the IMS and GDAL drivers
     * read only the cells covering it (and a margin); NaN (default): all */
    double bbox[4];
} ice_raster_options;

/* Concentration unit of a GDAL band (initial.gdal.conc_units). */
enum { ICE_CONC_UNITS_AUTO = 0, ICE_CONC_UNITS_FRACTION, ICE_CONC_UNITS_PERCENT };

void ice_raster_options_default(ice_raster_options *o);

/* Reads `path` (NetCDF, IMS ASCII, GeoTIFF or ESRI ASCII). opt may be NULL (defaults). */
int ice_raster_read(const char *path, const ice_raster_options *opt, ice_raster **out,
                    sph_error *err);
void ice_raster_free(ice_raster *r); /* NULL does nothing */

/* Area of cell (i, j) on the sphere of radius ICE_RASTER_EARTH_RADIUS:
 * R^2 dlon (sin(lat_n) - sin(lat_s)), m^2. */
#define ICE_RASTER_EARTH_RADIUS 6371000.0
/* Thickest value accepted, m: ridge keels reach some 50 m, so more is bad
 * input (a unit or an undeclared fill), refused naming the cell. */
#define ICE_RASTER_MAX_THICKNESS 100.0
double ice_raster_cell_area(const ice_raster *r, int j);

/* Any grid kind: centre (degrees) and true area (m^2) of cell (i, j).
 * LONLAT: lon[i], lat[j] and ice_raster_cell_area (bit-identical to
 * before). PROJECTED: the centre unprojected with PROJ, the area
 * dx dy / areal_scale (PROJ's proj_factors at the centre: for a conformal
 * projection k^2, for an equal-area one 1) or the file's cell-area
 * variable (cell_measures "area: NAME"). CURVILINEAR: the 2-D lat/lon and
 * the cell-area variable, else the geodesic area (WGS84) of the
 * quadrilateral whose corners are the means of the four surrounding
 * centres. */
void ice_raster_cell_lonlat(const ice_raster *r, int i, int j, double *lon, double *lat);
double ice_raster_area(const ice_raster *r, int i, int j);
/* 1 when ice_raster_sample works on this grid (LONLAT, PROJECTED). */
int ice_raster_can_sample(const ice_raster *r);

/* Bilinear sample at (lon, lat) over the cell centres, in the raster's
 * native coordinates (lon/lat, or x/y of its projection); missing corners
 * are left out and the weights renormalised; returns 0 and NaNs when all
 * four are missing or the point is outside the centres' hull. */
int ice_raster_sample(const ice_raster *r, double lon, double lat, double *conc, double *thick);

#endif
