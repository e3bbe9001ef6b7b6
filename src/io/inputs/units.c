/* Physical unit conversion through udunits2.
 *
 * udunits prints parse diagnostics on stderr by default; a daemon's log
 * must carry one line per event, so the handler is set to ut_ignore and the
 * caller reports failures itself. Conversions the forcing reader needs are
 * all affine, so each is reduced to (a, b) once and the converter freed. */
#include "io/cf.h"

#include <ctype.h>
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <udunits2.h>

struct cf_units {
    ut_system *sys;
};

/* One unit system per process, read on first use and never freed:
 * ut_free_system leaves the prefix tables ut_read_xml builds (global
 * tsearch trees of udunits2's prefix.c) allocated, so a daemon that read
 * and freed the database every cycle grew by some kilobytes a cycle
 * (issue 21's soak). The system is only read after loading. */
static pthread_once_t units_once = PTHREAD_ONCE_INIT;
static ut_system *units_sys;
static int units_status;

static void units_load(void)
{
    ut_set_error_message_handler(ut_ignore);
    units_sys = ut_read_xml(NULL);
    units_status = (int)ut_get_status();
}

int cf_units_create(cf_units **out, sph_error *err)
{
    *out = NULL;
    pthread_once(&units_once, units_load);
    if (!units_sys)
        return sph_err_set(err, SPH_ERR_UNITS,
                           "units: cannot read the udunits2 database (ut_read_xml status %d)",
                           units_status);
    cf_units *u = calloc(1, sizeof *u);
    if (!u)
        return sph_err_set(err, SPH_ERR_NOMEM, "units: out of memory");
    u->sys = units_sys;
    *out = u;
    return 0;
}

void cf_units_free(cf_units *u)
{
    free(u); /* the shared system stays (see units_sys) */
}

/* Spellings found in real forcing files that udunits does not read as
 * intended (or at all). Compared case-insensitively after trimming. */
static const char *alias(const char *s)
{
    static const struct {
        const char *from, *to;
    } table[] = {
        {"degrees_C", "degC"}, {"degree_C", "degC"}, {"deg_C", "degC"}, {"degrees C", "degC"},
        {"deg C", "degC"},     {"C", "degC"},        {"celsius", "degC"}, {"degrees_K", "K"},
        {"degree_K", "K"},     {"kg/kg", "1"},       {"kg kg-1", "1"},    {"kg kg**-1", "1"},
        {"kg.kg-1", "1"},      {"psu", "1"},         {"kts", "knot"},     {"kn", "knot"},
        {"fraction", "1"},     {"-", "1"},
        /* GrADS / NOMADS (GFS over OPeNDAP) write units in lower case:
         * "k" and "w/m^2" are no udunits units, "mb" would be millibarn */
        {"k", "K"},            {"pa", "Pa"},         {"hpa", "hPa"},      {"mb", "hPa"},
        {"w/m^2", "W m-2"},    {"w/m2", "W m-2"},    {"w m-2", "W m-2"},  {"w m**-2", "W m-2"},
        {"j/m^2", "J m-2"},    {"j m-2", "J m-2"},   {"j m**-2", "J m-2"},
        /* udunits reads "degrees Celsius" as an angle times Celsius (a
         * factor pi/180): spell the temperatures out */
        {"degrees Celsius", "degC"}, {"degree Celsius", "degC"}, {"degrees_Celsius", "degC"},
        {"deg K", "K"},        {"deg_K", "K"},       {"degrees K", "K"},  {"degree K", "K"},
        {"degrees Kelvin", "K"}, {"degree Kelvin", "K"}, {"degrees_Kelvin", "K"},
        {"degrees Fahrenheit", "degF"}, {"degree Fahrenheit", "degF"}, {"degrees F", "degF"},
        {"deg F", "degF"},
        /* ERA5's fractions (sea-ice cover, cloud cover) */
        {"(0 - 1)", "1"},      {"(0-1)", "1"},       {"0-1", "1"},
    };
    for (size_t i = 0; i < sizeof table / sizeof table[0]; i++)
        if (strcasecmp(s, table[i].from) == 0)
            return table[i].to;
    return s;
}

static ut_unit *parse(cf_units *u, const char *text)
{
    char buf[256];
    while (isspace((unsigned char)*text))
        text++;
    size_t n = strlen(text);
    while (n > 0 && isspace((unsigned char)text[n - 1]))
        n--;
    if (n >= sizeof buf)
        return NULL;
    memcpy(buf, text, n);
    buf[n] = '\0';
    return ut_parse(u->sys, alias(buf), UT_ASCII);
}

int cf_units_linear(cf_units *u, const char *from, const char *to, double *a, double *b)
{
    ut_unit *uf = parse(u, from);
    if (!uf)
        return -1;
    ut_unit *ut = parse(u, to);
    if (!ut) {
        ut_free(uf);
        return -1;
    }
    int rc = 0;
    cv_converter *cv = ut_are_convertible(uf, ut) ? ut_get_converter(uf, ut) : NULL;
    if (!cv) {
        rc = -2;
    } else {
        double y0 = cv_convert_double(cv, 0.0), y1 = cv_convert_double(cv, 1.0);
        double y2 = cv_convert_double(cv, 1000.0);
        *b = y0;
        *a = y1 - y0;
        /* Affine check: the converter must agree with a*x+b far from 0..1. */
        if (!(fabs(y2 - (1000.0 * *a + *b)) <= 1e-9 * (fabs(y2) + 1.0)))
            rc = -3;
        /* A temperature converts to another with slope 1 (K, degC) or 5/9
         * (degF, degR); any other slope is a misread compound such as an
         * angle times a temperature ("degrees Celsius" not aliased). */
        ut_unit *kelvin = rc == 0 ? ut_get_unit_by_name(u->sys, "kelvin") : NULL;
        if (kelvin && ut_are_convertible(ut, kelvin) &&
            !(fabs(*a - 1.0) < 1e-9 || fabs(*a - 5.0 / 9.0) < 1e-9 ||
              fabs(*a - 9.0 / 5.0) < 1e-9))
            rc = -2;
        ut_free(kelvin);
        cv_free(cv);
    }
    ut_free(uf);
    ut_free(ut);
    return rc;
}

int cf_units_convertible(cf_units *u, const char *from, const char *to)
{
    double a, b;
    return cf_units_linear(u, from, to, &a, &b) == 0;
}
