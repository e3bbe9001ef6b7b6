#include "util/timeutil.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* Howard Hinnant's days_from_civil: exact for the proleptic Gregorian calendar. */
long time_days_from_civil(long y, int m, int d)
{
    y -= m <= 2;
    long era = (y >= 0 ? y : y - 399) / 400;
    long yoe = y - era * 400;
    long doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
    long doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    return era * 146097 + doe - 719468;
}

void time_civil_from_days(long z, long *year, int *month, int *day)
{
    z += 719468;
    long era = (z >= 0 ? z : z - 146096) / 146097;
    long doe = z - era * 146097;
    long yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
    long y = yoe + era * 400;
    long doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    long mp = (5 * doy + 2) / 153;
    int d = (int)(doy - (153 * mp + 2) / 5 + 1);
    int m = (int)(mp < 10 ? mp + 3 : mp - 9);
    *year = y + (m <= 2);
    *month = m;
    *day = d;
}

static int days_in_month(long y, int m)
{
    static const int dm[] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
    if (m == 2 && ((y % 4 == 0 && y % 100 != 0) || y % 400 == 0))
        return 29;
    return dm[m - 1];
}

static int read_int(const char **p, int ndigits, long *out)
{
    long v = 0;
    for (int i = 0; i < ndigits; i++) {
        if (!isdigit((unsigned char)(*p)[i]))
            return -1;
        v = v * 10 + ((*p)[i] - '0');
    }
    *p += ndigits;
    *out = v;
    return 0;
}

int time_parse_iso(const char *text, double *seconds)
{
    if (!text)
        return -1;
    const char *p = text;
    long y, mo, d, hh = 0, mi = 0, ss = 0;
    double frac = 0.0;
    if (read_int(&p, 4, &y) || *p++ != '-' || read_int(&p, 2, &mo) || *p++ != '-' ||
        read_int(&p, 2, &d))
        return -1;
    if (mo < 1 || mo > 12 || d < 1 || d > days_in_month(y, (int)mo))
        return -1;
    long offset = 0;
    if (*p == 'T' || *p == ' ') {
        p++;
        if (read_int(&p, 2, &hh) || *p++ != ':' || read_int(&p, 2, &mi))
            return -1;
        if (*p == ':') {
            p++;
            if (read_int(&p, 2, &ss))
                return -1;
            if (*p == '.') {
                char *end;
                frac = strtod(p, &end);
                p = end;
            }
        }
        if (hh > 23 || mi > 59 || ss > 60)
            return -1;
        if (*p == 'Z') {
            p++;
        } else if (*p == '+' || *p == '-') {
            int sign = *p == '-' ? -1 : 1;
            long oh, om = 0;
            p++;
            if (read_int(&p, 2, &oh))
                return -1;
            if (*p == ':')
                p++;
            if (isdigit((unsigned char)*p) && read_int(&p, 2, &om))
                return -1;
            offset = sign * (oh * 3600 + om * 60);
        }
    }
    if (*p != '\0')
        return -1;
    *seconds = (double)time_days_from_civil(y, (int)mo, (int)d) * 86400.0 +
               (double)(hh * 3600 + mi * 60 + ss) + frac - (double)offset;
    return 0;
}

void time_format_iso(double seconds, char *buf, size_t len)
{
    /* a time from a bad file in an error message: beyond +-1e15 s (about
     * 30 million years) the day count would not fit a long */
    if (!(fabs(seconds) <= 1e15)) {
        snprintf(buf, len, "%g s since 1970-01-01Z", seconds);
        return;
    }
    double r = floor(seconds + 0.5);
    long days = (long)floor(r / 86400.0);
    long sod = (long)(r - (double)days * 86400.0);
    long y;
    int m, d;
    time_civil_from_days(days, &y, &m, &d);
    snprintf(buf, len, "%04ld-%02d-%02dT%02ld:%02ld:%02ldZ", y, m, d, sod / 3600,
             (sod / 60) % 60, sod % 60);
}

double time_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

double time_monotonic(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}
