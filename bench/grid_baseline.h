/* Eulerian grid baseline for the benchmarks: advection of cell-mean
 * fields (concentration A and mean thickness hbar = A h) by a prescribed
 * velocity field, in conservative flux form on a regular grid:
 *
 *   q_i^{n+1} = q_i^n - dt/dx (F_{i+1/2} - F_{i-1/2})   (then the same in y)
 *
 * with face velocities sampled at face centres. Schemes: first-order
 * upwind (donor cell) and the second-order flux-limited scheme of LeVeque
 * (2002, ch. 6): F = u q_upwind + |u|/2 (1 - |u| dt/dx) phi(theta) dq, with
 * the minmod, van Leer or superbee limiter. Two dimensions by Strang-style
 * alternating x-y / y-x sweeps. Each 1-D sweep is conservative (the flux
 * leaving one cell enters its neighbour) and stable for |u| dt/dx <= 1.
 * Boundary: empty ghost cells (open water flows in, no ice), outflow
 * leaves the grid (recorded in outflow[]).
 *
 * Not part of libsphice: bench programs and tests/test_grid_baseline.c
 * compile bench/grid_baseline.c with themselves. */
#ifndef SPHICE_BENCH_GRID_BASELINE_H
#define SPHICE_BENCH_GRID_BASELINE_H

typedef enum { GRID_UPWIND = 0, GRID_MINMOD, GRID_VANLEER, GRID_SUPERBEE } grid_scheme;

/* Velocity at (x, y) and time t, m/s. */
typedef void (*grid_velocity_fn)(double x, double y, double t, void *ctx, double *u, double *v);

typedef struct grid_adv {
    int nx, ny, nf;      /* cells, fields */
    double x0, y0, dx;   /* corner of cell (0,0), square cells */
    double *q;           /* nf * nx * ny, field f at q[f*nx*ny + j*nx + i] */
    double *work;        /* one row/column of fluxes */
    double outflow[8];   /* per field: sum of q dA that left the grid */
    long steps;
} grid_adv;

grid_adv *grid_adv_create(int nx, int ny, int nf, double x0, double y0, double dx);
void grid_adv_free(grid_adv *g);
static inline double *grid_adv_field(grid_adv *g, int f) { return g->q + (long)f * g->nx * g->ny; }
/* Largest step with Courant number `cfl` in every sweep at time t. */
double grid_adv_max_dt(const grid_adv *g, grid_velocity_fn vel, void *ctx, double t, double cfl);
/* One step of length dt from time t (velocities at t + dt/2). */
void grid_adv_step(grid_adv *g, grid_scheme s, grid_velocity_fn vel, void *ctx, double t,
                   double dt);
/* Sum of field f times the cell area. */
double grid_adv_total(const grid_adv *g, int f);

#endif
