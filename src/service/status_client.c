/* `sphice status` (service/status_client.h): one GET through io/fetch.h. */
#include "service/status_client.h"

#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/fetch.h"

int service_status_get(const char *base, char **text, sph_error *err)
{
    *text = NULL;
    char url[2100];
    if (!base)
        base = STATUS_DEFAULT_URL;
    size_t bl = strlen(base);
    while (bl && base[bl - 1] == '/')
        bl--;
    if (bl >= 7 && !strncmp(base + bl - 7, "/status", 7))
        snprintf(url, sizeof url, "%.*s", (int)bl, base);
    else
        snprintf(url, sizeof url, "%.*s/status", (int)bl, base);
    char *body = NULL;
    long http = 0;
    int rc = fetch_http_get(url, 10.0, 16u << 20, &body, NULL, &http, err);
    if (rc)
        return rc;
    if (http != 200) {
        free(body);
        return sph_err_set(err, SPH_ERR_DOWNLOAD, "%s: HTTP %ld", url, http);
    }
    cJSON *j = cJSON_Parse(body);
    free(body);
    *text = j ? cJSON_Print(j) : NULL;
    cJSON_Delete(j);
    if (!*text)
        return sph_err_set(err, SPH_ERR_BAD_DATA, "%s: the answer is not JSON", url);
    return SPH_OK;
}
