#include "util/log.h"

#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

int sph_log_level = LOG_LVL_INFO;

static pthread_mutex_t log_lock = PTHREAD_MUTEX_INITIALIZER;

int sph_log_level_parse(const char *name)
{
    if (!name)
        return -1;
    if (!strcmp(name, "error")) return LOG_LVL_ERROR;
    if (!strcmp(name, "warn")) return LOG_LVL_WARN;
    if (!strcmp(name, "info")) return LOG_LVL_INFO;
    if (!strcmp(name, "debug")) return LOG_LVL_DEBUG;
    return -1;
}

void sph_log_write(int level, const char *fmt, ...)
{
    static const char *names[] = {"", "", "", "error", "warn", "", "info", "debug"};
    char line[2048];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    /* one event, one line */
    for (char *p = line; *p; p++)
        if (*p == '\n')
            *p = ' ';
    pthread_mutex_lock(&log_lock);
    if (getenv("JOURNAL_STREAM")) {
        fprintf(stderr, "<%d>%s\n", level, line);
    } else {
        char ts[32];
        time_t now = time(NULL);
        struct tm tm;
        gmtime_r(&now, &tm);
        strftime(ts, sizeof ts, "%Y-%m-%dT%H:%M:%SZ", &tm);
        fprintf(stderr, "%s sphice %s: %s\n", ts, names[level & 7], line);
    }
    fflush(stderr);
    pthread_mutex_unlock(&log_lock);
}
