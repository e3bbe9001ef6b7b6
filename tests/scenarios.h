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

/* Plastic wave (PHYSICS.md section 8, linearised uniaxial plastic
 * compression): packed ice (A = 1, h = 1 m, P* = 27.5e3, replacement
 * pressure, no drag, wind or Coriolis), 500 km of a channel 3 particles
 * wide at spacing dx, converging uniformly at 3e-5 s^-1 (v = -eps (y - yc):
 * every particle on the yield curve, stress initialised there; eps well
 * above the wave's own strain rates, c_p AMP / W = 3e-6 s^-1, so no part
 * of it unloads), with a 0.5 % Gaussian thickness bump (width 10 km) at
 * yc. The bump splits into two waves; *speed is the speed of one wave's
 * peak relative to the ice (least squares over 1 to 2.5 h), *cp the
 * analytic sqrt(k P* / rho_i). prm gives the kernel, smoothing, solver,
 * iterations, dt and max_neighbours. Returns 0, or the model's rc (with
 * *st) when init refused or a step failed. */
static inline int plastic_wave_run(const sph_params *prm, double dx, double *speed, double *cp,
                                   sph_status *st)
{
    sph_params pp = *prm;
    sph_params *p = &pp;
    p->physics = SPH_PHYSICS_FULL;
    p->replacement_pressure = 1;
    p->pressure_form = SPH_PRESSURE_SEED;
    p->P0 = 27.5e3;
    p->Cw = 0.0;
    /* pack from Y0 to Y0 + L0, converging uniformly on yc at EPS s^-1 */
    const double L0 = 500e3, Y0 = 100e3, yc = Y0 + 0.5 * L0, EPS = 3e-5, AMP = 0.005, W = 10e3;
    const double h0 = 1.0;
    coast_case cc;
    coast_setup(&cc, p, dx, 3, L0 + Y0, h0, 0.0);
    sph_particles *P = sph_model_particles(cc.model);
    double kk = 0.5 * (1 + sqrt(1 + 1 / (p->ecc * p->ecc)));
    double cp_ = sqrt(kk * p->P0 / p->rho_i);
    double *y0 = malloc(P->n * sizeof(double));
    long *ids = malloc(P->n * sizeof(long));
    size_t n = 0;
    for (size_t k = 0; k < P->n; k++) {
        if (P->y[k] < Y0)
            continue;
        double y = P->y[k], h = h0 * (1.0 + AMP * exp(-(y - yc) * (y - yc) / (W * W)));
        P->x[n] = P->x[k];
        P->y[n] = y;
        P->u[n] = 0.0;
        P->v[n] = -EPS * (y - yc);
        P->thick[n] = h;
        P->conc[n] = 1.0;
        P->mass[n] = p->rho_i * h * dx * dx;
        P->sml[n] = P->sml0[n] = P->sml[k];
        P->lat[n] = P->lat[k];
        P->id[n] = P->id[k];
        P->ua[n] = P->va[n] = P->uw[n] = P->vw[n] = P->sshx[n] = P->sshy[n] = 0.0;
        /* on the yield curve in uniaxial compression (e_yy < 0, e_xx = 0) */
        double Pn = p->P0 * h, rr = sqrt(1 + 1 / (p->ecc * p->ecc));
        P->s22[n] = -kk * Pn;
        P->s11[n] = -0.5 * Pn * (1 + (1 - 1 / (p->ecc * p->ecc)) / rr);
        P->s12[n] = 0.0;
        y0[n] = y;
        ids[n] = P->id[n];
        n++;
    }
    P->n = n;
    int rc = sph_model_init(cc.model, st);
    if (rc != 0) { /* outside the measured envelope */
        free(y0);
        free(ids);
        coast_free(&cc);
        return rc;
    }
    /* rows of the initial lattice within +-100 km of yc */
    const int nrow = 2 * (int)(100e3 / dx) + 1;
    double *rsum = malloc((size_t)nrow * sizeof(double)), *rcnt = malloc((size_t)nrow * sizeof(double));
    double T = 2.5 * 3600.0;
    long steps = (long)(T / p->dt + 0.5);
    double st_sum = 0, sy = 0, stt = 0, sty = 0;
    int np = 0;
    for (long s = 1; s <= steps; s++) {
        rc = sph_model_step(cc.model, st);
        if (rc != 0)
            break;
        double t = s * p->dt;
        if (t < 3600.0 || s % 8)
            continue;
        /* the front: the peak of the right-moving pulse, in the
         * particles' initial positions (Lagrangian labels xi): hbar
         * averaged across the channel per lattice row, the largest row
         * between 5 and 85 km from yc, refined by a parabola through it
         * and its neighbours. Every particle keeps its velocity -eps xi
         * (no forces but the wave's), so y - yc = xi (1 - eps t), and a
         * wave at speed c relative to the ice moves in labels as
         * d xi / d tau = c with tau = -ln(1 - eps t) / eps: the speed is
         * the slope of xi_front against tau. */
        for (int b = 0; b < nrow; b++)
            rsum[b] = rcnt[b] = 0.0;
        for (size_t k = 0; k < P->n; k++) {
            size_t q = 0;
            while (q < n && ids[q] != P->id[k])
                q++;
            if (q == n)
                continue;
            int b = (int)floor((y0[q] - yc) / dx + 0.5) + nrow / 2;
            if (b >= 0 && b < nrow) {
                rsum[b] += P->dens[k] / p->rho_i;
                rcnt[b] += 1.0;
            }
        }
        int best = -1;
        for (int b = nrow / 2 + (int)ceil(5e3 / dx); b < nrow - 1 && (b - nrow / 2) * dx <= 85e3; b++)
            if (rcnt[b] > 0 && (best < 0 || rsum[b] / rcnt[b] > rsum[best] / rcnt[best]))
                best = b;
        if (best > 0 && rcnt[best - 1] > 0 && rcnt[best + 1] > 0) {
            double fm = rsum[best - 1] / rcnt[best - 1], f0 = rsum[best] / rcnt[best],
                   fp = rsum[best + 1] / rcnt[best + 1];
            double den = fm - 2 * f0 + fp, off = den < 0 ? 0.5 * (fm - fp) / den : 0.0;
            double front = (best - nrow / 2 + off) * dx;
            t = -log(1.0 - EPS * t) / EPS;
            st_sum += t;
            sy += front;
            stt += t * t;
            sty += t * front;
            np++;
        }
    }
    *speed = np > 2 ? (np * sty - st_sum * sy) / (np * stt - st_sum * st_sum) : NAN;
    *cp = cp_;
    free(y0);
    free(ids);
    free(rsum);
    free(rcnt);
    coast_free(&cc);
    return rc;
}


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

/* The peer case R300 (PHYSICS.md section 8; tests/test_r300.c,
 * bench/bench_r300.c): Hibler's pressure with replacement pressure, aEVP
 * with 250 iterations, full physics, Gaussian truncated at 3 h, h = dx. */
static inline void r300_params(sph_params *p, double dt)
{
    sph_params_default(p);
    p->pressure_form = SPH_PRESSURE_HIBLER;
    p->P0 = 27.5e3;
    p->C = 20.0;
    p->ecc = 2.0;
    p->delta_min = 2e-9;
    p->replacement_pressure = 1;
    p->rho_a = 1.3;
    p->Ca = 1.2e-3;
    p->rho_w = 1026.0;
    p->Cw = 5.5e-3;
    p->rho_i = 900.0;
    p->dt = dt;
    p->solver = SPH_SOLVER_MEVP;
    p->evp_adaptive = 1;
    p->evp_iterations = 250;
    p->physics = SPH_PHYSICS_FULL;
    p->kernel = SPH_KERNEL_GAUSSIAN;
    p->kernel_radius = 3.0;
    p->sml_factor = 1.0;
}

#endif
