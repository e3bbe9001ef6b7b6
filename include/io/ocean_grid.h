/* A curvilinear ocean model grid read from one of its files, for the
 * ocean-fluxes file (io/ocean_fluxes.h OFX_GRID_CURV, docs/ocean-coupling.md).
 *
 * Cell centres: 2-D longitude/latitude, found in this order: ROMS's
 * lon_rho/lat_rho; the 2-D variables a data variable's CF `coordinates`
 * attribute names (standard_name longitude/latitude, or units
 * degrees_east/north), which covers NEMO, HYCOM, MOM6 and CF rotated-pole
 * or projected files that carry their auxiliary latitude/longitude; NEMO's
 * nav_lon/nav_lat. Else a grid given by its CF grid_mapping alone (1-D
 * coordinates, no 2-D latitude/longitude): a projection (io/cf_mapping.h;
 * projection_x/y_coordinate in m or km) or a rotated pole
 * (rotated_latitude_longitude, grid_longitude/grid_latitude in degrees):
 * centres and corners (half-way between the centres' coordinates) through
 * PROJ's inverse or the rotation of the sphere, areas as the plane's
 * rectangle over PROJ's areal scale at the centre, or the rotated
 * sphere's cell. A mapping that cannot be resolved, or a file with no
 * coordinates at all, is refused with one line naming the file, the
 * variable and `key`.
 * Cell corners: the CF `bounds` of the longitude and latitude (4 vertices
 * per cell, anticlockwise), else the midpoints of the surrounding centres
 * (on the sphere; extrapolated by one half cell at the grid's edges);
 * `corners` says which.
 * Cell areas: ROMS 1/(pm pn), NEMO e1t e2t, a variable with standard_name
 * cell_area on the same dimensions, else the area of the corner polygon on
 * the sphere of radius 6371 km (its two geodesic triangles); `area_from`
 * says which.
 * Land: landmask_read_model's choice (a mask variable whose flags or ROMS
 * name say which value is land, else the fill of a current or sea-surface
 * height), on the same dimensions as the centres.
 * Only the cells over the box (lon_min, lon_max, lat_min, lat_max: a cell
 * whose centre lies within the box widened by the largest longitude or
 * latitude difference to its neighbouring centres), as the rectangle of
 * indices holding them, are kept; longitudes are moved by whole turns to
 * within 180 degrees of the box's centre. */
#ifndef SPHICE_IO_OCEAN_GRID_H
#define SPHICE_IO_OCEAN_GRID_H

#include "util/err.h"

typedef struct ocean_grid {
    int nx, ny;              /* cells kept; cell c = j * nx + i */
    int i0, j0;              /* their first index in the file */
    double *lon, *lat;       /* [n] centres, degrees */
    double *blon, *blat;     /* [4 n] corners, anticlockwise: (i-, j-), (i+, j-), (i+, j+), (i-, j+) */
    double *area;            /* [n] m^2 (> 0) */
    unsigned char *land;     /* [n] 1 land */
    char lonvar[64], latvar[64];
    char corners[160];       /* "CF bounds lon_bnds / lat_bnds" or "midpoints of the centres ..." */
    char area_from[96];
    char desc[700];          /* one phrase: variables, sizes, corners, areas, land */
} ocean_grid;

/* Reads path's grid over box[4] = {lon_min, lon_max, lat_min, lat_max}.
 * Errors: one line naming the file, the variable and `key`;
 * SPH_ERR_MISSING_VAR when the file has nothing to place cells by (no
 * 2-D coordinates and no grid_mapping), SPH_ERR_CONFIG for a mapping
 * without coordinates. */
int ocean_grid_read(const char *path, const double box[4], const char *key, ocean_grid **out, sph_error *err);
void ocean_grid_free(ocean_grid *g); /* NULL does nothing */

#endif
