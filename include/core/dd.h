/* Hooks for a spatial domain decomposition of one model (the driver:
 * service/domain_mpi.c, make MPI=1; docs/domain.md). The core stays free
 * of MPI: a driver gives each rank a model holding the particles it owns
 * plus halo copies of other ranks' particles near its boundary, and the
 * core calls the driver back where the halo must be refreshed.
 *
 * The answer must not depend on the decomposition, so a model in
 * canonical mode (sph_model_set_canonical):
 *  - sorts every neighbour list by a global key (particle id; a mirror
 *    ghost after its source, in the order its walls were found), so every
 *    sum over neighbours runs in an order that does not depend on which
 *    rank holds which particle or in which slot;
 *  - computes the stress solver's norms (mEVP residuals, RMS velocity
 *    change) with an exact accumulator (sph_xsum), whose sum does not
 *    depend on the order of the terms, over owned particles only, and
 *    hands the accumulators to the driver's reduce hook to be summed over
 *    the ranks (integer sums: associative).
 * A serial model in canonical mode without hooks is the reference a
 * decomposed run equals bit for bit (tests/test_mpi_dd.c). The default
 * (non-canonical) path is unchanged.
 */
#ifndef SPHICE_CORE_DD_H
#define SPHICE_CORE_DD_H

#include <stddef.h>
#include <stdint.h>

#include "core/model.h"

/* An exact sum of doubles: fixed-point digits of 32 bits (int64 with room
 * for 2^31 additions) spanning the whole double range, so the value is
 * exact whatever the order of the terms; rounded once by sph_xsum_value. */
#define SPH_XSUM_DIGITS 68
typedef struct sph_xsum {
    int64_t d[SPH_XSUM_DIGITS];
    int64_t nonfinite; /* terms that were NaN or infinite */
} sph_xsum;
void sph_xsum_clear(sph_xsum *a);
void sph_xsum_add(sph_xsum *a, double x);
/* Adds b's digits into a (what the driver's reduce does over ranks). */
void sph_xsum_merge(sph_xsum *a, const sph_xsum *b);
/* The sum, deterministic in the exact value (NaN if a term was not finite). */
double sph_xsum_value(const sph_xsum *a);

enum {
    SPH_DD_LISTS = 1,    /* neighbour lists, density and the active set are ready
                            (after any reordering of the step): map particles */
    SPH_DD_ITER_POST = 2, /* an mEVP iteration updated u, v, s11, s22, s12:
                             start sending the owned boundary values */
    SPH_DD_ITER_WAIT = 3, /* before the next iteration: the halo must be current */
    SPH_DD_OCEAN = 4,     /* the mixed layer's step (a thermodynamic step, before and
                             after the columns): fill the view (sph_model_dd_view) */
    SPH_DD_OUTFLOW = 5    /* after a step's removals at open boundaries, with the
                             mixed layer and thermo.ocean_fluxes: gather every rank's
                             rows (sph_model_dd_outflow) */
};

typedef struct sph_dd_hooks {
    void *ctx;
    /* Called by the core at the stages above. */
    void (*exchange)(void *ctx, sph_model *m, int stage);
    /* Sums nsum accumulators and takes the maximum of nmax doubles over
     * the ranks, in place. */
    void (*reduce)(void *ctx, sph_xsum *sums, int nsum, double *maxes, int nmax);
    /* 0 (the default): the refresh posted after an iteration is completed
     * (SPH_DD_ITER_WAIT) inside the next one, after the strain rates and
     * stresses of the interior particles (owned, every neighbour an owned
     * particle: no halo copy, no coast ghost) are computed, so the messages
     * travel during that work; then the boundary particles. 1: the old
     * order (completed right after the norms' reduction). The same answer
     * either way (each particle's arithmetic is unchanged). */
    int no_overlap;
    /* 1 on exactly one rank (the driver's rank 0): the rank that takes the
     * particles the mixed layer creates (the next step's migration moves
     * them to their owners) and books their mass in its sources. */
    int lead;
} sph_dd_hooks;

/* Canonical mode on (1) or off (0); allocates its workspace (outside a
 * step). 0 on success. */
int sph_model_set_canonical(sph_model *m, int on);
/* Hooks of a decomposition driver (NULL: none; serial). Implies nothing
 * about canonical mode, which the driver turns on itself. */
void sph_model_set_dd(sph_model *m, const sph_dd_hooks *h);
/* Per slot (live particles of this step, after its reordering): 1 where
 * this rank owns the particle. The driver fills it at SPH_DD_LISTS; NULL
 * unless canonical mode is on. Without hooks every particle is owned. */
unsigned char *sph_model_dd_owned(sph_model *m);
/* The thermodynamic and open-boundary sources of the budget in canonical
 * mode, summed exactly (cumulative since init or resume) over the particles
 * this rank owns: the first nine are the thermodynamics' per-particle terms
 * (sph_thermo_outcome_terms, in its order), then the open boundaries'. A
 * decomposed driver sums them over the ranks; a serial canonical model
 * takes its budget's source terms from them (so they do not depend on the
 * order of the particles). */
enum {
    SPH_DD_SRC_GROWTH,
    SPH_DD_SRC_NEW_ICE,
    SPH_DD_SRC_MELT_TOP,
    SPH_DD_SRC_MELT_BOTTOM,
    SPH_DD_SRC_LATERAL_MELT,
    SPH_DD_SRC_SNOW_ICE,
    SPH_DD_SRC_SNOWFALL,
    SPH_DD_SRC_SNOW_MELT,
    SPH_DD_SRC_SNOW_TO_OCEAN,
    SPH_DD_SRC_OUTFLOW,
    SPH_DD_SRC_REMOVED, /* particles removed at open boundaries (a count) */
    SPH_DD_NSRC
};
const sph_xsum *sph_model_dd_sources(const sph_model *m);
/* b's source terms (growth ... snow_to_ocean, outflow, removed_particles)
 * = base's plus the accumulators' values. */
void sph_dd_budget_sources(sph_budget *b, const sph_budget *base, const sph_xsum src[SPH_DD_NSRC]);

/* The mixed layer under decomposition (canonical mode; docs/domain.md):
 * its step runs on a view of every rank's particles, gathered by the
 * driver at SPH_DD_OCEAN: the driver copies every rank's owned particles
 * (sph_model_dd_owned) into the view (every field, any order: the core
 * sorts it by id), sets its n, writes each one's sph_model_dd_local_ea
 * value into *ea at the same position, and replaces *rc by the worst
 * of every rank's *rc (SPH_STEP_FATAL if any, else any other failure). NULL when the model has no view. */
sph_particles *sph_model_dd_view(sph_model *m, double **ea, int **rc);
const double *sph_model_dd_local_ea(const sph_model *m);
/* The accumulators of the particles that left at an open boundary in this
 * step (canonical mode with the mixed layer and thermo.ocean_fluxes): rows
 * of 11 doubles (id, x, y, footprint, seven accumulators). Returns this
 * rank's nlocal rows; at SPH_DD_OUTFLOW the driver copies every rank's rows
 * (any order: the core books them in id order) into *all and sets **nall;
 * at most *cap rows in all. */
double *sph_model_dd_outflow(sph_model *m, size_t *nlocal, double **all, size_t **nall, size_t *cap);

/* The kernel's support in units of the smoothing length. */
double sph_model_kernel_radius(const sph_model *m);
/* After sph_model_resume on a rank: marks the coast cells for mirror
 * ghosts with the global largest sml0 (resume takes the largest of the
 * particles it holds, which differs between ranks). */
void sph_model_dd_coast(sph_model *m, double sml0_max);
/* The halo near coasts (docs/domain.md "Halo depth"): a particle reads a
 * mirror ghost within its support, whose source may lie up to
 * sph_model_dd_ghost_reach() supports beyond the ghost (on the far side of
 * a wall: a headland, an island narrower than the support, a particle
 * outside the mask). sph_model_dd_zone fills zone (sph_model_dd_zone_cells
 * bytes, 0 without a land mask) with 1 for the mask cells within radius of
 * land; sph_model_dd_in_zone says whether (x, y) lies in such a cell (or
 * outside the mask). */
double sph_model_dd_ghost_reach(void);
size_t sph_model_dd_zone_cells(const sph_model *m);
void sph_model_dd_zone(const sph_model *m, double radius, unsigned char *zone);
int sph_model_dd_in_zone(const sph_model *m, const unsigned char *zone, double x, double y);

#endif
