/* Cheap ice-load models and load-series statistics. */
#include "dem_impl.h"
#include <string.h>

double dem_iso_pressure(double c_r, double h, double w)
{
    if (!(h > 0.0) || !(w > 0.0) || !(c_r > 0.0) || !(w / h > 2.0))
        return NAN;
    const double h1 = 1.0, m = -0.16;
    double n = h < 1.0 ? -0.5 + h / 5.0 : -0.3;
    return c_r * pow(h / h1, n) * pow(w / h, m);
}

double dem_iso_force(double c_r, double h, double w)
{
    return dem_iso_pressure(c_r, h, w) * w * h;
}

void dem_load_moments(const double *f, size_t n, double *mean, double *max, double *std)
{
    double s = 0.0, mx = -HUGE_VAL;
    for (size_t i = 0; i < n; i++) {
        s += f[i];
        mx = fmax(mx, f[i]);
    }
    double mu = n ? s / (double)n : 0.0, v = 0.0;
    for (size_t i = 0; i < n; i++)
        v += (f[i] - mu) * (f[i] - mu);
    *mean = mu;
    *max = n ? mx : 0.0;
    *std = n > 1 ? sqrt(v / (double)(n - 1)) : 0.0;
}

void dem_load_stats(const double *f, size_t n, double dt, double *mean, double *max,
                    double *std, double *freq)
{
    dem_load_moments(f, n, mean, max, std);
    const double mu = *mean;
    /* Dominant frequency: the largest amplitude of the demeaned series'
     * DFT over k = 1 .. n/2 (a direct sum: block means, include/core/dem.h) */
    double best = -1.0, fk = 0.0;
    for (size_t k = 1; k <= n / 2; k++) {
        double re = 0.0, im = 0.0, wk = 2.0 * M_PI * (double)k / (double)n;
        for (size_t i = 0; i < n; i++) {
            re += (f[i] - mu) * cos(wk * (double)i);
            im -= (f[i] - mu) * sin(wk * (double)i);
        }
        double a = re * re + im * im;
        if (a > best) {
            best = a;
            fk = (double)k / ((double)n * dt);
        }
    }
    *freq = fk;
}

int dem_scene_choose(const dem_scene_keys *k, double concentration, double speed,
                     double thickness, const char **why)
{
    if (!(k->min_concentration >= 0.0 && k->min_concentration <= 1.0) || !(k->min_speed >= 0.0) ||
        !(k->min_thickness >= 0.0) || k->force < DEM_CHOOSE_AUTO || k->force > DEM_CHOOSE_DEM) {
        *why = "a scene threshold is out of range";
        return -1;
    }
    if (k->force == DEM_CHOOSE_CHEAP) {
        *why = "the cheap model is forced by the configuration";
        return DEM_MODEL_CHEAP;
    }
    if (k->force == DEM_CHOOSE_DEM) {
        *why = "the DEM is forced by the configuration";
        return DEM_MODEL_DEM;
    }
    if (!isfinite(concentration) || !isfinite(speed) || !isfinite(thickness)) {
        *why = "the scene's concentration, speed or thickness is not finite";
        return -1;
    }
    if (concentration < k->min_concentration) {
        *why = "concentration below the DEM threshold";
        return DEM_MODEL_CHEAP;
    }
    if (speed < k->min_speed) {
        *why = "drift speed below the DEM threshold";
        return DEM_MODEL_CHEAP;
    }
    if (thickness < k->min_thickness) {
        *why = "thickness below the DEM threshold";
        return DEM_MODEL_CHEAP;
    }
    *why = "ice present, moving and thick: all DEM thresholds reached";
    return DEM_MODEL_DEM;
}

/* Complete elliptic integrals K(k) and E(k) of modulus k (parameter
 * m = k^2) by the arithmetic-geometric mean (Abramowitz & Stegun 17.6). */
static void elliptic_ke(double k, double *K, double *E)
{
    double a = 1.0, b = sqrt(1.0 - k * k), c = k, sum = 0.5 * c * c, p2 = 0.5;
    for (int n = 0; n < 40 && fabs(c) > 1e-16; n++) {
        double an = 0.5 * (a + b);
        c = 0.5 * (a - b);
        b = sqrt(a * b);
        a = an;
        p2 *= 2.0;
        sum += p2 * c * c;
    }
    *K = M_PI / (2.0 * a);
    *E = *K * (1.0 - sum);
}

int dem_ralston_cone(const dem_cone_ice *c, dem_cone_load *out, const char **why)
{
    memset(out, 0, sizeof *out);
    out->h = out->v = out->h_break = out->h_rideup = NAN;
    const double Y = 2.711, grav = 9.81;
    if (!(c->flexural_strength > 0.0) || !(c->thickness > 0.0) || !(c->ice_density > 0.0) ||
        !(c->rideup_thickness >= 0.0) || !isfinite(c->rideup_thickness)) {
        *why = "Ralston: flexural strength, thickness, ride-up thickness or density not positive";
        return -1;
    }
    if (!(c->diameter > 0.0) || !(c->top_diameter >= 0.0 && c->top_diameter < c->diameter)) {
        *why = "Ralston: the waterline diameter must be positive and above the top (neck) diameter";
        return -1;
    }
    if (!(c->angle >= 20.0 && c->angle <= 70.0)) {
        *why = "Ralston: cone angle outside the method's range [20, 70] degrees";
        return -1;
    }
    double a = c->angle * M_PI / 180.0, sa = sin(a), ca = cos(a), ta = tan(a), mu = c->friction;
    if (!(mu >= 0.0 && mu <= fmin(ta, 1.0 / ta) - 0.01)) {
        *why = "Ralston: friction outside [0, min(tan a, cot a) - 0.01]";
        return -1;
    }
    double g = (sa + a / ca) / (2.0 * mu * a * ca + 0.5 * M_PI * sa * sa);
    double den = 1.0 - g * mu;
    if (!(den > 0.0)) {
        *why = "Ralston: 1 - g mu is not positive (the cone jams: angle and friction too large)";
        return -1;
    }
    double h = c->thickness, D = c->diameter, sf = c->flexural_strength;
    double G = c->ice_density * grav * D * D / (4.0 * sf * h);
    double x = 1.0 + 1.0 / sqrt(3.0 * G + 0.5 * Y);
    double hb = sf * h * h / 3.0 * ta / den *
                (G * (x - 1.0) * (x + 2.0) + (1.0 + Y * x * log(x)) / (x - 1.0));
    double K, E;
    elliptic_ke(sa, &K, &E);
    double W = c->ice_density * grav * c->rideup_thickness *
               (D * D - c->top_diameter * c->top_diameter) / (4.0 * ca);
    double f = mu * K * ca + sa;
    double hr = W * (ta + mu * (E - f * g * ca)) / den;
    double xi = (sa + mu * ca) / (ca - mu * sa);
    out->h_break = hb;
    out->h_rideup = hr;
    out->h = hb + hr;
    out->v = out->h / xi;
    out->g = g;
    out->xi = xi;
    *why = "within Ralston's range";
    return 0;
}
