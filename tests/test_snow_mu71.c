/* Maykut & Untersteiner (1971) standard case WITH their snow (issue 20
 * item 3), both columns, against the published reproductions.
 *
 * Forcing: tests/mu71_forcing.h (MU71 Table 1, prescribed monthly albedo,
 * snowfall 30 cm over 20 Aug - 30 Oct, 5 cm over Nov - Apr, 5 cm in May,
 * F_w = 2 W/m^2), MU71's radiation form (all LW absorbed, emissivity
 * 0.99), i0 = 0.17, 30 years at 1 h from 3 m; the last year is measured.
 *
 * Published values used (annual mean ice thickness of the equilibrium
 * cycle), as quoted in the brief (not re-read from the papers in
 * this session):
 *   Semtner (1976) zero-layer model: 2.6 - 3.0 m;
 *   Semtner (1976) three-layer model: about 2.92 m;
 *   Bitz & Lipscomb (1999): 2.8 - 3.1 m;
 *   MU71 themselves: about 3 m (PHYSICS.md section 8: 2.5 - 3.5 m).
 * Asserted: the zero-layer column within Semtner's zero-layer range; the
 * multi-layer column within MU71's 2.5 - 3.5 m (it is above BL99's range:
 * a known discrepancy, docs/thermo.md, printed here beside the range);
 * the snow never exceeds the 0.40 m that fell, nearly all of it stays
 * until the June melt, and it is gone by late July; the
 * snow insulates: without it the same run grows thicker winter ice
 * (a larger maximum), as MU71 found for snow depths up to 0.7 m.
 * Numbers: build/tests/test_snow_mu71 prints them. */
#include "check.h"
#include "core/thermo.h"

#include "mu71_forcing.h"

typedef struct {
    double mean, hmax, hmin, snow_max, snow_min_summer;
} cycle;

static cycle run(const sph_thermo_params *p, int multi, int with_snow, int years, double dt)
{
    sph_column_solver *s = sph_column_solver_create();
    sph_column c;
    sph_column_init(p, &c, 3.0, 0.0, -25.0);
    sph_column_forcing f;
    sph_column_forcing_default(&f);
    f.fw = 2.0;
    cycle y = {0};
    int steps = (int)(365 * 86400.0 / dt);
    for (int yr = 0; yr < years; yr++) {
        y = (cycle){0.0, -1e30, 1e30, 0.0, 1e30};
        for (int i = 0; i < steps; i++) {
            double day = (i + 0.5) * dt / 86400.0;
            mu71_step(p, &c, &f, multi, with_snow, day, dt, s);
            y.mean += c.thick / steps;
            y.hmax = fmax(y.hmax, c.thick);
            y.hmin = fmin(y.hmin, c.thick);
            y.snow_max = fmax(y.snow_max, c.snow);
            if (day >= 200.0 && day < 231.0) /* 19 Jul - 19 Aug: after the melt, before the snow */
                y.snow_min_summer = fmin(y.snow_min_summer, c.snow);
        }
    }
    sph_column_solver_free(s);
    return y;
}

int main(void)
{
    sph_thermo_params p;
    mu71_params(&p);
    const int quick = check_quick();
    const int years = quick ? 4 : 30;
    const double dt = quick ? 6 * 3600.0 : 3600.0;
    cycle z = run(&p, 0, 1, years, dt), m = run(&p, 1, 1, years, dt);
    cycle z0 = run(&p, 0, 0, years, dt), m0 = run(&p, 1, 0, years, dt);
    printf("MU71 with snow, %d years at %.0f h (published annual means: Semtner 1976 zero-layer "
           "2.6-3.0 m, three-layer 2.92 m; BL99 2.8-3.1 m; MU71 about 3 m)\n",
           years, dt / 3600.0);
    const cycle *all[4] = {&z, &m, &z0, &m0};
    const char *name[4] = {"zero-layer, snow ", "multi-layer, snow", "zero-layer, none ", "multi-layer, none"};
    for (int k = 0; k < 4; k++)
        printf("  %s: mean %.3f m, max %.3f, min %.3f, range %.3f m, snow max %.3f m\n", name[k],
               all[k]->mean, all[k]->hmax, all[k]->hmin, all[k]->hmax - all[k]->hmin,
               all[k]->snow_max);
    for (int k = 0; k < 2; k++) {
        /* at most what fell (0.30 + 0.05 + 0.05 m); melt in late August
         * and late May takes a little (the exact accumulation: test_snow) */
        CHECK(all[k]->snow_max <= 0.40 + 1e-9 && all[k]->snow_max > 0.39,
              "%s: snow max %.4f m, at most the 0.40 m that fell", name[k], all[k]->snow_max);
        CHECK(all[k]->snow_min_summer == 0.0, "%s: the snow has melted by late July", name[k]);
    }
    if (!quick) {
        CHECK(z.mean >= 2.6 && z.mean <= 3.0, "zero-layer annual mean %.3f m in Semtner's 2.6-3.0 m", z.mean);
        CHECK(m.mean >= 2.5 && m.mean <= 3.5, "multi-layer annual mean %.3f m in MU71's 2.5-3.5 m", m.mean);
        if (!(m.mean >= 2.8 && m.mean <= 3.1))
            printf("  known discrepancy: multi-layer mean %.3f m is outside BL99's 2.8-3.1 m "
                   "(docs/thermo.md)\n", m.mean);
        CHECK(z0.hmax > z.hmax && m0.hmax > m.hmax, "snow insulates: winter maximum without snow "
              "%.3f / %.3f m above %.3f / %.3f m with", z0.hmax, m0.hmax, z.hmax, m.hmax);
    }
    return check_summary("test_snow_mu71");
}
