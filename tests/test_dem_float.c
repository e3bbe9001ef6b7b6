/* A floating bonded sheet loaded at its free edge (issue 25: the cone's
 * bending failure, step by step; docs/dem.md, "The floating sheet").
 *
 * A strip of the close-packed sheet the bonds are calibrated on
 * (dem_add_sheet_hcp: three layers of r = 0.05 m spheres, h = 0.263 m, the
 * seed's 0.26 m ice; ny = 4 rows, b = 4 sqrt(3) r = 0.346 m: two rows,
 * 0.17 m, roll over, their metacentric height being negative) floats free;
 * its end column is pulled up -- the cone's direction: downward the sheet's
 * 3 cm freeboard ends the linear foundation long before it breaks -- by a
 * slowly increasing force P (PFC local damping: quasi-static). Against
 * Hetenyi (1946), a semi-infinite beam on an elastic foundation of modulus
 * k = rho_w g b loaded at its end:
 *   w0 = 2 P beta / k,  beta = (k / (4 E I))^(1/4),  I = b h^3 / 12,
 *   the moment's extreme 0.3224 P / beta at x = pi / (4 beta).
 *
 * Or (GUIDED) the strip is the half of one twice as long lifted at its
 * middle: its end a plane of symmetry (the spheres on it held in x and in
 * rotation), loaded with Q = P / 2 (Hetenyi's infinite beam under P):
 *   w0 = Q beta / k,  the moment's extreme Q / (2 beta) at the plane.
 *
 * make check: the elastic end deflection at E_b = 3 MPa (a short strip,
 * 1 / beta = 1.16 m, 3.5 m long, beta L = 3.0), free and guided, within
 * 20 % of w0 (the spheres' waterplane is 0.88 of the strip's at the
 * floating level and ripples by about +-25 % with depth, the hcp
 * lattice's E is E_b to a few per cent: together about 10 %).
 *
 * SPHICE_LONG: the default E_b (1 GPa, 1 / beta = 4.96 m, a 13 m strip,
 * beta L = 2.6, where the finite strip's moment is Hetenyi's to 0.5 %),
 * guided, the load ramped over 3 s to 1.6 x Hetenyi's failure load until
 * the strip breaks through: the first broken bond in the top layer within
 * 0.2 / beta of the plane; the load at which the strip fails -- its end's
 * compliance w / Q twice the elastic one -- against Hetenyi's load for the
 * flexural strength the default bonds are calibrated to (0.6 MPa,
 * test_dem_bend):
 *   Q_f = sigma_f (b h^2 / 6) 2 beta  (free end: sigma_f (b h^2 / 6) beta / 0.3224),
 * within [0.75, 1.3] x Q_f (docs/dem.md, "The floating strip": the
 * basis). Guided, not free: at Q_f the elastic lift of the middle is
 * 0.056 m, a quarter of the 0.231 m draft, where the free end's 0.174 m
 * (0.75 of it) lifts the lattice's bottom spheres towards the waterline
 * and the foundation is no longer Hetenyi's linear one.
 * SPHICE_DEM_FLOAT="nx E_b ramp_s [guided|free]" overrides. */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>

#include "check.h"
#include "core/dem.h"

/* The flexural strength the default bonds are calibrated to (test_dem_bend:
 * Xiu et al. 2022, Bohai ice, 0.5-0.7 MPa). */
#define SIGMA_F 0.6e6

/* Archimedes: the vertical shift that floats the strip (buoyancy of the
 * spheres' submerged caps = weight), by bisection. */
static double float_shift(const dem *d)
{
    double lo = -0.5, hi = 0.5, W = 0.0;
    for (size_t i = 0; i < d->n; i++)
        W += d->m[i] * d->p.gravity;
    for (int it = 0; it < 60; it++) {
        double mid = 0.5 * (lo + hi), B = 0.0;
        for (size_t i = 0; i < d->n; i++) {
            double r = d->r[i], s = r - (d->z[i] + mid);
            s = s < 0.0 ? 0.0 : (s > 2.0 * r ? 2.0 * r : s);
            B += d->p.water_density * d->p.gravity * M_PI * s * s * (3.0 * r - s) / 3.0;
        }
        if (B > W)
            lo = mid; /* too deep: raise it */
        else
            hi = mid;
    }
    return 0.5 * (lo + hi);
}

/* The loaded end: FREE, the strip's free end (Hetenyi's semi-infinite
 * beam loaded at its end); GUIDED, a plane of symmetry (the strip is the
 * half of a strip twice as long loaded at its middle: Hetenyi's infinite
 * beam under a point load 2 Q, of which the half carries Q). */
enum { FREE = 0, GUIDED = 1 };

typedef struct strip {
    dem *d;
    double b, h, beta, k, xmax, dt, dz_layer, zbot;
    int nend, mode;
    size_t *end;  /* the loaded spheres */
    double *xend; /* GUIDED: their x, held */
} strip;

/* GUIDED: the close-packed sheet cut at a plane through sphere centres,
 * x_s = 2 r (nx - 1), where the lattice is mirror-symmetric (every layer
 * and row has its x at whole or odd multiples of r): the spheres beyond
 * the plane are left out, those on it are held in x and in rotation (the
 * mirror's condition: no normal displacement, no rotation about an axis in
 * the plane) and carry the load; they keep their whole mass and buoyancy
 * (the mirror shares them: half a sphere column, r / (1 / beta) of the
 * foundation, about 1 % at 1 GPa). */
static void strip_build(strip *s, int nx, double E, int mode)
{
    dem_params p;
    dem_params_default(&p);
    p.bond_modulus = E;
    p.local_damping = 0.7;
    const int ny = 4, nz = 3;
    const double r = 0.05;
    size_t np = (size_t)nx * ny * nz;
    s->mode = mode;
    s->d = dem_create(np, 8 * np, &p);
    CHECK(s->d != NULL, "strip created");
    dem *d = s->d;
    if (mode == GUIDED) {
        dem *t = dem_create(np, 8 * np, &p);
        CHECK(t && dem_add_sheet_hcp(t, 0.0, 0.0, nx, ny, nz, r, 0.0, 0.0) == 0, "sheet built");
        double xs = 2.0 * r * (nx - 1);
        for (size_t i = 0; i < t->n; i++)
            if (t->x[i] < xs + 0.25 * r)
                dem_add_particle(d, t->x[i], t->y[i], t->z[i], r);
        dem_free(t);
        CHECK(dem_bond_touching(d, 1e-6) > 0, "strip bonded");
    } else {
        CHECK(dem_add_sheet_hcp(d, 0.0, 0.0, nx, ny, nz, r, 0.0, 0.0) == 0, "strip built");
    }
    double dz = float_shift(d);
    s->xmax = -HUGE_VAL;
    s->zbot = HUGE_VAL;
    for (size_t i = 0; i < d->n; i++) {
        d->z[i] += dz;
        s->xmax = fmax(s->xmax, d->x[i]);
        s->zbot = fmin(s->zbot, d->z[i]);
    }
    s->dz_layer = 2.0 * r * sqrt(2.0 / 3.0);
    s->end = malloc(d->n * sizeof *s->end);
    s->xend = malloc(d->n * sizeof *s->xend);
    s->nend = 0;
    for (size_t i = 0; i < d->n; i++)
        if (mode == GUIDED ? d->x[i] > s->xmax - 0.5 * r : d->x[i] > s->xmax - 2.5 * r) {
            s->xend[s->nend] = d->x[i];
            s->end[s->nend++] = i;
            if (mode == GUIDED)
                d->flags[i] = DEM_FIX_ROTATION;
        }
    s->b = ny * sqrt(3.0) * r;
    s->h = 2.0 * r + (nz - 1) * 2.0 * r * sqrt(2.0 / 3.0);
    s->k = p.water_density * p.gravity * s->b;
    s->beta = pow(s->k / (4.0 * E * s->b * pow(s->h, 3) / 12.0), 0.25);
    s->dt = 0.9 * p.dt_safety * dem_dt_critical(d);
}

static void strip_free(strip *s)
{
    dem_free(s->d);
    free(s->end);
    free(s->xend);
}

/* The layer (0 the bottom) of sphere i, from its height at rest. */
static int layer_of(const strip *s, double z0)
{
    return (int)lround((z0 - s->zbot) / s->dz_layer);
}

static double end_z(const strip *s)
{
    double z = 0.0;
    for (int q = 0; q < s->nend; q++)
        z += s->d->z[s->end[q]];
    return z / s->nend;
}

static void set_load(strip *s, double P)
{
    for (int q = 0; q < s->nend; q++)
        s->d->ext[3 * s->end[q] + 2] = P / s->nend;
}

/* One step; GUIDED: the plane's spheres put back on it (x held, at rest in
 * x: the step's x increment is the mirror's reaction, undone). */
static int strip_step(strip *s, sph_status *st)
{
    if (dem_step(s->d, s->dt, st) != SPH_STEP_OK)
        return -1;
    if (s->mode == GUIDED)
        for (int q = 0; q < s->nend; q++) {
            s->d->x[s->end[q]] = s->xend[q];
            s->d->vx[s->end[q]] = 0.0;
        }
    return 0;
}

static int run_for(strip *s, double t)
{
    sph_status st;
    long n = (long)(t / s->dt);
    for (long k = 0; k < n; k++)
        if (strip_step(s, &st))
            return -1;
    return 0;
}

/* Hetenyi: the end's compliance w0 / P and the load at which the extreme
 * fibre of the most loaded section reaches sigma_f (FREE: the moment's
 * extreme 0.3224 P / beta at pi / (4 beta); GUIDED: Q / (2 beta) at the
 * plane, the infinite beam's 2 Q / (4 beta)). */
static double compliance(const strip *s)
{
    return (s->mode == GUIDED ? 1.0 : 2.0) * s->beta / s->k;
}
static double moment_per_load(const strip *s)
{
    return s->mode == GUIDED ? 0.5 / s->beta : 0.3224 / s->beta;
}

static const char *mode_name(int mode)
{
    return mode == GUIDED ? "guided" : "free";
}

/* The elastic end deflection against Hetenyi's w0. */
static void test_elastic(int mode, int nx)
{
    strip s;
    const double E = 3.0e6;
    strip_build(&s, nx, E, mode);
    double t0 = omp_get_wtime();
    int bad = run_for(&s, 1.0);
    double z0 = end_z(&s);
    /* sigma at the most loaded section about 2 kPa: elastic, w0 about 1 cm */
    const double P = mode == GUIDED ? 30.0 : 20.0;
    long n = (long)(1.5 / s.dt);
    sph_status st;
    for (long k = 0; k < n && !bad; k++) {
        set_load(&s, P * (double)(k + 1) / (double)n);
        bad |= strip_step(&s, &st);
    }
    bad |= run_for(&s, 1.0);
    double w = end_z(&s) - z0, w_an = P * compliance(&s);
    CHECK(!bad, "elastic strip (%s end): steps ok", mode_name(mode));
    CHECK(s.d->bonds_broken_tension + s.d->bonds_broken_shear == 0, "elastic strip (%s end): no bond broke",
          mode_name(mode));
    printf("float elastic, %s end: %zu spheres, E_b %.3g Pa, b %.3f m, h %.3f m, beta %.4f /m (1/beta %.3f m,"
           " beta L %.2f), P %.1f N up: end deflection %.5f m, Hetenyi %s %.5f m (ratio %.3f);"
           " %.1f s wall\n",
           mode_name(mode), s.d->n, E, s.b, s.h, s.beta, 1.0 / s.beta, s.beta * s.xmax, P, w,
           mode == GUIDED ? "P beta / k" : "2 P beta / k", w_an, w / w_an, omp_get_wtime() - t0);
    CHECK(w > 0.8 * w_an && w < 1.2 * w_an, "%s end: deflection %.5f m within 20 %% of Hetenyi's %.5f m",
          mode_name(mode), w, w_an);
    strip_free(&s);
}

/* The break: the load ramped until the strip fails through. */
static void test_break(int mode, int nx, double E, double ramp)
{
    strip s;
    strip_build(&s, nx, E, mode);
    dem *d = s.d;
    double t0 = omp_get_wtime();
    int bad = run_for(&s, 1.0);
    double z0 = end_z(&s), Z = s.b * s.h * s.h / 6.0;
    double Pf = SIGMA_F * Z / moment_per_load(&s), comp = compliance(&s);
    double draft = -(s.zbot - s.d->r[0]), freeboard = s.h - draft;
    double Pmax = 1.6 * Pf, P = 0.0, p_first = -1.0, x_first = -1.0, p_fail = -1.0, c_04 = -1.0;
    int layer_first = -1, layer_a = -1, layer_b = -1;
    double *z_rest = malloc(d->n * sizeof *z_rest);
    for (size_t i = 0; i < d->n; i++)
        z_rest[i] = d->z[i];
    long n = (long)(ramp / s.dt);
    sph_status st;
    for (long k = 0; k < n && !bad; k++) {
        P = Pmax * (double)(k + 1) / (double)n;
        set_load(&s, P);
        bad |= strip_step(&s, &st);
        if (c_04 < 0.0 && P >= 0.4 * Pf)
            c_04 = (end_z(&s) - z0) / P / comp; /* quasi-static: the elastic compliance */
        if (p_first < 0.0 && d->bonds_broken_tension + d->bonds_broken_shear > 0) {
            p_first = P;
            for (size_t q = 0; q < d->nbonds; q++)
                if (d->bonds[q].broken) {
                    const dem_bond *bd = &d->bonds[q];
                    x_first = s.xmax - 0.5 * (d->x[bd->i] + d->x[bd->j]);
                    layer_a = layer_of(&s, z_rest[bd->i]);
                    layer_b = layer_of(&s, z_rest[bd->j]);
                    layer_first = layer_a == layer_b ? layer_a : -1;
                    break;
                }
        }
        if (p_first > 0.0 && k % 100 == 0 && (end_z(&s) - z0) / P > 2.0 * comp) {
            p_fail = P;
            break;
        }
    }
    free(z_rest);
    CHECK(!bad, "breaking strip (%s end): steps ok", mode_name(mode));
    double sf_first = p_first * moment_per_load(&s) / Z;
    double sf_fail = p_fail * moment_per_load(&s) / Z;
    /* the end lifts, the rest sinks: the free end's trough is 0.067 w0
     * down at 3 pi / (4 beta), the guided end's 0.043 w0 at pi / beta */
    double w0 = Pf * comp, sink = (mode == GUIDED ? 0.0432 : 0.0670) * w0;
    printf("float break, %s end: %zu spheres, E_b %.3g Pa, bonds sigma_t %.4g MPa, tau_c %.4g MPa; beta %.4f "
           "/m (1/beta %.2f m, beta L %.2f); Hetenyi's load for sigma_f %.2f MPa: %.1f N; its elastic end "
           "lift w0 %.4f m (draft %.3f m: %.2f of it), trough %.4f m down (freeboard %.3f m); dt %.3g s, "
           "%ld steps for the ramp; end compliance at 0.4 P_f %.3f of Hetenyi's\n",
           mode_name(mode), d->n, E, d->p.bond_tensile / 1e6, d->p.bond_shear / 1e6, s.beta, 1.0 / s.beta,
           s.beta * s.xmax, SIGMA_F / 1e6, Pf, w0, draft, w0 / draft, sink, freeboard, s.dt, n, c_04);
    printf("float break, %s end: first broken bond at P %.1f N (%.3f P_f: sigma %.4g MPa = %.3f sigma_t), "
           "%.2f m from the end, layers %d-%d; failed through (w/P twice elastic) at P %.1f N (%.3f P_f: "
           "sigma %.4g MPa), %ld + %ld bonds broken; %.1f s wall\n",
           mode_name(mode), p_first, p_first / Pf, sf_first / 1e6, sf_first / d->p.bond_tensile, x_first,
           layer_a, layer_b, p_fail, p_fail / Pf, sf_fail / 1e6, d->bonds_broken_tension,
           d->bonds_broken_shear, omp_get_wtime() - t0);
    if (mode == GUIDED) {
        /* the upward load at the middle arches the strip: the top fibre in
         * tension, the moment's extreme at the plane (0.64 of it at 0.2 /
         * beta, the free end's window's width) */
        CHECK(p_first > 0.0 && layer_first == 2,
              "the first bond broke in the top layer (in tension over the lifted middle)");
        CHECK(x_first < 0.2 / s.beta, "first break %.2f m from the plane, within 0.2 / beta = %.2f m",
              x_first, 0.2 / s.beta);
    } else {
        CHECK(p_first > 0.0 && layer_first == 0,
              "the first bond broke in the bottom layer (in tension under the lifted end)");
        CHECK(fabs(x_first - M_PI / 4.0 / s.beta) < 0.25 * M_PI / 4.0 / s.beta,
              "first break %.2f m from the end, Hetenyi's moment extreme at %.2f m", x_first,
              M_PI / 4.0 / s.beta);
    }
    CHECK(p_fail > 0.75 * Pf && p_fail < 1.3 * Pf,
          "the strip fails at %.1f N, within [0.75, 1.3] x Hetenyi's %.1f N for sigma_f %.2f MPa", p_fail,
          Pf, SIGMA_F / 1e6);
    strip_free(&s);
}

int main(void)
{
    setvbuf(stdout, NULL, _IOLBF, 0);
    test_elastic(FREE, 35);
    test_elastic(GUIDED, 36);
    if (check_long() || getenv("SPHICE_DEM_FLOAT")) {
        int nx = 130;
        double E = 1.0e9, ramp = 3.0;
        char end[16] = "guided";
        const char *e = getenv("SPHICE_DEM_FLOAT");
        if (e)
            sscanf(e, "%d %lf %lf %15s", &nx, &E, &ramp, end);
        test_break(end[0] == 'f' ? FREE : GUIDED, nx, E, ramp);
    }
    return check_summary("test_dem_float");
}
