/* Status HTTP server on libmicrohttpd (service/http.h). */
#include "service/http.h"

#include <arpa/inet.h>
#include <microhttpd.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>

struct http_server {
    struct MHD_Daemon *mhd;
    http_route_fn route;
    void *ctx;
    int port;
};

static enum MHD_Result reply(struct MHD_Connection *c, int code, char *body, const char *ctype)
{
    if (!body)
        body = strdup("");
    struct MHD_Response *r =
        MHD_create_response_from_buffer(body ? strlen(body) : 0, body, body ? MHD_RESPMEM_MUST_FREE : MHD_RESPMEM_PERSISTENT);
    if (!r) {
        free(body);
        return MHD_NO;
    }
    MHD_add_response_header(r, MHD_HTTP_HEADER_CONTENT_TYPE, ctype);
    MHD_add_response_header(r, MHD_HTTP_HEADER_CACHE_CONTROL, "no-store");
    if (code == MHD_HTTP_METHOD_NOT_ALLOWED)
        MHD_add_response_header(r, MHD_HTTP_HEADER_ALLOW, "GET, HEAD");
    enum MHD_Result ret = MHD_queue_response(c, (unsigned)code, r);
    MHD_destroy_response(r);
    return ret;
}

static char *error_body(int code, const char *why)
{
    char *b = malloc(256);
    if (b)
        snprintf(b, 256, "{\"error\": %d, \"message\": \"%s\"}\n", code, why);
    return b;
}

static enum MHD_Result handler(void *cls, struct MHD_Connection *c, const char *url, const char *method,
                               const char *version, const char *upload_data, size_t *upload_data_size,
                               void **con_cls)
{
    (void)version; (void)upload_data;
    http_server *s = cls;
    static int first_marker;
    if (*con_cls == NULL) {
        /* first call: headers only. Refusals happen here, before any body is read. */
        *con_cls = &first_marker;
        const char *json = "application/json";
        if (strcmp(method, MHD_HTTP_METHOD_GET) && strcmp(method, MHD_HTTP_METHOD_HEAD))
            return reply(c, MHD_HTTP_METHOD_NOT_ALLOWED, error_body(405, "only GET"), json);
        if (strlen(url) > HTTP_MAX_URL)
            return reply(c, MHD_HTTP_URI_TOO_LONG, error_body(414, "URL too long"), json);
        const char *cl = MHD_lookup_connection_value(c, MHD_HEADER_KIND, MHD_HTTP_HEADER_CONTENT_LENGTH);
        const char *te = MHD_lookup_connection_value(c, MHD_HEADER_KIND, MHD_HTTP_HEADER_TRANSFER_ENCODING);
        if ((cl && strcmp(cl, "0")) || te)
            return reply(c, MHD_HTTP_CONTENT_TOO_LARGE, error_body(413, "no request body accepted"), json);
        int code = 200;
        const char *ctype = json;
        char *body = s->route(s->ctx, url, &code, &ctype);
        if (!body)
            return reply(c, MHD_HTTP_NOT_FOUND, error_body(404, "no such path"), json);
        return reply(c, code, body, ctype);
    }
    /* a body arrived after all (the response is already queued): discard it */
    *upload_data_size = 0;
    return MHD_YES;
}

int http_start(http_server **out, const char *listen, int max_connections, int per_ip_limit,
               http_route_fn route, void *ctx, sph_error *err)
{
    *out = NULL;
    char host[64];
    const char *colon = strrchr(listen, ':');
    if (!colon || (size_t)(colon - listen) >= sizeof host)
        return sph_err_set(err, SPH_ERR_CONFIG, "status.listen \"%s\": expected ADDRESS:PORT", listen);
    memcpy(host, listen, (size_t)(colon - listen));
    host[colon - listen] = 0;
    char *end;
    long port = strtol(colon + 1, &end, 10);
    struct sockaddr_in sa;
    memset(&sa, 0, sizeof sa);
    sa.sin_family = AF_INET;
    sa.sin_port = htons((unsigned short)port);
    if (*end || port < 0 || port > 65535 || inet_pton(AF_INET, host, &sa.sin_addr) != 1)
        return sph_err_set(err, SPH_ERR_CONFIG, "status.listen \"%s\": expected IPV4:PORT", listen);
    http_server *s = calloc(1, sizeof *s);
    if (!s)
        return sph_err_set(err, SPH_ERR_NOMEM, "http: out of memory");
    s->route = route;
    s->ctx = ctx;
    s->mhd = MHD_start_daemon(MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_EPOLL_LINUX_ONLY, (uint16_t)port, NULL,
                              NULL, handler, s, MHD_OPTION_SOCK_ADDR, (struct sockaddr *)&sa,
                              MHD_OPTION_CONNECTION_LIMIT, (unsigned)max_connections,
                              MHD_OPTION_PER_IP_CONNECTION_LIMIT, (unsigned)per_ip_limit,
                              MHD_OPTION_CONNECTION_TIMEOUT, 10u, MHD_OPTION_CONNECTION_MEMORY_LIMIT,
                              (size_t)(64 * 1024), MHD_OPTION_LISTEN_BACKLOG_SIZE, 64u, MHD_OPTION_END);
    if (!s->mhd) {
        free(s);
        return sph_err_set(err, SPH_ERR_IO, "http: cannot listen on %s (address in use or not local?)", listen);
    }
    const union MHD_DaemonInfo *info = MHD_get_daemon_info(s->mhd, MHD_DAEMON_INFO_BIND_PORT);
    s->port = info ? info->port : (int)port;
    *out = s;
    return SPH_OK;
}

int http_port(const http_server *s) { return s ? s->port : -1; }

void http_stop(http_server *s)
{
    if (!s)
        return;
    if (s->mhd)
        MHD_stop_daemon(s->mhd);
    free(s);
}
