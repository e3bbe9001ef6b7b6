/* Canonical mode for domain decomposition (core/dd.h): neighbour lists in
 * a global order, exact norms, and the driver's hooks. */
#include "core/dd.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "model_impl.h"

/* ------------------------------------------------------------------ */
/* exact accumulator                                                   */

/* Bit 0 of digit 0 has weight 2^-1074 (the smallest subnormal); a double's
 * 53-bit significand shifted into place spans at most three digits. */
#define XSUM_BIAS 1074

void sph_xsum_clear(sph_xsum *a) { memset(a, 0, sizeof *a); }

void sph_xsum_add(sph_xsum *a, double x)
{
    if (!isfinite(x)) {
        a->nonfinite++;
        return;
    }
    if (x == 0.0)
        return;
    uint64_t bits;
    memcpy(&bits, &x, sizeof bits);
    int neg = (int)(bits >> 63);
    int ex = (int)((bits >> 52) & 0x7ff);
    uint64_t mant = bits & ((UINT64_C(1) << 52) - 1);
    int pos; /* weight of the significand's lowest bit, from 2^-1074 */
    if (ex == 0) {
        pos = 0; /* subnormal: mant x 2^-1074 */
    } else {
        mant |= UINT64_C(1) << 52;
        pos = ex - 1;
    }
    int dig = pos / 32, sh = pos % 32;
    unsigned __int128 v = (unsigned __int128)mant << sh;
    int64_t p0 = (int64_t)(uint32_t)v, p1 = (int64_t)(uint32_t)(v >> 32),
            p2 = (int64_t)(uint32_t)(v >> 64);
    if (neg) {
        a->d[dig] -= p0;
        a->d[dig + 1] -= p1;
        a->d[dig + 2] -= p2;
    } else {
        a->d[dig] += p0;
        a->d[dig + 1] += p1;
        a->d[dig + 2] += p2;
    }
}

void sph_xsum_merge(sph_xsum *a, const sph_xsum *b)
{
    for (int i = 0; i < SPH_XSUM_DIGITS; i++)
        a->d[i] += b->d[i];
    a->nonfinite += b->nonfinite;
}

double sph_xsum_value(const sph_xsum *a)
{
    if (a->nonfinite)
        return NAN;
    int64_t d[SPH_XSUM_DIGITS];
    double sign = 1.0;
    for (int pass = 0; pass < 2; pass++) {
        for (int i = 0; i < SPH_XSUM_DIGITS; i++)
            d[i] = pass ? -a->d[i] : a->d[i];
        /* carries: digits 0 .. D-2 in [0, 2^32), the top one signed; this
         * form is unique for the exact value */
        for (int i = 0; i < SPH_XSUM_DIGITS - 1; i++) {
            int64_t c = d[i] >> 32; /* floor division (arithmetic shift) */
            d[i] -= c * ((int64_t)1 << 32);
            d[i + 1] += c;
        }
        if (d[SPH_XSUM_DIGITS - 1] >= 0)
            break;
        sign = -1.0; /* a negative total: convert its magnitude */
    }
    double s = 0.0;
    for (int i = SPH_XSUM_DIGITS; i-- > 0;)
        if (d[i] != 0)
            s += ldexp((double)d[i], 32 * i - XSUM_BIAS);
    return sign * s;
}

/* ------------------------------------------------------------------ */
/* canonical mode                                                      */

int sph_model_set_canonical(sph_model *m, int on)
{
    if (!on) {
        m->canonical = 0;
        return 0;
    }
    size_t slots = sph_model_slots(m);
    if (!m->dd_key)
        m->dd_key = malloc(slots * sizeof *m->dd_key);
    if (!m->dd_owned)
        m->dd_owned = calloc(slots, 1);
    if (!m->dd_key || !m->dd_owned)
        return -1;
    m->canonical = 1;
    return sph_dd_ocean_alloc(m); /* the mixed layer's view (ocean/ocean_dd.c) */
}

void sph_model_set_dd(sph_model *m, const sph_dd_hooks *h) { m->dd = h; }

unsigned char *sph_model_dd_owned(sph_model *m) { return m->canonical ? m->dd_owned : NULL; }

double sph_model_kernel_radius(const sph_model *m) { return m->kern.radius; }

void sph_model_dd_coast(sph_model *m, double sml0_max)
{
    /* as sph_model_init: new particles' smoothing length too */
    if (sph_ocean_on(m) && m->prm.ocean.create)
        sml0_max = fmax(sml0_max, m->prm.sml_factor * m->ocean->g.ds);
    if (m->has_mask)
        sph_mark_near_land(m, m->kern.radius * m->prm.sml_max_factor * sml0_max);
}

/* The halo's coast zone (docs/domain.md "Halo depth"). A mirror ghost lies
 * 2 d1 from its source across the first wall, 2 d2 across the second, and
 * |2 d1 n1 + 2 d2 n2| across both (a corner: |n1 . n2| < 0.5, so at most
 * 2 sqrt(d1^2 + d2^2 + d1 d2) <= 2 sqrt(3) S), d1, d2 within the source's
 * support (coast.c sph_build_ghosts), S the largest support. */
double sph_model_dd_ghost_reach(void) { return 2.0 * sqrt(3.0); }

size_t sph_model_dd_zone_cells(const sph_model *m)
{
    return m->has_mask ? (size_t)m->mask.nx * (size_t)m->mask.ny : 0;
}

void sph_model_dd_zone(const sph_model *m, double radius, unsigned char *zone)
{
    if (m->has_mask)
        sph_mark_land_within(m, radius, zone);
}

int sph_model_dd_in_zone(const sph_model *m, const unsigned char *zone, double x, double y)
{
    if (!m->has_mask)
        return 0;
    const sph_landmask *k = &m->mask;
    double fi = floor((x - k->x0) / k->dx), fj = floor((y - k->y0) / k->dy);
    if (!(fi >= 0 && fj >= 0 && fi < k->nx && fj < k->ny))
        return 1; /* outside the mask (a new particle at an open edge): in */
    return zone[(size_t)fj * (size_t)k->nx + (size_t)fi] != 0;
}

/* Keys: live particle id * 4; a mirror ghost id * 4 + 1 + its number among
 * its source's ghosts (coast.c adds a source's ghosts one after another:
 * first wall, second wall, corner). */
void sph_dd_sort_lists(sph_model *m)
{
    sph_particles *P = m->P;
    sph_nbr *nb = m->nb;
    size_t n = P->n;
    long *key = m->dd_key;
    for (size_t k = 0; k < n; k++)
        key[k] = P->id[k] * 4;
    for (size_t g = 0, ord = 0; g < m->ng; g++) {
        ord = g > 0 && m->ghost_src[g] == m->ghost_src[g - 1] ? ord + 1 : 0;
        key[n + g] = P->id[m->ghost_src[g]] * 4 + 1 + (long)ord;
    }
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++) {
        size_t b = nb->off[k];
        int c = nb->count[k];
        int *idx = nb->idx + b;
        /* W moves along only where the build stored it (nb->keep_w), gy
         * only in the stored-components form (nb->factor: gx holds the
         * gradient's factor F, its dx, dy come from the positions) */
        double *w = nb->keep_w ? nb->w + b : NULL, *gx = nb->gx + b;
        double *gy = nb->factor ? NULL : nb->gy + b;
        for (int a = 1; a < c; a++) { /* insertion sort: lists are short */
            int ti = idx[a];
            long tk = key[ti];
            double tw = w ? w[a] : 0.0, tx = gx[a], ty = gy ? gy[a] : 0.0;
            int q = a;
            while (q > 0 && key[idx[q - 1]] > tk) {
                idx[q] = idx[q - 1];
                if (w)
                    w[q] = w[q - 1];
                gx[q] = gx[q - 1];
                if (gy)
                    gy[q] = gy[q - 1];
                q--;
            }
            idx[q] = ti;
            if (w)
                w[q] = tw;
            gx[q] = tx;
            if (gy)
                gy[q] = ty;
        }
    }
}

void sph_dd_lists_ready(sph_model *m)
{
    if (m->dd)
        m->dd->exchange(m->dd->ctx, m, SPH_DD_LISTS);
    else
        memset(m->dd_owned, 1, m->P->n);
}

void sph_dd_mevp_norms(sph_model *m, const int *act, size_t na, const double *res2, double *r,
                       double *s2, double *q2, double *u2, double *nact)
{
    const sph_particles *P = m->P;
    const unsigned char *own = m->dd_owned;
    sph_xsum acc[4];
    for (int q = 0; q < 4; q++)
        sph_xsum_clear(&acc[q]);
    double mx = 0.0;
    for (size_t i = 0; i < na; i++) {
        size_t k = (size_t)act[i];
        if (!own[k])
            continue;
        double d = m->dvel[k];
        mx = fmax(mx, d);
        sph_xsum_add(&acc[0], d * d);
        sph_xsum_add(&acc[1], res2[k]);
        sph_xsum_add(&acc[2], P->u[k] * P->u[k] + P->v[k] * P->v[k]);
        sph_xsum_add(&acc[3], 1.0);
    }
    if (m->dd && m->dd->reduce)
        m->dd->reduce(m->dd->ctx, acc, 4, &mx, 1);
    *r = mx;
    *s2 = sph_xsum_value(&acc[0]);
    *q2 = sph_xsum_value(&acc[1]);
    *u2 = sph_xsum_value(&acc[2]);
    *nact = sph_xsum_value(&acc[3]);
}

const sph_xsum *sph_model_dd_sources(const sph_model *m) { return m->dd_src; }

void sph_dd_budget_sources(sph_budget *b, const sph_budget *base, const sph_xsum src[SPH_DD_NSRC])
{
    double v[SPH_DD_NSRC];
    for (int q = 0; q < SPH_DD_NSRC; q++)
        v[q] = sph_xsum_value(&src[q]);
    b->growth = base->growth + v[SPH_DD_SRC_GROWTH];
    b->new_ice = base->new_ice + v[SPH_DD_SRC_NEW_ICE];
    b->melt_top = base->melt_top + v[SPH_DD_SRC_MELT_TOP];
    b->melt_bottom = base->melt_bottom + v[SPH_DD_SRC_MELT_BOTTOM];
    b->lateral_melt = base->lateral_melt + v[SPH_DD_SRC_LATERAL_MELT];
    b->snow_ice = base->snow_ice + v[SPH_DD_SRC_SNOW_ICE];
    b->snowfall = base->snowfall + v[SPH_DD_SRC_SNOWFALL];
    b->snow_melt = base->snow_melt + v[SPH_DD_SRC_SNOW_MELT];
    b->snow_to_ocean = base->snow_to_ocean + v[SPH_DD_SRC_SNOW_TO_OCEAN];
    b->outflow = base->outflow + v[SPH_DD_SRC_OUTFLOW];
    b->removed_particles = base->removed_particles + (long)v[SPH_DD_SRC_REMOVED];
}

void sph_dd_remove(sph_model *m, size_t k)
{
    sph_particles *P = m->P;
    if (m->canonical && k + 1 < P->n)
        m->dd_owned[k] = m->dd_owned[P->n - 1];
    sph_particles_remove(P, k);
}

/* Carries every digit but the top one into [0, 2^32): the same exact value,
 * and room for 2^31 more additions (the sources accumulate over the whole
 * run: particles x thermodynamic steps). */
static void xsum_carry(sph_xsum *a)
{
    for (int i = 0; i < SPH_XSUM_DIGITS - 1; i++) {
        int64_t c = a->d[i] >> 32;
        a->d[i] -= c * ((int64_t)1 << 32);
        a->d[i + 1] += c;
    }
}

void sph_dd_update_sources(sph_model *m)
{
    if (!m->canonical)
        return;
    for (int q = 0; q < SPH_DD_NSRC; q++)
        xsum_carry(&m->dd_src[q]);
    sph_dd_budget_sources(&m->budget, &m->dd_base, m->dd_src);
}
