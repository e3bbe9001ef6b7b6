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

/* A definition from cf_mapping_proj as geo_proj_create takes it (PROJ
 * text or an EPSG code): a WKT converted by PROJ to a PROJ string in
 * place. 0; -1 when PROJ cannot read it or it is not a projected CRS. */
int cf_mapping_proj_text(char *def, size_t len);

/* A CF rotated pole (grid_mapping_name rotated_latitude_longitude): the
 * rotated frame's axes in earth-fixed coordinates. The rotated north pole
 * is at (grid_north_pole_longitude, grid_north_pole_latitude); the true
 * north pole lies on the rotated meridian north_pole_grid_longitude
 * (default 0), so that the rotated origin is at (pole longitude + 180,
 * 90 - pole latitude) (PROJ's ob_tran with o_lat_p = pole latitude,
 * o_lon_p = north_pole_grid_longitude, lon_0 = 180 + pole longitude). */
typedef struct cf_rotated_pole {
    double ex[3], ey[3], ez[3];
    double l0;                /* north_pole_grid_longitude, degrees */
} cf_rotated_pole;
/* From grid-mapping variable gm: 0; -1 with why ("lacks ...") set. */
int cf_rotated_pole_read(int ncid, int gm, cf_rotated_pole *rp, char *why, size_t wlen);
/* Rotated (rlon, rlat) degrees to longitude/latitude, and (angle not
 * NULL) the angle in radians, anticlockwise, from local east to the
 * direction of increasing rlon (geo_grid_angle's convention). */
void cf_rotated_to_geo(const cf_rotated_pole *rp, double rlon, double rlat, double *lon, double *lat,
                       double *angle);

/* The same angle at a geographic point (lon, lat) degrees. */
double cf_rotated_angle_at(const cf_rotated_pole *rp, double lon, double lat);

/* A numeric attribute of at most max values into v (n: how many): 1 when
 * it is there and numeric. */
int cf_att_num(int ncid, int varid, const char *att, double *v, size_t *n, size_t max);

#endif
