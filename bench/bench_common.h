/* Shared helpers of the benchmark programs (bench/bench_*.c): clocks, peak
 * memory, one forked child per run (so that peak RSS and a crash belong to
 * that run alone) and the one CSV row format of bench/out/results.csv:
 *
 *   problem,method,config,cpu_s,wall_s,peak_rss_mb,status,
 *   err_name,err,err2_name,err2,err3_name,err3
 *
 * `err` is the problem's primary error (the y axis of its speed-accuracy
 * chart); err2/err3 are secondary measures (empty when unused). `status`
 * is "ok" or a word saying how the run ended (fatal, recoverable, ...).
 * Header-only: each benchmark is one translation unit. */
#ifndef SPHICE_BENCH_COMMON_H
#define SPHICE_BENCH_COMMON_H

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#define BENCH_CSV_HEADER                                                                   \
    "problem,method,config,cpu_s,wall_s,peak_rss_mb,status,err_name,err,err2_name,err2," \
    "err3_name,err3"

static inline double bench_wall(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* CPU time of the whole process (all threads), s. */
static inline double bench_cpu(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Peak resident set of this process so far, MB (Linux reports KiB). */
static inline double bench_peak_rss_mb(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return (double)ru.ru_maxrss / 1024.0;
}

/* Quick mode (BENCH_QUICK=1): smaller matrices for CI. */
static inline int bench_quick(void)
{
    const char *q = getenv("BENCH_QUICK");
    return q && q[0] && strcmp(q, "0") != 0;
}

typedef struct bench_row {
    const char *problem;
    char method[64];
    char config[160];
    double cpu_s, wall_s, rss_mb;
    char status[64];
    const char *err_name[3];
    double err[3];
} bench_row;

static inline void bench_row_init(bench_row *r, const char *problem)
{
    memset(r, 0, sizeof *r);
    r->problem = problem;
    snprintf(r->status, sizeof r->status, "ok");
    for (int i = 0; i < 3; i++) {
        r->err_name[i] = "";
        r->err[i] = NAN;
    }
}

static inline void bench_row_print(const bench_row *r)
{
    printf("%s,%s,%s,%.4g,%.4g,%.1f,%s", r->problem, r->method, r->config, r->cpu_s, r->wall_s,
           r->rss_mb, r->status);
    for (int i = 0; i < 3; i++) {
        if (r->err_name[i][0] && isfinite(r->err[i]))
            printf(",%s,%.6g", r->err_name[i], r->err[i]);
        else
            printf(",%s,", r->err_name[i]);
    }
    printf("\n");
    fflush(stdout);
}

/* Runs fn(arg, row) in a forked child, which times it, prints the row and
 * exits; the parent waits. A child that dies prints nothing, so the parent
 * writes a row with status "crashed". The row comes back in *out if not
 * NULL (shared memory). Returns 0, or -1 when the child died. */
typedef void (*bench_fn)(const void *arg, bench_row *row);

static inline int bench_run_forked_row(const char *problem, bench_fn fn, const void *arg,
                                       const char *method, const char *config, bench_row *out)
{
    fflush(stdout);
    bench_row *shared = mmap(NULL, sizeof(bench_row), PROT_READ | PROT_WRITE,
                             MAP_SHARED | MAP_ANONYMOUS, -1, 0);
    if (shared == MAP_FAILED)
        shared = NULL;
    pid_t pid = fork();
    if (pid == 0) {
        bench_row r;
        bench_row_init(&r, problem);
        snprintf(r.method, sizeof r.method, "%s", method);
        snprintf(r.config, sizeof r.config, "%s", config);
        double c0 = bench_cpu(), w0 = bench_wall();
        fn(arg, &r);
        if (r.cpu_s == 0.0) { /* fn may time only its own section */
            r.cpu_s = bench_cpu() - c0;
            r.wall_s = bench_wall() - w0;
        }
        r.rss_mb = bench_peak_rss_mb();
        bench_row_print(&r);
        if (shared)
            *shared = r; /* err_name points at string literals: same in both */
        _exit(0);
    }
    int ws = 0;
    if (pid < 0 || waitpid(pid, &ws, 0) < 0 || !WIFEXITED(ws) || WEXITSTATUS(ws) != 0) {
        bench_row r;
        bench_row_init(&r, problem);
        snprintf(r.method, sizeof r.method, "%s", method);
        snprintf(r.config, sizeof r.config, "%s", config);
        snprintf(r.status, sizeof r.status, "crashed");
        bench_row_print(&r);
        if (out)
            *out = r;
        if (shared)
            munmap(shared, sizeof(bench_row));
        return -1;
    }
    if (out && shared)
        *out = *shared;
    if (shared)
        munmap(shared, sizeof(bench_row));
    return 0;
}

static inline int bench_run_forked(const char *problem, bench_fn fn, const void *arg,
                                   const char *method, const char *config)
{
    return bench_run_forked_row(problem, fn, arg, method, config, NULL);
}

#endif
