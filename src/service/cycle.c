/* The forecast cycle state machine (service/cycle.h). */
#include "service/cycle.h"
#include "io/fetch.h"
#include "io/ncfile.h"

#include <cjson/cJSON.h>
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <ftw.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "io/products.h"
#include "service/config.h"
#include "service/cycle_phase.h"
#include "service/ensemble.h"
#include "service/schedule.h"
#include "util/fileio.h"
#include "util/log.h"
#include "util/timeutil.h"
#include "util/version.h"

/* ensemble_run is forecast_run when ensemble.members is 1 */
static cycle_engine_fn engine_fn = ensemble_run;

void cycle_set_engine(cycle_engine_fn fn) { engine_fn = fn ? fn : ensemble_run; }

static int local_fetch(const char *tmpl, double t, const cycle_fetch_ctx *ctx, char *local, size_t len,
                       char sha256[65], sph_error *err);
static cycle_fetch_fn fetch_fn = local_fetch;

void cycle_set_fetcher(cycle_fetch_fn fn) { fetch_fn = fn ? fn : local_fetch; }

/* ------------------------------------------------------------- helpers */

static int rm_entry(const char *path, const struct stat *sb, int flag, struct FTW *ftw)
{
    (void)sb; (void)flag; (void)ftw;
    return remove(path) != 0 && errno != ENOENT ? -1 : 0;
}

int cycle_remove_tree(const char *path)
{
    struct stat st;
    if (lstat(path, &st) != 0)
        return errno == ENOENT ? 0 : -1;
    return nftw(path, rm_entry, 16, FTW_DEPTH | FTW_PHYS);
}

/* The built-in fetcher: local paths and file:// URLs as they are, remote
 * URLs downloaded into the cache (tests may register another one). */
static int local_fetch(const char *tmpl, double t, const cycle_fetch_ctx *ctx, char *local, size_t len,
                       char sha256[65], sph_error *err)
{
    char path[4096];
    int rc = cycle_expand_template(tmpl, t, path, sizeof path, err);
    if (rc)
        return rc;
    const char *p = path;
    if (!strncmp(p, "file://", 7)) {
        p += 7;
    } else if (strstr(p, "://")) {
        /* http(s):// and ftp://: libcurl with timeouts, retries, a cache,
         * conditional requests, validated NetCDF (io/fetch.h) */
        const struct sph_config *cfg = ctx->cfg;
        fetch_options o;
        fetch_options_default(&o);
        o.cache_dir = cfg->paths.cache_dir;
        o.connect_timeout_s = cfg->fetch.connect_timeout_s;
        o.timeout_s = cfg->fetch.timeout_s;
        o.low_speed_bytes = cfg->fetch.low_speed_bytes;
        o.stall_timeout_s = cfg->fetch.low_speed_s;
        o.retries = cfg->fetch.retries;
        o.backoff_s = cfg->fetch.backoff_s;
        o.expect_vars = ctx->expect_vars;
        o.n_expect = ctx->n_expect;
        o.cancel = ctx->cancel;
        if (ctx->cache_only)
            return fetch_cached_copy(path, &o, local, len, sha256, err);
        return fetch_url(path, &o, local, len, sha256, err);
    }
    if (access(p, R_OK) != 0)
        return sph_err_set(err, SPH_ERR_IO, "%s: %s", p, strerror(errno));
    snprintf(local, len, "%s", p);
    return sha256_file(p, sha256, err);
}

/* A lock file may be removed by its holder when it is done (release_lock):
 * a lock taken on a file that is no longer the one at `path` (removed, or
 * removed and created anew by a third process, between our open and our
 * flock) locks nothing, so it is dropped and taken again. */
static int take_lock(const char *path, int *fd_out, sph_error *err)
{
    for (int attempt = 0;; attempt++) {
        int fd = open(path, O_CREAT | O_RDWR | O_CLOEXEC, 0644);
        if (fd < 0)
            return sph_err_set(err, SPH_ERR_IO, "lock %s: %s", path, strerror(errno));
        if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
            int e = errno;
            close(fd);
            if (e == EWOULDBLOCK)
                return sph_err_set(err, SPH_ERR_LOCKED, "lock %s: held by another sphice process", path);
            return sph_err_set(err, SPH_ERR_IO, "lock %s: %s", path, strerror(e));
        }
        struct stat held, named;
        if (fstat(fd, &held) == 0 && stat(path, &named) == 0 && held.st_dev == named.st_dev &&
            held.st_ino == named.st_ino) {
            *fd_out = fd;
            return SPH_OK;
        }
        close(fd);
        if (attempt >= 100)
            return sph_err_set(err, SPH_ERR_LOCKED, "lock %s: removed and created again while being taken",
                               path);
    }
}

/* Removes the lock file while still holding the lock, then drops it: no
 * file is left per cycle, and take_lock tells a removed file from the one
 * at the path. */
static void release_lock(const char *path, int fd)
{
    if (fd < 0)
        return;
    (void)unlink(path);
    close(fd);
}

/* Sleeps up to `seconds`, in short slices; returns 1 if cancelled. */
static int nap(double seconds, const volatile sig_atomic_t *cancel)
{
    double end = time_monotonic() + seconds;
    while (time_monotonic() < end) {
        if (cancel && *cancel)
            return 1;
        double left = end - time_monotonic();
        double s = left < 0.05 ? left : 0.05;
        if (s > 0) {
            struct timespec ts = {0, (long)(s * 1e9)};
            nanosleep(&ts, NULL);
        }
    }
    return cancel && *cancel;
}

/* Removes stage dirs left by processes that no longer exist. */
static void sweep_stages(const char *out_dir)
{
    DIR *d = opendir(out_dir);
    if (!d)
        return;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (strncmp(e->d_name, ".stage-", 7) && strncmp(e->d_name, ".old-", 5))
            continue;
        const char *dash = strrchr(e->d_name, '-');
        char *end;
        long pid = dash ? strtol(dash + 1, &end, 10) : 0;
        if (pid <= 0 || *end)
            continue;
        if (kill((pid_t)pid, 0) == 0 || errno != ESRCH)
            continue;
        char p[4096];
        snprintf(p, sizeof p, "%s/%s", out_dir, e->d_name);
        log_warn("removing stage dir %s left by process %ld", p, pid);
        cycle_remove_tree(p);
    }
    closedir(d);
}

/* Published cycle times in out_dir, ascending. Caller frees. */
static size_t list_published(const char *out_dir, double **times)
{
    *times = NULL;
    DIR *d = opendir(out_dir);
    if (!d)
        return 0;
    size_t n = 0, cap = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        double t;
        if (cycle_name_parse(e->d_name, &t))
            continue;
        if (n == cap) {
            cap = cap ? cap * 2 : 16;
            double *g = realloc(*times, cap * sizeof *g);
            if (!g)
                break;
            *times = g;
        }
        (*times)[n++] = t;
    }
    closedir(d);
    for (size_t i = 1; i < n; i++) /* insertion sort: lists are short */
        for (size_t j = i; j > 0 && (*times)[j - 1] > (*times)[j]; j--) {
            double x = (*times)[j];
            (*times)[j] = (*times)[j - 1];
            (*times)[j - 1] = x;
        }
    return n;
}

/* The newest restart file for cycle time t in a cycle published before t. */
static int find_warm_start(const char *out_dir, double t, char *path, size_t len, double *mtime)
{
    double *times;
    size_t n = list_published(out_dir, &times);
    char want[64];
    cycle_restart_name(t, want, sizeof want);
    int found = 0;
    for (size_t i = n; i-- > 0 && !found;) {
        if (times[i] >= t)
            continue;
        char name[32];
        cycle_name(times[i], name, sizeof name);
        snprintf(path, len, "%s/%s/%s", out_dir, name, want);
        struct stat st;
        if (stat(path, &st) == 0 && S_ISREG(st.st_mode)) {
            found = 1;
            *mtime = (double)st.st_mtim.tv_sec + st.st_mtim.tv_nsec * 1e-9;
        }
    }
    free(times);
    return found;
}

/* ---------------------------------------------------------- test double */

static double env_seconds(const struct sph_config *cfg, int *fail)
{
    const char *e = getenv("SPHICE_TEST_ENGINE");
    *fail = 0;
    if (e && !strcmp(e, "fail")) {
        *fail = 1;
        return 0;
    }
    if (e && !strncmp(e, "sleep:", 6)) {
        char *end;
        double s = strtod(e + 6, &end);
        if (end != e + 6 && *end == 0 && s >= 0)
            return s;
    }
    return cfg->test_engine_seconds;
}

int cycle_test_engine(const struct sph_config *cfg, const forecast_request *req, forecast_progress *prog,
                      const volatile sig_atomic_t *cancel, forecast_result *res, sph_error *err)
{
    int fail;
    double seconds = env_seconds(cfg, &fail);
    if (fail)
        return sph_err_set(err, SPH_ERR_NUMERICS, "test engine: failing as SPHICE_TEST_ENGINE=fail asks");
    double t0 = time_monotonic();
    cycle_set_phase(prog, req->cycle_time, FC_PHASE_RUNNING, "test engine");
    for (;;) {
        double f = seconds > 0 ? (time_monotonic() - t0) / seconds : 1;
        if (f > 1)
            f = 1;
        prog->percent = 100 * f;
        prog->model_time = req->cycle_time + f * req->hours * 3600;
        prog->particles = 1000;
        prog->frac_free_drift = 0.25;
        prog->frac_rheology = 0.75;
        if (f >= 1)
            break;
        if (nap(0.02, cancel))
            return sph_err_set(err, SPH_ERR_CANCELLED, "test engine: cancelled");
    }
    cycle_set_phase(prog, req->cycle_time, FC_PHASE_WRITING, "test engine: its product");
    /* The product records the inputs: two runs with the same inputs write
     * the same bytes, as the real engine must. */
    char iso[32];
    time_format_iso(req->cycle_time, iso, sizeof iso);
    size_t cap = 65536, used = 0;
    char *buf = malloc(cap);
    if (!buf)
        return sph_err_set(err, SPH_ERR_NOMEM, "test engine: out of memory");
    used += (size_t)snprintf(buf + used, cap - used, "cycle %s\nhours %g\nstale %d\nwarm_start %s\n", iso,
                             req->hours, req->stale, req->warm_start ? "yes" : "no");
    for (size_t i = 0; req->forcing_sha256[i] && used < cap; i++) {
        const char *sp = strrchr(req->forcing_sha256[i], ' ');
        used += (size_t)snprintf(buf + used, cap - used, "forcing %s\n", sp ? sp + 1 : "");
    }
    if (used >= cap)
        used = cap - 1;
    char path[4096];
    snprintf(path, sizeof path, "%s/fields.txt", req->stage_dir);
    int rc = atomic_write_file(path, buf, used, err);
    free(buf);
    if (rc)
        return rc;
    char rname[64];
    cycle_restart_name(schedule_next(cfg, req->cycle_time), rname, sizeof rname);
    snprintf(path, sizeof path, "%s/%s", req->stage_dir, rname);
    if ((rc = atomic_write_file(path, "restart\n", 8, err)))
        return rc;
    memset(res, 0, sizeof *res);
    res->run.particles_start = res->run.particles_end = 1000;
    res->ice_area_km2 = 1234.5;
    res->ice_volume_km3 = 0.25;
    res->edge_distance_nm = NAN;
    res->run.frac_free_drift = 0.25;
    res->run.frac_rheology = 0.75;
    snprintf(res->start_mode, sizeof res->start_mode, "%s", req->warm_start ? "warm" : "cold");
    res->nproducts = 2;
    snprintf(res->products[0], sizeof res->products[0], "fields.txt");
    snprintf(res->products[1], sizeof res->products[1], "%s", rname);
    if (req->observation) {
        res->has_scores = 1;
        res->iiee_km2 = 10;
    }
    return SPH_OK;
}

/* ------------------------------------------------------------- forcing */

typedef struct fetched {
    char *files[CYCLE_MAX_SOURCES][CYCLE_MAX_FILES + 1];
    size_t nfiles[CYCLE_MAX_SOURCES];
    int found[CYCLE_MAX_SOURCES];
    char *prov[CYCLE_MAX_SOURCES * CYCLE_MAX_FILES + 1];
    size_t nprov;
} fetched;

static void fetched_free(fetched *f)
{
    for (size_t s = 0; s < CYCLE_MAX_SOURCES; s++)
        for (size_t i = 0; i < f->nfiles[s]; i++)
            free(f->files[s][i]);
    for (size_t i = 0; i < f->nprov; i++)
        free(f->prov[i]);
    memset(f, 0, sizeof *f);
}

/* The variables a download of source src must hold: the mapped variables
 * (`variables`) of its `required` quantities; with no `required` list,
 * every mapped variable whose quantity is not listed as `optional`. */
static size_t required_vars(const cfg_forcing_source *src, const char **vars, size_t max)
{
    int req = 0, opt = 0; /* the names are checked when the configuration is read */
    for (size_t i = 0; i < src->required.n; i++)
        req |= config_quantity_flag(src->required.v[i]);
    for (size_t i = 0; i < src->optional_q.n; i++)
        opt |= config_quantity_flag(src->optional_q.v[i]);
    size_t n = 0;
    for (size_t i = 0; i < src->variables.n && n < max; i++) {
        int q = forcing_quantity_of(src->variables.key[i]);
        if (src->required.n ? (q & req) != 0 : !(q & opt))
            vars[n++] = src->variables.val[i];
    }
    return n;
}

/* Tries every template of source s with issue time t; all must be there.
 * cache_only: the last good cached downloads, no network. */
static int try_source(const struct sph_config *cfg, size_t s, double t, fetched *f, sph_error *why,
                      const volatile sig_atomic_t *cancel, int cache_only)
{
    const cfg_forcing_source *src = &cfg->forcing[s];
    /* a download must hold the variables the source maps, or it does not
     * replace the cached copy */
    const char *vars[64];
    cycle_fetch_ctx ctx = {cfg, vars, required_vars(src, vars, 64), cancel, cache_only};
    char *files[CYCLE_MAX_FILES] = {0};
    char sums[CYCLE_MAX_FILES][65];
    size_t n = 0;
    for (size_t i = 0; i < src->urls.n && n < CYCLE_MAX_FILES; i++) {
        char local[4096];
        sph_error e;
        sph_error_clear(&e);
        if (fetch_fn(src->urls.v[i], t, &ctx, local, sizeof local, sums[n], &e)) {
            sph_error_clear(why);
            sph_err_set(why, e.code, "%s", e.msg);
            for (size_t j = 0; j < n; j++)
                free(files[j]);
            return -1;
        }
        files[n++] = strdup(local);
    }
    for (size_t i = 0; i < n; i++) {
        f->files[s][i] = files[i];
        char line[4200];
        snprintf(line, sizeof line, "%s %s", files[i] ? files[i] : "", sums[i]);
        f->prov[f->nprov++] = strdup(line);
    }
    f->nfiles[s] = n;
    f->found[s] = 1;
    return 0;
}

/* Fetch with the late-data rule. Returns SPH_OK with *stale set, or an error. */
static int fetch_all(const struct sph_config *cfg, const cycle_opts *o, const char *cname, fetched *f,
                     cycle_report *rep, const volatile sig_atomic_t *cancel, sph_error *err)
{
    sph_error why[CYCLE_MAX_SOURCES];
    double wait = o->hindcast ? 0 : cfg->schedule.late_data.wait_minutes * 60.0;
    double deadline = time_monotonic() + wait;
    size_t ns = cfg->nforcing < CYCLE_MAX_SOURCES ? cfg->nforcing : CYCLE_MAX_SOURCES;
    for (size_t s = 0; s < ns; s++) {
        sph_error_clear(&why[s]);
        rep->source_age_h[s] = NAN;
        snprintf(rep->source_name[s], sizeof rep->source_name[s], "%s", cfg->forcing[s].name);
    }
    rep->nsources = ns;
    /* .part files of downloads killed with -9 (daemon start, `run`) */
    fetch_sweep_parts(cfg->paths.cache_dir);
    int logged = 0;
    for (;;) {
        int missing = 0;
        for (size_t s = 0; s < ns; s++) {
            if (f->found[s])
                continue;
            if (try_source(cfg, s, o->cycle_time, f, &why[s], cancel, 0) == 0)
                rep->source_age_h[s] = 0;
            else if (cancel && *cancel)
                return sph_err_set(err, SPH_ERR_CANCELLED, "cycle %s: cancelled while fetching forcing: %s",
                                   cname, why[s].msg);
            else if (!cfg->forcing[s].optional_source)
                missing++;
        }
        if (!missing || time_monotonic() >= deadline)
            break;
        if (!logged++)
            log_info("cycle %s: waiting up to %g min for forcing", cname, wait / 60);
        double left = deadline - time_monotonic();
        double poll = cfg->schedule.late_data.poll_seconds;
        if (nap(left < poll ? left : poll, cancel))
            return sph_err_set(err, SPH_ERR_CANCELLED, "cycle %s: cancelled while waiting for forcing", cname);
    }
    for (size_t s = 0; s < ns; s++) {
        const cfg_forcing_source *src = &cfg->forcing[s];
        if (f->found[s])
            continue;
        if (cfg->schedule.late_data.policy == CFG_LATE_STALE) {
            /* the last good download of this very issue, kept in the cache
             * when the server failed or sent a file that failed the check */
            sph_error e0;
            sph_error_clear(&e0);
            if (try_source(cfg, s, o->cycle_time, f, &e0, cancel, 1) == 0) {
                rep->source_age_h[s] = 0;
                rep->stale = 1;
                log_warn("cycle %s: forcing %s: %s; using the last good cached download (stale)", cname,
                         src->name, why[s].msg);
            }
            for (int k = 1; k * src->issue_hours <= src->max_age_hours + 1e-9 && !f->found[s]; k++) {
                double t = o->cycle_time - k * src->issue_hours * 3600.0;
                sph_error e;
                sph_error_clear(&e);
                if (try_source(cfg, s, t, f, &e, cancel, 0) == 0) {
                    rep->source_age_h[s] = k * src->issue_hours;
                    rep->stale = 1;
                    log_warn("cycle %s: forcing %s: using the issue of %g h before the cycle (stale)", cname,
                             src->name, k * src->issue_hours);
                }
            }
        }
        if (f->found[s])
            continue;
        if (src->optional_source) {
            log_warn("cycle %s: optional forcing %s missing: %s", cname, src->name, why[s].msg);
            continue;
        }
        return sph_err_set(err, SPH_ERR_COVERAGE, "cycle %s: forcing %s missing after waiting %g min: %s", cname,
                           src->name, wait / 60, why[s].msg);
    }
    return SPH_OK;
}

/* ------------------------------------------------------------- publish */

static cJSON *ensemble_json(const forecast_result *r);

static cJSON *result_json(const forecast_result *r)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "particles_start", (double)r->run.particles_start);
    cJSON_AddNumberToObject(o, "particles_end", (double)r->run.particles_end);
#define NUM(k, v) (isfinite(v) ? cJSON_AddNumberToObject(o, k, v) : cJSON_AddNullToObject(o, k))
    NUM("ice_area_km2", r->ice_area_km2);
    NUM("ice_volume_km3", r->ice_volume_km3);
    NUM("edge_distance_nm", r->edge_distance_nm);
    NUM("budget_residual", r->run.budget_residual);
    if (r->run.ocean) { /* the mixed layer's budgets (issue 20) */
        NUM("energy_budget_residual", r->run.energy_residual);
        NUM("water_budget_residual", r->run.water_residual);
        NUM("salt_budget_residual", r->run.salt_residual);
    }
    NUM("wall_seconds", r->wall_seconds);
    NUM("raster_ice_area_km2", r->raster_ice_area_km2);
    NUM("raster_ice_volume_km3", r->raster_ice_volume_km3);
    NUM("seeded_ice_area_km2", r->seeded_ice_area_km2);
    NUM("seeded_ice_volume_km3", r->seeded_ice_volume_km3);
    NUM("particles_on_land_fraction", r->land_fraction);
    if (r->raster_assumed[0]) /* only where configuration stood in for the file */
        cJSON_AddStringToObject(o, "initial_raster_assumed", r->raster_assumed);
    if (r->quality_flag[0])
        cJSON_AddStringToObject(o, "quality_flag", r->quality_flag);
    else
        cJSON_AddNullToObject(o, "quality_flag");
    if (r->run.dt > 0) {
        NUM("dt", r->run.dt);
        cJSON_AddStringToObject(o, "dt_policy", r->run.dt_auto ? "auto" : "configured");
        cJSON *rg = cJSON_AddObjectToObject(o, "regimes");
        cJSON_AddNumberToObject(rg, "free_drift", r->run.frac_free_drift);
        cJSON_AddNumberToObject(rg, "rheology", r->run.frac_rheology);
        cJSON_AddNumberToObject(rg, "zero_layer", r->run.frac_zero_layer);
        cJSON_AddNumberToObject(rg, "multi_layer", r->run.frac_multi_layer);
        cJSON *sv = cJSON_AddObjectToObject(o, "solver");
        cJSON_AddNumberToObject(sv, "mean_iterations", r->run.solver_iterations);
        cJSON_AddNumberToObject(sv, "stalled_fraction", r->run.solver_stalled);
        if (r->run.solver_rel_tol_on) { /* model.evp.rel_tol > 0: the residual rule */
            cJSON_AddNumberToObject(sv, "mean_relative_residual", r->run.solver_residual);
            cJSON_AddNumberToObject(sv, "max_relative_residual", r->run.solver_residual_max);
            cJSON_AddNumberToObject(sv, "unconverged_fraction", r->run.solver_unconverged);
        }
    }
    cJSON *ens = ensemble_json(r);
    if (ens)
        cJSON_AddItemToObject(o, "ensemble", ens);
#undef NUM
    return o;
}

/* The ensemble's block (members > 1), or NULL. */
static cJSON *ensemble_json(const forecast_result *r)
{
    if (r->ensemble.members <= 1)
        return NULL;
    cJSON *o = cJSON_CreateObject();
    char seed[32];
    snprintf(seed, sizeof seed, "%llu", r->ensemble.seed);
    cJSON_AddNumberToObject(o, "members", r->ensemble.members);
    cJSON_AddStringToObject(o, "seed", seed);
    cJSON_AddNumberToObject(o, "mean_conc_spread", r->ensemble.mean_spread_conc);
    if (r->ensemble.has_scores) {
        cJSON_AddNumberToObject(o, "sps_km2", r->ensemble.sps_km2);
        cJSON_AddNumberToObject(o, "iiee_median_km2", r->ensemble.iiee_median_km2);
    }
    return o;
}

static cJSON *cycle_scores_json(const forecast_result *r)
{
    cJSON *ens = ensemble_json(r);
    if (!r->has_scores) {
        if (!ens)
            return cJSON_CreateNull();
        cJSON *o = cJSON_CreateObject();
        cJSON_AddItemToObject(o, "ensemble", ens);
        return o;
    }
    cJSON *o = cJSON_CreateObject();
    if (ens)
        cJSON_AddItemToObject(o, "ensemble", ens);
    cJSON_AddNumberToObject(o, "iiee_km2", r->iiee_km2);
    cJSON_AddNumberToObject(o, "aee_km2", r->aee_km2);
    cJSON_AddNumberToObject(o, "me_km2", r->me_km2);
    cJSON_AddNumberToObject(o, "edge_displacement_km", r->edge_displacement_km);
    cJSON_AddNumberToObject(o, "conc_bias", r->conc_bias);
    cJSON_AddNumberToObject(o, "conc_rmse", r->conc_rmse);
    cJSON_AddNumberToObject(o, "skill_persistence", r->skill_persistence);
    return o;
}

/* cycle.json's timing block (written with a load product): the
 * forecast's wall time and the stage "loads", the DEM runs inside it. */
static cJSON *cycle_loads_timing_json(const forecast_result *r)
{
    const prod_loads_summary *l = &r->loads;
    cJSON *t = cJSON_CreateObject(), *f = cJSON_AddObjectToObject(t, "forecast"),
          *o = cJSON_AddObjectToObject(t, "loads");
    cJSON_AddNumberToObject(f, "wall_seconds", r->wall_seconds);
    cJSON_AddNumberToObject(o, "dem_wall_seconds", l->dem_seconds);
    cJSON_AddNumberToObject(o, "dem_share_of_forecast", r->wall_seconds > 0 ? l->dem_seconds / r->wall_seconds : 0.0);
    cJSON_AddNumberToObject(o, "dem_runs", (double)l->dem_runs);
    cJSON_AddNumberToObject(o, "dem_cached", (double)l->dem_cached);
    cJSON_AddNumberToObject(o, "dem_rows", (double)l->dem_rows);
    cJSON_AddNumberToObject(o, "cheap_rows", (double)l->cheap_rows);
    cJSON_AddNumberToObject(o, "dem_particle_steps", (double)l->dem_particle_steps);
    return t;
}

/* The latest load and model per station (cycle.json "loads"; /status copies it). */
static cJSON *cycle_loads_json(const prod_loads_summary *l)
{
    cJSON *a = cJSON_CreateArray();
    for (int k = 0; k < l->nstations; k++) {
        const prod_load_latest *q = &l->st[k];
        cJSON *o = cJSON_CreateObject();
        char iso[32];
        cJSON_AddStringToObject(o, "station", q->name);
        if (isfinite(q->time)) {
            time_format_iso(q->time, iso, sizeof iso);
            cJSON_AddStringToObject(o, "valid_time", iso);
        } else {
            cJSON_AddNullToObject(o, "valid_time");
        }
        if (isfinite(q->load))
            cJSON_AddNumberToObject(o, "load_kN", q->load * 1e-3);
        else
            cJSON_AddNullToObject(o, "load_kN");
        cJSON_AddStringToObject(o, "model", q->model);
        if (isfinite(q->max_load))
            cJSON_AddNumberToObject(o, "max_load_kN", q->max_load * 1e-3);
        else
            cJSON_AddNullToObject(o, "max_load_kN");
        cJSON_AddItemToArray(a, o);
    }
    return a;
}

static cJSON *products_json(const forecast_result *r, const char *dir)
{
    cJSON *a = cJSON_CreateArray();
    for (int i = 0; i < r->nproducts && i < FC_MAX_PRODUCTS; i++) {
        char p[4700];
        snprintf(p, sizeof p, "%s/%s", dir, r->products[i]);
        cJSON_AddItemToArray(a, cJSON_CreateString(p));
    }
    return a;
}

static int write_manifest(const struct sph_config *cfg, const cycle_opts *o, const cycle_report *rep,
                          const char *stage, const fetched *f, sph_error *err)
{
    cJSON *m = cJSON_CreateObject();
    char iso[32];
    time_format_iso(o->cycle_time, iso, sizeof iso);
    cJSON_AddStringToObject(m, "cycle", iso);
    cJSON_AddNumberToObject(m, "forecast_hours", o->hours > 0 ? o->hours : cfg->schedule.forecast_hours);
    cJSON_AddStringToObject(m, "start_mode", rep->mode);
    cJSON_AddBoolToObject(m, "stale", rep->stale);
    cJSON_AddBoolToObject(m, "hindcast", o->hindcast);
    cJSON_AddStringToObject(m, "sphice_version", SPHICE_VERSION);
    cJSON_AddStringToObject(m, "config_sha256", cfg->sha256);
    cJSON *src = cJSON_AddArrayToObject(m, "forcing");
    for (size_t i = 0; i < f->nprov; i++)
        cJSON_AddItemToArray(src, cJSON_CreateString(f->prov[i]));
    cJSON_AddItemToObject(m, "result", result_json(&rep->res));
    if (rep->res.loads.on) { /* the ice-load product: its DEM's cost, the latest load per station */
        cJSON_AddItemToObject(m, "timing", cycle_loads_timing_json(&rep->res));
        cJSON_AddItemToObject(m, "loads", cycle_loads_json(&rep->res.loads));
    }
    cJSON_AddItemToObject(m, "scores", cycle_scores_json(&rep->res));
    cJSON *prods = cJSON_AddArrayToObject(m, "products");
    for (int i = 0; i < rep->res.nproducts && i < FC_MAX_PRODUCTS; i++)
        cJSON_AddItemToArray(prods, cJSON_CreateString(rep->res.products[i]));
    char *text = cJSON_Print(m);
    cJSON_Delete(m);
    if (!text)
        return sph_err_set(err, SPH_ERR_NOMEM, "manifest: out of memory");
    char path[4400];
    snprintf(path, sizeof path, "%s/cycle.json", stage);
    int rc = atomic_write_file(path, text, strlen(text), err);
    free(text);
    return rc;
}

static void fsync_dir(const char *dir)
{
    int fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd >= 0) {
        (void)fsync(fd);
        close(fd);
    }
}

/* OUTDIR/latest must be a symbolic link, or absent: a directory or file
 * there cannot be switched atomically, and is not ours to remove. Checked
 * before the cycle runs and again before publishing, so that a cycle
 * either publishes and switches latest or publishes nothing. */
static int check_latest(const char *out_dir, sph_error *err)
{
    char link[4200];
    snprintf(link, sizeof link, "%s/latest", out_dir);
    struct stat st;
    if (lstat(link, &st) != 0) {
        if (errno == ENOENT)
            return SPH_OK;
        return sph_err_set(err, SPH_ERR_IO, "publish: %s: %s", link, strerror(errno));
    }
    if (!S_ISLNK(st.st_mode))
        return sph_err_set(err, SPH_ERR_IO,
                           "publish: %s is a %s, not a symbolic link: move it away (sphice points latest at the "
                           "newest cycle by replacing a symbolic link)",
                           link, S_ISDIR(st.st_mode) ? "directory" : "file");
    return SPH_OK;
}

static int publish(const struct sph_config *cfg, const char *out_dir, const char *stage, const char *cname,
                   double cycle_time, char *final, size_t flen, sph_error *err)
{
    snprintf(final, flen, "%s/%s", out_dir, cname);
    if (fault_point("cycle.publish"))
        return sph_err_set(err, SPH_ERR_IO, "publish %s: injected fault (SPHICE_FAULT=cycle.publish)", final);
    int rc = check_latest(out_dir, err);
    if (rc)
        return rc;
    char old[4200] = "";
    struct stat st;
    if (lstat(final, &st) == 0) {
        /* a re-run (--force, or after a crash between publish and history):
         * the old dir is moved aside, never mixed with the new one */
        snprintf(old, sizeof old, "%s/.old-%s-%ld", out_dir, cname, (long)getpid());
        if (rename(final, old) != 0)
            return sph_err_set(err, SPH_ERR_IO, "publish: rename %s -> %s: %s", final, old, strerror(errno));
    }
    if (rename(stage, final) != 0) {
        int e = errno;
        if (old[0])
            (void)rename(old, final);
        return sph_err_set(err, SPH_ERR_IO, "publish: rename %s -> %s: %s", stage, final, strerror(e));
    }
    fsync_dir(out_dir);
    if (old[0])
        cycle_remove_tree(old);
    /* latest moves forward only: catching up an older cycle leaves it alone */
    char link[4200], target[256];
    snprintf(link, sizeof link, "%s/latest", out_dir);
    ssize_t n = readlink(link, target, sizeof target - 1);
    double cur;
    if (n > 0)
        target[n] = 0;
    if (n <= 0 || cycle_name_parse(target, &cur) != 0 || cur <= cycle_time) {
        if ((rc = atomic_symlink(cname, link, err)))
            return rc;
        fsync_dir(out_dir);
    }
    /* retention: oldest first, never the one `latest` names */
    if (cfg->output.retention_cycles > 0) {
        double *times;
        size_t count = list_published(out_dir, &times);
        n = readlink(link, target, sizeof target - 1);
        if (n > 0)
            target[n] = 0;
        for (size_t i = 0; i + (size_t)cfg->output.retention_cycles < count; i++) {
            char name[32], p[4200];
            cycle_name(times[i], name, sizeof name);
            if (n > 0 && !strcmp(name, target))
                continue;
            snprintf(p, sizeof p, "%s/%s", out_dir, name);
            log_info("retention: removing %s", p);
            cycle_remove_tree(p);
        }
        free(times);
    }
    return SPH_OK;
}

/* --------------------------------------------------------------- cycle */

static void record(history *h, const cycle_report *rep, const char *result)
{
    if (!h)
        return;
    history_run r;
    memset(&r, 0, sizeof r);
    r.cycle = rep->cycle;
    r.started = rep->started;
    r.ended = rep->ended;
    snprintf(r.result, sizeof r.result, "%s", result);
    snprintf(r.message, sizeof r.message, "%s", rep->message);
    r.area_km2 = r.volume_km3 = r.edge_nm = NAN;
    if (!strcmp(result, "ok")) {
        r.area_km2 = rep->res.ice_area_km2;
        r.volume_km3 = rep->res.ice_volume_km3;
        r.edge_nm = rep->res.edge_distance_nm;
        cJSON *s = cycle_scores_json(&rep->res);
        r.scores_json = cJSON_PrintUnformatted(s);
        cJSON_Delete(s);
        cJSON *p = products_json(&rep->res, rep->product_dir);
        r.products_json = cJSON_PrintUnformatted(p);
        cJSON_Delete(p);
    }
    r.stale = rep->stale;
    snprintf(r.mode, sizeof r.mode, "%s", rep->mode);
    sph_error e;
    sph_error_clear(&e);
    if (history_put(h, &r, &e))
        log_error("%s", e.msg);
    history_run_clear(&r);
}

int cycle_run(const struct sph_config *cfg, const cycle_opts *o, forecast_progress *prog,
              const volatile sig_atomic_t *cancel, cycle_report *rep, sph_error *err)
{
    forecast_progress local_prog;
    if (!prog)
        prog = &local_prog;
    memset((void *)prog, 0, sizeof *prog);
    memset(rep, 0, sizeof *rep);
    rep->cycle = o->cycle_time;
    rep->started = time_now();
    rep->ended = NAN;
    rep->res.edge_distance_nm = NAN;
    rep->result = CYCLE_FAILED;
    snprintf(rep->mode, sizeof rep->mode, "none");
    char cname[32];
    cycle_name(o->cycle_time, cname, sizeof cname);
    const char *out_dir = o->out_dir ? o->out_dir : cfg->output.dir;
    double hours = o->hours > 0 ? o->hours : cfg->schedule.forecast_hours;
    int run_fd = -1, cyc_fd = -1, rc;
    char stage[4200] = "", lockp[4200] = "";
    fetched f;
    memset(&f, 0, sizeof f);
    sph_error e;
    sph_error_clear(&e);

    if ((rc = mkdir_p(cfg->paths.state_dir, &e)) || (rc = mkdir_p(out_dir, &e)))
        goto done;
    if (!o->hindcast) {
        snprintf(lockp, sizeof lockp, "%s/run.lock", cfg->paths.state_dir);
        if ((rc = take_lock(lockp, &run_fd, &e)))
            goto done;
    }
    snprintf(lockp, sizeof lockp, "%s/%scycle-%s.lock", cfg->paths.state_dir, o->hindcast ? "hindcast-" : "",
             cname);
    if ((rc = take_lock(lockp, &cyc_fd, &e)))
        goto done;

    if (o->hist && !o->force) {
        history_run prev;
        int found = history_get(o->hist, o->cycle_time, &prev, &e);
        if (found < 0) {
            rc = e.code;
            goto done;
        }
        if (found && (!strcmp(prev.result, "ok") || !strcmp(prev.result, "failed"))) {
            rep->result = CYCLE_SKIPPED;
            rep->skipped_failed = !strcmp(prev.result, "failed");
            if (rep->skipped_failed)
                snprintf(rep->message, sizeof rep->message,
                         "cycle %s already ran and failed (%.700s); --force runs it again", cname,
                         prev.message[0] ? prev.message : "no message");
            else
                snprintf(rep->message, sizeof rep->message, "cycle %s already ran (%s)", cname, prev.result);
            history_run_clear(&prev);
            release_lock(lockp, cyc_fd);
            if (run_fd >= 0)
                close(run_fd);
            return SPH_OK;
        }
        if (found)
            history_run_clear(&prev);
    }
    if ((rc = check_latest(out_dir, &e)))
        goto done;
    snprintf(rep->message, sizeof rep->message, "running");
    record(o->hist, rep, "running");
    sweep_stages(out_dir);
    log_info("cycle %s: started (%g h%s)", cname, hours, o->hindcast ? ", hindcast" : "");

    /* fetch */
    cycle_set_phase(prog, o->cycle_time, FC_PHASE_FETCHING, "forcing");
    if ((rc = fetch_all(cfg, o, cname, &f, rep, cancel, &e)))
        goto done;

    /* start: warm, cold or reinit */
    char warm[4200] = "";
    double warm_mtime = 0;
    int have_warm = cfg->initial.reinit != CFG_REINIT_COLD &&
                    (find_warm_start(out_dir, o->cycle_time, warm, sizeof warm, &warm_mtime) ||
                     (o->hindcast && strcmp(out_dir, cfg->output.dir) &&
                      find_warm_start(cfg->output.dir, o->cycle_time, warm, sizeof warm, &warm_mtime)));
    snprintf(rep->mode, sizeof rep->mode, "%s", have_warm ? "warm" : "cold");
    if (have_warm && cfg->initial.reinit == CFG_REINIT_NEWER_RASTER && cfg->initial.path[0]) {
        char raster[4096];
        struct stat st;
        if (cycle_expand_template(cfg->initial.path, o->cycle_time, raster, sizeof raster, &e) == 0 &&
            stat(raster, &st) == 0 &&
            (double)st.st_mtim.tv_sec + st.st_mtim.tv_nsec * 1e-9 > warm_mtime) {
            have_warm = 0;
            snprintf(rep->mode, sizeof rep->mode, "reinit");
            log_info("cycle %s: raster %s is newer than the warm-start file: re-initialising", cname, raster);
        }
        sph_error_clear(&e);
    }
    char observation[4096] = "";
    if (cfg->observations.path[0] && cfg->output.products.verification) {
        struct stat st;
        if (cycle_expand_template(cfg->observations.path, o->cycle_time + hours * 3600.0, observation,
                                  sizeof observation, &e) != 0 ||
            stat(observation, &st) != 0)
            observation[0] = 0;
        sph_error_clear(&e);
    }

    /* run */
    snprintf(stage, sizeof stage, "%s/.stage-%s-%ld", out_dir, cname, (long)getpid());
    cycle_remove_tree(stage);
    if (mkdir(stage, 0755) != 0) {
        rc = sph_err_set(&e, SPH_ERR_IO, "cycle %s: mkdir %s: %s", cname, stage, strerror(errno));
        goto done;
    }
    forecast_request req;
    memset(&req, 0, sizeof req);
    req.cycle_time = o->cycle_time;
    req.hours = hours;
    req.stage_dir = stage;
    req.warm_start = have_warm ? warm : NULL;
    for (size_t s = 0; s < rep->nsources && s < SPHICE_MAX_SOURCES; s++)
        req.forcing_files[s] = (const char *const *)f.files[s];
    for (size_t i = 0; i < f.nprov && i < SPHICE_MAX_PROVENANCE; i++)
        req.forcing_sha256[i] = f.prov[i];
    req.stale = rep->stale;
    req.observation = observation[0] ? observation : NULL;
    log_info("cycle %s: %s start%s%s", cname, rep->mode, have_warm ? " from " : "", have_warm ? warm : "");
    cycle_set_phase(prog, o->cycle_time, FC_PHASE_INITIALISING, rep->mode);
    cycle_engine_fn fn = (getenv("SPHICE_TEST_ENGINE") || cfg->engine == CFG_ENGINE_TEST_DOUBLE)
                             ? cycle_test_engine
                             : engine_fn;
    if ((rc = fn(cfg, &req, prog, cancel, &rep->res, &e)))
        goto done;
    if (cancel && *cancel) {
        rc = sph_err_set(&e, SPH_ERR_CANCELLED, "cycle %s: cancelled", cname);
        goto done;
    }

    /* write and publish */
    cycle_set_phase(prog, o->cycle_time, FC_PHASE_WRITING, "manifest and publication");
    if ((rc = write_manifest(cfg, o, rep, stage, &f, &e)))
        goto done;
    char mpath[4400];
    struct stat mst;
    snprintf(mpath, sizeof mpath, "%s/manifest.json", stage);
    if (stat(mpath, &mst) == 0) { /* the test engine writes no manifest */
        /* manifest.json (written by the products) also lists what came
         * after it: the restart file and cycle.json */
        const char *more[FC_MAX_PRODUCTS + 2];
        int nm = 0;
        for (int i = 0; i < rep->res.nproducts && i < FC_MAX_PRODUCTS; i++)
            if (strcmp(rep->res.products[i], "manifest.json"))
                more[nm++] = rep->res.products[i];
        more[nm++] = "cycle.json";
        more[nm] = NULL;
        if ((rc = products_manifest_add(stage, more, &e)))
            goto done;
    }
    if ((rc = publish(cfg, out_dir, stage, cname, o->cycle_time, rep->product_dir, sizeof rep->product_dir, &e)))
        goto done;
    stage[0] = 0;
    rep->result = CYCLE_OK;
    snprintf(rep->message, sizeof rep->message, "published %.900s%s", rep->product_dir, rep->stale ? " (stale forcing)" : "");
    if (rep->res.run.solver_unconverged > 0.0) { /* evp.rel_tol: the status's last_run shows it */
        size_t ml = strlen(rep->message);
        snprintf(rep->message + ml, sizeof rep->message - ml,
                 "; warning: %.3g %% of the steps ended unconverged (mEVP relative residual above model.evp.rel_tol, "
                 "largest %.3g)", 100.0 * rep->res.run.solver_unconverged, rep->res.run.solver_residual_max);
        log_warn("cycle %s: %.3g %% of the steps ended with the mEVP relative residual above model.evp.rel_tol "
                 "(largest %.3g): raise model.evp.iterations", cname, 100.0 * rep->res.run.solver_unconverged,
                 rep->res.run.solver_residual_max);
    }

done:
    rep->ended = time_now();
    fetched_free(&f);
    if (stage[0])
        cycle_remove_tree(stage);
    if (rc) {
        rep->result = rc == SPH_ERR_CANCELLED ? CYCLE_CANCELLED : CYCLE_FAILED;
        snprintf(rep->message, sizeof rep->message, "%s", e.msg);
        sph_err_set(err, rc, "%s", e.msg);
        cycle_set_phase(prog, o->cycle_time, FC_PHASE_FAILED, rc == SPH_ERR_CANCELLED ? "cancelled" : e.msg);
        /* a cycle another process holds is not ours to record */
        if (rc != SPH_ERR_LOCKED)
            record(o->hist, rep, rc == SPH_ERR_CANCELLED ? "cancelled" : "failed");
        if (rc == SPH_ERR_CANCELLED)
            log_warn("cycle %s: cancelled; products left as they were", cname);
        else
            log_error("cycle %s: failed: %s", cname,
                      !strncmp(e.msg, "cycle ", 6) && strchr(e.msg, ':') ? strchr(e.msg, ':') + 2 : e.msg);
    } else {
        cycle_set_phase(prog, o->cycle_time, FC_PHASE_DONE, "published");
        record(o->hist, rep, "ok");
        log_info("cycle %s: %s in %.1f s", cname, rep->message, rep->ended - rep->started);
    }
    release_lock(lockp, cyc_fd);
    if (run_fd >= 0)
        close(run_fd);
    ncfile_release_memory(); /* HDF5's free lists: flat memory over cycles (make soak) */
    return rc;
}
