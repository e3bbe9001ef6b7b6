/* The status HTTP server on its own (service/http.h), in process, on
 * 127.0.0.1 and ::1 only:
 * - replies: 200 with Content-Type, Content-Length and Cache-Control:
 *   no-store; HEAD without a body; 404 JSON; 405 with Allow: GET, HEAD;
 *   414 for a long URL; 413 for a body; 400 for garbage; a 1 MiB body
 *   arrives whole;
 * - listen forms: "127.0.0.1:0", "[::1]:0", "::1" (port 8642), and bad
 *   forms refused as configuration errors naming the string;
 * - robustness (the server as the daemon runs it: 32 connections, 8 per
 *   address): with 8 slow sockets (one byte every 0.5 s) /status answers
 *   within 1 s and the slow sockets are closed at the whole-request
 *   deadline, which the trickle does not extend; with 200 idle sockets and
 *   8 slow ones open /status answers within 1 s and every socket is closed
 *   by the deadline; 200 simultaneous requests are all answered.
 * Times are printed. Everything is bounded: about 15 s in all. */
#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "check.h"
#include "service/http.h"
#include "util/timeutil.h"

#define NIDLE 200
#define NSLOW 8
#define NSIM 200
#define BIG (1024 * 1024)

static double answer_limit = 1.0; /* seconds; relaxed under valgrind */

static void nap(double s)
{
    struct timespec ts = {(time_t)s, (long)((s - floor(s)) * 1e9)};
    nanosleep(&ts, NULL);
}

static char *route(void *ctx, const char *path, int *code, const char **ctype)
{
    (void)ctx;
    if (!strcmp(path, "/status"))
        return strdup("{\"ok\": true}\n");
    if (!strcmp(path, "/unhealthy")) {
        *code = 503;
        return strdup("{\"health\": \"unhealthy\"}\n");
    }
    if (!strcmp(path, "/metrics")) {
        *ctype = "text/plain; version=0.0.4";
        return strdup("# HELP x An x.\n# TYPE x gauge\nx 1\n");
    }
    if (!strcmp(path, "/binary")) { /* a body with NULs (a PNG's), its length told */
        char *b = malloc(5);
        if (b) {
            memcpy(b, "a\0b\0c", 5);
            http_set_body_length(5);
        }
        return b;
    }
    if (!strcmp(path, "/big")) {
        char *b = malloc(BIG + 1);
        if (b) {
            memset(b, 'z', BIG);
            b[BIG] = 0;
        }
        return b;
    }
    return NULL;
}

/* A socket to 127.0.0.1 or ::1, connected without blocking (the connection
 * completes in the kernel's accept queue whether or not the server accepts). */
static int open_sock(int family, int port)
{
    int fd = socket(family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0)
        return -1;
    struct sockaddr_storage ss;
    socklen_t len;
    memset(&ss, 0, sizeof ss);
    if (family == AF_INET6) {
        struct sockaddr_in6 *a = (struct sockaddr_in6 *)&ss;
        a->sin6_family = AF_INET6;
        a->sin6_port = htons((unsigned short)port);
        a->sin6_addr = in6addr_loopback;
        len = sizeof *a;
    } else {
        struct sockaddr_in *a = (struct sockaddr_in *)&ss;
        a->sin_family = AF_INET;
        a->sin_port = htons((unsigned short)port);
        a->sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        len = sizeof *a;
    }
    if (connect(fd, (struct sockaddr *)&ss, len) != 0 && errno != EINPROGRESS) {
        close(fd);
        return -1;
    }
    return fd;
}

/* Writes all of buf within the time left; 0 on success. */
static int send_all(int fd, const char *buf, size_t n, double end)
{
    size_t off = 0;
    while (off < n) {
        ssize_t w = send(fd, buf + off, n - off, MSG_NOSIGNAL);
        if (w > 0) {
            off += (size_t)w;
            continue;
        }
        if (w < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR && errno != ENOTCONN)
            return -1;
        double left = end - time_monotonic();
        if (left <= 0)
            return -1;
        struct pollfd p = {fd, POLLOUT, 0};
        poll(&p, 1, (int)(left * 1000) + 1);
    }
    return 0;
}

/* Reads until the server closes or the time is up; returns what came, malloc'd. */
static char *recv_all(int fd, double end, size_t *len)
{
    size_t n = 0, cap = 4096;
    char *b = malloc(cap + 1);
    for (;;) {
        if (n == cap) {
            cap *= 2;
            char *g = realloc(b, cap + 1);
            if (!g)
                break;
            b = g;
        }
        ssize_t r = recv(fd, b + n, cap - n, 0);
        if (r > 0) {
            n += (size_t)r;
            continue;
        }
        if (r == 0 || (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR && errno != ENOTCONN))
            break;
        double left = end - time_monotonic();
        if (left <= 0)
            break;
        struct pollfd p = {fd, POLLIN, 0};
        poll(&p, 1, (int)(left * 1000) + 1);
    }
    b[n] = 0;
    *len = n;
    return b;
}

/* One raw request; returns the status code (0: no answer within timeout);
 * the whole reply in *reply (malloc'd) if non-NULL; the time it took in *took. */
static int request(int family, int port, const char *raw, size_t rawlen, double timeout, char **reply,
                   size_t *replylen, double *took)
{
    double t0 = time_monotonic(), end = t0 + timeout;
    int fd = open_sock(family, port);
    int code = 0;
    char *b = NULL;
    size_t n = 0;
    if (fd >= 0) {
        send_all(fd, raw, rawlen, end);
        b = recv_all(fd, end, &n);
        if (!strncmp(b, "HTTP/1.", 7) && n >= 12)
            code = atoi(b + 9);
        close(fd);
    }
    if (took)
        *took = time_monotonic() - t0;
    if (replylen)
        *replylen = n;
    if (reply)
        *reply = b;
    else
        free(b);
    return code;
}

static int get(int family, int port, const char *path, double timeout, double *took)
{
    char raw[256];
    snprintf(raw, sizeof raw, "GET %s HTTP/1.1\r\nHost: localhost\r\n\r\n", path);
    return request(family, port, raw, strlen(raw), timeout, NULL, NULL, took);
}

static const char *body_of(const char *reply)
{
    const char *p = strstr(reply, "\r\n\r\n");
    return p ? p + 4 : "";
}

/* 1 once the peer has closed fd (EOF or reset), without blocking. */
static int peer_closed(int fd)
{
    char c[64];
    for (;;) {
        ssize_t r = recv(fd, c, sizeof c, MSG_DONTWAIT);
        if (r > 0)
            continue;
        if (r == 0)
            return 1;
        return errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR && errno != ENOTCONN;
    }
}

static int ipv6_loopback(void)
{
    int fd = socket(AF_INET6, SOCK_STREAM, 0);
    if (fd < 0)
        return 0;
    struct sockaddr_in6 a;
    memset(&a, 0, sizeof a);
    a.sin6_family = AF_INET6;
    a.sin6_addr = in6addr_loopback;
    int ok = bind(fd, (struct sockaddr *)&a, sizeof a) == 0;
    close(fd);
    return ok;
}

/* ------------------------------------------------------------ replies */

static void replies(int port)
{
    char *r = NULL;
    size_t n;
    const char *get_status = "GET /status HTTP/1.1\r\nHost: x\r\n\r\n";
    CHECK(request(AF_INET, port, get_status, strlen(get_status), 3, &r, &n, NULL) == 200, "GET /status 200");
    CHECK(strstr(r, "\r\nCache-Control: no-store\r\n") && strstr(r, "\r\nContent-Type: application/json\r\n") &&
              strstr(r, "\r\nContent-Length: 13\r\n"),
          "headers: %s", r);
    CHECK(!strcmp(body_of(r), "{\"ok\": true}\n"), "body: %s", body_of(r));
    free(r);

    const char *bin = "GET /binary HTTP/1.1\r\nHost: x\r\n\r\n";
    CHECK(request(AF_INET, port, bin, strlen(bin), 3, &r, &n, NULL) == 200, "GET /binary 200");
    const char *bb = r ? strstr(r, "\r\n\r\n") : NULL;
    CHECK(r && strstr(r, "\r\nContent-Length: 5\r\n") && bb && (size_t)(r + n - (bb + 4)) == 5 &&
              !memcmp(bb + 4, "a\0b\0c", 5),
          "a body with NULs goes out whole, with its length");
    free(r);
    CHECK(request(AF_INET, port, get_status, strlen(get_status), 3, &r, &n, NULL) == 200 &&
              strstr(r, "\r\nContent-Length: 13\r\n"),
          "the told length applies to that body only");
    free(r);

    const char *head = "HEAD /status HTTP/1.1\r\nHost: x\r\n\r\n";
    CHECK(request(AF_INET, port, head, strlen(head), 3, &r, &n, NULL) == 200, "HEAD 200");
    CHECK(strstr(r, "\r\nContent-Length: 13\r\n") && !strcmp(body_of(r), ""), "HEAD: length, no body: %s", r);
    free(r);

    const char *q = "GET /status?pretty=1 HTTP/1.0\r\n\r\n";
    CHECK(request(AF_INET, port, q, strlen(q), 3, &r, &n, NULL) == 200, "HTTP/1.0, query ignored");
    CHECK(!strcmp(body_of(r), "{\"ok\": true}\n"), "query: body");
    free(r);

    const char *nope = "GET /nope HTTP/1.1\r\nHost: x\r\n\r\n";
    CHECK(request(AF_INET, port, nope, strlen(nope), 3, &r, &n, NULL) == 404, "unknown path 404");
    CHECK(strstr(body_of(r), "\"error\": 404") && strstr(r, "\r\nContent-Type: application/json\r\n") &&
              strstr(r, "\r\nCache-Control: no-store\r\n"),
          "404 JSON: %s", r);
    free(r);

    const char *post = "POST /status HTTP/1.1\r\nHost: x\r\nContent-Length: 3\r\n\r\na=1";
    CHECK(request(AF_INET, port, post, strlen(post), 3, &r, &n, NULL) == 405, "POST 405");
    CHECK(strstr(r, "\r\nAllow: GET, HEAD\r\n") && strstr(body_of(r), "\"error\": 405"), "405 Allow: %s", r);
    free(r);

    const char *body = "GET /status HTTP/1.1\r\nHost: x\r\nContent-Length: 5\r\n\r\nhello";
    CHECK(request(AF_INET, port, body, strlen(body), 3, &r, &n, NULL) == 413, "a body 413: %.40s", r);
    free(r);
    const char *chunked = "GET /status HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n0\r\n\r\n";
    CHECK(request(AF_INET, port, chunked, strlen(chunked), 3, NULL, NULL, NULL) == 413, "chunked body 413");

    static char longreq[HTTP_MAX_URL + 200];
    int k = snprintf(longreq, sizeof longreq, "GET /");
    memset(longreq + k, 'a', HTTP_MAX_URL + 10);
    k += HTTP_MAX_URL + 10;
    k += snprintf(longreq + k, sizeof longreq - (size_t)k, " HTTP/1.1\r\nHost: x\r\n\r\n");
    CHECK(request(AF_INET, port, longreq, (size_t)k, 3, NULL, NULL, NULL) == 414, "long URL 414");
    /* 64 KiB of URL: refused as soon as it is too long, not read to the end */
    size_t hn = 70000;
    char *huge = malloc(hn);
    memcpy(huge, "GET /", 5);
    memset(huge + 5, 'b', hn - 5);
    CHECK(request(AF_INET, port, huge, hn, 3, NULL, NULL, NULL) == 414, "64 KiB URL 414");
    free(huge);

    const char *junk = "hello\r\n\r\n";
    CHECK(request(AF_INET, port, junk, strlen(junk), 3, NULL, NULL, NULL) == 400, "garbage 400");
    const char *v2 = "GET /status HTTP/2.0\r\n\r\n";
    CHECK(request(AF_INET, port, v2, strlen(v2), 3, NULL, NULL, NULL) == 505, "HTTP/2.0 505");

    CHECK(get(AF_INET, port, "/unhealthy", 3, NULL) == 503, "route's code passed on");
    const char *met = "GET /metrics HTTP/1.1\r\nHost: x\r\n\r\n";
    CHECK(request(AF_INET, port, met, strlen(met), 3, &r, &n, NULL) == 200 &&
              strstr(r, "\r\nContent-Type: text/plain; version=0.0.4\r\n"),
          "route's content type passed on");
    free(r);
    const char *bigreq = "GET /big HTTP/1.1\r\nHost: x\r\n\r\n";
    CHECK(request(AF_INET, port, bigreq, strlen(bigreq), 5, &r, &n, NULL) == 200 && strlen(body_of(r)) == BIG,
          "1 MiB body arrives whole: %zu", strlen(body_of(r)));
    free(r);
}

static void listen_forms(void)
{
    static const char *bad[] = {"localhost:8642", "127.0.0.1:99999", "127.0.0.1:", "[::1:8642",
                                "[::1]8642",      ":8642",           "",            "1.2.3:80"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        http_server *s = NULL;
        sph_error e;
        sph_error_clear(&e);
        int rc = http_start(&s, bad[i], 4, 2, route, NULL, &e);
        CHECK(rc == SPH_ERR_CONFIG && !s && strstr(e.msg, "status.listen") && strstr(e.msg, bad[i]),
              "\"%s\" refused: %d %s", bad[i], rc, e.msg);
        http_stop(s);
    }
    if (!ipv6_loopback()) {
        printf("note: no IPv6 loopback on this machine: the ::1 checks are skipped (counted as passed)\n");
        CHECK(1, "skipped");
        return;
    }
    http_server *s = NULL;
    sph_error e;
    sph_error_clear(&e);
    CHECK(http_start(&s, "[::1]:0", 32, 8, route, NULL, &e) == SPH_OK, "[::1]:0: %s", e.msg);
    int port = http_port(s);
    CHECK(port > 0 && get(AF_INET6, port, "/status", 3, NULL) == 200, "GET /status over ::1 (port %d)", port);
    CHECK(get(AF_INET, port, "/status", 1, NULL) == 0, "[::1] does not listen on 127.0.0.1");
    http_stop(s);
    /* the address alone: port 8642 (may be taken on this machine: then the
     * error is about listening, not about the form) */
    s = NULL;
    sph_error_clear(&e);
    int rc = http_start(&s, "::1", 32, 8, route, NULL, &e);
    CHECK((rc == SPH_OK && http_port(s) == 8642) || (rc == SPH_ERR_IO && strstr(e.msg, "8642")),
          "\"::1\" means [::1]:8642: %d %s", rc, e.msg);
    http_stop(s);
}

/* ---------------------------------------------------------- robustness */

typedef struct slow {
    int fd[NSLOW];
    double opened[NSLOW], closed[NSLOW];
    size_t sent[NSLOW];
    double next;
} slow;

static const char trickle[] = "GET /status HTTP/1.1\r\nHost: x\r\nX-Slow: aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa";

static void slow_open(slow *w, int port)
{
    for (int i = 0; i < NSLOW; i++) {
        w->fd[i] = open_sock(AF_INET, port);
        w->opened[i] = time_monotonic();
        w->closed[i] = -1;
        w->sent[i] = 0;
    }
    w->next = time_monotonic();
}

/* One byte on each open slow socket every 0.5 s; notes when they close. */
static void slow_tick(slow *w)
{
    double now = time_monotonic();
    for (int i = 0; i < NSLOW; i++) {
        if (w->closed[i] >= 0)
            continue;
        if (w->fd[i] < 0 || peer_closed(w->fd[i])) {
            w->closed[i] = now;
            continue;
        }
        if (now >= w->next && w->sent[i] < sizeof trickle - 1) {
            if (send(w->fd[i], trickle + w->sent[i], 1, MSG_NOSIGNAL | MSG_DONTWAIT) == 1)
                w->sent[i]++;
            else if (errno != EAGAIN && errno != ENOTCONN)
                w->closed[i] = now;
        }
    }
    if (now >= w->next)
        w->next = now + 0.5;
}

static int slow_open_count(const slow *w)
{
    int n = 0;
    for (int i = 0; i < NSLOW; i++)
        n += w->closed[i] < 0;
    return n;
}

static void slow_close(slow *w)
{
    for (int i = 0; i < NSLOW; i++)
        if (w->fd[i] >= 0)
            close(w->fd[i]);
}

/* Waits while trickling, up to `seconds`; stops early when all are closed. */
static void trickle_for(slow *w, const int *idle, double *idle_closed, int nidle, double seconds)
{
    double end = time_monotonic() + seconds;
    while (time_monotonic() < end) {
        slow_tick(w);
        int open = slow_open_count(w);
        for (int i = 0; i < nidle; i++) {
            if (idle_closed[i] < 0 && (idle[i] < 0 || peer_closed(idle[i])))
                idle_closed[i] = time_monotonic();
            open += idle_closed[i] < 0;
        }
        if (!open)
            return;
        nap(0.02);
    }
}

int main(void)
{
    signal(SIGPIPE, SIG_IGN);
    if (getenv("SPHICE_VALGRIND"))
        answer_limit = 5.0;
    double t_start = time_monotonic();
    http_server *s = NULL;
    sph_error e;
    sph_error_clear(&e);
    /* the daemon's defaults: status.max_connections 32, status.per_ip_limit 8 */
    CHECK(http_start(&s, "127.0.0.1:0", 32, 8, route, NULL, &e) == SPH_OK, "start: %s", e.msg);
    int port = http_port(s);
    CHECK(port > 0, "port %d", port);

    replies(port);
    listen_forms();

    /* 8 slow sockets (the per-address limit), one byte every 0.5 s */
    printf("whole-request deadline %.1f s\n", (double)HTTP_DEADLINE_S);
    slow w;
    slow_open(&w, port);
    trickle_for(&w, NULL, NULL, 0, 1.0);
    double took;
    int code = get(AF_INET, port, "/status", 3, &took);
    printf("  8 slow sockets: /status %s in %.1f ms\n", code == 200 ? "answered" : "NOT answered", took * 1e3);
    CHECK(code == 200 && took < answer_limit, "/status within 1 s beside 8 slow sockets: %d in %.3f s", code,
          took);
    trickle_for(&w, NULL, NULL, 0, HTTP_DEADLINE_S + 2.0);
    int by_deadline = 0, early = 0;
    for (int i = 0; i < NSLOW; i++) {
        double life = w.closed[i] - w.opened[i];
        if (w.closed[i] >= 0 && life <= HTTP_DEADLINE_S + 1.0)
            by_deadline++;
        if (w.closed[i] >= 0 && life < HTTP_DEADLINE_S - 0.5)
            early++;
    }
    printf("  slow sockets closed by the deadline: %d of %d (%d before it: made room)\n", by_deadline, NSLOW,
           early);
    CHECK(by_deadline == NSLOW, "every slow socket closed by the deadline although it kept sending: %d of %d",
          by_deadline, NSLOW);
    CHECK(early <= 1, "the others lived to the deadline: %d closed early", early);
    slow_close(&w);

    /* 200 idle sockets, then 8 slow ones */
    int idle[NIDLE];
    double idle_closed[NIDLE], idle_opened = time_monotonic();
    for (int i = 0; i < NIDLE; i++) {
        idle[i] = open_sock(AF_INET, port);
        idle_closed[i] = -1;
    }
    slow_open(&w, port);
    trickle_for(&w, idle, idle_closed, NIDLE, 0.3);
    double worst = 0;
    for (int k = 0; k < 3; k++) {
        code = get(AF_INET, port, "/status", 3, &took);
        printf("  200 idle + 8 slow sockets: /status %s in %.1f ms\n", code == 200 ? "answered" : "NOT answered",
               took * 1e3);
        worst = code == 200 && took > worst ? took : code == 200 ? worst : INFINITY;
        trickle_for(&w, idle, idle_closed, NIDLE, 0.4);
    }
    CHECK(worst < answer_limit, "/status within 1 s beside 200 idle and 8 slow sockets: worst %.3f s", worst);
    trickle_for(&w, idle, idle_closed, NIDLE, HTTP_DEADLINE_S + 1.5 - (time_monotonic() - idle_opened));
    int idle_open = 0;
    for (int i = 0; i < NIDLE; i++)
        idle_open += idle_closed[i] < 0;
    printf("  after %.1f s: %d idle and %d slow sockets still open\n", time_monotonic() - idle_opened, idle_open,
           slow_open_count(&w));
    CHECK(idle_open == 0 && slow_open_count(&w) == 0, "every socket closed by the deadline: %d idle, %d slow open",
          idle_open, slow_open_count(&w));
    for (int i = 0; i < NIDLE; i++)
        if (idle[i] >= 0)
            close(idle[i]);
    slow_close(&w);

    /* 200 simultaneous requests: all connected and sent before any is read */
    int fds[NSIM], ok = 0;
    const char *req = "GET /status HTTP/1.1\r\nHost: x\r\n\r\n";
    double t0 = time_monotonic();
    for (int i = 0; i < NSIM; i++) {
        fds[i] = open_sock(AF_INET, port);
        if (fds[i] >= 0)
            send_all(fds[i], req, strlen(req), t0 + 3);
    }
    for (int i = 0; i < NSIM; i++) {
        size_t n;
        char *b = fds[i] >= 0 ? recv_all(fds[i], t0 + 5, &n) : NULL;
        ok += b && !strncmp(b, "HTTP/1.1 200 ", 13) && !strcmp(body_of(b), "{\"ok\": true}\n");
        free(b);
        if (fds[i] >= 0)
            close(fds[i]);
    }
    printf("  200 simultaneous requests: %d answered in %.3f s\n", ok, time_monotonic() - t0);
    CHECK(ok == NSIM, "200 simultaneous requests all answered: %d", ok);

    CHECK(get(AF_INET, port, "/status", 3, NULL) == 200, "still serving");
    http_stop(s);
    CHECK(get(AF_INET, port, "/status", 1, NULL) == 0, "stopped: nothing listens");
    printf("test_http took %.1f s\n", time_monotonic() - t_start);
    return check_summary("test_http");
}
