/* Cycles as launched jobs (service/launch.h). */
#include "service/launch.h"

#include <errno.h>
#include <math.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "service/config.h"
#include "service/cycle_phase.h"
#include "service/history.h"
#include "service/schedule.h"
#include "util/fileio.h"
#include "util/log.h"
#include "util/timeutil.h"

extern char **environ;

#define LAUNCH_MAX_WORDS 64

int launch_split(const char *cmd, char *buf, size_t len, char **words, int max, sph_error *err)
{
    size_t o = 0;
    int n = 0;
    const char *p = cmd;
    for (;;) {
        while (*p == ' ' || *p == '\t')
            p++;
        if (!*p)
            return n;
        if (n == max)
            return sph_err_set(err, SPH_ERR_CONFIG, "launcher.command: more than %d words", max), -1;
        words[n++] = buf + o;
        while (*p && *p != ' ' && *p != '\t') {
            if (*p == '\'' || *p == '"') {
                char q = *p++;
                const char *end = strchr(p, q);
                if (!end)
                    return sph_err_set(err, SPH_ERR_CONFIG, "launcher.command: unbalanced %c in \"%s\"", q, cmd),
                           -1;
                for (; p < end; p++) {
                    if (o + 1 >= len)
                        return sph_err_set(err, SPH_ERR_CONFIG, "launcher.command: too long"), -1;
                    buf[o++] = *p;
                }
                p++;
                continue;
            }
            if (o + 1 >= len)
                return sph_err_set(err, SPH_ERR_CONFIG, "launcher.command: too long"), -1;
            buf[o++] = *p++;
        }
        buf[o++] = 0;
    }
}

static void sleep_s(double s)
{
    struct timespec ts = {(time_t)s, (long)((s - (double)(time_t)s) * 1e9)};
    while (nanosleep(&ts, &ts) != 0 && errno == EINTR) {
    }
}

/* The job's own process group: posix_spawn with an empty signal mask (the
 * worker thread has the service's signals blocked) and default actions. */
static int spawn_job(char *const argv[], pid_t *pid)
{
    posix_spawnattr_t at;
    posix_spawnattr_init(&at);
    sigset_t none, dflt;
    sigemptyset(&none);
    sigemptyset(&dflt);
    sigaddset(&dflt, SIGTERM);
    sigaddset(&dflt, SIGINT);
    sigaddset(&dflt, SIGHUP);
    sigaddset(&dflt, SIGPIPE);
    posix_spawnattr_setsigmask(&at, &none);
    posix_spawnattr_setsigdefault(&at, &dflt);
    posix_spawnattr_setpgroup(&at, 0);
    posix_spawnattr_setflags(&at, POSIX_SPAWN_SETPGROUP | POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
    int rc = posix_spawnp(pid, argv[0], NULL, &at, argv, environ);
    posix_spawnattr_destroy(&at);
    return rc;
}

/* Waits for the job; on cancel, SIGTERM to the group, SIGKILL after grace.
 * Returns the wait status; *cancelled says whether it was cancelled. */
static int wait_job(pid_t pid, double grace, const volatile sig_atomic_t *cancel, int *cancelled)
{
    double kill_at = NAN;
    int st = 0;
    *cancelled = 0;
    for (;;) {
        pid_t w = waitpid(pid, &st, WNOHANG);
        if (w == pid)
            break;
        if (w < 0 && errno != EINTR) {
            st = 0x7f00; /* cannot wait: treat as failed */
            break;
        }
        if (cancel && *cancel && !*cancelled) {
            *cancelled = 1;
            kill(-pid, SIGTERM);
            kill_at = time_monotonic() + grace;
        }
        if (isfinite(kill_at) && time_monotonic() >= kill_at) {
            kill(-pid, SIGKILL);
            kill_at = INFINITY;
        }
        sleep_s(0.05);
    }
    /* nothing of the job outlives it: ranks left behind by a failed or
     * cancelled launcher go with their group */
    if (*cancelled || !WIFEXITED(st) || WEXITSTATUS(st) != 0)
        kill(-pid, SIGKILL);
    return st;
}

static void describe_status(int st, char *buf, size_t len)
{
    if (WIFEXITED(st))
        snprintf(buf, len, "exit status %d", WEXITSTATUS(st));
    else if (WIFSIGNALED(st))
        snprintf(buf, len, "signal %d", WTERMSIG(st));
    else
        snprintf(buf, len, "status 0x%x", st);
}

/* The row of a job that did not record its own end (it died, or never
 * started): so the cycle shows in status and is not launched again in a loop. */
static void record_end(history *h, const cycle_report *rep, const char *result)
{
    if (!h)
        return;
    history_run r;
    sph_error e;
    sph_error_clear(&e);
    int found = history_get(h, rep->cycle, &r, &e);
    if (found <= 0) {
        memset(&r, 0, sizeof r);
        r.cycle = rep->cycle;
        r.started = rep->started;
        r.area_km2 = r.volume_km3 = r.edge_nm = NAN;
    }
    snprintf(r.result, sizeof r.result, "%s", result);
    snprintf(r.message, sizeof r.message, "%s", rep->message);
    r.ended = rep->ended;
    if (history_put(h, &r, &e))
        log_error("%s", e.msg);
    history_run_clear(&r);
}

int launch_cycle(const struct sph_config *cfg, const cycle_opts *o, forecast_progress *prog,
                 const volatile sig_atomic_t *cancel, cycle_report *rep, sph_error *err)
{
    memset(rep, 0, sizeof *rep);
    rep->cycle = o->cycle_time;
    rep->started = time_now();
    rep->result = CYCLE_FAILED;
    char cname[32], iso[32], hours[32] = "";
    cycle_name(o->cycle_time, cname, sizeof cname);
    time_format_iso(o->cycle_time, iso, sizeof iso);
    if (o->hours > 0)
        snprintf(hours, sizeof hours, "%.17g", o->hours);
    snprintf(rep->product_dir, sizeof rep->product_dir, "%s/%s", cfg->output.dir, cname);

    char wbuf[2048], *argv[LAUNCH_MAX_WORDS + 12];
    int nw = launch_split(cfg->launcher.command, wbuf, sizeof wbuf, argv, LAUNCH_MAX_WORDS, err);
    if (nw < 0)
        goto failed;
    if (nw == 0) {
        sph_err_set(err, SPH_ERR_CONFIG, "launcher.command is empty");
        goto failed;
    }
    char program[4096];
    if (cfg->launcher.program[0]) {
        snprintf(program, sizeof program, "%s", cfg->launcher.program);
    } else {
        ssize_t n = readlink("/proc/self/exe", program, sizeof program - 1);
        if (n <= 0) {
            sph_err_set(err, SPH_ERR_IO, "launcher.program: cannot find the running executable (%s)",
                        strerror(errno));
            goto failed;
        }
        program[n] = 0;
    }
    if (access(program, X_OK) != 0) {
        sph_err_set(err, SPH_ERR_CONFIG, "launcher.program %s: %s", program, strerror(errno));
        goto failed;
    }
    /* the configuration in force, not the file as it is now */
    char snap[4200];
    snprintf(snap, sizeof snap, "%s/launch-%s.json", cfg->paths.state_dir, cname);
    char *text = sph_config_to_json(cfg);
    int wr = text ? atomic_write_file(snap, text, strlen(text), err) : sph_err_set(err, SPH_ERR_NOMEM, "launch: no memory");
    free(text);
    if (wr)
        goto failed;
    int a = nw;
    argv[a++] = program;
    argv[a++] = "run";
    argv[a++] = snap;
    argv[a++] = "--cycle";
    argv[a++] = iso;
    if (hours[0]) {
        argv[a++] = "--hours";
        argv[a++] = hours;
    }
    if (o->force)
        argv[a++] = "--force";
    argv[a] = NULL;

    double t_launch = time_now();
    pid_t pid;
    int sr = spawn_job(argv, &pid);
    if (sr) {
        sph_err_set(err, SPH_ERR_IO, "launcher.command \"%s\": cannot start %s: %s", cfg->launcher.command, argv[0],
                    strerror(sr));
        unlink(snap);
        goto failed;
    }
    log_info("cycle %s: launched as pid %ld: %s %s run %s --cycle %s", cname, (long)pid, cfg->launcher.command,
             program, snap, iso);
    cycle_set_phase(prog, o->cycle_time, FC_PHASE_RUNNING, "launched job");
    int cancelled;
    int st = wait_job(pid, cfg->launcher.grace_s, cancel, &cancelled);
    unlink(snap);
    rep->ended = time_now();
    char how[64];
    describe_status(st, how, sizeof how);

    /* what the job recorded */
    history_run r;
    sph_error he;
    sph_error_clear(&he);
    int found = o->hist ? history_get(o->hist, o->cycle_time, &r, &he) : 0;
    int recorded = found > 0 && r.started >= t_launch - 1.0 && strcmp(r.result, "running");
    if (found > 0) {
        snprintf(rep->message, sizeof rep->message, "%s", r.message);
        snprintf(rep->mode, sizeof rep->mode, "%s", r.mode);
        rep->stale = r.stale;
        rep->res.ice_area_km2 = r.area_km2;
        rep->res.ice_volume_km3 = r.volume_km3;
        rep->res.edge_distance_nm = r.edge_nm;
    }
    int ok_exit = WIFEXITED(st) && WEXITSTATUS(st) == 0;
    if (ok_exit && found > 0 && !strcmp(r.result, "ok")) {
        rep->result = r.started >= t_launch - 1.0 ? CYCLE_OK : CYCLE_SKIPPED;
        history_run_clear(&r);
        return SPH_OK;
    }
    if (cancelled || (found > 0 && !strcmp(r.result, "cancelled"))) {
        rep->result = CYCLE_CANCELLED;
        sph_err_set(err, SPH_ERR_CANCELLED, "cycle %s: launched job cancelled (%s)", cname, how);
    } else {
        rep->result = CYCLE_FAILED;
        if (recorded && r.message[0])
            sph_err_set(err, SPH_ERR_IO, "cycle %s: launched job failed (%s): %.700s", cname, how, r.message);
        else
            sph_err_set(err, SPH_ERR_IO, "cycle %s: launched job \"%s\" failed with %s", cname,
                        cfg->launcher.command, how);
    }
    if (found > 0)
        history_run_clear(&r);
    snprintf(rep->message, sizeof rep->message, "%s", err->msg);
    log_error("%s", err->msg);
    if (!recorded) /* it died before recording its end */
        record_end(o->hist, rep, rep->result == CYCLE_CANCELLED ? "cancelled" : "failed");
    return err->code;
failed:
    rep->ended = time_now();
    snprintf(rep->message, sizeof rep->message, "%s", err->msg);
    log_error("cycle %s: %s", cname, err->msg);
    record_end(o->hist, rep, "failed");
    return err->code;
}
