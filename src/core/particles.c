#include "core/particles.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Every per-particle double array, in one list so create/free/copy/remove
 * can never drift apart. */
#define SPH_DOUBLE_FIELDS(X)                                                          \
    X(x) X(y) X(u) X(v) X(mass) X(thick) X(conc) X(sml) X(snow) X(tsurf) X(s11)    \
    X(s22) X(s12) X(dens) X(e11) X(e22) X(e12) X(pres) X(ax) X(ay) X(lat) X(ua)     \
    X(va) X(uw) X(vw) X(sshx) X(sshy) X(tair) X(qair) X(swdn) X(lwdn) X(sst) X(fw) \
    X(fsens) X(flat) X(sml0) X(dens0) X(coastc)

sph_particles *sph_particles_create(size_t cap, int nlayers)
{
    if (cap == 0 || nlayers < 1 || nlayers > SPH_MAX_LAYERS)
        return NULL;
    sph_particles *p = calloc(1, sizeof *p);
    if (!p)
        return NULL;
    p->cap = cap;
    p->nlayers = nlayers;
    int ok = 1;
#define ALLOC_(f) ok &= (p->f = calloc(cap, sizeof(double))) != NULL;
    SPH_DOUBLE_FIELDS(ALLOC_)
#undef ALLOC_
    ok &= (p->enth = calloc(cap * (size_t)nlayers, sizeof(double))) != NULL;
    ok &= (p->id = calloc(cap, sizeof(long))) != NULL;
    ok &= (p->regime = calloc(cap, 1)) != NULL;
    if (!ok) {
        sph_particles_free(p);
        return NULL;
    }
    for (size_t k = 0; k < cap; k++) {
        p->fsens[k] = NAN;
        p->flat[k] = NAN;
    }
    return p;
}

void sph_particles_free(sph_particles *p)
{
    if (!p)
        return;
#define FREE_(f) free(p->f);
    SPH_DOUBLE_FIELDS(FREE_)
#undef FREE_
    free(p->enth);
    free(p->id);
    free(p->regime);
    free(p);
}

void sph_particles_copy_one(sph_particles *dst, size_t d, const sph_particles *src, size_t s)
{
#define COPY_(f) dst->f[d] = src->f[s];
    SPH_DOUBLE_FIELDS(COPY_)
#undef COPY_
    int nl = dst->nlayers < src->nlayers ? dst->nlayers : src->nlayers;
    memcpy(dst->enth + d * (size_t)dst->nlayers, src->enth + s * (size_t)src->nlayers,
           (size_t)nl * sizeof(double));
    dst->id[d] = src->id[s];
    dst->regime[d] = src->regime[s];
}

void sph_particles_remove(sph_particles *p, size_t k)
{
    if (k >= p->n)
        return;
    size_t last = p->n - 1;
    if (k != last)
        sph_particles_copy_one(p, k, p, last);
    p->n = last;
}

void sph_particles_permute(sph_particles *p, const int *order, double *scratch)
{
    size_t n = p->n;
#define PERM_(f)                                      \
    for (size_t i = 0; i < n; i++)                    \
        scratch[i] = p->f[order[i]];                  \
    memcpy(p->f, scratch, n * sizeof(double));
    SPH_DOUBLE_FIELDS(PERM_)
#undef PERM_
    size_t nl = (size_t)p->nlayers;
    for (size_t i = 0; i < n; i++)
        memcpy(scratch + i * nl, p->enth + (size_t)order[i] * nl, nl * sizeof(double));
    memcpy(p->enth, scratch, n * nl * sizeof(double));
    long *ids = (long *)scratch;
    for (size_t i = 0; i < n; i++)
        ids[i] = p->id[order[i]];
    memcpy(p->id, ids, n * sizeof(long));
    unsigned char *rg = (unsigned char *)scratch;
    for (size_t i = 0; i < n; i++)
        rg[i] = p->regime[order[i]];
    memcpy(p->regime, rg, n);
}
