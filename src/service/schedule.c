#include "service/schedule.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "service/config.h"
#include "util/timeutil.h"

/* Period of a regular schedule in seconds, or 0 for a list of times of day. */
static double period(const struct sph_config *c)
{
    if (c->schedule.every_seconds > 0)
        return c->schedule.every_seconds;
    if (c->schedule.every_hours > 0)
        return c->schedule.every_hours * 3600.0;
    return 0;
}

double schedule_prev(const struct sph_config *c, double t)
{
    double p = period(c);
    if (p > 0) {
        double base = c->schedule.every_seconds > 0 ? 0 : floor(t / 86400.0) * 86400.0;
        return base + floor((t - base) / p) * p;
    }
    double day = floor(t / 86400.0) * 86400.0;
    /* today's latest slot <= t, else yesterday's last (the list is sorted, non-empty) */
    for (size_t i = c->schedule.cycles.n; i-- > 0;)
        if (day + c->schedule.cycles.sec[i] <= t)
            return day + c->schedule.cycles.sec[i];
    return day - 86400.0 + c->schedule.cycles.sec[c->schedule.cycles.n - 1];
}

double schedule_next(const struct sph_config *c, double t)
{
    double p = period(c);
    if (p > 0) {
        double base = c->schedule.every_seconds > 0 ? 0 : floor(t / 86400.0) * 86400.0;
        double n = base + (floor((t - base) / p) + 1) * p;
        /* every_hours restarts at each 00:00 when it does not divide 24 h */
        if (c->schedule.every_seconds <= 0 && n > base + 86400.0)
            n = base + 86400.0;
        return n;
    }
    double day = floor(t / 86400.0) * 86400.0;
    for (size_t i = 0; i < c->schedule.cycles.n; i++)
        if (day + c->schedule.cycles.sec[i] > t)
            return day + c->schedule.cycles.sec[i];
    return day + 86400.0 + c->schedule.cycles.sec[0];
}

void cycle_name(double t, char *buf, size_t len)
{
    long s = (long)llround(t);
    long days = (long)floor((double)s / 86400.0);
    long sod = s - days * 86400;
    long y;
    int m, d;
    time_civil_from_days(days, &y, &m, &d);
    int hh = (int)(sod / 3600), mm = (int)(sod / 60 % 60), ss = (int)(sod % 60);
    if (mm == 0 && ss == 0)
        snprintf(buf, len, "%04ld%02d%02dT%02dZ", y, m, d, hh);
    else
        snprintf(buf, len, "%04ld%02d%02dT%02d%02d%02dZ", y, m, d, hh, mm, ss);
}

int cycle_name_parse(const char *name, double *t)
{
    int y, m, d, hh, mm = 0, ss = 0, n = 0;
    size_t len = strlen(name);
    if (len == 12) {
        if (sscanf(name, "%4d%2d%2dT%2dZ%n", &y, &m, &d, &hh, &n) != 4 || n != 12)
            return -1;
    } else if (len == 16) {
        if (sscanf(name, "%4d%2d%2dT%2d%2d%2dZ%n", &y, &m, &d, &hh, &mm, &ss, &n) != 6 || n != 16)
            return -1;
    } else {
        return -1;
    }
    if (m < 1 || m > 12 || d < 1 || d > 31 || hh > 23 || mm > 59 || ss > 59 || hh < 0 || mm < 0 || ss < 0)
        return -1;
    *t = (double)time_days_from_civil(y, m, d) * 86400.0 + hh * 3600.0 + mm * 60.0 + ss;
    return 0;
}
