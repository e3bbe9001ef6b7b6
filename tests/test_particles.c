/* The particle field list (core/particles.h, SPH_PARTICLE_FIELDS): every
 * field of the list is allocated, permuted, copied and moved by removal,
 * entry by entry; the table agrees with the struct; the thermal forcing's
 * release. Restart files of every field: test_restart. */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "check.h"
#include "core/particles.h"

/* A distinct, finite value for (field, particle, layer), exactly
 * representable in every field's type once reduced below. */
static double value_of(int f, size_t k, size_t j, int salt)
{
    return (double)((f * 131 + (long)k * 7 + (long)j * 3 + salt * 17) % 251) + 1.0;
}

static void set_entry(sph_particles *P, int f, size_t k, size_t j, double val)
{
    size_t c = sph_particles_field_count(P, f), e = k * c + j;
    void *a = sph_particles_field(P, f);
    switch (sph_particle_fields[f].type) {
    case SPH_FIELD_DOUBLE: ((double *)a)[e] = val + 0.25; break;
    case SPH_FIELD_LONG: ((long *)a)[e] = (long)val * 1000003L; break;
    default: ((unsigned char *)a)[e] = (unsigned char)val; break;
    }
}

/* Bytes of particle k's entries of field f. */
static const unsigned char *entry(const sph_particles *P, int f, size_t k)
{
    const unsigned char *a = sph_particles_field(P, f);
    return a + k * sph_particles_field_count(P, f) * sph_particle_fields[f].size;
}

static void fill(sph_particles *P, int salt)
{
    for (int f = 0; f < SPH_PARTICLE_NFIELDS; f++)
        for (size_t k = 0; k < P->cap; k++)
            for (size_t j = 0; j < sph_particles_field_count(P, f); j++)
                set_entry(P, f, k, j, value_of(f, k, j, salt));
}

/* Particle k of P equals particle s of Q in every field (same layer count). */
static int same_particle(const sph_particles *P, size_t k, const sph_particles *Q, size_t s, int *which)
{
    for (int f = 0; f < SPH_PARTICLE_NFIELDS; f++) {
        size_t bytes = sph_particles_field_count(P, f) * sph_particle_fields[f].size;
        if (memcmp(entry(P, f, k), entry(Q, f, s), bytes)) {
            *which = f;
            return 0;
        }
    }
    return 1;
}

static void table(void)
{
    const char *want[] = {"x", "y", "u", "v", "mass", "thick", "conc", "sml", "enth", "id", "regime",
                          "lat", "ua", "va", "tair", "fsens", "flat", "coastc", "sml0", "dens0"};
    for (size_t w = 0; w < sizeof want / sizeof want[0]; w++) {
        int found = 0;
        for (int f = 0; f < SPH_PARTICLE_NFIELDS; f++)
            found += !strcmp(sph_particle_fields[f].name, want[w]);
        CHECK(found == 1, "field %s listed once (%d)", want[w], found);
    }
    sph_particles *P = sph_particles_create(4, 3);
    CHECK(P != NULL, "create");
    if (!P)
        return;
    int layered = 0, state_out = 0, names_dup = 0;
    for (int f = 0; f < SPH_PARTICLE_NFIELDS; f++) {
        const sph_particle_field *d = &sph_particle_fields[f];
        layered += d->layered;
        CHECK(sph_particles_field(P, f) != NULL, "field %s has an array", d->name);
        CHECK(sph_particles_field_count(P, f) == (d->layered ? 3u : 1u), "%s: entries", d->name);
        size_t want_size = d->type == SPH_FIELD_DOUBLE ? sizeof(double)
                           : d->type == SPH_FIELD_LONG ? sizeof(long) : 1;
        CHECK(d->size == want_size, "%s: %zu bytes per entry", d->name, d->size);
        /* the restart file carries the complete prognostic state */
        state_out += d->tag == SPH_FIELD_STATE && d->restart == SPH_RESTART_NO;
        for (int g = 0; g < f; g++) {
            names_dup += !strcmp(d->name, sph_particle_fields[g].name);
            CHECK(sph_particles_field(P, f) != sph_particles_field(P, g), "%s, %s: own arrays",
                  d->name, sph_particle_fields[g].name);
        }
    }
    CHECK(layered == 1 && sph_particle_fields[SPH_PF_enth].layered, "enth alone has layers");
    CHECK(state_out == 0, "every STATE field is in the restart file (%d are not)", state_out);
    CHECK(names_dup == 0, "names unique");
    CHECK(sph_particles_field(P, -1) == NULL && sph_particles_field(P, SPH_PARTICLE_NFIELDS) == NULL,
          "no field outside the list");
    CHECK((void *)P->enth == sph_particles_field(P, SPH_PF_enth) &&
              (void *)P->regime == sph_particles_field(P, SPH_PF_regime) &&
              (void *)P->id == sph_particles_field(P, SPH_PF_id),
          "field numbers name their members");

    /* created zeroed, prescribed fluxes NaN (compute from bulk formulae) */
    int nonzero = 0;
    for (int f = 0; f < SPH_PARTICLE_NFIELDS; f++) {
        if (f == SPH_PF_fsens || f == SPH_PF_flat)
            continue;
        const unsigned char *a = sph_particles_field(P, f);
        size_t bytes = P->cap * sph_particles_field_count(P, f) * sph_particle_fields[f].size;
        for (size_t b = 0; b < bytes; b++)
            nonzero += a[b] != 0;
    }
    CHECK(nonzero == 0, "created zeroed (%d bytes are not)", nonzero);
    CHECK(isnan(P->fsens[3]) && isnan(P->flat[0]), "prescribed fluxes NaN");
    sph_particles_free(P);
}

static void permute(void)
{
    enum { N = 37, NL = 4 };
    sph_particles *P = sph_particles_create(N, NL), *O = sph_particles_create(N, NL);
    CHECK(P && O, "create");
    if (!P || !O)
        goto done;
    P->n = O->n = N;
    fill(P, 1);
    fill(O, 1);
    int order[N], inverse[N];
    for (int i = 0; i < N; i++)
        order[i] = (i * 11 + 5) % N; /* 11 and 37 are coprime: a permutation */
    for (int i = 0; i < N; i++)
        inverse[order[i]] = i;
    double scratch[N * NL];
    sph_particles_permute(P, order, scratch);
    int bad = 0, which = -1;
    for (size_t i = 0; i < N; i++)
        bad += !same_particle(P, i, O, (size_t)order[i], &which);
    CHECK(bad == 0, "slot i holds old particle order[i] in every field (%d differ, e.g. %s)", bad,
          which >= 0 ? sph_particle_fields[which].name : "-");
    sph_particles_permute(P, inverse, scratch);
    bad = 0;
    for (size_t i = 0; i < N; i++)
        bad += !same_particle(P, i, O, i, &which);
    CHECK(bad == 0, "the inverse permutation restores every field (%d differ, e.g. %s)", bad,
          which >= 0 ? sph_particle_fields[which].name : "-");

    /* removal moves the last particle into the slot, every field */
    sph_particles_remove(P, 3);
    CHECK(P->n == N - 1, "removed");
    CHECK(same_particle(P, 3, O, N - 1, &which), "removal moved the last particle (%s differs)",
          sph_particle_fields[which].name);
    CHECK(same_particle(P, 2, O, 2, &which) && same_particle(P, 4, O, 4, &which),
          "removal left the others");
done:
    sph_particles_free(P);
    sph_particles_free(O);
}

static void copy_one(void)
{
    sph_particles *A = sph_particles_create(5, 3), *B = sph_particles_create(6, 3),
                  *B0 = sph_particles_create(6, 3), *C = sph_particles_create(6, 2);
    CHECK(A && B && B0 && C, "create");
    if (!A || !B || !B0 || !C)
        goto done;
    A->n = 5;
    B->n = B0->n = C->n = 6;
    fill(A, 1);
    fill(B, 2);
    fill(B0, 2);
    fill(C, 3);
    sph_particles_copy_one(B, 4, A, 2);
    int which = -1, others = 1;
    CHECK(same_particle(B, 4, A, 2, &which), "copy_one copies every field (%s differs)",
          which >= 0 ? sph_particle_fields[which].name : "-");
    for (size_t k = 0; k < 6; k++)
        others &= k == 4 || same_particle(B, k, B0, k, &which);
    CHECK(others, "copy_one leaves the other particles");
    /* fewer layers in the destination: the top ones */
    double next = C->enth[4];
    sph_particles_copy_one(C, 1, A, 0);
    CHECK(C->enth[2] == A->enth[0] && C->enth[3] == A->enth[1] && C->enth[4] == next,
          "copy to two layers: the top two, nothing beyond");
    CHECK(C->x[1] == A->x[0] && C->id[1] == A->id[0] && C->regime[1] == A->regime[0],
          "copy to two layers: the rest");
done:
    sph_particles_free(A);
    sph_particles_free(B);
    sph_particles_free(B0);
    sph_particles_free(C);
}

/* sph_particles_release_thermal_forcing: the nine thermal forcing fields
 * zero (fresh arrays), every other field of every particle as it was. */
static void release_thermal(void)
{
    sph_particles *P = sph_particles_create(9, 3), *P0 = sph_particles_create(9, 3);
    CHECK(P && P0, "create");
    if (!P || !P0)
        goto done;
    P->n = P0->n = 9;
    fill(P, 4);
    fill(P0, 4);
    double *before = P->tair;
    CHECK(sph_particles_release_thermal_forcing(P) == 0, "release: 0");
    static const char *thermal[] = {"tair", "qair", "swdn", "lwdn", "sst", "fw", "fsens", "flat",
                                    "snowfall"};
    int nz = 0, kept = 1, nthermal = 0;
    for (int f = 0; f < SPH_PARTICLE_NFIELDS; f++) {
        int th = 0;
        for (size_t t = 0; t < sizeof thermal / sizeof thermal[0]; t++)
            th |= !strcmp(sph_particle_fields[f].name, thermal[t]);
        nthermal += th;
        size_t bytes = P->cap * sph_particles_field_count(P, f) * sph_particle_fields[f].size;
        const unsigned char *a = sph_particles_field(P, f), *b = sph_particles_field(P0, f);
        if (th) {
            for (size_t i = 0; i < bytes; i++)
                nz += a[i] != 0;
        } else {
            kept &= !memcmp(a, b, bytes);
        }
    }
    CHECK(nthermal == 9, "the nine thermal forcing fields are in the list (%d)", nthermal);
    CHECK(nz == 0, "thermal forcing zero after the release (%d bytes not)", nz);
    CHECK(kept, "every other field unchanged");
    CHECK(P->tair != NULL && P->cap == 9, "fresh arrays of the same capacity");
    (void)before; /* freed: only its replacement is read */
    /* the set works as before: a removal and a copy move the zeros along */
    sph_particles_remove(P, 0); /* particle 8 into slot 0 */
    sph_particles_copy_one(P, 7, P, 0);
    CHECK(P->n == 8 && P->x[0] == P0->x[8] && P->x[7] == P0->x[8] && P->tair[0] == 0.0 &&
              P->flat[7] == 0.0 && P->u[1] == P0->u[1],
          "removal and copy after the release");
done:
    sph_particles_free(P);
    sph_particles_free(P0);
}

int main(void)
{
    table();
    permute();
    copy_one();
    release_thermal();
    return check_summary("test_particles");
}
