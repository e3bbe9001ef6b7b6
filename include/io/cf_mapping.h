/* CF grid mappings (CF conventions, appendix F) as PROJ definitions, for
 * the readers of projected grids: the initial ice raster (raster_netcdf.c)
 * and the ocean grid of the ocean-fluxes file (ocean_grid.c).
 *
 * Tried in this order: a text attribute holding a full definition
 * (crs_wkt, spatial_ref, proj4, proj4text, proj4_params, proj4string,
 * proj4_string); an EPSG code (epsg_code, EPSG, epsg, srid: "EPSG:3413",
 * "3413" or a number); the grid_mapping_name with its parameters:
 * polar_stereographic, stereographic, lambert_azimuthal_equal_area,
 * lambert_conformal_conic, transverse_mercator. The figure of the earth
 * must be given (semi_major_axis with semi_minor_axis or
 * inverse_flattening, or earth_radius): it is never assumed. */
#ifndef SPHICE_IO_CF_MAPPING_H
#define SPHICE_IO_CF_MAPPING_H

#include <stddef.h>

/* The definition of grid-mapping variable gm of open file ncid into def:
 * 0; or -1 with why set to a phrase that completes "grid mapping NAME ..."
 * ("has no grid_mapping_name, crs_wkt, proj4 or EPSG code", "(polar_stereographic)
 * lacks straight_vertical_longitude_from_pole", ...). */
int cf_mapping_proj(int ncid, int gm, char *def, size_t len, char *why, size_t wlen);

/* A numeric attribute of at most max values into v (n: how many): 1 when
 * it is there and numeric. */
int cf_att_num(int ncid, int varid, const char *att, double *v, size_t *n, size_t max);

#endif
