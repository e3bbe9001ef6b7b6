/* The core's choice enums: which kernel, solver, rheology, pressure form,
 * physics mode and refusal policy a run uses. Apart from model.h so that
 * headers needing one enum (kernel.h) do not pull in the whole model API.
 * The solver and rheology values index the registries (include/core/registry.h). */
#ifndef SPHICE_CORE_KINDS_H
#define SPHICE_CORE_KINDS_H

typedef enum { SPH_KERNEL_GAUSSIAN = 0, SPH_KERNEL_WENDLAND_C2, SPH_KERNEL_CUBIC_SPLINE } sph_kernel_kind;

typedef enum {
    SPH_SOLVER_EXPLICIT = 0, /* sub-stepped to its own stability limit */
    SPH_SOLVER_MEVP,         /* modified / adaptive EVP */
    SPH_SOLVER_IMPLICIT,     /* Picard with GSL sparse GMRES */
    SPH_SOLVER_JFNK          /* Jacobian-free Newton-Krylov */
} sph_solver_kind;

typedef enum {
    SPH_RHEOLOGY_VP = 0,     /* Hibler viscous-plastic */
    SPH_RHEOLOGY_COLLISION   /* Shen, Hibler & Lepparanta (1987) */
} sph_rheology_kind;

typedef enum {
    SPH_PRESSURE_SEED = 0,   /* P = P0 exp(-C(1-A)), integrated hbar P */
    SPH_PRESSURE_HIBLER      /* P = P* hbar exp(-C(1-A)) */
} sph_pressure_form;

typedef enum {
    SPH_PHYSICS_AUTO = 0,    /* per particle: free drift where loose, rheology where packed */
    SPH_PHYSICS_FULL,        /* rheology everywhere */
    SPH_PHYSICS_FREE_DRIFT   /* internal stress off */
} sph_physics_mode;

typedef enum { SPH_UNSTABLE_SUBSTEP = 0, SPH_UNSTABLE_REFUSE } sph_unstable_policy;

#endif
