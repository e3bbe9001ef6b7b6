/* CF time units and calendars, and udunits conversions. Expected times come
 * from calendar arithmetic done by hand (and util's ISO parser); expected
 * conversion factors from the unit definitions (1 knot = 1852/3600 m/s). */
#include "check.h"
#include "io/cf.h"
#include "util/timeutil.h"

static double iso(const char *s)
{
    double t = NAN;
    if (time_parse_iso(s, &t) != 0)
        fprintf(stderr, "bad iso %s\n", s);
    return t;
}

static double cf(const char *units, const char *cal, double v, int *rc)
{
    cf_calendar c;
    cf_time_units u;
    double t = NAN;
    *rc = -9;
    if (cf_calendar_parse(cal, &c) != 0 || cf_time_parse(units, c, &u) != 0)
        return NAN;
    *rc = cf_time_to_model(&u, v, &t);
    return t;
}

static void test_time(void)
{
    int rc;
    double t = cf("hours since 1900-01-01 00:00:0.0", "gregorian", 1060000.0, &rc);
    /* 1900-01-01 is 25567 days before 1970-01-01. */
    CHECK_CLOSE(t, 1060000.0 * 3600.0 - 25567.0 * 86400.0, 0, 0, "hours since 1900");
    t = cf("days since 1950-1-1", NULL, 0.5, &rc);
    CHECK_CLOSE(t, iso("1950-01-01T12:00:00Z"), 0, 0, "days since 1950-1-1");
    t = cf("seconds since 1970-01-01T00:00:00Z", "proleptic_gregorian", 12345.0, &rc);
    CHECK_CLOSE(t, 12345.0, 0, 0, "seconds since epoch");
    t = cf("minutes since 2020-01-01 00:00:00 UTC", "standard", 90.0, &rc);
    CHECK_CLOSE(t, iso("2020-01-01T01:30:00Z"), 0, 0, "minutes UTC");
    t = cf("hours since 2020-01-01 00:00:00 +05:30", "standard", 0.0, &rc);
    CHECK_CLOSE(t, iso("2019-12-31T18:30:00Z"), 0, 0, "offset +05:30");
    /* an unsigned offset is positive: UDUNITS-2 (ut_parse) gives 19691231T183000 UTC
     * for "... 5:30" and 19700101T000000 for wgrib2's "... 00:00:00.0 0:00" */
    t = cf("seconds since 1970-01-01 00:00:00.0 5:30", "standard", 0.0, &rc);
    CHECK_CLOSE(t, iso("1969-12-31T18:30:00Z"), 0, 0, "unsigned offset 5:30");
    t = cf("seconds since 1970-01-01 00:00:00.0 0:00", "standard", 7200.0, &rc);
    CHECK(rc == 0, "wgrib2's time units parse");
    CHECK_CLOSE(t, iso("1970-01-01T02:00:00Z"), 0, 0, "wgrib2 0:00");
    /* Mixed Julian/Gregorian: Julian 0001-01-01 is two days before the
     * proleptic Gregorian 0001-01-01, so 1970-01-01 is day 719164. */
    t = cf("days since 0001-01-01 00:00:00", "standard", 719164.0, &rc);
    CHECK_CLOSE(t, 0.0, 0, 0, "standard calendar before 1582");
    t = cf("days since 0001-01-01 00:00:00", "proleptic_gregorian", 719162.0, &rc);
    CHECK_CLOSE(t, 0.0, 0, 0, "proleptic from year 1");
    /* noleap: day 59 after 2000-01-01 is March 1 (31 + 28 days). */
    t = cf("days since 2000-01-01", "noleap", 59.0, &rc);
    CHECK(rc == 0, "noleap rc");
    CHECK_CLOSE(t, iso("2000-03-01"), 0, 0, "noleap day 59");
    t = cf("days since 2000-01-01", "365_day", 365.25, &rc);
    CHECK_CLOSE(t, iso("2001-01-01T06:00:00Z"), 0, 0, "365_day one year");
    /* 360_day: 30-day months; day 59 is Feb 30, which has no real date. */
    t = cf("days since 2000-01-01", "360_day", 59.0, &rc);
    CHECK(rc == -1, "360_day Feb 30 is dropped (rc %d)", rc);
    t = cf("days since 2000-01-01", "360_day", 60.0, &rc);
    CHECK(rc == 0, "360_day Mar 1");
    CHECK_CLOSE(t, iso("2000-03-01"), 0, 0, "360_day Mar 1");
    t = cf("hours since 2001-01-01", "360_day", 359.5 * 24, &rc);
    CHECK_CLOSE(t, iso("2001-12-30T12:00:00Z"), 0, 0, "360_day Dec 30");
    t = cf("days since 2001-01-01", "julian", 0.0, &rc);
    CHECK_CLOSE(t, iso("2001-01-14"), 0, 0, "julian calendar is 13 days behind");

    cf_calendar c;
    cf_time_units u;
    CHECK(cf_calendar_parse("lunar", &c) == -1, "unknown calendar");
    CHECK(cf_time_parse("furlongs since 2000-01-01", CF_CAL_STANDARD, &u) == -1, "bad unit");
    CHECK(cf_time_parse("hours after 2000-01-01", CF_CAL_STANDARD, &u) == -1, "no since");
    CHECK(cf_time_parse("hours since 2000-13-01", CF_CAL_STANDARD, &u) == -1, "bad month");
    CHECK(cf_time_parse("hours since 2000-01-01 garbage", CF_CAL_STANDARD, &u) == -1,
          "trailing text");
}

static void test_units(void)
{
    sph_error err;
    sph_error_clear(&err);
    cf_units *u = NULL;
    CHECK(cf_units_create(&u, &err) == 0, "create: %s", err.msg);
    if (!u)
        return;
    double a, b;
    CHECK(cf_units_linear(u, "K", "degC", &a, &b) == 0, "K");
    CHECK_CLOSE(a * 300.0 + b, 26.85, 0, 1e-12, "300 K");
    CHECK(cf_units_linear(u, "degrees_C", "degC", &a, &b) == 0, "degrees_C");
    CHECK_CLOSE(a * 5.0 + b, 5.0, 0, 1e-12, "degrees_C identity");
    CHECK(cf_units_linear(u, "cm s-1", "m s-1", &a, &b) == 0, "cm/s");
    CHECK_CLOSE(a, 0.01, 1e-14, 0, "cm/s factor");
    CHECK(cf_units_linear(u, "knots", "m s-1", &a, &b) == 0, "knots");
    CHECK_CLOSE(a, 1852.0 / 3600.0, 1e-12, 0, "knot factor");
    CHECK(cf_units_linear(u, "m s**-1", "m s-1", &a, &b) == 0, "ERA5 m s**-1");
    CHECK(cf_units_linear(u, "J m**-2", "W m-2", &a, &b) == -2, "J m-2 not W m-2");
    CHECK(cf_units_convertible(u, "J m**-2", "J m-2"), "J m-2");
    CHECK(cf_units_linear(u, "kg kg**-1", "1", &a, &b) == 0, "kg kg**-1");
    CHECK(cf_units_linear(u, "bananas per hour", "m s-1", &a, &b) == -1, "unknown");
    /* GrADS (GFS over NOMADS) lower case: k, pa, mb (millibar: 100 Pa; not
     * udunits' millibarn, an area), w/m^2; and percent for humidity */
    CHECK(cf_units_linear(u, "k", "degC", &a, &b) == 0, "k");
    CHECK_CLOSE(a * 273.15 + b, 0.0, 0, 1e-12, "273.15 k");
    CHECK(cf_units_linear(u, "mb", "Pa", &a, &b) == 0, "mb");
    CHECK_CLOSE(a, 100.0, 1e-14, 0, "mb factor");
    CHECK(cf_units_linear(u, "pa", "Pa", &a, &b) == 0 && a == 1.0, "pa");
    CHECK(cf_units_linear(u, "w/m^2", "W m-2", &a, &b) == 0 && a == 1.0, "w/m^2");
    CHECK(cf_units_linear(u, "%", "1", &a, &b) == 0, "percent");
    CHECK_CLOSE(a, 0.01, 1e-14, 0, "percent factor");
    /* udunits alone reads "degrees Celsius" as an angle (pi/180) times
     * Celsius: aliased, and any temperature slope other than 1 or 5/9 is
     * refused rather than applied */
    CHECK(cf_units_linear(u, "degrees Celsius", "degC", &a, &b) == 0, "degrees Celsius");
    CHECK_CLOSE(a * 5.0 + b, 5.0, 0, 1e-12, "5 degrees Celsius");
    CHECK(cf_units_linear(u, "degrees Fahrenheit", "degC", &a, &b) == 0, "degrees Fahrenheit");
    CHECK_CLOSE(a * 212.0 + b, 100.0, 0, 1e-9, "212 F");
    CHECK(cf_units_linear(u, "deg K", "degC", &a, &b) == 0, "deg K");
    CHECK(cf_units_linear(u, "arcminute Celsius", "degC", &a, &b) == -2, "angle times Celsius refused");
    CHECK(cf_units_linear(u, "(0 - 1)", "1", &a, &b) == 0 && a == 1.0, "ERA5 (0 - 1)");
    cf_units_free(u);
    cf_units_free(NULL);
}

int main(void)
{
    test_time();
    test_units();
    return check_summary("test_cf");
}
