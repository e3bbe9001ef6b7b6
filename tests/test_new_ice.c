/* The ocean mixed layer and new ice in open water (issue 20, items 1, 2, 5).
 *
 *  - the freezing point against the UNESCO (1983) / Fofonoff & Millard
 *    check values (S 10: -0.542, S 30: -1.638, S 35: -1.922 deg C) and the
 *    linear law -0.054 S;
 *  - a slab above freezing cools at the rate F / (rho_w c_w d), F the
 *    open-water flux of the bulk formulas written out here;
 *  - open-water freeze at -20 C, dark, longwave 180 W/m^2, wind (5, 5),
 *    q 6e-4, no ocean heat flux, from no ice and no particles: thickness at
 *    days 5, 10, 20, 30 within 5 % of Icepack 1.5.3's Bitz-Lipscomb column
 *    (0.27, 0.40, 0.60, 0.75 m; issue 20);
 *  - new particles: where the cell froze, never on land, never inside
 *    existing ice; their mass equals the frazil of the cell, the heat the
 *    open water lost (bulk formulas here) over -q of new ice at Tf;
 *  - conservation over 30 days with creation, merging, removal and
 *    outflow: energy, water and salt of ice plus ocean to round-off. */
#include "check.h"
#include "core/model.h"
#include "core/ocean.h"
#include "ocean_column.h"

#include <string.h>

typedef struct {
    double ta, q, ua, va, sw, lw;
} atm;

/* The same atmosphere over every particle and every cell of the mixed layer. */
static void fill(sph_model *m, const atm *a) { oc_fill_atm(m, a->ta, a->q, a->ua, a->va, a->sw, a->lw, 40.0); }

static void base_params(sph_params *p)
{
    sph_params_default(p);
    p->dt = 3600.0;
    p->thermo_dt = 3600.0;
    p->physics = SPH_PHYSICS_FREE_DRIFT;
    p->coriolis = 0;
    p->Ca = 0.0; /* the wind enters the bulk formulas only: a column */
    p->thermo.model = SPH_THERMO_MULTI_LAYER;
    p->ocean.mixed_layer = 1;
    p->ocean.create = 1;
}

static double ice_thickness(sph_model *m)
{
    sph_particles *P = sph_model_particles(m);
    double v = 0.0, a = 0.0;
    for (size_t k = 0; k < P->n; k++) {
        double foot = P->mass[k] / (900.0 * P->conc[k] * P->thick[k]);
        v += P->mass[k] / 900.0;
        a += P->conc[k] * foot;
    }
    return a > 0 ? v / a : 0.0;
}

static void test_freezing_point(void)
{
    /* UNESCO (1983) check values at p = 0 (Fofonoff & Millard, table of
     * the freezing point; marelac sw_tfreeze check values) */
    CHECK_CLOSE(sph_ocean_freezing_point(SPH_FREEZING_UNESCO, 0.054, 10.0), -0.542, 0, 6e-4, "Tf(10)");
    CHECK_CLOSE(sph_ocean_freezing_point(SPH_FREEZING_UNESCO, 0.054, 30.0), -1.638, 0, 6e-4, "Tf(30)");
    CHECK_CLOSE(sph_ocean_freezing_point(SPH_FREEZING_UNESCO, 0.054, 35.0), -1.922, 0, 6e-4, "Tf(35)");
    CHECK_CLOSE(sph_ocean_freezing_point(SPH_FREEZING_LINEAR, 0.054, 32.0), -1.728, 1e-12, 0, "linear Tf(32)");
}

/* A model on land mask mk with an nx x ny grid of 10 km cells, lattice 2.5 km. */
static sph_model *grid_model(const sph_params *p, size_t cap, const sph_landmask *mk, int nx, int ny)
{
    sph_model *m = sph_model_create(p, cap, mk);
    sph_ocean_grid g = {nx, ny, 0.0, 0.0, 1e4, 1e4, 1250.0, 1250.0, 2500.0};
    int ok = m && sph_model_ocean_create(m, &g) == SPH_STEP_OK;
    CHECK(ok, "model");
    if (!ok)
        sph_model_free(m);
    return ok ? m : NULL;
}

/* One open cell 10 km x 10 km, lattice 2.5 km (16 points), at T0 and
 * S 32 under atmosphere a, initialised; NULL (and a failed check) if not. */
static sph_model *column_start(const sph_params *p, size_t cap, double T0, const atm *a)
{
    sph_model *m = grid_model(p, cap, NULL, 1, 1);
    if (!m)
        return NULL;
    sph_ocean_set_cell(sph_model_ocean(m), 0, p->ocean.depth, 32.0, T0);
    fill(m, a);
    sph_status st;
    int rc = sph_model_init(m, &st);
    CHECK(rc == SPH_STEP_OK, "init: %s", st.what);
    if (rc != SPH_STEP_OK) {
        sph_model_free(m);
        m = NULL;
    }
    return m;
}

static void test_slab_cooling(void)
{
    sph_params p;
    base_params(&p);
    p.ocean.create = 0;
    atm a = {-10.0, 1e-3, 3.0, 4.0, 0.0, 250.0};
    sph_model *m = column_start(&p, 16, 5.0, &a);
    if (!m)
        return;
    sph_status st;
    double H = 1026.0 * 3990.0 * 20.0, T = 5.0, Tlast = T;
    for (int i = 0; i < 24; i++) {
        Tlast = T;
        double T1 = T + ow_flux(T, -10.0, 1e-3, 5.0, 0.0, 250.0) * 3600.0 / H;
        fill(m, &a);
        CHECK(sph_model_step(m, &st) == SPH_STEP_OK, "step: %s %s", st.quantity, st.what);
        if (i == 0)
            CHECK_CLOSE(sph_model_ocean(m)->temp[0] - T, T1 - T, 1e-9, 0, "first-hour cooling of the slab");
        T = T1;
    }
    CHECK_CLOSE(sph_model_ocean(m)->temp[0], T, 1e-9, 0, "slab temperature after a day");
    const double *heat;
    sph_ocean_open_water_fluxes(sph_model_ocean(m), &heat, NULL, NULL);
    CHECK_CLOSE(heat[0], ow_flux(Tlast, -10.0, 1e-3, 5.0, 0.0, 250.0), 1e-12, 0,
                "open-water heat flux into the ocean (the accessor), W/m2");
    const double *fresh, *salt;
    sph_ocean_open_water_fluxes(sph_model_ocean(m), NULL, &fresh, &salt);
    CHECK(fresh[0] == 0.0 && salt[0] == 0.0, "no frazil above freezing: no fresh-water or salt flux");
    sph_model_free(m);
}

/* Heat, water or salt from nowhere fails the step as the mass budget does. */
static void test_budget_violation(void)
{
    sph_params p;
    base_params(&p);
    atm a = {-10.0, 1e-3, 3.0, 4.0, 0.0, 250.0};
    static const char *const which[3] = {"energy", "water", "salt"};
    for (int q = 0; q < 3; q++) {
        sph_model *m = column_start(&p, 16, 2.0, &a);
        if (!m)
            return;
        sph_status st;
        fill(m, &a);
        CHECK(sph_model_step(m, &st) == SPH_STEP_OK, "step");
        sph_ocean *o = sph_model_ocean(m);
        double *x = q == 0 ? &o->temp[0] : q == 1 ? &o->water[0] : &o->salt[0];
        *x += q == 0 ? 1e-3 : 1e-6 * *x; /* a millikelvin; a millionth of the water or salt */
        fill(m, &a);
        int rc = sph_model_step(m, &st);
        CHECK(rc == SPH_STEP_FATAL && st.kind == SPH_FAULT_MASS && strstr(st.quantity, which[q]),
              "%s from nowhere fails the step: rc %d %s", which[q], rc, st.quantity);
        sph_model_free(m);
    }
}

static void test_open_water_freeze(void)
{
    sph_params p;
    base_params(&p);
    double Tf = -0.054 * 32.0;
    atm a = {-20.0, 6e-4, 5.0, 5.0, 0.0, 180.0};
    sph_model *m = column_start(&p, 64, Tf, &a);
    if (!m)
        return;
    sph_status st;
    CHECK(sph_model_particles(m)->n == 0, "starts with no particles");
    const double want[4] = {0.27, 0.40, 0.60, 0.75};
    const int day[4] = {5, 10, 20, 30};
    int d = 0;
    /* the frazil at creation: the open water's heat loss (at Tf, constant
     * forcing) over -q of new ice */
    double F = ow_flux(Tf, -20.0, 6e-4, hypot(5, 5), 0, 180.0);
    int created_step = -1;
    double created_mass = 0.0;
    for (int h = 1; h <= 30 * 24; h++) {
        fill(m, &a);
        int rc = sph_model_step(m, &st);
        CHECK(rc == SPH_STEP_OK, "step %d: %s %s", h, st.quantity, st.what);
        if (rc != SPH_STEP_OK)
            break;
        if (created_step < 0 && sph_model_particles(m)->n > 0) {
            created_step = h;
            sph_particles *P = sph_model_particles(m);
            for (size_t k = 0; k < P->n; k++)
                created_mass += P->mass[k];
        }
        if (d < 4 && h == day[d] * 24) {
            double th = ice_thickness(m);
            printf("open-water freeze: day %d thickness %.3f m (Icepack BL %.2f)\n", day[d], th, want[d]);
            CHECK_CLOSE(th, want[d], 0.05, 0, "thickness against Icepack 1.5.3 Bitz-Lipscomb");
            d++;
        }
    }
    CHECK(created_step > 0, "particles created");
    CHECK(sph_model_particles(m)->n == 16 || created_step < 0, "one particle per lattice point: %zu",
          sph_model_particles(m)->n);
    /* per m^2: each hour the open water loses F; below the freezing point
     * of the slab's salinity the deficit freezes at -q_new; the brine the
     * frazil leaves raises S, so the slab also cools to the lower Tf */
    oc_slab sl = {Tf, 1026.0 * 20.0, 1026.0 * 20.0 * 32.0 / 1000.0, 1026.0 * 3990.0 * 20.0};
    double frz = 0.0;
    for (int n = 0; n < created_step; n++)
        frz += oc_slab_step(&sl, ow_flux(sl.T, -20.0, 6e-4, hypot(5, 5), 0, 180.0), 3600.0, 7);
    (void)F;
    CHECK_CLOSE(created_mass, frz * 1e8, 1e-9, 0, "created mass = the frazil of the open water");
    const sph_budget *b = sph_model_budget(m);
    CHECK(sph_budget_energy_residual(b) < 1e-12, "energy residual %g", sph_budget_energy_residual(b));
    CHECK(sph_budget_water_residual(b) < 1e-12, "water residual %g", sph_budget_water_residual(b));
    CHECK(sph_budget_salt_residual(b) < 1e-12, "salt residual %g", sph_budget_salt_residual(b));
    sph_model_free(m);
}

/* Three cells of 10 km in a row; the western 5 km is land (mask of 5 km
 * cells); the west half of cell 1 holds 0.5 m ice on its lattice points;
 * cell 2 is held warm by restoring. Cold air everywhere. */
static void test_placement(void)
{
    sph_params p;
    base_params(&p);
    p.ocean.restore_days = 0.1;
    static unsigned char land[6 * 2] = {1, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0};
    sph_landmask mk = {6, 2, 0.0, 0.0, 5000.0, 5000.0, land, 1};
    sph_model *m = grid_model(&p, 256, &mk, 3, 1);
    if (!m)
        return;
    sph_ocean *o = sph_model_ocean(m);
    CHECK_CLOSE(o->seafrac[0], 0.5, 1e-12, 0, "sea fraction of the coastal cell");
    for (size_t c = 0; c < 3; c++)
        sph_ocean_set_cell(o, c, 20.0, 32.0, c == 2 ? 5.0 : -1.728);
    o->sst_restore[2] = 5.0;
    sph_particles *P = sph_model_particles(m);
    size_t n0 = 0;
    for (int b = 0; b < 4; b++)
        for (int a = 0; a < 2; a++, n0++) {
            P->x[n0] = 11250.0 + 2500.0 * a;
            P->y[n0] = 1250.0 + 2500.0 * b;
            P->thick[n0] = 0.5;
            P->conc[n0] = 1.0;
            P->mass[n0] = 900.0 * 0.5 * 2500.0 * 2500.0;
            P->sml[n0] = 2500.0;
            P->id[n0] = (long)n0 + 100;
        }
    P->n = n0;
    for (size_t k = 0; k < n0; k++)
        sph_thermo_init_particle(&p.thermo, P, k, -20.0);
    atm a = {-20.0, 6e-4, 5.0, 5.0, 0.0, 180.0};
    fill(m, &a);
    sph_status st;
    CHECK(sph_model_init(m, &st) == SPH_STEP_OK, "init: %s", st.what);
    double frazil_before[3] = {0, 0, 0}, new_before = 0.0;
    int done = 0;
    for (int h = 0; h < 48 && !done; h++) {
        for (int c = 0; c < 3; c++)
            frazil_before[c] = o->frazil[c];
        new_before = sph_model_budget(m)->new_ice;
        size_t nb = P->n;
        fill(m, &a);
        CHECK(sph_model_step(m, &st) == SPH_STEP_OK, "step: %s %s", st.quantity, st.what);
        if (P->n > nb) {
            done = 1;
            double made = 0.0;
            size_t in0 = 0, in1 = 0;
            for (size_t k = 0; k < P->n; k++) {
                if (P->id[k] >= 100 && P->id[k] < 108)
                    continue;
                made += P->mass[k];
                CHECK(P->id[k] >= 108, "new ids continue from the largest: %ld", P->id[k]);
                CHECK(P->x[k] > 5000.0, "no new particle on land: x %g", P->x[k]);
                CHECK(P->x[k] < 20000.0, "none in the warm cell: x %g", P->x[k]);
                for (size_t j = 0; j < P->n; j++)
                    if (P->id[j] >= 100 && P->id[j] < 108)
                        CHECK(hypot(P->x[k] - P->x[j], P->y[k] - P->y[j]) >= 2499.0,
                              "no new particle inside existing ice");
                in0 += P->x[k] < 1e4;
                in1 += P->x[k] >= 1e4;
            }
            CHECK(in0 == 8 && in1 == 8, "the free sea lattice points: %zu + %zu (want 8 + 8)", in0, in1);
            /* the cells' frazil of this step: all of it became particles */
            CHECK(o->frazil[0] == 0.0 && o->frazil[1] == 0.0, "frazil used up");
            CHECK_CLOSE(made, sph_model_budget(m)->new_ice - new_before, 1e-12, 0, "created mass in the budget");
            CHECK(made > frazil_before[0] + frazil_before[1], "created mass includes this hour's frazil");
        }
    }
    CHECK(done, "new ice created");
    CHECK(o->frazil[2] == 0.0 && o->temp[2] > 0.0, "the warm cell does not freeze: T %g", o->temp[2]);
    sph_model_free(m);
}

/* 30 days on a 2 x 2 grid of 10 km cells with a land corner: cold, a warm
 * sunny spell with restoring (melt-out, removal), cold again; ice drifts
 * out through the open edge; merging on. */
static void test_conservation(void)
{
    sph_params p;
    base_params(&p);
    p.Ca = 1.2e-3;
    p.ocean.restore_days = 5.0;
    p.ocean.merge = 1;
    p.ocean.merge_distance = 1.05;
    p.ocean.freezing = SPH_FREEZING_UNESCO;
    p.thermo.model = SPH_THERMO_AUTO;
    static unsigned char land[4 * 4] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0};
    sph_landmask mk = {4, 4, 0.0, 0.0, 5000.0, 5000.0, land, 0};
    sph_model *m = grid_model(&p, 4000, &mk, 2, 2);
    if (!m)
        return;
    sph_ocean *o = sph_model_ocean(m);
    for (size_t c = 0; c < 4; c++) {
        sph_ocean_set_cell(o, c, c == 1 ? 5.0 : 25.0, 31.0, -1.0);
        o->sst_restore[c] = -1.0;
        o->sss_restore[c] = 31.5;
    }
    atm cold = {-15.0, 6e-4, 2.0, 1.0, 0.0, 200.0};
    atm warm = {6.0, 5e-3, 2.0, 1.0, 400.0, 330.0};
    fill(m, &cold);
    sph_status st;
    CHECK(sph_model_init(m, &st) == SPH_STEP_OK, "init: %s", st.what);
    size_t nmax = 0, nmin_warm = 100000;
    int ok = 1;
    double worst[3] = {0, 0, 0};
    for (int h = 0; h < 30 * 24 && ok; h++) {
        int day = h / 24;
        const atm *a = day >= 6 && day < 12 ? &warm : &cold;
        for (size_t c = 0; c < 4; c++)
            o->sst_restore[c] = a == &warm ? 3.0 : -1.0;
        fill(m, a);
        int rc = sph_model_step(m, &st);
        CHECK(rc == SPH_STEP_OK, "step %d: %s %s (%g vs %g)", h, st.quantity, st.what, st.value, st.limit);
        ok = rc == SPH_STEP_OK;
        size_t n = sph_model_particles(m)->n;
        if (day < 6)
            nmax = n > nmax ? n : nmax;
        if (day >= 10 && day < 12)
            nmin_warm = n < nmin_warm ? n : nmin_warm;
        const sph_budget *b = sph_model_budget(m);
        worst[0] = fmax(worst[0], sph_budget_energy_residual(b));
        worst[1] = fmax(worst[1], sph_budget_water_residual(b));
        worst[2] = fmax(worst[2], sph_budget_salt_residual(b));
    }
    const sph_budget *b = sph_model_budget(m);
    printf("conservation 30 d: created %ld merged %ld outflow %ld particles, max %zu, min in the thaw %zu, "
           "now %zu; residuals energy %.2e water %.2e salt %.2e\n",
           b->created_particles, b->merged_particles, b->removed_particles, nmax, nmin_warm,
           sph_model_particles(m)->n, worst[0], worst[1], worst[2]);
    CHECK(b->created_particles > 0 && b->merged_particles > 0, "creation and merging happened");
    CHECK(nmin_warm < nmax, "the thaw removed melted particles (%zu < %zu)", nmin_warm, nmax);
    CHECK(b->outflow > 0.0 && b->energy_outflow < 0.0, "ice left through the open edge");
    CHECK(b->energy_restoring != 0.0 && b->salt_restoring != 0.0, "restoring acted");
    CHECK(worst[0] < 1e-12, "energy budget closes: %g", worst[0]);
    CHECK(worst[1] < 1e-12, "water budget closes: %g", worst[1]);
    CHECK(worst[2] < 1e-12, "salt budget closes: %g", worst[2]);
    /* no particle on land */
    sph_particles *P = sph_model_particles(m);
    for (size_t k = 0; k < P->n; k++)
        CHECK(!(P->x[k] < 5000.0 && P->y[k] >= 15000.0 && P->y[k] < 20000.0), "particle on land");
    sph_model_free(m);
}

/* Two cells of 10 km in a row under an OPEN land mask that covers only
 * x < 15 km (all sea): beyond an open mask's grid particles leave as
 * outflow, so that water is not the model's to freeze: the second cell's
 * sea fraction is 1/2 and no particle is created beyond x = 15 km. */
static void test_open_mask_edge(void)
{
    sph_params p;
    base_params(&p);
    static unsigned char land[3 * 2] = {0, 0, 0, 0, 0, 0};
    sph_landmask mk = {3, 2, 0.0, 0.0, 5000.0, 5000.0, land, 0};
    sph_model *m = grid_model(&p, 256, &mk, 2, 1);
    if (!m)
        return;
    sph_ocean *o = sph_model_ocean(m);
    CHECK_CLOSE(o->seafrac[0], 1.0, 1e-12, 0, "sea fraction inside the mask");
    CHECK_CLOSE(o->seafrac[1], 0.5, 1e-12, 0, "sea fraction of the cell half beyond the open mask");
    for (size_t c = 0; c < 2; c++)
        sph_ocean_set_cell(o, c, 20.0, 32.0, -1.728);
    atm a = {-20.0, 6e-4, 0.0, 0.0, 0.0, 180.0};
    fill(m, &a);
    sph_status st;
    CHECK(sph_model_init(m, &st) == SPH_STEP_OK, "init: %s", st.what);
    sph_particles *P = sph_model_particles(m);
    size_t beyond = 0, in1 = 0;
    for (int h = 0; h < 48 && P->n == 0; h++) {
        fill(m, &a);
        CHECK(sph_model_step(m, &st) == SPH_STEP_OK, "step: %s %s", st.quantity, st.what);
    }
    CHECK(P->n > 0, "new ice created");
    for (size_t k = 0; k < P->n; k++) {
        beyond += P->x[k] >= 15000.0;
        in1 += P->x[k] >= 1e4 && P->x[k] < 15000.0;
    }
    CHECK(beyond == 0, "no new particle beyond the open mask: %zu", beyond);
    CHECK(P->n == 24 && in1 == 8, "the lattice points inside the mask: %zu in all, %zu in cell 1 (want 24, 8)",
          P->n, in1);
    sph_model_free(m);
}

int main(void)
{
    test_freezing_point();
    test_slab_cooling();
    test_budget_violation();
    test_open_water_freeze();
    test_placement();
    test_open_mask_edge();
    test_conservation();
    return check_summary("test_new_ice");
}
