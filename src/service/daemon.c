/* `sphice serve` and `sphice hindcast` (service/daemon.h). */
#include "service/daemon.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <systemd/sd-daemon.h>
#include <time.h>
#include <unistd.h>

#include "io/ncfile.h"
#include "service/config.h"
#include "service/cycle.h"
#include "service/history.h"
#include "service/launch.h"
#include "service/http.h"
#include "service/schedule.h"
#include "service/status_page.h"
#include "util/fileio.h"
#include "util/jsonutil.h"
#include "util/log.h"
#include "util/timeutil.h"
#include "util/version.h"

volatile sig_atomic_t service_term, service_hup;

static void on_term(int sig) { (void)sig; service_term = 1; }
static void on_hup(int sig) { (void)sig; service_hup = 1; }

void service_install_signals(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sigemptyset(&sa.sa_mask);
    sa.sa_handler = on_term;
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
    sa.sa_handler = on_hup;
    sigaction(SIGHUP, &sa, NULL);
    sa.sa_handler = SIG_IGN;
    sigaction(SIGPIPE, &sa, NULL);
}

/* ------------------------------------------------------------ the state */

typedef struct svc {
    pthread_mutex_t lock;          /* guards everything below read by the HTTP thread */
    struct sph_config *cfg;        /* in force; never changed while a cycle runs */
    struct sph_config *pending;    /* valid reloaded config, applied between cycles */
    char config_path[4096];
    char config_error[1024];       /* last reload's problem, "" if none */
    char restart_keys[512];        /* changed keys that need a restart */
    double config_loaded;          /* time of the config in force */
    history *hist;
    http_server *http;
    double started_wall, started_mono, last_tick_mono;
    double next_cycle;
    /* worker */
    pthread_t worker;
    int worker_running;
    volatile int worker_done;
    volatile sig_atomic_t cancel;
    cycle_opts wopts;
    cycle_report wrep;
    sph_error werr;
    int wrc;
    forecast_progress prog;
    double current_cycle, current_started;
    /* last finished cycle of this process */
    int have_last;
    cycle_report last;
    double retry_after_mono;       /* after a lock conflict */
} svc;

static const char *phase_name(int phase)
{
    switch (phase) {
    case FC_PHASE_FETCHING: return "fetching";
    case FC_PHASE_INITIALISING:
    case FC_PHASE_RUNNING: return "running";
    case FC_PHASE_WRITING: return "writing";
    case FC_PHASE_DONE: return "writing";
    case FC_PHASE_FAILED: return "failed";
    default: return "idle";
    }
}

static const char *result_name(int r)
{
    switch (r) {
    case CYCLE_OK: return "ok";
    case CYCLE_FAILED: return "failed";
    case CYCLE_CANCELLED: return "cancelled";
    default: return "skipped";
    }
}

/* Caller holds the lock. */
static const char *state_name(const svc *s)
{
    if (s->worker_running)
        return phase_name(s->prog.phase);
    if (s->have_last && s->last.result == CYCLE_FAILED)
        return "failed";
    if (s->have_last && s->last.result == CYCLE_CANCELLED)
        return "cancelled";
    return "idle";
}

static int scheduler_alive(const svc *s) { return time_monotonic() - s->last_tick_mono < 10.0; }

/* ------------------------------------------------------------- routes */

#define STATUS_RECENT_RUNS 10 /* cycles of the history in /status (the page's table) */

static char *status_json(svc *s)
{
    cJSON *root = cJSON_CreateObject();
    pthread_mutex_lock(&s->lock);
    cJSON *sv = cJSON_AddObjectToObject(root, "service");
    cJSON_AddStringToObject(sv, "state", state_name(s));
    cJSON_AddStringToObject(sv, "version", SPHICE_VERSION);
    cJSON_AddStringToObject(sv, "git", SPHICE_GIT);
    cJSON_AddNumberToObject(sv, "pid", (double)getpid());
    json_add_time(sv, "started", s->started_wall);
    cJSON_AddNumberToObject(sv, "uptime_s", time_monotonic() - s->started_mono);
    cJSON_AddBoolToObject(sv, "scheduler_alive", scheduler_alive(s));
    cJSON_AddStringToObject(sv, "config_file", s->config_path);
    cJSON_AddStringToObject(sv, "config_sha256", s->cfg->sha256);
    json_add_time(sv, "config_loaded", s->config_loaded);
    if (s->config_error[0])
        cJSON_AddStringToObject(sv, "config_error", s->config_error);
    else
        cJSON_AddNullToObject(sv, "config_error");
    cJSON_AddStringToObject(sv, "restart_required_for", s->restart_keys);
    cJSON_AddBoolToObject(sv, "reload_pending", s->pending != NULL);

    if (s->worker_running) {
        cJSON *cur = cJSON_AddObjectToObject(root, "current");
        json_add_time(cur, "cycle", s->current_cycle);
        json_add_time(cur, "started", s->current_started);
        cJSON_AddStringToObject(cur, "phase", phase_name(s->prog.phase));
        if (s->cfg->launcher.command[0]) /* a launched job: its progress is in its own log */
            cJSON_AddStringToObject(cur, "launcher", s->cfg->launcher.command);
        json_add_time(cur, "model_time", s->prog.model_time > 0 ? s->prog.model_time : NAN);
        cJSON_AddNumberToObject(cur, "percent", s->prog.percent);
        cJSON_AddNumberToObject(cur, "particles", (double)s->prog.particles);
        cJSON *rg = cJSON_AddObjectToObject(cur, "regimes");
        cJSON_AddNumberToObject(rg, "free_drift", s->prog.frac_free_drift);
        cJSON_AddNumberToObject(rg, "rheology", s->prog.frac_rheology);
        cJSON_AddNumberToObject(rg, "zero_layer", s->prog.frac_zero_layer);
        cJSON_AddNumberToObject(rg, "multi_layer", s->prog.frac_multi_layer);
        if (s->prog.dt > 0) {
            cJSON_AddNumberToObject(cur, "dt", s->prog.dt);
            cJSON_AddStringToObject(cur, "dt_policy", s->prog.dt_auto ? "auto" : "configured");
        }
    } else {
        cJSON_AddNullToObject(root, "current");
    }
    json_add_time(root, "next_cycle", s->next_cycle);
    if (s->have_last) {
        cJSON *fc = cJSON_AddArrayToObject(root, "forcing");
        for (size_t i = 0; i < s->last.nsources; i++) {
            cJSON *o = cJSON_CreateObject();
            cJSON_AddStringToObject(o, "name", s->last.source_name[i]);
            json_add_num(o, "age_hours", s->last.source_age_h[i]);
            json_add_time(o, "issue", isfinite(s->last.source_age_h[i])
                                     ? s->last.cycle - s->last.source_age_h[i] * 3600.0
                                     : NAN);
            cJSON_AddItemToArray(fc, o);
        }
    } else {
        cJSON_AddArrayToObject(root, "forcing");
    }
    char out_dir[4096];
    snprintf(out_dir, sizeof out_dir, "%s", s->cfg->output.dir);
    pthread_mutex_unlock(&s->lock);

    char *last = history_last_finished_json(s->hist, NULL);
    cJSON *lj = last ? cJSON_Parse(last) : NULL;
    free(last);
    cJSON_AddItemToObject(root, "last_run", lj ? lj : cJSON_CreateNull());
    /* the status page's: the last cycles (cycle, result, duration, ice
     * area, edge distance, stale, start mode: /runs has the rest) and the
     * latest published cycle's maps and edge */
    char *recent = history_recent_json(s->hist, STATUS_RECENT_RUNS);
    cJSON *rj = recent ? cJSON_Parse(recent) : NULL, *r;
    free(recent);
    static const char *const drop[] = {"products", "scores", "message", "started", "ended", "ice_volume_km3"};
    cJSON_ArrayForEach(r, rj) {
        for (size_t k = 0; k < sizeof drop / sizeof drop[0]; k++)
            cJSON_DeleteItemFromObjectCaseSensitive(r, drop[k]);
    }
    cJSON_AddItemToObject(root, "recent", rj ? rj : cJSON_CreateArray());
    cJSON_AddItemToObject(root, "latest", status_latest_json(out_dir));
    char *text = cJSON_PrintUnformatted(root);
    cJSON_Delete(root);
    return text;
}

/* The configuration in force, every key with its effective value. */
static char *config_json(svc *s)
{
    pthread_mutex_lock(&s->lock);
    char *text = sph_config_to_json(s->cfg);
    pthread_mutex_unlock(&s->lock);
    return text;
}

static int last_ok(svc *s, history_run *r, int *have)
{
    char *j = history_last_finished_json(s->hist, r);
    *have = j != NULL;
    free(j);
    return *have && !strcmp(r->result, "ok");
}

static char *health_text(svc *s, int *code)
{
    history_run r;
    int have;
    int ok = last_ok(s, &r, &have);
    pthread_mutex_lock(&s->lock);
    int alive = scheduler_alive(s);
    pthread_mutex_unlock(&s->lock);
    *code = ok && alive ? 200 : 503;
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "health", *code == 200 ? "ok" : "unhealthy");
    cJSON_AddBoolToObject(o, "scheduler_alive", alive);
    cJSON_AddStringToObject(o, "last_result", have ? r.result : "none");
    if (have)
        history_run_clear(&r);
    char *t = cJSON_Print(o);
    cJSON_Delete(o);
    return t;
}

typedef struct sbuf { char *p; size_t n, cap; } sbuf;

static void sb_vadd(sbuf *b, const char *fmt, va_list ap) __attribute__((format(printf, 2, 0)));
static void sb_vadd(sbuf *b, const char *fmt, va_list ap)
{
    for (;;) {
        size_t room = b->cap - b->n;
        va_list aq;
        va_copy(aq, ap);
        int w = b->p ? vsnprintf(b->p + b->n, room, fmt, aq) : -1;
        va_end(aq);
        if (w >= 0 && (size_t)w < room) {
            b->n += (size_t)w;
            return;
        }
        size_t cap = b->cap ? b->cap * 2 : 4096;
        if (w >= 0 && cap < b->n + (size_t)w + 1)
            cap = b->n + (size_t)w + 1;
        char *g = realloc(b->p, cap);
        if (!g)
            return;
        b->p = g;
        b->cap = cap;
    }
}

static void sb_add(sbuf *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void sb_add(sbuf *b, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    sb_vadd(b, fmt, ap);
    va_end(ap);
}

/* One gauge family in the Prometheus text format: HELP, TYPE, its sample. */
static void gauge(sbuf *b, const char *name, const char *help, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
static void gauge(sbuf *b, const char *name, const char *help, const char *fmt, ...)
{
    sb_add(b, "# HELP %s %s\n# TYPE %s gauge\n%s ", name, help, name, name);
    va_list ap;
    va_start(ap, fmt);
    sb_vadd(b, fmt, ap);
    va_end(ap);
    sb_add(b, "\n");
}

static char *metrics_text(svc *s)
{
    sbuf b = {0};
    history_run r;
    int have;
    int ok = last_ok(s, &r, &have);
    pthread_mutex_lock(&s->lock);
    gauge(&b, "sphice_up", "1 while the service runs.", "1");
    gauge(&b, "sphice_uptime_seconds", "Seconds since the service started.", "%.3f",
          time_monotonic() - s->started_mono);
    gauge(&b, "sphice_scheduler_alive", "1 if the scheduler ticked in the last 10 s.", "%d", scheduler_alive(s));
    gauge(&b, "sphice_cycle_running", "1 while a cycle runs.", "%d", s->worker_running);
    gauge(&b, "sphice_run_progress_percent", "Progress of the running cycle in percent (0 when none runs).",
          "%.2f", s->worker_running ? s->prog.percent : 0.0);
    if (isfinite(s->next_cycle))
        gauge(&b, "sphice_next_cycle_timestamp_seconds", "Time of the next scheduled cycle (Unix time).", "%.0f",
              s->next_cycle);
    gauge(&b, "sphice_config_reload_failed", "1 if the last reload was refused (invalid configuration).", "%d",
          s->config_error[0] != 0);
    pthread_mutex_unlock(&s->lock);
    gauge(&b, "sphice_last_run_success", "1 if the last finished cycle succeeded.", "%d", ok);
    if (have) {
        if (isfinite(r.ended) && isfinite(r.started))
            gauge(&b, "sphice_last_run_duration_seconds", "Wall time of the last finished cycle.", "%.3f",
                  r.ended - r.started);
        gauge(&b, "sphice_last_run_cycle_timestamp_seconds", "Cycle time of the last finished cycle (Unix time).",
              "%.0f", r.cycle);
        gauge(&b, "sphice_last_run_stale", "1 if the last finished cycle ran on stale forcing.", "%d", r.stale);
        if (isfinite(r.area_km2))
            gauge(&b, "sphice_ice_area_km2", "Ice area of the last finished cycle, km2.", "%.6g", r.area_km2);
        if (isfinite(r.volume_km3))
            gauge(&b, "sphice_ice_volume_km3", "Ice volume of the last finished cycle, km3.", "%.6g", r.volume_km3);
        if (isfinite(r.edge_nm))
            gauge(&b, "sphice_edge_distance_nm", "Ice edge distance of the last finished cycle, nautical miles.",
                  "%.6g", r.edge_nm);
        history_run_clear(&r);
    }
    static const char *results[] = {"ok", "failed", "cancelled", "interrupted"};
    /* a gauge, not a counter (an interrupted cycle that runs again becomes
     * ok), so no _total suffix */
    sb_add(&b, "# HELP sphice_runs Cycles in the history by result.\n# TYPE sphice_runs gauge\n");
    for (size_t i = 0; i < 4; i++)
        sb_add(&b, "sphice_runs{result=\"%s\"} %ld\n", results[i], history_count(s->hist, results[i]));
    return b.p;
}

static char *route(void *ctx, const char *path, int *code, const char **ctype)
{
    svc *s = ctx;
    *code = 200;
    *ctype = "application/json";
    if (!strcmp(path, "/")) {
        *ctype = "text/html; charset=utf-8";
        return strdup(status_page_html());
    }
    if (!strncmp(path, "/latest/", 8)) {
        char out_dir[4096];
        pthread_mutex_lock(&s->lock);
        snprintf(out_dir, sizeof out_dir, "%s", s->cfg->output.dir);
        pthread_mutex_unlock(&s->lock);
        size_t len = 0;
        char *b = status_latest_file(out_dir, path + 8, &len, ctype);
        if (b)
            http_set_body_length(len);
        return b;
    }
    if (!strcmp(path, "/status"))
        return status_json(s);
    if (!strcmp(path, "/config"))
        return config_json(s);
    if (!strcmp(path, "/runs"))
        return history_recent_json(s->hist, 50);
    if (!strcmp(path, "/health"))
        return health_text(s, code);
    if (!strcmp(path, "/metrics")) {
        *ctype = "text/plain; version=0.0.4";
        return metrics_text(s);
    }
    return NULL;
}

/* ------------------------------------------------------------ the worker */

static void *worker_main(void *arg)
{
    svc *s = arg;
    ncfile_thread_quiet(); /* HDF5's error printing is per thread */
    sph_error_clear(&s->werr);
    /* the configuration cannot change under the worker: a reload waits for it (apply_pending) */
    if (s->cfg->launcher.command[0])
        s->wrc = launch_cycle(s->cfg, &s->wopts, &s->prog, &s->cancel, &s->wrep, &s->werr);
    else
        s->wrc = cycle_run(s->cfg, &s->wopts, &s->prog, &s->cancel, &s->wrep, &s->werr);
    __atomic_store_n(&s->worker_done, 1, __ATOMIC_RELEASE);
    return NULL;
}

/* Starts a worker thread with the service signals blocked in it. */
static int start_worker(svc *s, double cycle)
{
    memset(&s->wopts, 0, sizeof s->wopts);
    s->wopts.cycle_time = cycle;
    s->wopts.hist = s->hist;
    s->cancel = 0;
    s->worker_done = 0;
    memset((void *)&s->prog, 0, sizeof s->prog);
    sigset_t block, old;
    sigemptyset(&block);
    sigaddset(&block, SIGTERM);
    sigaddset(&block, SIGINT);
    sigaddset(&block, SIGHUP);
    pthread_sigmask(SIG_BLOCK, &block, &old);
    pthread_mutex_lock(&s->lock);
    s->current_cycle = cycle;
    s->current_started = time_now();
    int rc = pthread_create(&s->worker, NULL, worker_main, s);
    if (rc == 0)
        s->worker_running = 1;
    pthread_mutex_unlock(&s->lock);
    pthread_sigmask(SIG_SETMASK, &old, NULL);
    if (rc) {
        log_error("cannot start the cycle thread: %s", strerror(rc));
        return -1;
    }
    return 0;
}

static void apply_pending(svc *s)
{
    pthread_mutex_lock(&s->lock);
    if (s->pending && !s->worker_running) {
        sph_config_free(s->cfg);
        s->cfg = s->pending;
        s->pending = NULL;
        s->config_loaded = time_now();
        sph_log_level = config_log_level(s->cfg);
        log_info("configuration %s applied", s->config_path);
    }
    pthread_mutex_unlock(&s->lock);
}

static void collect_worker(svc *s)
{
    pthread_join(s->worker, NULL);
    pthread_mutex_lock(&s->lock);
    s->worker_running = 0;
    if (s->wrep.result != CYCLE_SKIPPED) {
        s->last = s->wrep;
        s->have_last = 1;
    }
    if (s->wrc == SPH_ERR_LOCKED)
        s->retry_after_mono = time_monotonic() + 10;
    pthread_mutex_unlock(&s->lock);
    apply_pending(s);
}

static void reload(svc *s)
{
    struct sph_config *fresh = NULL;
    sph_error e;
    sph_error_clear(&e);
    sd_notify(0, "RELOADING=1");
    if (sph_config_load(s->config_path, &fresh, &e)) {
        log_error("reload refused, keeping the running configuration: %s", e.msg);
        pthread_mutex_lock(&s->lock);
        snprintf(s->config_error, sizeof s->config_error, "%s", e.msg);
        pthread_mutex_unlock(&s->lock);
        sd_notify(0, "READY=1\nSTATUS=reload refused: invalid configuration (see /status)");
        return;
    }
    pthread_mutex_lock(&s->lock);
    char changed[512];
    if (sph_config_keep_unreloadable(fresh, s->cfg, changed, sizeof changed))
        log_warn("reload: %s changed; the running value is kept until restart", changed);
    snprintf(s->restart_keys, sizeof s->restart_keys, "%s", changed);
    s->config_error[0] = 0;
    sph_config_free(s->pending);
    s->pending = fresh;
    int running = s->worker_running;
    pthread_mutex_unlock(&s->lock);
    if (running)
        log_info("reload: valid; applied when the running cycle ends");
    apply_pending(s);
    sd_notify(0, "READY=1");
}

static int runnable(svc *s, double cycle)
{
    history_run r;
    sph_error e;
    sph_error_clear(&e);
    int found = history_get(s->hist, cycle, &r, &e);
    if (found < 0) {
        log_error("%s", e.msg);
        return 0;
    }
    if (!found)
        return 1;
    int ok = !strcmp(r.result, "interrupted") || !strcmp(r.result, "cancelled");
    history_run_clear(&r);
    return ok;
}

/* The cycle to run now, or NaN. Missed cycles: oldest first when catching up. */
static double due_cycle(svc *s)
{
    const struct sph_config *c = s->cfg;
    double now = time_now();
    double latest = schedule_prev(c, now);
    if (!c->schedule.catch_up)
        return runnable(s, latest) ? latest : NAN;
    double done = history_last_done(s->hist);
    double oldest = now - c->schedule.catch_up_hours * 3600.0;
    double pick = NAN;
    double t = latest;
    for (int i = 0; i < 1000 && t >= oldest && (!isfinite(done) || t > done); i++) {
        if (runnable(s, t))
            pick = t;
        t = schedule_prev(c, t - 1);
    }
    if (!isfinite(pick) && runnable(s, latest) && (isfinite(done) && latest > done))
        pick = latest;
    /* an interrupted or cancelled latest cycle is always run again */
    if (!isfinite(pick) && runnable(s, latest))
        pick = latest;
    return pick;
}

static void notify_status(svc *s)
{
    char buf[512], next[32] = "none";
    pthread_mutex_lock(&s->lock);
    if (isfinite(s->next_cycle))
        time_format_iso(s->next_cycle, next, sizeof next);
    if (s->worker_running) {
        char cyc[32];
        time_format_iso(s->current_cycle, cyc, sizeof cyc);
        snprintf(buf, sizeof buf, "STATUS=cycle %s %s %.0f%%", cyc, phase_name(s->prog.phase), s->prog.percent);
    } else if (s->have_last) {
        char cyc[32];
        time_format_iso(s->last.cycle, cyc, sizeof cyc);
        snprintf(buf, sizeof buf, "STATUS=%s; last cycle %s %s; next %s", state_name(s), cyc,
                 result_name(s->last.result), next);
    } else {
        snprintf(buf, sizeof buf, "STATUS=idle; next cycle %s", next);
    }
    pthread_mutex_unlock(&s->lock);
    sd_notify(0, buf);
}

/* One `sphice serve` per state directory: state_dir/serve.lock, flock'ed
 * before the daemon changes anything and held (by the open descriptor)
 * until it exits; it holds the pid for the message of a second one. */
static int take_serve_lock(const char *state_dir, int *fd_out, sph_error *err)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/serve.lock", state_dir);
    int fd = open(path, O_CREAT | O_RDWR | O_CLOEXEC, 0644);
    if (fd < 0)
        return sph_err_set(err, SPH_ERR_IO, "lock %s: %s", path, strerror(errno));
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
        int en = errno;
        char pid[24] = "";
        ssize_t n = pread(fd, pid, sizeof pid - 1, 0);
        pid[n > 0 ? n : 0] = 0;
        pid[strcspn(pid, "\n")] = 0;
        close(fd);
        if (en == EWOULDBLOCK)
            return sph_err_set(err, SPH_ERR_LOCKED, "lock %s: held by another sphice serve%s%s%s; not starting",
                               path, pid[0] ? " (pid " : "", pid, pid[0] ? ")" : "");
        return sph_err_set(err, SPH_ERR_IO, "lock %s: %s", path, strerror(en));
    }
    char pid[24];
    int l = snprintf(pid, sizeof pid, "%ld\n", (long)getpid());
    if (ftruncate(fd, 0) == 0)
        (void)!pwrite(fd, pid, (size_t)l, 0);
    *fd_out = fd;
    return SPH_OK;
}

/* Marks the rows a dead process left `running` as interrupted, unless a
 * cycle runs in another process right now (`sphice run` holds
 * state_dir/run.lock, service/cycle.c, for its whole cycle: its row is
 * live). Returns 1 when done, 0 to try again on a later tick. */
static int mark_interrupted(svc *s)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/run.lock", s->cfg->paths.state_dir);
    int fd = open(path, O_CREAT | O_RDWR | O_CLOEXEC, 0644);
    if (fd >= 0 && flock(fd, LOCK_EX | LOCK_NB) != 0) {
        close(fd);
        return 0;
    }
    sph_error e;
    sph_error_clear(&e);
    int n = history_mark_interrupted(s->hist, &e);
    if (fd >= 0)
        close(fd);
    if (n > 0)
        log_warn("%d cycle(s) were interrupted by the previous process; they will run again", n);
    else if (n < 0)
        log_error("%s", e.msg);
    return 1;
}

int service_serve(const char *config_path, const char *listen)
{
    svc s;
    memset(&s, 0, sizeof s);
    pthread_mutex_init(&s.lock, NULL);
    s.next_cycle = NAN;
    snprintf(s.config_path, sizeof s.config_path, "%s", config_path);
    sph_error e;
    sph_error_clear(&e);
    if (sph_config_load(config_path, &s.cfg, &e)) {
        log_error("%s", e.msg);
        return 1;
    }
    if (listen && !s.cfg->status.enabled) {
        log_error("serve --listen %s: the status server is off (status.enabled is false in %s); "
                  "set it to true or drop --listen",
                  listen, config_path);
        sph_config_free(s.cfg);
        return 2;
    }
    sph_log_level = config_log_level(s.cfg);
    s.config_loaded = s.started_wall = time_now();
    s.started_mono = s.last_tick_mono = time_monotonic();
    service_install_signals();

    /* order: the daemon's lock, the history, the port; only then are the
     * runs of a dead process marked (a second daemon that fails changes nothing) */
    char dbpath[4200];
    int serve_fd = -1;
    snprintf(dbpath, sizeof dbpath, "%s/history.sqlite", s.cfg->paths.state_dir);
    if (mkdir_p(s.cfg->paths.state_dir, &e) || take_serve_lock(s.cfg->paths.state_dir, &serve_fd, &e) ||
        history_open(&s.hist, dbpath, &e)) {
        log_error("%s", e.msg);
        if (serve_fd >= 0)
            close(serve_fd);
        sph_config_free(s.cfg);
        return 1;
    }

    if (s.cfg->status.enabled) {
        const char *where = listen ? listen : s.cfg->status.listen;
        int rc = http_start(&s.http, where, s.cfg->status.max_connections, s.cfg->status.per_ip_limit, route,
                            &s, &e);
        if (rc) {
            log_error("%s", e.msg);
            history_close(s.hist);
            close(serve_fd);
            sph_config_free(s.cfg);
            return 1;
        }
        log_info("status on %s (port %d)", where, http_port(s.http));
    }
    int marked = mark_interrupted(&s);
    if (!marked)
        log_info("a cycle runs in another sphice process (%s/run.lock held): runs left running are marked "
                 "interrupted when it ends",
                 s.cfg->paths.state_dir);

    uint64_t wd_usec = 0;
    int wd = sd_watchdog_enabled(0, &wd_usec) > 0;
    double wd_last = 0, status_last = 0;
    log_info("sphice %s serving %s (pid %ld)", SPHICE_VERSION, config_path, (long)getpid());
    sd_notifyf(0, "READY=1\nMAINPID=%ld", (long)getpid());

    int term_logged = 0, was_running = -1;
    for (;;) {
        double mono = time_monotonic();
        pthread_mutex_lock(&s.lock);
        s.last_tick_mono = mono;
        pthread_mutex_unlock(&s.lock);
        if (wd && mono - wd_last >= wd_usec / 2e6) {
            sd_notify(0, "WATCHDOG=1");
            wd_last = mono;
        }
        if (s.worker_running && __atomic_load_n(&s.worker_done, __ATOMIC_ACQUIRE))
            collect_worker(&s);
        if (service_term) {
            if (!term_logged++) {
                sd_notify(0, "STOPPING=1");
                log_info("SIGTERM: stopping%s", s.worker_running ? "; cancelling the running cycle" : "");
            }
            if (!s.worker_running)
                break;
            s.cancel = 1;
        } else {
            if (service_hup) {
                service_hup = 0;
                log_info("SIGHUP: reloading %s", s.config_path);
                reload(&s);
            }
            if (!marked && !s.worker_running)
                marked = mark_interrupted(&s);
            if (marked && !s.worker_running && mono >= s.retry_after_mono) {
                double due = due_cycle(&s);
                if (isfinite(due))
                    start_worker(&s, due);
            }
            double next = schedule_next(s.cfg, time_now());
            pthread_mutex_lock(&s.lock);
            s.next_cycle = next;
            pthread_mutex_unlock(&s.lock);
        }
        if (mono - status_last >= 5 || s.worker_running != was_running) {
            notify_status(&s);
            status_last = mono;
            was_running = s.worker_running;
        }
        struct timespec ts = {0, 100 * 1000 * 1000};
        nanosleep(&ts, NULL);
    }
    http_stop(s.http);
    history_close(s.hist);
    close(serve_fd);
    sph_config_free(s.pending);
    sph_config_free(s.cfg);
    pthread_mutex_destroy(&s.lock);
    log_info("stopped");
    return 0;
}

/* -------------------------------------------------------------- hindcast */

int service_hindcast(const struct sph_config *cfg, double from, double to, const char *out_dir, int force,
                     sph_error *err)
{
    char dir[4200], dbpath[4200];
    if (out_dir)
        snprintf(dir, sizeof dir, "%s", out_dir);
    else if (cfg->paths.hindcast_dir[0])
        snprintf(dir, sizeof dir, "%s", cfg->paths.hindcast_dir);
    else
        snprintf(dir, sizeof dir, "%s/hindcast", cfg->output.dir);
    if (mkdir_p(cfg->paths.state_dir, err) || mkdir_p(dir, err))
        return -1;
    snprintf(dbpath, sizeof dbpath, "%s/hindcast.sqlite", cfg->paths.state_dir);
    history *h = NULL;
    if (history_open(&h, dbpath, err))
        return -1;
    history_mark_interrupted(h, err);
    int failed = 0, ran = 0;
    for (double t = schedule_next(cfg, from - 1); t <= to && !service_term; t = schedule_next(cfg, t)) {
        cycle_opts o;
        memset(&o, 0, sizeof o);
        o.cycle_time = t;
        o.out_dir = dir;
        o.hindcast = 1;
        o.force = force;
        o.hist = h;
        cycle_report rep;
        sph_error e;
        sph_error_clear(&e);
        int rc = cycle_run(cfg, &o, NULL, &service_term, &rep, &e);
        char iso[32];
        time_format_iso(t, iso, sizeof iso);
        if (rc)
            failed++;
        else if (rep.result == CYCLE_OK)
            ran++;
        printf("%s %s %s%s%s\n", iso, rc ? "failed" : result_name(rep.result), rep.mode,
               rep.stale ? " stale" : "", rc ? "" : "");
        if (rc)
            printf("  %s\n", e.msg);
        else if (rep.res.has_scores)
            printf("  IIEE %.1f km2, edge displacement %.1f km\n", rep.res.iiee_km2, rep.res.edge_displacement_km);
        fflush(stdout);
    }
    history_close(h);
    log_info("hindcast: %d cycle(s) published, %d failed, into %s", ran, failed, dir);
    return failed;
}
