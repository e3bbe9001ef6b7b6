/* The step's sums and checks on the OpenMP threads (core/model.c
 * update_budget, check_health, regime_fractions; core/coast.c
 * sph_remove_outflow), for a scene of three budget blocks (40000 parcels,
 * SPH_SUM_BLOCK 16384):
 *  - the budget's mass, area and kinetic energy after 5 steps with 1 and
 *    2 threads are bit-identical and equal to the documented order (each
 *    block of 16384 particles summed in index order, then the blocks in
 *    order), recomputed here from the particles; the mass agrees with
 *    the exact sum (the cold start's) to round-off;
 *  - a scene of one block sums in plain index order (today's sums);
 *  - two non-finite velocities (particles 30000 and 35000): the step's
 *    report names the first in index order with 1 and 2 threads.
 * The outflow removal's parallel search is checked by test_coast_ghosts
 * and the free-drift bench's products (1 against 2 threads). */
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "core/model.h"
#include "lattice.h"

enum { NX = 200, NY = 200, NSTEP = 5, BLOCK = 16384 };

static sph_model *scene(int threads, int nx, int ny)
{
    omp_set_num_threads(threads);
    sph_params p;
    sph_params_default(&p);
    p.physics = SPH_PHYSICS_FREE_DRIFT;
    p.free_drift_parcels = 1;
    p.thermo_dt = 0;
    p.dt = 300.0;
    sph_model *m = sph_model_create(&p, (size_t)nx * ny, NULL);
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, &p, nx, ny, 0.0, 0.0, 2e3, 0.4, 0.6, 40.0);
    for (size_t k = 0; k < P->n; k++) {
        P->sml[k] = P->sml0[k] = 100.0;
        P->thick[k] = 0.2 + 0.6 * (double)(k % 11) / 10.0;
        P->mass[k] *= 1.0 + 1e-3 * (double)(k % 13); /* sums whose order shows */
        P->ua[k] = 8.0 + 3.0 * sin(1e-4 * P->x[k]);
        P->va[k] = -4.0 + 5.0 * cos(1e-4 * P->y[k]);
        P->lat[k] = 40.0;
    }
    return m;
}

/* The documented order: blocks of BLOCK in index order, then the blocks. */
static double blocked(const sph_particles *P, double (*term)(const sph_particles *, size_t))
{
    size_t n = P->n;
    if (n <= BLOCK) {
        double s = 0.0;
        for (size_t k = 0; k < n; k++)
            s += term(P, k);
        return s;
    }
    double tot = 0.0;
    for (size_t b = 0; b * BLOCK < n; b++) {
        double s = 0.0;
        for (size_t k = b * BLOCK; k < n && k < (b + 1) * BLOCK; k++)
            s += term(P, k);
        tot += s;
    }
    return tot;
}
static double t_mass(const sph_particles *P, size_t k) { return P->mass[k]; }
static double t_ke(const sph_particles *P, size_t k)
{
    return 0.5 * P->mass[k] * (P->u[k] * P->u[k] + P->v[k] * P->v[k]);
}
static double t_area(const sph_particles *P, size_t k) { return P->mass[k] / (900.0 * P->thick[k]); }

static int run(sph_model *m)
{
    sph_status st;
    if (sph_model_init(m, &st) != SPH_STEP_OK)
        return 0;
    for (int s = 0; s < NSTEP; s++)
        if (sph_model_step(m, &st) != SPH_STEP_OK)
            return 0;
    return 1;
}

int main(void)
{
    int nt = omp_get_max_threads();
    sph_budget b[2];
    for (int t = 0; t < 2; t++) {
        sph_model *m = scene(t + 1, NX, NY);
        CHECK(run(m), "%d threads: 5 steps", t + 1);
        b[t] = *sph_model_budget(m);
        if (t == 0) {
            const sph_particles *P = sph_model_particles(m);
            CHECK(P->n == (size_t)NX * NY && P->n > 2 * BLOCK, "%zu particles, three blocks", P->n);
            CHECK(sph_model_params(m)->rho_i == 900.0, "rho_i 900 (the area's term)");
            double mass = blocked(P, t_mass), ke = blocked(P, t_ke), area = blocked(P, t_area);
            printf("  budget: mass %.17g (blocked %.17g), KE %.17g (%.17g), area %.17g (%.17g)\n", b[0].mass,
                   mass, b[0].kinetic_energy, ke, b[0].area, area);
            CHECK(b[0].mass == mass, "mass in the blocks' order");
            CHECK(b[0].kinetic_energy == ke, "kinetic energy in the blocks' order");
            CHECK(b[0].area == area, "area in the blocks' order");
            CHECK(ke > 0.0, "the parcels move");
            double plain = 0.0;
            for (size_t k = 0; k < P->n; k++)
                plain += t_ke(P, k);
            CHECK(plain != ke, "the scene tells the orders apart (plain KE %.17g)", plain);
            CHECK_CLOSE(b[0].mass, b[0].mass_initial, 0, 1e-14, "mass against the cold start's, to round-off");
        }
        sph_model_free(m);
    }
    CHECK(b[0].mass == b[1].mass && b[0].area == b[1].area && b[0].volume == b[1].volume &&
              b[0].kinetic_energy == b[1].kinetic_energy && b[0].snow == b[1].snow,
          "1 and 2 threads: the same budget bit for bit");

    /* one block: the plain sum in index order */
    {
        sph_model *m = scene(2, 100, 100);
        CHECK(run(m), "one block: 5 steps");
        const sph_particles *P = sph_model_particles(m);
        double s = 0.0, ke = 0.0;
        for (size_t k = 0; k < P->n; k++) {
            s += P->mass[k];
            ke += t_ke(P, k);
        }
        CHECK(sph_model_budget(m)->mass == s && sph_model_budget(m)->kinetic_energy == ke,
              "%zu particles: the sums in index order", P->n);
        sph_model_free(m);
    }

    /* the first unhealthy particle in index order, whatever the threads */
    for (int t = 1; t <= 2; t++) {
        sph_model *m = scene(t, NX, NY);
        sph_status st;
        CHECK(sph_model_init(m, &st) == SPH_STEP_OK, "init");
        sph_particles *P = sph_model_particles(m);
        P->ua[35000] = NAN;
        P->ua[30000] = NAN;
        long id = P->id[30000];
        int rc = sph_model_step(m, &st);
        printf("  %d threads: %s of particle %ld %s\n", t, st.quantity ? st.quantity : "?", st.particle,
               st.what ? st.what : "");
        CHECK(rc == SPH_STEP_FATAL && st.kind == SPH_FAULT_NONFINITE, "%d threads: non-finite reported", t);
        CHECK(st.particle == id, "%d threads: particle %ld (want %ld, the first)", t, st.particle, id);
        sph_model_free(m);
    }
    omp_set_num_threads(nt);
    return check_summary("test_step_sums");
}
