/* The status HTTP server: a small HTTP/1.0-1.1 GET server on poll(), one
 * thread, non-blocking sockets.
 *
 * It owns the protocol rules: only GET and HEAD (else 405 with Allow: GET,
 * HEAD), no request body (413), URL at most HTTP_MAX_URL bytes (414),
 * request line and headers at most HTTP_MAX_REQUEST bytes (431), one
 * request per connection (Connection: close), Cache-Control: no-store on
 * every reply. Routing is the caller's: `route` gets the path (percent-
 * decoded, without the query) and returns a malloc'd body, the status code
 * and the content type, or NULL for 404.
 *
 * Robustness: every connection has an absolute deadline, HTTP_DEADLINE_S
 * after it was accepted, for the whole exchange (reading the request and
 * writing the reply); activity does not extend it. The connection table
 * holds max_connections; one address holds at most per_ip_limit of them
 * (beyond, its oldest unfinished connection is closed to make room), and
 * when the table is full the oldest connection that has not finished its
 * request is closed for the newcomer. So idle or slow sockets cannot keep a
 * request that arrives whole from being answered. */
#ifndef SPHICE_SERVICE_HTTP_H
#define SPHICE_SERVICE_HTTP_H

#include <stddef.h>

#include "util/err.h"

#define HTTP_MAX_URL 2048
#define HTTP_MAX_REQUEST 8192    /* request line and headers */
#define HTTP_DEADLINE_S 5        /* seconds from accept to the last byte of the reply */
#define HTTP_DEFAULT_PORT 8642   /* when status.listen names only an address */

typedef char *(*http_route_fn)(void *ctx, const char *path, int *code, const char **content_type);

/* For a body that is not a NUL-terminated text (a PNG): the route calls
 * this with the body's length before returning it. Applies to the body
 * the route returns next, on the calling thread. */
void http_set_body_length(size_t len);

typedef struct http_server http_server;

/* listen: "A.B.C.D:PORT", "[IPV6]:PORT", or an address alone ("127.0.0.1",
 * "::1", "[::1]": port HTTP_DEFAULT_PORT); numeric addresses only. Port 0:
 * any free port (see http_port). A malformed listen is SPH_ERR_CONFIG, a
 * bind failure SPH_ERR_IO; both name the string. */
int http_start(http_server **out, const char *listen, int max_connections, int per_ip_limit,
               http_route_fn route, void *ctx, sph_error *err);
int http_port(const http_server *s);
void http_stop(http_server *s);

/* SPH_OK if listen is one of the forms above, else SPH_ERR_CONFIG naming it
 * (for the configuration's check of status.listen). */
int http_check_listen(const char *listen, sph_error *err);

/* The reply to the bytes of one request received so far: 0 while more are
 * needed, else the status code, with the whole reply (status line,
 * headers, body) malloc'd in *reply (NULL if out of memory). route may be
 * NULL (every path 404). What the server runs per connection; exposed for
 * tests and fuzzing. */
int http_respond(const char *req, size_t n, http_route_fn route, void *ctx, char **reply, size_t *reply_len);

#endif
