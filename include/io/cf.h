/* Lower-level CF conventions helpers used by the forcing reader: CF time
 * coordinates (units "<unit> since <date>" and calendars) and physical unit
 * conversion through udunits2.
 *
 * Model time is seconds since 1970-01-01T00:00:00Z, proleptic Gregorian
 * (util/timeutil.h). CF times in the model calendars noleap/365_day,
 * all_leap/366_day and 360_day are converted date by date: the calendar
 * date (Y-M-D h:m:s) a value denotes becomes the same real date. Dates that
 * do not exist in the real calendar (360_day Feb 29 in a non-leap year,
 * Feb 30) have no real time: cf_time_to_model returns -1 for them and the
 * caller drops them from the time axis.
 */
#ifndef SPHICE_IO_CF_H
#define SPHICE_IO_CF_H

#include "util/err.h"

typedef enum {
    CF_CAL_STANDARD = 0,     /* "standard", "gregorian": Julian before 1582-10-15 */
    CF_CAL_PROLEPTIC,        /* "proleptic_gregorian" */
    CF_CAL_JULIAN,           /* "julian" */
    CF_CAL_NOLEAP,           /* "noleap", "365_day" */
    CF_CAL_ALL_LEAP,         /* "all_leap", "366_day" */
    CF_CAL_360               /* "360_day" */
} cf_calendar;

typedef struct cf_time_units {
    double unit_seconds;     /* seconds per unit: 1, 60, 3600, 86400, 604800 */
    long ref_year;           /* reference date in the calendar */
    int ref_month, ref_day;
    double ref_seconds;      /* seconds into the reference day, minus the UTC offset */
    cf_calendar calendar;
} cf_time_units;

/* Parses a calendar attribute (case-insensitive; NULL or "" means
 * standard). Returns 0, or -1 for an unknown calendar. */
int cf_calendar_parse(const char *name, cf_calendar *cal);

/* Parses "hours since 1900-01-01 00:00:0.0", "days since 1950-1-1",
 * "seconds since 1970-01-01T00:00:00Z", "... +05:30", "... UTC".
 * Returns 0, or -1 when the text is not a CF time unit. */
int cf_time_parse(const char *units, cf_calendar cal, cf_time_units *out);

/* Converts a coordinate value to model time. Returns 0, or -1 when the
 * calendar date it denotes does not exist in the real calendar. */
int cf_time_to_model(const cf_time_units *u, double value, double *model_seconds);

/* Days from 1970-01-01 of a date in the given calendar counted as that
 * calendar's day number (not the real date). Used by the conversions. */
double cf_calendar_day_number(cf_calendar cal, long year, int month, int day);

/* Unit conversion through udunits2: create an object, ask for
 * conversions, free it. The udunits2 database behind the objects is read
 * once per process and kept (udunits2 does not free all of it). Not
 * thread-safe per object. */
typedef struct cf_units cf_units;

int cf_units_create(cf_units **out, sph_error *err);
void cf_units_free(cf_units *u);

/* Linear conversion to = a * from + b for a value in units `from` into
 * units `to`. Common non-udunits spellings are accepted (degrees_C,
 * "kg/kg", "m s**-1", "psu"...). Returns 0; -1 when `from` cannot be
 * parsed; -2 when the units are not convertible; -3 when the conversion
 * is not linear. */
int cf_units_linear(cf_units *u, const char *from, const char *to, double *a, double *b);

/* 1 when `from` parses and converts to `to`, else 0. */
int cf_units_convertible(cf_units *u, const char *from, const char *to);

#endif
