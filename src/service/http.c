/* The status HTTP server (service/http.h): HTTP/1.0-1.1 GET and HEAD on
 * poll(), one thread, non-blocking sockets, a fixed connection table, an
 * absolute deadline per connection. Why not libmicrohttpd: its timeout
 * restarts on every byte and it cannot close an old connection to make room
 * for a new one, so eight slow sockets or a crowd of idle ones kept /status
 * from answering for as long as they liked. */
#include "service/http.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "util/timeutil.h"

#define LINGER_S 1.0       /* after the reply: wait this long for the client to close */
#define ACCEPT_BURST 64    /* connections accepted per loop, so open ones are served too */

/* ------------------------------------------------------- listen forms */

/* Splits spec into a numeric address and a port; 0 if well formed. */
static int split_listen(const char *spec, char *host, size_t hostsz, char *port, size_t portsz)
{
    const char *h = spec, *p = NULL;
    size_t hl;
    if (spec[0] == '[') {
        const char *close = strchr(spec, ']');
        if (!close)
            return -1;
        h = spec + 1;
        hl = (size_t)(close - h);
        if (close[1] == ':')
            p = close + 2;
        else if (close[1])
            return -1;
    } else {
        const char *first = strchr(spec, ':'), *last = strrchr(spec, ':');
        if (first && first == last) { /* IPv4:PORT; more colons: an IPv6 address alone */
            hl = (size_t)(first - spec);
            p = first + 1;
        } else {
            hl = strlen(spec);
        }
    }
    if (hl == 0 || hl >= hostsz)
        return -1;
    memcpy(host, h, hl);
    host[hl] = 0;
    struct in_addr a4; /* dotted quads only: getaddrinfo would take "1.2.3" too */
    if (!strchr(host, ':') && inet_pton(AF_INET, host, &a4) != 1)
        return -1;
    if (!p) {
        snprintf(port, portsz, "%d", HTTP_DEFAULT_PORT);
        return 0;
    }
    size_t pl = strlen(p);
    if (pl == 0 || pl > 5 || strspn(p, "0123456789") != pl || atoi(p) > 65535)
        return -1;
    snprintf(port, portsz, "%s", p);
    return 0;
}

static int resolve_listen(const char *spec, struct sockaddr_storage *ss, socklen_t *len, sph_error *err)
{
    char host[INET6_ADDRSTRLEN + 8], port[8];
    struct addrinfo hints, *ai = NULL;
    memset(&hints, 0, sizeof hints);
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    hints.ai_flags = AI_NUMERICHOST | AI_NUMERICSERV | AI_PASSIVE;
    if (split_listen(spec, host, sizeof host, port, sizeof port) || getaddrinfo(host, port, &hints, &ai) ||
        !ai || ai->ai_addrlen > sizeof *ss) {
        if (ai)
            freeaddrinfo(ai);
        return sph_err_set(err, SPH_ERR_CONFIG,
                           "status.listen \"%s\": expected IPV4:PORT, [IPV6]:PORT or a numeric address alone "
                           "(port %d)",
                           spec, HTTP_DEFAULT_PORT);
    }
    memcpy(ss, ai->ai_addr, ai->ai_addrlen);
    *len = ai->ai_addrlen;
    freeaddrinfo(ai);
    return SPH_OK;
}

int http_check_listen(const char *spec, sph_error *err)
{
    struct sockaddr_storage ss;
    socklen_t len;
    return resolve_listen(spec, &ss, &len, err);
}

/* ------------------------------------------------------ one request */

static const char *reason(int code)
{
    switch (code) {
    case 200: return "OK";
    case 400: return "Bad Request";
    case 404: return "Not Found";
    case 405: return "Method Not Allowed";
    case 413: return "Content Too Large";
    case 414: return "URI Too Long";
    case 431: return "Request Header Fields Too Large";
    case 500: return "Internal Server Error";
    case 503: return "Service Unavailable";
    case 505: return "HTTP Version Not Supported";
    default: return "Unknown";
    }
}

/* The length of the next body a route returns when it is not text (see
 * http_set_body_length); per thread, since the route runs on the server's. */
static _Thread_local size_t next_body_len;
static _Thread_local int next_body_len_set;

void http_set_body_length(size_t len)
{
    next_body_len = len;
    next_body_len_set = 1;
}

/* Status line, headers and (unless head) body of blen bytes into one
 * malloc'd buffer. */
static int make_reply(int code, const char *ctype, const char *body, size_t blen, int head, char **out,
                      size_t *len)
{
    char date[64] = "";
    time_t now = time(NULL);
    struct tm tm;
    if (gmtime_r(&now, &tm))
        strftime(date, sizeof date, "%a, %d %b %Y %H:%M:%S GMT", &tm);
    char hdr[512];
    int hl = snprintf(hdr, sizeof hdr,
                      "HTTP/1.1 %d %s\r\nDate: %s\r\nContent-Type: %s\r\nContent-Length: %zu\r\n"
                      "Cache-Control: no-store\r\nConnection: close\r\n%s\r\n",
                      code, reason(code), date, ctype, blen, code == 405 ? "Allow: GET, HEAD\r\n" : "");
    if (hl < 0 || (size_t)hl >= sizeof hdr)
        return code;
    size_t n = (size_t)hl + (head ? 0 : blen);
    char *r = malloc(n + 1);
    if (r) {
        memcpy(r, hdr, (size_t)hl);
        if (!head && blen)
            memcpy(r + hl, body, blen);
        r[n] = 0;
        *out = r;
        *len = n;
    }
    return code;
}

static int error_reply(int code, const char *why, int head, char **out, size_t *len)
{
    char body[256];
    snprintf(body, sizeof body, "{\"error\": %d, \"message\": \"%s\"}\n", code, why);
    return make_reply(code, "application/json", body, strlen(body), head, out, len);
}

static int hexval(int c)
{
    if (c >= '0' && c <= '9')
        return c - '0';
    if (c >= 'a' && c <= 'f')
        return c - 'a' + 10;
    if (c >= 'A' && c <= 'F')
        return c - 'A' + 10;
    return -1;
}

/* Percent-decodes p[0..n) into out (size > n); -1 for %00. */
static int decode_path(const char *p, size_t n, char *out)
{
    size_t o = 0;
    for (size_t i = 0; i < n; i++) {
        int hi, lo;
        if (p[i] == '%' && i + 2 < n && (hi = hexval((unsigned char)p[i + 1])) >= 0 &&
            (lo = hexval((unsigned char)p[i + 2])) >= 0) {
            int c = hi * 16 + lo;
            if (!c)
                return -1;
            out[o++] = (char)c;
            i += 2;
        } else {
            out[o++] = p[i];
        }
    }
    out[o] = 0;
    return 0;
}

static int is_tchar(int c)
{
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
           (c && strchr("!#$%&'*+-.^_`|~", c));
}

/* Length of the line at p (up to and without "\n" or "\r\n"), or -1 if
 * the line is not complete within end; *next is the following line. */
static long line_at(const char *p, const char *end, const char **next)
{
    const char *nl = memchr(p, '\n', (size_t)(end - p));
    if (!nl)
        return -1;
    *next = nl + 1;
    return nl > p && nl[-1] == '\r' ? nl - 1 - p : nl - p;
}

int http_respond(const char *req, size_t n, http_route_fn route, void *ctx, char **reply, size_t *reply_len)
{
    *reply = NULL;
    *reply_len = 0;
    const char *p = req, *end = req + n, *next;
    while (p < end && (*p == '\r' || *p == '\n')) /* empty lines before the request line */
        p++;
    long ll = line_at(p, end, &next);
    if (ll < 0)
        return end - p > HTTP_MAX_URL + 64 ? error_reply(414, "URL too long", 0, reply, reply_len) : 0;
    if (ll > HTTP_MAX_URL + 64)
        return error_reply(414, "URL too long", 0, reply, reply_len);

    /* the request line: METHOD SP TARGET SP HTTP/1.x */
    const char *line = p, *lend = p + ll;
    const char *sp1 = memchr(line, ' ', (size_t)ll);
    const char *sp2 = sp1 ? memchr(sp1 + 1, ' ', (size_t)(lend - sp1 - 1)) : NULL;
    int head = sp1 && sp1 - line == 4 && !memcmp(line, "HEAD", 4);
    int get = sp1 && sp1 - line == 3 && !memcmp(line, "GET", 3);

    /* the headers, to the empty line */
    int body = 0, bad = 0;
    const char *h = next;
    for (;;) {
        long hl = line_at(h, end, &next);
        if (hl < 0)
            return n >= HTTP_MAX_REQUEST ? error_reply(431, "request headers too large", head, reply, reply_len)
                                         : 0;
        if (hl == 0)
            break;
        const char *colon = memchr(h, ':', (size_t)hl);
        if (!colon || colon == h || h[0] == ' ' || h[0] == '\t') {
            bad = 1;
        } else {
            size_t nl = (size_t)(colon - h);
            const char *v = colon + 1, *vend = h + hl;
            while (v < vend && (*v == ' ' || *v == '\t'))
                v++;
            while (vend > v && (vend[-1] == ' ' || vend[-1] == '\t'))
                vend--;
            if (nl == 14 && !strncasecmp(h, "Content-Length", 14)) {
                int zero = v < vend; /* an empty value, or anything but zeros, is a body */
                for (const char *d = v; d < vend; d++)
                    zero &= *d == '0';
                body |= !zero;
            } else if (nl == 17 && !strncasecmp(h, "Transfer-Encoding", 17)) {
                body = 1;
            }
        }
        h = next;
    }

    if (!sp1 || !sp2 || sp1 == line || sp2 == sp1 + 1 || memchr(sp2 + 1, ' ', (size_t)(lend - sp2 - 1)))
        return error_reply(400, "malformed request line", head, reply, reply_len);
    for (const char *c = line; c < sp1; c++)
        if (!is_tchar((unsigned char)*c))
            return error_reply(400, "malformed request line", head, reply, reply_len);
    const char *ver = sp2 + 1;
    size_t vl = (size_t)(lend - ver);
    if (vl != 8 || memcmp(ver, "HTTP/", 5) || ver[6] != '.' || ver[5] < '0' || ver[5] > '9' || ver[7] < '0' ||
        ver[7] > '9')
        return error_reply(400, "malformed request line", head, reply, reply_len);
    if (ver[5] != '1')
        return error_reply(505, "only HTTP/1.0 and HTTP/1.1", head, reply, reply_len);
    if (bad)
        return error_reply(400, "malformed header", head, reply, reply_len);
    if (!get && !head)
        return error_reply(405, "only GET", 0, reply, reply_len);

    /* the target: origin form, or absolute form (scheme://host/path) */
    const char *t = sp1 + 1, *tend = sp2;
    for (const char *c = t; c < tend; c++)
        if ((unsigned char)*c <= ' ' || *c == 127)
            return error_reply(400, "malformed request line", head, reply, reply_len);
    if (*t != '/') {
        const char *scheme = memchr(t, ':', (size_t)(tend - t));
        if (!scheme || tend - scheme < 3 || memcmp(scheme, "://", 3))
            return error_reply(400, "malformed request target", head, reply, reply_len);
        const char *slash = memchr(scheme + 3, '/', (size_t)(tend - scheme - 3));
        t = slash ? slash : tend;
    }
    const char *q = memchr(t, '?', (size_t)(tend - t));
    size_t pl = (size_t)((q ? q : tend) - t);
    if (pl > HTTP_MAX_URL)
        return error_reply(414, "URL too long", head, reply, reply_len);
    if (body)
        return error_reply(413, "no request body accepted", head, reply, reply_len);
    char path[HTTP_MAX_URL + 2];
    if (pl == 0) {
        path[0] = '/';
        path[1] = 0;
    } else if (decode_path(t, pl, path)) {
        return error_reply(400, "NUL in the path", head, reply, reply_len);
    }

    int code = 200;
    const char *ctype = "application/json";
    next_body_len_set = 0;
    char *b = route ? route(ctx, path, &code, &ctype) : NULL;
    size_t blen = b && next_body_len_set ? next_body_len : b ? strlen(b) : 0;
    next_body_len_set = 0;
    if (!b)
        return error_reply(404, "no such path", head, reply, reply_len);
    make_reply(code, ctype, b, blen, head, reply, reply_len);
    free(b);
    return code;
}

/* ------------------------------------------------------- the server */

enum { C_FREE, C_READ, C_WRITE, C_LINGER };

typedef struct conn {
    int fd, state;
    double opened, deadline;
    int family;
    unsigned char addr[16];        /* the peer's address: the per-address limit */
    char *out;
    size_t out_n, out_off, n;
    char req[HTTP_MAX_REQUEST];
} conn;

struct http_server {
    int lfd, wake[2], port;
    int nconn, per_ip;
    conn *c;
    struct pollfd *pfd;
    int *pidx;
    http_route_fn route;
    void *ctx;
    pthread_t thread;
    int running;
    int stop;                      /* atomic: set by http_stop */
};

static void conn_close(conn *c)
{
    if (c->fd >= 0)
        close(c->fd);
    free(c->out);
    c->out = NULL;
    c->fd = -1;
    c->state = C_FREE;
}

static void conn_write(conn *c)
{
    while (c->out_off < c->out_n) {
        ssize_t w = send(c->fd, c->out + c->out_off, c->out_n - c->out_off, MSG_NOSIGNAL);
        if (w > 0) {
            c->out_off += (size_t)w;
        } else if (w < 0 && errno == EINTR) {
            continue;
        } else if (w < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
            return; /* the poll loop waits for POLLOUT */
        } else {
            conn_close(c);
            return;
        }
    }
    /* all sent: half-close, then read what the client still sends until it
     * closes, so that unread bytes do not turn the close into a reset that
     * could destroy the reply in flight */
    free(c->out);
    c->out = NULL;
    shutdown(c->fd, SHUT_WR);
    c->state = C_LINGER;
    double linger = time_monotonic() + LINGER_S;
    if (linger < c->deadline)
        c->deadline = linger;
}

/* Reads what has arrived; a complete request is answered at once. */
static void conn_read(http_server *s, conn *c)
{
    for (;;) {
        char sink[4096];
        int reading = c->state == C_READ;
        char *dst = reading ? c->req + c->n : sink;
        size_t room = reading ? sizeof c->req - c->n : sizeof sink;
        ssize_t r = recv(c->fd, dst, room, 0);
        if (r < 0 && errno == EINTR)
            continue;
        if (r < 0 && (errno == EAGAIN || errno == EWOULDBLOCK))
            return;
        if (r <= 0) { /* the client closed (or reset) before or after its reply */
            conn_close(c);
            return;
        }
        if (!reading)
            continue;
        c->n += (size_t)r;
        int code = http_respond(c->req, c->n, s->route, s->ctx, &c->out, &c->out_n);
        if (!code && c->n < sizeof c->req)
            continue;
        if (!c->out) {
            conn_close(c);
            return;
        }
        c->state = C_WRITE;
        c->out_off = 0;
        conn_write(c);
        return;
    }
}

static int same_peer(const conn *c, int family, const unsigned char *addr)
{
    return c->family == family && !memcmp(c->addr, addr, family == AF_INET6 ? 16 : 4);
}

/* The oldest connection in `state` (of that peer if family), or -1. */
static int oldest(const http_server *s, int state, int family, const unsigned char *addr)
{
    int best = -1;
    for (int i = 0; i < s->nconn; i++) {
        const conn *c = &s->c[i];
        if (c->state == state && (!family || same_peer(c, family, addr)) &&
            (best < 0 || c->opened < s->c[best].opened))
            best = i;
    }
    return best;
}

/* Makes room for a connection from (family, addr); returns a free slot. */
static int make_room(http_server *s, int family, const unsigned char *addr)
{
    /* first read what the unfinished ones sent meanwhile: whoever has sent
     * a whole request is answered, not evicted */
    for (int i = 0; i < s->nconn; i++)
        if (s->c[i].state == C_READ)
            conn_read(s, &s->c[i]);
    /* one address holds at most per_ip unfinished or unread replies */
    for (;;) {
        int mine = 0;
        for (int i = 0; i < s->nconn; i++)
            mine += (s->c[i].state == C_READ || s->c[i].state == C_WRITE) && same_peer(&s->c[i], family, addr);
        if (mine < s->per_ip)
            break;
        int v = oldest(s, C_READ, family, addr);
        if (v < 0)
            v = oldest(s, C_WRITE, family, addr);
        conn_close(&s->c[v]);
    }
    for (int i = 0; i < s->nconn; i++)
        if (s->c[i].state == C_FREE)
            return i;
    /* full: a finished one, else the oldest unfinished, else the oldest writer */
    int v = oldest(s, C_LINGER, 0, NULL);
    if (v < 0)
        v = oldest(s, C_READ, 0, NULL);
    if (v < 0)
        v = oldest(s, C_WRITE, 0, NULL);
    conn_close(&s->c[v]);
    return v;
}

/* Returns 1 when accept ran out of descriptors (pause accepting). */
static int accept_some(http_server *s)
{
    for (int k = 0; k < ACCEPT_BURST; k++) {
        struct sockaddr_storage ss;
        socklen_t sl = sizeof ss;
        int fd = accept4(s->lfd, (struct sockaddr *)&ss, &sl, SOCK_NONBLOCK | SOCK_CLOEXEC);
        if (fd < 0) {
            if (errno == EINTR || errno == ECONNABORTED)
                continue;
            return errno == EMFILE || errno == ENFILE || errno == ENOBUFS || errno == ENOMEM;
        }
        int family = ss.ss_family;
        unsigned char addr[16] = {0};
        if (family == AF_INET6)
            memcpy(addr, &((struct sockaddr_in6 *)&ss)->sin6_addr, 16);
        else
            memcpy(addr, &((struct sockaddr_in *)&ss)->sin_addr, 4);
        int i = make_room(s, family, addr);
        conn *c = &s->c[i];
        c->fd = fd;
        c->state = C_READ;
        c->opened = time_monotonic();
        c->deadline = c->opened + HTTP_DEADLINE_S;
        c->family = family;
        memcpy(c->addr, addr, sizeof addr);
        c->n = c->out_n = c->out_off = 0;
        conn_read(s, c);
    }
    return 0;
}

static void *serve(void *arg)
{
    http_server *s = arg;
    double pause_until = 0;
    while (!__atomic_load_n(&s->stop, __ATOMIC_ACQUIRE)) {
        double now = time_monotonic(), wake_at = now + 1.0;
        int np = 0;
        s->pfd[np++] = (struct pollfd){s->wake[0], POLLIN, 0};
        int listening = now >= pause_until;
        if (listening)
            s->pfd[np++] = (struct pollfd){s->lfd, POLLIN, 0};
        else if (pause_until < wake_at)
            wake_at = pause_until;
        for (int i = 0; i < s->nconn; i++) {
            conn *c = &s->c[i];
            if (c->state == C_FREE)
                continue;
            if (now >= c->deadline) {
                conn_close(c);
                continue;
            }
            if (c->deadline < wake_at)
                wake_at = c->deadline;
            s->pidx[np] = i;
            s->pfd[np++] = (struct pollfd){c->fd, (short)(c->state == C_WRITE ? POLLOUT : POLLIN), 0};
        }
        int ms = (int)((wake_at - now) * 1000) + 1;
        if (poll(s->pfd, (nfds_t)np, ms) < 0 && errno != EINTR) {
            struct timespec ts = {0, 10 * 1000 * 1000};
            nanosleep(&ts, NULL);
            continue;
        }
        if (s->pfd[0].revents) {
            char b[64];
            while (read(s->wake[0], b, sizeof b) > 0) {
            }
        }
        for (int k = listening ? 2 : 1; k < np; k++) {
            conn *c = &s->c[s->pidx[k]];
            if (!s->pfd[k].revents || c->fd != s->pfd[k].fd)
                continue;
            if (c->state == C_WRITE)
                conn_write(c);
            else
                conn_read(s, c);
        }
        if (listening && s->pfd[1].revents && accept_some(s))
            pause_until = time_monotonic() + 0.1;
    }
    for (int i = 0; i < s->nconn; i++)
        if (s->c[i].state != C_FREE)
            conn_close(&s->c[i]);
    return NULL;
}

static void server_free(http_server *s)
{
    if (s->lfd >= 0)
        close(s->lfd);
    if (s->wake[0] >= 0)
        close(s->wake[0]);
    if (s->wake[1] >= 0)
        close(s->wake[1]);
    free(s->c);
    free(s->pfd);
    free(s->pidx);
    free(s);
}

int http_start(http_server **out, const char *spec, int max_connections, int per_ip_limit,
               http_route_fn route, void *ctx, sph_error *err)
{
    *out = NULL;
    struct sockaddr_storage ss;
    socklen_t sl;
    if (resolve_listen(spec, &ss, &sl, err))
        return SPH_ERR_CONFIG;
    http_server *s = calloc(1, sizeof *s);
    if (!s)
        return sph_err_set(err, SPH_ERR_NOMEM, "status.listen %s: out of memory", spec);
    s->lfd = s->wake[0] = s->wake[1] = -1;
    s->nconn = max_connections > 0 ? max_connections : 1;
    s->per_ip = per_ip_limit > 0 ? per_ip_limit : 1;
    s->route = route;
    s->ctx = ctx;
    s->c = calloc((size_t)s->nconn, sizeof *s->c);
    s->pfd = calloc((size_t)s->nconn + 2, sizeof *s->pfd);
    s->pidx = calloc((size_t)s->nconn + 2, sizeof *s->pidx);
    if (!s->c || !s->pfd || !s->pidx || pipe2(s->wake, O_NONBLOCK | O_CLOEXEC)) {
        server_free(s);
        return sph_err_set(err, SPH_ERR_NOMEM, "status.listen %s: out of memory or descriptors", spec);
    }
    for (int i = 0; i < s->nconn; i++)
        s->c[i].fd = -1;
    int one = 1;
    s->lfd = socket(ss.ss_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (s->lfd < 0 || setsockopt(s->lfd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) ||
        (ss.ss_family == AF_INET6 && setsockopt(s->lfd, IPPROTO_IPV6, IPV6_V6ONLY, &one, sizeof one)) ||
        bind(s->lfd, (struct sockaddr *)&ss, sl) || listen(s->lfd, SOMAXCONN)) {
        int e = errno;
        server_free(s);
        return sph_err_set(err, SPH_ERR_IO, "status.listen %s: cannot listen: %s", spec, strerror(e));
    }
    struct sockaddr_storage bound;
    socklen_t bl = sizeof bound;
    if (getsockname(s->lfd, (struct sockaddr *)&bound, &bl) == 0)
        s->port = ntohs(bound.ss_family == AF_INET6 ? ((struct sockaddr_in6 *)&bound)->sin6_port
                                                    : ((struct sockaddr_in *)&bound)->sin_port);
    /* the server thread takes no signals: they are the main thread's */
    sigset_t all, old;
    sigfillset(&all);
    pthread_sigmask(SIG_BLOCK, &all, &old);
    int rc = pthread_create(&s->thread, NULL, serve, s);
    pthread_sigmask(SIG_SETMASK, &old, NULL);
    if (rc) {
        server_free(s);
        return sph_err_set(err, SPH_ERR_IO, "status.listen %s: cannot start the server thread: %s", spec,
                           strerror(rc));
    }
    s->running = 1;
    *out = s;
    return SPH_OK;
}

int http_port(const http_server *s) { return s ? s->port : -1; }

void http_stop(http_server *s)
{
    if (!s)
        return;
    if (s->running) {
        __atomic_store_n(&s->stop, 1, __ATOMIC_RELEASE);
        (void)!write(s->wake[1], "x", 1);
        pthread_join(s->thread, NULL);
    }
    server_free(s);
}
