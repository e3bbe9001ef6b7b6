/* Snow with its heat capacity over the slab mixed layer (issue 20;
 * thermo.snow_heat_capacity with ocean.mixed_layer, docs/ocean.md).
 *
 * The slab gets from each particle the energy the atmosphere did not
 * explain: E_atm - dE, dE the change of the particle's ice and snow
 * enthalpy. Counted with the column's snow enthalpy
 * -rho_s (L0 - c0 T_s) per m^3 (Bitz & Lipscomb 1999), and snowfall on
 * the ice booked as arriving from the atmosphere at -rho_s L0, the slab
 * under a full cover of snowy ice receives exactly what the column took
 * from it: minus the ice-ocean heat flux F_w = 246 (T - Tf) over the ice
 * (dark, concentration 1: no leads, no shortwave). Before, the snow
 * counted at 0 C: the snow layer's cooling (and the latent heat of the
 * snowfall) showed up as heat given to the slab.
 *
 * Then 30 days with snowfall, creation, merging, melt-out and outflow of
 * particles, snow heat capacity on: energy, water and salt of ice, snow
 * and ocean close to round-off (1e-12 relative, the model's own budget),
 * and merging kept the snow enthalpy (the budget would show it). */
#include "check.h"
#include "core/model.h"
#include "core/ocean.h"
#include "ocean_column.h"

static void base(sph_params *p)
{
    oc_params(p, SPH_THERMO_MULTI_LAYER);
    p->thermo.snow_heat_capacity = 1;
}

static void set_snowfall(sph_model *m, double rate)
{
    sph_particles *P = sph_model_particles(m);
    for (size_t k = 0; k < P->n; k++)
        P->snowfall[k] = rate;
}

/* One step of one snowy particle filling a 10 km cell at Tf + 0.1 K. */
static void test_one_step(double snowfall)
{
    sph_params p;
    base(&p);
    sph_model *m = sph_model_create(&p, 4, NULL);
    sph_ocean_grid g = {1, 1, 0.0, 0.0, 1e4, 1e4, 1250.0, 1250.0, 2500.0};
    int ok = m && sph_model_ocean_create(m, &g) == SPH_STEP_OK;
    CHECK(ok, "model");
    if (!ok) {
        sph_model_free(m);
        return;
    }
    const double Tf = -0.054 * 32.0, T0 = Tf + 0.1, foot = 1e8;
    sph_ocean *o = sph_model_ocean(m);
    sph_ocean_set_cell(o, 0, 20.0, 32.0, T0);
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, &p, 1, 1, 5e3, 5e3, 1e4, 1.0, 1.0, 40.0);
    P->mass[0] = p.thermo.rho_i * 1.0 * foot; /* freeboard 0.12 m holds the 0.3 m of snow */
    sph_thermo_init_particle(&p.thermo, P, 0, -15.0);
    P->snow[0] = 0.3;
    P->tsnow[0] = -8.0;
    oc_fill_atm(m, -25.0, 4e-4, 3.0, 4.0, 0.0, 170.0, 40.0);
    set_snowfall(m, snowfall);
    sph_status st;
    CHECK(sph_model_init(m, &st) == SPH_STEP_OK, "init: %s", st.what);
    CHECK(sph_model_step(m, &st) == SPH_STEP_OK, "step: %s %s", st.quantity, st.what);
    double fw = 246.0 * (T0 - Tf); /* below the cap H (T - Tf) / (dt foot) */
    double want = -fw * foot * 3600.0;
    printf("snowy ice over the slab (snowfall %g kg/m2/s): heat to the slab %.6e J, -F_w A dt %.6e J, "
           "snow %.4f m at %.3f C\n",
           snowfall, o->acc_e[0], want, P->snow[0], P->tsnow[0]);
    CHECK(P->tsnow[0] < -8.0 && P->snow[0] > 0.3 - 1e-9, "the snow layer is solved and cooled (%.3f C)", P->tsnow[0]);
    CHECK_CLOSE(o->acc_e[0], want, 1e-8, 0, "the slab gave the ice its heat flux, nothing else");
    CHECK_CLOSE(o->temp[0], T0 + want / (1026.0 * 3990.0 * 20.0 * 1e8), 1e-12, 0, "slab temperature");
    const sph_budget *b = sph_model_budget(m);
    CHECK(sph_budget_energy_residual(b) < 1e-12, "energy budget %g", sph_budget_energy_residual(b));
    sph_model_free(m);
}

/* 30 days as tests/test_new_ice.c's conservation case, with snow. */
static void test_season(void)
{
    sph_params p;
    base(&p);
    p.Ca = 1.2e-3;
    p.ocean.create = 1;
    p.ocean.restore_days = 5.0;
    p.ocean.merge = 1;
    p.ocean.merge_distance = 1.05;
    p.ocean.merge_thickness = 0.3;
    p.thermo.model = SPH_THERMO_AUTO;
    p.thermo.auto_thickness = 0.1;
    static unsigned char land[4 * 4] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0};
    sph_landmask mk = {4, 4, 0.0, 0.0, 5000.0, 5000.0, land, 0};
    sph_model *m = sph_model_create(&p, 4000, &mk);
    sph_ocean_grid g = {2, 2, 0.0, 0.0, 1e4, 1e4, 1250.0, 1250.0, 2500.0};
    int ok = m && sph_model_ocean_create(m, &g) == SPH_STEP_OK;
    CHECK(ok, "model");
    if (!ok) {
        sph_model_free(m);
        return;
    }
    sph_ocean *o = sph_model_ocean(m);
    for (size_t c = 0; c < 4; c++) {
        sph_ocean_set_cell(o, c, c == 1 ? 5.0 : 25.0, 31.0, -1.0);
        o->sss_restore[c] = 31.5;
    }
    oc_fill_atm(m, -15.0, 6e-4, 2.0, 1.0, 0.0, 200.0, 40.0);
    sph_status st;
    CHECK(sph_model_init(m, &st) == SPH_STEP_OK, "init: %s", st.what);
    double worst[3] = {0, 0, 0}, tsmin = 0.0;
    int rc = SPH_STEP_OK;
    for (int h = 0; h < 30 * 24 && rc == SPH_STEP_OK; h++) {
        int day = h / 24, warm = day >= 14 && day < 19;
        for (size_t c = 0; c < 4; c++)
            o->sst_restore[c] = warm ? 3.0 : -1.0;
        if (warm)
            oc_fill_atm(m, 6.0, 5e-3, 2.0, 1.0, 400.0, 330.0, 40.0);
        else
            oc_fill_atm(m, -15.0 + 5.0 * sin(2 * M_PI * h / 24.0), 6e-4, 2.0, 1.0, 0.0, 200.0, 40.0);
        set_snowfall(m, warm ? 0.0 : 3e-5); /* 2.6 mm of water a day */
        rc = sph_model_step(m, &st);
        CHECK(rc == SPH_STEP_OK, "step %d: %s %s (%g vs %g)", h, st.quantity, st.what, st.value, st.limit);
        const sph_budget *b = sph_model_budget(m);
        worst[0] = fmax(worst[0], sph_budget_energy_residual(b));
        worst[1] = fmax(worst[1], sph_budget_water_residual(b));
        worst[2] = fmax(worst[2], sph_budget_salt_residual(b));
        const sph_particles *P = sph_model_particles(m);
        for (size_t k = 0; k < P->n; k++)
            tsmin = fmin(tsmin, P->snow[k] > 0.0 ? P->tsnow[k] : 0.0);
    }
    const sph_budget *b = sph_model_budget(m);
    printf("snow season 30 d: created %ld merged %ld outflow %ld, %zu now, coldest snow %.2f C; residuals "
           "energy %.2e water %.2e salt %.2e\n",
           b->created_particles, b->merged_particles, b->removed_particles, sph_model_particles(m)->n, tsmin,
           worst[0], worst[1], worst[2]);
    CHECK(b->created_particles > 0 && b->merged_particles > 0, "creation and merging happened");
    CHECK(b->outflow > 0.0, "ice left through the open edge");
    CHECK(tsmin < -1.0, "the snow had a temperature of its own (%.2f C)", tsmin);
    CHECK(worst[0] < 1e-12, "energy budget closes: %g", worst[0]);
    CHECK(worst[1] < 1e-12, "water budget closes: %g", worst[1]);
    CHECK(worst[2] < 1e-12, "salt budget closes: %g", worst[2]);
    sph_model_free(m);
}

int main(void)
{
    test_one_step(0.0);
    test_one_step(1e-4);
    test_season();
    return check_summary("test_ocean_snow_enthalpy");
}
