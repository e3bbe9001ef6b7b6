/* Inputs the fuzz harnesses (tests/fuzz/) found, replayed in the ordinary
 * build so that the suite keeps them fixed without clang:
 *   fuzz_forcing: a time axis of about -1.1e212 s; the coverage error
 *   formatted it with time_format_iso, whose cast of the day count to long
 *   was undefined. A time that far out (or not finite) is now written as
 *   seconds since 1970, naming the value; one in range keeps ISO 8601.
 * (fuzz_raster's huge ESRI ncols is checked in test_raster.) */
#include <math.h>

#include "util/timeutil.h"

#include "check.h"

int main(void)
{
    char buf[64];
    time_format_iso(-1.12435e212, buf, sizeof buf);
    CHECK(strstr(buf, "-1.12435e+212") && strstr(buf, "since 1970"), "huge time: %s", buf);
    time_format_iso(NAN, buf, sizeof buf);
    CHECK(strstr(buf, "nan") != NULL, "NaN time: %s", buf);
    time_format_iso(INFINITY, buf, sizeof buf);
    CHECK(strstr(buf, "inf") != NULL, "infinite time: %s", buf);
    /* in range: 1999-02-08T06:00:00Z is 918453600 s (10630 days + 6 h) */
    time_format_iso(10630.0 * 86400.0 + 6 * 3600.0, buf, sizeof buf);
    CHECK(strcmp(buf, "1999-02-08T06:00:00Z") == 0, "ISO time: %s", buf);
    /* the edge of the range still formats as a date: 1e15 s is about year 31.7 million */
    time_format_iso(1e15, buf, sizeof buf);
    CHECK(strchr(buf, 'T') && buf[strlen(buf) - 1] == 'Z', "1e15 s: %s", buf);
    return check_summary("test_fuzz_regress");
}
