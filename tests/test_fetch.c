/* Downloads against a local HTTP server (libmicrohttpd on 127.0.0.1, a free
 * port): success with sha256 of the served bytes, 404 (no retry), 500
 * (retried, each attempt counted by the server), a stalled server, a
 * truncated response (Content-Length larger than the body), not NetCDF,
 * NetCDF without the expected variable: each with its own message and no
 * partial file left in the cache. Conditional requests: unchanged file ->
 * 304 and no re-download (server hits counted); ETag and If-Modified-Since.
 * file:// and plain paths; URL templates against hand-computed dates. */
#include "io/fetch.h"
#include "service/cycle.h"

#include <arpa/inet.h>
#include <curl/curl.h>
#include <dirent.h>
#include <microhttpd.h>
#include <netcdf.h>
#include <netinet/in.h>
#include <pthread.h>
#include <stdatomic.h>
#include <time.h>
#include <unistd.h>

#include "util/fileio.h"
#include "util/timeutil.h"

#include "check.h"

static char *good_bytes, *novar_bytes;
static size_t good_len, novar_len;
static atomic_int hits_good, hits_200_good, hits_500, hits_404, hits_stall, hits_trunc, hits_ims,
    ims_304;
static atomic_int stopping;
static int good_version = 1;
static const time_t good_mtime = 946684800; /* 2000-01-01 */

/* A small NetCDF file with variables `vars` (comma list), read into memory. */
static char *make_nc(const char *dir, const char *name, const char *var, float value, size_t *len)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    int ncid, d, v;
    nc_create(path, NC_CLOBBER, &ncid);
    nc_def_dim(ncid, "x", 1000, &d);
    nc_def_var(ncid, var, NC_FLOAT, 1, &d, &v);
    nc_enddef(ncid);
    static float data[1000];
    for (int k = 0; k < 1000; k++)
        data[k] = value + k;
    nc_put_var_float(ncid, v, data);
    nc_close(ncid);
    char *bytes = NULL;
    read_file(path, &bytes, len, NULL);
    return bytes;
}

typedef struct {
    const char *data;
    size_t len, cut; /* bytes to send before failing */
    int stall;       /* sleep instead of finishing */
} slow_body;

static ssize_t body_reader(void *cls, uint64_t pos, char *buf, size_t max)
{
    slow_body *b = cls;
    if (pos < b->cut) {
        size_t n = b->cut - (size_t)pos;
        if (n > max)
            n = max;
        memcpy(buf, b->data + pos, n);
        return (ssize_t)n;
    }
    if (b->stall) {
        /* stay silent for up to 5 s (the client gives up after 1 s) */
        for (int k = 0; k < 100 && !atomic_load(&stopping); k++)
            usleep(50000);
    }
    return MHD_CONTENT_READER_END_WITH_ERROR; /* close: body shorter than announced */
}

static slow_body trunc_body, stall_body;

static enum MHD_Result queue(struct MHD_Connection *c, unsigned code, const char *data, size_t len,
                             const char *etag, time_t mtime)
{
    struct MHD_Response *r = MHD_create_response_from_buffer(len, (void *)data, MHD_RESPMEM_MUST_COPY);
    if (etag)
        MHD_add_response_header(r, "ETag", etag);
    if (mtime) {
        char date[64];
        struct tm tm;
        gmtime_r(&mtime, &tm);
        strftime(date, sizeof date, "%a, %d %b %Y %H:%M:%S GMT", &tm);
        MHD_add_response_header(r, "Last-Modified", date);
    }
    enum MHD_Result ret = MHD_queue_response(c, code, r);
    MHD_destroy_response(r);
    return ret;
}

static enum MHD_Result handler(void *cls, struct MHD_Connection *c, const char *url,
                               const char *method, const char *version, const char *upload,
                               size_t *upload_size, void **state)
{
    (void)cls, (void)method, (void)version, (void)upload, (void)upload_size;
    if (!*state) { /* first call per request: headers only */
        *state = (void *)1;
        return MHD_YES;
    }
    if (strcmp(url, "/good.nc") == 0) {
        atomic_fetch_add(&hits_good, 1);
        char etag[32];
        snprintf(etag, sizeof etag, "\"v%d\"", good_version);
        const char *inm = MHD_lookup_connection_value(c, MHD_HEADER_KIND, "If-None-Match");
        if (inm && strcmp(inm, etag) == 0)
            return queue(c, 304, "", 0, etag, good_mtime);
        atomic_fetch_add(&hits_200_good, 1);
        return queue(c, 200, good_bytes, good_len, etag, good_mtime + good_version);
    }
    if (strcmp(url, "/ims.nc") == 0) { /* Last-Modified only, no ETag */
        atomic_fetch_add(&hits_ims, 1);
        const char *ims = MHD_lookup_connection_value(c, MHD_HEADER_KIND, "If-Modified-Since");
        if (ims && curl_getdate(ims, NULL) >= good_mtime) {
            atomic_fetch_add(&ims_304, 1);
            return queue(c, 304, "", 0, NULL, good_mtime);
        }
        return queue(c, 200, good_bytes, good_len, NULL, good_mtime);
    }
    if (strcmp(url, "/error500.nc") == 0) {
        atomic_fetch_add(&hits_500, 1);
        return queue(c, 500, "boom", 4, NULL, 0);
    }
    if (strcmp(url, "/notnc.nc") == 0)
        return queue(c, 200, "<html>not here</html>", 21, NULL, 0);
    if (strcmp(url, "/novar.nc") == 0)
        return queue(c, 200, novar_bytes, novar_len, NULL, 0);
    if (strcmp(url, "/truncated.nc") == 0 || strcmp(url, "/stall.nc") == 0) {
        int stall = url[1] == 's';
        atomic_fetch_add(stall ? &hits_stall : &hits_trunc, 1);
        slow_body *b = stall ? &stall_body : &trunc_body;
        struct MHD_Response *r = MHD_create_response_from_callback(b->len, 4096, body_reader, b, NULL);
        enum MHD_Result ret = MHD_queue_response(c, 200, r);
        MHD_destroy_response(r);
        return ret;
    }
    atomic_fetch_add(&hits_404, 1);
    return queue(c, 404, "no", 2, NULL, 0);
}

/* Files in the cache directory other than completed downloads and ETags. */
static int stray_files(const char *dir, char *names, size_t len)
{
    DIR *d = opendir(dir);
    int n = 0;
    names[0] = '\0';
    if (!d)
        return 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.')
            continue;
        const char *s = e->d_name;
        size_t l = strlen(s);
        int ok = (l > 3 && strcmp(s + l - 3, ".nc") == 0) || (l > 5 && strcmp(s + l - 5, ".etag") == 0);
        if (!ok || strstr(s, ".part") || strstr(s, ".tmp")) {
            n++;
            strncat(names, s, len - strlen(names) - 2);
            strncat(names, " ", len - strlen(names) - 1);
        }
    }
    closedir(d);
    return n;
}

static int cache_has(const char *dir, const char *suffix)
{
    DIR *d = opendir(dir);
    int found = 0;
    struct dirent *e;
    while (d && (e = readdir(d)))
        if (strstr(e->d_name, suffix))
            found = 1;
    if (d)
        closedir(d);
    return found;
}

static void expect_fail(const char *base, const char *path, const fetch_options *o, const char *cache,
                        const char *m1, const char *m2)
{
    char url[256], local[4096], stray[1024];
    snprintf(url, sizeof url, "%s%s", base, path);
    sph_error err;
    sph_error_clear(&err);
    double t0 = time_monotonic();
    int rc = fetch_url(url, o, local, sizeof local, NULL, &err);
    double dt = time_monotonic() - t0;
    CHECK(rc != SPH_OK, "%s must fail", path);
    CHECK(strstr(err.msg, url) != NULL, "message names the URL: %s", err.msg);
    CHECK(strstr(err.msg, m1) && (!m2 || strstr(err.msg, m2)), "%s: message has \"%s\"%s%s: %s", path,
          m1, m2 ? " and " : "", m2 ? m2 : "", err.msg);
    CHECK(stray_files(cache, stray, sizeof stray) == 0, "%s left in cache: %s", path, stray);
    CHECK(!cache_has(cache, path + 1), "%s: no file of that name in the cache", path);
    CHECK(dt < 8, "%s took %.1f s", path, dt);
    if (getenv("SPHICE_TEST_VERBOSE"))
        fprintf(stderr, "expected error (%.2f s): %s\n", dt, err.msg);
}

int main(void)
{
    sph_error err;
    sph_error_clear(&err);
    char dir[] = "/tmp/sphice_fetch_XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    char cache[600];
    snprintf(cache, sizeof cache, "%s/cache", dir);
    good_bytes = make_nc(dir, "good_src.nc", "siconc", 0.5f, &good_len);
    novar_bytes = make_nc(dir, "novar_src.nc", "other", 1.5f, &novar_len);
    trunc_body = (slow_body){good_bytes, good_len, good_len / 2, 0};
    stall_body = (slow_body){good_bytes, good_len, 0, 1}; /* headers, then silence */

    /* --- templates (dates worked out by hand): the one template syntax is
     * the configuration's strftime form (service/cycle.h); a lead time is
     * expanded as the valid time, cycle + lead --- */
    double t;
    time_parse_iso("1999-02-08T06:00:00Z", &t);
    char out[256];
    CHECK(cycle_expand_template("https://x/%Y/%m/%d/gfs.t%Hz.%Y%m%d.nc", t, out, sizeof out, &err) == SPH_OK &&
          strcmp(out, "https://x/1999/02/08/gfs.t06z.19990208.nc") == 0, "template: %s %s", out, err.msg);
    CHECK(cycle_expand_template("f_%Y%m%d%H", t + 42 * 3600.0, out, sizeof out, &err) == SPH_OK &&
          strcmp(out, "f_1999021000") == 0, "lead template: %s", out);
    CHECK(cycle_expand_template("%j", t, out, sizeof out, &err) == SPH_OK && strcmp(out, "039") == 0,
          "day of year: %s", out);
    time_parse_iso("2000-12-31T23:00:00Z", &t);
    CHECK(cycle_expand_template("%Y%m%d%H", t + 3600.0, out, sizeof out, &err) == SPH_OK &&
          strcmp(out, "2001010100") == 0, "year rollover: %s", out);
    CHECK(cycle_expand_template("%j", t, out, sizeof out, &err) == SPH_OK && strcmp(out, "366") == 0,
          "leap day of year: %s", out);
    sph_error_clear(&err);
    CHECK(cycle_expand_template("a%Qb", t, out, sizeof out, &err) == SPH_ERR_CONFIG && strstr(err.msg, "%Q"),
          "unknown placeholder: %s", err.msg);
    sph_error_clear(&err);
    CHECK(cycle_expand_template("%Y%Y", t, out, 6, &err) == SPH_ERR_CONFIG, "too long");

    /* --- server --- */
    struct sockaddr_in sa;
    memset(&sa, 0, sizeof sa);
    sa.sin_family = AF_INET;
    sa.sin_port = 0;
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    struct MHD_Daemon *d = MHD_start_daemon(MHD_USE_THREAD_PER_CONNECTION | MHD_USE_INTERNAL_POLLING_THREAD,
                                            0, NULL, NULL, handler, NULL, MHD_OPTION_SOCK_ADDR, &sa,
                                            MHD_OPTION_END);
    CHECK(d != NULL, "MHD_start_daemon");
    if (!d)
        return check_summary("test_fetch");
    const union MHD_DaemonInfo *info = MHD_get_daemon_info(d, MHD_DAEMON_INFO_BIND_PORT);
    char base[64];
    snprintf(base, sizeof base, "http://127.0.0.1:%u", (unsigned)info->port);

    fetch_options o;
    fetch_options_default(&o);
    o.cache_dir = cache;
    o.timeout_s = 4;
    o.connect_timeout_s = 1;
    o.stall_timeout_s = 1;
    o.retries = 2;
    o.backoff_s = 0.05;
    const char *vars[] = {"siconc"};
    o.expect_vars = vars;
    o.n_expect = 1;

    /* success */
    char url[1024], local[4096], sha[65], want_sha[65], stray[1024];
    sha256_hex(good_bytes, good_len, want_sha);
    snprintf(url, sizeof url, "%s/good.nc", base);
    fetch_result res;
    CHECK(fetch_url_ex(url, &o, local, sizeof local, sha, &res, &err) == SPH_OK, "good: %s", err.msg);
    CHECK(strcmp(sha, want_sha) == 0, "sha256 of the served bytes");
    CHECK(res.downloaded == 1 && res.attempts == 1 && res.http_status == 200, "first fetch downloads");
    CHECK(strncmp(local, cache, strlen(cache)) == 0, "cached under the cache dir: %s", local);
    char expect_path[4096];
    fetch_cache_path(url, cache, expect_path, sizeof expect_path, NULL);
    CHECK(strcmp(local, expect_path) == 0, "deterministic cache name");
    char *got = NULL;
    size_t got_len = 0;
    read_file(local, &got, &got_len, NULL);
    CHECK(got && got_len == good_len && memcmp(got, good_bytes, good_len) == 0, "cached bytes equal served bytes");
    free(got);
    CHECK(stray_files(cache, stray, sizeof stray) == 0, "stray: %s", stray);

    /* conditional: unchanged -> 304, no re-download */
    int before = atomic_load(&hits_good), before200 = atomic_load(&hits_200_good);
    char local2[4096], sha2[65];
    CHECK(fetch_url_ex(url, &o, local2, sizeof local2, sha2, &res, &err) == SPH_OK, "again: %s", err.msg);
    CHECK(atomic_load(&hits_good) == before + 1 && atomic_load(&hits_200_good) == before200,
          "second fetch: one request, answered 304 (hits %d, 200s %d)", atomic_load(&hits_good) - before,
          atomic_load(&hits_200_good) - before200);
    CHECK(res.not_modified == 1 && res.downloaded == 0, "not modified reported");
    CHECK(strcmp(local2, local) == 0 && strcmp(sha2, want_sha) == 0, "cached path and sha returned");
    /* changed on the server -> downloaded again */
    free(good_bytes);
    good_bytes = make_nc(dir, "good_src2.nc", "siconc", 7.0f, &good_len);
    good_version = 2;
    sha256_hex(good_bytes, good_len, want_sha);
    CHECK(fetch_url_ex(url, &o, local2, sizeof local2, sha2, &res, &err) == SPH_OK, "changed: %s", err.msg);
    CHECK(res.downloaded == 1 && strcmp(sha2, want_sha) == 0, "changed file downloaded again");
    trunc_body.data = stall_body.data = good_bytes;

    /* If-Modified-Since alone */
    snprintf(url, sizeof url, "%s/ims.nc", base);
    CHECK(fetch_url_ex(url, &o, local2, sizeof local2, NULL, &res, &err) == SPH_OK && res.downloaded, "ims first");
    CHECK(fetch_url_ex(url, &o, local2, sizeof local2, NULL, &res, &err) == SPH_OK && res.not_modified,
          "ims second not modified");
    CHECK(atomic_load(&hits_ims) == 2 && atomic_load(&ims_304) == 1, "If-Modified-Since answered 304");

    /* failures */
    expect_fail(base, "/missing.nc", &o, cache, "HTTP 404", NULL);
    CHECK(atomic_load(&hits_404) == 1, "404 not retried (%d hits)", atomic_load(&hits_404));
    expect_fail(base, "/error500.nc", &o, cache, "HTTP 500", "after 3 attempts");
    CHECK(atomic_load(&hits_500) == 3, "500 retried twice (%d hits)", atomic_load(&hits_500));
    fetch_options o1 = o;
    o1.retries = 1;
    expect_fail(base, "/truncated.nc", &o1, cache, "truncated transfer", "after 2 attempts");
    CHECK(atomic_load(&hits_trunc) == 2, "truncated retried once (%d hits)", atomic_load(&hits_trunc));
    fetch_options o0 = o;
    o0.retries = 0;
    expect_fail(base, "/stall.nc", &o0, cache, "timed out", "stalled");
    CHECK(atomic_load(&hits_stall) == 1, "stall: one attempt");
    expect_fail(base, "/notnc.nc", &o, cache, "not a NetCDF file", "<html>");
    expect_fail(base, "/novar.nc", &o, cache, "lacks variable \"siconc\"", NULL);
    /* connection refused: nobody listens on port 1 */
    {
        fetch_options oc = o;
        oc.retries = 1;
        sph_error_clear(&err);
        CHECK(fetch_url("http://127.0.0.1:1/x.nc", &oc, local, sizeof local, NULL, &err) == SPH_ERR_DOWNLOAD &&
              strstr(err.msg, "after 2 attempts"), "connection refused retried: %s", err.msg);
    }
    /* fault injected between the check and the rename: nothing stays */
    setenv("SPHICE_FAULT", "fetch_before_rename", 1);
    snprintf(url, sizeof url, "%s/good.nc?fresh=1", base);
    sph_error_clear(&err);
    CHECK(fetch_url(url, &o, local, sizeof local, NULL, &err) != SPH_OK, "fault injected");
    unsetenv("SPHICE_FAULT");
    CHECK(stray_files(cache, stray, sizeof stray) == 0, "after fault: %s", stray);

    /* file:// and a plain path, checked the same way */
    char src[600];
    snprintf(src, sizeof src, "%s/good_src2.nc", dir);
    snprintf(url, sizeof url, "file://%s", src);
    CHECK(fetch_url(url, &o, local, sizeof local, sha, &err) == SPH_OK, "file://: %s", err.msg);
    CHECK(strcmp(local, src) == 0 && strcmp(sha, want_sha) == 0, "file:// used in place, sha ok");
    CHECK(fetch_url(src, &o, local, sizeof local, sha, &err) == SPH_OK && strcmp(local, src) == 0, "plain path");
    snprintf(src, sizeof src, "%s/novar_src.nc", dir);
    sph_error_clear(&err);
    CHECK(fetch_url(src, &o, local, sizeof local, sha, &err) == SPH_ERR_MISSING_VAR && strstr(err.msg, src),
          "local file checked for variables: %s", err.msg);
    sph_error_clear(&err);
    CHECK(fetch_url("gopher://x/y.nc", &o, local, sizeof local, sha, &err) == SPH_ERR_CONFIG, "bad scheme");

    atomic_store(&stopping, 1);
    MHD_stop_daemon(d);
    free(good_bytes);
    free(novar_bytes);
    curl_global_cleanup();
    char cmd[700];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    CHECK(system(cmd) == 0, "cleanup");
    return check_summary("test_fetch");
}
