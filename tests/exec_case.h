/* Running the built program from a test: where it is (BUILD, default
 * build/), one run with its output in a log file and, optionally, a
 * file-size limit (a "full disk") or a test-double engine, and the log
 * printed when a check failed. */
#ifndef SPHICE_TESTS_EXEC_CASE_H
#define SPHICE_TESTS_EXEC_CASE_H

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "util/fileio.h"

extern char **environ;

/* Absolute path of BUILD/sphice into exe; 0, or -1 when it is not built. */
static inline int xc_find_sphice(char *exe, size_t len)
{
    char cwd[512];
    const char *build = getenv("BUILD");
    int ok = getcwd(cwd, sizeof cwd) != NULL;
    int n = snprintf(exe, len, "%s/%s/sphice", ok ? cwd : ".", build ? build : "build");
    if (n > 0 && (size_t)n < len && access(exe, X_OK) == 0)
        return 0;
    fprintf(stderr, "%s: not built\n", exe);
    return -1;
}

/* How a run differs from the test's own environment. */
typedef struct xc_opts {
    const char *engine; /* SPHICE_TEST_ENGINE for the run; NULL: unset */
    long fsize;         /* > 0: RLIMIT_FSIZE in bytes, SIGXFSZ ignored (writes past it fail) */
} xc_opts;

/* Runs argv[0] with argv, stdout and stderr into log (truncated). Returns
 * the exit status, 128 + the signal when it was killed, -1 when it did not
 * start. The limit and the ignored SIGXFSZ are set in this process around
 * posix_spawn (both are inherited) and restored after. */
static inline int xc_run(char *const argv[], const char *log, const xc_opts *o)
{
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, log, O_CREAT | O_WRONLY | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&fa, 1, 2);
    char *saved = getenv("SPHICE_TEST_ENGINE") ? strdup(getenv("SPHICE_TEST_ENGINE")) : NULL;
    if (o && o->engine)
        setenv("SPHICE_TEST_ENGINE", o->engine, 1);
    else
        unsetenv("SPHICE_TEST_ENGINE");
    struct rlimit old_rl;
    getrlimit(RLIMIT_FSIZE, &old_rl);
    void (*old_xfsz)(int) = signal(SIGXFSZ, o && o->fsize > 0 ? SIG_IGN : SIG_DFL);
    if (o && o->fsize > 0) {
        struct rlimit rl = {(rlim_t)o->fsize, old_rl.rlim_max};
        setrlimit(RLIMIT_FSIZE, &rl);
    }
    fflush(NULL);
    pid_t pid;
    int started = posix_spawn(&pid, argv[0], &fa, NULL, argv, environ) == 0;
    setrlimit(RLIMIT_FSIZE, &old_rl);
    signal(SIGXFSZ, old_xfsz);
    if (saved)
        setenv("SPHICE_TEST_ENGINE", saved, 1);
    else
        unsetenv("SPHICE_TEST_ENGINE");
    free(saved);
    posix_spawn_file_actions_destroy(&fa);
    int st;
    if (!started || waitpid(pid, &st, 0) != pid)
        return -1;
    return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

/* The log's text (caller frees), or NULL. */
static inline char *xc_slurp(const char *log)
{
    char *text = NULL;
    size_t len;
    sph_error e;
    sph_error_clear(&e);
    return read_file(log, &text, &len, &e) == SPH_OK ? text : NULL;
}

static inline void xc_show_log(const char *log)
{
    char *text = xc_slurp(log);
    fprintf(stderr, "--- %s\n%s---\n", log, text ? text : "(unreadable)\n");
    free(text);
}

/* Sleeps s seconds. */
static inline void xc_nap(double s)
{
    struct timespec ts = {(time_t)s, (long)((s - (double)(time_t)s) * 1e9)};
    nanosleep(&ts, NULL);
}

/* Waits for pid to exit; returns its exit status (128 + the signal when
 * killed), or -1 on timeout (then kills it). */
static inline int xc_wait_exit(pid_t pid, double timeout)
{
    struct timespec t0;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    int st;
    for (;;) {
        if (waitpid(pid, &st, WNOHANG) == pid)
            return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
        struct timespec t;
        clock_gettime(CLOCK_MONOTONIC, &t);
        if ((double)(t.tv_sec - t0.tv_sec) + 1e-9 * (double)(t.tv_nsec - t0.tv_nsec) >= timeout)
            break;
        xc_nap(0.05);
    }
    kill(pid, SIGKILL);
    waitpid(pid, &st, 0);
    return -1;
}

#endif
