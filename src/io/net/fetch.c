/* Downloads with libcurl: see io/fetch.h. */
#include "io/fetch.h"

#include <curl/curl.h>
#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <netcdf.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>
#include <utime.h>

#include "io/nc_guard.h"
#include "util/fileio.h"
#include "util/log.h"
#include "util/timeutil.h"

void fetch_options_default(fetch_options *o)
{
    memset(o, 0, sizeof *o);
    o->timeout_s = 600;
    o->connect_timeout_s = 30;
    o->stall_timeout_s = 60;
    o->low_speed_bytes = 1024;
    o->retries = 3;
    o->backoff_s = 5;
    o->check_netcdf = 1;
}

/* ------------------------------------------------- NetCDF completeness */

int fetch_check_netcdf(const char *path, const char *label, const char *const *vars,
                       size_t nvars, sph_error *err)
{
    if (!label)
        label = path;
    FILE *f = fopen(path, "rb");
    if (!f)
        return sph_err_set(err, SPH_ERR_IO, "%s: cannot open %s: %s", label, path, strerror(errno));
    unsigned char buf[16];
    size_t got = fread(buf, 1, sizeof buf, f);
    struct stat st;
    int have_stat = fstat(fileno(f), &st) == 0;
    fclose(f);
    int classic = got >= 4 && memcmp(buf, "CDF", 3) == 0 &&
                  (buf[3] == 1 || buf[3] == 2 || buf[3] == 5);
    int hdf5 = got >= 8 && memcmp(buf, "\x89HDF\r\n\x1a\n", 8) == 0;
    if (!classic && !hdf5) {
        char shown[17];
        size_t k;
        for (k = 0; k < got && k < 16; k++)
            shown[k] = buf[k] >= 32 && buf[k] < 127 ? (char)buf[k] : '.';
        shown[k] = '\0';
        return sph_err_set(err, SPH_ERR_NETCDF, "%s: not a NetCDF file (%lld bytes starting \"%s\")",
                           label, have_stat ? (long long)st.st_size : -1LL, shown);
    }
    /* the whole classic header against the format and the file's size; a
     * netCDF-4 file first opened in a checking process (io/nc_guard.h) */
    int grc = nc_guard_check(path, label, err);
    if (grc != SPH_OK)
        return grc;
    int ncid, status = nc_guard_nc_open(path, &ncid);
    if (status != NC_NOERR)
        return sph_err_set(err, SPH_ERR_NETCDF, "%s: cannot open as NetCDF (truncated or corrupt?): %s",
                           label, nc_strerror(status));
    int rc = SPH_OK;
    for (size_t k = 0; k < nvars && rc == SPH_OK; k++) {
        int varid;
        if (nc_inq_varid(ncid, vars[k], &varid) != NC_NOERR)
            rc = sph_err_set(err, SPH_ERR_MISSING_VAR, "%s: NetCDF file lacks variable \"%s\"", label,
                             vars[k]);
    }
    nc_close(ncid);
    return rc;
}

/* ------------------------------------------------------------ downloads */

static pthread_once_t curl_once = PTHREAD_ONCE_INIT;
static void curl_init_once(void) { curl_global_init(CURL_GLOBAL_DEFAULT); }

static const char *scheme_end(const char *url)
{
    const char *p = strstr(url, "://");
    if (!p)
        return NULL;
    for (const char *q = url; q < p; q++)
        if (!((*q >= 'a' && *q <= 'z') || (*q >= 'A' && *q <= 'Z') || *q == '+' || *q == '.' ||
              *q == '-'))
            return NULL;
    return p + 3;
}

int fetch_cache_path(const char *url, const char *cache_dir, char *path, size_t len,
                     sph_error *err)
{
    if (!cache_dir || !*cache_dir)
        return sph_err_set(err, SPH_ERR_CONFIG, "download %s: no cache directory configured", url);
    char hex[65];
    sha256_hex(url, strlen(url), hex);
    /* basename of the URL path, without query, restricted to safe characters */
    const char *start = scheme_end(url);
    start = start ? start : url;
    const char *q = strpbrk(start, "?#");
    size_t plen = q ? (size_t)(q - start) : strlen(start);
    const char *base = start;
    for (size_t k = 0; k < plen; k++)
        if (start[k] == '/')
            base = start + k + 1;
    char safe[96];
    size_t n = 0;
    for (const char *c = base; c < start + plen && n < sizeof safe - 1; c++)
        safe[n++] = (*c >= 'a' && *c <= 'z') || (*c >= 'A' && *c <= 'Z') ||
                            (*c >= '0' && *c <= '9') || *c == '.' || *c == '-' || *c == '_'
                        ? *c
                        : '_';
    safe[n] = '\0';
    int w = snprintf(path, len, "%s/%.16s-%s", cache_dir, hex, n ? safe : "download");
    if (w < 0 || (size_t)w >= len)
        return sph_err_set(err, SPH_ERR_CONFIG, "download %s: cache path too long", url);
    return SPH_OK;
}

typedef struct {
    FILE *f;
    long long bytes;
    int write_error;
    char etag[256];
} transfer;

static size_t on_data(char *ptr, size_t size, size_t nmemb, void *userdata)
{
    transfer *t = userdata;
    size_t n = size * nmemb;
    if (fwrite(ptr, 1, n, t->f) != n) {
        t->write_error = errno ? errno : EIO;
        return 0;
    }
    t->bytes += (long long)n;
    return n;
}

static size_t on_header(char *buf, size_t size, size_t nitems, void *userdata)
{
    transfer *t = userdata;
    size_t n = size * nitems;
    if (n > 5 && strncasecmp(buf, "ETag:", 5) == 0) {
        const char *v = buf + 5;
        while (*v == ' ' || *v == '\t')
            v++;
        size_t m = (size_t)(buf + n - v);
        while (m && (v[m - 1] == '\r' || v[m - 1] == '\n' || v[m - 1] == ' '))
            m--;
        if (m < sizeof t->etag) {
            memcpy(t->etag, v, m);
            t->etag[m] = '\0';
        }
    }
    return n;
}

static void read_etag(const char *etag_path, char *etag, size_t len)
{
    etag[0] = '\0';
    FILE *f = fopen(etag_path, "r");
    if (!f)
        return;
    if (fgets(etag, (int)len, f)) {
        size_t n = strlen(etag);
        while (n && (etag[n - 1] == '\n' || etag[n - 1] == '\r'))
            etag[--n] = '\0';
    }
    fclose(f);
}

/* Outcome of one attempt. */
enum { ATTEMPT_OK, ATTEMPT_NOT_MODIFIED, ATTEMPT_TRANSIENT, ATTEMPT_FATAL, ATTEMPT_CANCELLED };

static int cancelled(const fetch_options *o) { return o->cancel && *o->cancel; }

/* libcurl's progress callback: non-zero aborts the transfer. */
static int on_progress(void *userdata, curl_off_t dltotal, curl_off_t dlnow, curl_off_t ultotal,
                       curl_off_t ulnow)
{
    (void)dltotal; (void)dlnow; (void)ultotal; (void)ulnow;
    return cancelled(userdata);
}

/* curl_easy_perform, but through the multi interface in 100 ms slices so
 * that a cancellation is seen even while nothing arrives. */
static CURLcode perform_cancellable(CURL *c, const fetch_options *o, int *was_cancelled)
{
    *was_cancelled = 0;
    CURLM *m = curl_multi_init();
    if (!m)
        return CURLE_OUT_OF_MEMORY;
    if (curl_multi_add_handle(m, c) != CURLM_OK) {
        curl_multi_cleanup(m);
        return CURLE_FAILED_INIT;
    }
    CURLcode cc = CURLE_OK;
    int running = 1;
    while (running) {
        if (curl_multi_perform(m, &running) != CURLM_OK) {
            cc = CURLE_FAILED_INIT;
            break;
        }
        if (!running)
            break;
        if (cancelled(o)) {
            *was_cancelled = 1;
            break;
        }
        if (curl_multi_poll(m, NULL, 0, 100, NULL) != CURLM_OK) {
            cc = CURLE_FAILED_INIT;
            break;
        }
    }
    if (!*was_cancelled) {
        CURLMsg *msg;
        int left;
        while ((msg = curl_multi_info_read(m, &left)))
            if (msg->msg == CURLMSG_DONE && msg->easy_handle == c)
                cc = msg->data.result;
    }
    curl_multi_remove_handle(m, c);
    curl_multi_cleanup(m);
    if (cc == CURLE_ABORTED_BY_CALLBACK && cancelled(o))
        *was_cancelled = 1;
    return cc;
}

static int one_attempt(const char *url, const fetch_options *o, const char *tmp,
                       const char *cached, const char *etag_path, fetch_result *res,
                       long *filetime, char *etag_out, size_t etag_len, char *why, size_t why_len)
{
    transfer t = {0};
    t.f = fopen(tmp, "wb");
    if (!t.f) {
        snprintf(why, why_len, "cannot create %s: %s", tmp, strerror(errno));
        return ATTEMPT_FATAL;
    }
    CURL *c = curl_easy_init();
    if (!c) {
        fclose(t.f);
        snprintf(why, why_len, "curl_easy_init failed");
        return ATTEMPT_FATAL;
    }
    char curl_err[CURL_ERROR_SIZE] = "";
    struct curl_slist *headers = NULL;
    curl_easy_setopt(c, CURLOPT_URL, url);
    curl_easy_setopt(c, CURLOPT_ERRORBUFFER, curl_err);
    curl_easy_setopt(c, CURLOPT_WRITEFUNCTION, on_data);
    curl_easy_setopt(c, CURLOPT_WRITEDATA, &t);
    curl_easy_setopt(c, CURLOPT_HEADERFUNCTION, on_header);
    curl_easy_setopt(c, CURLOPT_HEADERDATA, &t);
    curl_easy_setopt(c, CURLOPT_FOLLOWLOCATION, 1L);
    curl_easy_setopt(c, CURLOPT_MAXREDIRS, 5L);
    curl_easy_setopt(c, CURLOPT_NOSIGNAL, 1L); /* thread-safe timeouts */
    curl_easy_setopt(c, CURLOPT_FILETIME, 1L);
    curl_easy_setopt(c, CURLOPT_USERAGENT, "sphice/" SPHICE_VERSION);
    curl_easy_setopt(c, CURLOPT_TIMEOUT_MS, (long)(o->timeout_s * 1000));
    curl_easy_setopt(c, CURLOPT_CONNECTTIMEOUT_MS, (long)(o->connect_timeout_s * 1000));
    curl_easy_setopt(c, CURLOPT_LOW_SPEED_LIMIT, o->low_speed_bytes < 1 ? 1L : o->low_speed_bytes);
    curl_easy_setopt(c, CURLOPT_XFERINFOFUNCTION, on_progress);
    curl_easy_setopt(c, CURLOPT_XFERINFODATA, (void *)o);
    curl_easy_setopt(c, CURLOPT_NOPROGRESS, 0L);
    curl_easy_setopt(c, CURLOPT_LOW_SPEED_TIME,
                     (long)(o->stall_timeout_s < 1 ? 1 : ceil(o->stall_timeout_s)));
    struct stat st;
    if (cached && stat(cached, &st) == 0) {
        curl_easy_setopt(c, CURLOPT_TIMECONDITION, (long)CURL_TIMECOND_IFMODSINCE);
        curl_easy_setopt(c, CURLOPT_TIMEVALUE, (long)st.st_mtime);
        char etag[256], line[300];
        read_etag(etag_path, etag, sizeof etag);
        if (etag[0]) {
            snprintf(line, sizeof line, "If-None-Match: %s", etag);
            headers = curl_slist_append(headers, line);
            curl_easy_setopt(c, CURLOPT_HTTPHEADER, headers);
        }
    }
    res->attempts++;
    int was_cancelled = 0;
    CURLcode cc = perform_cancellable(c, o, &was_cancelled);
    long status = 0, unmet = 0;
    curl_off_t expected = -1;
    curl_easy_getinfo(c, CURLINFO_RESPONSE_CODE, &status);
    curl_easy_getinfo(c, CURLINFO_CONDITION_UNMET, &unmet);
    curl_easy_getinfo(c, CURLINFO_CONTENT_LENGTH_DOWNLOAD_T, &expected);
    curl_easy_getinfo(c, CURLINFO_FILETIME, filetime);
    res->http_status = status;
    int closed_bad = fclose(t.f) != 0;
    curl_easy_cleanup(c);
    curl_slist_free_all(headers);
    snprintf(etag_out, etag_len, "%s", t.etag);
    int is_http = strncmp(url, "http", 4) == 0;

    if (was_cancelled) {
        snprintf(why, why_len, "cancelled after %lld bytes", t.bytes);
        return ATTEMPT_CANCELLED;
    }
    if (cc == CURLE_OK && (status == 304 || unmet)) {
        res->not_modified = 1;
        return ATTEMPT_NOT_MODIFIED;
    }
    if (t.write_error || closed_bad) {
        snprintf(why, why_len, "writing %s: %s", tmp, strerror(t.write_error ? t.write_error : EIO));
        return ATTEMPT_FATAL;
    }
    if (cc == CURLE_HTTP_RETURNED_ERROR || (cc == CURLE_OK && is_http && status >= 400)) {
        int transient = status >= 500 || status == 408 || status == 429;
        snprintf(why, why_len, "HTTP %ld%s", status,
                 status == 404 ? " (not found)" : status >= 500 ? " (server error)" : "");
        return transient ? ATTEMPT_TRANSIENT : ATTEMPT_FATAL;
    }
    switch (cc) {
    case CURLE_OK:
        break;
    case CURLE_OPERATION_TIMEDOUT:
        if (strstr(curl_err, "too slow"))
            snprintf(why, why_len,
                     "timed out: stalled or too slow (under %ld bytes/s for %.0f s) after %lld bytes",
                     o->low_speed_bytes < 1 ? 1L : o->low_speed_bytes,
                     o->stall_timeout_s < 1 ? 1 : ceil(o->stall_timeout_s), t.bytes);
        else
            snprintf(why, why_len, "timed out after %lld bytes (limit %.3g s connect, %.3g s "
                     "total): %s", t.bytes, o->connect_timeout_s, o->timeout_s, curl_err);
        return ATTEMPT_TRANSIENT;
    case CURLE_PARTIAL_FILE:
        snprintf(why, why_len, "truncated transfer: got %lld of %lld bytes", t.bytes,
                 (long long)expected);
        return ATTEMPT_TRANSIENT;
    case CURLE_COULDNT_CONNECT:
    case CURLE_COULDNT_RESOLVE_HOST:
    case CURLE_RECV_ERROR:
    case CURLE_SEND_ERROR:
    case CURLE_GOT_NOTHING:
    case CURLE_SSL_CONNECT_ERROR:
    case CURLE_FTP_ACCEPT_TIMEOUT:
        snprintf(why, why_len, "%s: %s", curl_easy_strerror(cc), curl_err);
        return ATTEMPT_TRANSIENT;
    case CURLE_REMOTE_FILE_NOT_FOUND:
        snprintf(why, why_len, "not found: %s", curl_err);
        return ATTEMPT_FATAL;
    default:
        snprintf(why, why_len, "%s: %s", curl_easy_strerror(cc), curl_err);
        return ATTEMPT_FATAL;
    }
    if (expected >= 0 && t.bytes != (long long)expected) {
        snprintf(why, why_len, "truncated transfer: got %lld of %lld bytes", t.bytes,
                 (long long)expected);
        return ATTEMPT_TRANSIENT;
    }
    return ATTEMPT_OK;
}

/* Sleeps s seconds in slices of at most 50 ms; returns 1 if cancelled. */
static int sleep_s(double s, const fetch_options *o)
{
    double end = time_monotonic() + s;
    for (;;) {
        if (cancelled(o))
            return 1;
        double left = end - time_monotonic();
        if (left <= 0)
            return 0;
        double d = left < 0.05 ? left : 0.05;
        struct timespec ts = {0, (long)(d * 1e9)};
        nanosleep(&ts, NULL);
    }
}

/* A file:// URL or plain path: used in place. */
static int fetch_local(const char *url, const fetch_options *o, char *local_path, size_t len,
                       char sha[65], fetch_result *res, sph_error *err)
{
    const char *path = url;
    char decoded[4096];
    if (strncmp(url, "file://", 7) == 0) {
        path = url + 7;
        if (strncmp(path, "localhost/", 10) == 0)
            path += 9;
        size_t n = 0;
        for (const char *p = path; *p && n < sizeof decoded - 1; p++) {
            int hi, lo;
            if (p[0] == '%' && sscanf(p + 1, "%1x%1x", (unsigned *)&hi, (unsigned *)&lo) == 2) {
                decoded[n++] = (char)(hi * 16 + lo);
                p += 2;
            } else {
                decoded[n++] = *p;
            }
        }
        decoded[n] = '\0';
        path = decoded;
    }
    struct stat st;
    if (stat(path, &st) != 0)
        return sph_err_set(err, SPH_ERR_IO, "fetch %s: %s", url, strerror(errno));
    if (o->check_netcdf) {
        int rc = fetch_check_netcdf(path, url, o->expect_vars, o->n_expect, err);
        if (rc != SPH_OK)
            return rc;
    }
    if ((size_t)snprintf(local_path, len, "%s", path) >= len)
        return sph_err_set(err, SPH_ERR_PARAM, "fetch %s: path longer than %zu", url, len - 1);
    res->bytes = (long long)st.st_size;
    return sha ? sha256_file(path, sha, err) : SPH_OK;
}

int fetch_url_ex(const char *url, const fetch_options *opt, char *local_path, size_t len,
                 char sha256_hex[65], fetch_result *result, sph_error *err)
{
    fetch_options defaults;
    if (!opt) {
        fetch_options_default(&defaults);
        opt = &defaults;
    }
    fetch_result local_res;
    fetch_result *res = result ? result : &local_res;
    memset(res, 0, sizeof *res);
    if (!url || !*url)
        return sph_err_set(err, SPH_ERR_CONFIG, "fetch: empty URL");
    if (!scheme_end(url) || strncmp(url, "file://", 7) == 0)
        return fetch_local(url, opt, local_path, len, sha256_hex, res, err);
    if (strncmp(url, "http://", 7) != 0 && strncmp(url, "https://", 8) != 0 &&
        strncmp(url, "ftp://", 6) != 0)
        return sph_err_set(err, SPH_ERR_CONFIG, "download %s: unsupported scheme", url);

    char final[4096], tmp[4200], etag_path[4200];
    int rc = fetch_cache_path(url, opt->cache_dir, final, sizeof final, err);
    if (rc != SPH_OK)
        return rc;
    if ((size_t)snprintf(local_path, len, "%s", final) >= len)
        return sph_err_set(err, SPH_ERR_PARAM, "download %s: cache path longer than %zu", url, len - 1);
    rc = mkdir_p(opt->cache_dir, err);
    if (rc != SPH_OK)
        return rc;
    /* unique per process and per call, so threads never share a temp file */
    static atomic_long serial;
    snprintf(tmp, sizeof tmp, "%s.part.%ld.%ld", final, (long)getpid(),
             atomic_fetch_add(&serial, 1));
    snprintf(etag_path, sizeof etag_path, "%s.etag", final);
    pthread_once(&curl_once, curl_init_once);

    /* A cached copy that no longer passes the check is not offered for a
     * conditional request (it would be kept forever). */
    int have_cache = access(final, R_OK) == 0 &&
                     (!opt->check_netcdf ||
                      fetch_check_netcdf(final, url, opt->expect_vars, opt->n_expect, NULL) == SPH_OK);

    char why[8192] = "", etag[256] = "";
    long filetime = -1;
    double wait = opt->backoff_s;
    int outcome = ATTEMPT_FATAL;
    for (int attempt = 0; attempt <= (opt->retries > 0 ? opt->retries : 0); attempt++) {
        if (attempt > 0) {
            log_warn("download %s: %s; retry %d of %d in %.3g s", url, why, attempt, opt->retries,
                     wait);
            if (sleep_s(wait, opt)) {
                outcome = ATTEMPT_CANCELLED;
                snprintf(why, sizeof why, "cancelled while waiting to retry");
                break;
            }
            wait *= 2;
        }
        why[0] = '\0';
        outcome = one_attempt(url, opt, tmp, have_cache ? final : NULL, etag_path, res, &filetime,
                              etag, sizeof etag, why, sizeof why);
        if (outcome != ATTEMPT_TRANSIENT)
            break;
    }
    if (outcome == ATTEMPT_NOT_MODIFIED) {
        unlink(tmp);
        struct stat st;
        if (stat(final, &st) == 0)
            res->bytes = (long long)st.st_size;
        log_info("download %s: not modified, using %s", url, final);
        return sha256_hex ? sha256_file(final, sha256_hex, err) : SPH_OK;
    }
    if (outcome == ATTEMPT_CANCELLED) {
        unlink(tmp);
        return sph_err_set(err, SPH_ERR_CANCELLED, "download %s: %s", url, why);
    }
    if (outcome != ATTEMPT_OK) {
        unlink(tmp);
        if (outcome == ATTEMPT_TRANSIENT && res->attempts > 1)
            return sph_err_set(err, SPH_ERR_DOWNLOAD, "download %s: %s (after %d attempts)", url,
                               why, res->attempts);
        return sph_err_set(err, SPH_ERR_DOWNLOAD, "download %s: %s", url, why);
    }
    if (opt->check_netcdf) {
        char label[4200];
        snprintf(label, sizeof label, "download %s", url);
        rc = fetch_check_netcdf(tmp, label, opt->expect_vars, opt->n_expect, err);
        if (rc != SPH_OK) {
            unlink(tmp);
            return rc;
        }
    }
    if (filetime > 0) {
        struct utimbuf ut = {(time_t)filetime, (time_t)filetime};
        utime(tmp, &ut);
    }
    if (fault_point("fetch_before_rename")) {
        unlink(tmp);
        return sph_err_set(err, SPH_ERR_IO, "download %s: fault injected before rename", url);
    }
    rc = atomic_commit(tmp, final, err);
    if (rc != SPH_OK)
        return rc;
    if (etag[0]) {
        char line[300];
        int n = snprintf(line, sizeof line, "%s\n", etag);
        atomic_write_file(etag_path, line, (size_t)n, NULL);
    } else {
        unlink(etag_path);
    }
    res->downloaded = 1;
    struct stat st;
    if (stat(final, &st) == 0)
        res->bytes = (long long)st.st_size;
    log_info("download %s: %lld bytes -> %s", url, res->bytes, final);
    return sha256_hex ? sha256_file(final, sha256_hex, err) : SPH_OK;
}

int fetch_url(const char *url, const fetch_options *opt, char *local_path, size_t len,
              char sha256_hex[65], sph_error *err)
{
    return fetch_url_ex(url, opt, local_path, len, sha256_hex, NULL, err);
}

int fetch_cached_copy(const char *url, const fetch_options *opt, char *local_path, size_t len,
                      char sha256_hex[65], sph_error *err)
{
    fetch_options defaults;
    if (!opt) {
        fetch_options_default(&defaults);
        opt = &defaults;
    }
    char final[4096];
    int rc = fetch_cache_path(url, opt->cache_dir, final, sizeof final, err);
    if (rc != SPH_OK)
        return rc;
    if (access(final, R_OK) != 0)
        return sph_err_set(err, SPH_ERR_IO, "download %s: no cached copy (%s)", url, final);
    if (opt->check_netcdf) {
        char label[4200];
        snprintf(label, sizeof label, "cached copy of %s", url);
        rc = fetch_check_netcdf(final, label, opt->expect_vars, opt->n_expect, err);
        if (rc != SPH_OK)
            return rc;
    }
    if ((size_t)snprintf(local_path, len, "%s", final) >= len)
        return sph_err_set(err, SPH_ERR_PARAM, "download %s: cache path longer than %zu", url, len - 1);
    return sha256_hex ? sha256_file(final, sha256_hex, err) : SPH_OK;
}

int fetch_sweep_parts(const char *cache_dir)
{
    if (!cache_dir || !*cache_dir)
        return 0;
    DIR *d = opendir(cache_dir);
    if (!d)
        return 0;
    int removed = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        /* "<name>.part.<pid>.<serial>": the last ".part." of the name */
        const char *p = NULL;
        for (const char *q = strstr(e->d_name, ".part."); q; q = strstr(q + 1, ".part."))
            p = q;
        if (!p)
            continue;
        char *end;
        errno = 0;
        long pid = strtol(p + 6, &end, 10);
        if (errno || pid <= 0 || end == p + 6 || *end != '.')
            continue;
        if (kill((pid_t)pid, 0) == 0 || errno != ESRCH)
            continue; /* that process still runs (or is not ours to judge) */
        char path[4400];
        if ((size_t)snprintf(path, sizeof path, "%s/%s", cache_dir, e->d_name) >= sizeof path)
            continue;
        if (unlink(path) == 0) {
            removed++;
            log_info("cache %s: removed %s, left by process %ld that is gone", cache_dir, e->d_name,
                     pid);
        }
    }
    closedir(d);
    return removed;
}

/* ------------------------------------------------- GET into memory */

typedef struct membuf {
    char *p;
    size_t n, max;
} membuf;

static size_t on_memory(void *data, size_t size, size_t nmemb, void *user)
{
    membuf *b = user;
    size_t add = size * nmemb;
    if (b->n + add > b->max)
        return 0;
    char *g = realloc(b->p, b->n + add + 1);
    if (!g)
        return 0;
    memcpy(g + b->n, data, add);
    b->p = g;
    b->n += add;
    b->p[b->n] = 0;
    return add;
}

int fetch_http_get(const char *url, double timeout_s, size_t max_bytes, char **body, size_t *len,
                   long *http_status, sph_error *err)
{
    *body = NULL;
    if (len)
        *len = 0;
    *http_status = 0;
    pthread_once(&curl_once, curl_init_once);
    CURL *c = curl_easy_init();
    membuf b = {NULL, 0, max_bytes};
    char errbuf[CURL_ERROR_SIZE] = "";
    CURLcode rc = CURLE_FAILED_INIT;
    if (c) {
        curl_easy_setopt(c, CURLOPT_URL, url);
        curl_easy_setopt(c, CURLOPT_WRITEFUNCTION, on_memory);
        curl_easy_setopt(c, CURLOPT_WRITEDATA, &b);
        curl_easy_setopt(c, CURLOPT_TIMEOUT_MS, (long)(timeout_s * 1000));
        curl_easy_setopt(c, CURLOPT_ERRORBUFFER, errbuf);
        curl_easy_setopt(c, CURLOPT_NOSIGNAL, 1L);
        rc = curl_easy_perform(c);
        curl_easy_getinfo(c, CURLINFO_RESPONSE_CODE, http_status);
        curl_easy_cleanup(c);
    }
    if (rc != CURLE_OK) {
        free(b.p);
        return sph_err_set(err, SPH_ERR_DOWNLOAD, "%s: %s", url, errbuf[0] ? errbuf : curl_easy_strerror(rc));
    }
    *body = b.p ? b.p : calloc(1, 1);
    if (!*body)
        return sph_err_set(err, SPH_ERR_NOMEM, "%s: out of memory", url);
    if (len)
        *len = b.n;
    return SPH_OK;
}
