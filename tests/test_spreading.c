/* What internal stress can and cannot do to a drifting ice patch (issue 6,
 * the seed's finding "free drift spreads more").
 *
 * A patch of seed-like ice (A 0.95, 0.35 m, 11 x 11 particles at 1 km,
 * the seed's pressure P0 exp(-C (1 - A)) with P0 = 1e4) in open water, no
 * Coriolis, no thermodynamics, started at the forcing's free-drift
 * velocity, run 12 h with full viscous-plastic physics and in free drift.
 *
 * 1. Shear: an ocean current u_w = gamma (y - y0), v_w = 0, no wind.
 *    Free drift: every particle keeps the water's velocity, so positions
 *    follow the kinematics exactly, x = x0 + gamma (y0 - y_c) t, and the
 *    mass-weighted mean square radius about the centre grows from R0^2 to
 *    R0^2 (1 + gamma^2 t^2 / 2) (a square lattice: <y'^2> = R0^2 / 2).
 *    With stress: the ice resists shear up to its yield strength, so the
 *    patch spreads less and its particle velocities are more uniform (the
 *    seed's finding; it needs forcing that differs across the patch), while
 *    its area grows at least as much: on the elliptical yield curve plastic
 *    shear comes with divergence.
 * 2. Divergence: a radially divergent wind (an anticyclone's outflow),
 *    no current. Free drift without Coriolis moves at sqrt(rho_a Ca /
 *    (rho_w Cw)) times the wind, so every distance from the centre grows
 *    as exp(r D t). Hibler's ice has no tensile strength (the yield ellipse
 *    passes through the origin), so internal stress cannot hold diverging
 *    ice together: the same spreading with stress, and an area at least
 *    as large.
 * 3. Convergence: the same wind reversed. Free drift contracts as
 *    exp(-r D t); the stress run resists (the pressure rises as A -> 1):
 *    it contracts less and keeps a larger area.
 *
 * Spreading is measured by the RMS radius (positions only). The area, sum
 * m / (rho_i A h), depends on the continuity concentration, which at a
 * free edge (kernel deficiency) follows a divergence only in part: in free
 * drift it grows x1.27 where the kinematics give x1.33, and changes by a
 * couple of percent in pure shear; it is compared between the two runs.
 * With the kernel gradient correction (model.gradient_correction, off by
 * default) the free-drift area follows the kinematics (x1.32, asserted
 * within 1 %).
 *
 * So "larger area growth in free drift" cannot come from the rheology
 * (docs/demo.md): in the demo's smooth synthetic forcing the patch moves
 * nearly rigidly and the stress run spreads more. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "check.h"
#include "core/model.h"
#include "lattice.h"

#define NSIDE 11
#define DX 1000.0
#define HOURS 12.0
#define GAMMA 2.0e-5 /* s^-1: 0.2 m/s across the 10 km patch */
#define WIND_DIV 2.0e-4 /* s^-1: 10 m/s wind 50 km from the centre */

typedef struct patch_stats {
    double r2;    /* mass-weighted mean square distance from the centre, m^2 */
    double area;  /* sum m / (rho_i A h), m^2 */
    double vsd;   /* mass-weighted RMS velocity deviation from the mean, m/s */
} patch_stats;

static void stats(const sph_particles *P, const sph_params *p, patch_stats *s)
{
    double M = 0, xc = 0, yc = 0, uc = 0, vc = 0;
    for (size_t k = 0; k < P->n; k++) {
        M += P->mass[k];
        xc += P->mass[k] * P->x[k];
        yc += P->mass[k] * P->y[k];
        uc += P->mass[k] * P->u[k];
        vc += P->mass[k] * P->v[k];
    }
    xc /= M;
    yc /= M;
    uc /= M;
    vc /= M;
    s->r2 = s->area = s->vsd = 0;
    for (size_t k = 0; k < P->n; k++) {
        double dx = P->x[k] - xc, dy = P->y[k] - yc, du = P->u[k] - uc, dv = P->v[k] - vc;
        s->r2 += P->mass[k] * (dx * dx + dy * dy);
        s->vsd += P->mass[k] * (du * du + dv * dv);
        s->area += P->mass[k] / (p->rho_i * P->conc[k] * P->thick[k]);
    }
    s->r2 /= M;
    s->vsd = sqrt(s->vsd / M);
}

enum { SHEAR, DIVERGE, CONVERGE };

/* Forcing at a point: the water for SHEAR, the wind for DIVERGE. */
static void forcing_at(int kind, double x, double y, double *ua, double *va, double *uw, double *vw)
{
    const double c = (NSIDE - 1) * DX / 2.0;
    *ua = *va = *uw = *vw = 0.0;
    if (kind == SHEAR) {
        *uw = GAMMA * (y - c);
    } else {
        double d = kind == DIVERGE ? WIND_DIV : -WIND_DIV;
        *ua = d * (x - c);
        *va = d * (y - c);
    }
}

/* Free drift without Coriolis or turning: ice speed / wind speed. */
static double wind_factor(void)
{
    sph_params p;
    sph_params_default(&p);
    return sqrt(p.rho_a * p.Ca / (p.rho_w * p.Cw));
}

/* Runs the patch; s0, s1: statistics at the start and the end; rms_err:
 * RMS distance of the particles from the free-drift kinematics of SHEAR
 * (m; NaN otherwise). Returns 0 or the step's error. */
static int run(int kind, sph_physics_mode physics, int gc, patch_stats *s0, patch_stats *s1, double *rms_err)
{
    sph_params p;
    sph_params_default(&p);
    p.physics = physics;
    p.pressure_form = SPH_PRESSURE_SEED;
    p.P0 = 1.0e4;
    p.C = 20.0;
    p.coriolis = 0;
    p.thermo_dt = 0;
    p.dt = 60.0;
    p.gradient_correction = gc;
    const size_t n = NSIDE * NSIDE;
    sph_model *m = sph_model_create(&p, n, NULL);
    CHECK(m != NULL, "model create");
    if (!m)
        return -1;
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, &p, NSIDE, NSIDE, 0.0, 0.0, DX, 0.35, 0.95, 40.6);
    double x0[NSIDE * NSIDE], y0[NSIDE * NSIDE]; /* start positions by particle id */
    double ua, va, uw, vw;
    for (size_t k = 0; k < n; k++) {
        x0[P->id[k]] = P->x[k];
        y0[P->id[k]] = P->y[k];
        forcing_at(kind, P->x[k], P->y[k], &ua, &va, &uw, &vw);
        /* start at the free-drift velocity: the water's; with wind, the
         * steady free drift without Coriolis, u = sqrt(rho_a Ca /
         * (rho_w Cw)) U_a */
        P->u[k] = uw + wind_factor() * ua;
        P->v[k] = vw + wind_factor() * va;
    }
    sph_status st;
    int rc = sph_model_init(m, &st);
    CHECK(rc == 0, "model init: %s %s", st.quantity ? st.quantity : "", st.what ? st.what : "");
    stats(P, &p, s0);
    long steps = (long)(HOURS * 3600.0 / p.dt + 0.5);
    for (long s = 0; rc == 0 && s < steps; s++) {
        for (size_t k = 0; k < P->n; k++) {
            forcing_at(kind, P->x[k], P->y[k], &P->ua[k], &P->va[k], &P->uw[k], &P->vw[k]);
            P->sshx[k] = P->sshy[k] = 0.0;
        }
        rc = sph_model_step(m, &st);
    }
    CHECK(rc == 0, "%s run: step failed: %s", physics == SPH_PHYSICS_FREE_DRIFT ? "free drift" : "stress",
          st.what ? st.what : "");
    stats(P, &p, s1);
    *rms_err = NAN;
    if (kind == SHEAR) {
        double e2 = 0, t = steps * p.dt, c = (NSIDE - 1) * DX / 2.0;
        for (size_t k = 0; k < P->n; k++) {
            long i = P->id[k];
            double xa = x0[i] + GAMMA * (y0[i] - c) * t;
            e2 += (P->x[k] - xa) * (P->x[k] - xa) + (P->y[k] - y0[i]) * (P->y[k] - y0[i]);
        }
        *rms_err = sqrt(e2 / (double)P->n);
    }
    CHECK(P->n == n, "particles %zu of %zu", P->n, n);
    sph_model_free(m);
    return rc;
}

/* Both runs of one forcing: free drift (f) and full physics (s); growth
 * of the area (a) and of the RMS radius (g) from start to end. */
typedef struct pair {
    patch_stats f0, f1, s0, s1;
    double af, as, gf, gs;
    double err_f; /* free drift's distance from the shear kinematics, m */
} pair;

static int run_pair(int kind, pair *q)
{
    double err_s;
    if (run(kind, SPH_PHYSICS_FREE_DRIFT, 0, &q->f0, &q->f1, &q->err_f) != 0 ||
        run(kind, SPH_PHYSICS_FULL, 0, &q->s0, &q->s1, &err_s) != 0)
        return -1;
    q->af = q->f1.area / q->f0.area;
    q->as = q->s1.area / q->s0.area;
    q->gf = sqrt(q->f1.r2 / q->f0.r2);
    q->gs = sqrt(q->s1.r2 / q->s0.r2);
    return 0;
}

int main(void)
{
    const double t = HOURS * 3600.0;
    pair q;

    /* 1. shear */
    if (run_pair(SHEAR, &q) == 0) {
        /* <y'^2> of the lattice: its mean square distance about the centre
         * is <x'^2> + <y'^2> with both equal (a square lattice) */
        double want = q.f0.r2 + GAMMA * GAMMA * t * t * 0.5 * q.f0.r2;
        printf("shear: RMS radius x%.4f free drift (kinematics x%.4f; particles %.3g m from it), x%.4f with "
               "stress; area x%.4f / x%.4f; velocity spread %.4f / %.4f m/s\n",
               q.gf, sqrt(want / q.f0.r2), q.err_f, q.gs, q.af, q.as, q.f1.vsd, q.s1.vsd);
        CHECK_CLOSE(q.f1.r2, want, 1e-9, 0, "free drift: mean square radius against the shear kinematics");
        CHECK(q.err_f < 1e-6 * DX, "free drift: particles %.3g m from the kinematics", q.err_f);
        CHECK(q.gs < q.gf, "with stress the patch spreads less in shear: RMS radius x%.4f against free drift's x%.4f",
              q.gs, q.gf);
        CHECK(q.s1.vsd < q.f1.vsd, "with stress the velocities are more uniform: %.4f against %.4f m/s", q.s1.vsd,
              q.f1.vsd);
        CHECK(q.as >= q.af, "with stress the area grows at least as much (dilatancy): x%.4f against x%.4f", q.as,
              q.af);
    }

    /* 2. divergence */
    if (run_pair(DIVERGE, &q) == 0) {
        /* free drift: u = r U_a = r D (x - c), so every distance from the
         * centre grows as exp(r D t) (less a lag of the drag's time scale,
         * minutes, against the 12 h) */
        double want = exp(wind_factor() * WIND_DIV * t);
        printf("divergence: RMS radius x%.4f free drift (kinematics x%.4f), x%.4f with stress; area x%.4f / x%.4f\n",
               q.gf, want, q.gs, q.af, q.as);
        CHECK_CLOSE(q.gf, want, 0.005, 0, "free drift: RMS radius against exp(r D t)");
        CHECK_CLOSE(q.gs, q.gf, 0.005, 0, "no tensile strength: RMS radius with stress equals free drift's");
        CHECK(q.as >= q.af, "no tensile strength: area with stress x%.4f, free drift x%.4f", q.as, q.af);
        /* the area through the continuity concentration: at the patch's
         * free edge the kernel is deficient and the SPH divergence of the
         * default operator falls short (x1.27 against x1.33); the kernel
         * gradient correction (Bonet & Lok) makes it exact for a linear
         * velocity, so the area follows exp(2 r D t) */
        patch_stats g0, g1;
        double e;
        if (run(DIVERGE, SPH_PHYSICS_FREE_DRIFT, 1, &g0, &g1, &e) == 0) {
            printf("divergence, gradient correction: area x%.4f free drift (kinematics x%.4f; x%.4f without)\n",
                   g1.area / g0.area, want * want, q.af);
            CHECK_CLOSE(g1.area / g0.area, want * want, 0.01, 0,
                        "free drift with gradient correction: area against exp(2 r D t)");
        }
    }

    /* 3. convergence */
    if (run_pair(CONVERGE, &q) == 0) {
        double want = exp(-wind_factor() * WIND_DIV * t);
        printf("convergence: RMS radius x%.4f free drift (kinematics x%.4f), x%.4f with stress; area x%.4f / "
               "x%.4f\n",
               q.gf, want, q.gs, q.af, q.as);
        CHECK_CLOSE(q.gf, want, 0.005, 0, "free drift: RMS radius against exp(-r D t)");
        CHECK(q.gs > q.gf, "stress resists convergence: RMS radius x%.4f against free drift's x%.4f", q.gs, q.gf);
        CHECK(q.as > q.af, "stress resists convergence: area x%.4f against free drift's x%.4f", q.as, q.af);
    }
    return check_summary("test_spreading");
}
