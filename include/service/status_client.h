/* The client side of the daemon's status server (service/daemon.h):
 * what `sphice status` prints. */
#ifndef SPHICE_SERVICE_STATUS_CLIENT_H
#define SPHICE_SERVICE_STATUS_CLIENT_H

#include "util/err.h"

#define STATUS_DEFAULT_URL "http://127.0.0.1:8642"

/* GETs the daemon's /status at base (NULL: STATUS_DEFAULT_URL;
 * "http://host:port", ".../" and ".../status" all mean /status) and returns
 * it pretty-printed in *text (caller frees). Errors name the URL: the
 * transfer's failure, "HTTP <code>" for an answer other than 200, or "the
 * answer is not JSON". */
int service_status_get(const char *base, char **text, sph_error *err);

#endif
