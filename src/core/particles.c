#include "core/particles.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Everything below iterates SPH_PARTICLE_FIELDS (core/particles.h), so that
 * create/free/copy/remove/permute can never drift apart from the struct. */

#define SPH_PF_TYPE_(name)                                                               \
    _Generic(((sph_particles *)0)->name, double *: SPH_FIELD_DOUBLE, long *: SPH_FIELD_LONG, \
             unsigned char *: SPH_FIELD_UCHAR)
#define INFO_(name, type, count, tag, restart, units, long_name)                             \
    {#name, units, long_name, SPH_FIELD_##tag, SPH_RESTART_##restart, SPH_PF_TYPE_(name), \
     sizeof(type), SPH_FIELD_LAYERED_##count},
const sph_particle_field sph_particle_fields[SPH_PARTICLE_NFIELDS] = {
    SPH_PARTICLE_FIELDS(INFO_)
};
#undef INFO_
#undef SPH_PF_TYPE_

sph_particles *sph_particles_create(size_t cap, int nlayers)
{
    return sph_particles_create_live(cap, cap, nlayers);
}

sph_particles *sph_particles_create_live(size_t cap, size_t live, int nlayers)
{
    if (cap == 0 || nlayers < 1 || nlayers > SPH_MAX_LAYERS)
        return NULL;
    sph_particles *p = calloc(1, sizeof *p);
    if (!p)
        return NULL;
    p->cap = cap;
    p->nlayers = nlayers;
    int ok = 1;
#define ALLOC_(name, type, count, ...) \
    ok &= (p->name = calloc(cap * SPH_FIELD_COUNT(p, count), sizeof(type))) != NULL;
    SPH_PARTICLE_FIELDS(ALLOC_)
#undef ALLOC_
    if (!ok) {
        sph_particles_free(p);
        return NULL;
    }
    for (size_t k = 0; k < live && k < cap; k++) {
        p->fsens[k] = NAN;
        p->flat[k] = NAN;
    }
    return p;
}

void sph_particles_free(sph_particles *p)
{
    if (!p)
        return;
#define FREE_(name, ...) free(p->name);
    SPH_PARTICLE_FIELDS(FREE_)
#undef FREE_
    free(p);
}

int sph_particles_release_thermal_forcing(sph_particles *p)
{
    double **f[] = {&p->tair, &p->qair, &p->swdn, &p->lwdn, &p->sst,
                    &p->fw,   &p->fsens, &p->flat, &p->snowfall};
    enum { NF = sizeof f / sizeof f[0] };
    double *fresh[NF];
    for (size_t k = 0; k < NF; k++) {
        fresh[k] = calloc(p->cap, sizeof(double));
        if (!fresh[k]) {
            while (k > 0)
                free(fresh[--k]);
            return -1;
        }
    }
    for (size_t k = 0; k < NF; k++) {
        free(*f[k]);
        *f[k] = fresh[k];
    }
    return 0;
}

void sph_particles_copy_one(sph_particles *dst, size_t d, const sph_particles *src, size_t s)
{
    /* layered fields: as many layers as both sets have */
#define COPY_(name, type, count, ...)                                                       \
    if (!SPH_FIELD_LAYERED_##count) {                                                       \
        dst->name[d] = src->name[s];                                                        \
    } else {                                                                                \
        size_t cd_ = SPH_FIELD_COUNT(dst, count), cs_ = SPH_FIELD_COUNT(src, count);        \
        memmove(dst->name + d * cd_, src->name + s * cs_, (cd_ < cs_ ? cd_ : cs_) * sizeof(type)); \
    }
    SPH_PARTICLE_FIELDS(COPY_)
#undef COPY_
}

void sph_particles_clear_one(sph_particles *p, size_t k)
{
#define CLEAR_(name, type, count, ...)                                                      \
    memset(p->name + k * SPH_FIELD_COUNT(p, count), 0, SPH_FIELD_COUNT(p, count) * sizeof(type));
    SPH_PARTICLE_FIELDS(CLEAR_)
#undef CLEAR_
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

/* 1 when the nbytes at a are all zero bits (a field no step has written:
 * calloc's zeros, whose pages reading does not make resident). */
static int all_zero_bytes(const void *a, size_t nbytes)
{
    const unsigned char *b = a;
    size_t k = 0;
    for (; k + sizeof(unsigned long long) <= nbytes; k += sizeof(unsigned long long)) {
        unsigned long long w;
        memcpy(&w, b + k, sizeof w);
        if (w)
            return 0;
    }
    for (; k < nbytes; k++)
        if (b[k])
            return 0;
    return 1;
}

/* copies, element by element: the same in any split over threads */
#define PERM_OMP_ _Pragma("omp parallel for schedule(static) if (n >= 4096)")

void sph_particles_permute(sph_particles *p, const int *order, double *scratch)
{
    size_t n = p->n;
    /* a field that is all zero bits is the same in any order: left alone, so
     * that the fields a run never uses (the ocean fluxes without them, the
     * stress in free drift, ...) never take memory */
#define PERM_(name, type, count, ...)                                                       \
    if (!all_zero_bytes(p->name, n * SPH_FIELD_COUNT(p, count) * sizeof(type))) {           \
        size_t c_ = SPH_FIELD_COUNT(p, count);                                              \
        type *s_ = (type *)(void *)scratch;                                                 \
        for (size_t l_ = 0; l_ < c_; l_++) { /* layer by layer: n entries of scratch */     \
            PERM_OMP_                                                                       \
            for (size_t i = 0; i < n; i++)                                                  \
                s_[i] = p->name[(size_t)order[i] * c_ + l_];                                \
            PERM_OMP_                                                                       \
            for (size_t i = 0; i < n; i++)                                                  \
                p->name[i * c_ + l_] = s_[i];                                               \
        }                                                                                   \
    }
    SPH_PARTICLE_FIELDS(PERM_)
#undef PERM_
}
#undef PERM_OMP_

void *sph_particles_field(const sph_particles *p, int k)
{
    switch (k) {
#define CASE_(name, ...) \
    case SPH_PF_##name:  \
        return p->name;
        SPH_PARTICLE_FIELDS(CASE_)
#undef CASE_
    default:
        return NULL;
    }
}

size_t sph_particles_field_count(const sph_particles *p, int k)
{
    return k >= 0 && k < SPH_PARTICLE_NFIELDS && sph_particle_fields[k].layered ? (size_t)p->nlayers
                                                                                   : 1;
}
