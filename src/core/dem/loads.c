/* Cheap ice-load models and load-series statistics. */
#include "dem_impl.h"

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

void dem_load_stats(const double *f, size_t n, double dt, double *mean, double *max,
                    double *std, double *freq)
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
    /* Dominant frequency: the largest amplitude of the demeaned series'
     * DFT over k = 1 .. n/2 (a direct sum; series are short). */
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
