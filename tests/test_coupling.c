/* The coupling of forcing to particles (service/coupling.h): a uniform
 * field sampled onto particles gives its value at every particle; east/
 * north vectors are rotated into the model plane's x/y as the projection
 * rotates them; currents add up over sources; the defaults of quantities
 * no source provides follow their published formulas (core/atmos.h). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <omp.h>

#include "check.h"
#include "core/atmos.h"
#include "core/particles.h"
#include "service/config.h"
#include "service/coupling.h"
#include "test_forcing_nc.h"

#define T0 918453600.0 /* 1999-02-08T06:00:00Z */
#define WIND_E 5.0
#define WIND_N 3.0
#define TAIR_K 263.15 /* -10 deg C */
#define CUR1_E 0.25
#define CUR2_E 0.125

static double field_fn(int which, double lon, double lat, size_t k)
{
    switch (which) { /* 10-12: varying in space and time (the particles' cells matter) */
    case 10: return WIND_E + 0.3 * (lon - 120.0) + 0.1 * (lat - 40.0) * (lat - 40.0) + 0.5 * (double)k;
    case 11: return WIND_N - 0.2 * (lat - 40.0) + 0.05 * (lon - 120.0) * (lat - 40.0) - 0.25 * (double)k;
    case 12: return TAIR_K + 0.5 * (lon - 120.0) - 0.3 * (lat - 40.0) + 1.5 * (double)k;
    default: break;
    }
    switch (which) {
    case 0: return WIND_E;
    case 1: return WIND_N;
    case 2: return TAIR_K;
    case 3: return CUR1_E;
    case 4: return CUR2_E;
    default: return 0.0;
    }
}

/* 1 deg over 100-140 E, 30-50 N, hourly from T0 - 3 h. */
static void write_file(const char *path, const tvar *v, size_t nv)
{
    tgrid g = {.nx = 41, .ny = 21, .lon0 = 100.0, .dlon = 1.0, .lat0 = 30.0, .dlat = 1.0,
               .time_units = "hours since 1999-02-08 00:00:00", .calendar = "standard", .tv0 = 3.0,
               .dtv = 1.0};
    tnc_write(path, &g, v, nv, 0, 12, NC_NETCDF4);
}

static struct sph_config *load(const char *dir, const char *sources)
{
    char text[4096];
    snprintf(text, sizeof text,
             "{ \"domain\": {\"name\": \"wide\", \"lon_min\": 110.0, \"lon_max\": 130.0,"
             " \"lat_min\": 35.0, \"lat_max\": 45.0},\n"
             "  \"forcing\": [%s],\n"
             "  \"initial\": {\"path\": \"%s/none.nc\"},\n"
             "  \"paths\": {\"state_dir\": \"%s/state\", \"cache_dir\": \"%s/cache\"},\n"
             "  \"output\": {\"dir\": \"%s/out\"},\n  \"status\": {\"enabled\": false} }\n",
             sources, dir, dir, dir, dir);
    struct sph_config *cfg = NULL;
    sph_error e;
    sph_error_clear(&e);
    int rc = sph_config_parse(text, "test_coupling", &cfg, &e);
    CHECK(rc == 0 && cfg, "config: %s", e.msg);
    return rc ? NULL : cfg;
}

/* Particles on a lon/lat lattice over the domain, at plane x/y. */
#define NI 9
#define NJ 5
#define NP (NI * NJ)
static sph_particles *lattice(const geo_proj *proj, double *lon, double *lat)
{
    sph_particles *P = sph_particles_create(NP, 1);
    for (int j = 0; j < NJ; j++)
        for (int i = 0; i < NI; i++) {
            lon[j * NI + i] = 110.5 + i * 19.0 / (NI - 1);
            lat[j * NI + i] = 35.5 + j * 9.0 / (NJ - 1);
        }
    sph_error e;
    sph_error_clear(&e);
    CHECK(geo_forward(proj, NP, lon, lat, P->x, P->y, &e) == 0, "forward: %s", e.msg);
    P->n = NP;
    for (size_t k = 0; k < NP; k++)
        P->id[k] = (long)k;
    return P;
}

/* Opens the coupling of the sources (JSON array members) over files
 * dir/<name[s]>, with work arrays for the lattice's particles (*P); cfg
 * and the file names live in *cs. */
typedef struct coupling_case {
    struct sph_config *cfg;
    fc_coupling c;
    sph_particles *P;
    double lon[NP], lat[NP];
    sph_error e;
    char path[2][1024];
    const char *files[2][2];
    forecast_request req;
} coupling_case;

static struct sph_config *open_case(coupling_case *cs, const char *dir, const char *sources,
                                    const char *const *names, size_t nsrc, const geo_proj *proj)
{
    memset(cs, 0, sizeof *cs);
    sph_error_clear(&cs->e);
    cs->cfg = load(dir, sources);
    if (!cs->cfg)
        return NULL;
    cs->req.cycle_time = T0;
    for (size_t s = 0; s < nsrc; s++) {
        snprintf(cs->path[s], sizeof cs->path[s], "%s/%s", dir, names[s]);
        cs->files[s][0] = cs->path[s];
        cs->req.forcing_files[s] = cs->files[s];
    }
    int rc = coupling_open(&cs->c, cs->cfg, &cs->req, T0, T0 + 6 * 3600.0, "test", &cs->e);
    cs->P = lattice(proj, cs->lon, cs->lat);
    CHECK(coupling_alloc(&cs->c, NP, &cs->e) == 0, "alloc");
    CHECK(rc == 0 && cs->c.nforc == nsrc, "open %zu source(s): %s", nsrc, cs->e.msg);
    if (rc == 0)
        return cs->cfg;
    coupling_free(&cs->c);
    sph_particles_free(cs->P);
    sph_config_free(cs->cfg);
    return NULL;
}

/* Published values (not the code under test): saturation vapour pressure
 * over water at -10 deg C, 286.5 Pa (WMO, Guide to Instruments, annex 4.B:
 * 2.865 hPa); clear-sky and overcast emissivities of Koenig-Langlo and
 * Augstein (1994), 0.765 and 0.985. */
static void check_atmos(void)
{
    const double p = 101325.0, T = -10.0;
    double q = sph_atmos_qair_rh(T, 1.0, p);
    double e = q * p / (0.622 + 0.378 * q); /* vapour pressure back from q */
    CHECK_CLOSE(e, 286.5, 3e-3, 0, "saturation vapour pressure at -10 C");
    CHECK_CLOSE(sph_atmos_qair_rh(T, 0.9, p) / q, 0.9, 2e-3, 0, "RH 0.9 is nine tenths of saturation");
    double sb = 5.670374419e-8 * pow(273.15 + T, 4);
    CHECK_CLOSE(sph_atmos_lwdn_cloud(T, 0.0), 0.765 * sb, 1e-12, 0, "clear sky");
    CHECK_CLOSE(sph_atmos_lwdn_cloud(T, 1.0), 0.985 * sb, 1e-12, 0, "overcast");
    CHECK_CLOSE(sph_atmos_lwdn_cloud(T, 0.5), (0.765 + 0.22 / 8) * sb, 1e-12, 0, "half cloud");
    CHECK(sph_atmos_lwdn_cloud(T + 10, 0.5) > sph_atmos_lwdn_cloud(T, 0.5), "warmer air, more longwave");
}

static void check_uniform(const char *dir, const geo_proj *proj)
{
    char src[1024];
    snprintf(src, sizeof src,
             "{\"name\": \"atm\", \"kind\": \"atmosphere\", \"urls\": \"%s/atm.nc\"}", dir);
    const char *names[] = {"atm.nc"};
    coupling_case cs;
    struct sph_config *cfg = open_case(&cs, dir, src, names, 1, proj);
    if (!cfg)
        return;
    int rc = coupling_fill(&cs.c, proj, &cfg->model.thermo, 1, cs.P, T0 + 1800.0, &cs.e);
    CHECK(rc == 0, "fill: %s", cs.e.msg);
    CHECK(cs.c.provided == (FQ_WIND | FQ_TAIR), "provided 0x%x", cs.c.provided);
    double ue[NP], vn[NP], ux[NP], uy[NP];
    for (size_t k = 0; k < NP; k++)
        ue[k] = WIND_E, vn[k] = WIND_N;
    CHECK(geo_rotate_to_plane(proj, NP, cs.lon, cs.lat, ue, vn, ux, uy, &cs.e) == 0, "rotate: %s", cs.e.msg);
    double max_angle = 0;
    const double pa = cfg->model.thermo.air_pressure;
    for (size_t k = 0; k < NP && rc == 0; k++) {
        CHECK_CLOSE(cs.lat[k], cs.P->lat[k], 0, 1e-9, "latitude back from the plane");
        CHECK_CLOSE(cs.P->tair[k], TAIR_K - 273.15, 0, 1e-4, "uniform air temperature");
        CHECK_CLOSE(hypot(cs.P->ua[k], cs.P->va[k]), hypot(WIND_E, WIND_N), 1e-6, 0, "wind speed kept");
        CHECK_CLOSE(cs.P->ua[k], ux[k], 0, 1e-6, "wind x as the projection rotates it");
        CHECK_CLOSE(cs.P->va[k], uy[k], 0, 1e-6, "wind y as the projection rotates it");
        /* the grid angle is that of the parallel on the plane: an eastward
         * step of 1e-4 deg, projected */
        double l2[2] = {cs.lon[k], cs.lon[k] + 1e-4}, p2[2] = {cs.lat[k], cs.lat[k]}, x2[2], y2[2];
        geo_forward(proj, 2, l2, p2, x2, y2, &cs.e);
        double alpha = -atan2(y2[1] - y2[0], x2[1] - x2[0]);
        CHECK_CLOSE(cs.c.angle[k], alpha, 0, 1e-5, "grid angle = direction of the parallel");
        double ca = cos(alpha), sa = sin(alpha);
        CHECK_CLOSE(cs.P->ua[k], WIND_E * ca + WIND_N * sa, 0, 1e-4, "wind x from the parallel's direction");
        CHECK_CLOSE(cs.P->va[k], -WIND_E * sa + WIND_N * ca, 0, 1e-4, "wind y from the parallel's direction");
        if (fabs(alpha) > max_angle)
            max_angle = fabs(alpha);
        /* defaults: no current, slope, shortwave; humidity at RH 0.9, longwave at cloud 0.5 */
        CHECK(cs.P->uw[k] == 0 && cs.P->vw[k] == 0 && cs.P->sshx[k] == 0 && cs.P->sshy[k] == 0 && cs.P->swdn[k] == 0,
              "no current, slope or shortwave at particle %zu", k);
        CHECK(isnan(cs.P->sst[k]) && isnan(cs.P->fw[k]) && isnan(cs.P->fsens[k]) && isnan(cs.P->flat[k]),
              "sst, fw, fsens, flat left to the thermodynamics");
        CHECK(cs.P->qair[k] == sph_atmos_qair_rh(cs.P->tair[k], SPH_ATMOS_DEFAULT_RH, pa), "humidity default");
        CHECK(cs.P->lwdn[k] == sph_atmos_lwdn_cloud(cs.P->tair[k], SPH_ATMOS_DEFAULT_CLOUD), "longwave default");
        CHECK(cs.c.ids_before[k] == cs.P->id[k] && isfinite(cs.c.lon[k]), "positions kept for messages");
    }
    CHECK(max_angle > 0.05, "the lattice reaches rotated parts of the plane (%.3f rad)", max_angle);
    CHECK(cs.c.n_before == NP, "n_before %zu", cs.c.n_before);
    coupling_free(&cs.c);
    sph_particles_free(cs.P);
    sph_config_free(cfg);
}

static void check_sum_and_missing(const char *dir, const geo_proj *proj)
{
    char src[2048];
    snprintf(src, sizeof src,
             "{\"name\": \"oc1\", \"kind\": \"ocean\", \"urls\": \"%s/oc1.nc\"},"
             "{\"name\": \"oc2\", \"kind\": \"ocean\", \"urls\": \"%s/oc2.nc\"}", dir, dir);
    const char *names[] = {"oc1.nc", "oc2.nc"};
    coupling_case cs;
    struct sph_config *cfg = open_case(&cs, dir, src, names, 2, proj);
    if (!cfg)
        return;
    int rc = coupling_fill(&cs.c, proj, &cfg->model.thermo, 0, cs.P, T0, &cs.e);
    CHECK(rc == 0, "fill without thermodynamics: %s", cs.e.msg);
    const double tf = sph_freezing_point(&cfg->model.thermo);
    for (size_t k = 0; k < NP && rc == 0; k++) {
        CHECK_CLOSE(hypot(cs.P->uw[k], cs.P->vw[k]), CUR1_E + CUR2_E, 1e-6, 0, "currents add up over sources");
        CHECK_CLOSE(cs.P->uw[k], (CUR1_E + CUR2_E) * cos(cs.c.angle[k]), 0, 1e-9, "current x");
        CHECK_CLOSE(cs.P->vw[k], -(CUR1_E + CUR2_E) * sin(cs.c.angle[k]), 0, 1e-9, "current y");
        CHECK(cs.P->ua[k] == 0 && cs.P->va[k] == 0, "no wind where no source gives it");
        CHECK(cs.P->tair[k] == tf, "air temperature defaults to the freezing point");
    }
    sph_error_clear(&cs.e);
    rc = coupling_fill(&cs.c, proj, &cfg->model.thermo, 1, cs.P, T0, &cs.e);
    CHECK(rc == SPH_ERR_MISSING_VAR && strstr(cs.e.msg, "air_temperature"),
          "thermodynamics without air temperature: %d %s", rc, cs.e.msg);
    coupling_free(&cs.c);
    sph_particles_free(cs.P);
    sph_config_free(cfg);
}


/* Ids and positions of NB particles on a finer lattice (more than the
 * coupling's threading threshold), shifted by (dx, dy) metres on the plane. */
#define NB 4800
static sph_particles *big_lattice(const geo_proj *proj, double dx, double dy)
{
    sph_particles *P = sph_particles_create(NB, 1);
    double *lon = malloc(NB * sizeof *lon), *lat = malloc(NB * sizeof *lat);
    for (int k = 0; k < NB; k++) {
        lon[k] = 112.0 + (k % 80) * 0.2;
        lat[k] = 36.0 + (k / 80) * 0.13;
    }
    sph_error e;
    sph_error_clear(&e);
    CHECK(geo_forward(proj, NB, lon, lat, P->x, P->y, &e) == 0, "forward: %s", e.msg);
    for (int k = 0; k < NB; k++) {
        P->x[k] += dx * (k % 3);
        P->y[k] += dy * (k % 2);
        P->id[k] = k;
    }
    P->n = NB;
    free(lon);
    free(lat);
    return P;
}

/* A coupling of the varying atmosphere (var.nc) for NB particles, sampled
 * in chunks of `chunk` particles (0: the default, more than NB). */
static int open_big_chunk(coupling_case *cs, const char *dir, const geo_proj *proj, size_t chunk);
static int open_big(coupling_case *cs, const char *dir, const geo_proj *proj)
{
    return open_big_chunk(cs, dir, proj, 0);
}
static int open_big_chunk(coupling_case *cs, const char *dir, const geo_proj *proj, size_t chunk)
{
    char src[1024];
    snprintf(src, sizeof src, "{\"name\": \"atm\", \"kind\": \"atmosphere\", \"urls\": \"%s/var.nc\"}", dir);
    memset(cs, 0, sizeof *cs);
    sph_error_clear(&cs->e);
    if (!(cs->cfg = load(dir, src)))
        return -1;
    cs->req.cycle_time = T0;
    snprintf(cs->path[0], sizeof cs->path[0], "%s/var.nc", dir);
    cs->files[0][0] = cs->path[0];
    cs->req.forcing_files[0] = cs->files[0];
    cs->P = big_lattice(proj, 0.0, 0.0);
    int rc = coupling_open(&cs->c, cs->cfg, &cs->req, T0, T0 + 6 * 3600.0, "test", &cs->e);
    cs->c.chunk = chunk;
    return rc ? rc : coupling_alloc(&cs->c, NB, &cs->e);
}

static void close_case(coupling_case *cs)
{
    coupling_free(&cs->c);
    sph_particles_free(cs->P);
    sph_config_free(cs->cfg);
}

static int same(const double *a, const double *b, size_t n)
{
    return memcmp(a, b, n * sizeof *a) == 0;
}

/* Bit for bit: a fill after the particles moved (the stencils start from
 * each point's previous cell) equals a fill of a fresh coupling at the new
 * positions; 2 threads equal 1; with dynamics_only the wind is the full
 * fill's and the thermal forcing stays that of the first fill (the field
 * changes in time, so a full fill changes it), the thermal work arrays gone. */
static void check_moved_threads_dynamics(const char *dir, const geo_proj *proj)
{
    const double t1 = T0 + 2700.0, DX = 37e3, DY = 23e3;
    coupling_case a, b, c;
    if (open_big(&a, dir, proj) || open_big(&b, dir, proj) || open_big(&c, dir, proj)) {
        CHECK(0, "open the varying atmosphere: %s %s %s", a.e.msg, b.e.msg, c.e.msg);
        return;
    }
    const sph_thermo_params *th = &a.cfg->model.thermo;
    omp_set_num_threads(1);
    CHECK(coupling_fill(&a.c, proj, th, 0, a.P, T0, &a.e) == 0, "fill a at T0: %s", a.e.msg);
    double *tair0 = malloc(NB * sizeof *tair0);
    memcpy(tair0, a.P->tair, NB * sizeof *tair0);
    sph_particles *moved = big_lattice(proj, DX, DY);
    memcpy(a.P->x, moved->x, NB * sizeof(double));
    memcpy(a.P->y, moved->y, NB * sizeof(double));
    CHECK(coupling_fill(&a.c, proj, th, 0, a.P, t1, &a.e) == 0, "fill a at t1: %s", a.e.msg);
    /* c: fresh, at the moved positions, on 2 threads */
    memcpy(c.P->x, moved->x, NB * sizeof(double));
    memcpy(c.P->y, moved->y, NB * sizeof(double));
    omp_set_num_threads(2);
    CHECK(coupling_fill(&c.c, proj, th, 0, c.P, t1, &c.e) == 0, "fill c at t1: %s", c.e.msg);
    CHECK(same(a.P->ua, c.P->ua, NB) && same(a.P->va, c.P->va, NB) && same(a.P->tair, c.P->tair, NB) &&
              same(a.P->lat, c.P->lat, NB),
          "moved particles (1 thread, previous cells) = fresh coupling (2 threads), bit for bit");
    size_t nmoved = 0;
    for (size_t k = 0; k < NB; k++)
        nmoved += fabs(a.P->tair[k] - tair0[k]) > 0.1;
    CHECK(nmoved == NB, "the air temperature changed at every particle (%zu of %d)", nmoved, NB);
    /* b: dynamics only after the first fill */
    CHECK(coupling_fill(&b.c, proj, th, 0, b.P, T0, &b.e) == 0, "fill b at T0: %s", b.e.msg);
    CHECK(same(b.P->tair, tair0, NB), "first fills agree");
    coupling_set_dynamics_only(&b.c);
    memcpy(b.P->x, moved->x, NB * sizeof(double));
    memcpy(b.P->y, moved->y, NB * sizeof(double));
    CHECK(coupling_fill(&b.c, proj, th, 0, b.P, t1, &b.e) == 0, "fill b at t1: %s", b.e.msg);
    CHECK(same(a.P->ua, b.P->ua, NB) && same(a.P->va, b.P->va, NB) && same(a.P->uw, b.P->uw, NB) &&
              same(a.P->sshx, b.P->sshx, NB) && same(a.P->lat, b.P->lat, NB),
          "dynamics only: the dynamics' forcing of a full fill, bit for bit");
    CHECK(same(b.P->tair, tair0, NB), "dynamics only: the air temperature of the first fill kept");
    CHECK(b.c.tair == NULL && b.c.q[CPL_Q_TAIR] == NULL && b.c.ue != NULL, "thermal work arrays freed");
    CHECK(b.c.provided & FQ_TAIR, "provided still names the air temperature of the last full fill");
    omp_set_num_threads(1);
    free(tair0);
    sph_particles_free(moved);
    close_case(&a);
    close_case(&b);
    close_case(&c);
}

/* Bit for bit: a fill in chunks of 7 and of 1000 particles (the forcing's
 * stencils and the samples one chunk at a time, the cell hints per particle)
 * equals the fill in one chunk, at the first fill, after the particles moved
 * and with dynamics only, on 1 and 2 threads; the work arrays hold a chunk. */
static void check_chunks(const char *dir, const geo_proj *proj)
{
    const double t1 = T0 + 2700.0, DX = 37e3, DY = 23e3;
    const size_t chunks[3] = {0, 7, 1000};
    coupling_case cs[3];
    for (int i = 0; i < 3; i++)
        if (open_big_chunk(&cs[i], dir, proj, chunks[i])) {
            CHECK(0, "open the varying atmosphere (chunk %zu): %s", chunks[i], cs[i].e.msg);
            return;
        }
    CHECK(cs[0].c.wcap == NB && cs[1].c.wcap == 7 && cs[2].c.wcap == 1000, "work arrays of one chunk: %zu %zu %zu",
          cs[0].c.wcap, cs[1].c.wcap, cs[2].c.wcap);
    const sph_thermo_params *th = &cs[0].cfg->model.thermo;
    sph_particles *moved = big_lattice(proj, DX, DY);
    for (int pass = 0; pass < 3; pass++) {
        for (int i = 0; i < 3; i++) {
            omp_set_num_threads(i == 1 ? 2 : 1);
            if (pass == 1) {
                memcpy(cs[i].P->x, moved->x, NB * sizeof(double));
                memcpy(cs[i].P->y, moved->y, NB * sizeof(double));
            }
            if (pass == 2)
                coupling_set_dynamics_only(&cs[i].c);
            double t = pass ? t1 : T0;
            CHECK(coupling_fill(&cs[i].c, proj, th, 0, cs[i].P, t, &cs[i].e) == 0, "fill %d chunk %zu: %s",
                  pass, chunks[i], cs[i].e.msg);
        }
        for (int i = 1; i < 3; i++) {
            const sph_particles *a = cs[0].P, *b = cs[i].P;
            CHECK(same(a->ua, b->ua, NB) && same(a->va, b->va, NB) && same(a->uw, b->uw, NB) &&
                      same(a->vw, b->vw, NB) && same(a->sshx, b->sshx, NB) && same(a->sshy, b->sshy, NB) &&
                      same(a->lat, b->lat, NB) && same(a->tair, b->tair, NB) && same(a->qair, b->qair, NB) &&
                      same(a->lwdn, b->lwdn, NB) && same(a->swdn, b->swdn, NB),
                  "fill %d: chunks of %zu (%d thread(s)) = one chunk, bit for bit", pass, chunks[i], i == 1 ? 2 : 1);
            CHECK(cs[i].c.n_before == NB && memcmp(cs[i].c.ids_before, b->id, NB * sizeof(long)) == 0 &&
                      same(cs[i].c.lon, cs[0].c.lon, NB) && same(cs[i].c.lat, cs[0].c.lat, NB),
                  "fill %d: ids and positions kept for messages", pass);
        }
    }
    omp_set_num_threads(1);
    sph_particles_free(moved);
    for (int i = 0; i < 3; i++)
        close_case(&cs[i]);
}

/* dir/name: u10, v10, t2m of field_fn's which0, which0 + 1, which0 + 2. */
static void write_atmosphere(const char *dir, const char *name, nc_type type, int which0)
{
    char path[1024];
    tvar atm[3];
    memset(atm, 0, sizeof atm);
    atm[0] = (tvar){"u10", "eastward_wind", "m s-1", type, 0, 0, 0, 0, 0, field_fn, which0};
    atm[1] = (tvar){"v10", "northward_wind", "m s-1", type, 0, 0, 0, 0, 0, field_fn, which0 + 1};
    atm[2] = (tvar){"t2m", "air_temperature", "K", type, 0, 0, 0, 0, 0, field_fn, which0 + 2};
    snprintf(path, sizeof path, "%s/%s", dir, name);
    write_file(path, atm, 3);
}

int main(void)
{
    check_atmos();
    char dir[] = "/tmp/test_coupling_XXXXXX";
    if (!mkdtemp(dir)) {
        perror("mkdtemp");
        return 1;
    }
    char path[1024];
    write_atmosphere(dir, "atm.nc", NC_FLOAT, 0);
    for (int s = 0; s < 2; s++) {
        tvar oc[2];
        memset(oc, 0, sizeof oc);
        oc[0] = (tvar){"uo", "eastward_sea_water_velocity", "m s-1", NC_DOUBLE, 0, 0, 0, 0, 0, field_fn, 3 + s};
        oc[1] = (tvar){"vo", "northward_sea_water_velocity", "m s-1", NC_DOUBLE, 0, 0, 0, 0, 0, field_fn, 9};
        snprintf(path, sizeof path, "%s/oc%d.nc", dir, s + 1);
        write_file(path, oc, 2);
    }
    write_atmosphere(dir, "var.nc", NC_DOUBLE, 10);
    sph_error e;
    sph_error_clear(&e);
    geo_proj *proj = geo_proj_create("aeqd", 120.0, 40.0, &e);
    CHECK(proj != NULL, "projection: %s", e.msg);
    if (proj) {
        check_uniform(dir, proj);
        check_sum_and_missing(dir, proj);
        check_moved_threads_dynamics(dir, proj);
        check_chunks(dir, proj);
    }
    geo_proj_free(proj);
    char cmd[1100];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    if (system(cmd) != 0)
        fprintf(stderr, "test_coupling: could not remove %s\n", dir);
    return check_summary("test_coupling");
}
