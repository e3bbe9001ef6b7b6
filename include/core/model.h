/* The SPH sea-ice model: the step-from-outside driver API (create / set
 * up / step / check / free; its parameters: core/params.h). No I/O, no logging, and no
 * allocation inside a step: all workspace is allocated by sph_model_create.
 *
 * Momentum (PHYSICS.md eq. 2, per unit area):
 *   M dV/dt = -M f k x V + tau_a + tau_w - M g grad(xi) + div(hbar sigma)
 * with M = rho_i A h_i the mass per unit area (Hibler 1979; CICE would
 * scale the drag by A, which changes only the Coriolis/inertia balance of
 * loose ice).
 */
#ifndef SPHICE_CORE_MODEL_H
#define SPHICE_CORE_MODEL_H

#include <stddef.h>
#include "core/kinds.h"
#include "core/particles.h"
#include "core/status.h"
#include "core/params.h" /* sph_params, the parameter table; the kinds */
#include "core/thermo.h"
#include "core/ocean.h"

/* Land mask on a regular grid of the projected plane. Cells are land
 * (1) or sea (0); outside the grid is open boundary (particles leaving are
 * removed and counted as outflow), unless closed_outside is set. */
typedef struct sph_landmask {
    int nx, ny;
    double x0, y0, dx, dy;   /* centre of cell (0,0) is (x0 + dx/2, y0 + dy/2) */
    const unsigned char *land; /* nx*ny, row-major (j*nx + i) */
    int closed_outside;      /* 1: the grid edge is a wall, not an open boundary */
} sph_landmask;

/* The measured stability envelope (docs/bench.md): the largest dynamic
 * step, s, inside the stable region measured for p's solver and rheology
 * at the initial particle spacing `spacing` (m); HUGE_VAL where nothing was
 * measured to bound it (free drift; the explicit solver, which sub-steps
 * itself; the implicit solver). *why (may be NULL) gets the message a
 * refusal gives. sph_model_init refuses a step above it. */
double sph_params_stable_dt(const sph_params *p, double spacing, const char **why);

/* Auto time stepping (model.dt = 0): the step is base / n for the smallest
 * whole n with base / n <= the safety factor x the stable step and
 * f dt <= SPH_AUTO_DT_CORIOLIS at the poles' f. base is the interval the
 * step must divide (thermodynamic step, output interval); base <= 0 takes
 * the bound itself. The safety factors are measurements, not guesses
 * (docs/dynamics.md "Auto time stepping"): SPH_AUTO_DT_SAFETY for the
 * solvers' envelopes (the Liaodong demo at 0.45 of its adaptive-EVP
 * bound stays within 5 % of the seed's 60 s errors against the converged
 * reference; the 1e5-particle packed case at 0.6 within 1 %),
 * SPH_AUTO_DT_SAFETY_RP with replacement pressure (R300's steady state
 * meets its 1 % aim at 0.45 of the plastic-wave bound and misses it at
 * 0.57). *why names the bound that decided. */
#define SPH_AUTO_DT_SAFETY 0.6
#define SPH_AUTO_DT_SAFETY_RP 0.5
#define SPH_AUTO_DT_CORIOLIS 0.1
double sph_params_auto_dt(const sph_params *p, double spacing, double base, const char **why);

typedef struct sph_model sph_model;

/* Creates a model able to hold `cap` particles. The land mask (may be
 * NULL: no land, open domain) is copied. Returns NULL on failure. */
sph_model *sph_model_create(const sph_params *p, size_t cap, const sph_landmask *mask);
void sph_model_free(sph_model *m);

sph_particles *sph_model_particles(sph_model *m);
/* Between steps the pair gradients hold nothing the model reads again:
 * every step and sph_model_init rebuild the neighbour lists before a pass
 * reads them. Until the next step (or init) the caller may use their
 * memory as scratch: *len doubles at the returned address, the slots the
 * last build wrote (resident pages, no new memory). NULL with *len 0 when
 * there are none (parcels, no build yet). */
double *sph_model_idle_scratch(sph_model *m, size_t *len);
/* The model's copy of the land mask given to sph_model_create (its land
 * pointing at the model's own cells, unchanged while the model lives), or
 * NULL without one. */
const sph_landmask *sph_model_landmask(const sph_model *m);
/* 1 when the last neighbour build kept the pair gradients in the factor
 * form (model.compact_gradients true, or auto at SPH_MEMORY_BOUND_PARTICLES
 * particles and more), 0 with the two components or before any build. */
int sph_model_compact_form(const sph_model *m);
/* Tests: the particle count from which model.compact_gradients auto keeps
 * the factor form in this model's next builds (default
 * SPH_MEMORY_BOUND_PARTICLES, core/params.h), so that a small scene can
 * take the memory-bound branch. */
void sph_model_set_memory_bound(sph_model *m, size_t n);
const sph_params *sph_model_params(const sph_model *m);
size_t sph_model_capacity(const sph_model *m); /* live particles it can hold */
/* Mirror ghosts of the last step, stored after the live particles. */
size_t sph_model_ghosts(const sph_model *m);
/* 1 once the model merges crowded mirror ghosts: a coast curved tighter
 * than the kernel support (an island, a headland, stair-step corners)
 * piled its ghosts up beyond max_neighbours (core/coast.c). */
int sph_model_ghosts_merging(const sph_model *m);
/* Smallest initial particle spacing of the placed particles, m:
 * min over particles of sml0 (sml before sph_model_init) / sml_factor. */
double sph_model_spacing(const sph_model *m);
/* Changes reloadable parameters (same capacity and layers). */
int sph_model_set_params(sph_model *m, const sph_params *p);

/* After particles were placed (positions, mass, thick, conc, sml):
 * computes densities, diagnoses concentration, records the initial mass. */
int sph_model_init(sph_model *m, sph_status *st);

/* The model's own state outside the particle arrays, for restart files:
 * with it and every particle array a run continues bit for bit. */
typedef struct sph_model_clock {
    double time;         /* seconds since init */
    long steps;          /* dynamic steps since init */
    double thermo_accum; /* s of dynamics since the last thermodynamic step */
    double dens_scale;   /* kernel lattice calibration (summation density; else 1) */
    sph_budget budget;
} sph_model_clock;
void sph_model_get_clock(const sph_model *m, sph_model_clock *c);

/* Instead of sph_model_init, for particles restored with their full state
 * (dens, dens0, sml0, stress, enthalpy ...) in the order they were saved:
 * validates them, builds the coast tables and sets the clock. Nothing is
 * re-diagnosed or reordered, so the next step is the step the saved run
 * would have taken. */
int sph_model_resume(sph_model *m, const sph_model_clock *c, sph_status *st);

/* One dynamic step of length params.dt (forcing arrays must be filled),
 * plus thermodynamics when its own step falls due. */
int sph_model_step(sph_model *m, sph_status *st);

/* Diagnoses the current state without advancing: neighbours, density,
 * concentration, strength, strain rates of the current velocities, the
 * constitutive stress (no EVP memory) and its divergence (ax, ay). */
int sph_model_diagnose(sph_model *m, sph_status *st);

/* Largest stable step of the explicit solver at the current state, s. */
double sph_model_explicit_dt_limit(sph_model *m);

/* The ocean mixed layer (core/ocean.h) on grid g, with new particles on
 * g's lattice: allocated here, after sph_model_create and before
 * sph_model_init (never inside a step); used when model.ocean.mixed_layer
 * is on. The driver fills its forcing and may set cells
 * (sph_ocean_set_cell) before init. SPH_STEP_OK or SPH_STEP_FATAL. */
int sph_model_ocean_create(sph_model *m, const sph_ocean_grid *g);
sph_ocean *sph_model_ocean(sph_model *m); /* NULL: none */

const sph_budget *sph_model_budget(const sph_model *m);
double sph_model_time(const sph_model *m);   /* seconds since init */
long sph_model_steps(const sph_model *m);
/* Statistics of the last step (sub-steps used, solver iterations, residual,
 * fraction of particles in each regime). */
typedef struct sph_step_stats {
    int substeps;
    int iterations;
    int stalled;        /* 1: the auto mode stopped the mEVP iteration at a stall */
    double residual;
    double rel_residual; /* mEVP: relative momentum residual at the last iteration,
                            RMS(beta |du|) / RMS(|u|) over the active set (0: no solve) */
    int unconverged;    /* 1: the step's stress iteration ended above evp.rel_tol
                           (only with evp.rel_tol > 0) */
    double frac_free_drift, frac_rheology;
    double frac_zero_layer, frac_multi_layer;
    double dt_limit_explicit;
} sph_step_stats;
const sph_step_stats *sph_model_stats(const sph_model *m);

/* Statistics of a whole run, the one struct that goes from the core to the
 * service's result, cycle.json, the status and the products' attributes:
 * sph_run_stats_begin after init, sph_run_stats_add after every step,
 * sph_run_stats_end after the last. The fractions and solver numbers are
 * means over the steps (0 when there was none). */
typedef struct sph_run_stats {
    double frac_free_drift, frac_rheology, frac_zero_layer, frac_multi_layer;
    double solver_iterations;   /* mean stress-solver iterations per step: mEVP, or Picard
                                   for the implicit solver (0: no stress solve) */
    double solver_stalled;      /* fraction of steps the auto mode stopped at a stall */
    double solver_residual;     /* mean relative mEVP residual per step (rel_residual) */
    double solver_residual_max; /* largest relative mEVP residual of a step */
    double solver_unconverged;  /* fraction of steps that ended above evp.rel_tol */
    int solver_rel_tol_on;      /* 1: evp.rel_tol > 0 (the residual rule in force) */
    long particles_start, particles_end;
    double budget_residual;     /* relative mass budget residual (sph_budget_residual) */
    int ocean;                  /* 1: the mixed layer's budgets below were kept */
    double energy_residual, water_residual, salt_residual; /* sph_budget_*_residual */
    double dt;                  /* dynamic step used, s */
    int dt_auto;                /* 1: chosen by auto time stepping (model.dt = 0) */
    long steps;                 /* steps added */
} sph_run_stats;
void sph_run_stats_begin(sph_run_stats *r, sph_model *m, int dt_auto);
void sph_run_stats_add(sph_run_stats *r, const sph_model *m);
void sph_run_stats_add_step(sph_run_stats *r, const sph_step_stats *ss);
void sph_run_stats_end(sph_run_stats *r, sph_model *m);

/* Normalised (Shepard-corrected) SPH interpolation of particle fields to
 * arbitrary points: out_f[q][i] = sum_j (m_j/M_j) f_q,j W / sum_j (m_j/M_j) W.
 * `fields` are nf arrays of particle values. Also returns at each point the
 * raw SPH mass density (kg/m^2) in out_dens if non-NULL (not normalised:
 * it falls to zero beyond the ice edge). Points with no neighbour get NaN
 * in out_f and 0 in out_dens. Threaded, deterministic. */
int sph_model_interpolate(sph_model *m, size_t npts, const double *px, const double *py,
                          int nf, const double *const *fields, double *const *out_f,
                          double *out_dens);

#endif
