/* Model time: seconds since 1970-01-01T00:00:00Z (UTC, proleptic Gregorian),
 * as a double. Every layer above the core uses this one time axis. */
#ifndef SPHICE_UTIL_TIMEUTIL_H
#define SPHICE_UTIL_TIMEUTIL_H

#include <stddef.h>

/* Parses ISO 8601 UTC: "YYYY-MM-DD", "YYYY-MM-DDTHH:MM[:SS[.fff]][Z]",
 * a space instead of 'T', or an offset "+HH:MM"/"-HH:MM". Returns 0 on
 * success, -1 on malformed text or an impossible date. */
int time_parse_iso(const char *text, double *seconds);

/* Formats as "YYYY-MM-DDTHH:MM:SSZ" (seconds rounded); a time beyond
 * +-1e15 s or not finite as "<%g> s since 1970-01-01Z". */
void time_format_iso(double seconds, char *buf, size_t len);

/* Days since 1970-01-01 of a proleptic Gregorian civil date. */
long time_days_from_civil(long year, int month, int day);
void time_civil_from_days(long days, long *year, int *month, int *day);

/* Wall-clock "now" in model time. */
double time_now(void);
/* Monotonic seconds, for durations. */
double time_monotonic(void);

#endif
