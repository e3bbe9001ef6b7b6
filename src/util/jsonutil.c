/* Small cJSON helpers (util/jsonutil.h). */
#include "util/jsonutil.h"

#include <math.h>
#include <stdlib.h>

#include "util/fileio.h"
#include "util/timeutil.h"

void json_add_num(cJSON *o, const char *k, double v)
{
    if (isfinite(v))
        cJSON_AddNumberToObject(o, k, v);
    else
        cJSON_AddNullToObject(o, k);
}

void json_add_time(cJSON *o, const char *k, double t)
{
    if (isfinite(t)) {
        char b[32];
        time_format_iso(t, b, sizeof b);
        cJSON_AddStringToObject(o, k, b);
    } else {
        cJSON_AddNullToObject(o, k);
    }
}

cJSON *json_read_file(const char *path, sph_error *err)
{
    char *text = NULL;
    if (read_file(path, &text, NULL, err) != SPH_OK)
        return NULL;
    cJSON *j = cJSON_Parse(text);
    free(text);
    if (!j)
        sph_err_set(err, SPH_ERR_BAD_DATA, "%s: not JSON", path);
    return j;
}
