/* Configuration errors found from outside (issue 21, item 9): a template
 * field the expander does not know (`%Q`) is refused when the
 * configuration is read, with one line naming the key (forcing[i].urls[j],
 * initial.path, observations.path) and the field -- not reported as
 * missing forcing after the late-data wait; a JSON key given twice (cJSON
 * keeps both) is refused with one line naming it, at the top, in a section
 * and inside an array element. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "service/config.h"
#include "util/err.h"

/* A valid configuration with the pieces the cases change. */
static int parse(const char *top, const char *url0, const char *url1, const char *initial, const char *model,
                 const char *forcing0_extra, sph_error *e)
{
    char text[4096];
    snprintf(text, sizeof text,
             "{%s \"engine\": \"test-double\","
             " \"domain\": {\"lon_min\": 119, \"lon_max\": 122, \"lat_min\": 38, \"lat_max\": 41},"
             " \"model\": {\"dt\": 60 %s},"
             " \"forcing\": [{\"name\": \"atm\", \"kind\": \"atmosphere\", \"urls\": [\"%s\"] %s},"
             "               {\"name\": \"sea\", \"kind\": \"ocean\", \"urls\": [\"/f/a.nc\", \"%s\"],"
             "                \"required\": [\"current\"]}],"
             " \"initial\": {\"path\": \"%s\"}, \"output\": {\"dir\": \"/tmp/x/out\"},"
             " \"paths\": {\"state_dir\": \"/tmp/x/state\", \"cache_dir\": \"/tmp/x/cache\"}}",
             top, model, url0, forcing0_extra, url1, initial);
    struct sph_config *c = NULL;
    sph_error_clear(e);
    int rc = sph_config_parse(text, "test.json", &c, e);
    sph_config_free(c);
    return rc;
}

static int count_lines(const char *s)
{
    int n = 1;
    for (; *s; s++)
        n += *s == '\n';
    return n;
}

int main(void)
{
    sph_error e;
    /* the valid base: every field the docs list */
    int rc = parse("", "/f/atm_%Y%m%d%H%M%S_%j_%y_100%%.nc", "/f/sea_%Y%m%d.nc", "/f/ice_%Y%m%d.nc", "", "", &e);
    CHECK(rc == SPH_OK, "the documented fields are accepted: %s", e.msg);

    /* ---- templates and duplicate keys: each refused with one line naming the key and the problem */
    static const struct {
        const char *top, *url0, *url1, *initial, *model, *forcing0_extra; /* the case */
        const char *key, *what;                                          /* the line names */
    } bad[] = {
        {"", "/f/atm_%Y.nc", "/f/sea_%Q.nc", "", "", "", "forcing[1].urls[1]", "%Q"},
        {"", "https://example.org/gfs_%Y%m%d_%H%k.nc", "/f/sea.nc", "", "", "", "forcing[0].urls[0]", "%k"},
        {"", "/f/atm.nc", "/f/sea.nc", "/f/ice_%Y%m%d_%Q.nc", "", "", "initial.path", "%Q"},
        {"", "/f/atm_%", "/f/sea.nc", "", "", "", "forcing[0].urls[0]", "unsupported field"},
        {"\"observations\": {\"path\": \"/obs/%Y%m%d%Q.nc\"},", "/f/atm.nc", "/f/sea.nc", "", "", "",
         "observations.path", "%Q"},
        {"\"log_level\": \"info\", \"log_level\": \"debug\",", "/f/atm.nc", "/f/sea.nc", "", "", "", "log_level",
         "twice"},
        {"", "/f/atm.nc", "/f/sea.nc", "", ", \"dt\": 30", "", "model.dt", "twice"},
        {"", "/f/atm.nc", "/f/sea.nc", "", "", ", \"name\": \"again\"", "forcing[0].name", "twice"},
    };
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        rc = parse(bad[k].top, bad[k].url0, bad[k].url1, bad[k].initial, bad[k].model, bad[k].forcing0_extra, &e);
        CHECK(rc == SPH_ERR_CONFIG && strstr(e.msg, "test.json") && strstr(e.msg, bad[k].key) &&
                  strstr(e.msg, bad[k].what) && count_lines(e.msg) == 1,
              "case %zu: refused naming %s and \"%s\": %s", k, bad[k].key, bad[k].what, e.msg);
    }
    /* the same name in two different objects is not a duplicate */
    rc = parse("\"observations\": {\"path\": \"/obs/%Y.nc\"}, \"status\": {\"enabled\": false},", "/f/atm.nc",
               "/f/sea.nc", "", "", "", &e);
    CHECK(rc == SPH_OK, "one key per object: accepted: %s", e.msg);

    return check_summary("test_config_hardening");
}
