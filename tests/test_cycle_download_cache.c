/* A good cached download is never replaced by a bad one (issue 21, item 1).
 * A server on 127.0.0.1 answers the same forcing URL with, in turn:
 *   phase 0: a good ERA5-style file (u10 and v10, ETag "E1", Last-Modified)
 *   phase 1: a valid NetCDF file without v10 (ETag "E2")
 *   phase 2: HTTP 500
 *   phase 3: a file that is not NetCDF at all
 * The source maps northward_wind -> v10, so the cycle tells the downloader
 * that v10 is required. Throughout, the cache holds the good bytes and its
 * .etag stays "E1"; with late_data.policy stale the cycle runs on the last
 * good download flagged stale (cycle.json: "stale": true, the good file's
 * sha256); with policy fail it fails naming the server's answer. */
#include <microhttpd.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "era5_file.h"
#include "io/fetch.h"
#include "service/config.h"
#include "service/cycle.h"
#include "util/err.h"
#include "util/fileio.h"

static char tmp[256];
static char *good, *novar;
static size_t good_len, novar_len;
static atomic_int phase, hits[4];

static enum MHD_Result answer(void *cls, struct MHD_Connection *c, const char *url, const char *method,
                              const char *version, const char *data, size_t *size, void **ptr)
{
    (void)cls; (void)url; (void)method; (void)version; (void)data; (void)size; (void)ptr;
    int p = atomic_load(&phase);
    atomic_fetch_add(&hits[p], 1);
    struct MHD_Response *r;
    unsigned code = MHD_HTTP_OK;
    static char err500[] = "internal error", html[] = "<html><body>maintenance</body></html>";
    if (p == 0) {
        r = MHD_create_response_from_buffer(good_len, good, MHD_RESPMEM_PERSISTENT);
        MHD_add_response_header(r, "ETag", "\"E1\"");
        MHD_add_response_header(r, "Last-Modified", "Sat, 01 Jan 2000 00:00:00 GMT");
    } else if (p == 1) {
        r = MHD_create_response_from_buffer(novar_len, novar, MHD_RESPMEM_PERSISTENT);
        MHD_add_response_header(r, "ETag", "\"E2\"");
        MHD_add_response_header(r, "Last-Modified", "Sun, 02 Jan 2000 00:00:00 GMT");
    } else if (p == 2) {
        r = MHD_create_response_from_buffer(strlen(err500), err500, MHD_RESPMEM_PERSISTENT);
        code = MHD_HTTP_INTERNAL_SERVER_ERROR;
    } else {
        r = MHD_create_response_from_buffer(strlen(html), html, MHD_RESPMEM_PERSISTENT);
        MHD_add_response_header(r, "ETag", "\"E3\"");
    }
    enum MHD_Result ret = MHD_queue_response(c, code, r);
    MHD_destroy_response(r);
    return ret;
}

static struct sph_config *config_for(int port, const char *policy, const char *quantities, const char *cache)
{
    char text[4096];
    snprintf(text, sizeof text,
             "{\"engine\": \"test-double\", \"test\": {\"engine_seconds\": 0.01},"
             " \"domain\": {\"lon_min\": 119, \"lon_max\": 122, \"lat_min\": 38, \"lat_max\": 41},"
             " \"forcing\": [{\"name\": \"era5\", \"kind\": \"atmosphere\","
             "   \"urls\": \"http://127.0.0.1:%d/era5_%%Y%%m%%d.nc\", \"issue_hours\": 24,"
             "   \"variables\": {\"eastward_wind\": \"u10\", \"northward_wind\": \"v10\"},"
             "   %s}],"
             " \"output\": {\"dir\": \"%s/out\"},"
             " \"fetch\": {\"retries\": 0, \"backoff_s\": 0},"
             " \"schedule\": {\"late_data\": {\"wait_minutes\": 0, \"policy\": \"%s\"}},"
             " \"paths\": {\"state_dir\": \"%s/state\", \"cache_dir\": \"%s/%s\"}}",
             port, quantities, tmp, policy, tmp, tmp, cache);
    struct sph_config *c = NULL;
    sph_error e = {0};
    return sph_config_parse(text, "test", &c, &e) == SPH_OK ? c : (fprintf(stderr, "%s\n", e.msg), NULL);
}

/* The cache holds exactly the good bytes and the ETag "E1". */
static void check_cache(const char *cached, const char *when)
{
    char *bytes = NULL, *etag = NULL, etag_path[4200];
    size_t n = 0;
    CHECK(read_file(cached, &bytes, &n, NULL) == 0 && n == good_len && !memcmp(bytes, good, n),
          "%s: the cache holds the good file (%zu bytes, want %zu)", when, n, good_len);
    snprintf(etag_path, sizeof etag_path, "%s.etag", cached);
    CHECK(read_file(etag_path, &etag, NULL, NULL) == 0 && etag && !strcmp(etag, "\"E1\"\n"),
          "%s: the cached ETag is still \"E1\" (%s)", when, etag ? etag : "none");
    free(bytes);
    free(etag);
}

static void check_published(const char *out, const char *sha, int stale, const char *when)
{
    char path[700];
    snprintf(path, sizeof path, "%s/20240208T00Z/cycle.json", out);
    char *txt = NULL;
    CHECK(read_file(path, &txt, NULL, NULL) == 0, "%s: %s published", when, path);
    CHECK(txt && strstr(txt, sha), "%s: cycle.json records the good file's sha256", when);
    CHECK(txt && strstr(txt, stale ? "\"stale\":\ttrue" : "\"stale\":\tfalse"), "%s: cycle.json says stale %s",
          when, stale ? "true" : "false");
    free(txt);
}

int main(void)
{
    snprintf(tmp, sizeof tmp, "/tmp/sphice-cycle-cache-XXXXXX");
    if (!mkdtemp(tmp))
        return 1;
    good = era5_wind_file(tmp, "good.nc", 1, &good_len);
    novar = era5_wind_file(tmp, "novar.nc", 0, &novar_len);
    CHECK(good && novar, "test files written");
    char good_sha[65];
    sha256_hex(good, good_len, good_sha);

    struct MHD_Daemon *d = MHD_start_daemon(MHD_USE_INTERNAL_POLLING_THREAD, 0, NULL, NULL, &answer, NULL,
                                            MHD_OPTION_END);
    CHECK(d != NULL, "server started");
    int port = d ? MHD_get_daemon_info(d, MHD_DAEMON_INFO_BIND_PORT)->port : 0;
    const char *req = "\"required\": [\"wind\"]";
    struct sph_config *c = config_for(port, "stale", req, "cache"),
                      *cfail = config_for(port, "fail", req, "cache");
    CHECK(c && cfail, "configs");
    if (d && c && cfail) {
        char url[256], cached[4096];
        snprintf(url, sizeof url, "http://127.0.0.1:%d/era5_20240208.nc", port);
        sph_error e;
        sph_error_clear(&e);
        CHECK(fetch_cache_path(url, c->paths.cache_dir, cached, sizeof cached, &e) == 0, "cache path");
        const char *names[] = {"good download", "valid NetCDF without v10", "HTTP 500", "not NetCDF"};
        for (int p = 0; p < 4; p++) {
            atomic_store(&phase, p);
            char out[600];
            snprintf(out, sizeof out, "%s/out%d", tmp, p);
            cycle_opts o;
            memset(&o, 0, sizeof o);
            o.cycle_time = 19761 * 86400.0; /* 2024-02-08T00:00Z */
            o.out_dir = out;
            cycle_report rep;
            sph_error_clear(&e);
            int rc = cycle_run(c, &o, NULL, NULL, &rep, &e);
            CHECK(rc == 0, "%s: the cycle runs: %s", names[p], e.msg);
            CHECK(atomic_load(&hits[p]) >= 1, "%s: the server was asked", names[p]);
            CHECK(rep.stale == (p > 0), "%s: stale flag %d (want %d)", names[p], rep.stale, p > 0);
            check_cache(cached, names[p]);
            if (rc == 0)
                check_published(out, good_sha, p > 0, names[p]);
            if (p == 0)
                continue;
            /* policy fail: the cycle fails naming what the server sent; the cache stays */
            snprintf(out, sizeof out, "%s/fail%d", tmp, p);
            o.out_dir = out;
            sph_error_clear(&e);
            rc = cycle_run(cfail, &o, NULL, NULL, &rep, &e);
            const char *want = p == 1 ? "v10" : p == 2 ? "500" : "not a NetCDF file";
            CHECK(rc != 0 && strstr(e.msg, "era5_20240208.nc") && strstr(e.msg, want),
                  "%s, policy fail: the cycle fails naming the URL and \"%s\": %s", names[p], want, e.msg);
            check_cache(cached, names[p]);
        }
    }
    /* Which mapped variables a download must hold: those of the required
     * quantities; with no required list, every mapped one not optional. */
    const struct { const char *quantities; int accepted; } q[] = {
        {"\"required\": [], \"optional\": [\"wind\"]", 1},
        {"\"required\": [\"tair\"], \"optional\": [\"wind\"]", 1},
        {"\"required\": []", 0},
    };
    for (int k = 0; d && k < 3; k++) {
        char cache[32];
        snprintf(cache, sizeof cache, "cache-q%d", k);
        struct sph_config *cq = config_for(port, "fail", q[k].quantities, cache);
        CHECK(cq != NULL, "config %s", q[k].quantities);
        if (!cq)
            continue;
        atomic_store(&phase, 1); /* the file without v10 */
        char out[600];
        snprintf(out, sizeof out, "%s/q%d", tmp, k);
        cycle_opts o;
        memset(&o, 0, sizeof o);
        o.cycle_time = 19761 * 86400.0;
        o.out_dir = out;
        cycle_report rep;
        sph_error e;
        sph_error_clear(&e);
        int rc = cycle_run(cq, &o, NULL, NULL, &rep, &e);
        CHECK((rc == 0) == q[k].accepted, "%s: a download without v10 is %s: %s", q[k].quantities,
              q[k].accepted ? "accepted" : "refused", e.msg);
        sph_config_free(cq);
    }
    if (d)
        MHD_stop_daemon(d);
    sph_config_free(c);
    sph_config_free(cfail);
    free(good);
    free(novar);
    cycle_remove_tree(tmp);
    return check_summary("test_cycle_download_cache");
}
