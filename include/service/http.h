/* The status HTTP server (libmicrohttpd, its own polling thread).
 *
 * It owns the protocol rules: only GET and HEAD (else 405), no request
 * body (413), URL at most HTTP_MAX_URL bytes (414), connection and per-IP
 * limits. Routing is the caller's: `route` gets the path and returns a
 * malloc'd body, the status code and the content type, or NULL for 404. */
#ifndef SPHICE_SERVICE_HTTP_H
#define SPHICE_SERVICE_HTTP_H

#include "util/err.h"

#define HTTP_MAX_URL 2048

typedef char *(*http_route_fn)(void *ctx, const char *path, int *code, const char **content_type);

typedef struct http_server http_server;

/* listen is "A.B.C.D:PORT" (port 0: any free port, see http_port). */
int http_start(http_server **out, const char *listen, int max_connections, int per_ip_limit,
               http_route_fn route, void *ctx, sph_error *err);
int http_port(const http_server *s);
void http_stop(http_server *s);

#endif
