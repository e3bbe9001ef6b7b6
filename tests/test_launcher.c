/* `serve` running cycles through launcher.command (issue 24, item 3): the
 * job runs `PROGRAM run SNAPSHOT --cycle TIME` in its own process group
 * and records the cycle in the shared history; SIGTERM to serve cancels
 * the whole group (SIGKILL after launcher.grace_s); a job that dies or
 * never starts is recorded failed in one line; under mpirun (when
 * installed) the job is an MPI run. The engine is the test double. */
#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "check.h"
#include "engine_case.h"
#include "exec_case.h"
#include "service/cycle.h"
#include "service/config.h"
#include "service/history.h"
#include "service/launch.h"
#include "service/schedule.h"
#include "util/fileio.h"
#include "util/timeutil.h"

static char tmp[] = "/tmp/sphice-launcher-XXXXXX", exe[600];

static void nap(double s) { xc_nap(s); }

/* A configuration for scenario NAME whose launcher.command is launcher
 * (a JSON string's contents) and extra keys. */
static void scene_config(const char *name, const char *launcher, const char *extra, char *cfg, size_t len)
{
    char text[8192], atm[700];
    snprintf(atm, sizeof atm, "%s/atm.nc", tmp);
    snprintf(cfg, len, "%s/%s.json", tmp, name);
    snprintf(text, sizeof text,
             "{\"engine\": \"test-double\","
             " \"domain\": {\"lon_min\": 119, \"lon_max\": 122, \"lat_min\": 38, \"lat_max\": 41},"
             " \"forcing\": [{\"name\": \"atm\", \"kind\": \"atmosphere\", \"urls\": \"%s\","
             "   \"issue_hours\": 24, \"max_age_hours\": 72}],"
             " \"output\": {\"dir\": \"%s/%s/out\"},"
             " \"schedule\": {\"every_seconds\": 3600, \"forecast_hours\": 6, \"catch_up\": false,"
             "   \"late_data\": {\"wait_minutes\": 0, \"policy\": \"fail\"}},"
             " \"status\": {\"enabled\": false},"
             " \"launcher\": {\"command\": \"%s\" %s},"
             " \"paths\": {\"state_dir\": \"%s/%s/state\", \"cache_dir\": \"%s/%s/cache\"}}",
             atm, tmp, name, launcher, extra ? extra : "", tmp, name, tmp, name);
    sph_error e;
    sph_error_clear(&e);
    CHECK(atomic_write_file(cfg, text, strlen(text), &e) == SPH_OK, "%s", e.msg);
}

static pid_t serve(const char *cfg, const char *engine, const char *log)
{
    pid_t pid = fork();
    if (pid == 0) {
        if (engine)
            setenv("SPHICE_TEST_ENGINE", engine, 1);
        else /* the real engine */
            unsetenv("SPHICE_TEST_ENGINE");
        int fd = open(log, O_CREAT | O_WRONLY | O_APPEND, 0644);
        if (fd >= 0) {
            dup2(fd, 1);
            dup2(fd, 2);
        }
        execl(exe, exe, "serve", cfg, (char *)NULL);
        _exit(127);
    }
    return pid;
}

/* The history row of cycle in scenario name once its result is one of
 * want ("ok|failed"), within timeout; result[0] = 0 when it never was. */
static void wait_row(const char *name, double cycle, const char *want, double timeout, history_run *out)
{
    char db[800];
    snprintf(db, sizeof db, "%s/%s/state/history.sqlite", tmp, name);
    double end = time_monotonic() + timeout;
    memset(out, 0, sizeof *out);
    while (time_monotonic() < end) {
        history *h = NULL;
        sph_error e;
        sph_error_clear(&e);
        if (access(db, R_OK) == 0 && history_open(&h, db, &e) == 0) {
            history_run r;
            int found = history_get(h, cycle, &r, &e);
            history_close(h);
            if (found == 1) {
                char key[24];
                snprintf(key, sizeof key, "|%s|", r.result);
                char w[64];
                snprintf(w, sizeof w, "|%s|", want);
                if (strstr(w, key)) {
                    *out = r;
                    return;
                }
                history_run_clear(&r);
            }
        }
        nap(0.05);
    }
}


static long read_pid(const char *path, double timeout)
{
    double end = time_monotonic() + timeout;
    while (time_monotonic() < end) {
        FILE *f = fopen(path, "r");
        long p = 0;
        int ok = f && fscanf(f, "%ld", &p) == 1;
        if (f)
            fclose(f);
        if (ok && p > 0)
            return p;
        nap(0.05);
    }
    return -1;
}

/* Gone, or a zombie waiting for a reaper that is not ours. */
static int gone(long pid)
{
    char p[64], buf[512];
    snprintf(p, sizeof p, "/proc/%ld/stat", pid);
    FILE *f = fopen(p, "r");
    if (!f)
        return 1;
    size_t n = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[n] = 0;
    const char *rp = strrchr(buf, ')');
    return rp && rp[1] == ' ' && rp[2] == 'Z';
}

static void show_log(const char *log) { xc_show_log(log); }

static double this_cycle(void) { return floor(time_now() / 3600.0) * 3600.0; }

/* The job reads the configuration in force as sph_config_to_json wrote it:
 * that text must load to the same configuration (every key, every table). */
static void test_snapshot_round_trip(void)
{
    static const char *const files[] = {"etc/liaodong-demo.json", "etc/liaodong-season.json", "etc/sphice.json"};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        struct sph_config *a = NULL, *b = NULL;
        sph_error e;
        sph_error_clear(&e);
        int ok = sph_config_load(files[i], &a, &e) == 0;
        char *ta = ok ? sph_config_to_json(a) : NULL;
        ok = ok && ta && sph_config_parse(ta, "snapshot", &b, &e) == 0;
        char *tb = ok ? sph_config_to_json(b) : NULL;
        CHECK(ok && tb && !strcmp(ta, tb), "%s: the snapshot loads to the same configuration (%s)", files[i],
              e.msg);
        free(ta);
        free(tb);
        sph_config_free(a);
        sph_config_free(b);
    }
}

static void test_split(void)
{
    char buf[256], *w[8];
    sph_error e;
    sph_error_clear(&e);
    int n = launch_split("  mpirun  -np 8 --mca 'btl self,tcp' \"a b\"c ", buf, sizeof buf, w, 8, &e);
    CHECK(n == 6, "split count %d", n);
    if (n == 6)
        CHECK(!strcmp(w[0], "mpirun") && !strcmp(w[1], "-np") && !strcmp(w[2], "8") && !strcmp(w[3], "--mca") &&
                  !strcmp(w[4], "btl self,tcp") && !strcmp(w[5], "a bc"),
              "split words");
    CHECK(launch_split("mpirun 'np", buf, sizeof buf, w, 8, &e) < 0 && strstr(e.msg, "launcher.command"),
          "unbalanced quote refused: %s", e.msg);
    CHECK(launch_split("a b c d e f g h i", buf, sizeof buf, w, 8, &e) < 0, "too many words refused");
}

/* A cycle through `sh -c '...; exec "$@"'`: another process, the same history. */
static void test_ok(void)
{
    char cfg[800], log[800], mark[800], launcher[1200], prod[1200];
    snprintf(mark, sizeof mark, "%s/ok.pid", tmp);
    snprintf(log, sizeof log, "%s/ok.log", tmp);
    snprintf(launcher, sizeof launcher, "sh -c 'echo $$ > %s; exec \\\"$@\\\"' job", mark);
    scene_config("ok", launcher, NULL, cfg, sizeof cfg);
    double cyc = this_cycle();
    pid_t pid = serve(cfg, "sleep:0.2", log);
    history_run r;
    wait_row("ok", cyc, "ok|failed", 30, &r);
    CHECK(!strcmp(r.result, "ok"), "launched cycle recorded ok (%s: %s)", r.result, r.message);
    long job = read_pid(mark, 1);
    CHECK(job > 0 && job != pid, "the cycle ran in a launched process (%ld, serve %ld)", job, (long)pid);
    char name[32];
    cycle_name(cyc, name, sizeof name);
    snprintf(prod, sizeof prod, "%s/ok/out/%s/cycle.json", tmp, name);
    CHECK(access(prod, R_OK) == 0, "the job published %s", prod);
    history_run_clear(&r);
    kill(pid, SIGTERM);
    int rc = xc_wait_exit(pid, 10);
    CHECK(rc == 0, "serve exits 0 on SIGTERM when idle (%d)", rc);
    char snap[900];
    snprintf(snap, sizeof snap, "%s/ok/state/launch-%s.json", tmp, name);
    CHECK(access(snap, F_OK) != 0, "the configuration snapshot is removed");
    if (check_failed_)
        show_log(log);
}

/* SIGTERM to serve while the job runs: the whole group goes (a grandchild
 * too), the cycle is recorded cancelled, the previous latest stays. With
 * grace_ignore, the job ignores SIGTERM and goes by SIGKILL after grace. */
static void test_cancel(const char *name, int ignore_term)
{
    char cfg[800], log[800], mark[800], gchild[800], launcher[2000];
    snprintf(mark, sizeof mark, "%s/%s.pid", tmp, name);
    snprintf(gchild, sizeof gchild, "%s/%s.gpid", tmp, name);
    snprintf(log, sizeof log, "%s/%s.log", tmp, name);
    if (ignore_term)
        snprintf(launcher, sizeof launcher,
                 "sh -c 'trap \\\"\\\" TERM; echo $$ > %s; sleep 300 & echo $! > %s; wait' job", mark, gchild);
    else
        snprintf(launcher, sizeof launcher, "sh -c 'echo $$ > %s; sleep 300 & echo $! > %s; \\\"$@\\\"' job",
                 mark, gchild);
    scene_config(name, launcher, ", \"grace_s\": 1", cfg, sizeof cfg);
    double cyc = this_cycle();
    pid_t pid = serve(cfg, "sleep:60", log);
    long job = read_pid(mark, 20), g = read_pid(gchild, 20);
    CHECK(job > 0 && g > 0, "job %ld and its grandchild %ld started", job, g);
    if (!ignore_term) /* the cycle has started inside the job */
        (void)wait_row(name, cyc, "running", 20, &(history_run){0});
    double t0 = time_monotonic();
    kill(pid, SIGTERM);
    int rc = xc_wait_exit(pid, 15);
    double took = time_monotonic() - t0;
    CHECK(rc == 0, "%s: serve exits 0 after cancelling (%d)", name, rc);
    CHECK(took < (ignore_term ? 1 + 5 : 5), "%s: within %.1f s", name, took);
    double end = time_monotonic() + 3;
    while (!(gone(job) && gone(g)) && time_monotonic() < end)
        nap(0.05);
    CHECK(job > 0 && gone(job), "%s: the job's process is gone", name);
    CHECK(g > 0 && gone(g), "%s: the grandchild in its group is gone", name);
    history_run r;
    wait_row(name, cyc, "cancelled", 2, &r);
    CHECK(!strcmp(r.result, "cancelled"), "%s: recorded cancelled (%s: %s)", name, r.result, r.message);
    history_run_clear(&r);
    if (check_failed_)
        show_log(log);
}

/* A launcher that cannot start, and a job killed before it records anything:
 * one line, recorded failed (so not relaunched in a loop), nothing published. */
static void test_failures(void)
{
    static const struct { const char *name, *launcher, *says; } c[] = {
        {"nolauncher", "/nonexistent/mpirun -np 2", "cannot start /nonexistent/mpirun"},
        {"killed", "sh -c 'kill -9 $$' job", "signal 9"},
        {"failing", "sh -c 'exit 3' job", "exit status 3"},
    };
    for (size_t i = 0; i < sizeof c / sizeof c[0]; i++) {
        char cfg[800], log[800], latest[900];
        snprintf(log, sizeof log, "%s/%s.log", tmp, c[i].name);
        scene_config(c[i].name, c[i].launcher, NULL, cfg, sizeof cfg);
        double cyc = this_cycle();
        pid_t pid = serve(cfg, "sleep:0", log);
        history_run r;
        wait_row(c[i].name, cyc, "failed|ok", 20, &r);
        CHECK(!strcmp(r.result, "failed") && strstr(r.message, c[i].says) && !strchr(r.message, '\n'),
              "%s: recorded failed in one line naming the cause (%s: %s)", c[i].name, r.result, r.message);
        history_run_clear(&r);
        kill(pid, SIGTERM);
        CHECK(xc_wait_exit(pid, 10) == 0, "%s: serve exits 0", c[i].name);
        snprintf(latest, sizeof latest, "%s/%s/out/latest", tmp, c[i].name);
        struct stat st;
        CHECK(lstat(latest, &st) != 0, "%s: nothing published", c[i].name);
        char *t = xc_slurp(log);
        CHECK(t && strstr(t, c[i].says), "%s: the log says it", c[i].name);
        free(t);
        if (check_failed_)
            show_log(log);
    }
}

/* Live processes whose command line contains what. */
static int count_procs(const char *what)
{
    DIR *d = opendir("/proc");
    struct dirent *de;
    int n = 0;
    while (d && (de = readdir(d))) {
        if (de->d_name[0] < '0' || de->d_name[0] > '9')
            continue;
        char p[300], buf[4096];
        snprintf(p, sizeof p, "/proc/%s/cmdline", de->d_name);
        FILE *f = fopen(p, "r");
        if (!f)
            continue;
        size_t len = fread(buf, 1, sizeof buf - 1, f);
        fclose(f);
        for (size_t i = 0; i < len; i++)
            if (!buf[i])
                buf[i] = ' ';
        buf[len] = 0;
        if (strstr(buf, what) && !gone(atol(de->d_name)))
            n++;
    }
    if (d)
        closedir(d);
    return n;
}

/* The real engine's decomposed cycle (parallel.decomposition "domain")
 * launched by serve under mpirun -np 2: the small engine case's packed ice
 * reaching within a kernel support of its coast (test_mpi_run's first
 * case) with an atmosphere whose time axis covers the wall clock (serve
 * names its cycles by it). Recorded ok; the products equal, by
 * tools/same-products.sh, those of the plain build's serial canonical run
 * of the same cycle and configuration; SIGTERM to serve during a longer
 * decomposed cycle leaves no rank. */
static void domain_config(const char *name, const char *launcher, const char *program, double hours, int iters,
                          char *cfg, size_t len)
{
    char text[8192], d[200], extra[1400];
    snprintf(d, sizeof d, "%s/%s", tmp, name);
    snprintf(extra, sizeof extra,
             "\"parallel\": {\"decomposition\": \"domain\"},"
             " \"launcher\": {\"command\": \"%s\", \"program\": \"%s\"},", launcher, program);
    ec_config(text, sizeof text, tmp, 300, "[\"wind\"]", "ice_packed.nc", extra);
    char model[200];
    snprintf(model, sizeof model, "\"thermo\": {\"dt\": 0}, \"physics\": \"full\", \"evp\": {\"iterations\": %d}", iters);
    int ok = ec_config_replace(text, sizeof text, "\"thermo\": {\"dt\": 600}", model);
    char sched[300];
    snprintf(sched, sizeof sched, "\"schedule\": {\"every_seconds\": 3600, \"catch_up\": false, \"forecast_hours\": %g,",
             hours);
    ok = ok && ec_config_replace(text, sizeof text, "\"schedule\": {\"every_hours\": 6, \"forecast_hours\": 6,", sched);
    char from[2000], to[2000];
    snprintf(from, sizeof from, "\"dir\": \"%s/out\"", tmp);
    snprintf(to, sizeof to, "\"dir\": \"%s/out\"", d);
    ok = ok && ec_config_replace(text, sizeof text, from, to);
    snprintf(from, sizeof from, "\"state_dir\": \"%s/state\", \"cache_dir\": \"%s/cache\"", tmp, tmp);
    snprintf(to, sizeof to, "\"state_dir\": \"%s/state\", \"cache_dir\": \"%s/cache\"", d, d);
    ok = ok && ec_config_replace(text, sizeof text, from, to);
    CHECK(ok, "%s: the engine case's configuration edited", name);
    snprintf(cfg, len, "%s/%s.json", tmp, name);
    sph_error e;
    sph_error_clear(&e);
    CHECK(atomic_write_file(cfg, text, strlen(text), &e) == SPH_OK, "%s", e.msg);
}

static void test_mpirun_domain(const char *mpi, const char *launcher)
{
    char p[900];
    snprintf(p, sizeof p, "%s/ice_packed.nc", tmp);
    ec_write_ice_at(p, 35, 21, 121.2, 40.1, 0.02, 0.02, 1.0, 1.0, -1); /* to 121.88 E, the coast at 121.9 */
    snprintf(p, sizeof p, "%s/mask.nc", tmp);
    ec_write_mask(p);
    double now = time_now();
    snprintf(p, sizeof p, "%s/atm.nc", tmp); /* hourly, from 6 h before the wall clock's hour to 10 h after */
    ec_write_atm_axis(p, "hours since 1970-01-01 00:00:00", floor(now / 3600.0) - 6.0, 17, NC_NETCDF4);

    char cfg[800], log[800], cmd[4000];
    domain_config("dd", launcher, mpi, 1, 30, cfg, sizeof cfg);
    snprintf(log, sizeof log, "%s/dd.log", tmp);
    double cyc = this_cycle();
    pid_t pid = serve(cfg, NULL, log);
    history_run r;
    wait_row("dd", cyc, "ok|failed", 180, &r);
    CHECK(!strcmp(r.result, "ok"), "domain: the decomposed cycle under %s recorded ok (%s: %s)", launcher, r.result,
          r.message);
    history_run_clear(&r);
    kill(pid, SIGTERM);
    CHECK(xc_wait_exit(pid, 20) == 0, "domain: serve exits 0");
    snprintf(cmd, sizeof cmd, "grep -q 'decomposition \"domain\" over 2 ranks' %s", log);
    CHECK(system(cmd) == 0, "domain: the launched run was decomposed over 2 ranks (%s)", log);
    char name[32], iso[32];
    cycle_name(cyc, name, sizeof name);
    time_format_iso(cyc, iso, sizeof iso);
    snprintf(cmd, sizeof cmd, "OMP_NUM_THREADS=1 %s run %s --cycle %s --hours 1 --out %s/dd-serial "
             "--force >%s/dd-serial.log 2>&1", exe, cfg, iso, tmp, tmp);
    CHECK(system(cmd) == 0, "domain: the serial canonical run of cycle %s (%s/dd-serial.log)", iso, tmp);
    snprintf(cmd, sizeof cmd, "sh tools/same-products.sh %s/dd-serial/%s %s/dd/out/%s", tmp, name, tmp, name);
    CHECK(system(cmd) == 0, "domain: every product serve published equals the serial canonical run's (%s)", cmd);
    if (check_failed_)
        show_log(log);

    /* SIGTERM to serve during a 9 h decomposed cycle: every rank goes */
    /* 100 times the iterations: the job outlasts the wait below on any machine */
    domain_config("ddcancel", launcher, mpi, 9, 3000, cfg, sizeof cfg);
    snprintf(log, sizeof log, "%s/ddcancel.log", tmp);
    pid = serve(cfg, NULL, log);
    wait_row("ddcancel", cyc, "running", 60, &r);
    history_run_clear(&r);
    char what[900];
    snprintf(what, sizeof what, "%s/ddcancel/state/launch-", tmp);
    double end = time_monotonic() + 30;
    while (count_procs(what) < 3 && time_monotonic() < end) /* mpirun and two ranks */
        nap(0.05);
    nap(1.0); /* into the decomposed steps */
    int before = count_procs(what);
    CHECK(before >= 3, "domain: mpirun and its ranks run (%d processes)", before);
    kill(pid, SIGTERM);
    CHECK(xc_wait_exit(pid, 40) == 0, "domain: serve exits 0 after cancelling the decomposed job");
    end = time_monotonic() + 5;
    while (count_procs(what) > 0 && time_monotonic() < end)
        nap(0.05);
    CHECK(count_procs(what) == 0, "domain: no rank left (%d of %d)", count_procs(what), before);
    wait_row("ddcancel", cyc, "cancelled|ok|failed", 2, &r);
    CHECK(!strcmp(r.result, "cancelled"), "domain: the decomposed job recorded cancelled (%s: %s)", r.result,
          r.message);
    history_run_clear(&r);
    if (check_failed_)
        show_log(log);
}

/* Under mpirun with the MPI build (skipped with one line without them). */
static void test_mpirun(void)
{
    char mpi[700];
    snprintf(mpi, sizeof mpi, "%s", exe);
    char *slash = strrchr(mpi, '/');
    if (slash)
        *slash = 0;
    slash = strrchr(mpi, '/');
    if (slash)
        *slash = 0;
    strncat(mpi, "/build-mpi/sphice", sizeof mpi - strlen(mpi) - 1);
    if (system("command -v mpirun >/dev/null 2>&1") != 0 || access(mpi, X_OK) != 0) {
        printf("note: mpirun or %s missing: the MPI launcher case skipped (sh tools/install-deps.sh --mpi; make MPI=1)\n",
               mpi);
        return;
    }
    char cfg[800], log[800], extra[900];
    snprintf(log, sizeof log, "%s/mpi.log", tmp);
    snprintf(extra, sizeof extra, ", \"program\": \"%s\"", mpi);
    const char *root = getuid() == 0 ? " --allow-run-as-root" : "";
    char launcher[256];
    snprintf(launcher, sizeof launcher, "mpirun --oversubscribe%s -np 2", root);
    scene_config("mpi", launcher, extra, cfg, sizeof cfg);
    double cyc = this_cycle();
    pid_t pid = serve(cfg, "sleep:0.2", log);
    history_run r;
    wait_row("mpi", cyc, "ok|failed", 60, &r);
    CHECK(!strcmp(r.result, "ok"), "cycle under mpirun -np 2 recorded ok (%s: %s)", r.result, r.message);
    history_run_clear(&r);
    kill(pid, SIGTERM);
    CHECK(xc_wait_exit(pid, 20) == 0, "serve exits 0");

    /* SIGTERM to serve while the MPI job runs: every rank goes */
    scene_config("mpicancel", launcher, extra, cfg, sizeof cfg);
    snprintf(log, sizeof log, "%s/mpicancel.log", tmp);
    pid = serve(cfg, "sleep:60", log);
    wait_row("mpicancel", cyc, "running", 60, &r);
    history_run_clear(&r);
    char what[900];
    snprintf(what, sizeof what, "%s/mpicancel/state/launch-", tmp);
    double end = time_monotonic() + 20;
    while (count_procs(what) < 3 && time_monotonic() < end) /* mpirun and two ranks */
        nap(0.05);
    int before = count_procs(what);
    CHECK(before >= 3, "mpirun and its ranks run (%d processes)", before);
    kill(pid, SIGTERM);
    CHECK(xc_wait_exit(pid, 40) == 0, "serve exits 0 after cancelling the MPI job");
    end = time_monotonic() + 5;
    while (count_procs(what) > 0 && time_monotonic() < end)
        nap(0.05);
    CHECK(count_procs(what) == 0, "no rank left (%d of %d)", count_procs(what), before);
    wait_row("mpicancel", cyc, "cancelled", 2, &r);
    CHECK(!strcmp(r.result, "cancelled"), "MPI job recorded cancelled (%s: %s)", r.result, r.message);
    history_run_clear(&r);
    if (check_failed_)
        show_log(log);
    snprintf(launcher, sizeof launcher, "mpirun --oversubscribe%s -x OMP_NUM_THREADS=1 -np 2", root);
    setenv("OMP_NUM_THREADS", "1", 1);
    test_mpirun_domain(mpi, launcher);
}

int main(void)
{
    if (xc_find_sphice(exe, sizeof exe))
        return 1;
    CHECK(mkdtemp(tmp) != NULL, "mkdtemp");
    char atm[700];
    snprintf(atm, sizeof atm, "%s/atm.nc", tmp);
    sph_error e;
    sph_error_clear(&e);
    atomic_write_file(atm, "forcing", 7, &e);
    test_snapshot_round_trip();
    test_split();
    test_ok();
    test_cancel("cancel", 0);
    test_cancel("grace", 1);
    test_failures();
    test_mpirun();
    if (!check_failed_)
        cycle_remove_tree(tmp);
    else
        fprintf(stderr, "kept %s\n", tmp);
    return check_summary("test_launcher");
}
