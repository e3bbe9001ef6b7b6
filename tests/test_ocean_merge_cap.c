/* The merged particles' size cap (issue 20; model.new_ice.merge_max_size,
 * docs/ocean.md "Merging"). A merged particle stays thin, so without a cap
 * it merges again every thermodynamic step: footprints 2, 4, 8, ...
 * lattice cells, smoothing lengths sqrt(2), 2, 2.8, ... times a new
 * particle's. A 6 x 6 block of thin particles (5 cm) on the seeding
 * lattice (1 km), each a lattice cell, at rest, merging on with reach
 * 1.05 footprint sides, 24 steps. With the cap k (2, the default, and 3):
 *  - every footprint <= (k ds)^2 and every smoothing length
 *    <= k sml_factor ds, checked after every step;
 *  - at least 36 / k^2 particles remain (a merged particle holds at most
 *    k^2 lattice cells of ice), and merging did happen;
 *  - energy, water and salt of ice plus ocean conserved;
 * and a compacted pack (run_compact) whose reference smoothing length
 * sml0 must stay within the cap as well. */
#include "check.h"
#include "core/model.h"
#include "core/ocean.h"
#include "ocean_column.h"

/* A model of 64 slots over one 20 km mixed-layer cell; NULL (and a
 * failed check) when it cannot be built. */
static sph_model *merge_model(const sph_params *p, double ds)
{
    sph_model *m = sph_model_create(p, 64, NULL);
    sph_ocean_grid g = {1, 1, 0.0, 0.0, 2e4, 2e4, 0.5 * ds, 0.5 * ds, ds};
    int ok = m && sph_model_ocean_create(m, &g) == SPH_STEP_OK;
    CHECK(ok, "model");
    if (!ok) {
        sph_model_free(m);
        return NULL;
    }
    return m;
}

static void run(double k)
{
    sph_params p;
    oc_params(&p, SPH_THERMO_ZERO_LAYER);
    p.ocean.merge = 1;
    p.ocean.merge_distance = 1.05;
    if (k > 0.0)
        p.ocean.merge_max_size = k;
    else
        k = 2.0; /* the default */
    CHECK(p.ocean.merge_max_size == k, "merge_max_size %g", p.ocean.merge_max_size);
    const double ds = 1000.0;
    sph_model *m = merge_model(&p, ds);
    if (!m)
        return;
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, &p, 6, 6, 7.5 * ds, 7.5 * ds, ds, 0.05, 1.0, 40.0);
    double m0 = 0.0;
    for (size_t q = 0; q < P->n; q++) {
        P->mass[q] = p.thermo.rho_i * 0.05 * ds * ds; /* footprint one lattice cell */
        sph_thermo_init_particle(&p.thermo, P, q, -2.0);
        m0 += P->mass[q];
    }
    const double h0 = p.sml_factor * ds;
    oc_fill_atm(m, -2.0, 3e-3, 0.0, 0.0, 0.0, 300.0, 40.0);
    sph_status st;
    CHECK(sph_model_init(m, &st) == SPH_STEP_OK, "init: %s", st.what);
    double fmx = 0.0, hmx = 0.0;
    for (int s = 0; s < 24; s++) {
        oc_fill_atm(m, -2.0, 3e-3, 0.0, 0.0, 0.0, 300.0, 40.0);
        int rc = sph_model_step(m, &st);
        CHECK(rc == SPH_STEP_OK, "step %d: %s %s", s, st.quantity, st.what);
        if (rc != SPH_STEP_OK)
            break;
        for (size_t q = 0; q < P->n; q++) {
            fmx = fmax(fmx, P->mass[q] / (p.thermo.rho_i * P->conc[q] * P->thick[q]));
            hmx = fmax(hmx, P->sml[q]);
        }
    }
    const sph_budget *b = sph_model_budget(m);
    double m1 = 0.0;
    for (size_t q = 0; q < P->n; q++)
        m1 += P->mass[q];
    printf("merge cap %g: %zu particles of 36 after 24 h, %ld merged; largest footprint %.3f lattice cells, "
           "smoothing length %.3f h0\n",
           k, P->n, b->merged_particles, fmx / (ds * ds), hmx / h0);
    CHECK(b->merged_particles > 0, "merging happened");
    CHECK(fmx <= k * k * ds * ds * (1.0 + 1e-9), "footprint %.4g lattice cells <= %g", fmx / (ds * ds), k * k);
    CHECK(hmx <= k * h0 * (1.0 + 1e-9), "smoothing length %.4g h0 <= %g", hmx / h0, k);
    CHECK((double)P->n >= 36.0 / (k * k), "%zu particles >= 36 / k^2", P->n);
    CHECK(m1 > 0.9 * m0 && m1 < 1.1 * m0, "the ice is still there (%g of its mass)", m1 / m0);
    CHECK(sph_budget_energy_residual(b) < 1e-12, "energy budget %g", sph_budget_energy_residual(b));
    CHECK(sph_budget_water_residual(b) < 1e-12, "water budget %g", sph_budget_water_residual(b));
    CHECK(sph_budget_salt_residual(b) < 1e-12, "salt budget %g", sph_budget_salt_residual(b));
    sph_model_free(m);
}

/* A compacted pack: 6 x 6 thin particles 0.5 ds apart, each a quarter of
 * a lattice cell, their smoothing lengths on the floor 0.5 h0 (sml0 h0).
 * The footprint cap alone would let 16 merge, the current smoothing
 * length's as many (sqrt(16) 0.5 h0 = 2 h0); the reference length sml0,
 * which bounds the variable h (sml_max_factor x sml0), must stay <= k h0
 * too: at most 4 of them in one particle. */
static void run_compact(void)
{
    sph_params p;
    oc_params(&p, SPH_THERMO_ZERO_LAYER);
    p.ocean.merge = 1;
    p.ocean.merge_distance = 1.05;
    const double ds = 1000.0, h0 = p.sml_factor * ds;
    sph_model *m = merge_model(&p, ds);
    if (!m)
        return;
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, &p, 6, 6, 8.25 * ds, 8.25 * ds, 0.5 * ds, 0.05, 1.0, 40.0);
    for (size_t q = 0; q < P->n; q++) {
        P->mass[q] = p.thermo.rho_i * 0.05 * 0.25 * ds * ds;
        P->sml0[q] = h0;
        P->sml[q] = 0.5 * h0;
        sph_thermo_init_particle(&p.thermo, P, q, -2.0);
    }
    oc_fill_atm(m, -2.0, 3e-3, 0.0, 0.0, 0.0, 300.0, 40.0);
    sph_status st;
    CHECK(sph_model_init(m, &st) == SPH_STEP_OK, "init: %s", st.what);
    for (size_t q = 0; q < P->n; q++) { /* compacted 4 x from the reference: h = sml0 sqrt(dens0 / dens) = 0.5 sml0 */
        P->dens0[q] = 0.25 * P->dens[q];
        P->sml[q] = 0.5 * h0;
    }
    double h0mx = 0.0;
    for (int s = 0; s < 12; s++) {
        oc_fill_atm(m, -2.0, 3e-3, 0.0, 0.0, 0.0, 300.0, 40.0);
        int rc = sph_model_step(m, &st);
        CHECK(rc == SPH_STEP_OK, "step %d: %s %s", s, st.quantity, st.what);
        if (rc != SPH_STEP_OK)
            break;
        for (size_t q = 0; q < P->n; q++)
            h0mx = fmax(h0mx, P->sml0[q]);
    }
    printf("merge cap, compacted pack: %zu particles of 36, %ld merged, largest sml0 %.3f h0\n", P->n,
           sph_model_budget(m)->merged_particles, h0mx / h0);
    CHECK(sph_model_budget(m)->merged_particles > 0, "merging happened");
    CHECK(h0mx <= 2.0 * h0 * (1.0 + 1e-9), "reference smoothing length %.4g h0 <= 2", h0mx / h0);
    CHECK(P->n >= 9, "%zu particles >= 36 / 4", P->n);
    sph_model_free(m);
}

int main(void)
{
    run(0.0);
    run(3.0);
    run_compact();
    return check_summary("test_ocean_merge_cap");
}
