/* Maykut & Untersteiner (1971) standard Arctic case (PHYSICS.md section 8,
 * Table 1 forcing in W/m^2, sensible and latent into the surface).
 * Monthly values are taken at mid-month and interpolated linearly in time
 * (cyclic). Snowfall: 30 cm spread over 20 Aug - 30 Oct, 5 cm over
 * 1 Nov - 30 Apr, 5 cm over May (accumulations; the snow melts in summer).
 * F_w = 2 W/m^2, 365-day years, 1 h step, prescribed monthly albedo.
 * Radiation as in MU71's surface balance: all incoming longwave absorbed,
 * emission with emissivity 0.99 (lw_absorptivity = 1, emissivity = 0.99);
 * i0 = 0.17 of the net shortwave penetrates bare ice, extinction 1.5 /m.
 * Asserts: the annual cycle repeats (< 1 cm year-on-year), the annual mean
 * thickness is 2.5-3.5 m (MU71: about 3 m), and the zero-layer column's
 * seasonal amplitude exceeds the multi-layer column's. */
#include "check.h"
#include "core/thermo.h"

#include "mu71_forcing.h"

typedef struct {
    double mean, hmax, hmin, h_jan1;
} year_stats;

static year_stats run_year(const sph_thermo_params *p, sph_column *c, int multi, sph_column_solver *s,
                           double dt, double *snow_max)
{
    sph_column_forcing f;
    sph_column_forcing_default(&f);
    f.fw = 2.0;
    year_stats y = {0.0, -1e30, 1e30, c->thick};
    int steps = (int)(365 * 86400.0 / dt);
    *snow_max = 0.0;
    for (int i = 0; i < steps; i++) {
        double day = (i + 0.5) * dt / 86400.0;
        mu71_step(p, c, &f, multi, 1, day, dt, s);
        y.mean += c->thick / steps;
        if (c->thick > y.hmax)
            y.hmax = c->thick;
        if (c->thick < y.hmin)
            y.hmin = c->thick;
        if (c->snow > *snow_max)
            *snow_max = c->snow;
    }
    return y;
}

int main(void)
{
    sph_thermo_params p;
    mu71_params(&p);
    sph_column_solver *s = sph_column_solver_create();
    /* Full: 30 years at 1 h. Quick (valgrind): 6 years at 6 h, no range asserts. */
    int years = check_quick() ? 6 : 30;
    double dt = check_quick() ? 6 * 3600.0 : 3600.0;
    year_stats last[2], prev[2];
    double snow_max = 0.0;
    for (int multi = 0; multi < 2; multi++) {
        sph_column c;
        sph_column_init(&p, &c, 3.0, 0.0, -25.0);
        for (int yr = 0; yr < years; yr++) {
            prev[multi] = last[multi];
            last[multi] = run_year(&p, &c, multi, s, dt, &snow_max);
        }
        printf("MU71 %s after %d years: mean %.3f m, max %.3f, min %.3f, amplitude %.3f m, "
               "year-on-year change of the mean %.2e m, snow max %.2f m\n",
               multi ? "multi-layer" : "zero-layer ", years, last[multi].mean, last[multi].hmax,
               last[multi].hmin, last[multi].hmax - last[multi].hmin, last[multi].mean - prev[multi].mean,
               snow_max);
    }
    for (int m = 0; m < 2; m++)
        CHECK(isfinite(last[m].mean) && last[m].hmin > 1.0, "MU71 ice survives (%s)", m ? "multi" : "zero");
    if (!check_quick()) {
        for (int m = 0; m < 2; m++) {
            CHECK(fabs(last[m].mean - prev[m].mean) < 0.01, "cycle repeats (%s): %.4f m", m ? "multi" : "zero",
                  last[m].mean - prev[m].mean);
            CHECK(fabs(last[m].h_jan1 - prev[m].h_jan1) < 0.01, "1 Jan thickness repeats (%s)", m ? "multi" : "zero");
        }
        CHECK(last[1].mean >= 2.5 && last[1].mean <= 3.5, "multi-layer annual mean %.3f m in 2.5-3.5",
              last[1].mean);
        CHECK(last[0].mean >= 2.5 && last[0].mean <= 3.5, "zero-layer annual mean %.3f m in 2.5-3.5",
              last[0].mean);
        CHECK(last[0].hmax - last[0].hmin > last[1].hmax - last[1].hmin,
              "zero-layer amplitude %.3f > multi-layer %.3f", last[0].hmax - last[0].hmin,
              last[1].hmax - last[1].hmin);
    }
    sph_column_solver_free(s);
    return check_summary("test_thermo_mu71");
}
