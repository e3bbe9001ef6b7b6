/* Random perturbation fields for ensemble members (issue 24).
 *
 * A field is a sum of M random Fourier modes (random-phase spectral
 * synthesis; Rahimi & Recht 2007 "random features", the construction
 * behind many stochastic forcing schemes):
 *
 *   f(x, y, t) = sigma sqrt(2/M) sum_m cos(kx_m x + ky_m y - om_m t + ph_m)
 *
 * with (kx, ky) ~ N(0, I / L^2), om ~ Cauchy(0, 1/T), ph ~ U(0, 2 pi).
 * Its expected covariance is exactly
 *
 *   E[f(x) f(x + r, t + tau)] = sigma^2 exp(-|r|^2 / (2 L^2)) exp(-|tau| / T)
 *
 * (the characteristic functions of the Gaussian and the Cauchy laws), so
 * sigma is the standard deviation, L the Gaussian correlation length (the
 * correlation falls to exp(-1/2) at distance L) and T the e-folding time.
 * L <= 0 gives a field uniform in space, T <= 0 one frozen in time. A field
 * is a pure function of (x, y, t): it does not depend on the order or the
 * number of evaluations, nor on threads or processes.
 *
 * Modes are drawn with GSL's MT19937 from a seed made of the ensemble seed,
 * the member and the stream (one stream per perturbed quantity), so the
 * same seed gives the same ensemble bit for bit. No I/O; allocation only in
 * sph_rfield_init. */
#ifndef SPHICE_CORE_PERTURB_H
#define SPHICE_CORE_PERTURB_H

typedef struct sph_rfield {
    int nmodes;
    double sigma, amp; /* amp = sigma sqrt(2 / nmodes) */
    double *kx, *ky, *om, *ph;
} sph_rfield;

/* The 64-bit generator seed of (seed, member, stream): a SplitMix64 mix,
 * so neighbouring members get unrelated streams. */
unsigned long long sph_perturb_seed(unsigned long long seed, int member, int stream);

/* Draws a field. sigma = 0 gives the zero field (no allocation). Returns 0,
 * or -1 when out of memory or nmodes < 1. */
int sph_rfield_init(sph_rfield *f, int nmodes, double sigma, double length_m, double time_s,
                    unsigned long long seed);
void sph_rfield_free(sph_rfield *f); /* NULL-safe; leaves the zero field */

/* f(x, y, t): x, y in m on the model plane, t in s. */
double sph_rfield_eval(const sph_rfield *f, double x, double y, double t);

/* One standard normal number from (seed, member, stream) into *g: the
 * scalar perturbations (ice strength, drag coefficients). Returns 0, or -1
 * when out of memory. */
int sph_perturb_normal(unsigned long long seed, int member, int stream, double *g);

#endif
