/* How core routines report: 0 fine, positive recoverable (retry with a
 * smaller step or simpler physics), negative fatal (SUNDIALS convention).
 * The core does no I/O: it fills sph_status and the driver writes the
 * sentence. `kind` says what went wrong, for callers to decide on;
 * `quantity` and `what` (prose, for the sentence only) point at static
 * strings. */
#ifndef SPHICE_CORE_STATUS_H
#define SPHICE_CORE_STATUS_H

#include <math.h>

enum {
    SPH_STEP_OK = 0,
    SPH_STEP_RECOVERABLE = 1, /* e.g. stability limit exceeded: sub-step or refuse */
    SPH_STEP_FATAL = -1       /* NaN/Inf, speed limit, mass not conserved, bad parameter */
};

/* What a status reports. The sentence puts `limit` after `what` for the
 * bounds a value crossed (speed, thickness, explicit limit), as
 * "(limit L)" for ranges (the stable step, forcing and parameter ranges),
 * and not at all for the rest. */
typedef enum {
    SPH_FAULT_NONE = 0,
    SPH_FAULT_NONFINITE,  /* a state, forcing or solver value is NaN or infinite */
    SPH_FAULT_SPEED,      /* speed above params.speed_limit (blow-up) */
    SPH_FAULT_THICKNESS,  /* mean thickness above params.thickness_limit (pile-up) */
    SPH_FAULT_MASS,       /* total mass changed with no source or sink to explain it */
    SPH_FAULT_CLUMPING,   /* a neighbour list overflowed max_neighbours */
    SPH_FAULT_TIMESTEP,   /* params.dt outside the measured stable region: refused */
    SPH_FAULT_SUBSTEPS,   /* params.dt beyond the explicit solver's limit, not sub-stepped */
    SPH_FAULT_SOLVER,     /* a solver failed (sparse assembly, GMRES, conduction column) */
    SPH_FAULT_INVALID,    /* an input value breaks a rule (must be positive, in (0, 1], valid) */
    SPH_FAULT_RANGE,      /* a forcing value outside its physical range (limit: the bound) */
    SPH_FAULT_PARAMETER,  /* a parameter outside its allowed range (value lo, limit hi) */
    SPH_FAULT_CAPACITY    /* more particles than a model or workspace holds */
} sph_fault;

typedef struct sph_status {
    int code;             /* SPH_STEP_* */
    sph_fault kind;       /* SPH_FAULT_*: what went wrong */
    long step;            /* dynamic step index where it happened, -1 if none */
    long particle;        /* particle index (id if known), -1 if none */
    const char *quantity; /* e.g. "velocity", "mass", "thickness" */
    double value;         /* offending value */
    double limit;         /* allowed bound, if any */
    const char *what;     /* static sentence: "is not finite", "exceeds the speed limit" */
} sph_status;

static inline void sph_status_clear(sph_status *s)
{
    s->code = SPH_STEP_OK;
    s->kind = SPH_FAULT_NONE;
    s->step = -1;
    s->particle = -1;
    s->quantity = "";
    s->value = 0.0;
    s->limit = 0.0;
    s->what = "";
}

static inline int sph_status_set(sph_status *s, int code, sph_fault kind, long particle,
                                 const char *quantity, double value, double limit,
                                 const char *what)
{
    if (s && s->code == SPH_STEP_OK) {
        s->code = code;
        s->kind = kind;
        s->particle = particle;
        s->quantity = quantity;
        s->value = value;
        s->limit = limit;
        s->what = what;
    }
    return code;
}

/* Run budget, kg unless stated. Closes as
 *   mass_initial + growth + new_ice + snow_ice - melt_top - melt_bottom
 *   - lateral_melt - outflow = mass  (to round-off).
 * `mass` is ice only (particle mass = rho_i A h area); snow has its own
 * budget (snow mass rho_s h_s A area per particle):
 *   snow_initial + snowfall - snow_melt - snow_ice - snow_to_ocean = snow.
 * snow_ice is the mass of snow flooded into ice: it leaves the snow
 * budget and enters the ice budget unchanged. */
typedef struct sph_budget {
    double mass_initial;
    double mass;
    double growth;       /* basal congelation growth of existing ice */
    double new_ice;      /* frazil / new ice formed in open water */
    double melt_top;     /* surface melt */
    double melt_bottom;  /* basal melt */
    double lateral_melt; /* lateral melt (concentration loss) */
    double outflow;      /* removed at open boundaries */
    long removed_particles;
    /* the ocean mixed layer (issue 20; zero when it is off). Energy J,
     * water and salt kg; ice (particles and pending frazil) plus ocean:
     *   energy = energy_initial + energy_surface + energy_restoring - energy_outflow
     *   water  = water_initial - water_outflow
     *   salt   = salt_initial + salt_restoring - salt_outflow            */
    int ocean;             /* 1: the budgets below are kept */
    double energy_initial, energy, energy_surface, energy_restoring, energy_outflow;
    double water_initial, water, water_outflow;
    double salt_initial, salt, salt_restoring, salt_outflow;
    long created_particles, merged_particles;
    /* diagnostics, recomputed each step */
    double area;           /* ice-covered area sum m/(rho_i h_i), m^2 */
    double volume;         /* ice volume sum m/rho_i, m^3 */
    double kinetic_energy; /* sum m |V|^2 / 2, J */
    /* snow (issue 20 item 3) */
    double snow_ice;      /* snow flooded into ice (a source of ice mass) */
    double snow_initial;
    double snow;          /* snow mass now, sum rho_s h_s A area (diagnostic) */
    double snowfall;      /* fallen on the ice part of the footprints */
    double snow_melt;     /* surface melt of snow */
    double snow_to_ocean; /* left with melted-out ice, lateral melt and open boundaries */
} sph_budget;

/* The mass the budget's sources and sinks explain, kg: what `mass` must
 * equal to round-off. */
static inline double sph_budget_expected(const sph_budget *b)
{
    return b->mass_initial + b->growth + b->new_ice + b->snow_ice - b->melt_top - b->melt_bottom -
           b->lateral_melt - b->outflow;
}

/* The snow mass the snow budget explains, kg. */
static inline double sph_budget_snow_expected(const sph_budget *b)
{
    return b->snow_initial + b->snowfall - b->snow_melt - b->snow_ice - b->snow_to_ocean;
}

/* |snow - expected| / max(snow_initial + snowfall, tiny); 0 with no snow at all. */
static inline double sph_budget_snow_residual(const sph_budget *b)
{
    double scale = b->snow_initial + b->snowfall;
    return scale > 0 ? fabs(sph_budget_snow_expected(b) - b->snow) / scale : 0.0;
}

/* |mass - expected| / mass_initial (0 for an empty start). */
static inline double sph_budget_residual(const sph_budget *b)
{
    return b->mass_initial > 0 ? fabs(sph_budget_expected(b) - b->mass) / b->mass_initial : 0.0;
}

/* The relative residuals of the ocean's budgets: |x - expected| / scale,
 * the scale the largest magnitude among the terms (0 when it is off). */
static inline double sph_budget_energy_residual(const sph_budget *b)
{
    if (!b->ocean)
        return 0.0;
    double e = b->energy_initial + b->energy_surface + b->energy_restoring - b->energy_outflow;
    double s = fmax(fmax(fabs(b->energy_initial), fabs(b->energy)),
                    fmax(fabs(b->energy_surface), fabs(b->energy_restoring)));
    return s > 0 ? fabs(b->energy - e) / s : 0.0;
}
static inline double sph_budget_water_residual(const sph_budget *b)
{
    if (!b->ocean)
        return 0.0;
    double s = fmax(fabs(b->water_initial), fabs(b->water));
    return s > 0 ? fabs(b->water - (b->water_initial - b->water_outflow)) / s : 0.0;
}
static inline double sph_budget_salt_residual(const sph_budget *b)
{
    if (!b->ocean)
        return 0.0;
    double s = fmax(fmax(fabs(b->salt_initial), fabs(b->salt)), fabs(b->salt_restoring));
    return s > 0 ? fabs(b->salt - (b->salt_initial + b->salt_restoring - b->salt_outflow)) / s : 0.0;
}

#endif
