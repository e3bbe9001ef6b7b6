/* Particle-level thermodynamics: the mass budget closes to round-off,
 * 1 and 2 OpenMP threads give bit-identical results, a particle that melts
 * completely ends with mass 0 and its mass in the budget, bad forcing is
 * fatal and names the quantity, bad parameters are named. */
#include "check.h"
#include "core/thermo.h"

#include <omp.h>
#include <string.h>

#define NP 64
#define AREA 1.0e6 /* footprint, m^2 */

static sph_particles *make_set(const sph_thermo_params *p)
{
    sph_particles *P = sph_particles_create(NP, p->nlayers);
    P->n = NP;
    for (size_t k = 0; k < NP; k++) {
        double u = (double)k / (NP - 1);
        P->id[k] = (long)k;
        P->thick[k] = 0.05 + 1.95 * u * u;
        P->conc[k] = 0.3 + 0.7 * fmod(u * 7.3, 1.0);
        P->snow[k] = (k % 3 == 0) ? 0.05 : 0.0;
        P->mass[k] = p->rho_i * P->conc[k] * P->thick[k] * AREA;
        P->sml[k] = 1000.0;
        P->ua[k] = 3.0 + 5.0 * u;
        P->va[k] = -2.0;
        if (k % 2 == 0) { /* Bohai-like freezing night: leads at freezing form new ice */
            P->tair[k] = -15.0 + 10.0 * u;
            P->qair[k] = 0.0008;
            P->swdn[k] = 0.0;
            P->lwdn[k] = 200.0;
            P->sst[k] = sph_freezing_point(p);
            P->fw[k] = NAN;
        } else { /* spring thaw: warm air, sun, warm leads melt laterally */
            P->tair[k] = 3.0 + 4.0 * u;
            P->qair[k] = 0.004;
            P->swdn[k] = 350.0;
            P->lwdn[k] = 300.0;
            P->sst[k] = 1.0;
            P->fw[k] = 20.0;
        }
        sph_thermo_init_particle(p, P, k, P->tair[k]);
    }
    /* Particle 1: thin ice in warm water, melts completely within hours. */
    P->thick[1] = 0.02;
    P->conc[1] = 0.5;
    P->mass[1] = p->rho_i * P->conc[1] * P->thick[1] * AREA;
    P->fw[1] = 300.0;
    P->sst[1] = 4.0;
    sph_thermo_init_particle(p, P, 1, 0.0);
    return P;
}

static double total_mass(const sph_particles *P)
{
    double m = 0.0;
    for (size_t k = 0; k < P->n; k++)
        m += P->mass[k];
    return m;
}

static int run(const sph_thermo_params *p, sph_particles *P, int steps, sph_budget *b, sph_status *st)
{
    sph_thermo_work *w = sph_thermo_work_create(P->cap, P->nlayers);
    int rc = SPH_STEP_OK;
    for (int i = 0; i < steps && rc == SPH_STEP_OK; i++)
        rc = sph_thermo_step(p, P, 3600.0, w, b, st);
    sph_thermo_work_free(w);
    return rc;
}

static int same_bits(const double *a, const double *b, size_t n) { return memcmp(a, b, n * sizeof(double)) == 0; }

int main(void)
{
    sph_thermo_params p;
    sph_thermo_params_default(&p);
    int steps = check_quick() ? 6 : 48;

    /* Budget closure and complete melt. */
    sph_particles *P = make_set(&p);
    double m1 = P->mass[1];
    sph_budget b;
    memset(&b, 0, sizeof b);
    b.mass_initial = total_mass(P);
    sph_status st;
    sph_status_clear(&st);
    int rc = run(&p, P, steps, &b, &st);
    CHECK(rc == SPH_STEP_OK, "step ok (%s %s)", st.quantity, st.what);
    /* snow_ice: the particles' snow (5 cm on thin ice) floods into ice (issue 20) */
    double lhs = b.mass_initial + b.growth + b.new_ice + b.snow_ice - b.melt_top - b.melt_bottom - b.lateral_melt -
                 b.outflow;
    double m = total_mass(P);
    printf("budget: initial %.6e kg, growth %.4e, new ice %.4e, melt top %.4e, bottom %.4e, lateral %.4e; "
           "final %.6e; residual %.3e (relative %.2e)\n",
           b.mass_initial, b.growth, b.new_ice, b.melt_top, b.melt_bottom, b.lateral_melt, m, lhs - m,
           (lhs - m) / b.mass_initial);
    CHECK(fabs(lhs - m) <= 1e-12 * b.mass_initial, "mass budget closes: residual %.3g kg", lhs - m);
    CHECK(b.growth > 0 && b.new_ice > 0 && b.melt_top > 0 && b.melt_bottom > 0 && b.lateral_melt > 0,
          "every budget term exercised");
    CHECK(P->mass[1] == 0.0 && P->thick[1] == 0.0, "particle 1 melted completely: mass %g thick %g", P->mass[1],
          P->thick[1]);
    CHECK(b.melt_top + b.melt_bottom + b.lateral_melt >= m1, "its mass is in the melt terms");
    int flags_ok = 1;
    for (size_t k = 0; k < P->n; k++) {
        if (P->mass[k] <= 0.0)
            continue;
        unsigned r = P->regime[k] & (SPH_REGIME_ZERO_LAYER | SPH_REGIME_MULTI_LAYER);
        if (r != SPH_REGIME_ZERO_LAYER && r != SPH_REGIME_MULTI_LAYER)
            flags_ok = 0;
        if (!(P->conc[k] > 0.0 && P->conc[k] <= 1.0 && P->thick[k] > 0.0 && isfinite(P->tsurf[k])))
            flags_ok = 0;
    }
    CHECK(flags_ok, "one regime flag per live particle, state in range");

    /* 1 vs 2 threads: bit-identical state and budget. */
    sph_particles *A = make_set(&p), *B = make_set(&p);
    sph_budget ba, bb;
    memset(&ba, 0, sizeof ba);
    memset(&bb, 0, sizeof bb);
    omp_set_num_threads(1);
    run(&p, A, steps, &ba, &st);
    omp_set_num_threads(2);
    run(&p, B, steps, &bb, &st);
    int same = same_bits(A->mass, B->mass, NP) && same_bits(A->thick, B->thick, NP) &&
               same_bits(A->conc, B->conc, NP) && same_bits(A->tsurf, B->tsurf, NP) &&
               same_bits(A->snow, B->snow, NP) && same_bits(A->enth, B->enth, NP * (size_t)p.nlayers) &&
               memcmp(&ba, &bb, sizeof ba) == 0;
    CHECK(same, "1 and 2 threads bit-identical");

    /* Bad forcing: fatal, names the quantity and the particle, changes nothing. */
    sph_particles *C = make_set(&p);
    double tair5 = C->tair[5];
    C->tair[5] = -100.0;
    double thick_before[NP];
    memcpy(thick_before, C->thick, sizeof thick_before);
    sph_status_clear(&st);
    sph_budget bc;
    memset(&bc, 0, sizeof bc);
    rc = run(&p, C, 1, &bc, &st);
    CHECK(rc == SPH_STEP_FATAL && st.code == SPH_STEP_FATAL, "tair = -100 C is fatal");
    CHECK(strcmp(st.quantity, "air_temperature") == 0, "names air_temperature, got %s", st.quantity);
    CHECK(st.particle == 5 && st.value == -100.0 && st.limit == -80.0, "particle 5, value -100, limit -80");
    CHECK(same_bits(thick_before, C->thick, NP), "state unchanged on bad input");
    C->tair[5] = tair5;
    C->swdn[7] = -5.0;
    sph_status_clear(&st);
    rc = run(&p, C, 1, &bc, &st);
    CHECK(rc == SPH_STEP_FATAL && strcmp(st.quantity, "shortwave_down") == 0, "negative SW names shortwave_down: %s %ld %g", st.quantity, st.particle, st.value);
    C->swdn[7] = 0.0;
    C->qair[9] = 0.05; /* RH >> 1 below 10 C */
    sph_status_clear(&st);
    rc = run(&p, C, 1, &bc, &st);
    CHECK(rc == SPH_STEP_FATAL && strcmp(st.quantity, "relative_humidity") == 0, "RH > 1.05 named");

    /* Parameters. */
    const char *name = NULL;
    double lo, hi;
    CHECK(sph_thermo_params_check(&p, &name, &lo, &hi) == SPH_STEP_OK, "defaults are valid");
    sph_thermo_params q = p;
    q.rho_i = -1.0;
    CHECK(sph_thermo_params_check(&q, &name, &lo, &hi) == SPH_STEP_FATAL && strcmp(name, "rho_i") == 0,
          "rho_i named");
    q = p;
    q.nlayers = SPH_MAX_LAYERS + 1;
    CHECK(sph_thermo_params_check(&q, &name, &lo, &hi) == SPH_STEP_FATAL && strcmp(name, "nlayers") == 0,
          "nlayers named");
    q = p;
    q.new_ice_thickness = NAN;
    CHECK(sph_thermo_params_check(&q, &name, &lo, &hi) == SPH_STEP_FATAL && strcmp(name, "new_ice_thickness") == 0,
          "NaN parameter named");

    sph_particles_free(P);
    sph_particles_free(A);
    sph_particles_free(B);
    sph_particles_free(C);
    return check_summary("test_thermo_particles");
}
