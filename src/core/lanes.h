/* Two doubles side by side (GNU C vector extension: SSE2 on x86-64, NEON
 * on AArch64; no wider target assumed), shared by the passes that run two
 * particles in two lanes (operators.c, solver/mevp.c, rheology/vp.c).
 * Each lane does the scalar code's operations in the scalar code's order:
 * IEEE operations are exact per lane and -std=c11 contracts nothing, so a
 * particle's result is bit for bit the scalar loop's. Private to the core. */
#ifndef SPHICE_CORE_LANES_H
#define SPHICE_CORE_LANES_H

#include <math.h>
#include <stddef.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

typedef double sph_v2d __attribute__((vector_size(16)));
typedef long long sph_v2l __attribute__((vector_size(16)));

static inline sph_v2d ld2(const double *a, size_t i0, size_t i1)
{
    return (sph_v2d){a[i0], a[i1]};
}

static inline void st2(double *a, size_t i0, size_t i1, sph_v2d x)
{
    a[i0] = x[0];
    a[i1] = x[1];
}

static inline sph_v2d splat2(double x) { return (sph_v2d){x, x}; }

#if defined(__SSE2__)
static inline sph_v2d sqrt2(sph_v2d x) { return (sph_v2d)_mm_sqrt_pd((__m128d)x); }
#else
static inline sph_v2d sqrt2(sph_v2d x) { return (sph_v2d){sqrt(x[0]), sqrt(x[1])}; }
#endif

/* keep ? old : nw, per lane (keep: all bits set or clear) */
static inline sph_v2d sel2(sph_v2l keep, sph_v2d old, sph_v2d nw)
{
    return (sph_v2d)((keep & (sph_v2l)old) | (~keep & (sph_v2l)nw));
}

/* |x| per lane (the sign bit cleared, as fabs) */
static inline sph_v2d fabs2(sph_v2d x)
{
    const sph_v2l mag = {0x7fffffffffffffffLL, 0x7fffffffffffffffLL};
    return (sph_v2d)((sph_v2l)x & mag);
}

/* fmax(x, y) without the library call (GCC calls libm's fmax at -O2 on
 * x86-64): the larger, the other where one is NaN, y where they compare
 * equal (x86-64 glibc's maxsd; the two zeros of equal magnitude are the
 * only values where "either" differs, and the callers see no -0). */
static inline double sph_fmax(double x, double y) { return (x > y || y != y) ? x : y; }

static inline sph_v2d fmax2(sph_v2d x, sph_v2d y)
{
    sph_v2l keep = (sph_v2l)(x > y) | (sph_v2l)(y != y);
    return sel2(keep, x, y);
}

#endif
