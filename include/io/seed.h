/* Particle seeding from the initial ice raster (PHYSICS.md sections 1, 4).
 *
 * Two layouts:
 *  - spacing_m == 0: per cell. cell_n x cell_n particles (cell_n 0 or 1:
 *    one, at the centre) in every raster cell with concentration >
 *    threshold, at the centres of its n x n sub-cells in the raster's own
 *    coordinates (lon/lat, or projected x/y unprojected by PROJ; on a
 *    curvilinear grid interpolated between the surrounding centres); a
 *    sub-cell whose centre is land is left out. Each takes its cell's
 *    concentration and thickness (never a neighbour's: a patch next to
 *    open water keeps its thickness) and 1 / n^2 of its true area
 *    (ice_raster_area: the sphere for lon/lat, the projection's own for
 *    projected grids): mass = rho_i * conc * thick * cell_area / n^2, so the
 *    seeded area and mass are exactly the raster's over those sub-cells.
 *    Footprint side (for the smoothing length) = sqrt(cell_area) / n.
 *  - spacing_m > 0: particles on a square lattice of that spacing on the
 *    projected plane (aligned to the plane origin), with conc/thick sampled
 *    bilinearly from the raster: conc = bilinear A, thick = bilinear (A h)
 *    / bilinear A, so an open-water corner (A = 0) dilutes the
 *    concentration but never the thickness (a 0.7 m patch seeds 0.7 m
 *    particles up to its edge). mass = rho_i * conc * thick * spacing^2
 *    (plane area); then the lattice's ice area (sum conc * footprint) and
 *    volume (sum mass / rho_i) are scaled to the raster's over the same
 *    region (seed_raster_totals over the lattice's plane box, within the
 *    bounds): mass by
 *    V_raster / V_lattice, thick by that over A_raster / A_lattice. The
 *    sampled totals before the scaling are in seed_totals.raw_*: how far
 *    the lattice alone was off (projection scale, the edge, the
 *    threshold).
 * Both: sml = sml_factor * footprint side, u = v = 0, lat set, id =
 * first_id + running index. Seeding fills x, y, lat, mass, thick, conc,
 * sml, u, v, id only; snow, surface temperature and enthalpy are the
 * caller's (thermodynamic initialisation). No particle is placed where the land mask says land (a point
 * outside the mask's grid counts as sea), nor in a cell the raster itself
 * flags as land (ice_raster.land; per cell such cells have no
 * concentration, the lattice skips its points in them).
 *
 * Threshold: default 0.05 (5 %): below that satellite concentration is
 * mostly retrieval noise (weather, land spill-over) and such parcels carry
 * little mass; 0.15 is the conventional ice-edge value if only the pack
 * should be modelled.
 */
#ifndef SPHICE_IO_SEED_H
#define SPHICE_IO_SEED_H

#include <stddef.h>
#include "core/particles.h"
#include "io/geo.h"
#include "io/landmask.h"
#include "io/raster.h"
#include "util/err.h"

#define SEED_MAX_CELL_N 10 /* at most 10 x 10 particles per raster cell */

typedef struct seed_options {
    double threshold;    /* seed where conc > threshold (0..1), default 0.05 */
    double spacing_m;    /* 0: raster cells; > 0: plane lattice spacing, m */
    double sml_factor;   /* h0 = sml_factor * spacing (default 1.0, the seed's h0 = spacing) */
    double rho_ice;      /* kg/m^3, default 900 */
    long first_id;       /* id of the first particle seeded (default 0) */
    int cell_n;          /* spacing_m == 0: cell_n x cell_n particles per cell (0, 1: one) */
    /* plane-lattice bounds (spacing_m > 0): the raster's projected
     * bounding box when all four are 0 */
    double xmin, xmax, ymin, ymax;
    /* the model's own land on its plane (the land mask as the model draws
     * it; NULL: none): no particle is placed on it, and the raster's
     * totals leave it out, so what is seeded is what the model calls sea.
     * plane_land[j * plane_nx + i] for the cell [x0 + i dx, x0 + (i+1) dx)
     * x [y0 + j dy, ...) */
    const unsigned char *plane_land;
    double plane_x0, plane_y0, plane_dx, plane_dy;
    long plane_nx, plane_ny;
} seed_options;

void seed_options_default(seed_options *o);

/* Ice area (sum conc * cell area, m^2) and volume (sum conc * thick *
 * cell area, m^3) of the raster over the cells seeding takes: conc >
 * threshold, thick > 0, centre sea by mask, and (box not NULL) centre
 * projected with p inside [box[0], box[1]) x [box[2], box[3]). Per cell
 * with cell_n > 1 the tests are made at the sub-cells' centres and a cell
 * counts by the fraction of its sub-cells that pass (what walk_cells
 * seeds). */
int seed_raster_totals(const ice_raster *r, const geo_proj *p, const landmask *mask,
                       const seed_options *o, const double box[4], double *area,
                       double *volume, sph_error *err);

/* Totals of one seed_from_raster_totals call. A particle's ice area is
 * mass / (rho_i thick), its volume mass / rho_i. */
typedef struct seed_totals {
    double raster_area_m2, raster_volume_m3; /* the raster over the seeded region */
    double raw_area_m2, raw_volume_m3;       /* as seeded, before the lattice's scaling */
    double seeded_area_m2, seeded_volume_m3; /* as seeded, after it */
    int rescaled;                            /* 1 where the lattice was scaled */
    size_t n;                                /* particles appended */
} seed_totals;

/* Number of particles seed_from_raster would append. */
int seed_count(const ice_raster *r, const geo_proj *p, const landmask *mask,
               const seed_options *o, size_t *count, sph_error *err);

/* Appends the particles to P (P->n grows). Fails without changing P when
 * P->cap - P->n is too small. mask may be NULL (all sea). */
int seed_from_raster(const ice_raster *r, const geo_proj *p, const landmask *mask,
                     const seed_options *o, sph_particles *P, sph_error *err);
/* The same, with the totals in *tot (may be NULL). */
int seed_from_raster_totals(const ice_raster *r, const geo_proj *p, const landmask *mask,
                            const seed_options *o, sph_particles *P, seed_totals *tot,
                            sph_error *err);

#endif
