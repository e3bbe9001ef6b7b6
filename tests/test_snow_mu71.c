/* Maykut & Untersteiner (1971) standard case WITH their snow (issue 20
 * item 3), both columns, against the published reproductions.
 *
 * Forcing: tests/mu71_forcing.h (MU71 Table 1, prescribed monthly albedo,
 * snowfall 30 cm over 20 Aug - 30 Oct, 5 cm over Nov - Apr, 5 cm in May,
 * 0.40 m in all, F_w = 2 W/m^2), MU71's radiation form (all LW absorbed,
 * emissivity 0.99), i0 = 0.17 on bare ice only (0 under snow), extinction
 * 1.5 /m, 10 layers, k_s = 0.31, rho_s = 330, S(z) of MU71 with
 * Tm = -0.054 S; 30 years at 1 h from 3 m; the last year is measured.
 * The multi-layer column is run as Bitz & Lipscomb (1999) run it, with
 * the snow's heat capacity (thermo.snow_heat_capacity); the same column
 * without it is printed beside it.
 *
 * Published values (as quoted in the brief; the papers were not
 * available to re-read in this session):
 *   Semtner (1976) zero-layer model, annual mean: 2.6 - 3.0 m;
 *   Bitz & Lipscomb (1999), annual mean: 2.8 - 3.1 m;
 *   MU71's annual cycle: about 3.5 m at most, 2.9 m at least.
 * Asserted in every run: the zero-layer mean in Semtner's range; the
 * cycle has converged (< 1 cm/yr); the snow never exceeds the 0.40 m that
 * fell, nearly all of it stays until the June melt, and it is gone by late
 * July; the snow insulates (without it the winter maximum is larger).
 * Asserted under SPHICE_LONG (make check-long): the multi-layer mean in
 * BL99's range and its cycle within MU71's maximum and minimum. Measured
 * (docs/thermo.md): the multi-layer mean is 3.40 m, above BL99's range;
 * without SPHICE_LONG the gap is printed as a KNOWN GAP line instead. Its
 * cause, measured against Bitz's BL99 column (docs/thermo.md, "Fourth
 * look"): this forcing's reading of the monthly table; on BL99's own daily
 * file (SPHICE_MU71_DAILY below) the same column gives 2.74 m.
 * Like with like (issue 20), asserted in every full run: the multi-layer
 * column's mean, maximum and minimum, with i0 = 0.17 and with i0 = 0,
 * within the 5 % (its tolerance against a peer column) of Bitz's
 * BL99 column run on this test's own forcing and set-up
 * (tests/reference/bl99_mu71.h: numbers and provenance; the forcing was
 * exported with SPHICE_MU71_EXPORT below). The same peer with its
 * snow-surface flux in sphice's two-point form is printed beside it.
 * Also under SPHICE_LONG: where the penetrating shortwave goes (one year
 * with i0 = 0.17 against i0 = 0 from the same converged column), with the
 * energy difference between the two equal to the difference of the
 * atmospheric flux taken up. */
#include "check.h"
#include "core/thermo.h"

#include "mu71_forcing.h"
#include "reference/bl99_mu71.h"

typedef struct {
    double mean, prev_mean, hmax, hmin, snow_max, snow_min_summer;
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
        y = (cycle){0.0, y.mean, -1e30, 1e30, 0.0, 1e30};
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

/* Where the penetrating shortwave goes (SPHICE_LONG): from the converged
 * multi-layer column without it (i0 = 0), one more year with i0 = 0 and
 * one with i0 = 0.17, side by side. Fluxes in MJ/m^2, summed over the
 * melt season (day 150-230) and the autumn after it (day 230-365). The
 * only difference between the runs is where the absorbed shortwave is
 * put, so the difference of the column's energy at the end equals the
 * difference of the atmospheric flux the surface took up (both runs
 * close their budgets per step: test_snow, test_thermo_sw). */
static void attribution(const sph_thermo_params *pc, int years, double dt)
{
    sph_thermo_params p0 = *pc;
    p0.sw_pen_frac = 0.0;
    sph_column_solver *s = sph_column_solver_create();
    sph_column c;
    sph_column_init(&p0, &c, 3.0, 0.0, -25.0);
    sph_column_forcing f;
    sph_column_forcing_default(&f);
    f.fw = 2.0;
    const int steps = (int)(365 * 86400.0 / dt);
    for (int yr = 0; yr < years; yr++)
        for (int i = 0; i < steps; i++)
            mu71_step(&p0, &c, &f, 1, 1, (i + 0.5) * dt / 86400.0, dt, s);
    const sph_column start = c;
    double fm[2][2] = {{0}}, fa[2][2] = {{0}}, ft[2][2] = {{0}}, top[2] = {0}, grow[2] = {0}, bot[2] = {0};
    double E[2], h[2];
    for (int run = 0; run < 2; run++) {
        const sph_thermo_params *p = run ? pc : &p0;
        c = start;
        double E0 = sph_column_energy(p, &c);
        for (int i = 0; i < steps; i++) {
            double day = (i + 0.5) * dt / 86400.0;
            f.swdn = monthly(SW, day);
            f.lwdn = monthly(LW, day);
            f.fsens = monthly(SENS, day);
            f.flat = monthly(LAT, day);
            f.albedo = monthly(ALB, day);
            f.snowfall = snowfall(day);
            sph_column_result r;
            sph_column_step_multi_layer(p, &c, &f, dt, s, &r);
            int season = day >= 150.0 && day < 230.0 ? 0 : day >= 230.0 ? 1 : -1;
            if (season >= 0) {
                fm[run][season] += r.fmelt * dt / 1e6;
                fa[run][season] += r.fatm * dt / 1e6;
                ft[run][season] += r.fcond_top * dt / 1e6;
            }
            top[run] += r.melt_top;
            grow[run] += r.growth;
            bot[run] += r.melt_bottom;
        }
        E[run] = sph_column_energy(p, &c) - E0;
        h[run] = c.thick;
    }
    sph_column_solver_free(s);
    double dfatm = (fa[1][0] + fa[1][1]) - (fa[0][0] + fa[0][1]); /* day 0-150: the same (snow, i0 = 0) */
    printf("  i0 0.17 vs 0 for one year from the converged i0 = 0 column (%.3f m): day 150-230 surface melt "
           "%.1f vs %.1f MJ/m^2, conduction into the ice %.1f vs %.1f, absorbed at the surface and below %.1f vs "
           "%.1f; day 230-365 atmospheric flux %.1f vs %.1f; top melt %.3f vs %.3f m, growth %.3f vs %.3f, "
           "bottom melt %.3f vs %.3f; thickness after the year %.4f vs %.4f m (%+.4f m)\n",
           start.thick, fm[1][0], fm[0][0], ft[1][0], ft[0][0], fa[1][0], fa[0][0], fa[1][1], fa[0][1], top[1],
           top[0], grow[1], grow[0], bot[1], bot[0], h[1], h[0], h[1] - h[0]);
    CHECK(fabs((E[1] - E[0]) / 1e6 - dfatm) < 1e-6 * fabs(fa[0][0]),
          "the penetrating shortwave changes the column's energy by the change of the atmospheric flux: "
          "%.4f vs %.4f MJ/m^2", (E[1] - E[0]) / 1e6, dfatm);
}

/* Optional (SPHICE_MU71_DAILY=FILE): the test's columns under a daily
 * forcing file in the layout of the Bitz-Lipscomb column's own MU71 forcing
 * (C.M. Bitz's column as ported in andrewpauling/pyBL99, column/data.mu71:
 * 365 rows of shortwave down, longwave down, upward sensible, upward latent,
 * all in mW/m^2, and MU71's albedo; each step linear between the previous
 * day's row and the day's row, as that column does). The file is not in
 * this repository; docs/thermo.md ("Fourth look") gives what it measures:
 * the same column, only the forcing's representation changed. Nothing is
 * asserted beyond reading the file. */
static void daily_file(const sph_thermo_params *pz, const sph_thermo_params *pm, const char *path, int years,
                       double dt)
{
    static double D[365][5];
    FILE *fp = fopen(path, "r");
    int ok = fp != NULL;
    for (int i = 0; ok && i < 365; i++)
        for (int j = 0; j < 5; j++)
            ok = ok && fscanf(fp, "%lf", &D[i][j]) == 1 && isfinite(D[i][j]);
    if (fp)
        fclose(fp);
    CHECK(ok, "SPHICE_MU71_DAILY=%s: 365 rows of 5 numbers", path);
    if (!ok)
        return;
    const int nper = (int)(86400.0 / dt + 0.5);
    for (int run = 0; run < 3; run++) {
        sph_thermo_params p = run == 0 ? *pz : *pm;
        if (run == 2)
            p.sw_pen_frac = 0.0;
        sph_column_solver *s = sph_column_solver_create();
        sph_column c;
        sph_column_init(&p, &c, 3.0, 0.0, -25.0);
        sph_column_forcing f;
        sph_column_forcing_default(&f);
        f.fw = 2.0;
        cycle y = {0};
        for (int yr = 0; yr < years; yr++) {
            y = (cycle){0.0, y.mean, -1e30, 1e30, 0.0, 1e30};
            for (int d = 0; d < 365; d++)
                for (int k = 0; k < nper; k++) {
                    const double *a = D[d > 0 ? d - 1 : (yr > 0 ? 364 : 0)], *b = D[d], w = (k + 1.0) / nper;
                    f.swdn = 1e-3 * (a[0] + w * (b[0] - a[0]));
                    f.lwdn = 1e-3 * (a[1] + w * (b[1] - a[1]));
                    f.fsens = -1e-3 * (a[2] + w * (b[2] - a[2]));
                    f.flat = -1e-3 * (a[3] + w * (b[3] - a[3]));
                    f.albedo = a[4] + w * (b[4] - a[4]);
                    f.snowfall = snowfall(d + (k + 0.5) / nper);
                    sph_column_result r;
                    if (run == 0)
                        sph_column_step_zero_layer(&p, &c, &f, dt, s, &r);
                    else
                        sph_column_step_multi_layer(&p, &c, &f, dt, s, &r);
                    y.mean += c.thick / (365.0 * nper);
                    y.hmax = fmax(y.hmax, c.thick);
                    y.hmin = fmin(y.hmin, c.thick);
                }
        }
        sph_column_solver_free(s);
        printf("  daily file %s, %s: mean %.3f m, max %.3f, min %.3f, last-year change %+.4f m\n", path,
               run == 0 ? "zero-layer, snow" : run == 1 ? "multi-layer, snow (BL99)" : "multi-layer, snow, i0 = 0",
               y.mean, y.hmax, y.hmin, y.mean - y.prev_mean);
    }
}

/* Optional (SPHICE_MU71_EXPORT=FILE): write this test's forcing, one row per
 * step of one year exactly as mu71_step gives it (the step's mid-time),
 * for a peer column: shortwave down, longwave down, upward sensible,
 * upward latent (all mW/m^2 = erg/cm^2/s, the units of the Bitz-Lipscomb
 * column's forcing file), MU71's albedo, snowfall during the step (m).
 * tests/reference/bl99_mu71.txt records the peer's run on it. */
static void export_forcing(const char *path, double dt)
{
    FILE *fp = fopen(path, "w");
    CHECK(fp != NULL, "SPHICE_MU71_EXPORT=%s opens for writing", path);
    if (!fp)
        return;
    const int steps = (int)(365 * 86400.0 / dt);
    fprintf(fp, "# test_snow_mu71 forcing, %d steps of %.0f s: swdn lwdn upsens upltnt (mW/m^2) albedo snowfall (m per "
                "step)\n", steps, dt);
    for (int i = 0; i < steps; i++) {
        double day = (i + 0.5) * dt / 86400.0;
        fprintf(fp, "%.17g %.17g %.17g %.17g %.17g %.17g\n", 1e3 * monthly(SW, day), 1e3 * monthly(LW, day),
                -1e3 * monthly(SENS, day), -1e3 * monthly(LAT, day), monthly(ALB, day), snowfall(day) * dt);
    }
    CHECK(fclose(fp) == 0, "SPHICE_MU71_EXPORT=%s: written", path);
}

/* A published range check: a CHECK under SPHICE_LONG, else a KNOWN GAP line. */
static void range(int hard, double v, double lo, double hi, const char *what, const char *published)
{
    int in = v >= lo && v <= hi;
    if (hard)
        CHECK(in, "%s %.3f m within %s", what, v, published);
    else if (!in)
        printf("  KNOWN GAP (issue 20): %s %.3f m, not within %s: %+.3f m (asserted under SPHICE_LONG; "
               "docs/thermo.md)\n", what, v, published, v > hi ? v - hi : v - lo);
}

int main(void)
{
    sph_thermo_params p, pc;
    mu71_params(&p);
    pc = p;
    pc.snow_heat_capacity = 1; /* BL99: snow with enthalpy */
    const int quick = check_quick();
    const int years = quick ? 4 : 30;
    const double dt = quick ? 6 * 3600.0 : 3600.0;
    const int hard = check_long();
    if (getenv("SPHICE_MU71_EXPORT"))
        export_forcing(getenv("SPHICE_MU71_EXPORT"), dt);
    cycle z = run(&p, 0, 1, years, dt), m = run(&pc, 1, 1, years, dt);
    cycle z0 = run(&p, 0, 0, years, dt), m0 = run(&pc, 1, 0, years, dt);
    cycle m1 = hard ? run(&p, 1, 1, years, dt) : m; /* without the snow's heat capacity: long runs only */
    printf("MU71 with snow, %d years at %.0f h (published: Semtner 1976 zero-layer mean 2.6-3.0 m; BL99 "
           "mean 2.8-3.1 m; MU71 cycle about 3.5 m max, 2.9 m min)\n",
           years, dt / 3600.0);
    const cycle *all[5] = {&z, &m, &m1, &z0, &m0};
    const int nrun = hard ? 5 : 4, order[5] = {0, 1, 3, 4, 2};
    const char *name[5] = {"zero-layer, snow           ", "multi-layer, snow (BL99)   ",
                           "multi-layer, snow, no c_s  ", "zero-layer, no snow        ",
                           "multi-layer, no snow       "};
    for (int i = 0; i < nrun; i++) {
        int k = order[i];
        printf("  %s: mean %.3f m, max %.3f, min %.3f, range %.3f m, snow max %.3f m, last-year change "
               "%+.4f m\n",
               name[k], all[k]->mean, all[k]->hmax, all[k]->hmin, all[k]->hmax - all[k]->hmin,
               all[k]->snow_max, all[k]->mean - all[k]->prev_mean);
    }
    for (int k = 0; k < (hard ? 3 : 2); k++) {
        /* at most what fell (0.30 + 0.05 + 0.05 m); melt in late August
         * and late May takes a little (the exact accumulation: test_snow) */
        CHECK(all[k]->snow_max <= 0.40 + 1e-9 && all[k]->snow_max > 0.39,
              "%s: snow max %.4f m, at most the 0.40 m that fell", name[k], all[k]->snow_max);
        CHECK(all[k]->snow_min_summer == 0.0, "%s: the snow has melted by late July", name[k]);
    }
    if (!quick) {
        for (int k = 0; k < 2; k++)
            CHECK(fabs(all[k]->mean - all[k]->prev_mean) < 0.01, "%s: the cycle repeats (%+.4f m/yr)", name[k],
                  all[k]->mean - all[k]->prev_mean);
        CHECK(z.mean >= 2.6 && z.mean <= 3.0, "zero-layer annual mean %.3f m in Semtner's 2.6-3.0 m", z.mean);
        range(hard, m.mean, 2.8, 3.1, "multi-layer annual mean", "BL99's 2.8-3.1 m");
        range(hard, m.hmax, 0.0, 3.5, "multi-layer annual maximum", "MU71's maximum of about 3.5 m");
        range(hard, m.hmin, 2.9, 1e9, "multi-layer annual minimum", "MU71's minimum of about 2.9 m");
        CHECK(z0.hmax > z.hmax && m0.hmax > m.hmax, "snow insulates: winter maximum without snow "
              "%.3f / %.3f m above %.3f / %.3f m with", z0.hmax, m0.hmax, z.hmax, m.hmax);
    }
    if (!quick) {
        /* Like with like (issue 20): Bitz's BL99 column run on this test's
         * own forcing and set-up (tests/reference/bl99_mu71.h, provenance
         * there). Tolerance: the 5 % for sphice against a peer
         * column (its Icepack comparison of thickness). */
        sph_thermo_params pd = pc;
        pd.sw_pen_frac = 0.0;
        cycle md = run(&pd, 1, 1, years, dt);
        printf("  multi-layer, snow, i0 = 0   : mean %.3f m, max %.3f, min %.3f, last-year change %+.4f m\n",
               md.mean, md.hmax, md.hmin, md.mean - md.prev_mean);
        const struct {
            double v, ref, ref2;
            const char *what;
        } cmp[6] = {
            {m.mean, BL99_MU71_MEAN, BL99_MU71_2PT_MEAN, "i0 0.17 annual mean"},
            {m.hmax, BL99_MU71_MAX, BL99_MU71_2PT_MAX, "i0 0.17 annual maximum"},
            {m.hmin, BL99_MU71_MIN, BL99_MU71_2PT_MIN, "i0 0.17 annual minimum"},
            {md.mean, BL99_MU71_I0_0_MEAN, BL99_MU71_2PT_I0_0_MEAN, "i0 0 annual mean"},
            {md.hmax, BL99_MU71_I0_0_MAX, BL99_MU71_2PT_I0_0_MAX, "i0 0 annual maximum"},
            {md.hmin, BL99_MU71_I0_0_MIN, BL99_MU71_2PT_I0_0_MIN, "i0 0 annual minimum"},
        };
        for (int k = 0; k < 6; k++) {
            double rel = (cmp[k].v - cmp[k].ref) / cmp[k].ref;
            printf("  like with like: multi-layer %s %.3f m, Bitz's BL99 column on this forcing %.3f m (%+.1f %%); "
                   "with its snow-surface flux in the two-point form %.3f m (%+.1f %%)\n",
                   cmp[k].what, cmp[k].v, cmp[k].ref, 100.0 * rel, cmp[k].ref2,
                   100.0 * (cmp[k].v - cmp[k].ref2) / cmp[k].ref2);
            CHECK(fabs(rel) <= 0.05, "multi-layer %s %.3f m within 5 %% of Bitz's BL99 column on the same forcing "
                  "(%.3f m): %+.1f %%", cmp[k].what, cmp[k].v, cmp[k].ref, 100.0 * rel);
        }
    }
    if (hard)
        attribution(&pc, years, dt);
    if (getenv("SPHICE_MU71_DAILY"))
        daily_file(&p, &pc, getenv("SPHICE_MU71_DAILY"), years, dt);
    return check_summary("test_snow_mu71");
}
