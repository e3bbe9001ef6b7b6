/* Map projection of the model plane (PROJ 9).
 *
 * The model works in metres on a projected plane; forcing, rasters and
 * land masks are on longitude/latitude. A geo_proj converts between the
 * two (degrees east/north <-> metres) and tells the driver how to rotate
 * east/north vectors into the plane's x/y components.
 *
 * Kinds for geo_proj_create:
 *   "auto"   azimuthal equidistant centred on (lon0, lat0) when |lat0| < 60,
 *            else polar stereographic (as "polar").
 *   "aeqd"   +proj=aeqd +lon_0=lon0 +lat_0=lat0: distances and directions
 *            from the centre are exact; scale error ~ (d/R)^2 / 6, about
 *            0.004 % at 100 km and 0.1 % at 500 km from the centre.
 *   "stere"  oblique stereographic centred on (lon0, lat0) (conformal).
 *   "polar"  polar stereographic +lat_0=+-90 +lat_ts=+-70 +lon_0=lon0
 *            (hemisphere from the sign of lat0).
 *   anything containing "+proj=" or "EPSG:": a full PROJ definition; it
 *            must map geographic WGS84 (lon, lat) to metres.
 * All built-in kinds use the WGS84 ellipsoid (plane distances match
 * ellipsoidal geodesics); a full definition may use a sphere (+R=...).
 *
 * Threads: each geo_proj owns its PJ_CONTEXT and a mutex, so calls on one
 * object from several threads are safe but serialised. For parallel
 * projection give each thread its own object with geo_proj_clone.
 */
#ifndef SPHICE_IO_GEO_H
#define SPHICE_IO_GEO_H

#include <stddef.h>
#include "util/err.h"

typedef struct geo_proj geo_proj;

geo_proj *geo_proj_create(const char *kind, double lon0, double lat0, sph_error *err);
/* An independent copy (own context) for use by another thread. */
geo_proj *geo_proj_clone(const geo_proj *p, sph_error *err);
void geo_proj_free(geo_proj *p); /* NULL does nothing */
/* The PROJ definition actually used (for provenance, CF grid_mapping). */
const char *geo_proj_definition(const geo_proj *p);
/* Centre given at creation (degrees). */
void geo_proj_centre(const geo_proj *p, double *lon0, double *lat0);

/* lon/lat (degrees) -> x/y (m), n points. Input and output arrays may not
 * alias. A point that does not project (far side of the globe) gets NaN
 * and makes the call return SPH_ERR_PARAM (after converting all points). */
int geo_forward(const geo_proj *p, size_t n, const double *lon, const double *lat, double *x,
                double *y, sph_error *err);
/* x/y (m) -> lon/lat (degrees east in -180..180, north). */
int geo_inverse(const geo_proj *p, size_t n, const double *x, const double *y, double *lon,
                double *lat, sph_error *err);

/* Angle alpha (radians, counter-clockwise positive) from local east to the
 * plane's x axis at (lon, lat), from a centred finite difference of
 * geo_forward along the parallel. A vector with east/north components
 * (ue, vn) has plane components
 *     ux =  ue cos(alpha) + vn sin(alpha)
 *     uy = -ue sin(alpha) + vn cos(alpha)
 * (exact for conformal projections, to the angular distortion otherwise:
 * for aeqd under 0.01 degree within 300 km of the centre).
 * Zero on the central meridian of every built-in kind. NaN if (lon, lat)
 * does not project. */
double geo_grid_angle(const geo_proj *p, double lon, double lat);
/* Applies the rotation above to n vectors (in place allowed). */
int geo_rotate_to_plane(const geo_proj *p, size_t n, const double *lon, const double *lat,
                        const double *ue, const double *vn, double *ux, double *uy,
                        sph_error *err);

/* Plane tables (domain.plane_tables): longitude, latitude and the grid
 * angle's cosine and sine tabulated once on a regular plane grid of
 * spacing `step` (m) over [x0, x1] x [y0, y1], so that the per-step path
 * looks them up by bilinear interpolation instead of calling PROJ and
 * trigonometry for every particle. Error against PROJ: h^2/8 times the
 * second derivatives, for aeqd about 2 cm of position and 1e-10 rad of
 * angle at h = 1 km within 300 km of the centre (tests/test_geo_table.c
 * measures it). Points outside the table, or in a cell touching a node
 * that does not unproject, go through geo_inverse and geo_grid_angle.
 * Refused (NULL, *err set) within 2 degrees of a pole. The table keeps a
 * pointer to p. */
typedef struct geo_plane_table geo_plane_table;
geo_plane_table *geo_plane_table_create(const geo_proj *p, double x0, double x1, double y0, double y1,
                                        double step, sph_error *err);
void geo_plane_table_free(geo_plane_table *t); /* NULL does nothing */
/* domain.plane_tables "auto": the table as geo_plane_table_create, except
 * that a domain the tables refuse (within 2 degrees of a pole, too many
 * nodes) gives NULL with *err clear and the reason in why (for the run's
 * log line): PROJ per particle then. Out of memory still fails (*err). */
geo_plane_table *geo_plane_table_auto(const geo_proj *p, double x0, double x1, double y0, double y1,
                                      double step, char *why, size_t whylen, sph_error *err);
/* lon/lat (degrees, -180..180) and cos/sin of the grid angle at n plane
 * points; a point that does not unproject gets NaN and the call returns
 * SPH_ERR_PARAM (cos 1, sin 0 there). */
int geo_plane_lookup(const geo_plane_table *t, size_t n, const double *x, const double *y,
                     double *lon, double *lat, double *cs, double *sn, sph_error *err);

#endif
