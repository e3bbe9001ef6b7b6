/* The parameter table (core/params.h): one row per model parameter, and
 * everything generated from it in the core: defaults, range checks, lookup
 * by key. The automatic time step's rules are here too.
 *
 * Bounds are the one set every caller sees: the configuration's `model.*`
 * keys take them as they are (src/service/config.c; the service overrides
 * only model.dt's default and range, for its automatic step). */
#include "core/params.h"

#include <math.h>
#include <string.h>

#include "core/model.h"
#include "core/registry.h"

_Static_assert(sizeof(sph_kernel_kind) == sizeof(int), "enums are stored as int");
_Static_assert(sizeof(sph_solver_kind) == sizeof(int), "enums are stored as int");
_Static_assert(sizeof(sph_unstable_policy) == sizeof(int), "enums are stored as int");
_Static_assert(sizeof(sph_physics_mode) == sizeof(int), "enums are stored as int");
_Static_assert(sizeof(sph_rheology_kind) == sizeof(int), "enums are stored as int");
_Static_assert(sizeof(sph_pressure_form) == sizeof(int), "enums are stored as int");
_Static_assert(sizeof(sph_thermo_model) == sizeof(int), "enums are stored as int");
_Static_assert(sizeof(sph_freezing_kind) == sizeof(int), "enums are stored as int");

/* index = enum value */
static const char *const kernel_names[] = {"gaussian", "wendland_c2", "cubic_spline", NULL};
static const char *const solver_names[] = {SPH_SOLVERS(SPH_REGISTRY_NAME) NULL};
static const char *const unstable_names[] = {"substep", "refuse", NULL};
static const char *const physics_names[] = {"auto", "full", "free_drift", NULL};
static const char *const rheology_names[] = {SPH_RHEOLOGIES(SPH_REGISTRY_NAME) NULL};
static const char *const pressure_names[] = {"seed", "hibler", NULL};
static const char *const thermo_names[] = {"off", "zero_layer", "multi_layer", "auto", NULL};
static const char *const freezing_names[] = {"linear", "unesco", NULL};
static const char *const drag_names[] = {"none", "concentration", NULL};
static const char *const compact_names[] = {"false", "true", "auto", NULL}; /* SPH_COMPACT_* */

/* One row each, by type (as Redis's createBoolConfig ...): key, member,
 * default, bounds, units, description. Every row is reloadable (a reloaded
 * configuration builds the next run's model). */
#define ROW(key, type, member, def, lo, hi, names, units, doc) \
    {key, SPH_PARAM_##type, offsetof(sph_params, member), (double)(def), #def, lo, hi, SPH_PARAM_RELOAD, \
     names, units, doc}
#define DBL(key, member, def, lo, hi, units, doc) ROW(key, DOUBLE, member, def, lo, hi, NULL, units, doc)
#define INT(key, member, def, lo, hi, units, doc) ROW(key, INT, member, def, lo, hi, NULL, units, doc)
#define BOOL(key, member, def, doc) ROW(key, BOOL, member, def, 0, 1, NULL, "", doc)
#define ENUM(key, member, names, def, doc) \
    ROW(key, ENUM, member, def, 0, (double)(sizeof names / sizeof names[0]) - 2.0, names, "", doc)

/* In the configuration's order. Bools are 0/1, enums their enumerator; the
 * units "1" is dimensionless. dt's default is the seed's 60 s (the
 * configuration's default is the automatic step, 0). */
static const sph_param rows[] = {
    DBL("dt", dt, 60, 1e-6, 86400, "s", "Dynamic time step, s; 0 = auto: the largest step within 0.6 of the measured stability envelope (half with replacement pressure; and f dt <= 0.1) that divides the thermodynamic step and the output interval (docs/dynamics.md). A number is used as given (refused if outside the envelope)."),
    ENUM("kernel", kernel, kernel_names, SPH_KERNEL_GAUSSIAN, "SPH kernel: gaussian (seed), wendland_c2, cubic_spline."),
    DBL("kernel_radius", kernel_radius, 3, 1, 5, "h", "Gaussian kernel truncation radius in units of h (the seed's 4h box is 2); compact kernels use 2."),
    BOOL("summation_density", summation_density, 0, "Mass per area by SPH summation every step (seed); false: evolved by continuity from the seeded field (default, stable)."),
    INT("density_reinit_steps", density_reinit_steps, 0, 0, 100000, "steps", "With continuity density (summation_density false): every N dynamic steps mass per area is re-initialised by the SPH summation (Colagrossi & Landrini 2003; needed with new_ice.create: docs/ocean.md); 0: never (continuity throughout)."),
    INT("max_neighbours", max_neighbours, 96, 8, 4096, "1", "Neighbour list capacity per particle; exceeding it is reported as particle clumping."),
    DBL("sml_min_factor", sml_min_factor, 0.5, 0.1, 1, "h0", "Variable smoothing length kept above this times h0."),
    DBL("sml_max_factor", sml_max_factor, 2, 1, 10, "h0", "Variable smoothing length kept below this times h0."),
    BOOL("coast_no_slip", coast_no_slip, 0, "Coasts: no-slip (mirror ghosts reverse velocity) instead of free slip."),
    BOOL("variable_sml", variable_sml, 1, "Variable smoothing length (seed eq. 10)."),
    BOOL("gradient_correction", gradient_correction, 0, "Kernel gradient correction (Bonet & Lok 1999) in the strain rates and the stress divergence: linear fields exact where the smoothing length varies; R300's ridged zone +0.47 % instead of +2.7 %; off by default: in the re-run speed-accuracy matrix it costs 5.7 % more CPU on the demo and makes its three errors worse (docs/bench.md, Defaults by the Pareto front)."),
    DBL("sml_factor", sml_factor, 1, 0.5, 3, "spacing", "Initial smoothing length h0 = sml_factor x initial particle spacing."),
    ENUM("solver", solver, solver_names, SPH_SOLVER_MEVP, "Momentum solver: explicit (sub-stepped), mevp (modified/adaptive EVP), implicit (Picard + GMRES), jfnk (Jacobian-free Newton-Krylov; its workspace holds the Picard matrix's block pattern and ILU, 4 x max_neighbours blocks a row: about 29 kB per particle at the default max_neighbours, so scenes up to about 1e5 particles; docs/dynamics.md)."),
    ENUM("unstable", unstable, unstable_names, SPH_UNSTABLE_SUBSTEP, "Explicit solver beyond its stability limit: substep, or refuse (fail)."),
    INT("max_substeps", max_substeps, 20000, 1, 10000000, "1", "Cap on explicit sub-steps per dynamic step; beyond it the step is refused."),
    DBL("explicit_safety", explicit_safety, 1, 0.001, 10, "1", "Explicit solver limit dt < safety x M h^2 / (zeta_max (1 + e^-2))."),
    INT("evp.iterations", evp_iterations, 120, 1, 10000, "1", "mEVP sub-iterations per step."),
    BOOL("evp.adaptive", evp_adaptive, 1, "Adaptive EVP: local alpha = beta from the stability bound."),
    DBL("evp.alpha", evp_alpha, 300, 1, 1e6, "1", "Fixed mEVP alpha."),
    DBL("evp.beta", evp_beta, 300, 1, 1e6, "1", "Fixed mEVP beta."),
    DBL("evp.tol", evp_tol, 1e-7, 0, 1, "m/s", "mEVP: stop iterating when no particle's velocity changes by more than this, m/s."),
    DBL("evp.rel_tol", evp_rel_tol, 0, 0, 1, "1", "mEVP: stop iterating when the relative momentum residual (RMS of beta times the velocity change over RMS speed of the active particles) is below this; 0: off (evp.tol, evp.iterations and the stall window only). With it on, a step that ends above it counts as unconverged in the run's statistics, status and products (docs/dynamics.md)."),
    DBL("evp.change_tol", evp_change_tol, 0, 0, 1, "1", "mEVP: stop iterating when an iteration changes the velocities by less than this relative to the RMS speed (floor 1e-4 m/s) and the stresses by less than this relative to the RMS strength (RMS over the active particles); 0: off (the default: the mEVP error is about alpha times the last change, so a tolerance that saves iterations stops R300 before it settles; docs/dynamics.md)."),
    INT("evp.anderson", evp_anderson, 0, 0, 16, "1", "mEVP: Anderson acceleration of the iteration's fixed point (velocities and stresses), mixing the last this many iterates; fixed when the solver is created; 0: off (the default: measured no faster, and slower with the default Delta_min; docs/dynamics.md)."),
    INT("evp.stall_window", evp_stall_window, 40, 0, 100000, "1", "auto physics: stop the mEVP iteration when its RMS velocity change has reached no new minimum in this many iterations (a limit cycle; 0: off)."),
    INT("implicit.max_picard", implicit_max_picard, 30, 1, 1000, "1", "Implicit solver: Picard iterations."),
    DBL("implicit.tol", implicit_tol, 1e-6, 1e-14, 1, "1", "Implicit solver: relative residual."),
    DBL("jfnk.tol", jfnk_tol, 1e-6, 1e-14, 1, "m/s", "JFNK solver: stop the Newton iteration when the RMS of the preconditioned momentum residual of the active particles (the Picard matrix's ILU applied to the time-discrete momentum equation's residual: an estimate of the velocity error, m/s) is below this (docs/dynamics.md)."),
    INT("jfnk.max_newton", jfnk_max_newton, 40, 1, 1000, "1", "JFNK solver: Newton iterations per step; a step that has not reached jfnk.tol by then fails as recoverable, naming its residual."),
    ENUM("physics", physics, physics_names, SPH_PHYSICS_AUTO, "auto (free drift where loose, rheology where packed), full, free_drift."),
    DBL("auto_tolerance", auto_tolerance, 1e-2, 0, 1, "1", "auto physics: free drift where exp(-C(1-A)) is below this."),
    ENUM("compact_gradients", compact_gradients, compact_names, SPH_COMPACT_AUTO, "The neighbour lists keep each pair's kernel gradient as its scalar factor F (grad W = F (x_k - x_j)) beside the build's positions (true) instead of its two components (false): the same results bit for bit, 8 bytes per pair less (about 97 MB at 1e6 particles), for 12-20 % more CPU in the strain-rate and stress-divergence passes (two products and a gathered position per pair). auto: true from 500000 particles (memory-bound runs: the 1e6 packed-ice run under 1 GB), false below (the demo's CPU unchanged); docs/bench.md, Sessions 9 and 11: memory at 1e6."),
    BOOL("free_drift_parcels", free_drift_parcels, 0, "physics free_drift: particles drift as independent parcels (no neighbour search, mirror ghosts, density, strain rates or continuity; mass per area changes only by thermodynamics): several times faster, and identical to the SPH path wherever particles lie farther apart than the kernel support (docs/engine.md). Off: free drift still evolves each parcel's mass per area by the SPH divergence of the drift."),
    ENUM("rheology.kind", rheology, rheology_names, SPH_RHEOLOGY_VP, "Rheology: vp (Hibler viscous-plastic) or collision (Shen, Hibler & Lepparanta 1987)."),
    ENUM("rheology.pressure_form", pressure_form, pressure_names, SPH_PRESSURE_SEED, "seed: P = P0 exp(-C(1-A)) integrated as hbar P; hibler: P = P* hbar exp(-C(1-A))."),
    DBL("rheology.P0", P0, 1.0e4, 1, 1e7, "N/m^2", "Ice strength P0 (seed) or P* (hibler), N/m^2."),
    DBL("rheology.C", C, 20, 0, 100, "1", "Concentration parameter C."),
    DBL("rheology.e", ecc, 2, 1, 10, "1", "Yield ellipse ratio e."),
    DBL("rheology.zeta_max_factor", zeta_max_factor, 2.5e8, 1, 1e12, "s", "zeta_max = factor x P, s."),
    DBL("rheology.delta_min", delta_min, 2e-9, 1e-15, 1e-3, "1/s", "Minimum Delta, 1/s."),
    BOOL("rheology.replacement_pressure", replacement_pressure, 0, "Hibler/Kreyscher replacement pressure (resting stress 0 instead of -P/2)."),
    DBL("rheology.collision.restitution", coll_restitution, 0.5, 0, 1, "1", "Collision rheology: restitution coefficient e_r."),
    DBL("rheology.collision.floe_diameter", coll_floe_diameter, 100, 0.1, 1e5, "m", "Collision rheology: floe diameter D, m."),
    DBL("rheology.collision.max_concentration", coll_max_conc, 0.91, 0.1, 1, "1", "Collision rheology: maximum packing concentration C0."),
    DBL("rheology.collision.vfluct_min", coll_vfluct_min, 1e-3, 0, 10, "m/s", "Collision rheology: floor of the fluctuating velocity v' (kernel-weighted RMS deviation of neighbours), m/s."),
    DBL("momentum.rho_ice", rho_i, 900, 800, 1000, "kg/m^3", "Ice density, kg/m^3."),
    DBL("momentum.rho_air", rho_a, 1.3, 0.5, 2, "kg/m^3", "Air density, kg/m^3."),
    DBL("momentum.rho_water", rho_w, 1026, 990, 1050, "kg/m^3", "Sea water density, kg/m^3."),
    DBL("momentum.Ca", Ca, 1.2e-3, 0, 0.1, "1", "Air drag coefficient."),
    DBL("momentum.Cw", Cw, 5.5e-3, 0, 0.1, "1", "Water drag coefficient."),
    DBL("momentum.turn_air", turn_air, 0, -90, 90, "degree", "Air turning angle, degrees (+ to the right in the NH)."),
    DBL("momentum.turn_water", turn_water, 0, -90, 90, "degree", "Water turning angle, degrees (25 typical in the Arctic)."),
    DBL("momentum.gravity", gravity, 9.81, 9, 10, "m/s^2", "Gravity, m/s^2."),
    BOOL("momentum.coriolis", coriolis, 1, "Coriolis force (off only for channel tests)."),
    ENUM("momentum.drag_scaling", drag_scaling, drag_names, SPH_DRAG_NONE, "Comparison option: none (Hibler 1979: air and water stress on the whole parcel; the default) or concentration (CICE: both stresses times the concentration A), for like-for-like comparison with CICE (docs/dynamics.md)."),
    DBL("momentum.coriolis_f", coriolis_f, 0, -2e-4, 2e-4, "s-1", "Comparison option: a constant Coriolis parameter f, s-1 (CICE's box2001 uses 1.46e-4); 0: 2 Omega sin(latitude) per particle (docs/dynamics.md)."),
    BOOL("fixed_state", fixed_state, 0, "Comparison option: solve the momentum on a fixed ice state (positions, concentration, thickness and mass per area never change; no thermodynamics), as CICE's box2001 does (docs/dynamics.md)."),
    DBL("health.speed_limit", speed_limit, 10, 0.01, 1000, "m/s", "Ice speed above which the run is declared blown up, m/s."),
    DBL("health.thickness_limit", thickness_limit, 30, 0.1, 1000, "m", "Mean ice thickness (ice volume per area) of a parcel above which the run is declared blown up (a numerical pile-up), m."),
    DBL("health.mass_tolerance", mass_tolerance, 1e-10, 0, 1, "1", "Relative mass change per step no source explains before the run fails."),
    DBL("thermo.dt", thermo_dt, 600, 0, 86400, "s", "Thermodynamic step, s; 0 turns thermodynamics off."),
    ENUM("thermo.model", thermo.model, thermo_names, SPH_THERMO_AUTO, "off, zero_layer (Semtner 1976), multi_layer (Bitz & Lipscomb 1999), auto (by thickness)."),
    INT("thermo.nlayers", thermo.nlayers, 7, 1, SPH_MAX_LAYERS, "1", "Multi-layer column layers."),
    DBL("thermo.auto_thickness", thermo.auto_thickness, 0.3, 0, 10, "m", "auto: zero-layer below this thickness, multi-layer above, m."),
    DBL("thermo.rho_ice", thermo.rho_i, 900, 800, 1000, "kg/m^3", "Ice density in the thermodynamics, kg/m^3."),
    DBL("thermo.rho_snow", thermo.rho_s, 330, 50, 700, "kg/m^3", "Snow density, kg/m^3: snowfall (water equivalent) becomes depth flux / rho_snow; freeboard (Maykut & Untersteiner 1971: 330)."),
    DBL("thermo.k_snow", thermo.k_s, 0.31, 0.01, 2, "W/m/K", "Snow thermal conductivity, W/m/K (Maykut & Untersteiner 1971: 0.31)."),
    BOOL("thermo.snow_heat_capacity", thermo.snow_heat_capacity, 0, "Snow heat capacity in the multi-layer column: snow at least 1 cm deep is a layer with enthalpy -rho_snow (L0 - c0 T) solved with the ice (Bitz & Lipscomb 1999); false: the snow holds latent heat only (at 0 C). The mixed layer's energy budget counts the snow with the same enthalpy (docs/thermo.md, docs/ocean.md)."),
    BOOL("thermo.snow_ice", thermo.snow_ice, 1, "Snow-ice formation: snow that pushes the freeboard below zero floods and becomes ice, mass and energy conserved (docs/thermo.md)."),
    DBL("thermo.snow_t_snow", thermo.snow_t_snow, 0, -20, 10, "degC", "Precipitation split by the 2 m air temperature: all snow at or below this, deg C (CLM 4.0: 0)."),
    DBL("thermo.snow_t_rain", thermo.snow_t_rain, 2, -20, 10, "degC", "All rain at or above this, deg C, linear in between (CLM 4.0: 2); must not be below thermo.snow_t_snow."),
    BOOL("ocean.mixed_layer", ocean.mixed_layer, 0, "Slab ocean mixed layer per cell of the ocean grid (temperature, salinity), heated and cooled by open water, ice and restoring (docs/ocean.md); false: the forcing's SST as before."),
    DBL("ocean.cell", ocean.cell, 0, 0, 1e6, "m", "Cell of the mixed layer's grid on the model plane, m; 0: four seeding lattice spacings (the grid covers the domain's plane box)."),
    DBL("ocean.depth", ocean.depth, 20, 0.1, 5000, "m", "Mixed-layer depth where no forcing field gives it, m (limited by the bathymetry)."),
    DBL("ocean.min_depth", ocean.min_depth, 1, 0.1, 100, "m", "Smallest mixed-layer depth of a sea cell (very shallow water), m."),
    ENUM("ocean.freezing_point", ocean.freezing, freezing_names, SPH_FREEZING_LINEAR, "Freezing point of the mixed layer from its salinity: linear (-thermo mu S, 0.054 K/psu) or unesco (Millero 1978, UNESCO 1983)."),
    DBL("ocean.restore_days", ocean.restore_days, 0, 0, 3650, "day", "Restoring time scale of the mixed layer to the forcing's SST and SSS, days; 0: no restoring."),
    DBL("ocean.heat_transfer", ocean.heat_transfer, 246, 0, 10000, "W/m^2/K", "Ice-ocean heat transfer rho_w c_w c_h u* (McPhee 1992: c_h 0.006, u* 0.01 m/s): heat flux into the ice base per kelvin of mixed layer above freezing."),
    BOOL("new_ice.create", ocean.create, 0, "New particles from frazil in open water with no particle (needs ocean.mixed_layer, and summation_density true or density_reinit_steps > 0: plain continuity is refused with it, docs/ocean.md)."),
    DBL("new_ice.thickness", ocean.new_thickness, 0.05, 0.001, 2, "m", "Frazil thickness over a cell's open water at which new particles are created there, m (Icepack hfrazilmin 0.05)."),
    BOOL("new_ice.merge", ocean.merge, 0, "Merge thin crowded particles (mass, momentum, enthalpy conserved) so the count stays bounded."),
    DBL("new_ice.merge_thickness", ocean.merge_thickness, 0.2, 0, 10, "m", "Merging: both particles thinner than this, m."),
    DBL("new_ice.merge_distance", ocean.merge_distance, 0.5, 0, 2, "1", "Merging: particles closer than this times the mean side of their footprints."),
    DBL("new_ice.merge_max_size", ocean.merge_max_size, 2, 1, 100, "1", "Merging: a merged particle may not be larger than this many seeding lattice spacings: its footprint at most merge_max_size^2 lattice cells and its smoothing length at most merge_max_size times a new particle's (sml_factor x spacing); a pair that would be is not merged (docs/ocean.md)."),
};
#undef ROW
#undef DBL
#undef INT
#undef BOOL
#undef ENUM

const sph_param *sph_param_table(size_t *n)
{
    if (n)
        *n = sizeof rows / sizeof rows[0];
    return rows;
}

const sph_param *sph_param_find(const char *key)
{
    for (size_t i = 0; key && i < sizeof rows / sizeof rows[0]; i++)
        if (!strcmp(rows[i].key, key))
            return &rows[i];
    return NULL;
}

double sph_param_get(const sph_param *r, const sph_params *p)
{
    const char *m = (const char *)p + r->offset;
    if (r->type == SPH_PARAM_DOUBLE)
        return *(const double *)(const void *)m;
    return *(const int *)(const void *)m;
}

int sph_param_set(const sph_param *r, sph_params *p, double v)
{
    if (!(v >= r->lo && v <= r->hi) || (r->type != SPH_PARAM_DOUBLE && v != floor(v)))
        return SPH_STEP_FATAL;
    char *m = (char *)p + r->offset;
    if (r->type == SPH_PARAM_DOUBLE)
        *(double *)(void *)m = v;
    else
        *(int *)(void *)m = (int)v;
    return SPH_STEP_OK;
}

/* Appends s to buf (truncating), returns the new length it would have. */
static size_t put(char *buf, size_t len, size_t at, const char *s)
{
    size_t n = strlen(s);
    if (at < len) {
        size_t room = len - at - 1, k = n < room ? n : room;
        memcpy(buf + at, s, k);
        buf[at + k] = 0;
    }
    return at + n;
}

int sph_param_default_json(const sph_param *r, char *buf, size_t len)
{
    size_t n = 0;
    if (len)
        buf[0] = 0;
    switch (r->type) {
    case SPH_PARAM_DOUBLE:
    case SPH_PARAM_INT: n = put(buf, len, 0, r->def_literal); break;
    case SPH_PARAM_BOOL: n = put(buf, len, 0, r->def != 0.0 ? "true" : "false"); break;
    case SPH_PARAM_ENUM:
        n = put(buf, len, 0, "\"");
        n = put(buf, len, n, r->names[(int)r->def]);
        n = put(buf, len, n, "\"");
        break;
    }
    return (int)n;
}

void sph_params_default(sph_params *p)
{
    memset(p, 0, sizeof *p);
    sph_thermo_params_default(&p->thermo);
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        char *m = (char *)p + rows[i].offset;
        if (rows[i].type == SPH_PARAM_DOUBLE)
            *(double *)(void *)m = rows[i].def;
        else
            *(int *)(void *)m = (int)rows[i].def;
    }
}

int sph_params_check(const sph_params *p, const char **name, double *lo, double *hi)
{
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        const sph_param *r = &rows[i];
        double v = sph_param_get(r, p);
        if (!(v >= r->lo && v <= r->hi)) { /* NaN fails too */
            *name = r->key;
            *lo = r->lo;
            *hi = r->hi;
            return SPH_STEP_FATAL;
        }
    }
    /* the thermodynamic step is a whole number of dynamic steps' worth */
    if (p->thermo_dt > 0.0 && p->thermo_dt < p->dt) {
        *name = "thermo.dt";
        *lo = p->dt;
        *hi = sph_param_find("thermo.dt")->hi;
        return SPH_STEP_FATAL;
    }
    return SPH_STEP_OK;
}

/* ------------------------------------------------- automatic time step */

static int thermo_on(const sph_params *p) { return p->thermo_dt > 0 && p->thermo.model != SPH_THERMO_OFF; }

double sph_params_dt_base(const sph_params *p, const double *intervals, size_t n)
{
    long g = 0;
    for (size_t i = 0; i <= n; i++) {
        /* the thermodynamic step first, then the caller's intervals */
        double iv = i == 0 ? (thermo_on(p) ? p->thermo_dt : 0.0) : intervals[i - 1];
        if (!(iv >= 1.0) || fabs(iv - round(iv)) > 1e-6)
            continue;
        long a = lround(iv), b = g;
        while (b) {
            long t = a % b;
            a = b;
            b = t;
        }
        g = a;
    }
    return (double)g;
}

double sph_params_resolve_dt(const sph_params *p, double spacing, double base, const char **why)
{
    double dt = sph_params_auto_dt(p, spacing, base, why);
    if (thermo_on(p) && dt > p->thermo_dt) {
        dt = p->thermo_dt;
        if (why)
            *why = "the thermodynamic step";
    }
    return dt;
}
