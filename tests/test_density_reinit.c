/* Continuity density re-initialised by summation (model.density_reinit_steps,
 * docs/ocean.md "Session 9"): the periodic re-initialisation of Colagrossi &
 * Landrini (2003) applied to the mass per area M.
 *
 * Case: a 9 x 9 patch of ice (1 km lattice, A 0.95, 0.35 m) in free drift
 * without Coriolis on a divergent current u_w = D (x - xc), v_w = D (y - yc),
 * D = 2e-5 s^-1, no wind, no thermodynamics, dt 600 s, 12 h; the kernel and
 * its radius as the freeze-up scene (Gaussian, 2 h). Asserted:
 *  - with density_reinit_steps N = 6, after every diagnosis at a step count
 *    that is a multiple of N, every particle's M equals the summation written
 *    out here, dens_scale sum_j m_j W(r_kj, (h_k + h_j) / 2) with W the
 *    truncated Gaussian exp(-q^2) / (pi (1 - exp(-R^2)) hh^2), to 1e-12
 *    relative; so every footprint m / M is at most the self term's bound
 *    pi (1 - exp(-R^2)) h_k^2 / dens_scale (the bound summation puts on a
 *    particle pulled off the edge of a pack, which continuity does not have);
 *  - in between, M evolves by continuity: the patch's centre particle's
 *    footprint follows the material area of its lattice cell (the quad of
 *    its four neighbours' positions / 2) within 3 % at the end (the Gaussian's
 *    lattice sum at h >= 0.8 s differs from 1 / s^2 by 4 exp(-pi^2 (h / s)^2)
 *    < 0.1 %: Poisson summation; the rest is the lag of the ice behind the
 *    current across the patch), with and without the gradient correction,
 *    while the spacing (x1.98 here) stays below what the capped smoothing
 *    length sml_max_factor h0 = 2 h0 represents (on a 15 x 15 patch over 16 h,
 *    spacing x2.58, both options fall 3-5 % off: not asserted). Plain
 *    continuity is printed, not asserted: x4.09 against x3.92 with the
 *    correction, x2.97 against x3.89 without (its SPH divergence loses the
 *    receding neighbours);
 *  - plain continuity (N = 0): M is never the summation (the corner particle
 *    differs from it by more than 10 % at the end: the kernel deficiency of a
 *    free edge, which summation has and continuity does not);
 *  - mass is conserved to 1e-13 both ways. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "check.h"
#include "core/model.h"
#include "lattice.h"

#define NSIDE 9
#define DX 1000.0
#define DIV 2.0e-5
#define NSTEP 72
#define REINIT 6

static double summation_at(const sph_particles *P, size_t k, double R, double scale)
{
    double s = 0.0;
    for (size_t j = 0; j < P->n; j++) {
        double dx = P->x[k] - P->x[j], dy = P->y[k] - P->y[j];
        double hh = 0.5 * (P->sml[k] + P->sml[j]);
        double q2 = (dx * dx + dy * dy) / (hh * hh);
        if (q2 >= R * R)
            continue;
        s += P->mass[j] * exp(-q2) / (M_PI * (1.0 - exp(-R * R)) * hh * hh);
    }
    return scale * s;
}

static size_t by_id(const sph_particles *P, long id)
{
    for (size_t k = 0; k < P->n; k++)
        if (P->id[k] == id)
            return k;
    return 0;
}

/* the material area of the centre particle's cell: half the quad of its four lattice neighbours */
static double centre_cell_area(const sph_particles *P)
{
    const long c = (NSIDE / 2) * NSIDE + NSIDE / 2;
    size_t e = by_id(P, c + 1), n = by_id(P, c + NSIDE), w = by_id(P, c - 1), s = by_id(P, c - NSIDE);
    double ax = P->x[e] - P->x[w], ay = P->y[e] - P->y[w], bx = P->x[n] - P->x[s], by = P->y[n] - P->y[s];
    return 0.5 * fabs(ax * by - ay * bx) * 0.5;
}

static void run(int reinit, int gc)
{
    sph_params p;
    sph_params_default(&p);
    p.physics = SPH_PHYSICS_FREE_DRIFT;
    p.coriolis = 0;
    p.thermo_dt = 0;
    p.dt = 600.0;
    p.kernel = SPH_KERNEL_GAUSSIAN;
    p.kernel_radius = 2.0;
    p.summation_density = 0;
    p.density_reinit_steps = reinit;
    p.gradient_correction = gc;
    const size_t n = NSIDE * NSIDE;
    sph_model *m = sph_model_create(&p, n, NULL);
    CHECK(m != NULL, "model create");
    if (!m)
        return;
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, &p, NSIDE, NSIDE, 0.0, 0.0, DX, 0.35, 0.95, 40.6);
    const double c = (NSIDE - 1) * DX / 2.0;
    sph_status st;
    int ok = sph_model_init(m, &st) == SPH_STEP_OK;
    CHECK(ok, "init: %s %s", st.quantity, st.what);
    sph_model_clock clk;
    sph_model_get_clock(m, &clk);
    double mass0 = 0.0;
    for (size_t k = 0; k < P->n; k++)
        mass0 += P->mass[k];
    const double a0 = centre_cell_area(P);
    size_t kc0 = by_id(P, (NSIDE / 2) * NSIDE + NSIDE / 2);
    const double foot0 = P->mass[kc0] / P->dens[kc0];
    double worst_sum = 0.0, worst_bound = 0.0;
    int checks = 0;
    for (int s = 1; ok && s <= NSTEP; s++) {
        for (size_t k = 0; k < P->n; k++) {
            P->ua[k] = P->va[k] = 0.0;
            P->uw[k] = DIV * (P->x[k] - c);
            P->vw[k] = DIV * (P->y[k] - c);
        }
        ok = sph_model_step(m, &st) == SPH_STEP_OK;
        CHECK(ok, "step %d: %s %s", s, st.quantity, st.what);
        if (ok && reinit > 0 && s % reinit == 0) {
            ok = sph_model_diagnose(m, &st) == SPH_STEP_OK;
            checks++;
            for (size_t k = 0; ok && k < P->n; k++) {
                double ref = summation_at(P, k, p.kernel_radius, clk.dens_scale);
                worst_sum = fmax(worst_sum, fabs(P->dens[k] - ref) / ref);
                double bound = M_PI * (1.0 - exp(-p.kernel_radius * p.kernel_radius)) * P->sml[k] * P->sml[k] /
                               clk.dens_scale;
                worst_bound = fmax(worst_bound, P->mass[k] / P->dens[k] / bound);
            }
        }
    }
    if (ok) {
        double mass = 0.0;
        for (size_t k = 0; k < P->n; k++)
            mass += P->mass[k];
        const long cid = (NSIDE / 2) * NSIDE + NSIDE / 2;
        size_t kc = by_id(P, cid), k00 = by_id(P, 0);
        double foot = P->mass[kc] / P->dens[kc], area = centre_cell_area(P);
        double grow_f = foot / foot0, grow_a = area / a0;
        double corner = summation_at(P, k00, p.kernel_radius, clk.dens_scale);
        double corner_dev = fabs(P->dens[k00] - corner) / corner;
        printf("reinit %d, gradient correction %d: centre footprint x%.4f, material area x%.4f; corner M / summation - 1 = %.3f; "
               "dens_scale %.5f; %d re-initialisations: worst |M - summation| %.2e, worst footprint / bound %.3f; "
               "mass %.3e\n", reinit, gc, grow_f, grow_a, corner_dev, clk.dens_scale, checks, worst_sum, worst_bound,
               fabs(mass - mass0) / mass0);
        CHECK(grow_a > 1.5, "the patch diverged: material area x%.3f", grow_a);
        if (reinit > 0) /* h below its cap sml_max_factor h0 = 2 h0 (spacing x1.98 here) */
            CHECK(fabs(grow_f / grow_a - 1.0) < 0.03, "reinit %d, gradient correction %d: centre footprint follows "
                  "the material area: x%.4f against x%.4f", reinit, gc, grow_f, grow_a);
        CHECK(fabs(mass - mass0) <= 1e-13 * mass0, "reinit %d: mass conserved", reinit);
        if (reinit > 0) {
            CHECK(checks == NSTEP / reinit, "%d re-initialisations checked", checks);
            CHECK(worst_sum < 1e-12, "re-initialised M is the summation: worst %.2e", worst_sum);
            CHECK(worst_bound <= 1.0, "every re-initialised footprint within the self term's bound: %.4f",
                  worst_bound);
        } else {
            CHECK(corner_dev > 0.10, "plain continuity is not the summation at a free corner: %.3f", corner_dev);
        }
    }
    sph_model_free(m);
}

int main(void)
{
    run(0, 1);
    run(REINIT, 0);
    run(REINIT, 1);
    return check_summary("test_density_reinit");
}
