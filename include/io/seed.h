/* Particle seeding from the initial ice raster (PHYSICS.md sections 1, 4).
 *
 * Two layouts:
 *  - spacing_m == 0: one particle at the centre of every raster cell with
 *    concentration > threshold whose centre is sea. mass = rho_i * conc *
 *    thick * cell_area with the cell's area on the sphere of radius
 *    6371 km (ice_raster_cell_area), so the seeded mass is exactly the
 *    raster's ice mass over those cells. Footprint side (for the smoothing
 *    length) = sqrt(cell_area).
 *  - spacing_m > 0: particles on a square lattice of that spacing on the
 *    projected plane (aligned to the plane origin), with conc/thick sampled
 *    bilinearly from the raster; mass = rho_i * conc * thick * spacing^2
 *    (plane area). The total then matches the raster's mass only to the
 *    sampling and projection-scale error (about 1 % for smooth fields).
 * Both: sml = sml_factor * footprint side, u = v = 0, lat set, id =
 * first_id + running index, snow = 0, tsurf = -1.8 C-ish defaults are left
 * to the caller (seeding fills x, y, lat, mass, thick, conc, sml, u, v,
 * id). No particle is placed where the land mask says land (a point
 * outside the mask's grid counts as sea).
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

typedef struct seed_options {
    double threshold;    /* seed where conc > threshold (0..1), default 0.05 */
    double spacing_m;    /* 0: raster cells; > 0: plane lattice spacing, m */
    double sml_factor;   /* h0 = sml_factor * spacing (default 1.0, the seed's h0 = spacing) */
    double rho_ice;      /* kg/m^3, default 900 */
    long first_id;       /* id of the first particle seeded (default 0) */
    /* plane-lattice bounds (spacing_m > 0): the raster's projected
     * bounding box when all four are 0 */
    double xmin, xmax, ymin, ymax;
} seed_options;

void seed_options_default(seed_options *o);

/* Number of particles seed_from_raster would append. */
int seed_count(const ice_raster *r, const geo_proj *p, const landmask *mask,
               const seed_options *o, size_t *count, sph_error *err);

/* Appends the particles to P (P->n grows). Fails without changing P when
 * P->cap - P->n is too small. mask may be NULL (all sea). */
int seed_from_raster(const ice_raster *r, const geo_proj *p, const landmask *mask,
                     const seed_options *o, sph_particles *P, sph_error *err);

#endif
