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
 * move included. */
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

static sph_model *scene(int parcels, int compact)
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
    sph_model *a = scene(0, 0), *b = scene(0, 0), *d = scene(0, 1);
    CHECK(a && b && d, "scenes");
    if (!a || !b || !d)
        return check_summary("test_idle_scratch");
    size_t len = 0;
    double *s = sph_model_idle_scratch(b, &len);
    size_t n = sph_model_particles(b)->n;
    CHECK(s != NULL && len >= n, "after init: the written slots, at least the self pairs (%zu for %zu)", len, n);
    int stepped = 1, iters = 0;
    for (int k = 0; k < NSTEP && stepped; k++) {
        sph_model *nan_ones[2] = {b, d};
        for (int q = 0; q < 2; q++) {
            s = sph_model_idle_scratch(nan_ones[q], &len);
            for (size_t i = 0; s && i < len; i++)
                s[i] = NAN;
        }
        sph_status st;
        stepped = sph_model_step(a, &st) == SPH_STEP_OK && sph_model_step(b, &st) == SPH_STEP_OK &&
                  sph_model_step(d, &st) == SPH_STEP_OK;
        iters += sph_model_stats(a)->iterations;
    }
    CHECK(stepped, "4 steps each");
    CHECK(iters > 0, "the scene iterates mEVP (%d iterations)", iters);
    const char *which = "-";
    CHECK(same_fields(sph_model_particles(a), sph_model_particles(b), &which),
          "NaN in the idle scratch before each step: the same bits (%s differs)", which);
    which = "-";
    CHECK(same_fields(sph_model_particles(a), sph_model_particles(d), &which),
          "compact_gradients (and NaN in its idle scratch): the same bits as the stored "
          "components (%s differs)", which);
    sph_model_free(a);
    sph_model_free(b);
    sph_model_free(d);
    sph_model *c = scene(1, 0);
    CHECK(c != NULL, "parcels scene");
    if (c) {
        len = 1;
        CHECK(sph_model_idle_scratch(c, &len) == NULL && len == 0, "parcels: no lists, no scratch");
        sph_model_free(c);
    }
    return check_summary("test_idle_scratch");
}
