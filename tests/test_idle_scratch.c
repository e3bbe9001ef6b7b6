/* sph_model_idle_scratch (core/model.h): between steps the model's pair
 * gradients hold nothing it reads again, so the engine's output may write
 * over them (service/forecast_output.c). A packed scene (mEVP where packed,
 * a diluted strip in free drift, coast-free) stepped 4 times twice: once
 * as is, once with the scratch overwritten by NaN before every step after
 * init. Every particle field of the two runs is bit-identical; the scratch
 * is the first thread block's written slots (at least one pair per
 * particle: the self pairs); a parcels run has none (NULL, 0).
 * model.compact_gradients (the pair gradients as their factor and the
 * build's positions, core/neighbours.h), with the same NaN scratch: the
 * same bits as the stored components, the final strain rates after the
 * move included. model.compact_gradients auto (the default): the stored
 * components below SPH_MEMORY_BOUND_PARTICLES (this scene's 480), the
 * factor form at and above it (the bound lowered to the scene's count by
 * sph_model_set_memory_bound), the same bits as both explicit settings. */
#include <math.h>
#include <omp.h>
#include <string.h>

#include "check.h"
#include "core/model.h"
#include "lattice.h"

enum { NX = 24, NY = 20, NSTEP = 4 };

static unsigned rng;
static double urand(void)
{
    rng = rng * 1103515245u + 12345u;
    return (double)(rng >> 8 & 0xffff) / 65535.0 - 0.5;
}

/* bound: 0 keeps the model's memory bound, else sph_model_set_memory_bound */
static sph_model *scene(int parcels, int compact, size_t bound)
{
    sph_params p;
    sph_params_default(&p);
    p.physics = parcels ? SPH_PHYSICS_FREE_DRIFT : SPH_PHYSICS_AUTO;
    p.free_drift_parcels = parcels;
    p.compact_gradients = compact;
    p.thermo_dt = 0;
    p.dt = 60.0;
    const double dx = 1000.0;
    sph_model *m = sph_model_create(&p, (size_t)NX * NY, NULL);
    if (!m)
        return NULL;
    if (bound)
        sph_model_set_memory_bound(m, bound);
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, &p, NX, NY, 0, 0, dx, 1.0, 1.0, 40.6);
    rng = 7;
    for (size_t k = 0; k < P->n; k++) {
        P->x[k] += 0.3 * dx * urand();
        P->y[k] += 0.3 * dx * urand();
        P->ua[k] = 12.0 + 4.0 * urand(); /* wind into a packed block: stress */
        P->va[k] = -3.0 + 4.0 * urand();
        P->uw[k] = 0.1 * urand();
        P->vw[k] = 0.1 * urand();
        if (P->x[k] < NX * dx / 4.0) {
            P->mass[k] *= 0.3;
            P->conc[k] = 0.3;
        }
    }
    sph_status st;
    if (sph_model_init(m, &st) != 0) {
        CHECK(0, "scene: %s %s", st.quantity, st.what);
        sph_model_free(m);
        return NULL;
    }
    return m;
}

/* 1 when every field of every live particle is the same bits in both. */
static int same_fields(const sph_particles *A, const sph_particles *B, const char **which)
{
    if (A->n != B->n)
        return 0;
    for (int f = 0; f < SPH_PARTICLE_NFIELDS; f++) {
        size_t bytes = A->n * sph_particles_field_count(A, f) * sph_particle_fields[f].size;
        if (memcmp(sph_particles_field(A, f), sph_particles_field(B, f), bytes)) {
            *which = sph_particle_fields[f].name;
            return 0;
        }
    }
    return 1;
}

int main(void)
{
    omp_set_num_threads(1);
    const size_t np = (size_t)NX * NY;
    /* a: stored components; b: the same with NaN scratch; d: compact, NaN
     * scratch; e: auto at the default bound; f: auto, bound = the count
     * (factor form); g: auto, bound one above it (components) */
    sph_model *a = scene(0, SPH_COMPACT_FALSE, 0), *b = scene(0, SPH_COMPACT_FALSE, 0),
              *d = scene(0, SPH_COMPACT_TRUE, 0), *e = scene(0, SPH_COMPACT_AUTO, 0),
              *f = scene(0, SPH_COMPACT_AUTO, np), *g = scene(0, SPH_COMPACT_AUTO, np + 1);
    sph_model *all[6] = {a, b, d, e, f, g};
    CHECK(a && b && d && e && f && g, "scenes");
    if (!a || !b || !d || !e || !f || !g) {
        for (int q = 0; q < 6; q++)
            sph_model_free(all[q]);
        return check_summary("test_idle_scratch");
    }
    sph_params dp;
    sph_params_default(&dp);
    CHECK(dp.compact_gradients == SPH_COMPACT_AUTO, "model.compact_gradients defaults to auto");
    CHECK(np < SPH_MEMORY_BOUND_PARTICLES, "the scene (%zu) is below the memory bound (%d)", np,
          SPH_MEMORY_BOUND_PARTICLES);
    CHECK(!sph_model_compact_form(a) && sph_model_compact_form(d), "false: components; true: factor form");
    CHECK(!sph_model_compact_form(e), "auto below the bound: components");
    CHECK(sph_model_compact_form(f), "auto at the bound: factor form");
    CHECK(!sph_model_compact_form(g), "auto with the bound one above the count: components");
    size_t len = 0;
    double *s = sph_model_idle_scratch(b, &len);
    size_t n = sph_model_particles(b)->n;
    CHECK(s != NULL && len >= n, "after init: the written slots, at least the self pairs (%zu for %zu)", len, n);
    int stepped = 1, iters = 0;
    for (int k = 0; k < NSTEP && stepped; k++) {
        sph_model *nan_ones[4] = {b, d, e, f};
        for (int q = 0; q < 4; q++) {
            s = sph_model_idle_scratch(nan_ones[q], &len);
            for (size_t i = 0; s && i < len; i++)
                s[i] = NAN;
        }
        sph_status st;
        for (int q = 0; q < 6 && stepped; q++)
            stepped = sph_model_step(all[q], &st) == SPH_STEP_OK;
        iters += sph_model_stats(a)->iterations;
    }
    CHECK(stepped, "4 steps each");
    CHECK(iters > 0, "the scene iterates mEVP (%d iterations)", iters);
    CHECK(sph_model_compact_form(f) && !sph_model_compact_form(e) && !sph_model_compact_form(g),
          "auto's choices after the steps' builds");
    const char *which = "-";
    CHECK(same_fields(sph_model_particles(a), sph_model_particles(b), &which),
          "NaN in the idle scratch before each step: the same bits (%s differs)", which);
    which = "-";
    CHECK(same_fields(sph_model_particles(a), sph_model_particles(d), &which),
          "compact_gradients (and NaN in its idle scratch): the same bits as the stored "
          "components (%s differs)", which);
    const char *names[3] = {"auto below the bound", "auto at the bound (factor form)", "auto with the bound above the count"};
    sph_model *autos[3] = {e, f, g};
    for (int q = 0; q < 3; q++) {
        which = "-";
        CHECK(same_fields(sph_model_particles(a), sph_model_particles(autos[q]), &which),
              "%s: the same bits as false (%s differs)", names[q], which);
        which = "-";
        CHECK(same_fields(sph_model_particles(d), sph_model_particles(autos[q]), &which),
              "%s: the same bits as true (%s differs)", names[q], which);
    }
    for (int q = 0; q < 6; q++)
        sph_model_free(all[q]);
    sph_model *c = scene(1, 0, 0);
    CHECK(c != NULL, "parcels scene");
    if (c) {
        len = 1;
        CHECK(sph_model_idle_scratch(c, &len) == NULL && len == 0, "parcels: no lists, no scratch");
        CHECK(!sph_model_compact_form(c), "parcels: no lists, no form");
        sph_model_free(c);
    }
    return check_summary("test_idle_scratch");
}
