/* Particle-level thermodynamics: parameters, workspace, and the threaded
 * step over every live particle (issue 8). The column physics lives in
 * thermo_column.c. Determinism: each particle writes its own slot of the
 * workspace; sums and error reports are made serially in index order. */
#include "core/thermo.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>

void sph_thermo_params_default(sph_thermo_params *p)
{
    p->model = SPH_THERMO_AUTO;
    p->nlayers = 7;
    p->auto_thickness = 0.30; /* bench/bench_thermo.c table, docs/thermo.md */
    p->rho_i = 917.0;
    p->k0 = 2.03;
    p->beta = 0.13;
    p->c0 = 2106.0;
    p->L0 = 3.34e5;
    p->mu = 0.054;
    p->salinity_max = 3.2;
    p->salinity_a = 0.407;
    p->salinity_b = 0.573;
    p->rho_s = 330.0;
    p->k_s = 0.31;
    p->rho_w = 1026.0;
    p->snow_ice = 1;
    p->snow_heat_capacity = 0;
    p->snow_t_snow = 0.0;
    p->snow_t_rain = 2.0;
    p->ocean_salinity = 32.0;
    p->fw_default = 2.0;
    p->emissivity = 0.98;
    p->lw_absorptivity = 0.98;
    p->emissivity_water = 0.97;
    p->albedo_snow = 0.80;
    p->albedo_snow_melt = 0.70;
    p->albedo_ice = 0.65;
    p->albedo_ice_melt = 0.55;
    p->albedo_water = 0.06;
    p->albedo_thin_scale = 0.3;
    p->sw_pen_frac = 0.17;
    p->sw_extinction = 1.5;
    p->rho_a = 1.3;
    p->cp_a = 1005.0;
    p->ch = 1.3e-3;
    p->ce = 1.3e-3;
    p->air_pressure = 101325.0;
    p->Lv_ice = 2.834e6;
    p->Lv_water = 2.501e6;
    p->wind_min = 0.5;
    p->new_ice_thickness = 0.05;
    p->sst_freeze_tolerance = 0.05;
    p->min_thickness = 1e-3;
    p->min_conc = 1e-3;
    p->tsurf_tolerance = 1e-10;
    p->tsurf_max_iter = 100;
    p->picard_tolerance = 1e-9;
    p->picard_max_iter = 50;
    p->ocean_fluxes = 0;
}

int sph_thermo_params_check(const sph_thermo_params *p, const char **name, double *lo, double *hi)
{
    struct {
        const char *name;
        double value, lo, hi;
    } t[] = {
        {"model", (double)p->model, SPH_THERMO_OFF, SPH_THERMO_AUTO},
        {"nlayers", p->nlayers, 1, SPH_MAX_LAYERS},
        {"auto_thickness", p->auto_thickness, 0.0, 20.0},
        {"rho_i", p->rho_i, 800.0, 1000.0},
        {"k0", p->k0, 0.5, 5.0},
        {"beta", p->beta, 0.0, 1.0},
        {"c0", p->c0, 1000.0, 5000.0},
        {"L0", p->L0, 1e5, 1e6},
        {"mu", p->mu, 0.0, 0.2},
        {"salinity_max", p->salinity_max, 0.0, 40.0},
        {"salinity_a", p->salinity_a, 1e-3, 10.0},
        {"salinity_b", p->salinity_b, 1e-3, 10.0},
        {"rho_s", p->rho_s, 50.0, 700.0},
        {"k_s", p->k_s, 0.01, 2.0},
        {"rho_w", p->rho_w, p->rho_i, 1100.0}, /* ice floats */
        {"snow_ice", p->snow_ice, 0, 1},
        {"snow_heat_capacity", p->snow_heat_capacity, 0, 1},
        {"snow_t_snow", p->snow_t_snow, -20.0, 10.0},
        {"snow_t_rain", p->snow_t_rain, p->snow_t_snow, 10.0},
        /* The base must be colder than the melting point of the bottom ice
         * (ocean at least as salty as the ice), else new ice has no latent heat. */
        {"ocean_salinity", p->ocean_salinity, p->salinity_max, 45.0},
        {"fw_default", p->fw_default, -50.0, 500.0},
        {"emissivity", p->emissivity, 0.5, 1.0},
        {"lw_absorptivity", p->lw_absorptivity, 0.5, 1.0},
        {"emissivity_water", p->emissivity_water, 0.5, 1.0},
        {"albedo_snow", p->albedo_snow, 0.0, 1.0},
        {"albedo_snow_melt", p->albedo_snow_melt, 0.0, 1.0},
        {"albedo_ice", p->albedo_ice, 0.0, 1.0},
        {"albedo_ice_melt", p->albedo_ice_melt, 0.0, 1.0},
        {"albedo_water", p->albedo_water, 0.0, 1.0},
        {"albedo_thin_scale", p->albedo_thin_scale, 0.0, 10.0},
        {"sw_pen_frac", p->sw_pen_frac, 0.0, 1.0},
        {"sw_extinction", p->sw_extinction, 0.01, 100.0},
        {"rho_a", p->rho_a, 0.5, 2.0},
        {"cp_a", p->cp_a, 900.0, 1100.0},
        {"ch", p->ch, 0.0, 0.01},
        {"ce", p->ce, 0.0, 0.01},
        {"air_pressure", p->air_pressure, 5e4, 1.1e5},
        {"Lv_ice", p->Lv_ice, 1e6, 4e6},
        {"Lv_water", p->Lv_water, 1e6, 4e6},
        {"wind_min", p->wind_min, 0.0, 10.0},
        {"new_ice_thickness", p->new_ice_thickness, 1e-3, 2.0},
        {"sst_freeze_tolerance", p->sst_freeze_tolerance, 0.0, 5.0},
        {"min_thickness", p->min_thickness, 1e-6, 0.5},
        {"min_conc", p->min_conc, 1e-9, 0.5},
        {"tsurf_tolerance", p->tsurf_tolerance, 1e-14, 0.1},
        {"tsurf_max_iter", p->tsurf_max_iter, 5, 1000},
        {"picard_tolerance", p->picard_tolerance, 1e-14, 0.1},
        {"picard_max_iter", p->picard_max_iter, 1, 1000},
    };
    for (size_t i = 0; i < sizeof t / sizeof t[0]; i++) {
        if (!(t[i].value >= t[i].lo && t[i].value <= t[i].hi)) { /* NaN fails too */
            if (name)
                *name = t[i].name;
            if (lo)
                *lo = t[i].lo;
            if (hi)
                *hi = t[i].hi;
            return SPH_STEP_FATAL;
        }
    }
    return SPH_STEP_OK;
}

/* Per-particle outcome, written by one thread, read serially. */
typedef struct {
    double growth, new_ice, melt_top, melt_bottom, lateral_melt; /* kg */
    double snowfall, snow_melt, snow_ice, snow_to_ocean;         /* kg (snow_ice: of ice) */
    double energy_atm; /* J: atmosphere into the column and the leads */
    int code;
    sph_fault kind;
    const char *quantity, *what;
    double value, limit;
} particle_outcome;

struct sph_thermo_work {
    size_t cap;
    int nlayers;
    particle_outcome *out;
    int nsolvers;
    sph_column_solver **solvers; /* one per thread */
};

sph_thermo_work *sph_thermo_work_create(size_t cap, int nlayers)
{
    if (cap == 0 || nlayers < 1 || nlayers > SPH_MAX_LAYERS)
        return NULL;
    sph_thermo_work *w = calloc(1, sizeof *w);
    if (!w)
        return NULL;
    w->cap = cap;
    w->nlayers = nlayers;
    int nt = omp_get_max_threads();
    if (omp_get_num_procs() > nt)
        nt = omp_get_num_procs();
    w->nsolvers = nt;
    w->out = calloc(cap, sizeof *w->out);
    w->solvers = calloc((size_t)nt, sizeof *w->solvers);
    if (!w->out || !w->solvers) {
        sph_thermo_work_free(w);
        return NULL;
    }
    for (int i = 0; i < nt; i++) {
        if (!(w->solvers[i] = sph_column_solver_create())) {
            sph_thermo_work_free(w);
            return NULL;
        }
    }
    return w;
}

void sph_thermo_work_free(sph_thermo_work *w)
{
    if (!w)
        return;
    if (w->solvers)
        for (int i = 0; i < w->nsolvers; i++)
            sph_column_solver_free(w->solvers[i]);
    free(w->solvers);
    free(w->out);
    free(w);
}

static void column_from_particle(const sph_particles *P, size_t k, sph_column *c)
{
    const double *q = P->enth + k * (size_t)P->nlayers;
    c->thick = P->thick[k];
    c->snow = P->snow[k] > 0.0 ? P->snow[k] : 0.0;
    c->tsurf = P->tsurf[k];
    c->tsnow = P->tsnow[k] < 0.0 && c->snow > 0.0 ? P->tsnow[k] : 0.0;
    c->nlayers = P->nlayers;
    for (int i = 0; i < P->nlayers; i++)
        c->enth[i] = q[i];
}

static void column_to_particle(const sph_column *c, sph_particles *P, size_t k)
{
    double *q = P->enth + k * (size_t)P->nlayers;
    P->thick[k] = c->thick;
    P->snow[k] = c->snow;
    P->tsurf[k] = c->tsurf;
    P->tsnow[k] = c->tsnow;
    for (int i = 0; i < P->nlayers; i++)
        q[i] = c->enth[i];
}

void sph_thermo_init_particle(const sph_thermo_params *p, sph_particles *P, size_t k, double tair)
{
    sph_thermo_params q = *p;
    q.nlayers = P->nlayers;
    sph_column c;
    double Ts = isfinite(tair) && tair < 0.0 ? tair : 0.0;
    sph_column_init(&q, &c, P->thick[k], P->snow[k], Ts);
    column_to_particle(&c, P, k);
}

static int outcome_fail(particle_outcome *o, sph_fault kind, const char *quantity, double value,
                        double limit, const char *what)
{
    o->code = SPH_STEP_FATAL;
    o->kind = kind;
    o->quantity = quantity;
    o->value = value;
    o->limit = limit;
    o->what = what;
    return SPH_STEP_FATAL;
}

/* Forcing and state checks (the driver adds time and place to the sentence). */
static int check_particle(const sph_thermo_params *p, const sph_particles *P, size_t k, particle_outcome *o)
{
    static const char range[] = "is outside the physical range";
    static const char nonfinite[] = "is not finite";
    double v;
    if (!isfinite(P->thick[k]))
        return outcome_fail(o, SPH_FAULT_NONFINITE, "thickness", P->thick[k], 0.0, nonfinite);
    if (!isfinite(P->conc[k]))
        return outcome_fail(o, SPH_FAULT_NONFINITE, "concentration", P->conc[k], 0.0, nonfinite);
    if (!isfinite(P->mass[k]))
        return outcome_fail(o, SPH_FAULT_NONFINITE, "mass", P->mass[k], 0.0, nonfinite);
    v = P->tair[k];
    if (!(v >= -80.0))
        return outcome_fail(o, SPH_FAULT_RANGE, "air_temperature", v, -80.0, range);
    if (!(v <= 50.0))
        return outcome_fail(o, SPH_FAULT_RANGE, "air_temperature", v, 50.0, range);
    v = P->swdn[k];
    if (!(v >= 0.0))
        return outcome_fail(o, SPH_FAULT_RANGE, "shortwave_down", v, 0.0, range);
    if (!(v <= 1500.0))
        return outcome_fail(o, SPH_FAULT_RANGE, "shortwave_down", v, 1500.0, range);
    v = P->lwdn[k];
    if (!(v >= 0.0))
        return outcome_fail(o, SPH_FAULT_RANGE, "longwave_down", v, 0.0, range);
    if (!(v <= 1000.0))
        return outcome_fail(o, SPH_FAULT_RANGE, "longwave_down", v, 1000.0, range);
    if (!isfinite(P->ua[k]) || !isfinite(P->va[k]))
        return outcome_fail(o, SPH_FAULT_NONFINITE, "wind_speed", isfinite(P->ua[k]) ? P->va[k] : P->ua[k], 0.0, nonfinite);
    /* Relative humidity over water (WMO convention) from q and T. */
    v = P->qair[k];
    if (!isfinite(v))
        return outcome_fail(o, SPH_FAULT_NONFINITE, "specific_humidity", v, 0.0, nonfinite);
    double e = v * p->air_pressure / (0.622 + 0.378 * v);
    double T = P->tair[k];
    double rh = e / (611.2 * exp(17.62 * T / (243.12 + T)));
    if (!(rh >= 0.0))
        return outcome_fail(o, SPH_FAULT_RANGE, "relative_humidity", rh, 0.0, range);
    if (!(rh <= 1.05))
        return outcome_fail(o, SPH_FAULT_RANGE, "relative_humidity", rh, 1.05, range);
    v = P->sst[k];
    if (isfinite(v) && !(v >= -3.0 && v <= 40.0))
        return outcome_fail(o, SPH_FAULT_RANGE, "sea_surface_temperature", v, v < -3.0 ? -3.0 : 40.0, range);
    if (isinf(P->fw[k]))
        return outcome_fail(o, SPH_FAULT_NONFINITE, "ocean_heat_flux", P->fw[k], 0.0, nonfinite);
    if (isinf(P->fsens[k]))
        return outcome_fail(o, SPH_FAULT_NONFINITE, "sensible_heat_flux", P->fsens[k], 0.0, nonfinite);
    if (isinf(P->flat[k]))
        return outcome_fail(o, SPH_FAULT_NONFINITE, "latent_heat_flux", P->flat[k], 0.0, nonfinite);
    return SPH_STEP_OK;
}

double sph_particle_snow_mass(const sph_thermo_params *p, const sph_particles *P, size_t k)
{
    if (!(P->snow[k] > 0.0) || !(P->mass[k] > 0.0) || !(P->thick[k] > 0.0))
        return 0.0;
    return p->rho_s * P->snow[k] * P->mass[k] / (p->rho_i * P->thick[k]);
}

static double c0_snow(const sph_particles *P, size_t k) { return P->snow[k] > 0.0 ? P->snow[k] : 0.0; }

static void mark_melted(sph_particles *P, size_t k)
{
    P->mass[k] = 0.0;
    P->thick[k] = 0.0;
    P->snow[k] = 0.0;
}

/* Heat into the ocean of one particle's step, J (docs/ocean-coupling.md). */
typedef struct {
    double ice, lead, sw_base;
} ocean_heat;

/* One particle: column step on the ice part, then the leads. */
static void particle_column_step(const sph_thermo_params *p, sph_particles *P, size_t k, double dt,
                                 sph_column_solver *solver, particle_outcome *o, ocean_heat *oh,
                                 double *snowfall_dt)
{
    o->growth = o->new_ice = o->melt_top = o->melt_bottom = o->lateral_melt = 0.0;
    o->snowfall = o->snow_melt = o->snow_ice = o->snow_to_ocean = 0.0;
    o->energy_atm = 0.0;
    o->code = SPH_STEP_OK;
    if (!(P->mass[k] > 0.0 && P->thick[k] > 0.0 && P->conc[k] > 0.0))
        return; /* already melted out, waiting for removal */

    const double rho = p->rho_i;
    double A = P->conc[k] > 1.0 ? 1.0 : P->conc[k];
    double h = P->thick[k];
    const double area = P->mass[k] / (rho * A * h); /* footprint, held fixed */
    const double Tf = sph_freezing_point(p);

    sph_column_forcing f;
    f.tair = P->tair[k];
    f.qair = P->qair[k];
    f.wind = hypot(P->ua[k], P->va[k]);
    f.swdn = P->swdn[k];
    f.lwdn = P->lwdn[k];
    f.fsens = P->fsens[k];
    f.flat = P->flat[k];
    f.albedo = NAN;
    f.sst = P->sst[k];
    /* Zero is a value: only an absent flux (NaN, as a fresh particle set
     * and the coupling leave it) takes the default. */
    f.fw = isfinite(P->fw[k]) ? P->fw[k] : p->fw_default;
    f.tsurf_prescribed = NAN;
    /* Snowfall forcing is water equivalent, kg m-2 s-1 over the footprint:
     * the part on the ice (A) builds the snow; on the leads it goes to the
     * ocean (not part of the ice budget). Depth rate = flux / rho_s. */
    double sf = P->snowfall[k] > 0.0 ? P->snowfall[k] : 0.0;
    f.snowfall = sf / p->rho_s;
    /* the hook of the ocean fluxes: snow that falls on the ice is not the ocean's */
    *snowfall_dt = f.snowfall > 0.0 ? f.snowfall * dt : 0.0;

    int multi;
    if (p->model == SPH_THERMO_MULTI_LAYER)
        multi = 1;
    else if (p->model == SPH_THERMO_ZERO_LAYER)
        multi = 0;
    else
        multi = h >= p->auto_thickness;
    P->regime[k] &= (unsigned char)~(SPH_REGIME_ZERO_LAYER | SPH_REGIME_MULTI_LAYER);
    P->regime[k] |= multi ? SPH_REGIME_MULTI_LAYER : SPH_REGIME_ZERO_LAYER;

    sph_column c;
    sph_column_result r;
    column_from_particle(P, k, &c);
    if (!isfinite(c.tsurf))
        c.tsurf = Tf;
    int rc = multi ? sph_column_step_multi_layer(p, &c, &f, dt, solver, &r)
                   : sph_column_step_zero_layer(p, &c, &f, dt, solver, &r);
    if (rc == SPH_STEP_FATAL) {
        outcome_fail(o, SPH_FAULT_SOLVER, "ice_temperature", c.tsurf, 0.0, "has no solution of the conduction equation");
        return;
    }
    /* Column changes, per unit ice area -> kg over the ice part of the footprint. */
    const double m_ice = rho * A * area;
    const double hs0 = c0_snow(P, k);
    /* atmosphere into the column over the ice part and into the leads */
    o->energy_atm = (r.fatm * A + (A < 1.0 ? sph_open_water_flux(p, &f) * (1.0 - A) : 0.0)) * area * dt;
    o->growth = m_ice * r.growth;
    o->melt_top = m_ice * r.melt_top;
    o->melt_bottom = m_ice * r.melt_bottom;
    /* Snow (kg over the ice part): fallen, melted, flooded into ice; what
     * else left the column (melt-out) goes to the ocean. snow_ice is the
     * ice it made, rho_i dh = rho_s ds: one mass, both budgets. */
    const double s_ice = p->rho_s * A * area;
    o->snowfall = sf * dt * A * area;
    o->snow_melt = s_ice * r.snow_melt;
    o->snow_ice = s_ice * r.snow_to_ice;
    o->snow_to_ocean = o->snowfall + s_ice * hs0 - o->snow_melt - o->snow_ice - s_ice * c.snow;
    /* Under the ice the ocean gives the base its heat flux and receives
     * what the column sheds (melt-out remnants, excess melt energy). */
    oh->ice = A * area * (-r.focean * dt + r.energy_to_ocean);
    oh->sw_base = A * area * r.sw_base * dt;
    if (r.melted_out) {
        column_to_particle(&c, P, k);
        mark_melted(P, k);
        return;
    }
    column_to_particle(&c, P, k);
    h = c.thick;

    /* Leads (Hibler's two-level model): heat lost by open water at the
     * freezing point forms new ice of thickness h0 that raises A; heat
     * gained melts ice laterally and lowers A at fixed h. */
    if (A < 1.0) {
        double Fow = sph_open_water_flux(p, &f);
        double Tw = isfinite(f.sst) ? f.sst : Tf;
        double *q = P->enth + k * (size_t)P->nlayers;
        int n = P->nlayers;
        if (Fow < 0.0 && Tw <= Tf + p->sst_freeze_tolerance) {
            double qnew_bulk = sph_bl_enthalpy(p, p->salinity_max, Tf);
            double dV = -Fow * (1.0 - A) * dt / (-qnew_bulk); /* m^3 per m^2 of footprint */
            double Anew = A + dV / p->new_ice_thickness;
            if (Anew > 1.0)
                Anew = 1.0;
            double hnew = (A * h + dV) / Anew;
            /* New ice joins the column at the freezing point, layer by layer. */
            for (int i = 0; i < n; i++) {
                double S = sph_bl_salinity(p, (i + 0.5) / n);
                double Tm = sph_bl_melting_temperature(p, S);
                double qn = sph_bl_enthalpy(p, S, Tf < Tm ? Tf : Tm);
                q[i] = (A * h * q[i] + dV * qn) / (Anew * hnew);
            }
            P->snow[k] *= A / Anew;
            o->new_ice = rho * area * dV;
            /* the heat the lead loses is the latent heat of its new ice:
             * the water under it stays at the freezing point (oh->lead 0) */
            A = Anew;
            h = hnew;
        } else if (Fow < 0.0) {
            oh->lead = area * Fow * (1.0 - A) * dt; /* warm water cools */
        } else if (Fow > 0.0) {
            double qbar = 0.0;
            for (int i = 0; i < n; i++)
                qbar += q[i] / n;
            double qmelt = qbar < 0.0 ? -qbar : rho * p->L0;
            double dV = Fow * (1.0 - A) * dt / qmelt;
            if (dV >= A * h) {
                o->lateral_melt = rho * area * A * h;
                o->snow_to_ocean += p->rho_s * P->snow[k] * area * A;
                /* what the melt did not use, and the snow, to the water */
                oh->lead = area * (Fow * (1.0 - A) * dt - A * h * qmelt +
                                   A * P->snow[k] * sph_snow_enthalpy(p, P->tsnow[k]));
                mark_melted(P, k);
                return;
            }
            o->lateral_melt = rho * area * dV;
            o->snow_to_ocean += p->rho_s * P->snow[k] * area * dV / h; /* the snow on the melted area */
            A -= dV / h;
        }
    }
    if (A < p->min_conc) {
        o->lateral_melt += rho * area * A * h;
        o->snow_to_ocean += p->rho_s * P->snow[k] * area * A;
        /* the remnant's ice and snow melt in the water, which pays for it */
        const double *q = P->enth + k * (size_t)P->nlayers;
        double e = 0.0;
        for (int i = 0; i < P->nlayers; i++)
            e += q[i] * h / P->nlayers;
        oh->lead += area * A * (e + P->snow[k] * sph_snow_enthalpy(p, P->tsnow[k]));
        mark_melted(P, k);
        return;
    }
    P->thick[k] = h;
    P->conc[k] = A;
    P->mass[k] = rho * A * h * area;
}

double sph_thermo_energy_atm(const sph_thermo_work *w, size_t k)
{
    return w && k < w->cap ? w->out[k].energy_atm : 0.0;
}

/* Bulk salinity of the ice, ppt: the mean of the Bitz-Lipscomb profile
 * over the layer midpoints, the profile every layer's enthalpy uses, so
 * that the salt a particle's ice holds is this times its mass. */
static double bulk_salinity(const sph_thermo_params *p, int n)
{
    double s = 0.0;
    for (int i = 0; i < n; i++)
        s += sph_bl_salinity(p, (i + 0.5) / n);
    return s / n;
}

/* The column step, then (thermo.ocean_fluxes) its fluxes into the ocean
 * added to the particle's accumulators: water and salt from the change of
 * the ice mass (ice of bulk salinity S_i: a share S_i/1000 of its mass is
 * salt) and of the snow mass; heat from the column and the leads. */
static void particle_step(const sph_thermo_params *p, sph_particles *P, size_t k, double dt,
                          sph_column_solver *solver, particle_outcome *o, double S_ice)
{
    ocean_heat oh = {0.0, 0.0, 0.0};
    double snowfall_dt = 0.0;
    const double m0 = P->mass[k], A0 = P->conc[k] > 1.0 ? 1.0 : P->conc[k], s0 = P->snow[k];
    const double footprint = m0 > 0.0 && P->thick[k] > 0.0 && A0 > 0.0 ? m0 / (p->rho_i * A0 * P->thick[k]) : 0.0;
    particle_column_step(p, P, k, dt, solver, o, &oh, &snowfall_dt);
    if (!p->ocean_fluxes || o->code != SPH_STEP_OK || !(footprint > 0.0))
        return;
    double A1 = P->conc[k] > 1.0 ? 1.0 : P->conc[k];
    double dice = m0 - P->mass[k]; /* kg of ice returned to the ocean (negative: frozen out of it) */
    /* snow melt and melt-out; snowfall_dt is the snowfall on the ice. Snow
     * turned into ice (snow-ice) leaves the snow and enters dice with the
     * opposite sign: its mass never reaches the ocean, only the salt share
     * S_i/1000 the ice of bulk salinity S_i holds is exchanged for fresh
     * water (docs/ocean-coupling.md). */
    double dsnow = p->rho_s * footprint * (A0 * ((s0 > 0.0 ? s0 : 0.0) + snowfall_dt) - A1 * P->snow[k]);
    /* snow on the leads goes straight into the water (water equivalent) */
    if (P->snowfall[k] > 0.0)
        dsnow += P->snowfall[k] * dt * (1.0 - A0) * footprint;
    P->ofx_water[k] += dice * (1.0 - 1e-3 * S_ice) + dsnow;
    P->ofx_salt[k] += dice * 1e-3 * S_ice;
    P->ofx_heat_ice[k] += oh.ice;
    P->ofx_heat_lead[k] += oh.lead;
    P->ofx_swbase[k] += oh.sw_base;
}

void sph_thermo_outcome_terms(const sph_thermo_work *w, size_t k, double t[9])
{
    const particle_outcome *o = &w->out[k];
    t[0] = o->growth;
    t[1] = o->new_ice;
    t[2] = o->melt_top;
    t[3] = o->melt_bottom;
    t[4] = o->lateral_melt;
    t[5] = o->snow_ice;
    t[6] = o->snowfall;
    t[7] = o->snow_melt;
    t[8] = o->snow_to_ocean;
}

int sph_thermo_step(const sph_thermo_params *p, sph_particles *P, double dt, sph_thermo_work *w,
                    sph_budget *b, sph_status *st)
{
    if (p->model == SPH_THERMO_OFF || P->n == 0)
        return SPH_STEP_OK;
    if (!w || P->n > w->cap || P->nlayers < 1 || P->nlayers > SPH_MAX_LAYERS)
        return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_CAPACITY, -1, "thermo_workspace", (double)P->n, (double)(w ? w->cap : 0),
                              "is smaller than the particle set");
    const char *bad;
    double lo, hi;
    if (sph_thermo_params_check(p, &bad, &lo, &hi) != SPH_STEP_OK)
        return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_PARAMETER, -1, bad, lo, hi, "is outside its allowed range");
    if (!(dt > 0.0))
        return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_INVALID, -1, "thermo_dt", dt, 0.0, "is not positive");

    const long n = (long)P->n;
    int nthreads = omp_get_max_threads();
    if (nthreads > w->nsolvers)
        nthreads = w->nsolvers;
    /* Check every particle's forcing before changing anything, so that bad
     * input leaves the state as it was. */
#pragma omp parallel for schedule(static) num_threads(nthreads)
    for (long k = 0; k < n; k++) {
        w->out[k].code = SPH_STEP_OK;
        if (P->mass[k] > 0.0 && P->thick[k] > 0.0 && P->conc[k] > 0.0)
            check_particle(p, P, (size_t)k, &w->out[k]);
    }
    /* Serial, index-ordered: the first failing particle is reported. */
    for (long k = 0; k < n; k++) {
        if (w->out[k].code != SPH_STEP_OK) {
            const particle_outcome *o = &w->out[k];
            return sph_status_set(st, o->code, o->kind, k, o->quantity, o->value, o->limit, o->what);
        }
    }

    const double S_ice = p->ocean_fluxes ? bulk_salinity(p, P->nlayers) : 0.0;
#pragma omp parallel for schedule(dynamic, 16) num_threads(nthreads)
    for (long k = 0; k < n; k++)
        particle_step(p, P, (size_t)k, dt, w->solvers[omp_get_thread_num()], &w->out[k], S_ice);
    for (long k = 0; k < n; k++) {
        if (w->out[k].code != SPH_STEP_OK) {
            const particle_outcome *o = &w->out[k];
            return sph_status_set(st, o->code, o->kind, k, o->quantity, o->value, o->limit, o->what);
        }
    }
    /* Sums in index order: the same for every thread count. */
    if (b) {
        for (long k = 0; k < n; k++) {
            const particle_outcome *o = &w->out[k];
            b->growth += o->growth;
            b->new_ice += o->new_ice;
            b->melt_top += o->melt_top;
            b->melt_bottom += o->melt_bottom;
            b->lateral_melt += o->lateral_melt;
            b->snow_ice += o->snow_ice;
            b->snowfall += o->snowfall;
            b->snow_melt += o->snow_melt;
            b->snow_to_ocean += o->snow_to_ocean;
        }
    }
    return SPH_STEP_OK;
}
