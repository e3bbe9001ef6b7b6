/* Sea-ice thermodynamics on every particle (PHYSICS.md section 5, issue 8).
 *
 * Two column models, chosen per particle:
 *  - zero-layer (Semtner 1976): linear temperature profile, no heat
 *    capacity, optional snow; basal growth integrated exactly for a
 *    fixed surface temperature (trapezoidal in thickness = Stefan's law);
 *  - multi-layer (Bitz & Lipscomb 1999): salinity-dependent heat capacity
 *    and conductivity, layer enthalpy as the prognostic variable, implicit
 *    conduction (tridiagonal), shortwave penetration, optional snow layer
 *    (conductive, no heat capacity). The enthalpy update is written in flux
 *    form so that the column's energy change equals the net boundary flux
 *    times the step to round-off.
 * Surface temperature from the surface energy balance (GSL Brent root);
 * above the melting point the excess melts the surface. Open water in the
 * particle's footprint (1 - A) freezes new ice or melts laterally (Hibler's
 * two-level treatment). See docs/thermo.md for every choice and default.
 *
 * Sign conventions: fluxes are W/m^2, positive INTO the ice (downward at
 * the surface, upward at the base for the ocean flux). Temperatures deg C.
 * Enthalpy q (J/m^3) is negative; zero is brine at its melting point. */
#ifndef SPHICE_CORE_THERMO_H
#define SPHICE_CORE_THERMO_H

#include <stddef.h>
#include "core/particles.h"
#include "core/status.h"

typedef enum {
    SPH_THERMO_OFF = 0,
    SPH_THERMO_ZERO_LAYER,  /* Semtner (1976) */
    SPH_THERMO_MULTI_LAYER, /* Bitz & Lipscomb (1999) */
    SPH_THERMO_AUTO         /* zero-layer below auto_thickness, multi-layer above */
} sph_thermo_model;

typedef struct sph_thermo_params {
    sph_thermo_model model;
    int nlayers;           /* multi-layer column layers, 1..SPH_MAX_LAYERS (7) */
    double auto_thickness; /* m: threshold of the automatic choice (0.30, docs/thermo.md) */
    double rho_i;          /* kg/m^3 (917) */

    /* Bitz & Lipscomb (1999) ice: c = c0 + L0 mu S / T^2, K = K0 + beta S / T,
     * Tm = -mu S, S(z) = Smax/2 (1 - cos(pi z^(a/(z+b)))), z = depth / h. */
    double k0;           /* W/m/K (2.03), also the zero-layer conductivity */
    double beta;         /* W/m/ppt (0.13) */
    double c0;           /* J/kg/K (2106) */
    double L0;           /* J/kg (3.34e5) */
    double mu;           /* K/ppt (0.054) */
    double salinity_max; /* ppt (3.2); 0 gives fresh ice */
    double salinity_a;   /* 0.407 */
    double salinity_b;   /* 0.573 */

    /* snow: conductive; enthalpy q_s(T) = -rho_s (L0 - c0 T) per m^3 at its
     * layer temperature T <= 0 (sph_snow_enthalpy). Without
     * snow_heat_capacity the snow stays at T = 0 (latent heat only). */
    double rho_s; /* kg/m^3 (330) */
    double k_s;   /* W/m/K (0.31) */
    int snow_heat_capacity; /* 1: the multi-layer column solves a snow layer with heat capacity
                               rho_s c0 (Bitz & Lipscomb 1999) once the snow is SPH_SNOW_LAYER_MIN deep */
    double rho_w; /* sea water, kg/m^3 (1026; the model sets momentum.rho_water): freeboard */
    int snow_ice; /* 1: snow pushed below the waterline floods and becomes ice (sph_column_snow_ice) */
    /* Rain/snow split of precipitation by the 2 m air temperature
     * (sph_snow_fraction): all snow at or below snow_t_snow, all rain at or
     * above snow_t_rain, linear in between (CLM 4.0: 0 and 2 deg C). */
    double snow_t_snow; /* deg C (0) */
    double snow_t_rain; /* deg C (2) */

    /* ocean */
    double ocean_salinity; /* psu (32): freezing point Tf = -mu * ocean_salinity */
    double fw_default;     /* W/m^2 (2): used when a particle's fw is NaN or 0 */

    /* radiation */
    double emissivity;       /* ice and snow (0.98): emits emissivity * sigma Ts^4 */
    double lw_absorptivity;  /* ice and snow (0.98, Kirchhoff); MU71 absorbed all LW down (1.0) */
    double emissivity_water; /* open water (0.97) */
    double albedo_snow;      /* dry snow (0.80) */
    double albedo_snow_melt; /* melting snow (0.70) */
    double albedo_ice;       /* cold bare ice, thick (0.65) */
    double albedo_ice_melt;  /* melting bare ice (0.55) */
    double albedo_water;     /* open water (0.06) */
    double albedo_thin_scale;/* m (0.3): bare-ice albedo ramps to open water below it (CICE ahmax) */
    double sw_pen_frac;      /* tau_i = i0: fraction of absorbed SW that penetrates bare ice (0.17) */
    double sw_extinction;    /* gamma_i: 1/m (1.5) */

    /* turbulent fluxes (bulk formulae) */
    double rho_a;        /* kg/m^3 (1.3) */
    double cp_a;         /* J/kg/K (1005) */
    double ch;           /* sensible-heat transfer coefficient (1.3e-3) */
    double ce;           /* latent-heat transfer coefficient (1.3e-3) */
    double air_pressure; /* Pa (101325), for saturation humidity */
    double Lv_ice;       /* J/kg (2.834e6): sublimation, over ice/snow */
    double Lv_water;     /* J/kg (2.501e6): evaporation, over open water */
    double wind_min;     /* m/s (0.5): floor of the wind speed in the bulk formulae */

    /* open water and melt-out */
    double new_ice_thickness;    /* m (0.05): h0 of Hibler's new ice in leads */
    double sst_freeze_tolerance; /* K (0.05): leads form ice only if SST <= Tf + this */
    double min_thickness;        /* m (1e-3): thinner ice melts out completely */
    double min_conc;             /* (1e-3): lower concentration melts out completely */

    /* numerics */
    double tsurf_tolerance; /* K (1e-10): Brent bracket width for the surface temperature */
    int tsurf_max_iter;     /* (100) */
    double picard_tolerance;/* K (1e-9): nonlinear (c, K) iteration of the multi-layer column */
    int picard_max_iter;    /* (50) */

    /* 1: every step adds each particle's fluxes into the ocean to its ofx_*
     * accumulators (core/particles.h; the model step adds the ice-ocean
     * stress). Set by the driver (output.ocean_fluxes), not a model key;
     * 0 (default) leaves them untouched. Reads the state only: the
     * trajectory is the same either way. docs/ocean-coupling.md. */
    int ocean_fluxes;
} sph_thermo_params;

void sph_thermo_params_default(sph_thermo_params *p);

/* SPH_STEP_OK, or SPH_STEP_FATAL with *name, *lo, *hi set to the first bad
 * parameter and its allowed range (any pointer may be NULL). */
int sph_thermo_params_check(const sph_thermo_params *p, const char **name, double *lo, double *hi);

/* Workspace for sph_thermo_step, allocated once (no allocation in a step).
 * Holds per-particle contributions (summed serially in index order, so the
 * result does not depend on the thread count) and one GSL root solver per
 * thread. `cap` must be >= the particle capacity. */
typedef struct sph_thermo_work sph_thermo_work;
sph_thermo_work *sph_thermo_work_create(size_t cap, int nlayers);
void sph_thermo_work_free(sph_thermo_work *w);
/* Particle k's budget terms of the last sph_thermo_step, kg: growth,
 * new_ice, melt_top, melt_bottom, lateral_melt, snow_ice, snowfall,
 * snow_melt, snow_to_ocean (core/dd.h's source order). */
void sph_thermo_outcome_terms(const sph_thermo_work *w, size_t k, double t[9]);

/* Sets a fresh particle's column (tsurf, enthalpy) consistent with its
 * thickness and the air temperature tair (deg C): the steady linear
 * profile between min(tair, 0) at the surface and Tf at the base. */
void sph_thermo_init_particle(const sph_thermo_params *p, sph_particles *P, size_t k, double tair);

/* One thermodynamic step of length dt on every live particle. Changes
 * thick, conc, mass (and snow, tsurf, enth, regime); adds growth/melt/new
 * ice to the budget (deterministically: no atomics, fixed summation order).
 * A particle that melts completely gets mass = 0 and thick = 0; the model
 * removes it. Returns SPH_STEP_OK or SPH_STEP_FATAL (status names the
 * first offending particle and quantity, e.g. "air_temperature"). */
int sph_thermo_step(const sph_thermo_params *p, sph_particles *P, double dt,
                    sph_thermo_work *w, sph_budget *b, sph_status *st);

/* Snow mass of particle k, kg: rho_s h_s over its ice area
 * mass / (rho_i h). 0 for a melted or snow-free particle. */
double sph_particle_snow_mass(const sph_thermo_params *p, const sph_particles *P, size_t k);
/* After sph_thermo_step: the atmospheric energy (J) particle k took in the
 * step, into its column over the ice part (the column's fatm) and into its
 * leads (sph_open_water_flux x (1 - A)); 0 for a particle it skipped. */
double sph_thermo_energy_atm(const sph_thermo_work *w, size_t k);

/* ------------------------------------------------------------------ */
/* Column-level API (tests, benchmarks, and the particle step itself).  */

/* Bitz & Lipscomb (1999) material functions. S ppt, T deg C, z = depth/h. */
double sph_bl_salinity(const sph_thermo_params *p, double z);
double sph_bl_melting_temperature(const sph_thermo_params *p, double S);
double sph_bl_heat_capacity(const sph_thermo_params *p, double S, double T);  /* J/kg/K */
double sph_bl_conductivity(const sph_thermo_params *p, double S, double T);   /* W/m/K, at least 0.10 */
/* q(S,T) = -rho_i [c0 (Tm - T) + L0 (1 - Tm / T)], J/m^3 (T <= Tm < 0; S = 0: -rho_i (L0 - c0 T)) */
double sph_bl_enthalpy(const sph_thermo_params *p, double S, double T);
/* Inverse of sph_bl_enthalpy in T (T <= Tm). */
double sph_bl_temperature(const sph_thermo_params *p, double S, double q);
/* Freezing point of sea water, -mu * ocean_salinity. */
double sph_freezing_point(const sph_thermo_params *p);

typedef struct sph_column {
    double thick;    /* ice thickness, m */
    double snow;     /* snow depth, m */
    double tsurf;    /* surface temperature (snow or ice top), deg C */
    int nlayers;     /* layers of enth (multi-layer; the zero-layer keeps its linear profile there) */
    double enth[SPH_MAX_LAYERS]; /* layer enthalpy, J/m^3, top first */
    double tsnow;    /* snow layer temperature, deg C (<= 0; 0 unless snow_heat_capacity) */
} sph_column;

/* Snow thinner than this is a conductance only (its temperature and
 * enthalpy are kept, not solved), m; Bitz & Lipscomb's column: 1 cm. */
#define SPH_SNOW_LAYER_MIN 0.01

/* Snow enthalpy per volume at temperature T (capped at 0), J/m^3:
 * -rho_s (L0 - c0 T); -rho_s L0 at 0 deg C. */
double sph_snow_enthalpy(const sph_thermo_params *p, double T);

typedef struct sph_column_forcing {
    double tair;     /* 2 m air temperature, deg C */
    double qair;     /* 2 m specific humidity, kg/kg */
    double wind;     /* 10 m wind speed, m/s */
    double swdn;     /* downwelling shortwave, W/m^2 */
    double lwdn;     /* downwelling longwave, W/m^2 */
    double fsens;    /* prescribed sensible flux into the surface, W/m^2; NaN: bulk formula */
    double flat;     /* prescribed latent flux into the surface, W/m^2; NaN: bulk formula */
    double albedo;   /* prescribed surface albedo; NaN: by surface state */
    double sst;      /* sea surface temperature (open water), deg C; NaN: freezing point */
    double fw;       /* ocean heat flux into the ice base, W/m^2; NaN: p->fw_default */
    double tsurf_prescribed; /* deg C; NaN: solve the surface energy balance */
    double snowfall; /* snow depth accumulation rate, m/s (0); added at the start of a step,
                        bringing its enthalpy -rho_s L0 per m^3 into the column */
} sph_column_forcing;

/* Everything NaN except zeros for wind, radiation, humidity and snowfall. */
void sph_column_forcing_default(sph_column_forcing *f);

typedef struct sph_column_result {
    double growth;      /* m of ice formed at the base */
    double melt_top;    /* m of ice melted at the surface */
    double melt_bottom; /* m of ice melted at the base */
    double snow_melt;   /* m of snow melted */
    double albedo;      /* surface albedo used */
    double fatm;        /* net atmospheric flux absorbed by the column at the final Ts (incl. penetrating SW) */
    double fmelt;       /* part of fatm that melted the surface */
    double fcond_top;   /* conductive flux at the surface, downward */
    double fcond_bottom;/* conductive flux at the base, downward (negative when the ice grows) */
    double focean;      /* ocean heat flux used */
    double snow_to_ice; /* m of snow flooded and turned into ice (sph_column_snow_ice) */
    double snow_ice;    /* m of ice formed from it (rho_i snow_ice = rho_s snow_to_ice) */
    double energy_to_ocean; /* J/m^2 leaving the column when it melts out (snow or ice remnants, excess melt energy) */
    double sw_base;     /* W/m^2 of shortwave reaching the base (absorbed there by the column) */
    int melted_out;     /* 1 when no ice is left */
    int iterations;     /* Picard iterations (multi-layer) */
} sph_column_result;

/* Fraction of precipitation that falls as snow at air temperature tair
 * (deg C): 1 at or below p->snow_t_snow, 0 at or above p->snow_t_rain,
 * linear in between; NaN tair gives 0. */
double sph_snow_fraction(const sph_thermo_params *p, double tair);

/* Snow-ice formation (flooding). Archimedes: the ice floats with draft
 * (rho_i h + rho_s hs) / rho_w; the freeboard h - draft is negative when
 * rho_s hs > (rho_w - rho_i) h. Sea water then floods the snow base and
 * the flooded snow becomes ice. Mass conserved (the snow's mass becomes
 * ice, rho_i dh = rho_s ds; the sea water filling the pores is not added,
 * as in CICE/Icepack with ktherm = 1) and the freeboard brought exactly to
 * zero: rho_s (hs - ds) = (rho_w - rho_i)(h + dh) gives
 *   dh = (rho_s hs - (rho_w - rho_i) h) / rho_w,   ds = rho_i dh / rho_s.
 * (CICE's freeboard routine converts the excess snow
 * hs - (rho_w - rho_i) h / rho_s, more by rho_w / rho_i, leaving a small
 * positive freeboard.) Energy conserved: the new top ice takes the snow's
 * enthalpy, -rho_s L0 ds = q dh, i.e. q = -rho_i L0 (multi-layer: a top
 * segment remapped onto the layers). Adds to r->snow_to_ice and
 * r->snow_ice; returns 1 when snow was converted. */
int sph_column_snow_ice(const sph_thermo_params *p, sph_column *c, sph_column_result *r);

/* Opaque surface-temperature solver (wraps a gsl_root_fsolver, Brent). */
typedef struct sph_column_solver sph_column_solver;
sph_column_solver *sph_column_solver_create(void);
void sph_column_solver_free(sph_column_solver *s);

/* Steady linear profile from tsurf (snow/ice top) to Tf at the base. */
void sph_column_init(const sph_thermo_params *p, sph_column *c, double thick, double snow, double tsurf);
/* Energy of the column, J/m^2: sum q_k h/N + snow (-rho_s L0 snow). */
double sph_column_energy(const sph_thermo_params *p, const sph_column *c);
/* Surface albedo for a state (snow depth, thickness, last Ts) unless f->albedo is finite. */
double sph_surface_albedo(const sph_thermo_params *p, const sph_column_forcing *f, double thick, double snow, double tsurf);
/* Net atmospheric flux into a surface at Ts, W/m^2: (1 - albedo) sw_fraction SW
 * + absorptivity LW - emissivity sigma Ts^4 + sensible + latent (prescribed or bulk). */
double sph_surface_flux(const sph_thermo_params *p, const sph_column_forcing *f, double albedo,
                        double sw_fraction, double absorptivity, double emissivity, double Lv,
                        int over_water, double Ts);
/* Net heat flux into open water at max(sst, Tf), W/m^2 (negative: heat loss). */
double sph_open_water_flux(const sph_thermo_params *p, const sph_column_forcing *f);

/* One step of each column model. Return SPH_STEP_OK, or
 * SPH_STEP_RECOVERABLE when the surface balance had no root in range. */
int sph_column_step_zero_layer(const sph_thermo_params *p, sph_column *c, const sph_column_forcing *f,
                               double dt, sph_column_solver *s, sph_column_result *r);
int sph_column_step_multi_layer(const sph_thermo_params *p, sph_column *c, const sph_column_forcing *f,
                                double dt, sph_column_solver *s, sph_column_result *r);

/* Thomas algorithm, no allocation: solves sub[i] x[i-1] + diag[i] x[i] +
 * sup[i] x[i+1] = rhs[i], i = 0..n-1 (sub[0], sup[n-1] unused). n <= SPH_MAX_LAYERS. */
int sph_tridiag_solve(int n, const double *sub, const double *diag, const double *sup,
                      const double *rhs, double *x);

#endif
