/* Column thermodynamics against analytic results and conservation laws:
 * Bitz-Lipscomb material functions (their formulas), the tridiagonal solver
 * (GSL as peer), Stefan's law (zero-layer exact, multi-layer within 2 %),
 * the equilibrium h = k (Tf - Ts) / F_w, and the multi-layer energy budget
 * over a year of varying forcing. */
#include "check.h"
#include "core/thermo.h"

#include <gsl/gsl_linalg.h>

#define SIGMA 5.670374419e-8

static void fresh(sph_thermo_params *p)
{
    sph_thermo_params_default(p);
    p->salinity_max = 0.0;
    p->ocean_salinity = 0.0; /* Tf = 0 */
}

static void test_material_functions(void)
{
    sph_thermo_params p;
    sph_thermo_params_default(&p);
    const double K0 = 2.03, beta = 0.13, c0 = 2106.0, L0 = 3.34e5, mu = 0.054;
    const double Smax = 3.2, a = 0.407, b = 0.573, rho = 917.0;
    const double zs[] = {0.05, 0.2, 0.5, 0.8, 1.0};
    for (int i = 0; i < 5; i++) {
        double z = zs[i];
        double want = Smax / 2 * (1 - cos(M_PI * pow(z, a / (z + b))));
        CHECK_CLOSE(sph_bl_salinity(&p, z), want, 1e-6, 0.0, "salinity profile");
    }
    CHECK_CLOSE(sph_bl_salinity(&p, 1.0), Smax, 1e-12, 0.0, "S(1) = Smax");
    const double Ss[] = {0.5, 2.0, 3.2};
    const double Ts[] = {-1.0, -5.0, -20.0, -40.0};
    for (int i = 0; i < 3; i++) {
        double S = Ss[i];
        CHECK_CLOSE(sph_bl_melting_temperature(&p, S), -mu * S, 1e-12, 0.0, "Tm = -mu S");
        for (int j = 0; j < 4; j++) {
            double T = Ts[j], Tm = -mu * S;
            CHECK_CLOSE(sph_bl_heat_capacity(&p, S, T), c0 + L0 * mu * S / (T * T), 1e-6, 0.0, "c(S,T)");
            CHECK_CLOSE(sph_bl_conductivity(&p, S, T), K0 + beta * S / T, 1e-6, 0.0, "K(S,T)");
            double q = -rho * (c0 * (Tm - T) + L0 * (1 - Tm / T));
            CHECK_CLOSE(sph_bl_enthalpy(&p, S, T), q, 1e-6, 0.0, "q(S,T)");
            CHECK_CLOSE(sph_bl_temperature(&p, S, q), T, 1e-10, 1e-12, "T(S,q) inverts q");
            /* The energy-conserving form needs dq/dT = rho c. */
            double d = 1e-5;
            double dq = (sph_bl_enthalpy(&p, S, T + d) - sph_bl_enthalpy(&p, S, T - d)) / (2 * d);
            CHECK_CLOSE(dq, rho * (c0 + L0 * mu * S / (T * T)), 1e-6, 0.0, "dq/dT = rho c");
        }
    }
    /* Fresh ice: q = -rho (L0 - c0 T), K = K0 */
    CHECK_CLOSE(sph_bl_enthalpy(&p, 0.0, -10.0), -rho * (L0 + c0 * 10.0), 1e-12, 0.0, "fresh q");
    CHECK_CLOSE(sph_bl_temperature(&p, 0.0, -rho * (L0 + c0 * 10.0)), -10.0, 1e-10, 0.0, "fresh T(q)");
    CHECK_CLOSE(sph_freezing_point(&p), -mu * p.ocean_salinity, 1e-12, 0.0, "Tf = -mu S_ocean");
}

static void test_tridiag(void)
{
    /* Random diagonally dominant system, compared with GSL. */
    enum { N = 9 };
    double sub[N], dia[N], sup[N], rhs[N], x[N], xg[N];
    unsigned s = 12345;
    for (int i = 0; i < N; i++) {
        s = s * 1103515245u + 12345u;
        sub[i] = -(double)(s % 1000) / 500.0;
        s = s * 1103515245u + 12345u;
        sup[i] = -(double)(s % 1000) / 500.0;
        dia[i] = 5.0 + (double)(i % 3);
        rhs[i] = sin(i + 1.0);
    }
    CHECK(sph_tridiag_solve(N, sub, dia, sup, rhs, x) == 0, "solve");
    gsl_vector_view D = gsl_vector_view_array(dia, N), A = gsl_vector_view_array(sup, N - 1),
                    B = gsl_vector_view_array(sub + 1, N - 1), R = gsl_vector_view_array(rhs, N),
                    X = gsl_vector_view_array(xg, N);
    gsl_linalg_solve_tridiag(&D.vector, &A.vector, &B.vector, &R.vector, &X.vector);
    for (int i = 0; i < N; i++)
        CHECK_CLOSE(x[i], xg[i], 1e-12, 1e-14, "tridiag vs GSL");
}

/* Stefan: fixed Ts (varying step by step), F_w = 0, fresh ice, no snow:
 * h^2 = h0^2 + 2 k sum (Tf - Ts) dt / (rho L).
 * Stefan neglects the heat capacity. The multi-layer column is checked
 * (a) under that assumption (c0 = 1 J/kg/K) against Stefan within 2 %, and
 * (b) with physical c0 against the quasi-steady law that keeps the heat
 * needed to cool each new slab to the mean of the linear profile:
 * rho (L + c0 dT/2) d(h^2)/2 = k dT dt, i.e. h^2 (1 + Ste/2) growth with
 * Ste = c0 dT / L (dT taken as the mean Tf - Ts). */
static void test_stefan(void)
{
    sph_thermo_params p, pc;
    fresh(&p);
    p.nlayers = 10;
    pc = p;
    pc.c0 = 1.0;
    sph_column_solver *s = sph_column_solver_create();
    sph_column_forcing f;
    sph_column_forcing_default(&f);
    f.fw = 0.0;
    const double h0 = 0.1, dt = 3600.0, k = 2.03, rho = 917.0, L = 3.34e5, c0 = 2106.0;
    const double Ste = c0 * 20.0 / L;

    sph_column z, m, mc;
    sph_column_init(&p, &z, h0, 0.0, -20.0);
    sph_column_init(&p, &m, h0, 0.0, -20.0);
    sph_column_init(&pc, &mc, h0, 0.0, -20.0);
    double integral = 0.0, worst_zero = 0.0, worst_c = 0.0, err5 = NAN;
    sph_column_result r;
    const int days = 30;
    for (int i = 0; i < days * 24; i++) {
        double Ts = -20.0 + 10.0 * sin(2 * M_PI * i / 240.0); /* -30 .. -10 */
        f.tsurf_prescribed = Ts;
        sph_column_step_zero_layer(&p, &z, &f, dt, s, &r);
        sph_column_step_multi_layer(&p, &m, &f, dt, s, &r);
        sph_column_step_multi_layer(&pc, &mc, &f, dt, s, &r);
        integral += (0.0 - Ts) * dt;
        double hs = sqrt(h0 * h0 + 2 * k * integral / (rho * L));
        double e = fabs(z.thick - hs) / hs;
        if (e > worst_zero)
            worst_zero = e;
        if (i >= 3 * 24 && fabs(mc.thick - hs) / hs > worst_c)
            worst_c = fabs(mc.thick - hs) / hs;
        if (i == 5 * 24 - 1)
            err5 = (mc.thick - hs) / hs;
    }
    double hs = sqrt(h0 * h0 + 2 * k * integral / (rho * L));
    double hq = sqrt(h0 * h0 + 2 * k * integral / (rho * L * (1 + Ste / 2)));
    printf("stefan 30 d: exact %.6f m; zero-layer %.6f (max rel err %.2e); multi-layer c0=1: %.6f "
           "(rel err at 5 d %.2e, worst after 3 d %.2e); multi-layer c0=2106: %.6f (vs Stefan %.4f, "
           "vs Stefan with heat capacity %.6f m: %.4f)\n",
           hs, z.thick, worst_zero, mc.thick, err5, worst_c, m.thick, (m.thick - hs) / hs, hq,
           (m.thick - hq) / hq);
    CHECK(worst_zero < 1e-12, "zero-layer Stefan to round-off: %.3g", worst_zero);
    CHECK(worst_c < 0.02, "multi-layer (no heat capacity) within 2 %% of Stefan after 3 days: %.4f", worst_c);
    CHECK_CLOSE(m.thick, hq, 0.02, 0.0, "multi-layer (physical c) vs quasi-steady law with heat capacity");
    sph_column_solver_free(s);
}

/* Equilibrium with an ocean heat flux: h = k (Tf - Ts) / F_w. */
static void test_equilibrium(void)
{
    sph_thermo_params p;
    fresh(&p);
    sph_column_solver *s = sph_column_solver_create();
    sph_column_forcing f;
    sph_column_forcing_default(&f);
    const double k = 2.03, Ts = -20.0, Fw = 20.0, heq = k * (0.0 - Ts) / Fw;
    f.fw = Fw;
    f.tsurf_prescribed = Ts;
    sph_column_result r;
    /* fixed point */
    sph_column z;
    sph_column_init(&p, &z, heq, 0.0, Ts);
    for (int i = 0; i < 100; i++)
        sph_column_step_zero_layer(&p, &z, &f, 86400.0, s, &r);
    CHECK_CLOSE(z.thick, heq, 1e-12, 0.0, "zero-layer: equilibrium is a fixed point");
    /* approach from both sides, 20 years of daily steps (relaxation time ~1 yr) */
    const double starts[] = {0.5, 4.0};
    for (int j = 0; j < 2; j++) {
        sph_column a, b;
        sph_column_init(&p, &a, starts[j], 0.0, Ts);
        sph_column_init(&p, &b, starts[j], 0.0, Ts);
        for (int i = 0; i < 20 * 365; i++) {
            sph_column_step_zero_layer(&p, &a, &f, 86400.0, s, &r);
            sph_column_step_multi_layer(&p, &b, &f, 86400.0, s, &r);
        }
        printf("equilibrium from %.1f m: want %.4f, zero-layer %.6f, multi-layer %.6f\n", starts[j], heq,
               a.thick, b.thick);
        CHECK_CLOSE(a.thick, heq, 1e-3, 0.0, "zero-layer equilibrium");
        CHECK_CLOSE(b.thick, heq, 1e-3, 0.0, "multi-layer equilibrium");
    }
    sph_column_solver_free(s);
}

/* Multi-layer energy budget over a year: saline ice, snowfall, SW
 * penetration, melting summer, surface temperature from the balance. The
 * expected flux is computed here from the forcing and the returned Ts. */
static void test_energy_conservation(void)
{
    sph_thermo_params p;
    sph_thermo_params_default(&p);
    sph_column_solver *s = sph_column_solver_create();
    sph_column c;
    sph_column_init(&p, &c, 2.0, 0.1, -15.0);
    sph_column_forcing f;
    sph_column_forcing_default(&f);
    const double dt = 3600.0, rho_s = 330.0, L0 = 3.34e5, eps = 0.98;
    double worst = 0.0, melt = 0.0, growth = 0.0;
    int steps = check_quick() ? 24 * 60 : 24 * 365;
    for (int i = 0; i < steps; i++) {
        double day = i / 24.0, ph = 2 * M_PI * day / 365.0;
        f.swdn = fmax(0.0, 150.0 - 170.0 * cos(ph)) * fmax(0.0, sin(2 * M_PI * i / 24.0) + 0.3);
        f.lwdn = 230.0 - 60.0 * cos(ph);
        f.fsens = 10.0 * cos(ph);
        f.flat = -5.0 + 4.0 * cos(ph);
        f.albedo = c.snow > 0.0 ? 0.8 : 0.6;
        f.fw = 2.0 + 3.0 * (1 - cos(ph));
        f.snowfall = (day > 230.0 && day < 300.0) ? 0.3 / (70 * 86400.0) : 0.0;
        double E0 = c.enth[0] * 0.0; /* energy computed here: sum q h/N - rho_s L0 snow */
        for (int k = 0; k < c.nlayers; k++)
            E0 += c.enth[k] * c.thick / c.nlayers;
        E0 -= rho_s * L0 * c.snow;
        sph_column_result r;
        sph_column_step_multi_layer(&p, &c, &f, dt, s, &r);
        double E1 = 0.0;
        for (int k = 0; k < c.nlayers; k++)
            E1 += c.enth[k] * c.thick / c.nlayers;
        E1 -= rho_s * L0 * c.snow;
        double Tk = c.tsurf + 273.15;
        /* All SW absorbed by the column: (1 - albedo) SW, whatever penetrates. */
        double fatm = (1 - f.albedo) * f.swdn + eps * f.lwdn - eps * SIGMA * Tk * Tk * Tk * Tk + f.fsens + f.flat;
        double in = (fatm + f.fw) * dt - rho_s * L0 * f.snowfall * dt - r.energy_to_ocean;
        double scale = (fabs(fatm) + fabs(f.fw)) * dt + rho_s * L0 * f.snowfall * dt;
        double rel = fabs((E1 - E0) - in) / scale;
        if (rel > worst)
            worst = rel;
        melt += r.melt_top + r.melt_bottom;
        growth += r.growth;
    }
    printf("energy: worst |dE - F dt| / (|F| dt) over %d steps = %.3e (growth %.3f m, melt %.3f m, h %.3f m)\n",
           steps, worst, growth, melt, c.thick);
    CHECK(worst < 1e-9, "multi-layer energy change equals boundary flux x dt: %.3g", worst);
    if (!check_quick())
        CHECK(melt > 0.1 && growth > 0.1, "the year both grew (%.3f) and melted (%.3f) ice", growth, melt);
    sph_column_solver_free(s);
}

int main(void)
{
    test_material_functions();
    test_tridiag();
    test_stefan();
    test_equilibrium();
    test_energy_conservation();
    return check_summary("test_thermo_column");
}
