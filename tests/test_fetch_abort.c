/* Downloads that must be abandoned, against a server on 127.0.0.1 that
 * trickles one byte per second (libmicrohttpd, a thread per connection):
 *   - the low-speed limit (fetch.low_speed_bytes / fetch.low_speed_s)
 *     abandons the transfer in the configured time;
 *   - a cancel during a transfer, and during a retry backoff sleep, returns
 *     within 1 s of the cancellation (SPH_ERR_CANCELLED, no .part left);
 *   - the cycle passes its cancel flag to the download;
 *   - a `.part` left by `sphice run` killed with -9 during a download is
 *     swept by the next `sphice run`;
 *   - `sphice serve` given SIGTERM while its cycle downloads exits 0
 *     within 1 s.
 * Times are measured with the monotonic clock and printed. */
#include "io/fetch.h"
#include "service/config.h"
#include "service/cycle.h"

#include <dirent.h>
#include <fcntl.h>
#include <microhttpd.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "util/fileio.h"
#include "util/timeutil.h"

#include "check.h"
#include "era5_file.h"

static char tmp[256];
static char *good;
static size_t good_len;
static atomic_int stopping, hits_500, serve_good;

static void nap(double s)
{
    struct timespec ts = {(time_t)s, (long)((s - (double)(time_t)s) * 1e9)};
    nanosleep(&ts, NULL);
}

/* One byte per second. */
static ssize_t trickle(void *cls, uint64_t pos, char *buf, size_t max)
{
    (void)cls;
    for (int k = 0; k < 20; k++) {
        if (atomic_load(&stopping))
            return MHD_CONTENT_READER_END_WITH_ERROR;
        nap(0.05);
    }
    if (pos >= good_len || max < 1)
        return MHD_CONTENT_READER_END_OF_STREAM;
    buf[0] = good[pos];
    return 1;
}

static enum MHD_Result handler(void *cls, struct MHD_Connection *c, const char *url, const char *method,
                               const char *version, const char *data, size_t *size, void **ptr)
{
    (void)cls; (void)method; (void)version; (void)data; (void)size;
    static int first;
    if (*ptr != &first) { /* headers only: answer on the second call */
        *ptr = &first;
        return MHD_YES;
    }
    struct MHD_Response *r;
    unsigned code = MHD_HTTP_OK;
    if (!strcmp(url, "/e500.nc")) {
        atomic_fetch_add(&hits_500, 1);
        static char msg[] = "server error";
        r = MHD_create_response_from_buffer(strlen(msg), msg, MHD_RESPMEM_PERSISTENT);
        code = MHD_HTTP_INTERNAL_SERVER_ERROR;
    } else if (!strncmp(url, "/switch_", 8) && atomic_load(&serve_good)) {
        r = MHD_create_response_from_buffer(good_len, good, MHD_RESPMEM_PERSISTENT);
    } else {
        r = MHD_create_response_from_callback(good_len, 1, trickle, NULL, NULL);
    }
    enum MHD_Result ret = MHD_queue_response(c, code, r);
    MHD_destroy_response(r);
    return ret;
}

static volatile sig_atomic_t cancel_flag;
static double cancel_after, cancelled_at;

static void *canceller(void *arg)
{
    (void)arg;
    nap(cancel_after);
    cancelled_at = time_monotonic();
    cancel_flag = 1;
    return NULL;
}

static int count_parts(const char *dir, char *first, size_t len)
{
    int n = 0;
    DIR *d = opendir(dir);
    if (!d)
        return 0;
    struct dirent *e;
    while ((e = readdir(d)))
        if (strstr(e->d_name, ".part.")) {
            if (!n++ && first)
                snprintf(first, len, "%s", e->d_name);
        }
    closedir(d);
    return n;
}

static fetch_options options(const char *cache, int retries, double backoff_s)
{
    fetch_options o;
    fetch_options_default(&o);
    o.cache_dir = cache;
    o.retries = retries;
    o.backoff_s = backoff_s;
    return o;
}

/* fetch_url with a cancel set cancel_after s in; returns the seconds from
 * the cancellation to the return. */
static double fetch_cancelled(const char *url, fetch_options *o, sph_error *e)
{
    char local[4096];
    cancel_flag = 0;
    o->cancel = &cancel_flag;
    pthread_t th;
    pthread_create(&th, NULL, canceller, NULL);
    sph_error_clear(e);
    int rc = fetch_url(url, o, local, sizeof local, NULL, e);
    double back = time_monotonic();
    pthread_join(th, NULL);
    CHECK(rc == SPH_ERR_CANCELLED, "cancelled download fails as cancelled: rc %d %s", rc, e->msg);
    return back - cancelled_at;
}

/* A configuration for `sphice run` / `sphice serve` whose forcing is
 * http://127.0.0.1:PORT/NAME_%Y%m%d%H.nc, cache in cache, written to
 * tmp/run.json (its path in path). */
static void write_config(char *path, size_t len, int port, const char *name, const char *cache,
                         const char *schedule)
{
    snprintf(path, len, "%s/run.json", tmp);
    char text[4096];
    int n = snprintf(text, sizeof text,
                     "{\"engine\": \"test-double\", \"test\": {\"engine_seconds\": 0.01},"
                     " \"domain\": {\"lon_min\": 119, \"lon_max\": 122, \"lat_min\": 38, \"lat_max\": 41},"
                     " \"forcing\": [{\"name\": \"atm\", \"kind\": \"atmosphere\","
                     "   \"urls\": \"http://127.0.0.1:%d/%s_%%Y%%m%%d%%H.nc\", \"issue_hours\": 24}],"
                     " \"output\": {\"dir\": \"%s/out-%s\"}, \"status\": {\"enabled\": false},"
                     " \"schedule\": {\"late_data\": {\"wait_minutes\": 0, \"policy\": \"fail\"}%s},"
                     " \"paths\": {\"state_dir\": \"%s/state-%s\", \"cache_dir\": \"%s\"}}\n",
                     port, name, tmp, name, schedule, tmp, name, cache);
    CHECK(atomic_write_file(path, text, (size_t)n, NULL) == 0, "wrote %s", path);
}

/* Starts `sphice CMD CONFIG` (run: for 2024-02-08T00Z) and waits up to 10 s
 * until its download has a .part file in cache (named in part). */
static pid_t start_download(const char *exe, const char *cmd, const char *cfgp, const char *logp,
                            const char *cache, char *part, size_t len)
{
    pid_t pid = fork();
    if (pid == 0) {
        int fd = open(logp, O_CREAT | O_WRONLY | O_APPEND, 0644);
        if (fd >= 0) {
            dup2(fd, 1);
            dup2(fd, 2);
        }
        if (!strcmp(cmd, "run"))
            execl(exe, exe, "run", cfgp, "--cycle", "2024-02-08T00:00Z", (char *)NULL);
        else
            execl(exe, exe, cmd, cfgp, (char *)NULL);
        _exit(127);
    }
    part[0] = '\0';
    double end = time_monotonic() + 10;
    while (time_monotonic() < end && count_parts(cache, part, len) == 0)
        nap(0.05);
    CHECK(part[0] != '\0', "sphice %s: the running download has a .part file", cmd);
    return pid;
}

int main(void)
{
    signal(SIGPIPE, SIG_IGN);
    snprintf(tmp, sizeof tmp, "/tmp/sphice-fetch-abort-XXXXXX");
    if (!mkdtemp(tmp))
        return 1;
    good = era5_wind_file(tmp, "era5.nc", 1, &good_len);
    CHECK(good != NULL, "test file written");

    struct MHD_Daemon *d = MHD_start_daemon(MHD_USE_THREAD_PER_CONNECTION | MHD_USE_INTERNAL_POLLING_THREAD,
                                            0, NULL, NULL, &handler, NULL, MHD_OPTION_END);
    CHECK(d != NULL, "server started");
    if (!d)
        return check_summary("test_fetch_abort");
    int port = MHD_get_daemon_info(d, MHD_DAEMON_INFO_BIND_PORT)->port;
    char url[256], cache[400];
    snprintf(cache, sizeof cache, "%s/cache", tmp);
    sph_error e;

    /* 1. the low-speed limit: 1 byte/s is under 100 bytes/s; abandoned after 2 s */
    {
        fetch_options o = options(cache, 0, 5);
        o.timeout_s = 60;
        o.low_speed_bytes = 100;
        o.stall_timeout_s = 2;
        snprintf(url, sizeof url, "http://127.0.0.1:%d/trickle.nc", port);
        char local[4096];
        sph_error_clear(&e);
        double t0 = time_monotonic();
        int rc = fetch_url(url, &o, local, sizeof local, NULL, &e);
        double dt = time_monotonic() - t0;
        printf("low-speed limit (100 bytes/s for 2 s) abandoned a 1 byte/s transfer after %.2f s\n", dt);
        CHECK(rc == SPH_ERR_DOWNLOAD && strstr(e.msg, "too slow") && strstr(e.msg, "100 bytes/s"),
              "trickle abandoned by the low-speed limit: %s", e.msg);
        CHECK(dt >= 1.5 && dt < 4.0, "in the configured time: %.2f s (limit 2 s)", dt);
        CHECK(count_parts(cache, NULL, 0) == 0, "no .part left");
    }

    /* 2. cancel during the transfer (1.5 s in), 3. during a 30 s backoff
     * sleep after an HTTP 500 (0.5 s in) */
    const struct { const char *path, *what; double backoff, after; } cases[] = {
        {"trickle2.nc", "a transfer", 5, 1.5},
        {"e500.nc", "a 30 s retry backoff", 30, 0.5},
    };
    for (int k = 0; k < 2; k++) {
        fetch_options o = options(cache, 3, cases[k].backoff);
        snprintf(url, sizeof url, "http://127.0.0.1:%d/%s", port, cases[k].path);
        cancel_after = cases[k].after;
        double dt = fetch_cancelled(url, &o, &e);
        printf("cancel during %s: returned %.3f s after the cancellation\n", cases[k].what, dt);
        CHECK(dt >= 0 && dt < 1.0, "%s: returns within 1 s of the cancel: %.3f s", cases[k].what, dt);
        CHECK(strstr(e.msg, "cancelled") != NULL, "message says cancelled: %s", e.msg);
        CHECK(count_parts(cache, NULL, 0) == 0, "no .part left");
    }
    CHECK(atomic_load(&hits_500) == 1, "no retry after the cancel (%d requests)", atomic_load(&hits_500));

    /* 4. the cycle hands its cancel flag to the download */
    {
        char text[4096];
        snprintf(text, sizeof text,
                 "{\"engine\": \"test-double\", \"test\": {\"engine_seconds\": 0.01},"
                 " \"domain\": {\"lon_min\": 119, \"lon_max\": 122, \"lat_min\": 38, \"lat_max\": 41},"
                 " \"forcing\": [{\"name\": \"atm\", \"kind\": \"atmosphere\","
                 "   \"urls\": \"http://127.0.0.1:%d/cyc_%%Y%%m%%d%%H.nc\", \"issue_hours\": 24}],"
                 " \"output\": {\"dir\": \"%s/out\"},"
                 " \"schedule\": {\"late_data\": {\"wait_minutes\": 0, \"policy\": \"fail\"}},"
                 " \"paths\": {\"state_dir\": \"%s/state\", \"cache_dir\": \"%s\"}}",
                 port, tmp, tmp, cache);
        struct sph_config *c = NULL;
        sph_error_clear(&e);
        CHECK(sph_config_parse(text, "test", &c, &e) == 0, "config: %s", e.msg);
        if (c) {
            CHECK(c->fetch.low_speed_bytes == 1024 && c->fetch.low_speed_s == 60 && c->fetch.retries == 3 &&
                      c->fetch.backoff_s == 5 && c->fetch.timeout_s == 600 && c->fetch.connect_timeout_s == 30,
                  "fetch.* defaults");
            cycle_opts co;
            memset(&co, 0, sizeof co);
            co.cycle_time = 19761 * 86400.0;
            cycle_report rep;
            cancel_flag = 0;
            cancel_after = 1.0;
            pthread_t th;
            pthread_create(&th, NULL, canceller, NULL);
            sph_error_clear(&e);
            int rc = cycle_run(c, &co, NULL, &cancel_flag, &rep, &e);
            double dt = time_monotonic() - cancelled_at;
            pthread_join(th, NULL);
            printf("cycle cancelled during its download: returned %.3f s after the cancellation\n", dt);
            CHECK(rc == SPH_ERR_CANCELLED, "cycle cancelled: rc %d %s", rc, e.msg);
            CHECK(dt >= 0 && dt < 1.0, "cycle returns within 1 s of the cancel: %.3f s", dt);
            sph_config_free(c);
        }
    }

    /* 5. kill -9 of `sphice run` during a download leaves a .part; the next run sweeps it */
    const char *build = getenv("BUILD") ? getenv("BUILD") : "build";
    char cwd[256], exe[600], cfgp[400], logp[400], cache2[400], part[300] = "";
    if (!getcwd(cwd, sizeof cwd))
        return 1;
    snprintf(exe, sizeof exe, "%s/%s/sphice", cwd, build);
    CHECK(access(exe, X_OK) == 0, "%s built", exe);
    snprintf(logp, sizeof logp, "%s/run.log", tmp);
    {
        snprintf(cache2, sizeof cache2, "%s/cache2", tmp);
        write_config(cfgp, sizeof cfgp, port, "switch", cache2, "");
        pid_t pid = start_download(exe, "run", cfgp, logp, cache2, part, sizeof part);
        kill(pid, SIGKILL);
        int st;
        waitpid(pid, &st, 0);
        CHECK(WIFSIGNALED(st) && WTERMSIG(st) == SIGKILL, "sphice run killed with -9");
        char pidtag[64];
        snprintf(pidtag, sizeof pidtag, ".part.%ld.", (long)pid);
        CHECK(count_parts(cache2, part, sizeof part) == 1 && strstr(part, pidtag),
              "kill -9 left %s (pid %ld)", part, (long)pid);
        atomic_store(&serve_good, 1);
        char cmd[2000];
        snprintf(cmd, sizeof cmd, "'%s' run '%s' --cycle 2024-02-08T00:00Z >>'%s' 2>&1", exe, cfgp, logp);
        int rc = system(cmd);
        CHECK(rc == 0, "the next sphice run succeeds (status %d; log %s)", rc, logp);
        CHECK(count_parts(cache2, part, sizeof part) == 0, "the stale .part was swept (left: %s)", part);
        char *log = NULL;
        read_file(logp, &log, NULL, NULL);
        CHECK(log && strstr(log, pidtag), "the sweep is logged, naming the file");
        free(log);
    }

    /* 6. SIGTERM to `sphice serve` while its cycle downloads: exits 0 within 1 s */
    {
        snprintf(cache2, sizeof cache2, "%s/cache3", tmp);
        write_config(cfgp, sizeof cfgp, port, "slow", cache2, ", \"every_seconds\": 3600");
        pid_t pid = start_download(exe, "serve", cfgp, logp, cache2, part, sizeof part);
        nap(0.5);
        double t0 = time_monotonic();
        kill(pid, SIGTERM);
        int st = 0;
        pid_t w = 0;
        while ((w = waitpid(pid, &st, WNOHANG)) == 0 && time_monotonic() < t0 + 20)
            nap(0.01);
        double dt = time_monotonic() - t0;
        if (w == 0) {
            kill(pid, SIGKILL);
            waitpid(pid, &st, 0);
        }
        printf("sphice serve: SIGTERM during a download, exited %.3f s later\n", dt);
        CHECK(w == pid && WIFEXITED(st) && WEXITSTATUS(st) == 0, "serve exits 0 on SIGTERM (status %d)", st);
        CHECK(dt < 1.0, "serve exits within 1 s of SIGTERM during a download: %.3f s", dt);
        CHECK(count_parts(cache2, part, sizeof part) == 0, "the cancelled download left no .part (%s)", part);
    }

    atomic_store(&stopping, 1);
    MHD_stop_daemon(d);
    free(good);
    cycle_remove_tree(tmp);
    return check_summary("test_fetch_abort");
}
