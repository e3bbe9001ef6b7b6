/* Leveled logging to stderr, one line per event, journald-friendly: when
 * stderr is the journal (JOURNAL_STREAM set) lines carry the "<N>" syslog
 * priority prefix instead of a timestamp. Never call from a signal handler. */
#ifndef SPHICE_UTIL_LOG_H
#define SPHICE_UTIL_LOG_H

enum { LOG_LVL_ERROR = 3, LOG_LVL_WARN = 4, LOG_LVL_INFO = 6, LOG_LVL_DEBUG = 7 };

extern int sph_log_level;  /* messages above this level are dropped */

void sph_log_write(int level, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* Parses "error", "warn", "info", "debug"; returns -1 if unknown. */
int sph_log_level_parse(const char *name);

#define sph_log(level, ...)                       \
    do {                                          \
        if ((level) <= sph_log_level)             \
            sph_log_write((level), __VA_ARGS__);  \
    } while (0)
#define log_error(...) sph_log(LOG_LVL_ERROR, __VA_ARGS__)
#define log_warn(...) sph_log(LOG_LVL_WARN, __VA_ARGS__)
#define log_info(...) sph_log(LOG_LVL_INFO, __VA_ARGS__)
#define log_debug(...) sph_log(LOG_LVL_DEBUG, __VA_ARGS__)

#endif
