/* A particle whose footprint covers several cells of the mixed layer
 * exchanges with all of them in proportion to the footprint's overlap
 * with each (issue 20, the drained cell of bench_season; docs/ocean.md,
 * "The footprint over the cells").
 *
 * One particle of concentration 1 on a 3 x 3 grid of 10 km cells, its
 * footprint m / (rho_i A h) = 20 km x 20 km centred at (13, 16) km: the
 * square [3, 23] x [6, 26] km overlaps the columns of cells by 7, 10 and
 * 3 km and the rows by 4, 10 and 6 km, so the weights are
 * w(i, j) = ox(i) oy(j) / 400 (written out here from the geometry). The
 * cells start at different temperatures a little above freezing (-1.728 C). After one step:
 *  - the particle's SST is sum w T, its ice-ocean heat flux sum w F_c with
 *    F_c = min(246 (T_c - Tf), H_c (T_c - Tf) / (dt w_c foot)) (each cell
 *    gives at most what brings it to freezing);
 *  - the heat and water the particle handed the cells (acc_e, acc_w) are
 *    w x their sums, and the water sums to minus the particle's mass
 *    change;
 *  - energy, water and salt of ice plus ocean close to round-off;
 *  - with a land mask that makes the western column land (sea fraction 0,
 *    counted as SPH_OCEAN_MIN_SEAFRAC), the weights are ox oy s / sum;
 *  - a particle that melts out in the step hands its accumulated fluxes
 *    (ocean_fluxes on) to the cells in the same proportions.
 * Before the fix everything went to the cell of the particle's centre. */
#include "check.h"
#include "core/model.h"
#include "core/ocean.h"
#include "ocean_column.h"

#define FOOT 4e8 /* m^2: 20 km x 20 km */

static const double OX[3] = {7e3, 10e3, 3e3}, OY[3] = {4e3, 10e3, 6e3};

static void base(sph_params *p)
{
    oc_params(p, SPH_THERMO_MULTI_LAYER);
}

/* The model with the one particle (thickness h); cell c at T[c], 20 m, 32 psu. */
static sph_model *one_particle(const sph_params *p, const sph_landmask *mk, double h, const double T[9])
{
    sph_model *m = sph_model_create(p, 16, mk);
    sph_ocean_grid g = {3, 3, 0.0, 0.0, 1e4, 1e4, 1250.0, 1250.0, 2500.0};
    if (!m || sph_model_ocean_create(m, &g) != SPH_STEP_OK) {
        sph_model_free(m);
        return NULL;
    }
    for (size_t c = 0; c < 9; c++)
        sph_ocean_set_cell(sph_model_ocean(m), c, 20.0, 32.0, T[c]);
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, p, 1, 1, 13e3, 16e3, 2e4, h, 1.0, 40.0);
    P->mass[0] = p->thermo.rho_i * 1.0 * h * FOOT;
    sph_thermo_init_particle(&p->thermo, P, 0, -20.0);
    return m;
}

static void weights(const double s[9], double w[9])
{
    double sum = 0.0;
    for (int c = 0; c < 9; c++)
        sum += (w[c] = OX[c % 3] * OY[c / 3] * s[c]);
    for (int c = 0; c < 9; c++)
        w[c] /= sum;
}

static void check_shares(const double *a, const double w[9], double tol, const char *what)
{
    double sum = 0.0;
    for (int c = 0; c < 9; c++)
        sum += a[c];
    CHECK(sum != 0.0, "%s: something was exchanged", what);
    for (int c = 0; c < 9; c++)
        CHECK(fabs(a[c] / sum - w[c]) <= tol, "%s: share of cell %d: %.15g, want %.15g", what, c, a[c] / sum, w[c]);
}

static void test_growth(int coast)
{
    sph_params p;
    base(&p);
    /* coast: the western column of cells is land (mask of 5 km cells) */
    static unsigned char land[6 * 6];
    for (int j = 0; j < 6; j++)
        for (int i = 0; i < 6; i++)
            land[j * 6 + i] = i < 2;
    sph_landmask mk = {6, 6, 0.0, 0.0, 5000.0, 5000.0, land, 0};
    const double T[9] = {-1.70, -1.65, -1.60, -1.55, -1.50, -1.45, -1.72, -1.68, -1.40};
    sph_model *m = one_particle(&p, coast ? &mk : NULL, 0.3, T);
    CHECK(m != NULL, "model");
    if (!m)
        return;
    sph_ocean *o = sph_model_ocean(m);
    oc_fill_atm(m, -20.0, 6e-4, 3.0, 4.0, 0.0, 180.0, 40.0);
    sph_status st;
    CHECK(sph_model_init(m, &st) == SPH_STEP_OK, "init: %s", st.what);
    double s[9], w[9];
    for (int c = 0; c < 9; c++)
        s[c] = coast && c % 3 == 0 ? SPH_OCEAN_MIN_SEAFRAC : 1.0;
    weights(s, w);
    double m0 = sph_model_particles(m)->mass[0];
    /* what the particle sees: written out from the cells */
    double sst = 0.0, fw = 0.0, Tf = -0.054 * 32.0;
    for (int c = 0; c < 9; c++) {
        double H = 1026.0 * 3990.0 * 20.0 * 1e8 * s[c];
        double dT = fmax(T[c] - Tf, 0.0);
        sst += w[c] * T[c];
        fw += w[c] * fmin(246.0 * dT, H * dT / (3600.0 * w[c] * FOOT));
    }
    CHECK(sph_model_step(m, &st) == SPH_STEP_OK, "step: %s %s", st.quantity, st.what);
    sph_particles *P = sph_model_particles(m);
    CHECK(P->n == 1, "the particle is still there");
    CHECK_CLOSE(P->sst[0], sst, 1e-12, 0, "SST under the particle: footprint mean of the cells");
    CHECK_CLOSE(P->fw[0], fw, 1e-12, 0, "ice-ocean heat flux: footprint mean of the cells' fluxes");
    check_shares(o->acc_e, w, 1e-12, coast ? "heat (coast)" : "heat");
    check_shares(o->acc_w, w, 1e-12, coast ? "water (coast)" : "water");
    double wsum = 0.0;
    for (int c = 0; c < 9; c++)
        wsum += o->acc_w[c];
    CHECK_CLOSE(wsum, m0 - P->mass[0], 1e-13, 0, "the cells got the water the particle lost");
    CHECK(m0 - P->mass[0] < 0.0, "the ice grew (%g kg)", P->mass[0] - m0);
    const sph_budget *b = sph_model_budget(m);
    CHECK(sph_budget_energy_residual(b) < 1e-12, "energy budget %g", sph_budget_energy_residual(b));
    CHECK(sph_budget_water_residual(b) < 1e-12, "water budget %g", sph_budget_water_residual(b));
    CHECK(sph_budget_salt_residual(b) < 1e-12, "salt budget %g", sph_budget_salt_residual(b));
    printf("footprint over 9 cells%s: SST %.6f C (centre cell %.2f), fw %.3f W/m2, water shares %.4f .. %.4f\n",
           coast ? " (coast)" : "", P->sst[0], T[4], P->fw[0], o->acc_w[6] / wsum, o->acc_w[4] / wsum);
    sph_model_free(m);
}

/* Thin ice over warm water under warm air melts out in one step. */
static void test_meltout(void)
{
    sph_params p;
    base(&p);
    p.thermo.ocean_fluxes = 1;
    const double T[9] = {3, 3, 3, 3, 3, 3, 3, 3, 3};
    sph_model *m = one_particle(&p, NULL, 0.005, T);
    CHECK(m != NULL, "model");
    if (!m)
        return;
    sph_ocean *o = sph_model_ocean(m);
    oc_fill_atm(m, 5.0, 5e-3, 3.0, 4.0, 300.0, 320.0, 40.0);
    sph_status st;
    CHECK(sph_model_init(m, &st) == SPH_STEP_OK, "init: %s", st.what);
    sph_ocean_clear_fluxes(o);
    CHECK(sph_model_step(m, &st) == SPH_STEP_OK, "step: %s %s", st.quantity, st.what);
    CHECK(sph_model_particles(m)->n == 0, "the particle melted out (%zu left)", sph_model_particles(m)->n);
    double s[9] = {1, 1, 1, 1, 1, 1, 1, 1, 1}, w[9];
    weights(s, w);
    /* no frazil above freezing: the cells' water accumulators hold only the particle's */
    check_shares(o->ofx_water, w, 1e-12, "melted-out particle's fresh water");
    check_shares(o->ofx_salt, w, 1e-12, "melted-out particle's salt");
    check_shares(o->ofx_heat_ice, w, 1e-12, "melted-out particle's heat under the ice");
    const sph_budget *b = sph_model_budget(m);
    CHECK(sph_budget_energy_residual(b) < 1e-12, "energy budget %g", sph_budget_energy_residual(b));
    CHECK(sph_budget_water_residual(b) < 1e-12, "water budget %g", sph_budget_water_residual(b));
    sph_model_free(m);
}

int main(void)
{
    test_growth(0);
    test_growth(1);
    test_meltout();
    return check_summary("test_ocean_footprint");
}
