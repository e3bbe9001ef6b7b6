/* Forcing to particles (service/coupling.h): open the sources, sample them
 * at the particles, merge, default, rotate into the model plane. */
#include "service/coupling.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/atmos.h"
#include "service/config.h"
#include "util/log.h"
#include "util/timeutil.h"

/* Particles from which the per-particle loops below run on the OpenMP
 * threads: per-particle writes only, so any thread count gives the same
 * forcing bit for bit. */
#define COUPLING_OMP_MIN 4096
/* Particles a thread takes at a time in those loops: dynamic, so that a
 * thread sharing its core (the products' writer, another process) takes
 * fewer and the other does not wait for it (docs/bench.md "Session 11:
 * free drift (fd5)"). */
#define COUPLING_OMP_GRAB 2048
/* Points per forcing call (fc_coupling.chunk's default): the per-point work
 * arrays of the samples and of the forcing's stencils hold one chunk. */
#define COUPLING_CHUNK 65536

void coupling_format_lonlat(double lon, double lat, char *buf, size_t len)
{
    if (!isfinite(lon) || !isfinite(lat)) {
        snprintf(buf, len, "an unknown position");
        return;
    }
    snprintf(buf, len, "%.2f%c %.2f%c", fabs(lon), lon < 0 ? 'W' : 'E', fabs(lat),
             lat < 0 ? 'S' : 'N');
}

int forecast_source_spec(const struct sph_config *cfg, size_t s, const char *const *files,
                         forcing_source_spec *sp, forcing_name_map **map, sph_error *err)
{
    const cfg_forcing_source *src = &cfg->forcing[s];
    size_t nfiles = 0;
    while (files && files[nfiles])
        nfiles++;
    memset(sp, 0, sizeof *sp);
    *map = NULL;
    sp->name = src->name;
    sp->kind = (forcing_kind)src->kind;
    sp->files = files;
    sp->nfiles = nfiles;
    if (src->variables.n) {
        *map = calloc(src->variables.n, sizeof **map);
        if (!*map)
            return sph_err_set(err, SPH_ERR_NOMEM, "forcing: out of memory");
        for (size_t k = 0; k < src->variables.n; k++) {
            (*map)[k].standard_name = src->variables.key[k];
            (*map)[k].variable = src->variables.val[k];
        }
        sp->map = *map;
        sp->nmap = src->variables.n;
    }
    sp->vectors = src->vectors; /* FORCING_VECTORS_* in the order of the key's names */
    sp->accumulation = src->accumulation; /* FORCING_ACCUMULATION_*, likewise */
    sp->window = src->margin_km < 20040.0; /* half the circumference: whole grids */
    sp->margin_km = src->margin_km;
    for (size_t k = 0; k < src->required.n; k++)
        sp->required |= (unsigned)config_quantity_flag(src->required.v[k]);
    for (size_t k = 0; k < src->optional_q.n; k++)
        sp->optional |= (unsigned)config_quantity_flag(src->optional_q.v[k]);
    /* the mixed layer reads its depth and the bathymetry from an ocean source when it has them */
    if (cfg->model.ocean.mixed_layer && sp->kind == FORCING_OCEAN) {
        if (!(sp->required | sp->optional))
            sp->optional = FQ_CURRENT | FQ_SSH | FQ_SST | FQ_OCEAN_FLUX;
        sp->optional |= FQ_MLD | FQ_BATHY;
    }
    return SPH_OK;
}

int coupling_open(fc_coupling *c, const struct sph_config *cfg, const forecast_request *req, double t0,
                  double t_end, const char *cname, sph_error *err)
{
    c->cname = cname;
    size_t ns = cfg->nforcing < COUPLING_MAX_SOURCES ? cfg->nforcing : COUPLING_MAX_SOURCES;
    forcing_source_spec specs[COUPLING_MAX_SOURCES];
    forcing_name_map *maps[COUPLING_MAX_SOURCES] = {0};
    size_t nspecs = 0;
    int rc = SPH_OK;
    for (size_t s = 0; s < ns; s++) {
        const cfg_forcing_source *src = &cfg->forcing[s];
        const char *const *files = req->forcing_files[s];
        size_t nfiles = 0;
        while (files && files[nfiles])
            nfiles++;
        if (nfiles == 0) {
            if (src->optional_source) {
                log_warn("forecast %s: optional forcing %s has no files: left out", cname, src->name);
                continue;
            }
            rc = sph_err_set(err, SPH_ERR_COVERAGE, "forcing %s: no files for cycle %s", src->name,
                             cname);
            break;
        }
        rc = forecast_source_spec(cfg, s, files, &specs[nspecs], &maps[s], err);
        if (rc != SPH_OK)
            break;
        nspecs++;
    }
    /* one forcing object per source (same checks and messages as opening
     * them together); currents and SSH are summed over sources here */
    for (size_t k = 0; k < nspecs && rc == SPH_OK; k++) {
        rc = forcing_open(&c->forc[k], &specs[k], 1, t0, t_end, cfg->domain.lon_min,
                          cfg->domain.lon_max, cfg->domain.lat_min, cfg->domain.lat_max, err);
        if (rc == SPH_OK) {
            c->forc_kind[k] = specs[k].kind;
            c->forc_name[k] = specs[k].name;
            c->nforc = k + 1;
        }
    }
    if (rc == SPH_OK && nspecs == 0)
        rc = sph_err_set(err, SPH_ERR_CONFIG, "forcing: no source has files for cycle %s", cname);
    for (size_t s = 0; s < COUPLING_MAX_SOURCES; s++)
        free(maps[s]);
    return rc;
}

int coupling_alloc(fc_coupling *c, size_t cap, sph_error *err)
{
    size_t n = cap ? cap : 1;
    if (!c->chunk)
        c->chunk = COUPLING_CHUNK;
    size_t w = n < c->chunk ? n : c->chunk; /* one chunk's samples (coupling_fill) */
    c->wcap = w;
    /* the merged dynamics forcing (ue vn uwe vwn gxe gyn) is summed in the
     * filled particles' own arrays (coupling_fill); the merged sea-surface
     * height is read by nothing */
    double **arrays[] = {&c->lon, &c->lat, &c->angle, &c->tair, &c->qair, &c->swdn, &c->lwdn, &c->sst, &c->fw,
                         &c->snowfall, &c->precip, &c->mld, &c->bathy, &c->cs, &c->sn};
    int ok = 1;
    for (size_t k = 0; k < sizeof arrays / sizeof arrays[0]; k++)
        ok &= (*arrays[k] = calloc(n, sizeof(double))) != NULL;
    for (int k = 0; k < CPL_NQ; k++)
        ok &= (c->q[k] = calloc(w, sizeof(double))) != NULL;
    ok &= (c->bad = calloc(w, 1)) != NULL;
    ok &= (c->ids_before = calloc(n, sizeof(long))) != NULL;
    return ok ? SPH_OK : sph_err_set(err, SPH_ERR_NOMEM, "forecast: out of memory (%zu particles)", n);
}

void coupling_set_dynamics_only(fc_coupling *c)
{
    c->dynamics_only = 1;
    /* the thermal work arrays: no fill touches them from now on */
    double **thermal[] = {&c->tair, &c->qair, &c->swdn, &c->lwdn, &c->sst, &c->fw, &c->snowfall,
                          &c->precip, &c->mld, &c->bathy, &c->q[CPL_Q_TAIR], &c->q[CPL_Q_QAIR],
                          &c->q[CPL_Q_SWDN], &c->q[CPL_Q_LWDN], &c->q[CPL_Q_SST], &c->q[CPL_Q_FW],
                          &c->q[CPL_Q_SNOW], &c->q[CPL_Q_PRECIP], &c->q[CPL_Q_MLD], &c->q[CPL_Q_BATHY]};
    for (size_t k = 0; k < sizeof thermal / sizeof thermal[0]; k++) {
        free(*thermal[k]);
        *thermal[k] = NULL;
    }
}

void coupling_free(fc_coupling *c)
{
    for (size_t k = 0; k < c->nforc; k++)
        forcing_close(c->forc[k]);
    c->nforc = 0;
    double *arrays[] = {c->lon, c->lat, c->angle, c->tair, c->qair, c->swdn, c->lwdn, c->sst, c->fw,
                        c->snowfall, c->precip, c->mld, c->bathy, c->cs, c->sn};
    for (size_t k = 0; k < sizeof arrays / sizeof arrays[0]; k++)
        free(arrays[k]);
    for (int k = 0; k < CPL_NQ; k++)
        free(c->q[k]);
    free(c->bad);
    free(c->ids_before);
    geo_plane_table_free(c->plane);
    c->plane = NULL;
}

/* The quantities the dynamics reads (fc_coupling.dynamics_only). */
#define CPL_DYNAMICS (FQ_WIND | FQ_CURRENT | FQ_SSH)

/* The sample slots of particle k: its place in each c->q[CPL_Q_*] (none for
 * the thermal quantities with c->dynamics_only: the reader skips them). */
static void sample_view(fc_coupling *c, size_t k, forcing_sample *s)
{
    memset(s, 0, sizeof *s);
    double **slot[CPL_NQ] = {&s->u_east, &s->v_north, &s->tair, &s->qair, &s->swdn, &s->lwdn,
                             &s->uw_east, &s->vw_north, &s->ssh, &s->ssh_dx_east, &s->ssh_dy_north,
                             &s->sst, &s->fw, &s->snowfall, &s->precip, &s->mld, &s->bathy};
    static const char dyn[CPL_NQ] = {[CPL_Q_UE] = 1, [CPL_Q_VN] = 1, [CPL_Q_UWE] = 1, [CPL_Q_VWN] = 1,
                                     [CPL_Q_SSH] = 1, [CPL_Q_GXE] = 1, [CPL_Q_GYN] = 1};
    for (int q = 0; q < CPL_NQ; q++)
        *slot[q] = c->dynamics_only && !dyn[q] ? NULL : c->q[q] + k;
}

/* The coverage fallback of one source over a fill (sample_source). */
typedef struct cpl_bad {
    size_t nbad, first_bad;
    int rc;                     /* the whole call's code of the first chunk that fell back */
    char msg[sizeof(((sph_error *)0)->msg)], why[sizeof(((sph_error *)0)->msg)];
} cpl_bad;

/* Samples source src at the n particles k0 .. k0 + n - 1 (one chunk of the
 * ntot of the fill) into c->q[.][0 .. n). An ocean or tide source whose
 * grid has no water near some particles (a coast the ocean model does not
 * resolve) serves the others; those get no current, no sea-surface slope
 * and the other defaults (c->bad); fb counts them over the fill's chunks
 * (the caller's end of the fill checks that some particle was served). Any
 * other failure is an error. */
static int sample_source(fc_coupling *c, size_t src, double t, size_t k0, size_t n, size_t ntot,
                         unsigned *got, cpl_bad *fb, sph_error *err)
{
    forcing_sample s;
    sample_view(c, 0, &s);
    memset(c->bad, 0, n);
    sph_error local;
    sph_error_clear(&local);
    forcing_set_point_base(c->forc[src], k0);
    int rc = forcing_sample_at(c->forc[src], t, n, c->lon + k0, c->lat + k0, &s, &local);
    if (rc == SPH_OK) {
        *got = s.provided;
        return SPH_OK;
    }
    char when[32]; /* for the messages only */
    time_format_iso(t, when, sizeof when);
    if (rc != SPH_ERR_COVERAGE || c->forc_kind[src] == FORCING_ATMOSPHERE || ntot < 2)
        return sph_err_set(err, rc, "forcing at %s: %s", when, local.msg);
    if (!fb->rc) {
        fb->rc = rc;
        snprintf(fb->msg, sizeof fb->msg, "%s", local.msg);
    }
    unsigned flags = 0;
    forcing_set_point_base(c->forc[src], 0); /* one point per call */
    for (size_t k = 0; k < n; k++) {
        forcing_sample one;
        sample_view(c, k, &one);
        sph_error e1;
        sph_error_clear(&e1);
        int r1 = forcing_sample_at(c->forc[src], t, 1, c->lon + k0 + k, c->lat + k0 + k, &one, &e1);
        if (r1 == SPH_OK) {
            flags |= one.provided;
        } else if (r1 == SPH_ERR_COVERAGE) {
            if (!fb->nbad++) {
                fb->first_bad = k0 + k;
                snprintf(fb->why, sizeof fb->why, "%s", e1.msg); /* outside its grid or read window */
            }
            c->bad[k] = 1;
        } else {
            return sph_err_set(err, r1, "forcing at %s: %s", when, e1.msg);
        }
    }
    *got = flags;
    return SPH_OK;
}

/* The end of source src's fill: no particle served is an error, some not
 * served are reported (once per run). */
static int source_fallbacks(fc_coupling *c, size_t src, double t, size_t ntot, const cpl_bad *fb,
                            sph_error *err)
{
    if (!fb->rc)
        return SPH_OK;
    char when[32];
    time_format_iso(t, when, sizeof when);
    if (fb->nbad == ntot)
        return sph_err_set(err, fb->rc, "forcing at %s: %s", when, fb->msg);
    if (!fb->nbad)
        return SPH_OK;
    if (!c->coast_fallbacks) {
        char ll[64];
        coupling_format_lonlat(c->lon[fb->first_bad], c->lat[fb->first_bad], ll, sizeof ll);
        log_warn("forecast %s: forcing %s has no water near %zu particle(s) (first at %s, %s): "
                 "no current or sea-surface slope there (reported once): %s", c->cname,
                 c->forc_name[src], fb->nbad, ll, when, fb->why);
    }
    c->coast_fallbacks += (long)fb->nbad;
    return SPH_OK;
}

/* Adds one source's sample to the particle forcing: currents and SSH sum
 * over sources (ocean + tide, as the forcing reader does), other
 * quantities come from the first source that provides them. */
static void merge_source(fc_coupling *c, size_t k0, size_t n, unsigned got, unsigned before)
{
    static const struct { int q; unsigned flag; int sum; } map[] = {
        {CPL_Q_UE, FQ_WIND, 0}, {CPL_Q_VN, FQ_WIND, 0}, {CPL_Q_TAIR, FQ_TAIR, 0},
        {CPL_Q_QAIR, FQ_HUMIDITY, 0}, {CPL_Q_SWDN, FQ_SWDN, 0}, {CPL_Q_LWDN, FQ_LWDN, 0},
        {CPL_Q_UWE, FQ_CURRENT, 1}, {CPL_Q_VWN, FQ_CURRENT, 1}, {CPL_Q_SSH, FQ_SSH, 1},
        {CPL_Q_GXE, FQ_SSH, 1}, {CPL_Q_GYN, FQ_SSH, 1}, {CPL_Q_SST, FQ_SST, 0},
        {CPL_Q_FW, FQ_OCEAN_FLUX, 0}, {CPL_Q_SNOW, FQ_SNOWFALL, 0}, {CPL_Q_PRECIP, FQ_PRECIP, 0},
        {CPL_Q_MLD, FQ_MLD, 0}, {CPL_Q_BATHY, FQ_BATHY, 0}};
    double *dst[CPL_NQ] = {c->ue, c->vn, c->tair, c->qair, c->swdn, c->lwdn, c->uwe, c->vwn, c->ssh,
                           c->gxe, c->gyn, c->sst, c->fw, c->snowfall, c->precip, c->mld, c->bathy};
    /* the quantities this source adds, then one pass over the particles
     * for all of them (one parallel loop per call, not one per quantity:
     * each quantity's own operations, so the same values) */
    struct { double *d; const double *q; int sum; } job[sizeof map / sizeof map[0]];
    size_t nj = 0;
    for (size_t m = 0; m < sizeof map / sizeof map[0]; m++) {
        if (!(got & map[m].flag) || (!map[m].sum && (before & map[m].flag)) || !dst[map[m].q])
            continue; /* dst NULL: the sea-surface height, read by nothing */
        job[nj].d = dst[map[m].q] + k0;
        job[nj].q = c->q[map[m].q]; /* the chunk k0 .. k0 + n - 1 */
        job[nj].sum = map[m].sum;
        nj++;
    }
    if (!nj)
        return;
    const unsigned char *bad = c->bad;
    const size_t ngrab = (n + COUPLING_OMP_GRAB - 1) / COUPLING_OMP_GRAB;
#pragma omp parallel for schedule(dynamic, 1) if (n >= COUPLING_OMP_MIN)
    for (size_t g = 0; g < ngrab; g++) {
        const size_t a = g * COUPLING_OMP_GRAB, b = a + COUPLING_OMP_GRAB < n ? a + COUPLING_OMP_GRAB : n;
        for (size_t j = 0; j < nj; j++) {
            double *d = job[j].d;
            const double *q = job[j].q;
            const int sum = job[j].sum;
            for (size_t k = a; k < b; k++) {
                if (bad[k])
                    continue; /* keeps the default (or the other sources' sum) */
                d[k] = sum ? d[k] + q[k] : q[k];
            }
        }
    }
}

/* See docs/engine.md for the defaults of quantities no source provides. */
int coupling_fill(fc_coupling *c, const geo_proj *proj, const sph_thermo_params *th, int thermo_on,
                  sph_particles *P, double t, sph_error *err)
{
    size_t n = P->n;
    if (n == 0)
        return SPH_OK;
    int rc = c->plane ? geo_plane_lookup(c->plane, n, P->x, P->y, c->lon, c->lat, c->cs, c->sn, err)
                      : geo_inverse(proj, n, P->x, P->y, c->lon, c->lat, err);
    if (rc)
        return rc;
    /* the merged east/north dynamics forcing is summed in P's own arrays,
     * turned to plane x/y in place below */
    c->ue = P->ua;
    c->vn = P->va;
    c->uwe = P->uw;
    c->vwn = P->vw;
    c->gxe = P->sshx;
    c->gyn = P->sshy;
    c->ssh = NULL;
    const double tf = sph_freezing_point(th);
    const int dyn = c->dynamics_only;
#pragma omp parallel for schedule(dynamic, COUPLING_OMP_GRAB) if (n >= COUPLING_OMP_MIN)
    for (size_t k = 0; k < n; k++) {
        c->ue[k] = c->vn[k] = 0.0;
        c->uwe[k] = c->vwn[k] = 0.0;
        c->gxe[k] = c->gyn[k] = 0.0;
        if (dyn)
            continue;
        c->tair[k] = tf;
        c->qair[k] = NAN;
        c->swdn[k] = 0.0;
        c->lwdn[k] = NAN;
        c->sst[k] = NAN; /* the thermodynamics takes the freezing point */
        c->fw[k] = NAN;  /* the thermodynamics takes fw_default */
        c->snowfall[k] = 0.0;
        c->precip[k] = 0.0;
        c->mld[k] = c->bathy[k] = NAN; /* the mixed layer's configured depth */
    }
    unsigned provided = 0;
    for (size_t src = 0; src < c->nforc; src++) { /* each source in chunks of c->wcap particles */
        unsigned got_all = 0;
        cpl_bad fb;
        memset(&fb, 0, sizeof fb);
        for (size_t k0 = 0; k0 < n; k0 += c->wcap) {
            size_t nk = n - k0 < c->wcap ? n - k0 : c->wcap;
            unsigned got = 0;
            int rc2 = sample_source(c, src, t, k0, nk, n, &got, &fb, err);
            if (rc2)
                return rc2;
            merge_source(c, k0, nk, got, provided);
            got_all |= got;
        }
        forcing_set_point_base(c->forc[src], 0);
        int rc2 = source_fallbacks(c, src, t, n, &fb, err);
        if (rc2)
            return rc2;
        provided |= got_all;
    }
    /* dynamics only: the thermal quantities found at the last full fill */
    c->provided = dyn ? provided | (c->provided & ~(unsigned)CPL_DYNAMICS) : provided;
    if (thermo_on && !(c->provided & FQ_TAIR))
        return sph_err_set(err, SPH_ERR_MISSING_VAR,
                           "forcing: no source provides air_temperature, which the thermodynamics "
                           "needs (add it, or set model.thermo.dt 0)");
    double pa = th->air_pressure;
    if (!c->plane) /* PROJ, serial (one context); the table gave cs, sn */
        for (size_t k = 0; k < n; k++) {
            double a = geo_grid_angle(proj, c->lon[k], c->lat[k]);
            if (!isfinite(a))
                a = 0.0;
            c->angle[k] = a;
            c->cs[k] = cos(a);
            c->sn[k] = sin(a);
        }
#pragma omp parallel for schedule(dynamic, COUPLING_OMP_GRAB) if (n >= COUPLING_OMP_MIN)
    for (size_t k = 0; k < n; k++) {
        const double cs = c->cs[k], sn = c->sn[k];
        /* east/north -> plane x/y (io/geo.h), in place */
        const double ue = c->ue[k], vn = c->vn[k], uwe = c->uwe[k], vwn = c->vwn[k];
        const double gxe = c->gxe[k], gyn = c->gyn[k];
        P->ua[k] = ue * cs + vn * sn;
        P->va[k] = -ue * sn + vn * cs;
        P->uw[k] = uwe * cs + vwn * sn;
        P->vw[k] = -uwe * sn + vwn * cs;
        P->sshx[k] = gxe * cs + gyn * sn;
        P->sshy[k] = -gxe * sn + gyn * cs;
        P->lat[k] = c->lat[k];
        c->ids_before[k] = P->id[k]; /* for messages about a step that fails (below) */
        if (dyn)
            continue;
        double T = c->tair[k];
        P->tair[k] = T;
        if (!(provided & FQ_HUMIDITY))
            c->qair[k] = sph_atmos_qair_rh(T, SPH_ATMOS_DEFAULT_RH, pa);
        P->qair[k] = c->qair[k];
        P->swdn[k] = c->swdn[k];
        if (!(provided & FQ_LWDN))
            c->lwdn[k] = sph_atmos_lwdn_cloud(T, SPH_ATMOS_DEFAULT_CLOUD);
        P->lwdn[k] = c->lwdn[k];
        P->sst[k] = c->sst[k];
        P->fw[k] = c->fw[k];
        P->fsens[k] = NAN;
        P->flat[k] = NAN;
        /* water equivalent; packing noise below zero is no snow */
        double sf = 0.0;
        if (provided & FQ_SNOWFALL)
            sf = c->snowfall[k];
        else if (provided & FQ_PRECIP)
            sf = c->precip[k] * sph_snow_fraction(th, T);
        P->snowfall[k] = sf > 0.0 ? sf : 0.0;
    }
    /* for messages about a step that fails: the ids (copied in the loop
     * above, on the threads) and their positions c->lon, c->lat */
    c->n_before = n;
    return SPH_OK;
}
