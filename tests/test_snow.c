/* Snow on the particles (issue 20 item 3), against numbers from outside
 * the code:
 *  - accumulation: snowfall F (kg m-2 s-1, water equivalent) on cold,
 *    dark ice with no melt gives the depth F t / rho_s;
 *  - the rain/snow split of precipitation is the CLM 4.0 ramp (all snow at
 *    or below 0 C, all rain at or above 2 C, linear in between), computed
 *    here from its definition;
 *  - snow-ice: a column whose snow pushes the freeboard below zero ends
 *    with the freeboard at zero, mass and energy conserved; the amount is
 *    found here by bisection on Archimedes' balance, not by the formula;
 *  - budgets: with snowfall, flooding, melt and lateral melt on a set of
 *    particles, the ice mass budget (with the snow-ice source) and the
 *    snow budget close to round-off;
 *  - snow heat capacity (thermo.snow_heat_capacity, Bitz & Lipscomb 1999):
 *    the multi-layer column's energy, snow enthalpy -rho_s (L0 - c0 T_s)
 *    computed here, changes by the boundary fluxes times dt to round-off
 *    over a year of snowfall, cold and melt; under a fixed surface
 *    temperature on fresh ice held at equilibrium by the ocean flux, the
 *    snow layer's temperature is the series-conduction value
 *    Ts + F hs / (2 k_s) with F = (Tf - Ts) / (hs / k_s + h / k0); without
 *    the option the snow stays at 0 C (latent heat only, as before). */
#include "check.h"
#include "core/thermo.h"

#include <string.h>

#include "column_energy.h"
#include "mu71_forcing.h"

#define AREA 1.0e6 /* footprint, m^2 */

static void set_particle(const sph_thermo_params *p, sph_particles *P, size_t k, double h, double A,
                         double hs, double tair)
{
    P->id[k] = (long)k;
    P->thick[k] = h;
    P->conc[k] = A;
    P->snow[k] = hs;
    P->mass[k] = p->rho_i * A * h * AREA;
    P->sml[k] = 1000.0;
    P->ua[k] = 5.0;
    P->va[k] = 0.0;
    P->tair[k] = tair;
    P->qair[k] = 2e-4;
    P->swdn[k] = 0.0;
    P->lwdn[k] = 180.0;
    P->sst[k] = NAN;
    P->fw[k] = 0.0;
    P->fsens[k] = NAN;
    P->flat[k] = NAN;
    P->snowfall[k] = 0.0;
    sph_thermo_init_particle(p, P, k, tair);
}

static double ice_mass(const sph_particles *P)
{
    double m = 0.0;
    for (size_t k = 0; k < P->n; k++)
        m += P->mass[k];
    return m;
}

static double snow_mass(const sph_thermo_params *p, const sph_particles *P)
{
    double m = 0.0;
    for (size_t k = 0; k < P->n; k++)
        m += sph_particle_snow_mass(p, P, k);
    return m;
}

/* No melt: -25 C, dark; thick ice so that no flooding happens. */
static void check_accumulation(const sph_thermo_params *p, int model)
{
    sph_thermo_params q = *p;
    q.model = model;
    sph_particles *P = sph_particles_create(2, q.nlayers);
    P->n = 2;
    set_particle(&q, P, 0, 2.0, 1.0, 0.0, -25.0);
    set_particle(&q, P, 1, 1.5, 0.6, 0.02, -25.0);
    const double F = 1.0e-4, dt = 3600.0; /* 0.36 mm/h water equivalent */
    const int steps = 240;                /* 10 days */
    P->snowfall[0] = P->snowfall[1] = F;
    sph_budget b;
    memset(&b, 0, sizeof b);
    b.snow_initial = snow_mass(&q, P);
    double A1_0 = P->conc[1], area1 = P->mass[1] / (q.rho_i * P->conc[1] * P->thick[1]);
    sph_thermo_work *w = sph_thermo_work_create(2, q.nlayers);
    sph_status st;
    sph_status_clear(&st);
    int rc = SPH_STEP_OK;
    for (int i = 0; i < steps && rc == SPH_STEP_OK; i++)
        rc = sph_thermo_step(&q, P, dt, w, &b, &st);
    sph_thermo_work_free(w);
    CHECK(rc == SPH_STEP_OK, "accumulation run (%d): %s", model, st.quantity);
    double t = steps * dt, depth = F * t / q.rho_s;
    CHECK_CLOSE(P->snow[0], depth, 1e-12, 0, "snow depth = F t / rho_s");
    CHECK(b.snow_ice == 0.0 && b.snow_melt == 0.0, "no flooding, no melt");
    /* the second particle's leads freeze (A grows, the snow spreads over the
     * new ice): its snow mass is what it had plus F t over its ice area,
     * step by step; the total is checked through the budget */
    double fell0 = F * t * AREA; /* particle 0: A = 1 */
    CHECK(b.snowfall > fell0 && b.snowfall < fell0 + F * t * area1, "snowfall on the ice parts only");
    CHECK(P->conc[1] > A1_0, "the leads of particle 1 froze (A %.3f -> %.3f)", A1_0, P->conc[1]);
    b.snow = snow_mass(&q, P);
    CHECK_CLOSE(b.snow, sph_budget_snow_expected(&b), 1e-13, 0, "snow budget");
    sph_particles_free(P);
}

static void check_split(const sph_thermo_params *p)
{
    const double T[] = {-30.0, -0.5, 0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 20.0};
    for (size_t i = 0; i < sizeof T / sizeof T[0]; i++) {
        /* CLM 4.0 (Oleson et al. 2010, eq. 7.19-7.20 as ramps): 1 at or below
         * T_f, 0 at or above T_f + 2 K, linear between */
        double want = T[i] <= 0.0 ? 1.0 : T[i] >= 2.0 ? 0.0 : (2.0 - T[i]) / 2.0;
        CHECK_CLOSE(sph_snow_fraction(p, T[i]), want, 0, 1e-15, "snow fraction");
    }
    CHECK(sph_snow_fraction(p, NAN) == 0.0, "unknown air temperature: no snow");
    sph_thermo_params q = *p;
    q.snow_t_snow = -1.0;
    q.snow_t_rain = 3.0;
    CHECK_CLOSE(sph_snow_fraction(&q, 0.0), 0.75, 0, 1e-15, "configured ramp -1 .. 3 C at 0 C");
}

/* Freeboard of ice h under snow hs. */
static double freeboard(const sph_thermo_params *p, double h, double hs)
{
    return h - (p->rho_i * h + p->rho_s * hs) / p->rho_w;
}

static void check_snow_ice(const sph_thermo_params *p)
{
    for (int multi = 0; multi < 2; multi++) {
        const double h = 0.5, hs = 0.3;
        CHECK(freeboard(p, h, hs) < 0.0, "the load floods (freeboard %.4f m)", freeboard(p, h, hs));
        /* Archimedes, mass conserved (ds of snow becomes rho_s ds / rho_i of
         * ice): bisection on ds for a zero freeboard */
        double lo = 0.0, hi = hs;
        for (int it = 0; it < 200; it++) {
            double mid = 0.5 * (lo + hi);
            double f = freeboard(p, h + p->rho_s * mid / p->rho_i, hs - mid);
            if (f < 0.0)
                lo = mid;
            else
                hi = mid;
        }
        double ds = 0.5 * (lo + hi), dh = p->rho_s * ds / p->rho_i;
        sph_column c;
        sph_thermo_params q = *p;
        q.nlayers = multi ? 7 : 1;
        sph_column_init(&q, &c, h, hs, -15.0);
        double E0 = sph_column_energy(&q, &c);
        sph_column_result r;
        memset(&r, 0, sizeof r);
        CHECK(sph_column_snow_ice(&q, &c, &r) == 1, "snow-ice forms");
        CHECK_CLOSE(c.thick, h + dh, 1e-12, 0, "ice thickness after flooding (bisection)");
        CHECK_CLOSE(c.snow, hs - ds, 1e-12, 0, "snow depth after flooding (bisection)");
        CHECK(fabs(freeboard(&q, c.thick, c.snow)) < 1e-14, "freeboard zero: %.3g m", freeboard(&q, c.thick, c.snow));
        CHECK_CLOSE(q.rho_i * c.thick + q.rho_s * c.snow, q.rho_i * h + q.rho_s * hs, 1e-14, 0, "mass conserved");
        CHECK_CLOSE(sph_column_energy(&q, &c), E0, 1e-13, 0, "energy conserved");
        CHECK_CLOSE(r.snow_to_ice, ds, 1e-12, 0, "reported snow converted");
        CHECK_CLOSE(q.rho_i * r.snow_ice, q.rho_s * r.snow_to_ice, 1e-14, 0, "reported ice = snow mass");
        CHECK(sph_column_snow_ice(&q, &c, &r) == 0, "nothing more at zero freeboard");
        /* through a column step: heavy snowfall on thin ice */
        sph_column_solver *s = sph_column_solver_create();
        sph_column_init(&q, &c, 0.3, 0.0, -15.0);
        sph_column_forcing f;
        sph_column_forcing_default(&f);
        f.tair = -15.0;
        f.lwdn = 180.0;
        f.wind = 5.0;
        f.qair = 2e-4;
        f.fw = 0.0;
        f.snowfall = 0.2 / 3600.0; /* 20 cm of snow in an hour */
        int rc = multi ? sph_column_step_multi_layer(&q, &c, &f, 3600.0, s, &r)
                       : sph_column_step_zero_layer(&q, &c, &f, 3600.0, s, &r);
        CHECK(rc == SPH_STEP_OK && r.snow_to_ice > 0.0, "a step floods (%s)", multi ? "multi" : "zero");
        CHECK(fabs(freeboard(&q, c.thick, c.snow)) < 1e-14, "freeboard zero after the step");
        q.snow_ice = 0;
        sph_column_init(&q, &c, 0.3, 0.0, -15.0);
        rc = multi ? sph_column_step_multi_layer(&q, &c, &f, 3600.0, s, &r)
                   : sph_column_step_zero_layer(&q, &c, &f, 3600.0, s, &r);
        CHECK(r.snow_to_ice == 0.0 && freeboard(&q, c.thick, c.snow) < 0.0, "thermo.snow_ice false: no flooding");
        sph_column_solver_free(s);
    }
}

/* Many particles, 10 days: snowfall, flooding, melt, lateral melt, melt-out. */
static void check_budgets(const sph_thermo_params *p)
{
    enum { N = 96 };
    sph_particles *P = sph_particles_create(N, p->nlayers);
    P->n = N;
    for (size_t k = 0; k < N; k++) {
        double u = (double)k / (N - 1);
        set_particle(p, P, k, 0.05 + 1.5 * u * u, 0.3 + 0.7 * fmod(u * 7.3, 1.0), (k % 4) * 0.05, -10.0);
        P->snowfall[k] = (k % 5) * 1.0e-4;
    }
    sph_budget b;
    memset(&b, 0, sizeof b);
    b.mass_initial = ice_mass(P);
    b.snow_initial = snow_mass(p, P);
    sph_thermo_work *w = sph_thermo_work_create(N, p->nlayers);
    sph_status st;
    sph_status_clear(&st);
    int rc = SPH_STEP_OK;
    double worst_ice = 0.0, worst_snow = 0.0;
    for (int i = 0; i < 240 && rc == SPH_STEP_OK; i++) {
        int warm = (i / 48) % 2 == 1; /* two warm, sunny spells */
        for (size_t k = 0; k < N; k++) {
            double u = (double)k / (N - 1);
            P->tair[k] = warm ? 2.0 + 4.0 * u : -20.0 + 10.0 * u;
            P->qair[k] = warm ? 0.004 : 2e-4;
            P->swdn[k] = warm ? 400.0 : 0.0;
            P->lwdn[k] = warm ? 300.0 : 180.0;
            P->sst[k] = warm ? 1.0 : NAN;
            P->fw[k] = warm ? 30.0 : 2.0;
        }
        rc = sph_thermo_step(p, P, 3600.0, w, &b, &st);
        b.mass = ice_mass(P);
        b.snow = snow_mass(p, P);
        worst_ice = fmax(worst_ice, sph_budget_residual(&b));
        worst_snow = fmax(worst_snow, sph_budget_snow_residual(&b));
    }
    sph_thermo_work_free(w);
    CHECK(rc == SPH_STEP_OK, "budget run: %s", st.quantity);
    int melted = 0;
    for (size_t k = 0; k < N; k++)
        melted += !(P->mass[k] > 0.0);
    printf("budgets, %d particles, 10 days: snowfall %.4g kg, snow melt %.4g, snow-ice %.4g, snow to "
           "ocean %.4g, %d melted out; worst residual ice %.2e, snow %.2e\n",
           N, b.snowfall, b.snow_melt, b.snow_ice, b.snow_to_ocean, melted, worst_ice, worst_snow);
    CHECK(b.snowfall > 0 && b.snow_melt > 0 && b.snow_ice > 0 && b.snow_to_ocean > 0 && b.lateral_melt > 0,
          "every snow process took part");
    CHECK(worst_ice < 1e-13, "ice mass budget with the snow-ice source: %.2e", worst_ice);
    CHECK(worst_snow < 1e-13, "snow budget: %.2e", worst_snow);
    sph_particles_free(P);
}

#define SIGMA 5.670374419e-8

/* Snow enthalpy and column energy from their definitions: column_energy.h. */

static void check_snow_heat_capacity(void)
{
    sph_thermo_params p;
    sph_thermo_params_default(&p);
    p.snow_heat_capacity = 1;
    sph_column_solver *s = sph_column_solver_create();
    /* a year of MU71's forcing (tests/mu71_forcing.h): snowfall, a cold
     * winter, a melting summer */
    sph_column c;
    sph_column_init(&p, &c, 2.0, 0.2, -15.0);
    CHECK(c.tsnow < 0.0, "a cold snow layer starts below 0 C (%.2f C)", c.tsnow);
    sph_column_forcing f;
    sph_column_forcing_default(&f);
    const double dt = 3600.0, eps = p.emissivity;
    double worst = 0.0, tmin = 0.0, melt = 0.0;
    int steps = check_quick() ? 24 * 90 : 24 * 365;
    for (int i = 0; i < steps; i++) {
        double day = fmod(270.0 + i / 24.0, 365.0); /* from late September: snow, winter, melt */
        f.swdn = monthly(SW, day);
        f.lwdn = monthly(LW, day);
        f.fsens = monthly(SENS, day);
        f.flat = monthly(LAT, day);
        f.albedo = monthly(ALB, day);
        f.fw = 2.0;
        f.snowfall = snowfall(day);
        double E0 = column_energy_here(&p, &c);
        sph_column_result r;
        int rc = sph_column_step_multi_layer(&p, &c, &f, dt, s, &r);
        if (rc != SPH_STEP_OK) {
            CHECK(0, "step %d: rc %d", i, rc);
            break;
        }
        double E1 = column_energy_here(&p, &c);
        double Tk = c.tsurf + 273.15;
        double fatm = (1 - f.albedo) * f.swdn + p.lw_absorptivity * f.lwdn - eps * SIGMA * Tk * Tk * Tk * Tk +
                      f.fsens + f.flat;
        /* new snow arrives at 0 C: -rho_s L0 per m^3 */
        double in = (fatm + f.fw) * dt + q_snow(&p, 0.0) * f.snowfall * dt - r.energy_to_ocean;
        double scale = (fabs(fatm) + fabs(f.fw)) * dt + p.rho_s * p.L0 * f.snowfall * dt;
        worst = fmax(worst, fabs((E1 - E0) - in) / scale);
        tmin = fmin(tmin, c.tsnow);
        melt += r.snow_melt;
    }
    printf("snow heat capacity: worst |dE - F dt| / (|F| dt) over %d steps = %.3e (coldest snow %.2f C, "
           "snow melted %.3f m)\n", steps, worst, tmin, melt);
    CHECK(worst < 1e-9, "energy with the snow's enthalpy changes by the fluxes x dt: %.3g", worst);
    CHECK(tmin < -10.0, "the snow layer cooled (%.2f C)", tmin);
    if (!check_quick())
        CHECK(melt > 0.05, "and melted in summer (%.3f m)", melt);

    /* steady series conduction: fresh ice (K = k0), Ts fixed, F_w = F */
    sph_thermo_params q = p;
    q.salinity_max = 0.0;
    const double h = 1.5, hs = 0.25, Ts = -30.0, Tf = sph_freezing_point(&q);
    const double F = (Tf - Ts) / (hs / q.k_s + h / q.k0);
    sph_column_init(&q, &c, h, hs, Ts);
    c.tsnow = -2.0; /* the snow far from its steady temperature: it relaxes in days */
    sph_column_forcing_default(&f);
    f.tsurf_prescribed = Ts;
    f.fw = F;
    for (int i = 0; i < 24 * 60; i++) {
        sph_column_result r;
        sph_column_step_multi_layer(&q, &c, &f, dt, s, &r);
    }
    /* the released heat thinned the ice a little, which regrows slowly: the
     * series value at the current thickness (quasi-steady) */
    double Fc = (Tf - Ts) / (hs / q.k_s + c.thick / q.k0), want = Ts + Fc * 0.5 * hs / q.k_s;
    printf("steady snow layer: %.6f C (series conduction %.6f C), h %.6f m\n", c.tsnow, want, c.thick);
    CHECK(fabs(c.tsnow - want) < 1e-3, "steady snow temperature %.5f C = Ts + F hs / (2 k_s) = %.5f C", c.tsnow,
          want);
    CHECK(fabs(c.thick - h) < 5e-3, "held near equilibrium by F_w (h %.5f m)", c.thick);

    /* without the option: latent heat only, the snow stays at 0 C */
    p.snow_heat_capacity = 0;
    sph_column_init(&p, &c, 2.0, 0.2, -15.0);
    CHECK(c.tsnow == 0.0, "option off: snow at 0 C");
    sph_column_forcing_default(&f);
    f.lwdn = 150.0;
    f.fsens = 0.0;
    f.flat = 0.0;
    f.fw = 2.0;
    f.snowfall = 1e-7;
    for (int i = 0; i < 24 * 30; i++) {
        sph_column_result r;
        sph_column_step_multi_layer(&p, &c, &f, dt, s, &r);
    }
    CHECK(c.tsnow == 0.0 && c.tsurf < -20.0, "option off: still 0 C after a cold month (surface %.1f C)", c.tsurf);
    sph_column_solver_free(s);
}

int main(void)
{
    sph_thermo_params p;
    sph_thermo_params_default(&p);
    check_accumulation(&p, SPH_THERMO_ZERO_LAYER);
    check_accumulation(&p, SPH_THERMO_MULTI_LAYER);
    check_split(&p);
    check_snow_ice(&p);
    check_budgets(&p);
    check_snow_heat_capacity();
    /* the same snow-ice and budget checks with the snow's heat capacity */
    p.snow_heat_capacity = 1;
    check_snow_ice(&p);
    check_budgets(&p);
    return check_summary("test_snow");
}
