/* The ocean mixed layer on a grid, and new ice in open water (issue 20,
 * items 1, 2 and 5). docs/ocean.md describes every choice.
 *
 * A slab per cell of a regular grid on the model plane: temperature T
 * (deg C), salinity S (psu), depth d (m; the configured depth, or the
 * forcing's mixed-layer depth, limited by the bathymetry so that shallow
 * water cools first). Per thermodynamic step, each cell takes
 *  - the atmosphere over its open water with no particle (the ice
 *    surface's bulk formulas, sph_open_water_flux),
 *  - from every particle whose footprint covers it, in proportion to the
 *    footprint's overlap with the cell (its sea part), the heat the
 *    particle's column and leads did not get from the atmosphere (the
 *    ice-ocean heat flux, shortwave through ice and leads, the remnants of
 *    melted-out ice), and the water and salt of the particle's mass change,
 *  - optional restoring to the forcing's SST / SSS over a time scale.
 * Below the freezing point of its salinity the cell's heat deficit forms
 * frazil (ice volume = deficit / -q_new); when the frazil over the cell's
 * open water reaches model.new_ice.thickness, new particles are created on
 * the seeding lattice points of the cell that are sea and not inside
 * existing ice, with the frazil's mass, enthalpy and salt.
 *
 * The slab's heat content is rho_w c_w d T per unit area with the heat
 * capacity of its (fixed) depth; water exchanged with the ice changes the
 * cell's water and salt mass (salinity = 1000 salt / water), so energy,
 * water and salt of ice plus ocean close to round-off (sph_budget).
 *
 * Sign conventions as core/thermo.h: fluxes W/m^2, enthalpy of ice
 * negative (zero: liquid at its melting point). No I/O, no allocation in a
 * step: everything is allocated by sph_model_ocean_create. */
#ifndef SPHICE_CORE_OCEAN_H
#define SPHICE_CORE_OCEAN_H

#include <stddef.h>

/* A cell's water is its sea fraction of the cell, at least this (so that a
 * coastal cell a particle drifts over still has a heat capacity). */
#define SPH_OCEAN_MIN_SEAFRAC 0.05
#define SPH_OCEAN_RHO_WATER 1026.0 /* kg/m^3, the slab's density (heat capacity, water mass) */
#define SPH_OCEAN_CP_WATER 3990.0 /* J/kg/K, sea water (CICE cp_ocn 4218; Gill 1982 3986) */

typedef enum {
    SPH_FREEZING_LINEAR = 0, /* Tf = -mu S (thermo.mu, 0.054 K/psu) */
    SPH_FREEZING_UNESCO      /* Millero (1978), UNESCO (1983) at p = 0 */
} sph_freezing_kind;

/* Model parameters (rows model.ocean.* and model.new_ice.* of params.c). */
typedef struct sph_ocean_params {
    int mixed_layer;        /* 1: the slab mixed layer is on (0) */
    double cell;            /* m (0: four seeding lattice spacings): the service's grid cell */
    double depth;           /* m (20): depth where no forcing field gives it */
    double min_depth;       /* m (1): floor of the depth of a sea cell */
    int freezing;           /* sph_freezing_kind (linear) */
    double restore_days;    /* days (0 = off): restoring time scale to SST / SSS */
    double heat_transfer;   /* W/m^2/K (246): ice-ocean heat flux rho_w c_w c_h u* (T - Tf)
                               (McPhee 1992: c_h 0.006, u* 0.01 m/s) */
    int create;             /* 1: new particles from frazil in open water (0) */
    double new_thickness;   /* m (0.05): frazil over the open water that creates particles */
    int merge;              /* 1: thin crowded particles are merged (0) */
    double merge_thickness; /* m (0.2): both thinner than this */
    double merge_distance;  /* (0.5): closer than this x the mean footprint side */
    double merge_max_size;  /* (2): the merged particle at most this many lattice spacings:
                               footprint <= (k ds)^2, smoothing length <= k sml_factor ds */
} sph_ocean_params;

/* The grid (cell (i, j) spans [x0 + i dx, x0 + (i+1) dx) x [y0 + j dy, ...))
 * and the seeding lattice new particles are placed on: points
 * (lx0 + a ds, ly0 + b ds). */
typedef struct sph_ocean_grid {
    int nx, ny;
    double x0, y0, dx, dy;
    double lx0, ly0, ds;
} sph_ocean_grid;

/* The mixed layer's arrays, nx*ny each, row-major (j*nx + i). The driver
 * fills the forcing before a step; the fluxes are those of the last
 * thermodynamic step. */
typedef struct sph_ocean {
    sph_ocean_grid g;
    size_t ncell;
    /* state */
    double *temp;        /* deg C */
    double *sal;         /* psu (diagnosed: 1000 salt / water) */
    double *depth;       /* m, used (configured or forcing, limited by bathymetry) */
    double *water;       /* kg of water in the cell */
    double *salt;        /* kg of salt in the cell */
    double *frazil;      /* kg of frazil ice waiting to become particles */
    double *frazil_enth; /* J of that frazil (< 0) */
    double *seafrac;     /* sea fraction of the cell (land mask sampled; 1 without one) */
    /* forcing (driver): atmosphere over open water, restoring targets */
    double *tair, *qair, *ua, *va, *swdn, *lwdn; /* as the particle fields */
    double *lat;                                 /* degrees_north, for new particles */
    double *sst_restore, *sss_restore;           /* NaN: no restoring there */
    /* open water with no particle, last thermodynamic step, per m^2 of cell */
    double *ow_heat;  /* W/m^2: net atmospheric heat into the ocean */
    double *ow_fresh; /* kg/m^2/s: fresh water into the ocean (negative: frazil formed) */
    double *ow_salt;  /* kg/m^2/s: salt into the ocean (negative: salt into frazil) */
    /* the same open water, summed over the thermodynamic steps since the
     * driver last zeroed them (sph_ocean_clear_fluxes; the fluxes file's
     * record), extensive over the cell's open water and the steps: heat
     * into the liquid ocean, J (the atmosphere, plus the latent heat of the
     * frazil the cell formed, minus what melting frazil took: water at its
     * freezing point that loses heat gives 0, as the particles' leads);
     * fresh water and salt into it, kg (minus the frazil formed). */
    double *ofx_heat, *ofx_water, *ofx_salt;
    /* a particle removed between two records (melted out, or left at an
     * open boundary) hands its seven accumulators (core/particles.h ofx_*)
     * to its cell before it goes (sph_ocean_take_particle): heat_lead to
     * ofx_heat, water and salt to ofx_water and ofx_salt, and these: the
     * heat under its ice, J (hfsithermds, also part of hfds); its stress
     * on the ocean, N s, plane x/y; the shortwave at its base, J. */
    double *ofx_heat_ice, *ofx_taux, *ofx_tauy, *ofx_swbase;
    /* workspace: particles binned by cell */
    size_t cap;
    int *bin_start; /* ncell + 1 */
    int *bin_list;  /* cap */
    int *pcell;     /* cap: cell of each particle's centre (clamped to the grid) */
    double *pfoot;  /* cap: footprint area of each particle before the step, m^2 */
    double *penth;  /* cap: enthalpy of each particle before the step, J */
    double *pmass;  /* cap: mass before the step, kg */
    double *psnowfall; /* cap: enthalpy of the snow falling on its ice in the step, J (< 0) */
    double *cfoot;  /* ncell: particle footprint in the cell (each footprint spread over the cells it covers), m^2 */
    double *acc_e, *acc_w; /* ncell: heat and water the particles gave the cell this step */
    double e_last, m_last; /* ice enthalpy (J) and mass (kg) of the particles at the last look */
} sph_ocean;

/* Freezing point of sea water at salinity S (psu), surface pressure:
 * linear -mu S, or UNESCO (1983, Millero 1978)
 * Tf = -0.0575 S + 1.710523e-3 S^1.5 - 2.154996e-4 S^2. */
double sph_ocean_freezing_point(int kind, double mu, double S);

/* Allocates the mixed layer for a model of capacity cap; every cell starts
 * at depth `depth`, salinity S0 and its freezing point; forcing NaN
 * (restoring) or 0. NULL on failure or a bad grid. */
sph_ocean *sph_ocean_create(const sph_ocean_grid *g, size_t cap, double depth, double S0,
                            double Tf0);
void sph_ocean_free(sph_ocean *o);

/* Cell of a point, clamped to the grid. */
size_t sph_ocean_cell(const sph_ocean *o, double x, double y);

/* Sets a cell's depth, salinity and temperature, keeping water and salt
 * consistent (water rho d x the cell's sea area, rho 1026 kg/m^3) (before sph_model_init / sph_model_step; not inside a step). */
void sph_ocean_set_cell(sph_ocean *o, size_t c, double depth, double S, double T);

/* The open-water fluxes of the last thermodynamic step over each cell's
 * open water with no particle, per m^2 of cell (heat into the ocean W/m^2,
 * fresh water and salt into the ocean kg/m^2/s); the leads of particles
 * are the particles' own. Any pointer may be NULL. Returns ncell. */
size_t sph_ocean_open_water_fluxes(const sph_ocean *o, const double **heat, const double **fresh,
                                   const double **salt);

/* Zeroes the cells' accumulators (ofx_heat, ofx_water, ofx_salt and the
 * removed particles' ofx_heat_ice, ofx_taux, ofx_tauy, ofx_swbase): the
 * driver, after each record of the fluxes file (not inside a step). */
void sph_ocean_clear_fluxes(sph_ocean *o);

#endif
