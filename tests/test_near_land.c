/* The coast's near-land cells (core/coast.c, sph_mark_near_land): a cell is
 * near land where a land cell, or the outside of a closed domain, lies
 * within ri columns and rj rows of it (ri = ceil(radius / dx) + 1, rj the
 * same with dy). The separable sliding count must mark exactly the cells
 * that the definition marks: asserted against a direct scan of every
 * window, written here, on random masks (1 % to 60 % land, blobs and
 * single cells), rectangular cells (dx != dy), radii from below one cell
 * to wider than the mask, open and closed domains, masks of one row or
 * one column and an all-sea mask (nothing near land when open, everything
 * within reach of the edge when closed). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "lattice.h"
#include "../src/core/model_impl.h"

static unsigned long rng = 12345;
static double urand(void)
{
    rng = rng * 6364136223846793005ul + 1442695040888963407ul;
    return (double)(rng >> 11) / 9007199254740992.0;
}

/* the definition: every cell of the window */
static int near_direct(const unsigned char *land, int nx, int ny, int closed, int ri, int rj, int i, int j)
{
    for (int b = -rj; b <= rj; b++)
        for (int a = -ri; a <= ri; a++) {
            int x = i + a, y = j + b;
            if (x < 0 || y < 0 || x >= nx || y >= ny) {
                if (closed)
                    return 1;
            } else if (land[(size_t)y * nx + x]) {
                return 1;
            }
        }
    return 0;
}

/* one mask: returns the number of cells that differ */
static long one_case(int nx, int ny, double dx, double dy, double frac, int blobs, int closed, double radius,
                     long *marked)
{
    unsigned char *land = calloc((size_t)nx * ny, 1);
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++)
            land[(size_t)j * nx + i] = urand() < frac;
    for (int b = 0; b < blobs; b++) { /* a few islands of a few cells */
        int ci = (int)(urand() * nx), cj = (int)(urand() * ny), r = 1 + (int)(urand() * 4);
        for (int j = cj - r; j <= cj + r; j++)
            for (int i = ci - r; i <= ci + r; i++)
                if (i >= 0 && j >= 0 && i < nx && j < ny && (i - ci) * (i - ci) + (j - cj) * (j - cj) <= r * r)
                    land[(size_t)j * nx + i] = 1;
    }
    sph_params p;
    sph_params_default(&p);
    sph_landmask mask = {nx, ny, 0, 0, dx, dy, land, closed};
    sph_model *m = sph_model_create(&p, 16, &mask);
    CHECK(m != NULL, "model %d x %d", nx, ny);
    if (!m) {
        free(land);
        return -1;
    }
    sph_mark_near_land(m, radius);
    const int ri = (int)ceil(radius / dx) + 1, rj = (int)ceil(radius / dy) + 1;
    long bad = 0;
    *marked = 0;
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++) {
            int want = near_direct(land, nx, ny, closed, ri, rj, i, j);
            int got = m->near_land[(size_t)j * nx + i];
            bad += got != want;
            *marked += want;
        }
    CHECK(m->near_radius == radius, "the radius kept");
    sph_model_free(m);
    free(land);
    return bad;
}

int main(void)
{
    struct {
        int nx, ny;
        double dx, dy, frac;
        int blobs;
        double radius;
    } cases[] = {
        {97, 61, 100.0, 100.0, 0.01, 3, 250.0},  {97, 61, 100.0, 100.0, 0.2, 0, 50.0},
        {120, 80, 50.0, 120.0, 0.0005, 3, 300.0}, {64, 64, 300.0, 300.0, 0.02, 0, 10.0},
        {33, 47, 10.0, 10.0, 0.002, 2, 2000.0},  {1, 50, 100.0, 100.0, 0.05, 0, 300.0},
        {50, 1, 100.0, 100.0, 0.05, 0, 300.0},   {200, 150, 25.0, 25.0, 0.003, 10, 400.0},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++)
        for (int closed = 0; closed <= 1; closed++) {
            long marked = 0;
            long bad = one_case(cases[c].nx, cases[c].ny, cases[c].dx, cases[c].dy, cases[c].frac, cases[c].blobs,
                                closed, cases[c].radius, &marked);
            CHECK(bad == 0, "case %zu (%d x %d, radius %g, closed %d): %ld cells differ from the direct scan",
                  c, cases[c].nx, cases[c].ny, cases[c].radius, closed, bad);
            printf("  case %zu, closed %d: %ld of %d cells near land\n", c, closed, marked,
                   cases[c].nx * cases[c].ny);
        }
    /* all sea: nothing near land in an open domain; in a closed one the
     * cells within ri, rj of the edge (5 x 5 cells of 100 m, radius 150 m:
     * ri = rj = 3, so every cell of a 20 x 12 mask's outer 3 rings) */
    long marked = 0;
    long bad = one_case(20, 12, 100.0, 100.0, 0.0, 0, 0, 150.0, &marked);
    CHECK(bad == 0 && marked == 0, "all sea, open: %ld near land, %ld differ", marked, bad);
    bad = one_case(20, 12, 100.0, 100.0, 0.0, 0, 1, 150.0, &marked);
    CHECK(bad == 0 && marked == 20 * 12 - 14 * 6, "all sea, closed: %ld near land (the 3 outer rings: %d)", marked,
          20 * 12 - 14 * 6);
    return check_summary("test_near_land");
}
