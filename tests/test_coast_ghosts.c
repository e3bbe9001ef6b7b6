/* Mirror ghosts of coasts curved tighter than the kernel support (issue
 * 19 item 6 leftover: stair-step coasts of native grids exceeded
 * model.max_neighbours, "particle clumping").
 *
 * Packed ice (A = 1, 1 m, spacing 1 km, Gaussian kernel of 3 h) around
 *  - an island of a native model grid: the cells of a grid of 2 km
 *    rotated by 30 degrees whose centres lie within 2.2 km of a point,
 *    rasterised on the model's plane mask of 1/3 km (a stair-step disc
 *    smaller than the support, the shape of test_landmask_model's coast);
 *  - a one-cell staircase at the particle spacing (45 degrees);
 *  - a straight coast.
 * Their reflections converge into the island: with max_neighbours 96 a
 * particle next to it had more neighbours than the lists hold and the
 * model refused to start. Now the crowded ghosts are merged once a list
 * would overflow; asserted: the model starts and runs 30 steps of wind
 * onto the coast with the default max_neighbours, merging is on for the
 * island only (the staircase and the straight coast keep every
 * reflection), no particle enters the land, and where the lists overflow
 * at once (h0 = 1.3 x spacing) the merged ghosts are fewer and carry
 * exactly the volume (sum m / rho) of the reflections (computed with
 * max_neighbours 400, where nothing is merged). And with the summation
 * density, ice of 1 m and 10 m in a checkerboard at rest (fixed state)
 * keeps its densities step after step, merged or not: before the fix of
 * session 9 a merged ghost counted its absorbed reflections' volume at its
 * source's density, that density fed on its own ghost, and the 10 m
 * particle next to the island passed the 30 m thickness limit in the
 * first step (docs/ocean.md, the freeze-up scene's pile-up). */
#include <math.h>
#include <stdlib.h>

#include "check.h"
#include "core/model.h"
#include "lattice.h"

enum { N = 40, CF = 3 }; /* particles per side; mask cells per particle spacing */
static const double D = 1000.0;

static int land_of(int shape, double x, double y)
{
    const double cx = 20.3 * D, cy = 19.8 * D;
    if (shape == 0) { /* the rotated native grid's cells near the centre */
        const double a = 30 * M_PI / 180, g = 2.0 * D;
        double u = (x - cx) * cos(a) + (y - cy) * sin(a), v = -(x - cx) * sin(a) + (y - cy) * cos(a);
        double cu = (floor(u / g) + 0.5) * g, cv = (floor(v / g) + 0.5) * g;
        return hypot(cu, cv) < 2.2 * D;
    }
    if (shape == 1) /* staircase: one particle spacing per step */
        return floor(x / D) + floor(y / D) >= 46;
    return x > 30.0 * D; /* straight */
}

typedef struct {
    int ok, merging;
    size_t n, ghosts;
    double ghost_volume, max_ghost_mass;
} outcome;

static outcome start(int shape, int max_nb, int steps, double sml_factor, size_t *on_land)
{
    outcome o = {0, 0, 0, 0, 0, 0};
    sph_params p;
    sph_params_default(&p);
    p.thermo_dt = 0;
    p.max_neighbours = max_nb;
    p.sml_factor = sml_factor;
    const int nx = N * CF, ny = N * CF;
    static unsigned char land[N * CF * N * CF];
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++)
            land[j * nx + i] = (unsigned char)land_of(shape, (i + 0.5) * D / CF, (j + 0.5) * D / CF);
    sph_landmask mask = {nx, ny, 0, 0, D / CF, D / CF, land, 0};
    sph_model *m = sph_model_create(&p, 2 * N * N, &mask);
    CHECK(m != NULL, "model");
    if (!m)
        return o;
    sph_particles *P = sph_model_particles(m);
    for (int j = 0; j < N; j++)
        for (int i = 0; i < N; i++) {
            double x = (i + 0.5) * D, y = (j + 0.5) * D;
            if (!land[(int)(y / (D / CF)) * nx + (int)(x / (D / CF))])
                lattice_fill(P, &p, 1, 1, x, y, D, 1.0, 1.0, 70.0);
        }
    sph_status st;
    o.ok = sph_model_init(m, &st) == SPH_STEP_OK;
    if (!o.ok)
        printf("  shape %d, max_neighbours %d: %s %s\n", shape, max_nb, st.quantity ? st.quantity : "",
               st.what ? st.what : "");
    o.n = P->n;
    o.ghosts = sph_model_ghosts(m);
    for (size_t g = 0; g < o.ghosts; g++) {
        o.ghost_volume += P->mass[P->n + g] / P->dens[P->n + g];
        o.max_ghost_mass = fmax(o.max_ghost_mass, P->mass[P->n + g]);
    }
    /* wind toward the coast (north-east), then where the ice went */
    lattice_set_forcing(P, 14.0, 14.0, 0.0, 0.0, 0.0, 0.0);
    for (int s = 0; o.ok && s < steps; s++)
        if (sph_model_step(m, &st) != SPH_STEP_OK) {
            o.ok = 0;
            printf("  shape %d, step %d: %s %s\n", shape, s, st.quantity ? st.quantity : "", st.what ? st.what : "");
        }
    o.merging = sph_model_ghosts_merging(m);
    *on_land = 0;
    for (size_t k = 0; k < P->n; k++) {
        int i = (int)floor(P->x[k] / (D / CF)), j = (int)floor(P->y[k] / (D / CF));
        *on_land += i >= 0 && j >= 0 && i < nx && j < ny && land[j * nx + i];
    }
    sph_model_free(m);
    return o;
}

/* The island with h0 = 1.3 x spacing (merged at the start with 96), ice of
 * 1 m and 10 m in a checkerboard, at rest (model.fixed_state, summation
 * density): the summation density of the 10 m particle nearest the island after each of
 * STEPS steps in d[1..STEPS] (d[0] after the start); returns its index. */
enum { STEPS = 8 };
static size_t at_rest(int max_nb, double d[STEPS + 1])
{
    sph_params p;
    sph_params_default(&p);
    p.thermo_dt = 0;
    p.max_neighbours = max_nb;
    p.sml_factor = 1.3;
    p.summation_density = 1;
    p.fixed_state = 1;
    const int nx = N * CF, ny = N * CF;
    static unsigned char land[N * CF * N * CF];
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++)
            land[j * nx + i] = (unsigned char)land_of(0, (i + 0.5) * D / CF, (j + 0.5) * D / CF);
    sph_landmask mask = {nx, ny, 0, 0, D / CF, D / CF, land, 0};
    sph_model *m = sph_model_create(&p, 2 * N * N, &mask);
    CHECK(m != NULL, "model");
    for (int s = 0; s <= STEPS; s++)
        d[s] = NAN;
    if (!m)
        return 0;
    sph_particles *P = sph_model_particles(m);
    for (int j = 0; j < N; j++)
        for (int i = 0; i < N; i++) {
            double x = (i + 0.5) * D, y = (j + 0.5) * D;
            if (!land[(int)(y / (D / CF)) * nx + (int)(x / (D / CF))])
                lattice_fill(P, &p, 1, 1, x, y, D, (i + j) % 2 ? 1.0 : 10.0, 1.0, 70.0);
        }
    sph_status st;
    int ok = sph_model_init(m, &st) == SPH_STEP_OK;
    CHECK(ok, "at rest, max_neighbours %d: starts (%s)", max_nb, ok ? "" : st.what ? st.what : "");
    size_t kb = 0; /* the 10 m particle nearest the island's centre */
    for (size_t k = 0; k < P->n; k++)
        if (P->thick[k] > 5.0 && hypot(P->x[k] - 20.3 * D, P->y[k] - 19.8 * D) <
                                     hypot(P->x[kb] - 20.3 * D, P->y[kb] - 19.8 * D))
            kb = k;
    d[0] = P->dens[kb];
    for (int s = 1; ok && s <= STEPS; s++) {
        ok = sph_model_step(m, &st) == SPH_STEP_OK;
        CHECK(ok, "at rest, max_neighbours %d: step %d (%s)", max_nb, s, ok ? "" : st.what ? st.what : "");
        d[s] = P->dens[kb];
    }
    if (max_nb < 400)
        CHECK(sph_model_ghosts_merging(m), "at rest, max_neighbours %d: ghosts merged", max_nb);
    sph_model_free(m);
    return kb;
}

int main(void)
{
    const char *names[3] = {"stair-step island of a rotated native grid", "one-cell staircase", "straight coast"};
    for (int shape = 0; shape < 3; shape++) {
        size_t land_all, land_def;
        outcome all = start(shape, 400, 0, 1.0, &land_all); /* lists that hold every ghost: none merged */
        outcome def = start(shape, 96, 30, 1.0, &land_def); /* the default capacity */
        printf("%s: %zu particles; with max_neighbours 400 %zu ghosts, volume %.6g m3; with 96 %s, %s, %zu "
               "ghosts, volume %.6g m3 (largest ghost mass %.3g x a particle's); after 30 steps %zu on land\n",
               names[shape], all.n, all.ghosts, all.ghost_volume, def.ok ? "runs" : "FAILS",
               def.merging ? "ghosts merged" : "none merged", def.ghosts, def.ghost_volume,
               def.max_ghost_mass / (900.0 * D * D), land_def);
        CHECK(all.ok, "%s: starts with room for every ghost", names[shape]);
        CHECK(def.ok, "%s: starts and runs 30 steps with max_neighbours 96", names[shape]);
        CHECK(def.merging == (shape == 0), "%s: ghosts merged only where the lists would overflow (%d)",
              names[shape], def.merging);
        CHECK(land_def == 0, "%s: no particle on land (%zu)", names[shape], land_def);
    }
    /* at the start (the same positions): merging keeps the reflections' volume */
    size_t l0, l1;
    outcome all = start(0, 400, 0, 1.3, &l0), def = start(0, 96, 0, 1.3, &l1);
    printf("island, h0 = 1.3 x spacing, at the start: %zu reflections, %zu ghosts once merged\n", all.ghosts,
           def.ghosts);
    CHECK(all.ok && !all.merging && def.ok && def.merging, "island, h0 1.3: merged at the start only with 96");
    CHECK(def.ghosts < all.ghosts, "island: fewer ghosts once merged (%zu of %zu)", def.ghosts, all.ghosts);
    CHECK_CLOSE(def.ghost_volume, all.ghost_volume, 1e-12, 0, "island: merged ghosts keep the reflections' volume");
    /* summation density with ice of two thicknesses at rest (fixed state):
     * the kernel sums of fixed masses at fixed positions are the same every
     * step, and the merged ghosts count the reflections' mass */
    double d_all[STEPS + 1], d_mrg[STEPS + 1];
    size_t k_all = at_rest(400, d_all), k_mrg = at_rest(96, d_mrg);
    printf("island, checkerboard of 1 m and 10 m ice at rest, summation density of the 10 m particle %zu nearest it: with "
           "every reflection %.6g kg/m2 (step 1) and %.6g (step %d); merged %.6g and %.6g\n",
           k_all, d_all[1], d_all[STEPS], STEPS, d_mrg[1], d_mrg[STEPS]);
    CHECK(k_all == k_mrg, "at rest: the same particle (%zu, %zu)", k_all, k_mrg);
    CHECK_CLOSE(d_all[STEPS], d_all[1], 1e-12, 0, "at rest, every reflection: the density is steady");
    CHECK_CLOSE(d_mrg[STEPS], d_mrg[1], 1e-12, 0, "at rest, ghosts merged: the density is steady (no ratchet)");
    return check_summary("test_coast_ghosts");
}
