/* Faults of the cycle found from outside (issue 21), with the test-double
 * engine:
 *   - item 7: no `cycle-<NAME>.lock` file is left per cycle (several
 *     cycles, files counted), and a held cycle lock still stops a second
 *     run of that cycle;
 *   - item 10: `OUTDIR/latest` a real directory: the cycle is refused
 *     before anything is published (one line naming the path), and the
 *     history says failed -- publication and history agree;
 *   - item 5: `sphice run` on a cycle the history says failed exits 1 (not
 *     0) and says --force runs it again; --force does; usage errors (no
 *     CONFIG, `--cycle yesterday`) exit 2. */
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include "check.h"
#include "exec_case.h"
#include "service/config.h"
#include "service/cycle.h"
#include "service/history.h"
#include "service/schedule.h"
#include "util/fileio.h"
#include "util/log.h"
#include "util/timeutil.h"

static char tmp[] = "/tmp/sphice-cycle-hardening-XXXXXX";
static char exe[512];
static const double DAY = 19761 * 86400.0; /* 2024-02-08T00:00Z */

static int config_text(char *text, size_t len)
{
    return snprintf(text, len,
                    "{\"engine\": \"test-double\", \"test\": {\"engine_seconds\": 0.01}, \"log_level\": \"warn\","
                    " \"domain\": {\"lon_min\": 119, \"lon_max\": 122, \"lat_min\": 38, \"lat_max\": 41},"
                    " \"forcing\": [{\"name\": \"atm\", \"kind\": \"atmosphere\", \"urls\": \"%s/f/atm.nc\"}],"
                    " \"output\": {\"dir\": \"%s/out\"},"
                    " \"schedule\": {\"every_hours\": 6, \"late_data\": {\"wait_minutes\": 0}},"
                    " \"status\": {\"enabled\": false},"
                    " \"paths\": {\"state_dir\": \"%s/state\", \"cache_dir\": \"%s/cache\"}}\n",
                    tmp, tmp, tmp, tmp);
}

/* Entries of dir whose name starts with prefix and ends with suffix. */
static int count_names(const char *dir, const char *prefix, const char *suffix)
{
    DIR *d = opendir(dir);
    if (!d)
        return -1;
    int n = 0;
    struct dirent *e;
    size_t ls = strlen(suffix);
    while ((e = readdir(d))) {
        size_t l = strlen(e->d_name);
        n += !strncmp(e->d_name, prefix, strlen(prefix)) && l >= ls && !strcmp(e->d_name + l - ls, suffix);
    }
    closedir(d);
    return n;
}

static int run_cycle(const struct sph_config *c, double t, int hindcast, history *h, cycle_report *rep,
                     sph_error *e)
{
    cycle_opts o;
    memset(&o, 0, sizeof o);
    o.cycle_time = t;
    o.hindcast = hindcast;
    o.hist = h;
    sph_error_clear(e);
    return cycle_run(c, &o, NULL, NULL, rep, e);
}

static int log_has(const char *log, const char *what)
{
    char *text = xc_slurp(log);
    int found = text && strstr(text, what) != NULL;
    free(text);
    if (!found)
        xc_show_log(log);
    return found;
}

static int run_engine(char *const argv[], const char *log, const char *engine)
{
    xc_opts o = {engine, 0};
    return xc_run(argv, log, &o);
}

int main(void)
{
    sph_log_level = LOG_LVL_ERROR;
    if (!mkdtemp(tmp))
        return 1;
    int built = xc_find_sphice(exe, sizeof exe) == 0;
    char p[2048], text[4096], state[512], out[512];
    sph_error e;
    sph_error_clear(&e);
    snprintf(p, sizeof p, "%s/f", tmp);
    mkdir_p(p, &e);
    snprintf(p, sizeof p, "%s/f/atm.nc", tmp);
    atomic_write_file(p, "forcing\n", 8, &e);
    snprintf(state, sizeof state, "%s/state", tmp);
    snprintf(out, sizeof out, "%s/out", tmp);
    config_text(text, sizeof text);
    struct sph_config *c = NULL;
    CHECK(sph_config_parse(text, "test", &c, &e) == SPH_OK, "config: %s", e.msg);
    if (!c)
        return check_summary("test_cycle_hardening");
    mkdir_p(state, &e);
    snprintf(p, sizeof p, "%s/history.sqlite", state);
    history *h = NULL;
    CHECK(history_open(&h, p, &e) == SPH_OK, "history: %s", e.msg);

    /* ---- item 7: several cycles, operational and hindcast: no lock file left */
    enum { NCYCLES = 6 };
    cycle_report rep;
    int ok = 0;
    for (int k = 0; k < NCYCLES; k++)
        ok += run_cycle(c, DAY + k * 6 * 3600.0, 0, h, &rep, &e) == SPH_OK && rep.result == CYCLE_OK;
    CHECK(ok == NCYCLES, "%d of %d cycles published (%s)", ok, NCYCLES, e.msg);
    ok = 0;
    for (int k = 0; k < 3; k++)
        ok += run_cycle(c, DAY - (k + 1) * 6 * 3600.0, 1, NULL, &rep, &e) == SPH_OK && rep.result == CYCLE_OK;
    CHECK(ok == 3, "%d of 3 hindcast cycles published (%s)", ok, e.msg);
    /* a skipped cycle (the history says it ran) releases its lock too */
    CHECK(run_cycle(c, DAY, 0, h, &rep, &e) == SPH_OK && rep.result == CYCLE_SKIPPED, "re-run skipped");
    int nlocks = count_names(state, "cycle-", ".lock") + count_names(state, "hindcast-cycle-", ".lock");
    CHECK(nlocks == 0, "no cycle lock file left after %d cycles: %d in %s", NCYCLES + 4, nlocks, state);

    /* the lock still works: a cycle whose lock another process holds is
     * refused, not recorded, and its holder's file stays */
    char name[32], lockp[1200];
    double t_held = DAY + NCYCLES * 6 * 3600.0;
    cycle_name(t_held, name, sizeof name);
    snprintf(lockp, sizeof lockp, "%s/cycle-%s.lock", state, name);
    int held = open(lockp, O_CREAT | O_RDWR, 0644);
    CHECK(held >= 0 && flock(held, LOCK_EX | LOCK_NB) == 0, "hold %s", lockp);
    int rc = run_cycle(c, t_held, 0, h, &rep, &e);
    CHECK(rc == SPH_ERR_LOCKED && strstr(e.msg, lockp), "held lock refused: %d %s", rc, e.msg);
    CHECK(access(lockp, F_OK) == 0, "the holder's lock file stays");
    history_run r;
    CHECK(history_get(h, t_held, &r, &e) == 0, "a locked-out cycle is not recorded");
    if (held >= 0)
        close(held);
    unlink(lockp);

    /* ---- item 10: latest a real directory */
    char latest[1200], keep[1300];
    snprintf(latest, sizeof latest, "%s/latest", out);
    CHECK(unlink(latest) == 0 && mkdir(latest, 0755) == 0, "latest made a directory");
    snprintf(keep, sizeof keep, "%s/operator-notes.txt", latest);
    atomic_write_file(keep, "mine\n", 5, &e);
    double t_dir = DAY + (NCYCLES + 1) * 6 * 3600.0;
    cycle_name(t_dir, name, sizeof name);
    rc = run_cycle(c, t_dir, 0, h, &rep, &e);
    CHECK(rc != SPH_OK && strstr(e.msg, latest) && strstr(e.msg, "not a symbolic link"),
          "latest a directory: refused naming it: %s", e.msg);
    snprintf(p, sizeof p, "%s/%s", out, name);
    CHECK(access(p, F_OK) != 0, "nothing published (%s)", p);
    CHECK(history_get(h, t_dir, &r, &e) == 1 && !strcmp(r.result, "failed"), "history says failed");
    history_run_clear(&r);
    struct stat st;
    CHECK(lstat(latest, &st) == 0 && S_ISDIR(st.st_mode) && access(keep, R_OK) == 0,
          "the directory and its file are left as they were");
    CHECK(count_names(out, ".stage-", "") == 0, "no stage dir left");
    /* moved away, the cycle runs (--force: the history says failed) and latest is a link again */
    cycle_opts o;
    memset(&o, 0, sizeof o);
    o.cycle_time = t_dir;
    o.hist = h;
    o.force = 1;
    char moved[1300];
    snprintf(moved, sizeof moved, "%s/latest-old", tmp);
    CHECK(rename(latest, moved) == 0, "operator moves it away");
    sph_error_clear(&e);
    rc = cycle_run(c, &o, NULL, NULL, &rep, &e);
    char target[256];
    ssize_t n = readlink(latest, target, sizeof target - 1);
    if (n > 0)
        target[n] = 0;
    CHECK(rc == SPH_OK && n > 0 && !strcmp(target, name), "then published, latest -> %s (%s)",
          n > 0 ? target : "none", e.msg);
    CHECK(history_get(h, t_dir, &r, &e) == 1 && !strcmp(r.result, "ok"), "history says ok");
    history_run_clear(&r);
    history_close(h);
    h = NULL;

    /* ---- item 5: exit statuses of `sphice run` */
    char config[1200], log[1200];
    snprintf(config, sizeof config, "%s/sphice.json", tmp);
    snprintf(log, sizeof log, "%s/log.txt", tmp);
    atomic_write_file(config, text, strlen(text), &e);
    if (!built) {
        CHECK(0, "%s: not built", exe);
    } else {
        char *no_config[] = {exe, "run", NULL};
        rc = run_engine(no_config, log, NULL);
        CHECK(rc == 2 && log_has(log, "CONFIG missing"), "run without CONFIG: exit 2 (%d)", rc);
        char *bad_cycle[] = {exe, "run", config, "--cycle", "yesterday", NULL};
        rc = run_engine(bad_cycle, log, NULL);
        CHECK(rc == 2 && log_has(log, "\"yesterday\""), "run --cycle yesterday: exit 2 (%d)", rc);
        char *check_none[] = {exe, "check", NULL};
        rc = run_engine(check_none, log, NULL);
        CHECK(rc == 2, "check without CONFIG: exit 2 (%d)", rc);
        char *hc_none[] = {exe, "hindcast", "--from", "2024-02-08T00:00Z", "--to", "2024-02-08T00:00Z", NULL};
        rc = run_engine(hc_none, log, NULL);
        CHECK(rc == 2, "hindcast without CONFIG: exit 2 (%d)", rc);

        char *cyc[] = {exe, "run", config, "--cycle", "2024-03-01T00:00Z", NULL};
        rc = run_engine(cyc, log, "fail");
        CHECK(rc == 1, "a failing cycle: exit 1 (%d)", rc);
        rc = run_engine(cyc, log, "sleep:0");
        CHECK(rc == 1 && log_has(log, "already ran and failed") && log_has(log, "--force"),
              "the failed cycle again: exit 1 and --force named (%d)", rc);
        char *forced[] = {exe, "run", config, "--cycle", "2024-03-01T00:00Z", "--force", NULL};
        rc = run_engine(forced, log, "sleep:0");
        CHECK(rc == 0, "--force re-runs it: exit 0 (%d)", rc);
        rc = run_engine(cyc, log, "sleep:0");
        CHECK(rc == 0 && log_has(log, "already ran (ok)"), "a cycle that ran ok again: exit 0 (%d)", rc);
        snprintf(p, sizeof p, "%s/20240301T00Z", out);
        CHECK(access(p, F_OK) == 0, "published %s", p);
    }

    sph_config_free(c);
    if (!check_failed_)
        cycle_remove_tree(tmp);
    return check_summary("test_cycle_hardening");
}
