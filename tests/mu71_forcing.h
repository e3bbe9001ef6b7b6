/* Maykut & Untersteiner (1971) standard Arctic case, the forcing
 * (PHYSICS.md section 8, Table 1 in W/m^2, sensible and latent into the
 * surface), shared by test_thermo_mu71 and test_snow_mu71. Monthly values
 * are taken at mid-month and interpolated linearly in time (cyclic).
 * Snowfall (MU71, and BL99 after them): 30 cm of snow spread over
 * 20 Aug - 30 Oct, 5 cm over 1 Nov - 30 Apr, 5 cm over May (depths;
 * the snow melts in summer). */
#ifndef SPHICE_TESTS_MU71_FORCING_H
#define SPHICE_TESTS_MU71_FORCING_H

static const double SW[12] = {0.0, 0.0, 30.2, 158.9, 281.6, 305.5, 216.4, 143.2, 58.9, 6.4, 0.0, 0.0};
static const double LW[12] = {165.5, 163.9, 163.9, 184.6, 240.2, 286.4, 303.9, 297.5, 262.5, 221.2, 178.2, 173.4};
static const double SENS[12] = {18.8, 12.1, 11.5, 4.6, -7.2, -6.2, -4.8, -6.4, -2.7, 1.6, 8.9, 12.6};
static const double LAT[12] = {0.0, -0.3, -0.5, -1.4, -7.3, -11.1, -10.2, -10.5, -6.2, -3.0, -0.2, -0.2};
static const double ALB[12] = {.85, .85, .83, .81, .82, .78, .64, .69, .84, .85, .85, .85};
static const int MDAYS[12] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};

/* Linear interpolation between mid-month values; day in [0, 365). */
static double monthly(const double *v, double day)
{
    double mid[12], start = 0.0;
    for (int m = 0; m < 12; m++) {
        mid[m] = start + 0.5 * MDAYS[m];
        start += MDAYS[m];
    }
    int m1 = 11;
    for (int m = 0; m < 12; m++)
        if (day >= mid[m])
            m1 = m;
    int m2 = (m1 + 1) % 12;
    double d1 = mid[m1], d2 = mid[m2];
    if (day < mid[0]) /* before mid-January: between mid-December of last year and mid-January */
        d1 -= 365.0;
    if (d2 < d1)
        d2 += 365.0;
    double w = (day - d1) / (d2 - d1);
    return v[m1] + w * (v[m2] - v[m1]);
}

/* Snowfall rate (m/s) on day-of-year `day` (0 = 1 Jan). */
static double snowfall(double day)
{
    const double aug20 = 231.0, oct31 = 304.0, nov1 = 304.0, may1 = 120.0, jun1 = 151.0;
    if (day >= aug20 && day < oct31)
        return 0.30 / ((oct31 - aug20) * 86400.0);
    if (day >= nov1 || day < may1)
        return 0.05 / (181.0 * 86400.0);
    if (day >= may1 && day < jun1)
        return 0.05 / (31.0 * 86400.0);
    return 0.0;
}

/* MU71's column: 10 layers, their radiation form (all incoming longwave
 * absorbed, emissivity 0.99); everything else the defaults. */
static inline void mu71_params(sph_thermo_params *p)
{
    sph_thermo_params_default(p);
    p->nlayers = 10;
    p->lw_absorptivity = 1.0;
    p->emissivity = 0.99;
}

/* One step of a column (multi: Bitz-Lipscomb, else zero-layer) under the
 * MU71 forcing of day-of-year `day` (with_snow: their snowfall, else none). */
static inline void mu71_step(const sph_thermo_params *p, sph_column *c, sph_column_forcing *f, int multi,
                             int with_snow, double day, double dt, sph_column_solver *s)
{
    f->swdn = monthly(SW, day);
    f->lwdn = monthly(LW, day);
    f->fsens = monthly(SENS, day);
    f->flat = monthly(LAT, day);
    f->albedo = monthly(ALB, day);
    f->snowfall = with_snow ? snowfall(day) : 0.0;
    sph_column_result r;
    if (multi)
        sph_column_step_multi_layer(p, c, f, dt, s, &r);
    else
        sph_column_step_zero_layer(p, c, f, dt, s, &r);
}

#endif
