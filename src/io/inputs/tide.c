/* Harmonic tide astronomy. Formulas and their sources are in io/tide.h;
 * references: P. Schureman (1958), Manual of Harmonic Analysis and
 * Prediction of Tides, US Coast and Geodetic Survey SP 98 (Tables 1, 2,
 * equations 73-78, 214-235); speeds from Doodson numbers as in IHO tables. */
#include "io/tide.h"

#include <math.h>
#include <strings.h>

#define DEG (M_PI / 180.0)

static const char *const names[TIDE_NCONST] = {"m2", "s2", "n2", "k2", "k1", "o1", "p1", "q1"};
static const double speeds[TIDE_NCONST] = {28.9841042, 30.0,       28.4397295, 30.0821373,
                                           15.0410686, 13.9430356, 14.9589314, 13.3986609};

const char *tide_constituent_name(int k)
{
    return k >= 0 && k < TIDE_NCONST ? names[k] : "?";
}

int tide_constituent_index(const char *name)
{
    for (int k = 0; name && k < TIDE_NCONST; k++)
        if (strcasecmp(name, names[k]) == 0)
            return k;
    return -1;
}

double tide_speed_deg_per_hour(int k)
{
    return k >= 0 && k < TIDE_NCONST ? speeds[k] : 0.0;
}

static double wrap360(double x)
{
    x = fmod(x, 360.0);
    return x < 0 ? x + 360.0 : x;
}

void tide_astro_at(double t, tide_astro *a)
{
    /* 1899-12-31 12:00 UT is 25567.5 days before 1970-01-01 00:00 UT. */
    double days = t / 86400.0 + 25567.5;
    double T = days / 36525.0, T2 = T * T, T3 = T2 * T;
    a->s = wrap360(270.434164 + 481267.8831 * T - 0.001133 * T2 + 0.0000019 * T3);
    a->h = wrap360(279.696678 + 36000.768925 * T + 0.0003025 * T2);
    a->p = wrap360(334.329556 + 4069.0340329 * T - 0.010325 * T2 - 0.000012 * T3);
    a->N = wrap360(259.183275 - 1934.142008 * T + 0.002078 * T2 + 0.0000022 * T3);
    double ut_hours = fmod(t / 3600.0, 24.0);
    if (ut_hours < 0)
        ut_hours += 24.0;
    a->tau = wrap360(180.0 + 15.0 * ut_hours);
}

double tide_v0_deg(int k, double t)
{
    tide_astro a;
    tide_astro_at(t, &a);
    double v = 0;
    switch (k) {
    case TIDE_M2: v = 2 * a.tau - 2 * a.s + 2 * a.h; break;
    case TIDE_S2: v = 2 * a.tau; break;
    case TIDE_N2: v = 2 * a.tau - 3 * a.s + 2 * a.h + a.p; break;
    case TIDE_K2: v = 2 * a.tau + 2 * a.h; break;
    case TIDE_K1: v = a.tau + a.h - 90.0; break;
    case TIDE_O1: v = a.tau - 2 * a.s + a.h + 90.0; break;
    case TIDE_P1: v = a.tau - a.h + 90.0; break;
    case TIDE_Q1: v = a.tau - 3 * a.s + a.h + a.p + 90.0; break;
    default: break;
    }
    return wrap360(v);
}

void tide_nodal(int k, double t, double *f, double *u_deg)
{
    tide_astro a;
    tide_astro_at(t, &a);
    const double w = 23.452 * DEG, i = 5.145 * DEG;
    double N = a.N > 180.0 ? a.N - 360.0 : a.N; /* (-180, 180]: N/2 in (-90, 90] */
    N *= DEG;
    double cosI = cos(w) * cos(i) - sin(w) * sin(i) * cos(N);
    double I = acos(cosI);
    /* atan2 with cos(N/2) >= 0 keeps both half-angles continuous in N. */
    double A = atan2(cos((w - i) / 2) * sin(N / 2), cos((w + i) / 2) * cos(N / 2));
    double B = atan2(sin((w - i) / 2) * sin(N / 2), sin((w + i) / 2) * cos(N / 2));
    double nu = A - B, xi = N - (A + B);
    double s2I = sin(2 * I), sI = sin(I), cI2 = cos(I / 2);
    double nup = atan2(s2I * sin(nu), s2I * cos(nu) + 0.3347);
    double nupp2 = atan2(sI * sI * sin(2 * nu), sI * sI * cos(2 * nu) + 0.0727);
    double ff = 1.0, uu = 0.0;
    switch (k) {
    case TIDE_M2:
    case TIDE_N2:
        ff = pow(cI2, 4) / 0.9154;
        uu = 2 * xi - 2 * nu;
        break;
    case TIDE_O1:
    case TIDE_Q1:
        ff = sI * cI2 * cI2 / 0.3800;
        uu = 2 * xi - nu;
        break;
    case TIDE_K1:
        ff = sqrt(0.8965 * s2I * s2I + 0.6001 * s2I * cos(nu) + 0.1006);
        uu = -nup;
        break;
    case TIDE_K2:
        ff = sqrt(19.0444 * pow(sI, 4) + 2.7702 * sI * sI * cos(2 * nu) + 0.0981);
        uu = -nupp2;
        break;
    default:
        break;
    }
    *f = ff;
    *u_deg = uu / DEG;
}

void tide_args_init(tide_args *a, double t_ref, int nodal)
{
    a->t_ref = t_ref;
    for (int k = 0; k < TIDE_NCONST; k++) {
        double f = 1.0, u = 0.0;
        if (nodal)
            tide_nodal(k, t_ref, &f, &u);
        a->f[k] = f;
        a->v0u_rad[k] = (tide_v0_deg(k, t_ref) + u) * DEG;
        a->omega_rad_s[k] = speeds[k] * DEG / 3600.0;
    }
}

double tide_phase_rad(const tide_args *a, int k, double t)
{
    return a->v0u_rad[k] + a->omega_rad_s[k] * (t - a->t_ref);
}

double tide_predict(const tide_args *a, double t, const double amp[TIDE_NCONST],
                    const double phase_deg[TIDE_NCONST])
{
    double x = 0.0;
    for (int k = 0; k < TIDE_NCONST; k++) {
        if (!(amp[k] >= 0.0))
            continue;
        x += a->f[k] * amp[k] * cos(tide_phase_rad(a, k, t) - phase_deg[k] * DEG);
    }
    return x;
}
