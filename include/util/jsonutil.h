/* Small cJSON helpers shared by the status, the history and the cycle
 * records: a number that may be NaN, a time that may be unknown. */
#ifndef SPHICE_UTIL_JSONUTIL_H
#define SPHICE_UTIL_JSONUTIL_H

#include <cjson/cJSON.h>

#include "util/err.h"

/* k: v, or k: null where v is not finite. */
void json_add_num(cJSON *o, const char *k, double v);
/* k: "YYYY-MM-DDTHH:MM:SSZ" for t seconds since 1970, or null where t is
 * not finite. */
void json_add_time(cJSON *o, const char *k, double t);
/* The JSON document in file path, parsed; NULL when it cannot be read
 * (err set by the read) or is not JSON (err says so). */
cJSON *json_read_file(const char *path, sph_error *err);

#endif
