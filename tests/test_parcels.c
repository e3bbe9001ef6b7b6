/* Free drift as independent parcels (model.free_drift_parcels): the fast
 * path against the SPH path on the same scene, 1 against 2 threads, the
 * drift pass's vector lanes against one parcel at a time, and
 * proof that it runs without the neighbour search.
 *
 * Scene: 66 x 66 particles (above the threading threshold) 10 km apart
 * with h = 500 m, so that each particle's kernel support (3 h, at most
 * 2 x h0 with the variable smoothing length) holds no other particle:
 * there the SPH path's sums reduce to the particle itself, its strain rates
 * are exactly 0, continuity divides by exactly 1 and the two paths solve
 * the same per-particle equation. Wind, current, sea-surface tilt and
 * latitude vary in space and follow the particles (reset every step from
 * their positions, as the coupling does), with water turning 25 degrees
 * and Coriolis on.
 *
 * Tolerance: the SPH path reaches the implicit-drag fixed point by Picard
 * sweeps stopped at |du| + |dv| <= 1e-13 (1 + |u| + |v|) (operators.c), the
 * parcels path solves it directly; per step the velocities may differ by
 * that stopping tolerance, so after N steps the positions by at most
 * N dt 1e-13 (1 + 2 |u|max). The check allows 10 times that; mass,
 * thickness, concentration, mass per area and smoothing length must be
 * bit-identical (no operation on them differs). */
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "core/model.h"
#include "lattice.h"

enum { NX = 66, NSTEP = 100 };
static const double DX = 10e3, DT = 300.0;

static void forcing_at(sph_particles *P)
{
    for (size_t k = 0; k < P->n; k++) {
        double x = P->x[k] / 1e5, y = P->y[k] / 1e5;
        P->ua[k] = 8.0 + 3.0 * sin(x) * cos(y);
        P->va[k] = -4.0 + 5.0 * cos(1.3 * x + 0.4 * y);
        P->uw[k] = 0.1 * sin(y);
        P->vw[k] = -0.05 + 0.08 * cos(x);
        P->sshx[k] = 2e-7 * cos(y);
        P->sshy[k] = -1e-7 * sin(x);
        P->lat[k] = 38.0 + 4.0 * y / 7.0;
    }
}

static sph_model *scene(int parcels, int threads)
{
    omp_set_num_threads(threads);
    sph_params p;
    sph_params_default(&p);
    p.physics = SPH_PHYSICS_FREE_DRIFT;
    p.free_drift_parcels = parcels;
    p.thermo_dt = 0;
    p.dt = DT;
    p.turn_water = 25.0;
    sph_model *m = sph_model_create(&p, NX * NX, NULL);
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, &p, NX, NX, 0.0, 0.0, DX, 0.4, 0.6, 40.0);
    for (size_t k = 0; k < P->n; k++) {
        P->sml[k] = P->sml0[k] = 500.0;
        P->thick[k] = 0.2 + 0.6 * (double)(k % 7) / 6.0; /* mass per area varies */
    }
    forcing_at(P);
    return m;
}

/* Runs NSTEP steps; returns the largest speed seen (for the tolerance). */
static double run(sph_model *m, int *ok)
{
    sph_particles *P = sph_model_particles(m);
    sph_status st;
    *ok = sph_model_init(m, &st) == SPH_STEP_OK;
    double umax = 0.0;
    for (int s = 0; s < NSTEP && *ok; s++) {
        forcing_at(P);
        *ok = sph_model_step(m, &st) == SPH_STEP_OK;
        for (size_t k = 0; k < P->n; k++)
            umax = fmax(umax, hypot(P->u[k], P->v[k]));
    }
    CHECK(*ok, "step %ld: %s %s", st.step, st.quantity, st.what);
    return umax;
}

/* Particle of id `id` in P (the model reorders by cell). */
static size_t find(const sph_particles *P, long id)
{
    for (size_t k = 0; k < P->n; k++)
        if (P->id[k] == id)
            return k;
    return (size_t)-1;
}

static void test_parcels_match_sph(void)
{
    int oka, okb;
    sph_model *a = scene(0, 1), *b = scene(1, 1);
    double umax = run(a, &oka);
    run(b, &okb);
    sph_particles *A = sph_model_particles(a), *B = sph_model_particles(b);
    CHECK(A->n == B->n && A->n == NX * NX, "particle counts %zu %zu", A->n, B->n);
    double tolx = 10.0 * NSTEP * DT * 1e-13 * (1.0 + 2.0 * umax), tolu = 10.0 * 1e-13 * (1.0 + 2.0 * umax);
    double dx = 0.0, du = 0.0;
    int same = 1, moved = 1;
    for (size_t k = 0; oka && okb && k < A->n; k++) {
        size_t q = find(B, A->id[k]);
        if (q == (size_t)-1) {
            same = 0;
            break;
        }
        dx = fmax(dx, fmax(fabs(A->x[k] - B->x[q]), fabs(A->y[k] - B->y[q])));
        du = fmax(du, fmax(fabs(A->u[k] - B->u[q]), fabs(A->v[k] - B->v[q])));
        same &= A->mass[k] == B->mass[q] && A->thick[k] == B->thick[q] && A->conc[k] == B->conc[q] &&
                A->dens[k] == B->dens[q] && A->sml[k] == B->sml[q] && A->e11[k] == 0.0 &&
                A->e22[k] == 0.0 && A->e12[k] == 0.0;
        long i = A->id[k] % NX, j = A->id[k] / NX;
        moved &= hypot(A->x[k] - i * DX, A->y[k] - j * DX) > 1e3; /* it drifted */
    }
    CHECK(dx <= tolx, "positions differ by %.3g m (tolerance %.3g m)", dx, tolx);
    CHECK(du <= tolu, "velocities differ by %.3g m/s (tolerance %.3g m/s)", du, tolu);
    CHECK(same, "mass, thickness, concentration, mass per area, smoothing length, strain rates: "
                "not bit-identical");
    CHECK(moved && umax > 0.05, "the scene must drift (umax %.3g m/s)", umax);
    printf("parcels vs SPH free drift: %d particles, %d steps, max |dx| %.3g m (tol %.3g), "
           "max |du| %.3g m/s (tol %.3g)\n", NX * NX, NSTEP, dx, tolx, du, tolu);
    sph_model_free(a);
    sph_model_free(b);
}

static void test_parcels_threads(void)
{
    int ok1, ok2;
    sph_model *a = scene(1, 1), *b = scene(1, 2);
    run(a, &ok1);
    run(b, &ok2);
    sph_particles *A = sph_model_particles(a), *B = sph_model_particles(b);
    size_t n = A->n;
    CHECK(ok1 && ok2 && A->n == B->n, "counts");
    int same = ok1 && ok2 && !memcmp(A->x, B->x, n * 8) && !memcmp(A->y, B->y, n * 8) &&
               !memcmp(A->u, B->u, n * 8) && !memcmp(A->v, B->v, n * 8) &&
               !memcmp(A->dens, B->dens, n * 8) && !memcmp(A->id, B->id, n * sizeof *A->id);
    CHECK(same, "parcels: 1 and 2 threads differ");
    sph_model_free(a);
    sph_model_free(b);
    omp_set_num_threads(1);
}

/* The drift pass solves parcels eight at a time side by side (vector
 * lanes) and the last n mod 8 one at a time; both must give the same bits.
 * The scene's first 4352 particles (in the model's cell order) go through
 * the lanes; a model holding one of them alone (same position, thickness
 * and forcing) goes through the one-at-a-time code. */
static void test_parcels_lanes(void)
{
    int ok;
    sph_model *a = scene(1, 1);
    run(a, &ok);
    sph_particles *A = sph_model_particles(a);
    static const long ids[] = {0, 1, 2, 3, 67, 1001, 2178, 3333, NX * NX - 1};
    int same = ok, checked = 0;
    for (size_t t = 0; ok && t < sizeof ids / sizeof ids[0]; t++) {
        long id = ids[t];
        sph_params p;
        sph_params_default(&p);
        p.physics = SPH_PHYSICS_FREE_DRIFT;
        p.free_drift_parcels = 1;
        p.thermo_dt = 0;
        p.dt = DT;
        p.turn_water = 25.0;
        sph_model *b = sph_model_create(&p, 1, NULL);
        sph_particles *B = sph_model_particles(b);
        lattice_fill(B, &p, 1, 1, (double)(id % NX) * DX, (double)(id / NX) * DX, DX, 0.4, 0.6, 40.0);
        B->sml[0] = B->sml0[0] = 500.0;
        B->thick[0] = 0.2 + 0.6 * (double)(id % 7) / 6.0;
        forcing_at(B);
        int okb;
        run(b, &okb);
        size_t q = find(A, id);
        int eq = okb && q != (size_t)-1 && B->n == 1 && A->x[q] == B->x[0] && A->y[q] == B->y[0] &&
                 A->u[q] == B->u[0] && A->v[q] == B->v[0] && A->dens[q] == B->dens[0];
        CHECK(eq, "particle %ld: eight at a time and alone differ (u %.17g %.17g)", id,
              q != (size_t)-1 ? A->u[q] : NAN, B->u[0]);
        same &= eq;
        checked++;
        sph_model_free(b);
    }
    CHECK(checked == (int)(sizeof ids / sizeof ids[0]), "checked %d particles", checked);
    printf("parcels in lanes vs alone: %d particles, %d steps: %s\n", checked, NSTEP,
           same ? "bit-identical" : "DIFFER");
    sph_model_free(a);
}

/* 200 particles on one spot: the SPH path refuses (more neighbours than
 * max_neighbours, clumping); parcels never build neighbour lists. */
static void test_no_neighbour_search(void)
{
    for (int parcels = 0; parcels < 2; parcels++) {
        sph_params p;
        sph_params_default(&p);
        p.physics = SPH_PHYSICS_FREE_DRIFT;
        p.free_drift_parcels = parcels;
        p.thermo_dt = 0;
        sph_model *m = sph_model_create(&p, 200, NULL);
        sph_particles *P = sph_model_particles(m);
        lattice_fill(P, &p, 200, 1, 0.0, 0.0, 1e-3, 0.5, 0.5, 40.0);
        lattice_set_forcing(P, 10.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for (size_t k = 0; k < P->n; k++)
            P->sml[k] = P->sml0[k] = 1000.0;
        sph_status st;
        int rc = sph_model_init(m, &st);
        if (rc == SPH_STEP_OK)
            rc = sph_model_step(m, &st);
        if (parcels)
            CHECK(rc == SPH_STEP_OK && P->u[0] > 0.01, "parcels: clumped particles drift (rc %d)", rc);
        else
            CHECK(rc != SPH_STEP_OK && st.kind == SPH_FAULT_CLUMPING, "SPH path: clumping expected (rc %d)",
                  rc);
        sph_model_free(m);
    }
}

/* With a land mask a model keeps room for coast ghosts (four slots per
 * particle), except one created for parcels, which never has ghosts: its
 * arrays hold the particles only, and switching it to the SPH path later
 * is refused rather than run short of ghost slots. */
static void test_parcels_capacity(void)
{
    static unsigned char land[16 * 16];
    sph_landmask mask = {16, 16, -80e3, -80e3, 10e3, 10e3, land, 0};
    for (int parcels = 0; parcels <= 1; parcels++) {
        sph_params p;
        sph_params_default(&p);
        p.physics = SPH_PHYSICS_FREE_DRIFT;
        p.free_drift_parcels = parcels;
        sph_model *m = sph_model_create(&p, 100, &mask);
        CHECK(m != NULL, "model with a mask (parcels %d)", parcels);
        if (!m)
            continue;
        CHECK(sph_model_particles(m)->cap == (parcels ? 100u : 400u), "slots %zu (parcels %d)",
              sph_model_particles(m)->cap, parcels);
        sph_params q = p;
        q.free_drift_parcels = !parcels;
        int rc = sph_model_set_params(m, &q);
        CHECK(parcels ? rc == SPH_STEP_FATAL : rc == SPH_STEP_OK,
              "switching parcels %d -> %d: %d", parcels, !parcels, rc);
        CHECK(sph_model_set_params(m, &p) == SPH_STEP_OK, "same parameters again");
        sph_model_free(m);
    }
}

int main(void)
{
    test_parcels_capacity();
    test_parcels_match_sph();
    test_parcels_threads();
    test_parcels_lanes();
    test_no_neighbour_search();
    return check_summary("test_parcels");
}
