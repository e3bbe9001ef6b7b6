/* CF time coordinates: "<unit> since <date>" with the CF calendars.
 *
 * Invariants: every conversion goes through a day number (days since
 * 1970-01-01 counted in some calendar) plus seconds into the day, so the
 * arithmetic on large offsets stays exact in doubles for whole seconds. */
#include "io/cf.h"
#include "util/timeutil.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

int cf_calendar_parse(const char *name, cf_calendar *cal)
{
    static const struct {
        const char *name;
        cf_calendar cal;
    } table[] = {
        {"standard", CF_CAL_STANDARD},        {"gregorian", CF_CAL_STANDARD},
        {"proleptic_gregorian", CF_CAL_PROLEPTIC}, {"julian", CF_CAL_JULIAN},
        {"noleap", CF_CAL_NOLEAP},            {"365_day", CF_CAL_NOLEAP},
        {"all_leap", CF_CAL_ALL_LEAP},        {"366_day", CF_CAL_ALL_LEAP},
        {"360_day", CF_CAL_360},
    };
    if (!name || !*name) {
        *cal = CF_CAL_STANDARD;
        return 0;
    }
    for (size_t i = 0; i < sizeof table / sizeof table[0]; i++)
        if (strcasecmp(name, table[i].name) == 0) {
            *cal = table[i].cal;
            return 0;
        }
    return -1;
}

static const int cum_noleap[13] = {0, 31, 59, 90, 120, 151, 181, 212, 243, 273, 304, 334, 365};
static const int cum_leap[13] = {0, 31, 60, 91, 121, 152, 182, 213, 244, 274, 305, 335, 366};

static long floordiv(long a, long b)
{
    long q = a / b;
    return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}

/* Julian-calendar date to days since 1970-01-01 (JDN 2440588). */
static long julian_days(long y, int m, int d)
{
    long a = (14 - m) / 12;
    long yy = y + 4800 - a;
    long mm = m + 12 * a - 3;
    long jdn = d + (153 * mm + 2) / 5 + 365 * yy + floordiv(yy, 4) - 32083;
    return jdn - 2440588;
}

double cf_calendar_day_number(cf_calendar cal, long y, int m, int d)
{
    switch (cal) {
    case CF_CAL_PROLEPTIC:
        return (double)time_days_from_civil(y, m, d);
    case CF_CAL_STANDARD:
        if (y > 1582 || (y == 1582 && (m > 10 || (m == 10 && d >= 15))))
            return (double)time_days_from_civil(y, m, d);
        return (double)julian_days(y, m, d);
    case CF_CAL_JULIAN:
        return (double)julian_days(y, m, d);
    case CF_CAL_NOLEAP:
        return (double)((y - 1970) * 365 + cum_noleap[m - 1] + d - 1);
    case CF_CAL_ALL_LEAP:
        return (double)((y - 1970) * 366 + cum_leap[m - 1] + d - 1);
    case CF_CAL_360:
        return (double)((y - 1970) * 360 + (m - 1) * 30 + d - 1);
    }
    return 0.0;
}

/* Inverse of the day number for the fixed-length-year calendars. */
static void fixed_calendar_date(cf_calendar cal, long days, long *y, int *m, int *d)
{
    long len = cal == CF_CAL_NOLEAP ? 365 : cal == CF_CAL_ALL_LEAP ? 366 : 360;
    long yq = floordiv(days, len);
    long doy = days - yq * len;
    *y = 1970 + yq;
    if (cal == CF_CAL_360) {
        *m = (int)(doy / 30) + 1;
        *d = (int)(doy % 30) + 1;
        return;
    }
    const int *cum = cal == CF_CAL_NOLEAP ? cum_noleap : cum_leap;
    int mo = 1;
    while (mo < 12 && doy >= cum[mo])
        mo++;
    *m = mo;
    *d = (int)(doy - cum[mo - 1]) + 1;
}

static int is_leap(long y)
{
    return (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
}

static int parse_long(const char **p, long *out)
{
    char *end;
    errno = 0;
    long v = strtol(*p, &end, 10);
    if (end == *p)
        return -1;
    *p = end;
    *out = v;
    return 0;
}

int cf_time_parse(const char *units, cf_calendar cal, cf_time_units *out)
{
    if (!units)
        return -1;
    const char *p = units;
    while (isspace((unsigned char)*p))
        p++;
    char word[32];
    size_t n = 0;
    while (isalpha((unsigned char)*p) && n + 1 < sizeof word)
        word[n++] = (char)tolower((unsigned char)*p++);
    word[n] = '\0';
    static const struct {
        const char *name;
        double sec;
    } unit_names[] = {
        {"seconds", 1}, {"second", 1}, {"secs", 1}, {"sec", 1}, {"s", 1},
        {"minutes", 60}, {"minute", 60}, {"mins", 60}, {"min", 60},
        {"hours", 3600}, {"hour", 3600}, {"hrs", 3600}, {"hr", 3600}, {"h", 3600},
        {"days", 86400}, {"day", 86400}, {"d", 86400},
        {"weeks", 604800}, {"week", 604800},
    };
    double usec = 0;
    for (size_t i = 0; i < sizeof unit_names / sizeof unit_names[0]; i++)
        if (strcmp(word, unit_names[i].name) == 0)
            usec = unit_names[i].sec;
    if (usec == 0)
        return -1;
    while (isspace((unsigned char)*p))
        p++;
    if (strncasecmp(p, "since", 5) != 0)
        return -1;
    p += 5;
    while (isspace((unsigned char)*p))
        p++;
    long y, mo, d, hh = 0, mi = 0;
    double ss = 0;
    if (parse_long(&p, &y) || *p++ != '-' || parse_long(&p, &mo) || *p++ != '-' ||
        parse_long(&p, &d))
        return -1;
    if (mo < 1 || mo > 12 || d < 1 || d > 31)
        return -1;
    if (*p == 'T' || *p == ' ') {
        const char *q = p + 1;
        while (isspace((unsigned char)*q))
            q++;
        if (isdigit((unsigned char)*q)) {
            p = q;
            if (parse_long(&p, &hh))
                return -1;
            if (*p == ':') {
                p++;
                if (parse_long(&p, &mi))
                    return -1;
                if (*p == ':') {
                    p++;
                    char *end;
                    ss = strtod(p, &end);
                    if (end == p)
                        return -1;
                    p = end;
                }
            }
        }
    }
    /* Time zone: "Z", "UTC", "GMT", "+h", "+hh:mm", "-hhmm", "h:mm" (CF allows one). */
    while (isspace((unsigned char)*p))
        p++;
    double tz = 0;
    if (*p == 'Z' || *p == 'z')
        p++;
    else if (strncasecmp(p, "UTC", 3) == 0 || strncasecmp(p, "GMT", 3) == 0)
        p += 3;
    else if (*p == '+' || *p == '-' || isdigit((unsigned char)*p)) {
        /* unsigned "h:mm" is a positive offset, as UDUNITS-2 reads it
         * (wgrib2 writes "seconds since 1970-01-01 00:00:00.0 0:00") */
        int sign = *p == '-' ? -1 : 1;
        if (!isdigit((unsigned char)*p))
            p++;
        const char *start = p;
        long th = 0, tm = 0;
        if (parse_long(&p, &th))
            return -1;
        if (*p == ':') {
            p++;
            if (parse_long(&p, &tm))
                return -1;
        } else if (p - start == 4) {
            tm = th % 100;
            th /= 100;
        }
        tz = sign * (th * 3600.0 + tm * 60.0);
    }
    while (isspace((unsigned char)*p))
        p++;
    if (*p != '\0')
        return -1;
    if (hh < 0 || hh > 24 || mi < 0 || mi > 59 || ss < 0 || ss > 61)
        return -1;
    out->unit_seconds = usec;
    out->ref_year = y;
    out->ref_month = (int)mo;
    out->ref_day = (int)d;
    out->ref_seconds = hh * 3600.0 + mi * 60.0 + ss - tz;
    out->calendar = cal;
    return 0;
}

int cf_time_to_model(const cf_time_units *u, double value, double *model_seconds)
{
    double ref_days = cf_calendar_day_number(u->calendar, u->ref_year, u->ref_month, u->ref_day);
    double secs = value * u->unit_seconds + u->ref_seconds;
    switch (u->calendar) {
    case CF_CAL_STANDARD:
    case CF_CAL_PROLEPTIC:
    case CF_CAL_JULIAN:
        /* Elapsed time is calendar-independent: only the reference date needed
         * the calendar. */
        *model_seconds = ref_days * 86400.0 + secs;
        return 0;
    default:
        break;
    }
    double whole = floor(secs / 86400.0);
    double sod = secs - whole * 86400.0;
    long days = (long)ref_days + (long)whole;
    long y;
    int m, d;
    fixed_calendar_date(u->calendar, days, &y, &m, &d);
    int dim_real = m == 2 ? (is_leap(y) ? 29 : 28)
                          : (m == 4 || m == 6 || m == 9 || m == 11) ? 30 : 31;
    if (d > dim_real)
        return -1;
    *model_seconds = (double)time_days_from_civil(y, m, d) * 86400.0 + sod;
    return 0;
}
