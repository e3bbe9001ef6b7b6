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


/* Four doubles side by side (AVX2, x86-64 only), for the per-particle
 * passes bound by the divider (mEVP's VP law, relaxation and velocity
 * update: a 256-bit division or root costs what a 128-bit one does on the
 * machines measured, docs/bench.md "Session 9"). Functions using them
 * carry SPH_LANES4_TARGET and run only where sph_lanes4_supported() said
 * so at the model's creation (sph_model.lanes4); each lane does the scalar
 * code's operations in its order, as above, so the bits are the scalar
 * code's. */
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define SPH_HAVE_LANES4 1
#include <immintrin.h>
#define SPH_LANES4_TARGET __attribute__((target("avx2")))
#define SPH_LANES4_INLINE static inline __attribute__((always_inline, target("avx2")))

typedef double sph_v4d __attribute__((vector_size(32)));
typedef long long sph_v4l __attribute__((vector_size(32)));

static inline int sph_lanes4_supported(void) { return __builtin_cpu_supports("avx2"); }

/* a[k[0..3]]; contig: k[l] = k[0] + l (one unaligned load) */
SPH_LANES4_INLINE sph_v4d ld4(const double *a, const size_t *k, int contig)
{
    if (contig)
        return (sph_v4d)_mm256_loadu_pd(a + k[0]);
    return (sph_v4d){a[k[0]], a[k[1]], a[k[2]], a[k[3]]};
}

SPH_LANES4_INLINE void st4(double *a, const size_t *k, int contig, sph_v4d x)
{
    if (contig) {
        _mm256_storeu_pd(a + k[0], (__m256d)x);
        return;
    }
    a[k[0]] = x[0];
    a[k[1]] = x[1];
    a[k[2]] = x[2];
    a[k[3]] = x[3];
}

SPH_LANES4_INLINE sph_v4d splat4(double x) { return (sph_v4d){x, x, x, x}; }
SPH_LANES4_INLINE sph_v4d sqrt4(sph_v4d x) { return (sph_v4d)_mm256_sqrt_pd((__m256d)x); }

SPH_LANES4_INLINE sph_v4d sel4(sph_v4l keep, sph_v4d old, sph_v4d nw)
{
    return (sph_v4d)((keep & (sph_v4l)old) | (~keep & (sph_v4l)nw));
}

SPH_LANES4_INLINE sph_v4d fabs4(sph_v4d x)
{
    const long long mg = 0x7fffffffffffffffLL;
    const sph_v4l mag = {mg, mg, mg, mg};
    return (sph_v4d)((sph_v4l)x & mag);
}

SPH_LANES4_INLINE sph_v4d fmax4(sph_v4d x, sph_v4d y)
{
    sph_v4l keep = (sph_v4l)(x > y) | (sph_v4l)(y != y);
    return sel4(keep, x, y);
}
#else
static inline int sph_lanes4_supported(void) { return 0; }
#endif

#endif
