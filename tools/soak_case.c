/* Writes the scene of `make soak` (tools/soak.sh) into DIR: the small
 * synthetic case of the engine tests (tests/engine_case.h: ice.nc,
 * mask.nc) with an atmosphere file whose hourly time axis covers the wall
 * clock from 6 h ago to HOURS ahead (the daemon names its cycles by the
 * wall clock), and DIR/sphice.json: cycles every EVERY seconds
 * (schedule.every_seconds), forecasts of 0.5 h, retention KEEP cycles,
 * the status server on 127.0.0.1:0 off (the soak reads /proc).
 * Usage: soak_case DIR HOURS EVERY KEEP */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "../tests/engine_case.h"

int main(int argc, char **argv)
{
    if (argc != 5) {
        fprintf(stderr, "usage: soak_case DIR HOURS EVERY KEEP\n");
        return 2;
    }
    const char *dir = argv[1];
    char *e1, *e2, *e3;
    double hours = strtod(argv[2], &e1), every = strtod(argv[3], &e2);
    long keep = strtol(argv[4], &e3, 10);
    if (*e1 || *e2 || *e3 || !(hours > 0) || !(every > 0) || keep < 0) {
        fprintf(stderr, "soak_case: bad HOURS, EVERY or KEEP\n");
        return 2;
    }
    char p[1024];
    snprintf(p, sizeof p, "%s/ice.nc", dir);
    ec_write_ice(p, -1);
    snprintf(p, sizeof p, "%s/mask.nc", dir);
    ec_write_mask(p);

    double now = (double)time(NULL);
    snprintf(p, sizeof p, "%s/atm.nc", dir);
    ec_write_atm_axis(p, "hours since 1970-01-01 00:00:00", (double)((long)(now / 3600.0)) - 6.0,
                      (size_t)(hours + 8), NC_NETCDF4);

    char text[8192], extra[256];
    snprintf(extra, sizeof extra, "\"log_level\": \"info\",");
    ec_config(text, sizeof text, dir, 300, "[\"wind\", \"tair\"]", "ice.nc", extra);
    /* the case's 6-hourly schedule and 6 h forecasts become the soak's */
    char *s = strstr(text, "\"schedule\": {\"every_hours\": 6, \"forecast_hours\": 6,");
    char *o = strstr(text, "\"interval_hours\": 1,");
    if (!s || !o) {
        fprintf(stderr, "soak_case: the engine case's configuration changed\n");
        return 1;
    }
    char out[8192];
    size_t a = (size_t)(o - text), b = (size_t)(s - text);
    snprintf(out, sizeof out, "%.*s\"interval_hours\": 0.5, \"retention_cycles\": %ld,%.*s"
             "\"schedule\": {\"every_seconds\": %g, \"catch_up\": false, \"forecast_hours\": 0.5,%s",
             (int)a, text, keep, (int)(b - a - strlen("\"interval_hours\": 1,")),
             o + strlen("\"interval_hours\": 1,"), every,
             s + strlen("\"schedule\": {\"every_hours\": 6, \"forecast_hours\": 6,"));
    snprintf(p, sizeof p, "%s/sphice.json", dir);
    FILE *f = fopen(p, "w");
    if (!f || fputs(out, f) < 0 || fclose(f) != 0) {
        fprintf(stderr, "soak_case: cannot write %s\n", p);
        return 1;
    }
    return 0;
}
