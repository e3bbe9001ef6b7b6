/* The model's parameters: struct sph_params and the one table that
 * describes every parameter a user sets (src/core/params.c).
 *
 * One row per parameter: its key (the configuration's key below `model.`,
 * e.g. "evp.iterations", "thermo.rho_ice"), type, member, default, bounds,
 * reload policy, units and description. The core's defaults
 * (sph_params_default) and range checks (sph_params_check), the service's
 * `model.*` configuration keys, `sphice config-doc` and docs/config.md are
 * all generated from it, so a new parameter is one member here and one row
 * in params.c. The column parameters of the thermodynamics without a key
 * keep sph_thermo_params_default / sph_thermo_params_check (core/thermo.h).
 *
 * The automatic time step (the configuration's model.dt = 0) is the core's
 * rule too: sph_params_dt_base and sph_params_resolve_dt. */
#ifndef SPHICE_CORE_PARAMS_H
#define SPHICE_CORE_PARAMS_H

#include <stddef.h>
#include "core/kinds.h"
#include "core/thermo.h"
#include "core/ocean.h"

/* model.momentum.drag_scaling (index = value) */
enum { SPH_DRAG_NONE = 0, SPH_DRAG_CONCENTRATION = 1 };

/* model.compact_gradients (index = value: false and true keep the 0/1 of
 * the former bool) */
enum { SPH_COMPACT_FALSE = 0, SPH_COMPACT_TRUE = 1, SPH_COMPACT_AUTO = 2 };

/* The particle count (without ghosts) from which a run is
 * memory-bound: model.compact_gradients "auto" chooses the factor form
 * there, and output.writer_thread "auto" writes the products in the step
 * loop (service/forecast_output.c) instead of holding a copy of them
 * while the next steps run. Both choices give the same bits as the
 * other form; they trade CPU (12-20 % of the strain and divergence
 * passes) or the writer's overlap for memory. The default path peaks near
 * 1.05 kB per particle at 1e6 particles (the 1 GB binds from
 * about 9e5); half of that leaves room for configurations that keep more
 * per particle (gradient correction, summation density, more neighbours),
 * and below it a run takes under about 0.5 GB, where memory binds nothing
 * (docs/bench.md, Session 11: memory at 1e6). */
#define SPH_MEMORY_BOUND_PARTICLES 500000

typedef struct sph_params {
    /* numerics */
    double dt;                  /* dynamic step, s (seed: 60) */
    sph_kernel_kind kernel;
    double kernel_radius;       /* support radius in units of h (Gaussian truncation; seed box 4h -> 2) */
    int variable_sml;           /* seed eq. 10 variable smoothing length */
    int gradient_correction;    /* kernel gradient correction (Bonet & Lok 1999) in the
                                   strain rates and the stress divergence */
    int summation_density;      /* 1: M = sum_j m_j W_kj every step (seed);
                                   0: M evolved by continuity dM/dt = -M div V
                                   from the seeded rho_i A h_i (default: no lattice
                                   noise, exact edges; see docs/dynamics.md) */
    int density_reinit_steps;   /* continuity only: every N steps M is reset by the
                                   summation (Colagrossi & Landrini 2003's periodic
                                   re-initialisation; 0: never, docs/ocean.md) */
    double sml_factor;          /* h0 = sml_factor * initial spacing */
    sph_solver_kind solver;
    sph_unstable_policy unstable; /* explicit solver beyond its limit */
    int evp_iterations;         /* mEVP sub-iterations per step */
    int evp_adaptive;           /* aEVP: local alpha = beta from the stability bound */
    double evp_alpha, evp_beta; /* fixed mEVP parameters */
    double evp_tol;             /* m/s: stop iterating when no velocity changes more */
    int evp_stall_window;       /* auto physics: stop iterating when the RMS velocity change
                                   has reached no new minimum in this many iterations (a
                                   limit cycle: more iterations do not move the solution);
                                   0 = off. Full physics always iterates to evp_tol or
                                   evp_iterations. */
    double explicit_safety;     /* explicit limit dt < safety * M h^2 / (zeta + eta) */
    int max_neighbours;         /* neighbour list capacity (more = clumping, an error) */
    int implicit_max_picard;    /* Picard iterations */
    double implicit_tol;        /* relative residual */
    double jfnk_tol;            /* m/s: JFNK stops when the RMS momentum residual is below */
    int jfnk_max_newton;        /* JFNK: Newton iterations per step before a recoverable failure */
    int max_substeps;           /* explicit solver sub-step cap per dynamic step */
    /* rheology */
    sph_physics_mode physics;
    sph_rheology_kind rheology;
    sph_pressure_form pressure_form;
    double P0;                  /* N/m^2: seed 1.0e4; Hibler P* 2.75e4 */
    double C;                   /* concentration parameter, 20 */
    double ecc;                 /* ellipse ratio e, 2 */
    double zeta_max_factor;     /* zeta_max = factor * P, 2.5e8 s */
    double delta_min;           /* s^-1, 2e-9 */
    int replacement_pressure;   /* Hibler/Kreyscher replacement pressure */
    double auto_tolerance;      /* auto: free drift where exp(-C(1-A)) < tol */
    int free_drift_parcels;     /* free_drift: independent parcels, no SPH (model.c) */
    int compact_gradients;      /* SPH_COMPACT_*: pair gradients as F and positions (core/neighbours.h) */
    /* collision rheology (Shen, Hibler & Lepparanta 1987) */
    double coll_restitution;    /* e_r */
    double coll_floe_diameter;  /* d = D, m */
    double coll_max_conc;       /* C0 */
    double coll_vfluct_min;     /* m/s: floor of v' (v' = kernel-weighted RMS deviation) */
    /* momentum */
    double rho_i, rho_a, rho_w; /* kg/m^3 */
    double Ca, Cw;              /* drag coefficients */
    double turn_air, turn_water;/* turning angles, degrees (+ to the right in the NH) */
    double gravity;             /* m/s^2 */
    int coriolis;               /* 0 disables (channel tests) */
    /* comparison options (off by default; docs/dynamics.md "Comparison
     * options"): like-for-like runs against grid models such as CICE */
    int fixed_state;            /* 1: momentum solved on a fixed ice state (positions, A, h
                                   and mass per area unchanged; no thermodynamics) */
    int drag_scaling;           /* SPH_DRAG_NONE (Hibler 1979) or SPH_DRAG_CONCENTRATION
                                   (CICE: air and water stress times A) */
    double coriolis_f;          /* s-1: constant Coriolis parameter; 0 = 2 Omega sin(lat) */
    double evp_rel_tol;         /* mEVP: stop when the relative momentum residual falls
                                   below this; 0 = off (counts and stall window only) */
    int evp_anderson;           /* mEVP: Anderson acceleration depth (0 = off; issue 22) */
    double evp_change_tol;      /* mEVP: stop when the relative velocity and stress change
                                   of an iteration fall below this; 0 = off (issue 22) */
    int coast_no_slip;          /* 1: ghosts reverse velocity; 0: free slip */
    double sml_min_factor, sml_max_factor; /* h kept within [min, max] * h0 */
    /* health */
    double speed_limit;         /* m/s: above is a fatal blow-up */
    double thickness_limit;     /* m: mean thickness M / rho_i above is a fatal pile-up */
    double mass_tolerance;      /* relative mass change per step no source explains */
    /* thermodynamics */
    double thermo_dt;           /* s (seed: 600); 0 = off */
    sph_thermo_params thermo;
    /* the ocean mixed layer and new ice in open water (core/ocean.h) */
    sph_ocean_params ocean;
} sph_params;

/* Every row's default; the thermodynamic column parameters without a row
 * from sph_thermo_params_default. dt is the seed's 60 s (the configuration
 * asks for the automatic step instead: see sph_params_resolve_dt). */
void sph_params_default(sph_params *p);
/* Range-checks every row (and thermo.dt against dt). On failure returns
 * SPH_STEP_FATAL and names the row's key ("dt", "rheology.P0") and its
 * allowed range in *name, *lo, *hi. */
int sph_params_check(const sph_params *p, const char **name, double *lo, double *hi);

/* ------------------------------------------------------------ the table */

typedef enum {
    SPH_PARAM_DOUBLE = 0,
    SPH_PARAM_INT,
    SPH_PARAM_BOOL,  /* an int member, 0 or 1 */
    SPH_PARAM_ENUM   /* an int-sized enum member, index into names */
} sph_param_type;

enum {
    SPH_PARAM_RELOAD = 1u << 0 /* a reloaded configuration applies a change (the next run's model) */
};

typedef struct sph_param {
    const char *key;          /* "dt", "evp.iterations", "momentum.rho_ice", "thermo.model" */
    sph_param_type type;
    size_t offset;            /* of the member in sph_params */
    double def;               /* default; bool 0/1, enum the index */
    const char *def_literal;  /* numbers: the default as written in the table ("1.0e4") */
    double lo, hi;            /* inclusive bounds; bool 0..1, enum 0..count-1 */
    unsigned flags;           /* SPH_PARAM_RELOAD */
    const char *const *names; /* enum: NULL-terminated, index = value; else NULL */
    const char *units;        /* "s", "kg/m^3", "1" (dimensionless), "" (bool, enum) */
    const char *doc;          /* one line for the reference */
} sph_param;

/* The rows, in the configuration's order; *n gets their count. */
const sph_param *sph_param_table(size_t *n);
/* The row of a key ("rheology.P0"), or NULL. */
const sph_param *sph_param_find(const char *key);
/* A row's value in p, as a double (bool and enum as their int). */
double sph_param_get(const sph_param *r, const sph_params *p);
/* Sets a row's value in p: SPH_STEP_OK, or SPH_STEP_FATAL (p unchanged)
 * when v is outside the row's bounds or not a whole number for an int,
 * bool or enum. */
int sph_param_set(const sph_param *r, sph_params *p, double v);
/* The row's default as JSON text ("1.0e4", "true", "\"gaussian\"") into
 * buf; returns the length snprintf would write. */
int sph_param_default_json(const sph_param *r, char *buf, size_t len);

/* ------------------------------------------------- automatic time step */

/* Whole seconds shared by the thermodynamic step (when thermodynamics is
 * on: thermo_dt > 0 and a thermodynamic model) and the n intervals the
 * caller's step must divide (output interval, the time to the next
 * restart), so that none of them falls between two steps; 0 when none is
 * whole. Intervals below 1 s or not whole are skipped. */
double sph_params_dt_base(const sph_params *p, const double *intervals, size_t n);
/* The automatic dynamic step at the initial particle spacing (m): the
 * largest base / k within the measured envelope (sph_params_auto_dt in
 * core/model.h), at most the thermodynamic step when thermodynamics is on.
 * p->dt is ignored. *why (may be NULL) names the bound that decided. */
double sph_params_resolve_dt(const sph_params *p, double spacing, double base, const char **why);

#endif
