/* The benchmarks' Eulerian grid baseline (bench/grid_baseline.c):
 * conservation of the flux form (closed and with outflow accounted), and
 * exact translation at Courant number 1 (a 1-cell-per-step shift is exact
 * for upwind and for every limited scheme, whose correction carries the
 * factor 1 - |u| dt/dx = 0). Expected values: the conservation law and the
 * exact solution q(x - u t). */
#include <math.h>
#include <stdlib.h>

#include "check.h"
#include "../bench/grid_baseline.c"

static void uniform(double x, double y, double t, void *ctx, double *u, double *v)
{
    const double *c = ctx;
    (void)x, (void)y, (void)t;
    *u = c[0];
    *v = c[1];
}

static void rotation(double x, double y, double t, void *ctx, double *u, double *v)
{
    const double *c = ctx; /* omega, centre */
    (void)t;
    *u = -c[0] * (y - c[2]);
    *v = c[0] * (x - c[1]);
}

static void test_translation(void)
{
    const grid_scheme schemes[] = {GRID_UPWIND, GRID_MINMOD, GRID_VANLEER, GRID_SUPERBEE};
    for (int s = 0; s < 4; s++) {
        int n = 40;
        double dx = 500.0, dt = 100.0;
        grid_adv *g = grid_adv_create(n, n, 2, 0, 0, dx);
        double *a = grid_adv_field(g, 0), *h = grid_adv_field(g, 1);
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                int in = (i - 10) * (i - 10) + (j - 12) * (j - 12) < 36;
                a[j * n + i] = in ? 0.9 : 0.0;
                h[j * n + i] = in ? 0.45 + 0.01 * i : 0.0;
            }
        double vel[2] = {dx / dt, dx / dt}; /* Courant 1 in both sweeps */
        int steps = 7;
        for (int k = 0; k < steps; k++)
            grid_adv_step(g, schemes[s], uniform, vel, k * dt, dt);
        double worst = 0.0;
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                int i0 = i - steps, j0 = j - steps;
                int in = (i0 - 10) * (i0 - 10) + (j0 - 12) * (j0 - 12) < 36;
                double wa = in ? 0.9 : 0.0, wh = in ? 0.45 + 0.01 * i0 : 0.0;
                worst = fmax(worst, fabs(a[j * n + i] - wa));
                worst = fmax(worst, fabs(h[j * n + i] - wh));
            }
        CHECK(worst < 1e-12, "scheme %d: Courant-1 shift exact (max error %g)", s, worst);
        grid_adv_free(g);
    }
}

static void test_conservation(void)
{
    const grid_scheme schemes[] = {GRID_UPWIND, GRID_VANLEER, GRID_SUPERBEE};
    for (int s = 0; s < 3; s++) {
        int n = 60;
        double dx = 1000.0;
        grid_adv *g = grid_adv_create(n, n, 1, -30e3, -30e3, dx);
        double *a = grid_adv_field(g, 0);
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                double x = -30e3 + (i + 0.5) * dx, y = -30e3 + (j + 0.5) * dx;
                a[j * n + i] = hypot(x - 10e3, y) < 6e3 ? 0.9 : 0.0;
            }
        double tot0 = grid_adv_total(g, 0);
        double rot[3] = {2 * M_PI / (96 * 3600.0), 0, 0};
        double t = 0.0;
        double dt = grid_adv_max_dt(g, rotation, rot, 0, 0.8);
        CHECK(dt > 0 && dt < 1e5, "CFL step %g", dt);
        for (int k = 0; k < 200; k++, t += dt)
            grid_adv_step(g, schemes[s], rotation, rot, t, dt);
        double tot = grid_adv_total(g, 0);
        CHECK(fabs(tot + g->outflow[0] - tot0) <= 1e-12 * tot0, "scheme %d: mass + outflow conserved", s);
        CHECK(fabs(g->outflow[0]) < 1e-3 * tot0, "scheme %d: (almost) nothing left the grid: %g of %g", s, g->outflow[0], tot0);
        double mn = 0, mx = 0;
        for (int k = 0; k < n * n; k++) {
            mn = fmin(mn, a[k]);
            mx = fmax(mx, a[k]);
        }
            CHECK(mn > -1e-12 && mx < 0.9 + 1e-12, "scheme %d: bounded (TVD) [%g, %g]", s, mn, mx);
        grid_adv_free(g);
    }
    /* outflow through an open side is accounted */
    grid_adv *g = grid_adv_create(20, 10, 1, 0, 0, 100.0);
    double *a = grid_adv_field(g, 0);
    for (int k = 0; k < 200; k++)
        a[k] = 1.0;
    double vel[2] = {5.0, 0.0};
    double tot0 = grid_adv_total(g, 0);
    for (int k = 0; k < 30; k++)
        grid_adv_step(g, GRID_VANLEER, uniform, vel, k * 10.0, 10.0);
    CHECK_CLOSE(grid_adv_total(g, 0) + g->outflow[0], tot0, 1e-12, 0, "outflow accounted");
    grid_adv_free(g);
}

int main(void)
{
    test_translation();
    test_conservation();
    return check_summary("test_grid_baseline");
}
