/* Penetrating shortwave in the multi-layer (Bitz & Lipscomb 1999) column
 * (issue 20, the MU71 check): where the absorbed shortwave goes, booked
 * once, against formulas computed here.
 *
 *  - Under snow nothing penetrates (BL99, CICE/Icepack: the snow absorbs
 *    it all): a snow-covered column steps bit-identically with
 *    thermo.sw_pen_frac 0 and 0.17, and nothing reaches the base.
 *  - Bare ice: the shortwave reaching the base is Beer's law,
 *    i0 (1 - albedo) SW exp(-kappa h), kappa from the ice surface.
 *  - A melting surface (Ts = 0): the surface melt flux is the surface's
 *    own share, (1 - i0)(1 - albedo) SW + LW_abs - eps sigma T^4 + F_s +
 *    F_l, less the conduction into the ice; the penetrating part is not
 *    also spent at the surface.
 *  - Brine-rich ice within millikelvins of its melting point under strong
 *    penetration: BL99's conductivity k0 + beta S / T turns negative
 *    between -beta S / k0 and Tm (-0.205 and -0.173 C at 3.2 ppt) and is
 *    floored at CICE's 0.10 W/m/K; before the floor the column's
 *    iteration diverged, the surface balance lost its bracket (step rc 1)
 *    and the energy did not close. Now no layer ends above Tm (q <= 0),
 *    the iteration converges and the energy closes: the excess is not
 *    discarded, it melts ice.
 *  In every case the column's energy (ice enthalpy, snow enthalpy) changes
 *  by the full absorbed shortwave (1 - albedo) SW plus the other surface
 *  fluxes and F_w, each step, to 1e-9 of |F| dt: a term booked on both
 *  sides would not be caught by a closure that used the code's own
 *  fluxes, so the flux here is computed from the forcing. */
#include "check.h"
#include "core/thermo.h"
#include "column_energy.h"

#include <math.h>
#include <string.h>

#define SIGMA 5.670374419e-8

/* Surface flux at Ts of the absorbed shortwave share `swf` (1: all of it). */
static double surface_flux(const sph_thermo_params *p, const sph_column_forcing *f, double swf, double Ts)
{
    double Tk = Ts + 273.15;
    return (1.0 - f->albedo) * swf * f->swdn + p->lw_absorptivity * f->lwdn - p->emissivity * SIGMA * Tk * Tk * Tk * Tk +
           f->fsens + f->flat;
}

/* One step with the energy check; returns |dE - F dt| / (|F| dt). */
static double step_checked(const sph_thermo_params *p, sph_column *c, const sph_column_forcing *f, double dt,
                           sph_column_solver *s, sph_column_result *r)
{
    double E0 = column_energy_here(p, c);
    int rc = sph_column_step_multi_layer(p, c, f, dt, s, r);
    CHECK(rc == SPH_STEP_OK, "step rc %d", rc);
    if (r->melted_out)
        return 0.0;
    double F = surface_flux(p, f, 1.0, c->tsurf);
    double in = (F + f->fw) * dt - r->energy_to_ocean;
    return fabs(column_energy_here(p, c) - E0 - in) / ((fabs(F) + fabs(f->fw)) * dt);
}

/* Defaults with n layers and penetrating fraction i0. */
static sph_thermo_params column_params(int n, double i0)
{
    sph_thermo_params p;
    sph_thermo_params_default(&p);
    p.nlayers = n;
    p.sw_pen_frac = i0;
    return p;
}

/* Brine-rich ice of thickness h: every layer dT below its melting point. */
static void warm_column(const sph_thermo_params *p, sph_column *c, double h, double dT)
{
    sph_column_init(p, c, h, 0.0, -1.0);
    for (int k = 0; k < c->nlayers; k++) {
        double S = sph_bl_salinity(p, (k + 0.5) / c->nlayers);
        c->enth[k] = sph_bl_enthalpy(p, S, sph_bl_melting_temperature(p, S) - dT);
    }
}

static void forcing(sph_column_forcing *f, double sw, double albedo, double lw, double fsens)
{
    sph_column_forcing_default(f);
    f->swdn = sw;
    f->albedo = albedo;
    f->lwdn = lw;
    f->fsens = fsens;
    f->flat = 0.0;
    f->fw = 2.0;
}

static void under_snow(sph_column_solver *s)
{
    for (int cap = 0; cap < 2; cap++) {
        sph_thermo_params p0 = column_params(7, 0.0), p1 = column_params(7, 0.17);
        p0.snow_heat_capacity = p1.snow_heat_capacity = cap;
        sph_column c0, c1;
        sph_column_init(&p0, &c0, 2.0, 0.10, -5.0);
        sph_column_init(&p1, &c1, 2.0, 0.10, -5.0);
        sph_column_forcing f;
        forcing(&f, 250.0, 0.80, 250.0, 5.0); /* the snow stays: Ts < 0 */
        double worst = 0.0, base = 0.0;
        int same = 1;
        for (int i = 0; i < 72; i++) {
            sph_column_result r0, r1;
            step_checked(&p0, &c0, &f, 3600.0, s, &r0);
            worst = fmax(worst, step_checked(&p1, &c1, &f, 3600.0, s, &r1));
            base = fmax(base, fabs(r1.sw_base));
            same = same && c0.thick == c1.thick && c0.snow == c1.snow && c0.tsurf == c1.tsurf &&
                   c0.tsnow == c1.tsnow && memcmp(c0.enth, c1.enth, sizeof c0.enth) == 0;
        }
        CHECK(c1.snow > 0.09 && c1.tsurf < 0.0, "snow cover kept (%.3f m, Ts %.2f C)", c1.snow, c1.tsurf);
        CHECK(same, "under snow (heat capacity %d) i0 0.17 steps bit-identically with i0 0", cap);
        CHECK(base == 0.0, "under snow nothing reaches the base (%.3g W/m^2)", base);
        CHECK(worst < 1e-9, "under snow: energy closes with the full absorbed SW (%.3g)", worst);
    }
}

static void bare_ice_beer(sph_column_solver *s)
{
    const double i0s[2] = {0.17, 0.5}, hs[2] = {0.6, 2.5};
    for (int a = 0; a < 2; a++)
        for (int b = 0; b < 2; b++) {
            sph_thermo_params p = column_params(10, i0s[a]);
            sph_column c;
            sph_column_init(&p, &c, hs[b], 0.0, -2.0);
            sph_column_forcing f;
            forcing(&f, 400.0, 0.60, 250.0, 0.0); /* cold enough: Ts < 0 */
            double h = c.thick;
            sph_column_result r;
            double err = step_checked(&p, &c, &f, 3600.0, s, &r);
            double want = i0s[a] * (1.0 - f.albedo) * f.swdn * exp(-p.sw_extinction * h);
            CHECK_CLOSE(r.sw_base, want, 1e-12, 0.0, "SW at the base: Beer's law from the ice surface");
            CHECK(err < 1e-9, "bare ice i0 %.2f h %.1f: energy closes with the full absorbed SW (%.3g)", i0s[a], hs[b],
                  err);
        }
}

static void melting_surface(sph_column_solver *s)
{
    const double i0s[3] = {0.0, 0.17, 0.6};
    for (int a = 0; a < 3; a++) {
        sph_thermo_params p = column_params(10, i0s[a]);
        sph_column c;
        sph_column_init(&p, &c, 1.5, 0.0, -0.5);
        sph_column_forcing f;
        forcing(&f, 400.0, 0.60, 320.0, 10.0);
        double worst = 0.0, worst_melt = 0.0, melt = 0.0;
        for (int i = 0; i < 48; i++) {
            sph_column_result r;
            worst = fmax(worst, step_checked(&p, &c, &f, 3600.0, s, &r));
            CHECK(c.tsurf == 0.0 && r.fmelt > 0.0, "i0 %.2f step %d: the surface melts (Ts %.3g, fmelt %.3g)",
                  i0s[a], i, c.tsurf, r.fmelt);
            double own = surface_flux(&p, &f, 1.0 - i0s[a], 0.0) - r.fcond_top;
            worst_melt = fmax(worst_melt, fabs(r.fmelt - own) / fabs(own));
            melt += r.melt_top;
        }
        CHECK(worst_melt < 1e-9, "i0 %.2f: surface melt flux = the surface's share less conduction (%.3g)", i0s[a],
              worst_melt);
        CHECK(worst < 1e-9, "i0 %.2f melting: energy closes with the full absorbed SW (%.3g); top melt %.3f m",
              i0s[a], worst, melt);
    }
}

/* Brine-rich ice near its melting point: BL99's k0 + beta S / T reaches
 * zero at T = -beta S / k0, above Tm = -mu S for beta / k0 > mu; CICE's
 * Bitz-Lipscomb column floors it at 0.10 W/m/K (kimin). */
static void conductivity_floor(void)
{
    sph_thermo_params p;
    sph_thermo_params_default(&p);
    const double S = 3.2, Tzero = -p.beta * S / p.k0, Tm = -p.mu * S;
    CHECK(Tzero < Tm, "k0 + beta S / T vanishes at %.4f C, below Tm %.4f C", Tzero, Tm);
    const double Ts[3] = {-0.19, -0.18, Tm};
    for (int i = 0; i < 3; i++)
        CHECK(sph_bl_conductivity(&p, S, Ts[i]) >= 0.10, "K(3.2 ppt, %.3f C) = %.3f, at least 0.10 W/m/K", Ts[i],
              sph_bl_conductivity(&p, S, Ts[i]));
    CHECK_CLOSE(sph_bl_conductivity(&p, S, -1.0), p.k0 + p.beta * S / -1.0, 1e-15, 0.0, "K unchanged away from Tm");
}

static void beyond_melting_point(sph_column_solver *s)
{
    const double i0s[2] = {0.17, 0.9}, dts[2] = {600.0, 3600.0};
    for (int m = 0; m < 4; m++) {
        const double i0 = i0s[m / 2], dt = dts[m % 2];
        sph_thermo_params p = column_params(5, i0);
        sph_column c;
        warm_column(&p, &c, 0.5, 0.002); /* 2 mK below the melting point */
        sph_column_forcing f;
        forcing(&f, 800.0, 0.30, 200.0, 0.0);
        double h0 = c.thick, worst = 0.0, melted = 0.0;
        int above = 0, steps = 0, maxit = 0;
        for (int i = 0; i < 12 && c.thick > 0.0; i++, steps++) {
            sph_column_result r;
            worst = fmax(worst, step_checked(&p, &c, &f, dt, s, &r));
            for (int k = 0; k < c.nlayers; k++)
                above += c.enth[k] > 0.0;
            melted += r.melt_top + r.melt_bottom;
            maxit = r.iterations > maxit ? r.iterations : maxit;
        }
        CHECK(above == 0, "no layer ends above its melting point (q > 0 in %d layer-steps)", above);
        CHECK(worst < 1e-9, "i0 %.2f, dt %.0f s, warm column: energy closes over %d steps (%.3g)", i0, dt, steps,
              worst);
        CHECK(maxit < p.picard_max_iter, "i0 %.2f, dt %.0f s: the iteration converges (%d iterations)", i0, dt, maxit);
        CHECK(melted > 0.0 && c.thick < h0, "the warm column melts (%.3f m of %.2f)", melted, h0);
    }
}

/* The same over a sweep of brine-rich columns: i0 0.17-0.9, 0.2-1.5 m,
 * 2 mK-0.3 K below Tm, 400/900 W/m^2, 10 min and 1 h, 3 and 7 layers, a
 * warm and a cold atmosphere, 20 steps each (before the conductivity floor:
 * 72 steps with rc 1 and energy errors up to 6 |F| dt). */
static void sweep(sph_column_solver *s)
{
    const double i0s[3] = {0.17, 0.5, 0.9}, dTs[4] = {0.002, 0.01, 0.05, 0.3}, hs[3] = {0.2, 0.5, 1.5};
    const double sws[2] = {400.0, 900.0}, dts[2] = {600.0, 3600.0};
    const int ns[2] = {3, 7};
    int bad_rc = 0, above = 0, at_limit = 0, steps = 0, columns = 0;
    double worst = 0.0;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 4; b++)
            for (int k3 = 0; k3 < 3; k3++)
                for (int w = 0; w < 2; w++)
                    for (int d = 0; d < 2; d++)
                        for (int nn = 0; nn < 2; nn++)
                            for (int cold = 0; cold < 2; cold++) {
                                sph_thermo_params p = column_params(ns[nn], i0s[a]);
                                sph_column c;
                                warm_column(&p, &c, hs[k3], dTs[b]);
                                sph_column_forcing f;
                                forcing(&f, sws[w], 0.30, cold ? 150.0 : 300.0, cold ? -20.0 : 10.0);
                                columns++;
                                for (int i = 0; i < 20 && c.thick > 0.0; i++, steps++) {
                                    sph_column_result r;
                                    double E0 = column_energy_here(&p, &c);
                                    int rc = sph_column_step_multi_layer(&p, &c, &f, dts[d], s, &r);
                                    bad_rc += rc != SPH_STEP_OK;
                                    at_limit += r.iterations >= p.picard_max_iter;
                                    for (int k = 0; k < c.nlayers; k++)
                                        above += c.enth[k] > 0.0;
                                    if (r.melted_out)
                                        continue;
                                    double F = surface_flux(&p, &f, 1.0, c.tsurf);
                                    double in = (F + f.fw) * dts[d] - r.energy_to_ocean;
                                    worst = fmax(worst, fabs(column_energy_here(&p, &c) - E0 - in) / ((fabs(F) + f.fw) * dts[d]));
                                }
                            }
    printf("sweep: %d brine-rich columns, %d steps: %d with rc != OK, worst energy %.3g of |F| dt, %d steps at the "
           "Picard limit\n",
           columns, steps, bad_rc, worst, at_limit);
    CHECK(bad_rc == 0, "sweep: every step solves its surface balance (%d failed)", bad_rc);
    CHECK(worst < 1e-9, "sweep: energy closes in every step (%.3g)", worst);
    CHECK(above == 0, "sweep: no layer above its melting point (%d)", above);
}

int main(void)
{
    sph_column_solver *s = sph_column_solver_create();
    under_snow(s);
    bare_ice_beer(s);
    melting_surface(s);
    conductivity_floor();
    beyond_melting_point(s);
    sweep(s);
    sph_column_solver_free(s);
    return check_summary("test_thermo_sw");
}
