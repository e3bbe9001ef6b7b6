/* Ice edge: the concentration contour at a threshold, by marching squares
 * on the output grid, plus the spherical geometry the products share
 * (cell areas, great-circle distances).
 *
 * Rule at the threshold: a grid node is ice when c >= threshold (so a value
 * exactly at the threshold is ice). Land nodes and squares touching land
 * carry no edge (the contour stops at the coast: the coastline is not an
 * ice edge); a sea node whose value is NaN counts as open water (c = 0).
 * Crossing points are linearly interpolated along grid edges and clamped
 * to stay 1e-6 of a cell away from the nodes, so every crossing lies on
 * exactly one grid edge and the topology is unambiguous. Saddle squares
 * (ice on one diagonal, water on the other) are resolved by the mean of
 * the four corners: mean >= threshold joins the ice diagonal.
 *
 * Lines are oriented with ice on the left (counter-clockwise around an ice
 * patch). A closed ring repeats its first point at its end; an open line
 * ends at the grid boundary or at land.
 */
#ifndef SPHICE_IO_EDGE_H
#define SPHICE_IO_EDGE_H

#include <stddef.h>
#include "util/err.h"

#define PROD_EARTH_RADIUS_M 6371000.0 /* sphere used for areas and distances */
#define PROD_NAUTICAL_MILE_M 1852.0

/* Regular lon/lat output grid. (lon0, lat0) is the centre of cell (0,0);
 * cell (i,j) is at (lon0 + i*dlon, lat0 + j*dlat). Arrays are nlat x nlon,
 * row-major (index j*nlon + i), south to north (dlat > 0). */
typedef struct prod_grid {
    int nlon, nlat;
    double lon0, lat0, dlon, dlat;
} prod_grid;

/* Checks sizes and spacing; one clear line in err on failure. */
int prod_grid_check(const prod_grid *g, sph_error *err);
/* Area of a cell of row j on the sphere, m^2:
 * R^2 dlon (sin(lat_north) - sin(lat_south)). */
double prod_grid_cell_area_m2(const prod_grid *g, int j);
/* Great-circle (haversine) distance in metres on the sphere of radius
 * PROD_EARTH_RADIUS_M. Degrees in. */
double prod_gc_distance_m(double lon1, double lat1, double lon2, double lat2);

typedef struct edge_line {
    size_t npts;
    int closed;          /* 1: ring, last point == first point */
    double *lon, *lat;   /* degrees */
} edge_line;

typedef struct edge_set {
    size_t nlines;
    edge_line *lines;
    size_t npts_total;   /* sum of npts over lines */
} edge_set;

/* Extracts the contour of `conc` (nlat*nlon) at `threshold`. `land` (may be
 * NULL) is 1 on land. *out is overwritten (call edge_set_free after). */
int edge_extract(const prod_grid *g, const double *conc, const unsigned char *land,
                 double threshold, edge_set *out, sph_error *err);
void edge_set_free(edge_set *s); /* NULL-safe; leaves an empty set */
/* Appends a point to a line, growing its arrays (capacity *cap); -1 when
 * out of memory (the line keeps its points). */
int edge_line_push(edge_line *l, size_t *cap, double lon, double lat);

/* Total great-circle length of all lines, km. */
double edge_length_km(const edge_set *s);
/* Distance of the outermost edge from a reference point, nautical miles:
 * the largest great-circle distance from (ref_lon, ref_lat) to any edge
 * point. NaN when there is no edge. */
double edge_max_distance_nm(const edge_set *s, double ref_lon, double ref_lat);

#endif
