/* The leg's bonded sheet in uniaxial compression (issue 25; docs/dem.md,
 * "Compression").
 *
 * A vertical leg in level ice fails the ice in crushing (the seed, section
 * 3.2.2: "在海冰与直立腿结构相互作用过程中,海冰以挤压破碎为主"), a
 * compressive failure at the contact. The bonds are calibrated in bending
 * (test_dem_bend: sigma_t 0.334 MPa, tau_c 0.558 MPa for the measured
 * 0.6 MPa flexural strength of Bohai ice). This test loads the same sheet
 * in compression:
 *
 *  1. One bond in pure compression. The seed's eq. 9 is the bond's maximum
 *     TENSILE stress (sigma_max = -F_n/A + |M_s| R/I with F_n positive in
 *     compression, "粘接圆盘上的最大拉应力", compared with the tensile
 *     strength): a bond pushed together must not break however hard, and
 *     carries F = k_n A * shortening (Hooke).
 *  2. The specimen with unbreakable bonds: linear to 0.4 % strain (the
 *     secant modulus at 0.4 % equals that at 0.1 % within 2 %).
 *  3. The specimen with the core's default (calibrated) bonds, dry,
 *     quasi-static (PFC local damping 0.7, strain rate 0.02 s-1, some 40
 *     wave transits to failure): it fails in compression (a peak, then
 *     the stress falls), by bonds broken in tension and in shear (eq. 9
 *     has no compressive failure); the peak is reported beside the
 *     flexural strength of the same bonds. Then the broken lattice, a
 *     packing of unbreakable elastic spheres, loads again past the peak by
 *     0.4 % strain: the spheres themselves never crush.
 *
 * SPHICE_LONG (or SPHICE_DEM_COMPRESS_SWEEP=1) adds the sweep of tau_c at
 * the calibrated sigma_t: the compressive peak and the flexural strength
 * of the same bonds (the bending specimen of test_dem_bend's calibration),
 * which says what the bonds would need to fail in compression at a given
 * stress while keeping 0.6 MPa in bending. SPHICE_DEM_COMPRESS_TARGET=S
 * (MPa) calibrates both strengths at once: 0.6 MPa in bending and S in
 * compression (no published Bohai compressive strength with a number was
 * found, so no S is the core's default; docs/dem.md ran S = 1.8 MPa, ISO
 * 19906's strength coefficient C_R for the region, as a stand-in). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "check.h"
#include "core/dem.h"
#include "dem_specimen.h"

enum { PLATEN_LO = 8, PLATEN_HI = 16 }; /* test-only flag bits beside DEM_FIX_* */

typedef struct comp_result {
    double peak;       /* peak stress before the first drop, Pa */
    double strain;     /* strain at that peak */
    double first;      /* stress when the first bond broke, Pa (-1: none) */
    double e_first;    /* secant modulus then, Pa */
    double e_lo, e_hi; /* secant moduli at 0.1 % and at the end, Pa */
    double s_end;      /* stress at the end */
    double dropped;    /* lowest stress after the peak, before the end */
    long bt, bs, bt_peak, bs_peak, nbonds;
} comp_result;

/* nx x ny x nz close-packed spheres of radius r (dem_add_sheet_hcp, the leg's
 * sheet), loaded along x between its end columns (within 1.5 r of either
 * end), driven towards each other at strain rate `rate` and held in
 * rotation; stress = the mean platen force over b h, b = ny sqrt(3) r, h
 * the sheet's depth; to strain e_end. */
static void compress(double r, int nx, int ny, int nz, double sigma_t, double tau_c, double rate,
                     double e_end, comp_result *out)
{
    dem_params p;
    dem_params_default(&p);
    p.water_density = p.gravity = 0.0; /* a dry specimen in the press */
    p.local_damping = 0.7;
    p.bond_tensile = sigma_t;
    p.bond_shear = tau_c;
    size_t np = (size_t)nx * ny * nz;
    dem *d = dem_create(np, 8 * np, &p);
    CHECK(d && dem_add_sheet_hcp(d, 0.0, 0.0, nx, ny, nz, r, 0.0, 0.0) == 0, "specimen built");
    double xlo = HUGE_VAL, xhi = -HUGE_VAL;
    for (size_t i = 0; i < d->n; i++) {
        xlo = fmin(xlo, d->x[i]);
        xhi = fmax(xhi, d->x[i]);
    }
    double L = xhi - xlo, v = 0.5 * rate * L;
    for (size_t i = 0; i < d->n; i++) {
        if (d->x[i] < xlo + 1.5 * r) {
            d->flags[i] = DEM_FIX_TRANSLATION | DEM_FIX_ROTATION | PLATEN_LO;
            dem_set_velocity(d, (long)i, v, 0.0, 0.0);
        } else if (d->x[i] > xhi - 1.5 * r) {
            d->flags[i] = DEM_FIX_TRANSLATION | DEM_FIX_ROTATION | PLATEN_HI;
            dem_set_velocity(d, (long)i, -v, 0.0, 0.0);
        }
    }
    double b = ny * sqrt(3.0) * r, h = 2.0 * r + (nz - 1) * 2.0 * r * sqrt(2.0 / 3.0);
    double dt = p.dt_safety * dem_dt_critical(d);
    long steps = (long)ceil(e_end / rate / dt);
    sph_status st;
    int bad = 0, past = 0;
    out->peak = out->strain = out->e_lo = out->e_hi = out->s_end = 0.0;
    out->first = -1.0;
    out->e_first = 0.0;
    out->dropped = HUGE_VAL;
    out->bt_peak = out->bs_peak = 0;
    for (long k = 0; k < steps; k++) {
        bad |= dem_step(d, dt, &st) != SPH_STEP_OK;
        double fl = 0.0, fr = 0.0;
        for (size_t i = 0; i < d->n; i++) {
            if (d->flags[i] & PLATEN_LO) fl += d->fx[i];
            if (d->flags[i] & PLATEN_HI) fr += d->fx[i];
        }
        /* the specimen pushes the low platen to -x and the high one to +x */
        double s = 0.5 * (fr - fl) / (b * h), e = rate * (double)(k + 1) * dt;
        long broken = d->bonds_broken_tension + d->bonds_broken_shear;
        if (out->first < 0.0 && broken > 0) {
            out->first = s;
            out->e_first = s / e;
        }
        if (!past && s > out->peak) {
            out->peak = s;
            out->strain = e;
            out->bt_peak = d->bonds_broken_tension;
            out->bs_peak = d->bonds_broken_shear;
        }
        if (!past && broken > 0 && s < 0.95 * out->peak)
            past = 1; /* the first drop: the bonded lattice has failed */
        if (past)
            out->dropped = fmin(out->dropped, s);
        if (out->e_lo == 0.0 && e >= 1e-3)
            out->e_lo = s / e;
        out->s_end = s;
        out->e_hi = s / e;
    }
    CHECK(!bad, "compression: steps ok (fault %d)", st.kind);
    if (!past)
        out->dropped = out->s_end;
    out->bt = d->bonds_broken_tension;
    out->bs = d->bonds_broken_shear;
    out->nbonds = (long)d->nbonds;
    dem_free(d);
}

/* The three-point-bending specimen of test_dem_bend's calibration
 * (tests/dem_specimen.h): 3 x 3 close-packed rows of spheres of r, the
 * span 16 times the depth, the nose a roller. */
static double flexural(double r, double sigma_t, double tau_c)
{
    long bt, bs;
    double span;
    int nx = hcp_nx_for_span(r, 3, DEM_SPECIMEN_SPAN_DEPTH);
    return flexural_hcp(r, nx, 3, 3, sigma_t, tau_c, &bt, &bs, &span);
}

/* Both strengths for a bending strength sigma_f and a compressive peak sigma_c
 * at once: tau_c (which sets the compressive peak, the sweep shows) bisected
 * for sigma_c at the present sigma_t, then sigma_t bisected for sigma_f at
 * that tau_c, three times over. */
static void joint_calibration(double r, int nx, int ny, int nz, double sigma_f, double sigma_c,
                              double *st_out, double *tc_out)
{
    dem_params p;
    dem_params_default(&p);
    double st = p.bond_tensile, tc = p.bond_shear;
    for (int pass = 0; pass < 3; pass++) {
        double lo = 0.05e6, hi = 5e6;
        for (int it = 0; it < 12; it++) {
            double mid = 0.5 * (lo + hi);
            comp_result c;
            compress(r, nx, ny, nz, st, mid, 0.02, 4e-3, &c);
            if (c.peak < sigma_c)
                lo = mid;
            else
                hi = mid;
        }
        tc = 0.5 * (lo + hi);
        lo = 0.02e6;
        hi = 0.4e6;
        for (int it = 0; it < 12; it++) {
            double mid = 0.5 * (lo + hi);
            if (flexural(r, mid, tc) < sigma_f)
                lo = mid;
            else
                hi = mid;
        }
        st = 0.5 * (lo + hi);
        comp_result c;
        compress(r, nx, ny, nz, st, tc, 0.02, 4e-3, &c);
        printf("joint calibration pass %d: sigma_t %.4g MPa, tau_c %.4g MPa: flexural %.4g MPa, compressive peak %.4g MPa\n",
               pass + 1, st / 1e6, tc / 1e6, flexural(r, st, tc) / 1e6, c.peak / 1e6);
    }
    *st_out = st;
    *tc_out = tc;
}

/* 1. two bonded spheres pushed together */
static void bond_in_compression(void)
{
    dem_params p;
    dem_params_default(&p);
    p.water_density = p.gravity = 0.0;
    const double r = 0.05;
    dem *d = dem_create(2, 1, &p);
    dem_add_particle(d, 0.0, 0.0, 0.0, r);
    dem_add_particle(d, 2 * r, 0.0, 0.0, r);
    CHECK(dem_add_bond(d, 0, 1) == 0, "bond made");
    d->flags[0] = d->flags[1] = DEM_FIX_TRANSLATION | DEM_FIX_ROTATION;
    const double v = 0.05;
    dem_set_velocity(d, 1, -v, 0.0, 0.0);
    double A = M_PI * r * r, kA = p.bond_modulus / (2 * r) * A;
    /* push until the compressive stress is 100 times the tensile strength */
    double target = 100.0 * p.bond_tensile * A / kA;
    double dt = 0.5 * dem_dt_critical(d);
    long steps = (long)ceil(target / v / dt);
    sph_status st;
    int bad = 0;
    for (long k = 0; k < steps; k++)
        bad |= dem_step(d, dt, &st) != SPH_STEP_OK;
    double shortening = 2 * r - (d->x[1] - d->x[0]);
    double f = -d->bonds[0].fn, want = kA * shortening;
    printf("bond in compression: shortening %.4g m, compressive stress %.4g MPa (%.0f x sigma_t), intact %d\n",
           shortening, f / A / 1e6, f / A / p.bond_tensile, d->bonds[0].broken == 0);
    CHECK(!bad, "bond in compression: steps ok");
    CHECK(d->bonds[0].broken == 0, "a bond in pure compression never breaks (eq. 9: the maximum tensile stress)");
    CHECK(f / A > 99.0 * p.bond_tensile, "compressive stress %.4g MPa beyond 99 sigma_t", f / A / 1e6);
    CHECK_CLOSE(f, want, 1e-6, 0.0, "bond force = k_n A * shortening");
    dem_free(d);
}

int main(void)
{
    dem_params p;
    dem_params_default(&p);
    const double r = 0.05, rate = 0.02;
    /* SPHICE_QUICK (valgrind): a smaller specimen, the same checks */
    const int nx = check_quick() ? 6 : 10, ny = check_quick() ? 3 : 5, nz = 3;
    bond_in_compression();

    /* 2. unbreakable bonds: a linear lattice */
    comp_result el;
    compress(r, nx, ny, nz, 1e12, 1e12, rate, 4e-3, &el);
    printf("compression, unbreakable bonds: secant modulus %.4g GPa at 0.1 %%, %.4g GPa at 0.4 %%, %ld bonds broken\n",
           el.e_lo / 1e9, el.e_hi / 1e9, el.bt + el.bs);
    CHECK(el.bt + el.bs == 0, "unbreakable bonds do not break");
    CHECK(fabs(el.e_hi / el.e_lo - 1.0) < 0.02, "linear to 0.4 %%: moduli %.4g / %.4g GPa", el.e_hi / 1e9,
          el.e_lo / 1e9);

    /* 3. the calibrated bonds */
    comp_result c;
    compress(r, nx, ny, nz, p.bond_tensile, p.bond_shear, rate, 4e-3, &c);
    double h = 2.0 * r + (nz - 1) * 2.0 * r * sqrt(2.0 / 3.0);
    printf("compression: hcp specimen %d x %d x %d of r %.3f m (%.3f m long, %.3f m wide, %.3f m deep), "
           "bonds sigma_t %.4g MPa, tau_c %.4g MPa, strain rate %.3g s-1:\n", nx, ny, nz, r,
           2 * r * (nx - 1) + r, ny * sqrt(3.0) * r, h, p.bond_tensile / 1e6, p.bond_shear / 1e6, rate);
    printf("compression:   first bond broken at %.4g MPa; peak %.4g MPa at strain %.3g (%ld tension + %ld shear "
           "of %ld bonds broken by then); lowest after it %.4g MPa; at 0.4 %% strain %.4g MPa (%ld + %ld broken)\n",
           c.first / 1e6, c.peak / 1e6, c.strain, c.bt_peak, c.bs_peak, c.nbonds, c.dropped / 1e6,
           c.s_end / 1e6, c.bt, c.bs);
    printf("compression:   secant modulus at the first break %.4g GPa (unbreakable: %.4g GPa); peak / the bending specimen's 0.6 MPa "
           "(test_dem_bend) = %.3g\n", c.e_first / 1e9, el.e_lo / 1e9, c.peak / 0.6e6);
    CHECK(c.first > 0.0 && c.peak >= c.first, "the specimen fails at or after its first broken bond");
    CHECK(c.dropped < 0.95 * c.peak, "the bonded lattice fails: the stress drops after the peak (%.4g < %.4g MPa)",
          c.dropped / 1e6, c.peak / 1e6);
    CHECK(c.bt > 0 && c.bs > 0, "bonds broken in tension (%ld) and in shear (%ld) under compression", c.bt, c.bs);
    CHECK(c.s_end > c.peak, "the broken packing of unbreakable spheres loads again past the peak (%.4g > %.4g MPa):"
          " the spheres never crush", c.s_end / 1e6, c.peak / 1e6);

    if (check_long() || getenv("SPHICE_DEM_COMPRESS_SWEEP")) {
        const double taus[] = {p.bond_shear, 2 * p.bond_shear, 4 * p.bond_shear, 8 * p.bond_shear,
                               16 * p.bond_shear};
        double prev = 0.0;
        for (int k = 0; k < 5; k++) {
            comp_result s;
            compress(r, nx, ny, nz, p.bond_tensile, taus[k], rate, 4e-3, &s);
            double sf = flexural(r, p.bond_tensile, taus[k]);
            printf("compression sweep: sigma_t %.4g MPa, tau_c %.4g MPa: compressive peak %.4g MPa at strain %.3g "
                   "(%ld + %ld broken)%s, flexural %.4g MPa, ratio %.3g\n", p.bond_tensile / 1e6, taus[k] / 1e6,
                   s.peak / 1e6, s.strain, s.bt_peak, s.bs_peak,
                   s.dropped < 0.95 * s.peak ? "" : " (no drop by 0.4 % strain: a lower bound)", sf / 1e6, s.peak / sf);
            CHECK(s.peak >= 0.98 * prev, "a stronger shear bond does not weaken the specimen in compression");
            prev = s.peak;
        }
    }
    const char *tg = getenv("SPHICE_DEM_COMPRESS_TARGET"); /* compressive peak to calibrate to, MPa */
    if (tg) {
        double st, tc, target = atof(tg) * 1e6;
        joint_calibration(r, nx, ny, nz, 0.6e6, target, &st, &tc);
        comp_result j;
        compress(r, nx, ny, nz, st, tc, rate, 4e-3, &j);
        double sf = flexural(r, st, tc);
        printf("joint calibration: sigma_t %.4g MPa, tau_c %.4g MPa give flexural %.4g MPa (target 0.6) and a "
               "compressive peak %.4g MPa (target %.4g)\n", st / 1e6, tc / 1e6, sf / 1e6, j.peak / 1e6, target / 1e6);
        CHECK(fabs(sf / 0.6e6 - 1.0) < 0.05 && fabs(j.peak / target - 1.0) < 0.05, "joint calibration within 5 %%");
    }
    return check_summary("test_dem_compress");
}
