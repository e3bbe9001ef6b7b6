/* Land/sea mask on a regular longitude/latitude grid.
 *
 * Cell (i, j) has its centre at (lon0 + (i + 0.5) dlon, lat0 + (j + 0.5) dlat),
 * row-major (j * nlon + i), latitude ascending; 1 = land (including lakes
 * and other inland water: sea ice never reaches them), 0 = sea.
 *
 * Sources:
 *  - GSHHG binned NetCDF (the files GMT uses, e.g. Debian gmt-gshhg-high
 *    /usr/share/gmt-gshhg/binned_GSHHS_h.nc or the full-resolution _f):
 *    each cell centre is classified exactly against the level-1 (ocean /
 *    land) shoreline, see landmask.c for the method;
 *  - a land-sea mask NetCDF: standard_name land_binary_mask (land where
 *    > 0.5), sea_binary_mask (land where < 0.5), land_area_fraction or
 *    ERA5 "lsm" (land where > 0.5), or a variable "mask" (land where > 0.5);
 *  - the fill pattern of a forcing variable: land where the value is the
 *    _FillValue / missing_value or NaN;
 *  - an ocean model's own file on its native grid (landmask_read_model):
 *    a mask variable whose flag_values/flag_meanings, standard name
 *    (land_binary_mask, sea_binary_mask, land/sea_area_fraction) or ROMS
 *    name (mask_rho: 1 water, 0 land) says which value is land, or a key
 *    (land_value, polarity) that says it; else the fill pattern of a
 *    current or sea-surface height at the level nearest the surface.
 *    Curvilinear grids (2-D lon/lat) stay native: a point is land where
 *    the cell with the nearest centre is land. A 0/1 mask that does not say
 *    which value is land is refused, never guessed.
 */
#ifndef SPHICE_IO_LANDMASK_H
#define SPHICE_IO_LANDMASK_H

#include <stddef.h>
#include "io/geo.h"
#include "util/err.h"

typedef struct landmask landmask;

/* A region and resolution: cells cover [lon_min, lon_max] x [lat_min,
 * lat_max] (degrees; lon_max may exceed 180 to cross the dateline) in
 * squares of `resolution` degrees (the extent is rounded up to whole cells). */
typedef struct landmask_grid {
    double lon_min, lon_max, lat_min, lat_max;
    double resolution;
} landmask_grid;

/* The GSHHG file to use when none is configured: $SPHICE_GSHHG if set,
 * else the first existing of binned_GSHHS_f.nc, binned_GSHHS_h.nc in
 * /usr/share/gmt-gshhg; NULL if none exists. */
const char *landmask_gshhg_default_path(void);

landmask *landmask_create_gshhg(const char *path, const landmask_grid *grid, sph_error *err);

typedef enum {
    LANDMASK_NC_AUTO = 0, /* by standard_name / name, see above */
    LANDMASK_NC_FILL      /* land where `variable` is missing (fill pattern) */
} landmask_nc_mode;
/* Reads a mask (or a fill pattern) from a NetCDF file on a 1-D regular
 * lon/lat grid; `variable` may be NULL in AUTO mode. For variables with
 * more than two dimensions the first index of the leading ones is used. */
landmask *landmask_read_netcdf(const char *path, const char *variable, landmask_nc_mode mode,
                               sph_error *err);

typedef enum {
    LANDMASK_FROM_AUTO = 0, /* a mask variable; else (fill_fallback) the fill of a current */
    LANDMASK_FROM_MASK,     /* a mask variable only */
    LANDMASK_FROM_FILL      /* the fill pattern of `variable` (or of a current) */
} landmask_from;
typedef enum {
    LANDMASK_POL_AUTO = 0,    /* from flag meanings, standard name or ROMS name; else refused */
    LANDMASK_POL_LAND_IS_1,   /* land where the value is > 0.5 */
    LANDMASK_POL_WATER_IS_1   /* land where the value is < 0.5 */
} landmask_polarity;
typedef struct landmask_read_opts {
    const char *variable;     /* NULL or "": found in the file */
    landmask_from from;
    landmask_polarity polarity;
    double land_value;        /* land where the (unpacked) value equals it; NAN: unset */
    int fill_fallback;        /* AUTO without a mask variable: use a current's fill */
    /* The cells' centres (degrees, [cell_ny x cell_nx]) where the file has
     * no longitude/latitude of its own (a grid given by its mapping, which
     * the caller has resolved: io/ocean_grid.h); NULL: none. Used only for
     * a mask variable on exactly that many cells. */
    const double *cell_lon, *cell_lat;
    size_t cell_nx, cell_ny;
} landmask_read_opts;
/* Reads land from a model or mask file; a 1-D regular lon/lat grid gives a
 * regular mask, anything else (2-D lon/lat, irregular axes) a native one.
 * Errors are one line naming the file, the variable and the key
 * (landmask.variable, landmask.land_value, landmask.polarity). */
landmask *landmask_read_model(const char *path, const landmask_read_opts *opts, sph_error *err);
/* 1 if the mask is on a native (not regular lon/lat) grid; its
 * landmask_get_grid gives nx, ny and NAN origin and steps. */
int landmask_is_native(const landmask *m);
/* A native mask's mean distance between neighbouring cell centres, m
 * (NAN for a regular mask); of a union (landmask_add) the smallest. */
double landmask_native_spacing_m(const landmask *m);

/* A mask from an array (copied), e.g. for tests or a model grid. */
landmask *landmask_create_array(int nlon, int nlat, double lon0, double lat0, double dlon,
                                double dlat, const unsigned char *land, sph_error *err);
void landmask_free(landmask *m); /* NULL does nothing */

/* The land an initial raster flags itself (ice_raster.land 1: land, coast,
 * lake): on its lon/lat grid, or native (nearest centre) for a projected
 * or curvilinear one. NULL and one error line naming `key` and the raster
 * when it flags no land. */
struct ice_raster;
landmask *landmask_from_raster(const struct ice_raster *r, const char *key, sph_error *err);
/* m is land where it says so or `also` says so (also is owned by m from
 * now on, freed with it); a point is outside (-1) only when outside both.
 * landmask_get_grid, _data, _is_native describe m alone. */
void landmask_add(landmask *m, landmask *also);

/* 1 land, 0 sea, -1 outside the mask's grid (caller decides). Longitudes
 * are taken modulo 360 into the grid's range. */
int landmask_is_land(const landmask *m, double lon, double lat);

void landmask_get_grid(const landmask *m, int *nlon, int *nlat, double *lon0, double *lat0,
                       double *dlon, double *dlat);
const unsigned char *landmask_data(const landmask *m);

/* Samples the mask at the centres of an nx x ny grid of the projected
 * plane (cell (i,j) centre (x0 + (i+0.5) dx, y0 + (j+0.5) dy), row-major
 * j*nx + i, the layout of sph_landmask). Centres outside the mask's grid
 * are sea (0): the model treats the domain edge as open boundary. */
int landmask_to_plane(const landmask *m, const geo_proj *p, double x0, double y0, double dx,
                      double dy, int nx, int ny, unsigned char *out, sph_error *err);

/* CF NetCDF: byte land_binary_mask(lat, lon) with lon/lat coordinates;
 * written atomically; read back with landmask_read_netcdf. */
int landmask_write_netcdf(const landmask *m, const char *path, const char *source,
                          sph_error *err);

#endif
