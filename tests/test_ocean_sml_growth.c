/* The smoothing length of ice that grows in place (issue 20; docs/ocean.md,
 * "Footprints and continuity density"). The variable smoothing length is
 * h = h0 sqrt(M0 / M) (seed eq. 10), with M the mass per area and M0 its
 * reference. At rest the footprint m / M of a particle does not change
 * (continuity at zero divergence; thermodynamics keeps the footprint and
 * scales M with the mass), so the particle spacing and h must not change
 * either: h = h0 sqrt(a / a0) = h0. With the mixed layer on, new particles
 * are born 5 cm thick and grow tenfold; before M0 followed the mass, their
 * h fell as h0 sqrt(m0 / m) to the floor sml_min_factor h0, the kernel
 * lost its neighbours, and continuity inflated the footprints over a cell
 * to 76-86 times its area (bench/bench_season.c with
 * BENCH_SEASON_DENSITY=continuity).
 *
 * Case: a 6 x 6 block of 5 cm ice on a 1 km lattice, concentration 1 (no
 * new particles: creation is off), at rest in free drift without wind, over one
 * mixed-layer cell, -25 C and dark for 48 hourly steps (the ice about
 * doubles its mass, more than 1.5 asserted). Asserted:
 *  - continuity, mixed layer on: every h = h0 sqrt(a / a0) to 1e-9
 *    relative, with a = m / M at the moment h is set (the footprint
 *    identity above), and so equal to its start;
 *  - mixed layer off (today's operational path, unchanged): the seeded
 *    reference is kept, h = h0 sqrt(M0 / M) to 1e-9 (continuity, where
 *    M scales with m at a fixed footprint: h falls to 0.63 h0);
 *  - summation density (M from the kernel sum; the block's edge particles
 *    have leads that freeze, so masses and M grow a little unevenly): with
 *    the mixed layer h stays within 0.85-1.25 of its start, without it
 *    h falls below 0.7 (0.50-0.62, the floor sml_min_factor included).
 * The budgets of ice plus ocean close to 1e-12 with the mixed layer. */
#include "check.h"
#include "core/model.h"
#include "core/ocean.h"
#include "ocean_column.h"

static void run(int summation, int ocean)
{
    sph_params p;
    oc_params(&p, SPH_THERMO_ZERO_LAYER);
    p.ocean.mixed_layer = ocean;
    p.summation_density = summation;
    const double ds = 1000.0;
    sph_model *m = sph_model_create(&p, 64, NULL);
    sph_ocean_grid g = {1, 1, 0.0, 0.0, 2e4, 2e4, 0.5 * ds, 0.5 * ds, ds};
    int ok = m && (!ocean || sph_model_ocean_create(m, &g) == SPH_STEP_OK);
    CHECK(ok, "model");
    if (!ok) {
        sph_model_free(m);
        return;
    }
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, &p, 6, 6, 7.5 * ds, 7.5 * ds, ds, 0.05, 1.0, 40.0);
    for (size_t q = 0; q < P->n; q++) {
        P->mass[q] = p.thermo.rho_i * 0.05 * ds * ds; /* footprint one lattice cell */
        sph_thermo_init_particle(&p.thermo, P, q, -25.0);
    }
    sph_status st;
    if (ocean)
        oc_fill_atm(m, -25.0, 4e-4, 0.0, 0.0, 0.0, 180.0, 40.0);
    else
        for (size_t q = 0; q < P->n; q++) {
            P->tair[q] = -25.0;
            P->qair[q] = 4e-4;
            P->ua[q] = P->va[q] = P->swdn[q] = 0.0;
            P->lwdn[q] = 180.0;
            P->lat[q] = 40.0;
        }
    CHECK(sph_model_init(m, &st) == SPH_STEP_OK, "init: %s", st.what);
    const size_t n = P->n;
    double h0[36], m0[36], M0[36], mb[36];
    for (size_t q = 0; q < n && q < 36; q++) {
        h0[q] = P->sml[q];
        m0[q] = P->mass[q];
        M0[q] = P->dens[q];
    }
    for (int s = 0; s < 48; s++) {
        for (size_t q = 0; q < n && q < 36; q++)
            mb[q] = P->mass[q]; /* the mass when this step sets h (before its thermodynamics) */
        if (ocean)
            oc_fill_atm(m, -25.0, 4e-4, 0.0, 0.0, 0.0, 180.0, 40.0);
        int rc = sph_model_step(m, &st);
        CHECK(rc == SPH_STEP_OK, "step %d: %s %s", s, st.quantity, st.what);
        if (rc != SPH_STEP_OK)
            break;
    }
    CHECK(P->n == n, "no particle created or removed (%zu of %zu)", P->n, n);
    double grow = 1e30, err = 0.0, hmin = 1e30, hmax = 0.0;
    for (size_t q = 0; q < n && q < 36; q++) {
        double f = P->mass[q] / m0[q];
        grow = fmin(grow, f);
        /* M when the last step set h: summation's from that step's sum
         * (the masses before its thermodynamics); continuity's scaled
         * back from the footprint-keeping update after it */
        double M = summation ? P->dens[q] : P->dens[q] * mb[q] / P->mass[q];
        double want = ocean ? h0[q] * sqrt((mb[q] / M) / (m0[q] / M0[q])) : h0[q] * sqrt(M0[q] / M);
        err = fmax(err, fabs(P->sml[q] - want) / want);
        hmin = fmin(hmin, P->sml[q] / h0[q]);
        hmax = fmax(hmax, P->sml[q] / h0[q]);
    }
    const char *what = summation ? "summation" : "continuity";
    printf("%s, mixed layer %s: mass x %.3f after 48 h; h / h(t0) %.6f-%.6f (%s); largest error %.2e\n", what,
           ocean ? "on" : "off", grow, hmin, hmax, ocean ? "expected h0 sqrt(a / a0), footprint a = m / M" :
           "expected h0 sqrt(M0 / M): the seeded reference", err);
    CHECK(grow > 1.5, "%s: the ice grew (mass x %.3f)", what, grow);
    if (!summation)
        CHECK(err < 1e-9, "%s, mixed layer %s: smoothing length within 1e-9 of %s (%.2e)", what,
              ocean ? "on" : "off", ocean ? "h0 sqrt(a / a0)" : "h0 sqrt(M0 / M)", err);
    else if (ocean) /* the block's edge particles have leads that freeze: M and a vary a little */
        CHECK(hmin > 0.85 && hmax < 1.25, "summation, mixed layer on: h / h(t0) %.4f-%.4f within 0.85-1.25 "
              "(without M0 following the mass: %.4f at most, the run without the mixed layer)", hmin, hmax,
              sqrt(1.0 / grow));
    else
        CHECK(hmax < 0.7, "summation, mixed layer off: h fell with the growth (%.4f at most), as before", hmax);
    if (ocean && !summation)
        CHECK(hmin > 1.0 - 1e-9 && hmax < 1.0 + 1e-9, "continuity at rest: the footprint and h kept (%.9f-%.9f)",
              hmin, hmax);
    if (!ocean && !summation)
        CHECK(hmax < 0.7, "continuity, mixed layer off: h fell with the growth (%.4f), as before", hmax);
    if (ocean) {
        const sph_budget *b = sph_model_budget(m);
        CHECK(sph_budget_energy_residual(b) < 1e-12, "energy budget %g", sph_budget_energy_residual(b));
        CHECK(sph_budget_water_residual(b) < 1e-12, "water budget %g", sph_budget_water_residual(b));
        CHECK(sph_budget_salt_residual(b) < 1e-12, "salt budget %g", sph_budget_salt_residual(b));
    }
    sph_model_free(m);
}

int main(void)
{
    for (int summation = 0; summation < 2; summation++)
        for (int ocean = 1; ocean >= 0; ocean--)
            run(summation, ocean);
    return check_summary("test_ocean_sml_growth");
}
