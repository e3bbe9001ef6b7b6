/* A bonded-particle specimen in three-point bending (issue 25): the
 * flexural strength sigma_f = 3 P L / (2 b h^2) of simply supported
 * plane specimens (one sphere wide, nx = 12 s long, nz = 3 s deep, s the
 * scale) against the bonds' tensile strength, and its decrease with size.
 *
 * Bond tensile strengths follow a Weibull law of modulus m = 4 (seeded,
 * deterministic), as the strength of ice does; weakest-link theory
 * (Weibull 1951) then lets the strength of geometrically similar plane
 * specimens fall as (area)^(-1/m) = s^(-2/m) = s^-0.5, the slope of the
 * seed's log-log scale effect (sigma ~ L^n, n ~ -0.5). The test fits the
 * slope of log sigma_f (peak load) against log s; under SPHICE_LONG
 * (scales 1, 2, 4, 8) it asserts it negative and within a factor 2 of
 * -2/m. make check runs scales 1 and 2 and reports the slope only. The supports are a pin and a roller (two
 * pins would arch).
 *
 * The stress at the first crack (the first broken bond) is asserted
 * within what beam theory allows for a cubic lattice whose bond of area
 * pi r^2 carries a cell of (2r)^2 (fibre stress about (pi / 4) sigma_t at
 * the bottom bonds, less for the weakest bond and the bonds' own bending):
 * 0.2 < sigma_crack / mean(sigma_t) < 1.5; the peak, after the lattice
 * redistributes, lies at or above it. Shear strength: 1 MPa (the core's
 * default before the calibration below, kept so that the scale effect is
 * the one measured before).
 *
 * The calibration (calibration(), first): the leg's close-packed sheet as a
 * specimen with uniform bonds (tests/dem_specimen.h: the span 16 times the
 * depth, ASTM D790's ratio; the loading nose a roller, free to rotate and
 * slide, as a rig's is); make check asserts that the core's default
 * bonds give the measured 0.6 MPa within 3 %; SPHICE_LONG (or
 * SPHICE_DEM_CALIBRATE=1) bisects sigma_t (tau_c at the default ratio) for
 * 0.6 MPa and asserts the default within 2 % of it. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "check.h"
#include "core/dem.h"
#include "dem_specimen.h"

static uint64_t rng = 0x9E3779B97F4A7C15ull;
static double uniform(void)
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return ((double)(rng >> 11) + 0.5) / 9007199254740992.0;
}

/* The scale-effect specimens below keep session 5's nose (fixed in
 * translation and rotation, started at full speed) and span (11 sphere
 * spacings, 3.7 depths): their Weibull slope is relative, not a strength. */

static double flexural(int s, double sigma0, double weibull_m, double *sigma_mean, double *crack)
{
    int nx = 12 * s, ny = 1, nz = 3 * s;
    dem_params p;
    dem_params_default(&p);
    p.water_density = p.gravity = 0.0; /* a dry specimen in the press */
    p.local_damping = 0.7;
    p.bond_shear = 1.0e6; /* this scale-effect test's shear strength (the uncalibrated 1 MPa) */
    double r = 0.05;
    size_t np = (size_t)nx * ny * nz;
    dem *d = dem_create(np, 3 * np, &p);
    dem_add_sheet(d, 0.0, 0.0, nx, ny, nz, r, 0.0, 0.0);
    double sum = 0.0;
    for (size_t b = 0; b < d->nbonds; b++) {
        d->bonds[b].sigma_t = sigma0 * pow(-log(uniform()), 1.0 / weibull_m);
        sum += d->bonds[b].sigma_t;
    }
    *sigma_mean = sum / (double)d->nbonds;
    double zmin = HUGE_VAL, zmax = -HUGE_VAL;
    for (size_t i = 0; i < d->n; i++) {
        zmin = fmin(zmin, d->z[i]);
        zmax = fmax(zmax, d->z[i]);
    }
    double xmid = 0.5 * 2 * r * (nx - 1), v = 0.01;
    int nload = 0;
    for (size_t i = 0; i < d->n; i++) {
        int bottom = d->z[i] < zmin + 0.5 * r, top = d->z[i] > zmax - 0.5 * r;
        if (bottom && d->x[i] < r)
            d->flags[i] = DEM_FIX_TRANSLATION; /* a pin */
        if (bottom && d->x[i] > 2 * r * (nx - 1) - r)
            d->flags[i] = DEM_FIX_Z; /* a roller: no arching */
        if (top && fabs(d->x[i] - xmid) < 1.01 * r) {
            d->flags[i] = DEM_FIX_TRANSLATION | DEM_FIX_ROTATION; /* the loading nose */
            dem_set_velocity(d, (long)i, 0.0, 0.0, -v);
            nload++;
        }
    }
    CHECK(nload >= 1, "loading nose");
    double span = 2 * r * (nx - 1), b = 2 * r * ny, h = 2 * r * nz;
    double dt = p.dt_safety * dem_dt_critical(d);
    /* elastic deflection at failure ~ sigma L^2 / (6 E h); stop at 6 x */
    double dmax = 6.0 * sigma0 * span * span / (6.0 * p.bond_modulus * M_PI / 4.0 * h);
    long steps = (long)(dmax / v / dt);
    double p_first;
    double pmax = push_nose(d, dt, steps, 0, 0.0, &p_first, "scaled specimen");
    CHECK(d->bonds_broken_tension > 0, "scale %d: the specimen broke", s);
    double sf = 3.0 * pmax * span / (2.0 * b * h * h);
    *crack = 3.0 * p_first * span / (2.0 * b * h * h);
    printf("bend scale %d: %zu spheres, span %.2f m, depth %.2f m: P_max %.4g N (at the first "
           "break %.4g N), sigma_f %.4g MPa (first crack %.4g MPa; bonds: mean sigma_t %.4g MPa), %ld bonds broken\n",
           s, d->n, span, h, pmax, p_first, sf / 1e6, *crack / 1e6, *sigma_mean / 1e6, d->bonds_broken_tension);
    dem_free(d);
    return sf;
}



/* The measured three-point-bending strength of Bohai ice, 0.5-0.7 MPa
 * (Xiu et al. 2022, Front. Energy Res. 10:970051): its middle, the target */
#define SIGMA_F_BOHAI 0.6e6

static void calibration(void)
{
    dem_params p;
    dem_params_default(&p);
    const double r = 0.05, ratio = p.bond_shear / p.bond_tensile;
    const int ny = 3, nz = 3, nx = hcp_nx_for_span(r, nz, DEM_SPECIMEN_SPAN_DEPTH);
    long bt, bs;
    double span;
    /* the core's defaults (the calibrated values) against the measurement */
    double sf = flexural_hcp(r, nx, ny, nz, p.bond_tensile, p.bond_shear, &bt, &bs, &span);
    printf("calibration: hcp specimen %d x %d x %d of r %.3f m (span %.3f m, depth %.3f m), default bonds "
           "sigma_t %.4g MPa, tau_c %.4g MPa: sigma_f %.4g MPa (%ld bonds broken in tension, %ld in shear); "
           "measured (Xiu et al. 2022) 0.5-0.7 MPa\n",
           nx, ny, nz, r, span, 2 * r + (nz - 1) * 2 * r * sqrt(2.0 / 3.0), p.bond_tensile / 1e6,
           p.bond_shear / 1e6, sf / 1e6, bt, bs);
    CHECK(sf > 0.5e6 && sf < 0.7e6, "the default bonds' specimen within the measured 0.5-0.7 MPa: %.4g MPa",
          sf / 1e6);
    CHECK(fabs(sf / SIGMA_F_BOHAI - 1.0) < 0.03, "the default bonds' specimen at 0.6 MPa within 3 %%: %.4g MPa",
          sf / 1e6);
    if (!check_long() && !getenv("SPHICE_DEM_CALIBRATE"))
        return;
    /* the bisection: sigma_t (tau_c = ratio sigma_t) for sigma_f = 0.6 MPa */
    double lo = 0.05e6, hi = 1.0e6;
    double flo = flexural_hcp(r, nx, ny, nz, lo, ratio * lo, &bt, &bs, &span);
    double fhi = flexural_hcp(r, nx, ny, nz, hi, ratio * hi, &bt, &bs, &span);
    CHECK(flo < SIGMA_F_BOHAI && fhi > SIGMA_F_BOHAI, "bracket: %.4g < 0.6 < %.4g MPa", flo / 1e6, fhi / 1e6);
    for (int it = 0; it < 14 && hi - lo > 1e-3 * lo; it++) {
        double mid = 0.5 * (lo + hi);
        double fm = flexural_hcp(r, nx, ny, nz, mid, ratio * mid, &bt, &bs, &span);
        printf("calibration: sigma_t %.5g MPa, tau_c %.5g MPa: sigma_f %.5g MPa\n", mid / 1e6,
               ratio * mid / 1e6, fm / 1e6);
        if (fm < SIGMA_F_BOHAI)
            lo = mid;
        else
            hi = mid;
    }
    double cal = 0.5 * (lo + hi);
    printf("calibration: bisected sigma_t %.4g MPa, tau_c %.4g MPa (ratio %.4g) for sigma_f 0.6 MPa; "
           "the core's default sigma_t %.4g MPa\n", cal / 1e6, ratio * cal / 1e6, ratio, p.bond_tensile / 1e6);
    /* the cone case's sheet (test_dem_cone: two layers of 0.2 m spheres, 0.363 m)
     * with the same bonds: the calibration is for the leg's particle size only */
    int nxc = hcp_nx_for_span(0.1, 2, DEM_SPECIMEN_SPAN_DEPTH);
    double sc = flexural_hcp(0.1, nxc, ny, 2, p.bond_tensile, p.bond_shear, &bt, &bs, &span);
    printf("calibration: the cone case's sheet as a specimen (%d x %d x 2 of r 0.100 m, span %.3f m, depth %.3f m), "
           "default bonds: sigma_f %.4g MPa\n", nxc, ny, span, 0.2 + 0.2 * sqrt(2.0 / 3.0), sc / 1e6);
    CHECK(fabs(p.bond_tensile / cal - 1.0) < 0.02, "the default sigma_t within 2 %% of the bisected %.4g MPa",
          cal / 1e6);
}

int main(void)
{
    calibration();
    const double sigma0 = 0.6e6, m = 4.0;
    int scales_quick[] = {1, 2}, scales_long[] = {1, 2, 4, 8};
    int *sc = check_long() ? scales_long : scales_quick;
    int ns = check_long() ? 4 : 2;
    double lx[4], ly[4], lc[4], smean, crack;
    for (int k = 0; k < ns; k++) {
        double sf = flexural(sc[k], sigma0, m, &smean, &crack);
        CHECK(crack > 0.2 * smean && crack < 1.5 * smean, "first crack / sigma_t = %.3f",
              crack / smean);
        CHECK(sf >= crack, "peak at or above the first crack");
        lx[k] = log((double)sc[k]);
        ly[k] = log(sf);
        lc[k] = log(crack);
    }
    /* least-squares slopes of log sigma on log s */
    double mx = 0, my = 0, mc = 0, sxx = 0, sxy = 0, sxc = 0;
    for (int k = 0; k < ns; k++) {
        mx += lx[k] / ns;
        my += ly[k] / ns;
        mc += lc[k] / ns;
    }
    for (int k = 0; k < ns; k++) {
        sxx += (lx[k] - mx) * (lx[k] - mx);
        sxy += (lx[k] - mx) * (ly[k] - my);
        sxc += (lx[k] - mx) * (lc[k] - mc);
    }
    double slope = sxy / sxx, slope_c = sxc / sxx, want = -2.0 / m;
    printf("bend: fitted log-log slope of the peak strength %.3f, of the first crack %.3f "
           "(weakest link -2/m = %.3f; the seed's n ~ -0.5), %d scales\n",
           slope, slope_c, want, ns);
    /* two sizes and one sample each cannot settle a slope: reported only */
    if (check_long()) {
        CHECK(slope < 0.0, "strength falls with size: slope %.3f", slope);
        CHECK(slope < 0.5 * want && slope > 2.0 * want, "slope %.3f within a factor 2 of %.3f",
              slope, want);
    }
    return check_summary("test_dem_bend");
}
