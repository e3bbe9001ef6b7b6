/* The station DEM through a whole cycle (issue 25 items 3 and 4): the
 * engine case (tests/engine_case.h) with its station given the seed's leg
 * and loads.model dem, run by cycle_run and published; then
 *  - cycle.json's timing block (stage "loads": runs + cached = the DEM's
 *    rows = the output times) and its latest load per station;
 *  - the load file's structure in SI units from the configuration's t and
 *    kN/m (300 t, 5.0e5 kN/m);
 *  - /status's latest loads read back from the published cycle;
 *  - a DEM step beyond the stability limit: the cycle fails with one line
 *    naming the station and loads.dem_dt, nothing published;
 *  - a long DEM (600 s of simulated ice) cancelled while it runs: the
 *    cycle ends within a second of the cancel flag, recorded "cancelled"
 *    in the history, nothing published. */
#include "engine_case.h"

#include <cjson/cJSON.h>
#include <netcdf.h>
#include <pthread.h>
#include <signal.h>
#include <time.h>

#include "check.h"
#include "service/config.h"
#include "service/cycle.h"
#include "service/history.h"
#include "service/status_page.h"
#include "util/jsonutil.h"

/* the station plots' fontconfig cache, as in test_products */
const char *__lsan_default_suppressions(void);
const char *__lsan_default_suppressions(void) { return "leak:libfontconfig\n"; }

static char dir[] = "/tmp/test_loads_cycle_XXXXXX";

/* the case's configuration with the leg at its station and the given loads.* members */
static struct sph_config *load(const char *loads)
{
    char text[8192], extra[512];
    snprintf(extra, sizeof extra, "\"log_level\": \"warn\", \"loads\": {%s},", loads);
    ec_config(text, sizeof text, dir, 300, "[\"wind\", \"tair\"]", "ice.nc", extra);
    const char *plain = "{\"name\": \"centre\", \"lon\": 121.5, \"lat\": 40.3}";
    char *at = strstr(text, plain);
    CHECK(at != NULL, "the case's station line");
    if (!at)
        return NULL;
    char out[8192];
    snprintf(out, sizeof out, "%.*s{\"name\": \"centre\", \"lon\": 121.5, \"lat\": 40.3, \"structure\": {\"kind\": "
             "\"vertical\"}}%s", (int)(at - text), text, at + strlen(plain));
    struct sph_config *cfg = NULL;
    sph_error err = {0};
    if (sph_config_parse(out, "test", &cfg, &err) != SPH_OK)
        CHECK(0, "config: %s", err.msg);
    return cfg;
}

/* runs the case's cycle for 3 h into dir/name (out gets that path) */
static int cycle(const struct sph_config *cfg, const char *name, char *out, size_t len, cycle_report *rep,
                 sph_error *err)
{
    snprintf(out, len, "%s/%s", dir, name);
    cycle_opts o = {.cycle_time = EC_CYCLE, .hours = 3, .out_dir = out, .force = 1};
    memset(rep, 0, sizeof *rep);
    sph_error_clear(err);
    return cycle_run(cfg, &o, NULL, NULL, rep, err);
}

/* the leg with the DEM forced on a small sheet for `duration` s */
static struct sph_config *load_forced_dem(const char *duration)
{
    char loads[256];
    snprintf(loads, sizeof loads, "\"model\": \"dem\", \"dem_duration\": %s, \"dem_sheet_length\": 0.4, "
             "\"dem_sheet_width\": 0.5", duration);
    return load(loads);
}

static double num(const cJSON *o, const char *k)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, k);
    return cJSON_IsNumber(v) ? v->valuedouble : NAN;
}

static void test_published(void)
{
    struct sph_config *cfg = load_forced_dem("0.004");
    if (!cfg)
        return;
    char out[1200], path[1400];
    cycle_report rep;
    sph_error err;
    int rc = cycle(cfg, "out", out, sizeof out, &rep, &err);
    CHECK(rc == SPH_OK && rep.result == CYCLE_OK, "the cycle is published: %s", err.msg);
    snprintf(path, sizeof path, "%s/19990208T06Z/cycle.json", out);
    sph_error e;
    sph_error_clear(&e);
    cJSON *j = json_read_file(path, &e);
    CHECK(j != NULL, "read %s: %s", path, e.msg);
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(j, "timing"), "loads");
    const cJSON *f = cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(j, "timing"), "forecast");
    double runs = num(t, "dem_runs"), cached = num(t, "dem_cached"), rows = num(t, "dem_rows");
    /* 3 h of hourly output: 4 times, each a DEM row (forced) */
    CHECK(rows == 4 && runs >= 1 && runs + cached == rows && num(t, "cheap_rows") == 0,
          "timing.loads: %g runs + %g cached = %g rows", runs, cached, rows);
    CHECK(num(t, "dem_wall_seconds") > 0 && num(t, "dem_wall_seconds") <= num(f, "wall_seconds") &&
              num(t, "dem_share_of_forecast") > 0 && num(t, "dem_share_of_forecast") <= 1,
          "the DEM's wall time %g s within the forecast's %g s", num(t, "dem_wall_seconds"), num(f, "wall_seconds"));
    const cJSON *l = cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(j, "loads"), 0);
    const char *st = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(l, "station"));
    const char *model = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(l, "model"));
    const char *vt = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(l, "valid_time"));
    CHECK(st && !strcmp(st, "centre") && model && !strcmp(model, "dem") && vt && !strcmp(vt, "1999-02-08T09:00:00Z") &&
              num(l, "max_load_kN") >= num(l, "load_kN"),
          "cycle.json loads: %s %s at %s, %g kN (max %g)", st ? st : "?", model ? model : "?", vt ? vt : "?",
          num(l, "load_kN"), num(l, "max_load_kN"));
    cJSON_Delete(j);
    /* the structure in SI units: 300 t = 3e5 kg, 5.0e5 kN/m = 5e8 N/m */
    snprintf(path, sizeof path, "%s/19990208T06Z/sphice_loads.nc", out);
    int nc, v;
    double mass = 0, k = 0, zeta = 0;
    CHECK(nc_open(path, NC_NOWRITE, &nc) == NC_NOERR, "open %s", path);
    CHECK(nc_inq_varid(nc, "structure_mass", &v) == NC_NOERR && nc_get_var_double(nc, v, &mass) == NC_NOERR &&
              nc_inq_varid(nc, "structure_stiffness", &v) == NC_NOERR && nc_get_var_double(nc, v, &k) == NC_NOERR &&
              nc_inq_varid(nc, "structure_damping", &v) == NC_NOERR && nc_get_var_double(nc, v, &zeta) == NC_NOERR,
          "read the structure");
    nc_close(nc);
    CHECK(mass == 3e5 && k == 5e8 && zeta == 0.03, "structure %g kg, %g N/m, damping %g", mass, k, zeta);
    /* /status: the latest load and model from the published cycle */
    cJSON *s = status_latest_json(out);
    const cJSON *sl = cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(s, "loads"), 0);
    const char *sm = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(sl, "model"));
    CHECK(sm && !strcmp(sm, "dem") && cJSON_GetArraySize(cJSON_GetObjectItemCaseSensitive(s, "loads")) == 1,
          "/status latest.loads: one station, model %s", sm ? sm : "?");
    cJSON_Delete(s);
    sph_config_free(cfg);
}

static void test_refused(void)
{
    struct sph_config *cfg = load("\"model\": \"dem\", \"dem_duration\": 0.004, \"dem_dt\": 0.001");
    if (!cfg)
        return;
    cycle_report rep;
    sph_error err;
    char out[1200], path[1400];
    int rc = cycle(cfg, "bad", out, sizeof out, &rep, &err);
    CHECK(rc != SPH_OK && rep.result == CYCLE_FAILED, "a step beyond the limit fails the cycle");
    CHECK(strstr(err.msg, "\"centre\"") && strstr(err.msg, "loads.dem_dt") && !strchr(err.msg, '\n'),
          "one line naming the station and the key: %s", err.msg);
    snprintf(path, sizeof path, "%s/19990208T06Z", out);
    CHECK(access(path, F_OK) != 0, "nothing published");
    snprintf(path, sizeof path, "%s/latest", out);
    CHECK(access(path, F_OK) != 0, "no latest");
    sph_config_free(cfg);
}

static void nap_ms(long ms)
{
    struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
    nanosleep(&ts, NULL);
}

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

typedef struct cancel_job {
    const struct sph_config *cfg;
    cycle_opts o;
    forecast_progress prog;
    volatile sig_atomic_t cancel;
    cycle_report rep;
    sph_error err;
    int rc;
    volatile int done;
} cancel_job;

static void *cancel_worker(void *arg)
{
    cancel_job *j = arg;
    j->rc = cycle_run(j->cfg, &j->o, &j->prog, &j->cancel, &j->rep, &j->err);
    j->done = 1;
    return NULL;
}

static void test_cancelled(void)
{
    /* 600 s of ice against the leg at the first output time: hours of work */
    struct sph_config *cfg = load_forced_dem("600");
    if (!cfg)
        return;
    char out[1200], path[1400];
    snprintf(out, sizeof out, "%s/cancel", dir);
    snprintf(path, sizeof path, "%s/history.sqlite", dir);
    history *h = NULL;
    sph_error e;
    sph_error_clear(&e);
    CHECK(history_open(&h, path, &e) == SPH_OK, "history: %s", e.msg);
    static cancel_job j;
    memset(&j, 0, sizeof j);
    j.cfg = cfg;
    j.o = (cycle_opts){.cycle_time = EC_CYCLE, .hours = 3, .out_dir = out, .force = 1, .hist = h};
    pthread_t th;
    CHECK(pthread_create(&th, NULL, cancel_worker, &j) == 0, "worker thread");
    /* the time loop starts with the first output time, whose DEM then runs
     * (it cannot end in the test's lifetime): cancel 0.5 s into it */
    double t0 = now();
    while (j.prog.phase != FC_PHASE_RUNNING && !j.done && now() - t0 < 60.0)
        nap_ms(10);
    nap_ms(500);
    CHECK(!j.done, "the cycle is still running when cancelled (rc %d: %s)", j.rc, j.err.msg);
    double tc = now();
    j.cancel = 1;
    while (!j.done && now() - tc < 10.0)
        nap_ms(5);
    double took = now() - tc;
    if (!j.done) { /* the DEM does not stop: the worker would run for hours */
        CHECK(0, "the cycle still runs %.1f s after the cancel", took);
        exit(check_summary("test_loads_cycle"));
    }
    pthread_join(th, NULL);
    printf("cancel: the cycle ended %.3f s after the flag: %s\n", took, j.err.msg);
    CHECK(took < 1.0, "the cycle ends within a second of the cancel (%.3f s)", took);
    CHECK(j.rc == SPH_ERR_CANCELLED && j.rep.result == CYCLE_CANCELLED, "the cycle is cancelled (rc %d, result %d)",
          j.rc, j.rep.result);
    CHECK(strstr(j.err.msg, "DEM cancelled") != NULL && strstr(j.err.msg, "\"centre\"") != NULL,
          "the DEM run was the one stopped: %s", j.err.msg);
    history_run r;
    memset(&r, 0, sizeof r);
    CHECK(history_get(h, EC_CYCLE, &r, &e) == 1 && !strcmp(r.result, "cancelled"),
          "recorded \"%s\" in the history", r.result);
    history_run_clear(&r);
    snprintf(path, sizeof path, "%s/19990208T06Z", out);
    CHECK(access(path, F_OK) != 0, "nothing published");
    snprintf(path, sizeof path, "%s/latest", out);
    CHECK(access(path, F_OK) != 0, "no latest");
    history_close(h);
    sph_config_free(cfg);
}

int main(int argc, char **argv)
{
    (void)argc;
    CHECK(ec_start(argv, dir) == 0, "mkdtemp");
    test_published();
    test_refused();
    test_cancelled();
    char cmd[1200];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    CHECK(system(cmd) == 0, "cleanup");
    return check_summary("test_loads_cycle");
}
