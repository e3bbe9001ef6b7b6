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
 * max_neighbours 400, where nothing is merged). */
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
    return check_summary("test_coast_ghosts");
}
