/* See grid_baseline.h. */
#include "grid_baseline.h"

#include <math.h>
#include <stdlib.h>

grid_adv *grid_adv_create(int nx, int ny, int nf, double x0, double y0, double dx)
{
    if (nx < 2 || ny < 2 || nf < 1 || nf > 8 || !(dx > 0))
        return NULL;
    grid_adv *g = calloc(1, sizeof *g);
    if (!g)
        return NULL;
    g->nx = nx;
    g->ny = ny;
    g->nf = nf;
    g->x0 = x0;
    g->y0 = y0;
    g->dx = dx;
    g->q = calloc((size_t)nf * nx * ny, sizeof(double));
    int m = (nx > ny ? nx : ny) + 8;
    g->work = calloc((size_t)3 * m, sizeof(double));
    if (!g->q || !g->work) {
        grid_adv_free(g);
        return NULL;
    }
    return g;
}

void grid_adv_free(grid_adv *g)
{
    if (!g)
        return;
    free(g->q);
    free(g->work);
    free(g);
}

double grid_adv_max_dt(const grid_adv *g, grid_velocity_fn vel, void *ctx, double t, double cfl)
{
    double umax = 0.0;
    for (int j = 0; j <= g->ny; j++)
        for (int i = 0; i <= g->nx; i++) {
            double u, v;
            vel(g->x0 + i * g->dx, g->y0 + (j + 0.5) * g->dx, t, ctx, &u, &v);
            umax = fmax(umax, fabs(u));
            vel(g->x0 + (i + 0.5) * g->dx, g->y0 + j * g->dx, t, ctx, &u, &v);
            umax = fmax(umax, fabs(v));
        }
    return umax > 0 ? cfl * g->dx / umax : HUGE_VAL;
}

static double limiter(grid_scheme s, double th)
{
    switch (s) {
    case GRID_MINMOD:
        return fmax(0.0, fmin(1.0, th));
    case GRID_VANLEER:
        return (th + fabs(th)) / (1.0 + fabs(th));
    case GRID_SUPERBEE:
        return fmax(0.0, fmax(fmin(1.0, 2.0 * th), fmin(2.0, th)));
    default:
        return 0.0;
    }
}

/* One conservative 1-D sweep over a line of n cells with stride `st`
 * starting at q; un[k] is the velocity at face k (k = 0..n, face k is the
 * left face of cell k); nu = dt/dx. Returns the amount that left. */
static double sweep(double *q, long st, int n, const double *un, double nu, grid_scheme s,
                    double *flux)
{
#define Q(i) ((i) < 0 || (i) >= n ? 0.0 : q[(long)(i) * st])
    for (int k = 0; k <= n; k++) {
        double u = un[k];
        double ql = Q(k - 1), qr = Q(k);
        double dq = qr - ql;
        double f = u >= 0 ? u * ql : u * qr;
        if (s != GRID_UPWIND && dq != 0.0) {
            double dup = u >= 0 ? Q(k - 1) - Q(k - 2) : Q(k + 1) - Q(k);
            double th = dup / dq;
            f += 0.5 * fabs(u) * (1.0 - fabs(u) * nu) * limiter(s, th) * dq;
        }
        flux[k] = f;
    }
#undef Q
    for (int k = 0; k < n; k++)
        q[(long)k * st] -= nu * (flux[k + 1] - flux[k]);
    return nu * (flux[n] - flux[0]); /* net outflow in q * dx units */
}

static void sweep_x(grid_adv *g, grid_scheme s, grid_velocity_fn vel, void *ctx, double t,
                    double dt)
{
    double *un = g->work, *flux = g->work + g->nx + 8;
    double nu = dt / g->dx;
    for (int j = 0; j < g->ny; j++) {
        double y = g->y0 + (j + 0.5) * g->dx;
        for (int i = 0; i <= g->nx; i++) {
            double v;
            vel(g->x0 + i * g->dx, y, t, ctx, &un[i], &v);
        }
        for (int f = 0; f < g->nf; f++) {
            double *row = grid_adv_field(g, f) + (long)j * g->nx;
            g->outflow[f] += sweep(row, 1, g->nx, un, nu, s, flux) * g->dx * g->dx;
        }
    }
}

static void sweep_y(grid_adv *g, grid_scheme s, grid_velocity_fn vel, void *ctx, double t,
                    double dt)
{
    int m = g->nx > g->ny ? g->nx : g->ny;
    double *vn = g->work, *flux = g->work + m + 8;
    double nu = dt / g->dx;
    for (int i = 0; i < g->nx; i++) {
        double x = g->x0 + (i + 0.5) * g->dx;
        for (int j = 0; j <= g->ny; j++) {
            double u;
            vel(x, g->y0 + j * g->dx, t, ctx, &u, &vn[j]);
        }
        for (int f = 0; f < g->nf; f++) {
            double *col = grid_adv_field(g, f) + i;
            g->outflow[f] += sweep(col, g->nx, g->ny, vn, nu, s, flux) * g->dx * g->dx;
        }
    }
}

void grid_adv_step(grid_adv *g, grid_scheme s, grid_velocity_fn vel, void *ctx, double t,
                   double dt)
{
    double tm = t + 0.5 * dt;
    if (g->steps % 2 == 0) {
        sweep_x(g, s, vel, ctx, tm, dt);
        sweep_y(g, s, vel, ctx, tm, dt);
    } else {
        sweep_y(g, s, vel, ctx, tm, dt);
        sweep_x(g, s, vel, ctx, tm, dt);
    }
    g->steps++;
}

double grid_adv_total(const grid_adv *g, int f)
{
    const double *q = g->q + (long)f * g->nx * g->ny;
    double s = 0.0;
    for (long k = 0; k < (long)g->nx * g->ny; k++)
        s += q[k];
    return s * g->dx * g->dx;
}
