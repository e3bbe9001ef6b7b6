/* Zero-layer vs multi-layer column on the same forcing, ice 0.05-2 m:
 * thickness after 96 h and after 30 days, and the cost of one column step.
 * Prints markdown tables (docs/thermo.md) that justify auto_thickness.
 *
 * Forcings (1800 s step, bulk turbulent fluxes):
 *  - "Bohai winter": as tests/test_thermo_bohai.c (air -15..-2 C, wind
 *    5-10 m/s, January sun at 40 N, F_w 20 W/m^2, grey-ice albedo 0.5);
 *  - "Bohai thaw": air -4..+4 C, stronger sun (March), same ocean.
 * Usage: bench_thermo [nlayers] (default 7). */
#include "core/thermo.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#define SIGMA 5.670374419e-8

static void forcing(sph_column_forcing *f, double t, int thaw)
{
    double day = t / 86400.0, hour = fmod(t / 3600.0, 24.0);
    double Ta = thaw ? 0.0 + 3.0 * sin(2 * M_PI * day / 6.0) - 1.0 * cos(2 * M_PI * hour / 24.0)
                     : -8.5 + 5.0 * sin(2 * M_PI * day / 6.0) - 1.5 * cos(2 * M_PI * hour / 24.0);
    f->tair = Ta;
    f->wind = 7.5 + 2.5 * sin(2 * M_PI * day / 3.3);
    double e = 0.7 * 611.2 * exp(17.62 * Ta / (243.12 + Ta));
    f->qair = 0.622 * e / (101325.0 - 0.378 * e);
    double noon = thaw ? 650.0 : 420.0;
    f->swdn = hour > 7.0 && hour < 17.0 ? noon * sin(M_PI * (hour - 7.0) / 10.0) : 0.0;
    double Tk = Ta + 273.15;
    f->lwdn = 0.78 * SIGMA * Tk * Tk * Tk * Tk;
    f->fw = 20.0;
}

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

int main(int argc, char **argv)
{
    sph_thermo_params p;
    sph_thermo_params_default(&p);
    p.albedo_ice = 0.5;
    if (argc > 1)
        p.nlayers = (int)strtol(argv[1], NULL, 10);
    const double h0s[] = {0.05, 0.10, 0.15, 0.20, 0.25, 0.30, 0.40, 0.50, 0.75, 1.00, 1.50, 2.00};
    const int nh = sizeof h0s / sizeof h0s[0];
    const double dt = 1800.0;
    const int steps96 = (int)(96 * 3600 / dt), steps30 = (int)(30 * 86400 / dt);
    sph_column_solver *s = sph_column_solver_create();
    double tz = 0.0, tm = 0.0;
    long nz = 0, nm = 0;
    for (int thaw = 0; thaw < 2; thaw++) {
        printf("\n%s, %d layers: thickness (m) after 96 h and 30 d, difference zero - multi\n\n",
               thaw ? "Bohai thaw" : "Bohai winter", p.nlayers);
        printf("| h0 (m) | zero 96 h | multi 96 h | diff 96 h (cm) | diff / multi change | zero 30 d | multi 30 d | "
               "diff 30 d (cm) | diff / multi change |\n");
        printf("|---|---|---|---|---|---|---|---|---|\n");
        for (int i = 0; i < nh; i++) {
            sph_column z, m;
            sph_column_forcing f;
            sph_column_forcing_default(&f);
            forcing(&f, 0.0, thaw);
            double Ts0 = f.tair < 0.0 ? f.tair : 0.0;
            sph_column_init(&p, &z, h0s[i], 0.0, Ts0);
            sph_column_init(&p, &m, h0s[i], 0.0, Ts0);
            double z96 = 0, m96 = 0;
            sph_column_result r;
            for (int k = 0; k < steps30; k++) {
                forcing(&f, (k + 0.5) * dt, thaw);
                double t0 = now();
                if (z.thick > 0.0)
                    sph_column_step_zero_layer(&p, &z, &f, dt, s, &r);
                double t1 = now();
                if (m.thick > 0.0)
                    sph_column_step_multi_layer(&p, &m, &f, dt, s, &r);
                double t2 = now();
                tz += t1 - t0;
                tm += t2 - t1;
                nz++;
                nm++;
                if (k == steps96 - 1) {
                    z96 = z.thick;
                    m96 = m.thick;
                }
            }
            double c96 = fabs(m96 - h0s[i]), c30 = fabs(m.thick - h0s[i]);
            char r96[32] = "-", r30[32] = "-"; /* ratio only where the change is > 1 cm */
            if (c96 > 0.01)
                snprintf(r96, sizeof r96, "%+.0f %%", 100 * (z96 - m96) / c96);
            if (c30 > 0.01)
                snprintf(r30, sizeof r30, "%+.0f %%", 100 * (z.thick - m.thick) / c30);
            printf("| %.2f | %.3f | %.3f | %+.1f | %s | %.3f | %.3f | %+.1f | %s |\n", h0s[i], z96, m96,
                   100 * (z96 - m96), r96, z.thick, m.thick, 100 * (z.thick - m.thick), r30);
        }
    }
    printf("\ncost per column step: zero-layer %.2f us, multi-layer (%d layers) %.2f us\n", 1e6 * tz / nz,
           p.nlayers, 1e6 * tm / nm);
    sph_column_solver_free(s);
    return 0;
}
