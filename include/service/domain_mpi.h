/* Spatial domain decomposition of one model over MPI ranks (issue 24,
 * item 2; make MPI=1; docs/domain.md). Compiled only in the MPI build.
 *
 * Cells of a square grid (side >= the halo width) are ordered along a
 * Hilbert curve and cut into one contiguous piece per rank of equal cost
 * (particles per cell, measured, summed over the ranks). Each rank's
 * sph_model holds the particles it owns; before every step particles that
 * drifted into another rank's cells migrate there, and every particle
 * within the halo width of another rank's cells is copied to it as a halo
 * particle. The halo width is 2 kernel supports (3 with the gradient
 * correction) of the largest smoothing
 * length, so that everything the step computes before the stress solver
 * (density, gradient correction, the active set) is exact on the halo
 * particles an owned one reads; inside the mEVP iteration the halo's
 * velocity and stress are refreshed from their owners after every
 * iteration (nonblocking, overlapped with the norms' reduction and the
 * next iteration's interior particles). The
 * model runs in canonical mode (core/dd.h), so the owned particles end
 * every step bit for bit as in a serial canonical run.
 */
#ifndef SPHICE_SERVICE_DOMAIN_MPI_H
#define SPHICE_SERVICE_DOMAIN_MPI_H

#ifdef SPHICE_MPI
#include <mpi.h>

#include "core/dd.h"
#include "core/model.h"

typedef struct dd_ctx dd_ctx;

typedef struct dd_options {
    double x0, y0, x1, y1;  /* the domain (particles outside go to the edge cells) */
    double cell;            /* cell side, m (>= the halo width; 0: the initial halo width) */
    int rebalance_every;    /* steps between repartitions (0: only at the start) */
} dd_options;

/* Statistics since dd_scatter or dd_reset_stats, summed over the steps
 * and the ranks by dd_run_stats. */
typedef struct dd_stats {
    long owned;            /* particles now */
    long halo;             /* halo copies received, all steps */
    long migrated;         /* particles that changed rank, all steps */
    long iterations;       /* halo refreshes (mEVP iterations), all steps */
    double halo_bytes;     /* bytes sent for the halo: copies + refreshes */
    double migrate_bytes;  /* bytes sent for migration */
    long owned_max;        /* the most particles one rank owns now */
    int ghosts_merging;    /* a rank merged crowded coast ghosts (order not canonical) */
    double wait_s;         /* wall s a rank spent completing halo refreshes (MPI_Waitall):
                              this rank's; the largest over the ranks from dd_run_stats */
    double wait_min_s;     /* dd_run_stats: the smallest over the ranks */
    double reduce_s;       /* wall s in the mEVP norms' MPI_Allreduce (the largest rank's) */
} dd_stats;

/* Budgets of the owned particles over all ranks, exact (core/dd.h sph_xsum). */
typedef struct dd_budget {
    double mass, area, volume, momentum_x, momentum_y, kinetic_energy;
} dd_budget;

/* A driver for model m (this rank's; capacity for its share plus halo):
 * puts m into canonical mode and installs the hooks. NULL on failure. */
dd_ctx *dd_create(MPI_Comm comm, sph_model *m, const dd_options *o);
void dd_free(dd_ctx *d);
/* Rank 0 hands out the particles of `all` (initialised by sph_model_init
 * of a serial model; ignored elsewhere) and its clock; every rank resumes
 * its share. SPH_STEP_OK or the first rank's failure. */
int dd_scatter(dd_ctx *d, const sph_particles *all, const sph_model_clock *c, sph_status *st);
/* One step: migration, repartition when due, halo, sph_model_step, halo
 * dropped. Returns the worst status over the ranks (a rank that cannot
 * hold its particles aborts the job with one line). */
int dd_step(dd_ctx *d, sph_status *st);
/* Collective: the statistics over the ranks into out. */
void dd_run_stats(dd_ctx *d, dd_stats *out);
void dd_reset_stats(dd_ctx *d);
/* 1 (the default): the halo refresh is completed inside the next mEVP
 * iteration, after the interior particles' strain and stress; 0: right
 * after the norms' reduction (the old order; core/dd.h no_overlap). The
 * same answer either way; for bench_mpi_dd's comparison. */
void dd_set_overlap(dd_ctx *d, int on);
void dd_budget_global(dd_ctx *d, dd_budget *b);
/* b's source terms (growth, melt, snow, outflow, removed particles: core/dd.h)
 * over every rank, as of the last dd_step or dd_scatter (the same on every
 * rank; no communication). */
void dd_sources(const dd_ctx *d, sph_budget *b);
/* The same budgets of particles [0, n) of one set (the serial reference). */
void dd_budget_of(const sph_particles *P, size_t n, double rho_i, dd_budget *b);
/* Every owned particle to rank 0, sorted by id, into out (rank 0 only;
 * capacity the global count). */
int dd_gather(dd_ctx *d, sph_particles *out);
#endif

#include "core/particles.h"
/* Sorts particles [0, n) of P by id (in place; scratch for n doubles x
 * layers). In both builds. */
void dd_sort_by_id(sph_particles *P);
#endif
