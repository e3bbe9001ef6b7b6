/* Restart files (io/restart.h): write, read, continue; the continued run
 * is bit for bit the uninterrupted one (the ocean-flux accumulators too). Then the same through the engine:
 * a forecast warm-started from the restart file an earlier forecast wrote
 * at the next cycle's time ends with the particles of the earlier
 * forecast, to the last bit. */
#include <math.h>
#include <netcdf.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "engine_case.h"
#include "core/model.h"
#include "core/ocean.h"
#include "io/products.h"
#include "io/restart.h"
#include "lattice.h"
#include "ocean_column.h"
#include "service/config.h"
#include "service/cycle.h"
#include "service/forecast.h"
#include "util/log.h"

static char dir[] = "/tmp/sphice-restart-XXXXXX";

#define NX 14
#define NY 10
#define DX 1000.0

/* A wall (land) north of the ice, wind towards it: packed ice, rheology,
 * ghosts, stress memory, thermodynamics every third step. */
static void setup_params(sph_params *p)
{
    sph_params_default(p);
    p->dt = 120.0;
    p->thermo_dt = 360.0;
    p->thermo.model = SPH_THERMO_AUTO;
    p->thermo.ocean_fluxes = 1; /* the accumulators continue too (docs/ocean-coupling.md) */
}

static unsigned char land[40 * 40];
static sph_landmask make_mask(void)
{
    sph_landmask m;
    m.nx = m.ny = 40;
    m.dx = m.dy = 500.0;
    m.x0 = -2000.0;
    m.y0 = -2000.0;
    for (int j = 0; j < 40; j++)
        for (int i = 0; i < 40; i++)
            land[j * 40 + i] = m.y0 + (j + 0.5) * m.dy > NY * DX + 1500.0;
    m.land = land;
    m.closed_outside = 0;
    return m;
}

static void set_forcing(sph_particles *P)
{
    lattice_set_forcing(P, 3.0, 12.0, 0.0, 0.0, 0.0, 0.0);
    for (size_t k = 0; k < P->n; k++) {
        P->lat[k] = 40.0;
        P->tair[k] = -12.0;
        P->qair[k] = 1.0e-3;
        P->swdn[k] = 50.0;
        P->lwdn[k] = 200.0;
        P->sst[k] = NAN;
        P->fw[k] = NAN;
        P->fsens[k] = P->flat[k] = NAN;
    }
}

static sph_model *fresh(const sph_params *p, const sph_landmask *mask)
{
    sph_model *m = sph_model_create(p, NX * NY, mask);
    if (!m)
        return NULL;
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, p, NX, NY, 0.0, 0.0, DX, 0.4, 0.95, 40.0);
    set_forcing(P);
    for (size_t k = 0; k < P->n; k++)
        sph_thermo_init_particle(&p->thermo, P, k, -12.0);
    sph_status st;
    if (sph_model_init(m, &st) != SPH_STEP_OK) {
        sph_model_free(m);
        return NULL;
    }
    return m;
}

static int steps(sph_model *m, int n)
{
    sph_status st;
    for (int s = 0; s < n; s++) {
        set_forcing(sph_model_particles(m));
        if (sph_model_step(m, &st) != SPH_STEP_OK) {
            fprintf(stderr, "step: %s %g %s\n", st.quantity, st.value, st.what);
            return -1;
        }
    }
    return 0;
}

#define SAME(field, count)                                                                    \
    do {                                                                                      \
        int same_ = memcmp(A->field, B->field, (count) * sizeof *A->field) == 0;              \
        CHECK(same_, "%s identical after the restart", #field);                               \
    } while (0)

/* The header of a restart file of model m valid at t (cycle 1000 s, plane "+proj=test"). */
static void test_header(restart_header *h, const sph_model *m, double t)
{
    memset(h, 0, sizeof *h);
    h->time = t;
    h->cycle_time = 1000.0;
    snprintf(h->projection, sizeof h->projection, "+proj=test");
    sph_model_get_clock(m, &h->clock);
}

static void module_level(void)
{
    sph_params p;
    setup_params(&p);
    sph_landmask mask = make_mask();
    const int total = 20, at = 8; /* 8 is not a multiple of the thermodynamic 3 steps */
    sph_model *a = fresh(&p, &mask), *b = fresh(&p, &mask);
    CHECK(a && b, "models");
    if (!a || !b)
        return;
    CHECK(steps(a, total) == 0, "uninterrupted run");
    CHECK(steps(b, at) == 0, "first part");
    const sph_step_stats *ss = sph_model_stats(a);
    CHECK(ss->frac_rheology > 0.5, "the case exercises the rheology (%.2f)", ss->frac_rheology);

    char path[1024];
    snprintf(path, sizeof path, "%s/restart.nc", dir);
    restart_header h;
    test_header(&h, b, 1000.0 + at * p.dt);
    sph_error err;
    sph_error_clear(&err);
    CHECK(restart_write(path, sph_model_particles(b), &h, &err) == SPH_OK, "write: %s", err.msg);
    size_t n_b = sph_model_particles(b)->n;
    sph_model_free(b);

    /* read back into a new model and continue */
    restart_header r;
    CHECK(restart_read_header(path, &r, &err) == SPH_OK, "header: %s", err.msg);
    CHECK(r.n == n_b && r.time == h.time && r.clock.steps == at, "header: %zu particles, steps %ld", r.n,
          r.clock.steps);
    sph_model *c = sph_model_create(&p, r.n, &mask);
    CHECK(c != NULL, "model for the restart");
    if (!c) {
        sph_model_free(a);
        return;
    }
    CHECK(restart_read(path, "+proj=test", &r, sph_model_particles(c), &err) == SPH_OK, "read: %s", err.msg);
    sph_status st;
    CHECK(sph_model_resume(c, &r.clock, &st) == SPH_STEP_OK, "resume: %s", st.what);
    CHECK(steps(c, total - at) == 0, "continued run");

    const sph_particles *A = sph_model_particles(a), *B = sph_model_particles(c);
    CHECK(A->n == B->n, "particles %zu vs %zu", A->n, B->n);
    if (A->n == B->n) {
        size_t n = A->n;
        SAME(x, n);
        SAME(y, n);
        SAME(u, n);
        SAME(v, n);
        SAME(mass, n);
        SAME(thick, n);
        SAME(conc, n);
        SAME(sml, n);
        SAME(dens, n);
        SAME(snow, n);
        SAME(tsurf, n);
        SAME(s11, n);
        SAME(s22, n);
        SAME(s12, n);
        SAME(id, n);
        SAME(enth, n * (size_t)A->nlayers);
        SAME(ofx_heat_ice, n);
        SAME(ofx_heat_lead, n);
        SAME(ofx_water, n);
        SAME(ofx_salt, n);
        SAME(ofx_taux, n);
        SAME(ofx_tauy, n);
        SAME(ofx_swbase, n);
        SAME(tsnow, n);
        double acc = 0.0;
        for (size_t k = 0; k < n; k++)
            acc += fabs(A->ofx_taux[k]) + fabs(A->ofx_water[k]) + fabs(A->ofx_heat_ice[k]);
        CHECK(acc > 0.0, "the ocean-flux accumulators hold something (%g)", acc);
    }
    const sph_budget *ba = sph_model_budget(a), *bc = sph_model_budget(c);
    CHECK(ba->mass == bc->mass && ba->growth == bc->growth && ba->new_ice == bc->new_ice,
          "budget identical after the restart");
    CHECK(sph_model_time(a) == sph_model_time(c) && sph_model_steps(a) == sph_model_steps(c), "clock");

    /* refusals: another plane, another layer count, not a restart file */
    sph_error_clear(&err);
    CHECK(restart_read(path, "+proj=other", &r, sph_model_particles(c), &err) == SPH_ERR_CONFIG &&
              strstr(err.msg, "restart.nc") && strstr(err.msg, "+proj=other"),
          "another projection: %s", err.msg);
    sph_params p2 = p;
    p2.thermo.nlayers = p.thermo.nlayers + 1;
    sph_model *d = sph_model_create(&p2, r.n, &mask);
    sph_error_clear(&err);
    CHECK(d && restart_read(path, NULL, &r, sph_model_particles(d), &err) == SPH_ERR_CONFIG &&
              strstr(err.msg, "layers"),
          "another layer count: %s", err.msg);
    sph_model_free(d);
    char other[1024];
    snprintf(other, sizeof other, "%s/ice.nc", dir);
    sph_error_clear(&err);
    CHECK(restart_read_header(other, &r, &err) == SPH_ERR_BAD_DATA && strstr(err.msg, "not an sphice restart"),
          "not a restart file: %s", err.msg);
    sph_error_clear(&err);
    snprintf(other, sizeof other, "%s/missing.nc", dir);
    CHECK(restart_read_header(other, &r, &err) == SPH_ERR_IO, "missing file: %s", err.msg);
    sph_model_free(a);
    sph_model_free(c);
}

/* ------------------------------------------------- the mixed layer */

/* The mixed layer under the ice of module_level's case and beside it: 5 x 5
 * cells of 4 km on the lattice of 1 km, every cell at its freezing point
 * under -12 C air, so the open water forms frazil, new particles
 * (threshold 2 mm; the eastern column later, from 0.05 K above freezing)
 * and merges thin ones. */
static const sph_ocean_grid ml_grid = {5, 5, -2000.0, -2000.0, 4000.0, 4000.0, 0.0, 0.0, DX};
#define ML_CAP 600

static void ml_forcing(sph_model *m)
{
    set_forcing(sph_model_particles(m));
    oc_fill_atm(m, -12.0, 1.0e-3, 3.0, 12.0, 50.0, 200.0, 40.0); /* set_forcing's, the cells too */
}

static int ml_steps(sph_model *m, int n)
{
    sph_status st;
    for (int s = 0; s < n; s++) {
        ml_forcing(m);
        if (sph_model_step(m, &st) != SPH_STEP_OK) {
            fprintf(stderr, "step: %s %g %s\n", st.quantity, st.value, st.what);
            return -1;
        }
    }
    return 0;
}

static sph_model *ml_fresh(const sph_params *p, const sph_landmask *mask)
{
    sph_model *m = sph_model_create(p, ML_CAP, mask);
    if (!m || sph_model_ocean_create(m, &ml_grid) != SPH_STEP_OK) {
        sph_model_free(m);
        return NULL;
    }
    /* the eastern column of cells starts 0.05 K above freezing: it freezes later */
    sph_ocean *o = sph_model_ocean(m);
    for (size_t c = 4; c < o->ncell; c += 5)
        sph_ocean_set_cell(o, c, o->depth[c], o->sal[c], o->temp[c] + 0.05);
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, p, NX, NY, 0.0, 0.0, DX, 0.4, 0.95, 40.0);
    for (size_t k = 0; k < P->n; k++)
        sph_thermo_init_particle(&p->thermo, P, k, -12.0);
    ml_forcing(m);
    sph_status st;
    if (sph_model_init(m, &st) != SPH_STEP_OK) {
        sph_model_free(m);
        return NULL;
    }
    return m;
}

/* 2N steps equal N steps, a restart file with the mixed layer, N steps, to
 * the bit (particles, the slab, its frazil and accumulators); a file
 * without the mixed layer leaves it alone; another grid is refused. */
static void mixed_layer_level(void)
{
    sph_params p;
    setup_params(&p);
    p.ocean.mixed_layer = 1;
    p.ocean.create = 1;
    p.ocean.merge = 1;
    p.ocean.new_thickness = 0.002;
    sph_landmask mask = make_mask();
    const int total = 80, at = 30;
    sph_model *a = ml_fresh(&p, &mask), *b = ml_fresh(&p, &mask);
    CHECK(a && b, "models with the mixed layer");
    if (!a || !b) {
        sph_model_free(a);
        sph_model_free(b);
        return;
    }
    CHECK(ml_steps(a, total) == 0, "uninterrupted run");
    CHECK(ml_steps(b, at) == 0, "first part");
    long created_at = sph_model_budget(b)->created_particles, created = sph_model_budget(a)->created_particles;
    printf("mixed layer restart: created %ld particles by step %d, %ld by %d; merged %ld; %zu particles\n",
           created_at, at, created, total, sph_model_budget(a)->merged_particles, sph_model_particles(a)->n);
    CHECK(created > created_at && created_at > 0, "new particles in both halves (%ld, %ld)", created_at,
          created - created_at);
    char path[1024], plain[1024];
    snprintf(path, sizeof path, "%s/restart_ml.nc", dir);
    snprintf(plain, sizeof plain, "%s/restart_plain.nc", dir);
    restart_header h;
    test_header(&h, b, 1000.0 + at * p.dt);
    sph_error err;
    sph_error_clear(&err);
    CHECK(restart_write_ocean(path, sph_model_particles(b), &h, sph_model_ocean(b), &err) == SPH_OK, "write: %s",
          err.msg);
    CHECK(restart_write(plain, sph_model_particles(b), &h, &err) == SPH_OK, "write without: %s", err.msg);
    double frazil_b = 0.0;
    for (size_t c = 0; c < sph_model_ocean(b)->ncell; c++)
        frazil_b += sph_model_ocean(b)->frazil[c];
    sph_model_free(b);

    restart_header r;
    sph_model *c = sph_model_create(&p, ML_CAP, &mask);
    int ok = c && sph_model_ocean_create(c, &ml_grid) == SPH_STEP_OK;
    CHECK(ok, "model for the restart");
    sph_status st;
    int found = -1;
    ok = ok && restart_read(path, "+proj=test", &r, sph_model_particles(c), &err) == SPH_OK &&
         restart_read_ocean(path, sph_model_ocean(c), &found, &err) == SPH_OK;
    CHECK(ok && found == 1, "read with the mixed layer: %s", err.msg);
    ok = ok && sph_model_resume(c, &r.clock, &st) == SPH_STEP_OK;
    CHECK(ok, "resume: %s", st.what);
    CHECK(ok && ml_steps(c, total - at) == 0, "continued run");
    const sph_particles *A = sph_model_particles(a), *B = sph_model_particles(c);
    CHECK(A->n == B->n, "particles %zu vs %zu", A->n, B->n);
    if (ok && A->n == B->n) {
        size_t n = A->n;
        SAME(x, n);
        SAME(y, n);
        SAME(u, n);
        SAME(mass, n);
        SAME(thick, n);
        SAME(conc, n);
        SAME(sml, n);
        SAME(tsurf, n);
        SAME(id, n);
        SAME(enth, n * (size_t)A->nlayers);
        SAME(ofx_water, n);
    }
    const sph_ocean *oa = sph_model_ocean(a), *oc = sph_model_ocean(c);
    const double *const arr[2][10] = {
        {oa->temp, oa->sal, oa->depth, oa->water, oa->salt, oa->frazil, oa->frazil_enth, oa->ofx_heat, oa->ofx_water,
         oa->ofx_salt},
        {oc->temp, oc->sal, oc->depth, oc->water, oc->salt, oc->frazil, oc->frazil_enth, oc->ofx_heat, oc->ofx_water,
         oc->ofx_salt}};
    static const char *const nm[10] = {"temp", "sal", "depth", "water", "salt", "frazil", "frazil_enth",
                                       "ofx_heat", "ofx_water", "ofx_salt"};
    for (int q = 0; q < 10; q++)
        CHECK(memcmp(arr[0][q], arr[1][q], oa->ncell * sizeof(double)) == 0, "mixed layer %s identical after "
              "the restart", nm[q]);
    CHECK(frazil_b > 0.0, "the restart file holds waiting frazil (%g kg)", frazil_b);

    /* a file without the mixed layer leaves it alone; another grid is refused */
    sph_ocean *o = sph_model_ocean(c);
    double t0 = o->temp[0];
    found = -1;
    CHECK(restart_read_ocean(plain, o, &found, &err) == SPH_OK && found == 0 && o->temp[0] == t0,
          "a file without the mixed layer: found %d", found);
    sph_ocean_grid g2 = ml_grid;
    g2.dx = g2.dy = 5000.0;
    g2.nx = g2.ny = 4;
    sph_model *d = sph_model_create(&p, ML_CAP, &mask);
    sph_error_clear(&err);
    int rc = d && sph_model_ocean_create(d, &g2) == SPH_STEP_OK ? restart_read_ocean(path, sph_model_ocean(d), &found, &err)
                                                                : -1;
    CHECK(rc == SPH_ERR_CONFIG && strstr(err.msg, "model.ocean.cell") && strstr(err.msg, "restart_ml.nc"),
          "another grid: %s", err.msg);
    sph_model_free(d);
    sph_model_free(a);
    sph_model_free(c);
}

/* ------------------------------------------------- every field of the list */

/* The variables of format sphice-restart-1, in file order (the baseline
 * demo's restart file): new fields may follow, these never move. */
static const char *const format1[] = {"x", "y", "u", "v", "mass", "thick", "conc", "sml", "sml0",
                                      "dens", "dens0", "snow", "tsurf", "s11", "s22", "s12",
                                      "coastc", "enth", "id", "regime"};
#define NFORMAT1 (sizeof format1 / sizeof format1[0])

/* A distinct value for (field, particle, layer) in the field's type. */
static void put_value(sph_particles *P, int f, size_t k, size_t j, int salt)
{
    size_t c = sph_particles_field_count(P, f), e = k * c + j;
    long w = (f * 131 + (long)k * 7 + (long)j * 3 + salt * 17) % 251 + 1;
    void *a = sph_particles_field(P, f);
    switch (sph_particle_fields[f].type) {
    case SPH_FIELD_DOUBLE: ((double *)a)[e] = (double)w / 3.0 - 40.0; break;
    case SPH_FIELD_LONG: ((long *)a)[e] = w * 100000000007L; break;
    default: ((unsigned char *)a)[e] = (unsigned char)w; break;
    }
}

static void fill_all(sph_particles *P, size_t n, int salt)
{
    for (int f = 0; f < SPH_PARTICLE_NFIELDS; f++)
        for (size_t k = 0; k < n; k++)
            for (size_t j = 0; j < sph_particles_field_count(P, f); j++)
                put_value(P, f, k, j, salt);
}

static int zeroed(const void *a, size_t bytes)
{
    const unsigned char *b = a;
    for (size_t i = 0; i < bytes; i++)
        if (b[i])
            return 0;
    return 1;
}

static void every_field(void)
{
    enum { N = 23, NL = 3 };
    sph_particles *W = sph_particles_create(N, NL), *R = sph_particles_create(N, NL),
                  *F = sph_particles_create(N, NL);
    CHECK(W && R && F, "particle sets");
    if (!W || !R || !F)
        goto done;
    W->n = N;
    fill_all(W, N, 1);
    fill_all(R, N, 2); /* what reading must replace, zero or leave alone */
    fill_all(F, N, 2);
    char path[1024];
    snprintf(path, sizeof path, "%s/fields.nc", dir);
    restart_header h;
    memset(&h, 0, sizeof h);
    h.time = 5000.0;
    h.cycle_time = 1000.0;
    snprintf(h.projection, sizeof h.projection, "+proj=test");
    sph_error err;
    sph_error_clear(&err);
    CHECK(restart_write(path, W, &h, &err) == SPH_OK, "write: %s", err.msg);

    /* the file's variables: format 1 first, in its order, then the rest of the list's */
    int nc, nvars = 0;
    if (nc_open(path, NC_NOWRITE, &nc) == NC_NOERR) {
        nc_inq_nvars(nc, &nvars);
        CHECK(nvars >= (int)NFORMAT1, "%d variables", nvars);
        for (int v = 0; v < nvars && v < (int)NFORMAT1; v++) {
            char name[NC_MAX_NAME + 1];
            nc_type t;
            nc_inq_var(nc, v, name, &t, NULL, NULL, NULL);
            nc_type want = !strcmp(name, "id") ? NC_INT64 : !strcmp(name, "regime") ? NC_UBYTE : NC_DOUBLE;
            CHECK(!strcmp(name, format1[v]) && t == want, "variable %d: %s (want %s)", v, name, format1[v]);
        }
        nc_close(nc);
    } else {
        CHECK(0, "open %s", path);
    }

    restart_header r;
    CHECK(restart_read(path, "+proj=test", &r, R, &err) == SPH_OK, "read: %s", err.msg);
    CHECK(R->n == N, "read %zu particles", R->n);
    int nwritten = 0;
    for (int f = 0; f < SPH_PARTICLE_NFIELDS; f++) {
        const sph_particle_field *d = &sph_particle_fields[f];
        size_t bytes = N * sph_particles_field_count(R, f) * d->size;
        const void *got = sph_particles_field(R, f);
        if (d->restart != SPH_RESTART_NO) {
            nwritten++;
            CHECK(!memcmp(got, sph_particles_field(W, f), bytes), "%s restored bit for bit", d->name);
        } else if (d->tag == SPH_FIELD_DIAGNOSTIC) {
            CHECK(zeroed(got, bytes), "diagnosed %s zeroed", d->name);
        } else {
            CHECK(!memcmp(got, sph_particles_field(F, f), bytes), "%s left alone", d->name);
        }
        if (d->tag == SPH_FIELD_STATE)
            CHECK(d->restart != SPH_RESTART_NO, "state field %s is in the restart file", d->name);
    }
    CHECK(nwritten == nvars, "one variable per restart field (%d, %d)", nwritten, nvars);

    /* a file written before coastc existed: it reads as zero */
    if (nc_open(path, NC_WRITE, &nc) == NC_NOERR) {
        int v;
        int ok = nc_redef(nc) == NC_NOERR && nc_inq_varid(nc, "coastc", &v) == NC_NOERR &&
                 nc_rename_var(nc, v, "coastc_later") == NC_NOERR;
        CHECK(nc_close(nc) == NC_NOERR && ok, "rename coastc");
        fill_all(R, N, 2);
        sph_error_clear(&err);
        CHECK(restart_read(path, NULL, &r, R, &err) == SPH_OK, "read without coastc: %s", err.msg);
        CHECK(zeroed(R->coastc, N * sizeof *R->coastc), "coastc absent: zero");
        CHECK(!memcmp(R->s12, W->s12, N * sizeof *R->s12), "the rest restored");
    }

    /* a field that is zero everywhere is left out of the file, which is
     * then the file written before the field existed, and reads back as
     * zero: a diagnostic optional one (an ocean-flux accumulator while
     * output.ocean_fluxes is off) and the snow temperature (state, class
     * NZ) without thermo.snow_heat_capacity; a nonzero one beside it is
     * written and restored */
    const int left_out[2][2] = {{SPH_PF_ofx_water, SPH_PF_ofx_salt}, {SPH_PF_tsnow, SPH_PF_coastc}};
    for (int i = 0; i < 2; i++) {
        int z = left_out[i][0], kept = left_out[i][1];
        const char *zn = sph_particle_fields[z].name, *kn = sph_particle_fields[kept].name;
        size_t bytes = N * sizeof(double);
        memset(sph_particles_field(W, z), 0, bytes);
        sph_error_clear(&err);
        CHECK(restart_write(path, W, &h, &err) == SPH_OK, "write: %s", err.msg);
        if (nc_open(path, NC_NOWRITE, &nc) == NC_NOERR) {
            int v;
            CHECK(nc_inq_varid(nc, zn, &v) != NC_NOERR && nc_inq_varid(nc, kn, &v) == NC_NOERR,
                  "an all-zero %s is left out, a nonzero %s written", zn, kn);
            nc_close(nc);
        }
        fill_all(R, N, 2);
        CHECK(restart_read(path, NULL, &r, R, &err) == SPH_OK, "read without %s: %s", zn, err.msg);
        CHECK(zeroed(sph_particles_field(R, z), bytes) &&
                  !memcmp(sph_particles_field(R, kept), sph_particles_field(W, kept), bytes),
              "%s absent: zero; %s restored", zn, kn);
    }
done:
    sph_particles_free(W);
    sph_particles_free(R);
    sph_particles_free(F);
}

/* ------------------------------------------------ malformed restart files */

/* Copies a good restart file to `out` and applies one change to it with
 * the NetCDF API (as another writer, or a damaged file, would have it). */
enum { MUT_TYPE, MUT_DIMS, MUT_MANY, MUT_NAN_CLOCK, MUT_NO_ATT, MUT_INF_BUDGET, MUT_NEG_COUNT,
       MUT_NLAYERS_2, MUT_TEXT_TIME, MUT_FLOAT_OK };

/* Rewrites the variables of src into dst (netCDF-4), with `what` changed. */
static int mutate(const char *src, const char *dst, int what)
{
    int in, out, st;
    if (nc_open(src, NC_NOWRITE, &in) != NC_NOERR)
        return -1;
    if (nc_create(dst, NC_NETCDF4 | NC_CLOBBER, &out) != NC_NOERR) {
        nc_close(in);
        return -1;
    }
    size_t np, nl;
    int dp, dl, dp_in, dl_in, dextra = -1;
    st = nc_inq_dimid(in, "particle", &dp_in) | nc_inq_dimlen(in, dp_in, &np) |
         nc_inq_dimid(in, "layer", &dl_in) | nc_inq_dimlen(in, dl_in, &nl);
    size_t np_out = what == MUT_MANY ? np + 5 : np;
    st |= nc_def_dim(out, "particle", np_out, &dp) | nc_def_dim(out, "layer", nl, &dl);
    if (what == MUT_DIMS)
        st |= nc_def_dim(out, "other", np, &dextra);
    int natts, nvars;
    st |= nc_inq_natts(in, &natts) | nc_inq_nvars(in, &nvars);
    for (int a = 0; a < natts; a++) {
        char name[NC_MAX_NAME + 1];
        st |= nc_inq_attname(in, NC_GLOBAL, a, name);
        if (what == MUT_NO_ATT && !strcmp(name, "budget_mass"))
            continue;
        if (what == MUT_NAN_CLOCK && !strcmp(name, "model_time_since_init")) {
            double nan = NAN;
            st |= nc_put_att_double(out, NC_GLOBAL, name, NC_DOUBLE, 1, &nan);
        } else if (what == MUT_INF_BUDGET && !strcmp(name, "budget_growth")) {
            double inf = INFINITY;
            st |= nc_put_att_double(out, NC_GLOBAL, name, NC_DOUBLE, 1, &inf);
        } else if (what == MUT_NEG_COUNT && !strcmp(name, "budget_removed_particles")) {
            long long m = -3;
            st |= nc_put_att_longlong(out, NC_GLOBAL, name, NC_INT64, 1, &m);
        } else if (what == MUT_NLAYERS_2 && !strcmp(name, "nlayers")) {
            int two[2] = {3, 3}; /* two values: the reader must not write two ints */
            st |= nc_put_att_int(out, NC_GLOBAL, name, NC_INT, 2, two);
        } else if (what == MUT_TEXT_TIME && !strcmp(name, "time")) {
            st |= nc_put_att_text(out, NC_GLOBAL, name, 4, "5000");
        } else if (what == MUT_MANY && !strcmp(name, "particles")) {
            long long m = (long long)np_out;
            st |= nc_put_att_longlong(out, NC_GLOBAL, name, NC_INT64, 1, &m);
        } else {
            st |= nc_copy_att(in, NC_GLOBAL, name, out, NC_GLOBAL);
        }
    }
    int vout[64];
    for (int v = 0; v < nvars && v < 64; v++) {
        char name[NC_MAX_NAME + 1];
        nc_type t;
        int nd, dims[2];
        st |= nc_inq_var(in, v, name, &t, &nd, NULL, NULL);
        int od[2] = {dp, dl};
        if (what == MUT_TYPE && !strcmp(name, "thick"))
            t = NC_INT; /* a thickness in whole metres: would truncate */
        if (what == MUT_FLOAT_OK && !strcmp(name, "thick"))
            t = NC_FLOAT;
        if (what == MUT_DIMS && !strcmp(name, "snow"))
            od[0] = dextra;
        (void)dims;
        st |= nc_def_var(out, name, t, nd, od, &vout[v]);
    }
    st |= nc_enddef(out);
    double *buf = calloc(np_out * nl + 1, sizeof(double));
    long long *ibuf = calloc(np_out * nl + 1, sizeof(long long));
    for (int v = 0; v < nvars && v < 64 && buf && ibuf; v++) {
        nc_type t;
        int nd;
        st |= nc_inq_vartype(in, v, &t) | nc_inq_varndims(in, v, &nd);
        size_t start[2] = {0, 0}, count[2] = {np, nl};
        if (t == NC_DOUBLE) {
            st |= nc_get_vara_double(in, v, start, count, buf);
            st |= nc_put_vara_double(out, vout[v], start, count, buf);
        } else {
            st |= nc_get_vara_longlong(in, v, start, count, ibuf);
            st |= nc_put_vara_longlong(out, vout[v], start, count, ibuf);
        }
    }
    free(buf);
    free(ibuf);
    st |= nc_close(out);
    nc_close(in);
    return st == NC_NOERR && buf && ibuf ? 0 : -1;
}

static void malformed(void)
{
    enum { N = 9, NL = 3 };
    sph_particles *W = sph_particles_create(N, NL), *R = sph_particles_create(N, NL),
                  *K = sph_particles_create(N, NL);
    CHECK(W && R && K, "particle sets");
    if (!W || !R || !K)
        goto done;
    W->n = N;
    fill_all(W, N, 1);
    for (size_t k = 0; k < N; k++)
        W->thick[k] = 0.25 + 0.5 * (double)k; /* exact in float: the float copy reads back equal */
    char good[1024], bad[1100];
    snprintf(good, sizeof good, "%s/good.nc", dir);
    snprintf(bad, sizeof bad, "%s/bad.nc", dir);
    restart_header h;
    memset(&h, 0, sizeof h);
    h.time = 5000.0;
    h.cycle_time = 1000.0;
    h.clock.time = 360.0;
    h.clock.budget.mass = 1.0e9;
    snprintf(h.projection, sizeof h.projection, "+proj=test");
    sph_error err;
    sph_error_clear(&err);
    CHECK(restart_write(good, W, &h, &err) == SPH_OK, "write: %s", err.msg);

    /* the copy itself is sound: it reads back (a float thickness converts) */
    restart_header r;
    CHECK(mutate(good, bad, MUT_FLOAT_OK) == 0, "float copy");
    sph_error_clear(&err);
    CHECK(restart_read(bad, "+proj=test", &r, R, &err) == SPH_OK && R->n == N &&
              !memcmp(R->thick, W->thick, N * sizeof *R->thick) && !memcmp(R->id, W->id, N * sizeof *R->id),
          "a restart copy with a float thickness reads: %s", err.msg);

    static const struct {
        int what;
        const char *name, *want1, *want2;
    } cases[] = {
        {MUT_TYPE, "a thickness of an integer type", "variable thick", "type"},
        {MUT_DIMS, "snow on another dimension", "variable snow", "dimensions"},
        {MUT_MANY, "more particles than the model's room", "particles", "room for 9"},
        {MUT_NAN_CLOCK, "a NaN clock", "attribute model_time_since_init", "not finite"},
        {MUT_NO_ATT, "a missing budget attribute", "attribute budget_mass", "missing"},
        {MUT_INF_BUDGET, "an infinite budget", "attribute budget_growth", "not finite"},
        {MUT_NEG_COUNT, "a negative count", "attribute budget_removed_particles", "0.."},
        {MUT_NLAYERS_2, "two nlayers values", "attribute nlayers", "one integer value"},
        {MUT_TEXT_TIME, "a time in text", "attribute time", "numeric"},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        CHECK(mutate(good, bad, cases[c].what) == 0, "copy for %s", cases[c].name);
        fill_all(K, N, 7);
        fill_all(R, N, 7);
        R->n = K->n = 5;
        sph_error_clear(&err);
        /* the engine reads the header, sizes the model, then the particles */
        int rc = restart_read_header(bad, &r, &err);
        if (rc == SPH_OK)
            rc = restart_read(bad, "+proj=test", &r, R, &err);
        int unchanged = R->n == K->n;
        for (int f = 0; f < SPH_PARTICLE_NFIELDS; f++)
            unchanged = unchanged && !memcmp(sph_particles_field(R, f), sph_particles_field(K, f),
                                             N * sph_particles_field_count(R, f) *
                                                 sph_particle_fields[f].size);
        CHECK(rc != SPH_OK && strstr(err.msg, "bad.nc") && strstr(err.msg, cases[c].want1) &&
                  strstr(err.msg, cases[c].want2) && !strchr(err.msg, '\n'),
              "%s refused in one line: %s", cases[c].name, err.msg);
        CHECK(unchanged, "%s: the particle set is left as it was", cases[c].name);
    }
done:
    sph_particles_free(W);
    sph_particles_free(R);
    sph_particles_free(K);
}

/* ------------------------------------------------------ through the engine */

static const char *atm_files[2];

static int forecast(const struct sph_config *cfg, const char *stage, double cycle, double hours,
                    const char *warm, forecast_result *res)
{
    forecast_request req;
    memset(&req, 0, sizeof req);
    req.cycle_time = cycle;
    req.hours = hours;
    req.stage_dir = stage;
    req.warm_start = warm;
    req.forcing_files[0] = atm_files;
    forecast_progress prog;
    memset((void *)&prog, 0, sizeof prog); /* cycle_set_phase reads it (valgrind) */
    sph_error err;
    sph_error_clear(&err);
    int rc = forecast_run(cfg, &req, &prog, NULL, res, &err);
    CHECK(rc == SPH_OK, "forecast %s: %s", stage, err.msg);
    return rc;
}

/* mixed: with the mixed layer and new ice (2 cm of frazil, reached after
 * the restart at +3 h: a layer started afresh there would not reach it by
 * +6 h). */
static void engine_level(int mixed)
{
    char text[8192];
    ec_config_more(text, sizeof text, dir, 300, "[\"wind\", \"tair\"]", "ice.nc", "",
                   mixed ? ", \"summation_density\": true, \"ocean\": {\"mixed_layer\": true}, \"new_ice\": {\"create\": true, "
                           "\"thickness\": 0.02}"
                         : "",
                   "");
    char *e = strstr(text, "\"every_hours\": 6");
    CHECK(e != NULL, "config text");
    if (!e)
        return;
    e[15] = '3'; /* cycles every 3 h: the restart is written at +3 h */
    struct sph_config *cfg = NULL;
    sph_error err;
    sph_error_clear(&err);
    CHECK(sph_config_parse(text, "test", &cfg, &err) == SPH_OK, "config: %s", err.msg);
    if (!cfg)
        return;
    char atm[1024], s1[1024], s2[1024], rs[1200], p1[1200], p2[1200];
    snprintf(atm, sizeof atm, "%s/atm.nc", dir);
    atm_files[0] = atm;
    snprintf(s1, sizeof s1, "%s/long%s", dir, mixed ? "-ml" : "");
    snprintf(s2, sizeof s2, "%s/continued%s", dir, mixed ? "-ml" : "");
    forecast_result r1, r2;
    if (forecast(cfg, s1, EC_CYCLE, 6, NULL, &r1) == SPH_OK) {
        char rname[64];
        cycle_restart_name(EC_CYCLE + 3 * 3600.0, rname, sizeof rname);
        snprintf(rs, sizeof rs, "%s/%s", s1, rname);
        CHECK(access(rs, R_OK) == 0, "restart at +3 h: %s", rs);
        if (forecast(cfg, s2, EC_CYCLE + 3 * 3600.0, 3, rs, &r2) == SPH_OK) {
            snprintf(p1, sizeof p1, "%s/sphice_particles.nc", s1);
            snprintf(p2, sizeof p2, "%s/sphice_particles.nc", s2);
            prod_particles a, b;
            double t = EC_CYCLE + 6 * 3600.0;
            int ra = products_read_particles(p1, t, &a, &err), rb = products_read_particles(p2, t, &b, &err);
            CHECK(ra == SPH_OK && rb == SPH_OK, "particles: %s", err.msg);
            if (ra == SPH_OK && rb == SPH_OK) {
                CHECK(a.n == b.n && a.n > 400, "particles at +6 h: %zu vs %zu", a.n, b.n);
                int same = a.n == b.n && !memcmp(a.lon, b.lon, a.n * sizeof *a.lon) &&
                           !memcmp(a.lat, b.lat, a.n * sizeof *a.lat) && !memcmp(a.id, b.id, a.n * sizeof *a.id);
                CHECK(same, "warm-started forecast ends on the uninterrupted one's positions, bit for bit");
                same = a.n == b.n && !memcmp(a.mass, b.mass, a.n * sizeof *a.mass) &&
                       !memcmp(a.thick, b.thick, a.n * sizeof *a.thick);
                CHECK(same, "and on its masses and thicknesses%s", mixed ? " (mixed layer, new ice)" : "");
                if (mixed) {
                    prod_particles c3;
                    int r3 = products_read_particles(p1, EC_CYCLE + 3 * 3600.0, &c3, &err);
                    printf("engine, mixed layer: %zu particles at +3 h, %zu at +6 h\n", r3 ? 0 : c3.n, a.n);
                    CHECK(r3 == SPH_OK && a.n > c3.n, "new particles after the restart: %zu at +3 h, %zu at +6 h",
                          r3 ? 0 : c3.n, a.n);
                    if (r3 == SPH_OK)
                        prod_particles_free(&c3);
                }
                CHECK(r2.run.budget_residual < 1e-10, "residual %g", r2.run.budget_residual);
            }
            prod_particles_free(&a);
            prod_particles_free(&b);
        }
    }
    sph_config_free(cfg);
}

/* A restart with no particle (an open-water start before its first ice) keeps one slot of the particle
 * dimension: that slot must hold the fill value, not whatever the particle arrays held (two runs of the
 * freeze-up scene wrote different restart bytes at 24 h before). Written twice with different stale values
 * in the arrays: x reads back NC_FILL_DOUBLE both times, and the file reads back with no particle. */
static void empty_restart(void)
{
    sph_params p;
    setup_params(&p);
    sph_landmask mask = make_mask();
    sph_model *m = fresh(&p, &mask);
    CHECK(m != NULL, "model");
    if (!m)
        return;
    sph_particles *P = sph_model_particles(m);
    for (int w = 0; w < 2; w++) {
        P->n = 1;
        P->x[0] = w ? 4.6e-310 : 12345.0; /* stale memory of a slot no particle uses */
        P->n = 0;
        char path[1024];
        snprintf(path, sizeof path, "%s/restart_empty%d.nc", dir, w);
        restart_header h;
        test_header(&h, m, 1000.0);
        sph_error err;
        sph_error_clear(&err);
        CHECK(restart_write(path, P, &h, &err) == SPH_OK, "empty: write: %s", err.msg);
        int nc, v;
        double x = 0.0;
        int ok = nc_open(path, NC_NOWRITE, &nc) == NC_NOERR;
        ok = ok && nc_inq_varid(nc, "x", &v) == NC_NOERR && nc_get_var_double(nc, v, &x) == NC_NOERR;
        if (ok)
            nc_close(nc);
        CHECK(ok && x == NC_FILL_DOUBLE, "empty: the one slot holds the fill value (%g)", x);
        restart_header r;
        CHECK(restart_read_header(path, &r, &err) == SPH_OK && r.n == 0, "empty: reads back with no particle: %s",
              err.msg);
    }
    sph_model_free(m);
}

int main(int argc, char **argv)
{
    (void)argc;
    ec_passive_openmp(argv);
    sph_log_level = LOG_LVL_WARN;
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    ec_write_inputs(dir);
    module_level();
    mixed_layer_level();
    every_field();
    malformed();
    engine_level(0);
    engine_level(1);
    empty_restart();
    if (check_failed_ == 0)
        cycle_remove_tree(dir);
    return check_summary("test_restart");
}
