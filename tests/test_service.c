/* The cycle state machine in-process, with the test-double engine:
 * publish + latest + manifest + history; never run twice; warm start
 * chain; failures and cancellation leave the published products as they
 * were (no stage dir, latest unchanged); late-data fail and stale
 * policies; locks; retention; hindcast reproduces the operational inputs. */
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <time.h>
#include <dirent.h>
#include <unistd.h>

#include "check.h"
#include "service/config.h"
#include "service/cycle.h"
#include "service/daemon.h"
#include "service/history.h"
#include "service/schedule.h"
#include "util/fileio.h"
#include "util/log.h"
#include "util/timeutil.h"

static char tmp[256];
static const double DAY = 19761 * 86400.0; /* 2024-02-08T00:00Z */

static struct sph_config *make_config(const char *policy, const char *extra)
{
    char text[4096];
    snprintf(text, sizeof text,
             "{\"engine\": \"test-double\", \"test\": {\"engine_seconds\": 0.05},"
             " \"domain\": {\"lon_min\": 119, \"lon_max\": 122, \"lat_min\": 38, \"lat_max\": 41},"
             " \"forcing\": [{\"name\": \"atm\", \"kind\": \"atmosphere\", \"urls\": \"%s/f/atm_%%Y%%m%%d%%H.nc\","
             "   \"issue_hours\": 12, \"max_age_hours\": 24}],"
             " \"output\": {\"dir\": \"%s/out\", \"retention_cycles\": 3},"
             " \"schedule\": {\"late_data\": {\"wait_minutes\": 0.005, \"poll_seconds\": 0.1, \"policy\": \"%s\"}},"
             " \"paths\": {\"state_dir\": \"%s/state\", \"cache_dir\": \"%s/cache\"} %s}",
             tmp, tmp, policy, tmp, tmp, extra ? extra : "");
    struct sph_config *c = NULL;
    sph_error e;
    sph_error_clear(&e);
    if (sph_config_parse(text, "test", &c, &e))
        fprintf(stderr, "config: %s\n", e.msg);
    return c;
}

static void touch_forcing(double t, const char *content)
{
    char p[512], name[64];
    sph_error e;
    sph_error_clear(&e);
    cycle_expand_template("atm_%Y%m%d%H.nc", t, name, sizeof name, &e);
    snprintf(p, sizeof p, "%s/f/%s", tmp, name);
    atomic_write_file(p, content, strlen(content), &e);
}

static int exists_out(const char *rel)
{
    char p[1024];
    snprintf(p, sizeof p, "%s/out/%s", tmp, rel);
    struct stat st;
    return stat(p, &st) == 0;
}

static int count_stage_dirs(const char *dir)
{
    DIR *d = opendir(dir);
    int n = 0;
    struct dirent *e;
    while (d && (e = readdir(d)))
        n += !strncmp(e->d_name, ".stage-", 7) || !strncmp(e->d_name, ".old-", 5);
    if (d)
        closedir(d);
    return n;
}

static char *slurp(const char *path)
{
    char *t = NULL;
    size_t n;
    sph_error e;
    sph_error_clear(&e);
    if (read_file(path, &t, &n, &e))
        return NULL;
    return t;
}

static void latest_target(char *buf, size_t len)
{
    char link[512];
    snprintf(link, sizeof link, "%s/out/latest", tmp);
    ssize_t n = readlink(link, buf, len - 1);
    buf[n > 0 ? n : 0] = 0;
}

static int run(const struct sph_config *c, double t, history *h, cycle_report *rep, sph_error *e)
{
    cycle_opts o;
    memset(&o, 0, sizeof o);
    o.cycle_time = t;
    o.hist = h;
    sph_error_clear(e);
    return cycle_run(c, &o, NULL, NULL, rep, e);
}

/* An engine that writes half a product and then fails. */
static int failing_engine(const struct sph_config *cfg, const forecast_request *req, forecast_progress *prog,
                          const volatile sig_atomic_t *cancel, forecast_result *res, sph_error *err)
{
    char p[1024];
    snprintf(p, sizeof p, "%s/fields.nc", req->stage_dir);
    FILE *f = fopen(p, "w");
    if (f) {
        fputs("half", f);
        fclose(f);
    }
    return sph_err_set(err, SPH_ERR_NUMERICS, "model: speed 99 m/s above the limit");
}

static volatile sig_atomic_t cancel_flag;
static void *canceller(void *arg)
{
    (void)arg;
    struct timespec ts = {0, 200 * 1000 * 1000};
    nanosleep(&ts, NULL);
    cancel_flag = 1;
    return NULL;
}

int main(void)
{
    sph_log_level = LOG_LVL_ERROR;
    snprintf(tmp, sizeof tmp, "/tmp/sphice-test-service-XXXXXX");
    if (!mkdtemp(tmp))
        return 1;
    char p[512];
    snprintf(p, sizeof p, "%s/f", tmp);
    sph_error e;
    sph_error_clear(&e);
    mkdir_p(p, &e);
    struct sph_config *c = make_config("fail", NULL);
    CHECK(c != NULL, "config");
    if (!c)
        return check_summary("test_service");
    snprintf(p, sizeof p, "%s/state", tmp);
    mkdir_p(p, &e);
    snprintf(p, sizeof p, "%s/state/history.sqlite", tmp);
    history *h = NULL;
    CHECK(history_open(&h, p, &e) == 0, "history: %s", e.msg);

    /* 1. a cycle publishes a directory, latest, a manifest and a history row */
    double t0 = DAY, t1 = DAY + 12 * 3600, t2 = DAY + 24 * 3600;
    touch_forcing(t0, "forcing t0");
    cycle_report rep;
    int rc = run(c, t0, h, &rep, &e);
    CHECK(rc == 0 && rep.result == CYCLE_OK, "cycle t0: %s", e.msg);
    CHECK(exists_out("20240208T00Z/fields.txt"), "product published");
    CHECK(exists_out("20240208T00Z/cycle.json"), "manifest published");
    char target[256];
    latest_target(target, sizeof target);
    CHECK(!strcmp(target, "20240208T00Z"), "latest -> %s", target);
    CHECK(!strcmp(rep.mode, "cold"), "first cycle cold: %s", rep.mode);
    history_run r;
    CHECK(history_get(h, t0, &r, &e) == 1 && !strcmp(r.result, "ok") && r.stale == 0 && r.products_json &&
              strstr(r.products_json, "fields.txt"),
          "history row ok");
    history_run_clear(&r);
    snprintf(p, sizeof p, "%s/out/20240208T00Z/cycle.json", tmp);
    char *manifest = slurp(p);
    CHECK(manifest && strstr(manifest, "2024-02-08T00:00:00Z") && strstr(manifest, c->sha256), "manifest content");
    free(manifest);

    /* 2. never twice: the history says it ran */
    rc = run(c, t0, h, &rep, &e);
    CHECK(rc == 0 && rep.result == CYCLE_SKIPPED, "rerun skipped: %d", rep.result);
    CHECK(history_count(h, "ok") == 1, "one row");

    /* 3. the next cycle warm-starts from the restart file the previous one wrote */
    touch_forcing(t1, "forcing t1");
    rc = run(c, t1, h, &rep, &e);
    CHECK(rc == 0 && !strcmp(rep.mode, "warm"), "warm start: %s %s", rep.mode, e.msg);
    latest_target(target, sizeof target);
    CHECK(!strcmp(target, "20240208T12Z"), "latest moved to 12Z");
    snprintf(p, sizeof p, "%s/out/20240208T12Z/fields.txt", tmp);
    char *before = slurp(p);

    /* 4. an engine failure leaves no partial product and the previous ones intact */
    touch_forcing(t2, "forcing t2");
    cycle_set_engine(failing_engine);
    c->engine = CFG_ENGINE_FORECAST;
    rc = run(c, t2, h, &rep, &e);
    CHECK(rc == SPH_ERR_NUMERICS && rep.result == CYCLE_FAILED && strstr(e.msg, "speed 99"), "failure: %s", e.msg);
    CHECK(!exists_out("20240209T00Z"), "nothing published");
    snprintf(p, sizeof p, "%s/out", tmp);
    CHECK(count_stage_dirs(p) == 0, "stage dir removed");
    latest_target(target, sizeof target);
    CHECK(!strcmp(target, "20240208T12Z"), "latest unchanged");
    CHECK(history_get(h, t2, &r, &e) == 1 && !strcmp(r.result, "failed") && strstr(r.message, "speed 99"),
          "failure recorded with its reason");
    history_run_clear(&r);
    cycle_set_engine(NULL);
    c->engine = CFG_ENGINE_TEST_DOUBLE;

    /* 5. a publish fault (disk, rename) is the same */
    setenv("SPHICE_FAULT", "cycle.publish", 1);
    cycle_opts o;
    memset(&o, 0, sizeof o);
    o.cycle_time = t2;
    o.hist = h;
    o.force = 1;
    rc = cycle_run(c, &o, NULL, NULL, &rep, &e);
    unsetenv("SPHICE_FAULT");
    CHECK(rc == SPH_ERR_IO && strstr(rep.message, "injected"), "publish fault: %s", rep.message);
    CHECK(!exists_out("20240209T00Z") && count_stage_dirs(p) == 0, "no partial publish");
    snprintf(p, sizeof p, "%s/out/20240208T12Z/fields.txt", tmp);
    char *after = slurp(p);
    CHECK(before && after && !strcmp(before, after), "previous products untouched");
    free(after);
    free(before);

    /* 6. cancellation mid-run: status cancelled, nothing published */
    c->test_engine_seconds = 5;
    pthread_t th;
    cancel_flag = 0;
    pthread_create(&th, NULL, canceller, NULL);
    double m0 = time_monotonic();
    rc = cycle_run(c, &o, NULL, &cancel_flag, &rep, &e);
    pthread_join(th, NULL);
    CHECK(rc == SPH_ERR_CANCELLED && rep.result == CYCLE_CANCELLED, "cancelled: %d %s", rc, rep.message);
    CHECK(time_monotonic() - m0 < 2, "cancel is prompt");
    snprintf(p, sizeof p, "%s/out", tmp);
    CHECK(!exists_out("20240209T00Z") && count_stage_dirs(p) == 0, "cancel: no partial product");
    CHECK(history_get(h, t2, &r, &e) == 1 && !strcmp(r.result, "cancelled"), "cancel recorded");
    history_run_clear(&r);
    c->test_engine_seconds = 0.05;

    /* 7. a held lock refuses the cycle, and the history is not touched */
    snprintf(p, sizeof p, "%s/state/run.lock", tmp);
    int fd = open(p, O_CREAT | O_RDWR, 0644);
    CHECK(fd >= 0 && flock(fd, LOCK_EX | LOCK_NB) == 0, "test holds the run lock");
    rc = cycle_run(c, &o, NULL, NULL, &rep, &e);
    CHECK(rc == SPH_ERR_LOCKED, "locked: %d %s", rc, rep.message);
    close(fd);

    /* 8. late data, fail policy: the reason names the source */
    double t3 = DAY + 36 * 3600; /* no file for 2024-02-09T12 */
    rc = run(c, t3, h, &rep, &e);
    CHECK(rc == SPH_ERR_COVERAGE && strstr(e.msg, "forcing atm missing") && strstr(e.msg, "atm_2024020912.nc"),
          "fail policy: %s", e.msg);

    /* 9. stale policy: the issue 12 h older (t2's file) is used and flagged */
    struct sph_config *cs = make_config("stale", NULL);
    o.cycle_time = t3;
    o.force = 1; /* the fail-policy attempt is in the history as failed */
    rc = cycle_run(cs, &o, NULL, NULL, &rep, &e);
    CHECK(rc == 0 && rep.stale == 1 && rep.source_age_h[0] == 12, "stale run: %s age %g", e.msg,
          rep.source_age_h[0]);
    CHECK(history_get(h, t3, &r, &e) == 1 && r.stale == 1 && !strcmp(r.result, "ok"), "stale flagged in history");
    history_run_clear(&r);
    snprintf(p, sizeof p, "%s/out/20240209T12Z/cycle.json", tmp);
    manifest = slurp(p);
    CHECK(manifest && strstr(manifest, "\"stale\":\ttrue"), "stale flagged in the manifest");
    free(manifest);
    /* beyond max_age_hours the stale policy fails too */
    rc = run(cs, DAY + 96 * 3600, h, &rep, &e);
    CHECK(rc == SPH_ERR_COVERAGE, "too old: %s", e.msg);

    /* 10. retention keeps 3 published cycles, latest included */
    touch_forcing(t2, "forcing t2");
    o.force = 1;
    o.cycle_time = t2;
    rc = cycle_run(c, &o, NULL, NULL, &rep, &e);
    CHECK(rc == 0, "t2 after all: %s", e.msg);
    CHECK(!exists_out("20240208T00Z") && exists_out("20240208T12Z") &&
              exists_out("20240209T12Z"),
          "retention");
    latest_target(target, sizeof target);
    CHECK(!strcmp(target, "20240209T12Z"), "an older cycle does not move latest back: %s", target);

    /* 11. interrupted rows: a "running" row left behind becomes "interrupted" */
    history_run fake;
    memset(&fake, 0, sizeof fake);
    fake.cycle = DAY + 48 * 3600;
    fake.started = time_now();
    fake.ended = fake.area_km2 = fake.volume_km3 = fake.edge_nm = NAN;
    snprintf(fake.result, sizeof fake.result, "running");
    history_put(h, &fake, &e);
    CHECK(history_mark_interrupted(h, &e) == 1, "one interrupted");
    CHECK(history_get(h, fake.cycle, &r, &e) == 1 && !strcmp(r.result, "interrupted"), "marked interrupted");
    history_run_clear(&r);

    /* 12. hindcast: same forcing, same config -> the same product bytes */
    struct sph_config *hc = make_config("fail", ", \"initial\": {\"reinit\": \"cold\"}");
    touch_forcing(DAY + 72 * 3600, "forcing t6");
    o.cycle_time = DAY + 72 * 3600;
    o.force = 0;
    rc = cycle_run(hc, &o, NULL, NULL, &rep, &e);
    CHECK(rc == 0, "operational: %s", e.msg);
    snprintf(p, sizeof p, "%s/hc", tmp);
    sph_error_clear(&e);
    int failed = service_hindcast(hc, DAY + 72 * 3600, DAY + 72 * 3600, p, 0, &e);
    CHECK(failed == 0, "hindcast: %s", e.msg);
    char a[512], b[512];
    snprintf(a, sizeof a, "%s/out/20240211T00Z/fields.txt", tmp);
    snprintf(b, sizeof b, "%s/hc/20240211T00Z/fields.txt", tmp);
    char *ta = slurp(a), *tb = slurp(b);
    CHECK(ta && tb && !strcmp(ta, tb), "hindcast reproduces the operational product");
    free(ta);
    free(tb);

    history_close(h);
    sph_config_free(c);
    sph_config_free(cs);
    sph_config_free(hc);
    cycle_remove_tree(tmp);
    return check_summary("test_service");
}
