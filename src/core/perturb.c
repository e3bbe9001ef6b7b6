/* Random perturbation fields: see core/perturb.h. */
#include "core/perturb.h"

#include <gsl/gsl_randist.h>
#include <gsl/gsl_rng.h>
#include <math.h>
#include <stdlib.h>

unsigned long long sph_perturb_seed(unsigned long long seed, int member, int stream)
{
    /* SplitMix64 (Steele, Lea & Flood 2014) of the three inputs in turn */
    unsigned long long z = seed;
    unsigned long long in[2] = {(unsigned long long)(unsigned)member, (unsigned long long)(unsigned)stream};
    for (int i = 0; i < 3; i++) {
        z += 0x9E3779B97F4A7C15ULL + (i ? in[i - 1] * 0xD1B54A32D192ED03ULL : 0);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
        z ^= z >> 31;
    }
    return z;
}

static gsl_rng *rng_for(unsigned long long seed)
{
    gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);
    if (r) /* MT19937 takes an unsigned long; fold the 64 bits */
        gsl_rng_set(r, (unsigned long)(seed ^ (seed >> 32)));
    return r;
}

void sph_rfield_free(sph_rfield *f)
{
    if (!f)
        return;
    free(f->kx);
    f->kx = f->ky = f->om = f->ph = NULL;
    f->nmodes = 0;
    f->sigma = f->amp = 0.0;
}

int sph_rfield_init(sph_rfield *f, int nmodes, double sigma, double length_m, double time_s,
                    unsigned long long seed)
{
    f->kx = f->ky = f->om = f->ph = NULL;
    f->nmodes = 0;
    f->sigma = f->amp = 0.0;
    if (nmodes < 1)
        return -1;
    if (!(sigma > 0.0))
        return 0;
    double *w = malloc(4 * (size_t)nmodes * sizeof *w);
    gsl_rng *r = rng_for(seed);
    if (!w || !r) {
        free(w);
        gsl_rng_free(r);
        return -1;
    }
    f->kx = w;
    f->ky = w + nmodes;
    f->om = w + 2 * nmodes;
    f->ph = w + 3 * nmodes;
    for (int m = 0; m < nmodes; m++) {
        /* drawn in a fixed order per mode: kx, ky, om, ph */
        double gx = gsl_ran_ugaussian(r), gy = gsl_ran_ugaussian(r);
        double c = gsl_ran_cauchy(r, 1.0);
        double u = gsl_rng_uniform(r);
        f->kx[m] = length_m > 0.0 ? gx / length_m : 0.0;
        f->ky[m] = length_m > 0.0 ? gy / length_m : 0.0;
        f->om[m] = time_s > 0.0 ? c / time_s : 0.0;
        f->ph[m] = 2.0 * M_PI * u;
    }
    gsl_rng_free(r);
    f->nmodes = nmodes;
    f->sigma = sigma;
    f->amp = sigma * sqrt(2.0 / nmodes);
    return 0;
}

double sph_rfield_eval(const sph_rfield *f, double x, double y, double t)
{
    if (f->nmodes == 0)
        return 0.0;
    double s = 0.0;
    for (int m = 0; m < f->nmodes; m++)
        s += cos(f->kx[m] * x + f->ky[m] * y - f->om[m] * t + f->ph[m]);
    return f->amp * s;
}

int sph_perturb_normal(unsigned long long seed, int member, int stream, double *g)
{
    gsl_rng *r = rng_for(sph_perturb_seed(seed, member, stream));
    if (!r)
        return -1;
    *g = gsl_ran_ugaussian(r);
    gsl_rng_free(r);
    return 0;
}
