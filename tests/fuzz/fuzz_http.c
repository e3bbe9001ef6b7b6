/* libFuzzer harness: the status server's request handling
 * (http_respond, what the server runs on each connection's bytes). Any
 * byte string must give "need more" (0) or a complete reply with a valid
 * status code, never a crash. The router echoes the decoded path. */
#include <string.h>

#include "service/http.h"

#include "fuzz.h"

static char *route(void *ctx, const char *path, int *code, const char **content_type)
{
    (void)ctx;
    if (!strcmp(path, "/missing"))
        return NULL;
    size_t n = strlen(path);
    char *b = malloc(n + 2);
    if (!b)
        return NULL;
    memcpy(b, path, n);
    b[n] = '\n';
    b[n + 1] = '\0';
    *code = 200;
    *content_type = "text/plain";
    return b;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char *reply = NULL;
    size_t len = 0;
    int code = http_respond((const char *)data, size, route, NULL, &reply, &len);
    if (code != 0 && (code < 100 || code > 599))
        abort();
    if (reply) {
        if (len < 12 || memcmp(reply, "HTTP/1.", 7) != 0)
            abort();
        free(reply);
    }
    return 0;
}
