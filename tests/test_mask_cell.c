/* The land mask's cell of a point (coast.c's mask_cell, behind
 * sph_is_land) is taken from a product with the cell size's reciprocal
 * and falls back to the division near cell edges: it must be the cell
 * floor((x - x0) / dx), floor((y - y0) / dy) of the division everywhere.
 * Checked on a mask with cell sizes and origin that no binary fraction
 * holds, at every cell edge x0 + i dx as rounded, one and two units in the
 * last place either side of it, and at pseudo-random points, against the
 * division evaluated here. */
#include <math.h>
#include <stdlib.h>

#include "check.h"
#include "../src/core/model_impl.h"

enum { NX = 37, NY = 29 };

static int land_ref(const sph_landmask *k, double x, double y)
{
    double fi = floor((x - k->x0) / k->dx), fj = floor((y - k->y0) / k->dy);
    if (!(fi >= 0 && fj >= 0 && fi < k->nx && fj < k->ny))
        return k->closed_outside;
    return k->land[(size_t)fj * k->nx + (size_t)fi] != 0;
}

int main(void)
{
    static unsigned char land[NX * NY];
    for (int j = 0; j < NY; j++)
        for (int i = 0; i < NX; i++)
            land[j * NX + i] = (i * 7 + j * 3) % 5 == 0;
    for (int closed = 0; closed <= 1; closed++) {
        sph_landmask mask = {NX, NY, -3e4 / 7.0, 1e5 / 3.0, 1234.567, 987.6543, land, closed};
        sph_params p;
        sph_params_default(&p);
        sph_model *m = sph_model_create(&p, 16, &mask);
        CHECK(m != NULL, "model with a mask");
        if (!m)
            continue;
        long tried = 0, differ = 0;
        /* the edges in x at rows' centres, and in y at columns' centres */
        for (int i = -1; i <= NX + 1; i++)
            for (int j = 0; j < NY; j++) {
                double xe = mask.x0 + i * mask.dx, yc = mask.y0 + (j + 0.5) * mask.dy;
                double ye = mask.y0 + i % (NY + 1) * mask.dy, xc = mask.x0 + (j % NX + 0.5) * mask.dx;
                double xs[5] = {nextafter(nextafter(xe, -INFINITY), -INFINITY), nextafter(xe, -INFINITY), xe,
                                nextafter(xe, INFINITY), nextafter(nextafter(xe, INFINITY), INFINITY)};
                double ys[5] = {nextafter(nextafter(ye, -INFINITY), -INFINITY), nextafter(ye, -INFINITY), ye,
                                nextafter(ye, INFINITY), nextafter(nextafter(ye, INFINITY), INFINITY)};
                for (int q = 0; q < 5; q++) {
                    differ += sph_is_land(m, xs[q], yc) != land_ref(&mask, xs[q], yc);
                    differ += sph_is_land(m, xc, ys[q]) != land_ref(&mask, xc, ys[q]);
                    tried += 2;
                }
            }
        srand(7);
        for (int r = 0; r < 200000; r++) {
            double x = mask.x0 + (1.1 * rand() / RAND_MAX - 0.05) * NX * mask.dx;
            double y = mask.y0 + (1.1 * rand() / RAND_MAX - 0.05) * NY * mask.dy;
            differ += sph_is_land(m, x, y) != land_ref(&mask, x, y);
            tried++;
        }
        differ += sph_is_land(m, NAN, 0.0) != land_ref(&mask, NAN, 0.0);
        differ += sph_is_land(m, INFINITY, mask.y0) != land_ref(&mask, INFINITY, mask.y0);
        tried += 2;
        CHECK(differ == 0, "closed %d: %ld of %ld points in another cell than the division's", closed, differ,
              tried);
        printf("mask cell vs division (closed %d): %ld points, %ld differ\n", closed, tried, differ);
        sph_model_free(m);
    }
    return check_summary("test_mask_cell");
}
