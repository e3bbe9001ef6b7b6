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
 * make check: the elastic end deflection at E_b = 3 MPa (a short strip,
 * 1 / beta = 1.16 m, 3.5 m long, beta L = 3.0) within 20 % of w0 (the
 * spheres' waterplane is 0.88 of the strip's at the floating level and
 * ripples by about +-25 % with depth, the hcp lattice's E is E_b to a few
 * per cent: together about 10 %).
 *
 * SPHICE_LONG: the default E_b (1 GPa, 1 / beta = 4.96 m, a 13 m strip,
 * beta L = 2.6), the load ramped until the strip breaks through: the first
 * broken bond lies near pi / (4 beta) and in the bottom layer; the load at
 * which the strip fails -- its end's compliance w / P twice the elastic
 * one -- against Hetenyi's load for the flexural strength the default bonds
 * are calibrated to (0.6 MPa, test_dem_bend):
 *   P_f = sigma_f (b h^2 / 6) beta / 0.3224,
 * within [0.75, 1.3] x P_f. SPHICE_DEM_FLOAT="nx E_b ramp_s" overrides. */
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

typedef struct strip {
    dem *d;
    double b, h, beta, k, xmax, dt;
    int nend;
} strip;

static void strip_build(strip *s, int nx, double E)
{
    dem_params p;
    dem_params_default(&p);
    p.bond_modulus = E;
    p.local_damping = 0.7;
    const int ny = 4, nz = 3;
    const double r = 0.05;
    size_t np = (size_t)nx * ny * nz;
    s->d = dem_create(np, 8 * np, &p);
    CHECK(s->d && dem_add_sheet_hcp(s->d, 0.0, 0.0, nx, ny, nz, r, 0.0, 0.0) == 0, "strip built");
    dem *d = s->d;
    double dz = float_shift(d);
    s->xmax = -HUGE_VAL;
    for (size_t i = 0; i < d->n; i++) {
        d->z[i] += dz;
        s->xmax = fmax(s->xmax, d->x[i]);
    }
    s->nend = 0;
    for (size_t i = 0; i < d->n; i++)
        s->nend += d->x[i] > s->xmax - 2.5 * r;
    s->b = ny * sqrt(3.0) * r;
    s->h = 2.0 * r + (nz - 1) * 2.0 * r * sqrt(2.0 / 3.0);
    s->k = p.water_density * p.gravity * s->b;
    s->beta = pow(s->k / (4.0 * E * s->b * pow(s->h, 3) / 12.0), 0.25);
    s->dt = 0.9 * p.dt_safety * dem_dt_critical(d);
}

static double end_z(const strip *s)
{
    double z = 0.0;
    for (size_t i = 0; i < s->d->n; i++)
        if (s->d->x[i] > s->xmax - 2.5 * s->d->r[i])
            z += s->d->z[i];
    return z / s->nend;
}

static void set_load(strip *s, double P)
{
    for (size_t i = 0; i < s->d->n; i++)
        if (s->d->x[i] > s->xmax - 2.5 * s->d->r[i])
            s->d->ext[3 * i + 2] = P / s->nend;
}

static int run_for(strip *s, double t)
{
    sph_status st;
    long n = (long)(t / s->dt);
    for (long k = 0; k < n; k++)
        if (dem_step(s->d, s->dt, &st) != SPH_STEP_OK)
            return -1;
    return 0;
}

/* The elastic end deflection against Hetenyi's w0. */
static void test_elastic(void)
{
    strip s;
    const double E = 3.0e6;
    strip_build(&s, 35, E);
    double t0 = omp_get_wtime();
    int bad = run_for(&s, 1.0);
    double z0 = end_z(&s);
    /* sigma at the moment's extreme about 2 kPa: elastic, w0 about 1 cm */
    const double P = 20.0;
    long n = (long)(1.5 / s.dt);
    sph_status st;
    for (long k = 0; k < n && !bad; k++) {
        set_load(&s, P * (double)(k + 1) / (double)n);
        bad |= dem_step(s.d, s.dt, &st) != SPH_STEP_OK;
    }
    bad |= run_for(&s, 1.0);
    double w = end_z(&s) - z0, w_an = 2.0 * P * s.beta / s.k;
    CHECK(!bad, "elastic strip: steps ok");
    CHECK(s.d->bonds_broken_tension + s.d->bonds_broken_shear == 0, "elastic strip: no bond broke");
    printf("float elastic: %zu spheres, E_b %.3g Pa, b %.3f m, h %.3f m, beta %.4f /m (1/beta %.3f m,"
           " beta L %.2f), P %.1f N up: end deflection %.5f m, Hetenyi 2 P beta / k %.5f m (ratio %.3f);"
           " %.1f s wall\n",
           s.d->n, E, s.b, s.h, s.beta, 1.0 / s.beta, s.beta * s.xmax, P, w, w_an, w / w_an,
           omp_get_wtime() - t0);
    CHECK(w > 0.8 * w_an && w < 1.2 * w_an, "end deflection %.5f m within 20 %% of Hetenyi's %.5f m", w,
          w_an);
    dem_free(s.d);
}

/* The break: the load ramped until the strip fails through. */
static void test_break(int nx, double E, double ramp)
{
    strip s;
    strip_build(&s, nx, E);
    dem *d = s.d;
    double t0 = omp_get_wtime();
    int bad = run_for(&s, 1.0);
    double z0 = end_z(&s);
    double Pf = SIGMA_F * (s.b * s.h * s.h / 6.0) * s.beta / 0.3224, comp = 2.0 * s.beta / s.k;
    double Pmax = 1.6 * Pf, P = 0.0, p_first = -1.0, x_first = -1.0, p_fail = -1.0;
    int layer_first = -1;
    size_t nl = d->n / 3;
    long n = (long)(ramp / s.dt);
    sph_status st;
    for (long k = 0; k < n && !bad; k++) {
        P = Pmax * (double)(k + 1) / (double)n;
        set_load(&s, P);
        bad |= dem_step(d, s.dt, &st) != SPH_STEP_OK;
        if (p_first < 0.0 && d->bonds_broken_tension + d->bonds_broken_shear > 0) {
            p_first = P;
            for (size_t q = 0; q < d->nbonds; q++)
                if (d->bonds[q].broken) {
                    const dem_bond *bd = &d->bonds[q];
                    x_first = s.xmax - 0.5 * (d->x[bd->i] + d->x[bd->j]);
                    layer_first = (size_t)bd->i < nl && (size_t)bd->j < nl ? 0 : 1;
                    break;
                }
        }
        if (p_first > 0.0 && k % 100 == 0 && (end_z(&s) - z0) / P > 2.0 * comp) {
            p_fail = P;
            break;
        }
    }
    CHECK(!bad, "breaking strip: steps ok");
    double sf_first = p_first * 0.3224 / s.beta / (s.b * s.h * s.h / 6.0);
    double sf_fail = p_fail * 0.3224 / s.beta / (s.b * s.h * s.h / 6.0);
    printf("float break: %zu spheres, E_b %.3g Pa, bonds sigma_t %.4g MPa, tau_c %.4g MPa; beta %.4f /m "
           "(pi/(4 beta) %.2f m, beta L %.2f); Hetenyi's load for sigma_f %.2f MPa: %.1f N (w0 %.4f m)\n",
           d->n, E, d->p.bond_tensile / 1e6, d->p.bond_shear / 1e6, s.beta, M_PI / 4.0 / s.beta,
           s.beta * s.xmax, SIGMA_F / 1e6, Pf, Pf * comp);
    printf("float break: first broken bond at P %.1f N (%.3f P_f: sigma %.4g MPa = %.3f sigma_t), %.2f m "
           "from the end, %s layer; failed through (w/P twice elastic) at P %.1f N (%.3f P_f: sigma %.4g MPa),"
           " %ld + %ld bonds broken; %.1f s wall\n",
           p_first, p_first / Pf, sf_first / 1e6, sf_first / d->p.bond_tensile, x_first,
           layer_first == 0 ? "the bottom" : "not the bottom", p_fail, p_fail / Pf, sf_fail / 1e6,
           d->bonds_broken_tension, d->bonds_broken_shear, omp_get_wtime() - t0);
    CHECK(p_first > 0.0 && layer_first == 0,
          "the first bond broke in the bottom layer (in tension under the lifted end)");
    CHECK(fabs(x_first - M_PI / 4.0 / s.beta) < 0.25 * M_PI / 4.0 / s.beta,
          "first break %.2f m from the end, Hetenyi's moment extreme at %.2f m", x_first,
          M_PI / 4.0 / s.beta);
    CHECK(p_fail > 0.75 * Pf && p_fail < 1.3 * Pf,
          "the strip fails at %.1f N, within [0.75, 1.3] x Hetenyi's %.1f N for sigma_f %.2f MPa", p_fail,
          Pf, SIGMA_F / 1e6);
    dem_free(d);
}

int main(void)
{
    setvbuf(stdout, NULL, _IOLBF, 0);
    test_elastic();
    if (check_long() || getenv("SPHICE_DEM_FLOAT")) {
        int nx = 130;
        double E = 1.0e9, ramp = 4.0;
        const char *e = getenv("SPHICE_DEM_FLOAT");
        if (e)
            sscanf(e, "%d %lf %lf", &nx, &E, &ramp);
        test_break(nx, E, ramp);
    }
    return check_summary("test_dem_float");
}
