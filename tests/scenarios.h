/* Reference problems shared by the tests and the benchmarks (bench/):
 * the 1-D ice-against-a-coast channel and its analytic steady state
 * (PHYSICS.md section 8). Header-only so both link nothing extra. */
#ifndef SPHICE_TESTS_SCENARIOS_H
#define SPHICE_TESTS_SCENARIOS_H

#include <math.h>
#include <stdlib.h>

#include "core/model.h"
#include "lattice.h"

/* A channel of `ncross` particles across (free-slip side walls at x = 0
 * and x = W), a wall at y = 0, ice of thickness h0 and A = 1 from y = 0 to
 * L0, wind `wind` m/s towards the wall, no Coriolis, no current. */
typedef struct coast_case {
    sph_model *model;
    unsigned char *land;
    double dx, W, L0, h0, wind, tau;
} coast_case;

static inline int coast_setup(coast_case *c, const sph_params *prm, double dx, int ncross,
                              double L0, double h0, double wind)
{
    c->dx = dx;
    c->W = ncross * dx;
    c->L0 = L0;
    c->h0 = h0;
    c->wind = wind;
    c->tau = prm->rho_a * prm->Ca * wind * wind;
    int nalong = (int)floor(L0 / dx + 0.5);
    sph_landmask mk;
    mk.dx = mk.dy = dx / 2;
    mk.x0 = -4 * dx;
    mk.y0 = -4 * dx;
    mk.nx = (int)ceil((c->W + 8 * dx) / mk.dx);
    mk.ny = (int)ceil((L0 * 1.5 + 8 * dx) / mk.dy);
    mk.closed_outside = 1;
    c->land = calloc((size_t)mk.nx * mk.ny, 1);
    for (int j = 0; j < mk.ny; j++)
        for (int i = 0; i < mk.nx; i++) {
            double x = mk.x0 + (i + 0.5) * mk.dx, y = mk.y0 + (j + 0.5) * mk.dy;
            c->land[(size_t)j * mk.nx + i] = x < 0 || x > c->W || y < 0;
        }
    mk.land = c->land;
    sph_params p = *prm;
    p.coriolis = 0;
    p.thermo_dt = 0;
    c->model = sph_model_create(&p, (size_t)(ncross * nalong), &mk);
    if (!c->model)
        return -1;
    sph_particles *P = sph_model_particles(c->model);
    lattice_fill(P, &p, ncross, nalong, dx / 2, dx / 2, dx, h0, 1.0, 40.0);
    lattice_set_forcing(P, 0.0, -wind, 0, 0, 0, 0);
    return 0;
}

static inline void coast_free(coast_case *c)
{
    sph_model_free(c->model);
    free(c->land);
}

/* Analytic steady state, mean thickness hbar(y), for the model's pressure
 * P_int = P0 hbar exp(-C (1 - A)), ice initially A = 1, h_i = h0.
 *  - no replacement pressure: at rest sigma = -P/2 I, so
 *    d(P_int)/dy = -2 tau and P_int = 2 tau (L - y). Where P_int < P0 h0
 *    the ice has spread (A < 1, h_i = h0): A exp(-C(1-A)) = P_int/(P0 h0);
 *    elsewhere it has ridged (A = 1): hbar = P_int / P0.
 *  - replacement pressure: a converging ridged zone sits on the yield
 *    curve, sigma_yy = -k P, k = (1 + sqrt(1 + e^-2)) / 2, so hbar falls
 *    linearly from the wall with slope tau / (k P0) until it meets the
 *    unridged ice h0; the unridged ice (A = 1) is rigid and carries
 *    tau (L - y) up to k P0 h0, so L - L_r = k P0 h0 / tau.
 * L (edge) and L_r (ridged zone) follow from the ice volume V = h0 L0. */
typedef struct coast_analytic {
    int replacement;
    double P0, C, k, tau, h0, L, Lr;
} coast_analytic;

static inline double coast_conc_from_ratio(double C, double r)
{
    /* solve A exp(-C (1 - A)) = r for A in (0, 1] (monotone), bisection */
    double lo = 0, hi = 1;
    for (int i = 0; i < 60; i++) {
        double a = 0.5 * (lo + hi);
        if (a * exp(-C * (1 - a)) > r)
            hi = a;
        else
            lo = a;
    }
    return 0.5 * (lo + hi);
}

static inline double coast_hbar(const coast_analytic *a, double y)
{
    if (y >= a->L)
        return 0.0;
    if (a->replacement)
        return y < a->Lr ? a->h0 + a->tau / (a->k * a->P0) * (a->Lr - y) : a->h0;
    double Pint = 2.0 * a->tau * (a->L - y);
    if (Pint >= a->P0 * a->h0)
        return Pint / a->P0;
    return a->h0 * coast_conc_from_ratio(a->C, Pint / (a->P0 * a->h0));
}

static inline void coast_solve(coast_analytic *a, const sph_params *p, double tau, double h0,
                               double L0)
{
    a->replacement = p->replacement_pressure;
    a->P0 = p->P0;
    a->C = p->C;
    a->k = 0.5 * (1.0 + sqrt(1.0 + 1.0 / (p->ecc * p->ecc)));
    a->tau = tau;
    a->h0 = h0;
    double V = h0 * L0;
    if (a->replacement) {
        double D = a->k * p->P0 * h0 / tau;
        /* h0 (Lr + D) + tau Lr^2 / (2 k P0) = V */
        double qa = tau / (2 * a->k * p->P0), qb = h0, qc = h0 * D - V;
        a->Lr = qc >= 0 ? 0.0 : (-qb + sqrt(qb * qb - 4 * qa * qc)) / (2 * qa);
        a->L = a->Lr + D;
        if (qc >= 0) { /* wind too weak to ridge: pack stays as it is */
            a->L = L0;
            a->Lr = 0;
        }
        return;
    }
    a->Lr = 0;
    double lo = 0, hi = 10 * L0;
    for (int it = 0; it < 60; it++) {
        a->L = 0.5 * (lo + hi);
        double vol = 0;
        int n = 2000;
        for (int i = 0; i < n; i++)
            vol += coast_hbar(a, (i + 0.5) * a->L / n) * a->L / n;
        if (vol > V)
            hi = a->L;
        else
            lo = a->L;
    }
}

/* Steps until the kinetic energy per mass falls below ke_tol (m^2/s^2) or
 * max_steps; returns steps taken, negative on a model failure. */
static inline long coast_run(coast_case *c, long max_steps, double ke_tol, sph_status *st)
{
    long s;
    for (s = 0; s < max_steps; s++) {
        if (sph_model_step(c->model, st) != 0)
            return -1 - s;
        const sph_budget *b = sph_model_budget(c->model);
        if (s > 10 && b->kinetic_energy / b->mass < ke_tol)
            return s + 1;
    }
    return s;
}

/* Measured steady state of a replacement-pressure channel (the R300 peer
 * case), in the quantities the analytic state names:
 *  - edge: the outermost particle's position plus half its own extent
 *    along the channel (its area m / M over the channel width per
 *    particle, dx);
 *  - the ridged zone: a least-squares line through hbar = M / rho_i of the
 *    particles that have ridged (hbar > 1.02 h0), leaving out the wall's
 *    kernel support (y < 2 sml): wall thickness = the line at y = 0, ridged
 *    length = where the line meets h0.
 * Returns the number of particles in the fit (0: nothing has ridged). */
typedef struct coast_measured {
    double edge, Lr, hwall;
    int nfit;
} coast_measured;

static inline int coast_measure_ridged(const coast_case *c, const sph_params *p, double sml,
                                       coast_measured *out)
{
    sph_particles *P = sph_model_particles(c->model);
    double ymax = -HUGE_VAL, ext = 0.0;
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    int n = 0;
    for (size_t k = 0; k < P->n; k++) {
        double y = P->y[k], hb = P->dens[k] / p->rho_i;
        if (y > ymax) {
            ymax = y;
            ext = P->mass[k] / (P->dens[k] * c->dx);
        }
        if (y > 2.0 * sml && hb > 1.02 * c->h0) {
            sx += y;
            sy += hb;
            sxx += y * y;
            sxy += y * hb;
            n++;
        }
    }
    out->edge = ymax + 0.5 * ext;
    out->nfit = n;
    out->Lr = out->hwall = NAN;
    if (n >= 2) {
        double slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
        out->hwall = (sy - slope * sx) / n;
        out->Lr = (out->hwall - c->h0) / -slope;
    }
    return n;
}

#endif

/* Places the channel's particles in the analytic steady state: uniform
 * spacing dx, each particle carrying the analytic mean thickness at its
 * position (A < 1 at h_i = h0 where the ice has spread, A = 1 and
 * h_i = hbar where it has ridged), at rest, with the analytic stress in its
 * EVP memory: isotropic -P/2 without replacement pressure, sigma_yy =
 * -tau (L - y) with it. Replaces coast_setup's uniform pack. */
static inline int coast_setup_steady(coast_case *c, const sph_params *prm, double dx, int ncross,
                                     const coast_analytic *a, double wind)
{
    if (coast_setup(c, prm, dx, ncross, a->L, a->h0, wind))
        return -1;
    sph_particles *P = sph_model_particles(c->model);
    for (size_t k = 0; k < P->n; k++) {
        double y = P->y[k];
        double hb = coast_hbar(a, y);
        double A = 1.0, hi = hb;
        if (!a->replacement && hb < a->h0) {
            A = hb / a->h0;
            hi = a->h0;
        }
        P->conc[k] = A;
        P->thick[k] = hi;
        P->mass[k] = prm->rho_i * hb * dx * dx;
        if (a->replacement) {
            P->s22[k] = -a->tau * (a->L - y);
            P->s11[k] = 0.0;
        } else {
            double Pint = prm->P0 * hb * exp(-prm->C * (1.0 - A));
            P->s11[k] = P->s22[k] = -0.5 * Pint;
        }
    }
    return 0;
}
