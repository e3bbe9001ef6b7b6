/* Downloads of forcing and initial-state files (libcurl).
 *
 * A source is a URL, expanded for a cycle by the caller (the configuration's
 * strftime template fields, %Y %m %d %H %M %j), fetched into a cache
 * directory (fetch_url) and checked to be valid NetCDF with the expected
 * variables before it gets its final name. The cache is never left with a
 * partial file: bytes go to "<name>.part.<pid>.<serial>", which is renamed
 * only after the check, and removed on any failure.
 *
 * URL schemes: http://, https://, ftp:// (libcurl); file://PATH and a plain
 * path (no scheme) are used in place, not copied, and checked the same way.
 *
 * Cache: one file per URL, named "<first 16 hex of sha256(url)>-<basename>"
 * in cache_dir, plus "<name>.etag" when the server sent an ETag. The
 * cached file's mtime is set to the server's Last-Modified. A later fetch
 * of the same URL sends If-Modified-Since (that mtime) and If-None-Match
 * (the ETag); a 304 returns the cached path without downloading.
 *
 * Retries: transient failures (HTTP 408, 429, 5xx; connection refused or
 * reset; timeouts; truncated transfers) are retried `retries` times,
 * waiting backoff_s, 2 backoff_s, 4 backoff_s, ...; other failures (404,
 * 403, not NetCDF, missing variable) are not.
 *
 * Timeouts: connect_timeout_s for the connection, timeout_s for the whole
 * transfer, and a low-speed limit: less than low_speed_bytes per second for
 * stall_timeout_s (CURLOPT_LOW_SPEED_LIMIT/TIME) aborts a server that stops
 * sending or trickles.
 *
 * Cancellation: when *cancel becomes non-zero the transfer is aborted
 * within about 0.1 s (the transfer loop polls in 100 ms slices and the
 * libcurl xferinfo callback checks the flag), and so is a backoff sleep
 * between retries; the call then fails with SPH_ERR_CANCELLED and leaves
 * the cache as it was.
 *
 * A download that fails its check (not NetCDF, truncated, a variable of
 * expect_vars missing) never replaces the cached copy or its .etag.
 * Interrupted processes can leave "<name>.part.<pid>.<serial>" files
 * (kill -9): fetch_sweep_parts removes those of processes that are gone.
 */
#ifndef SPHICE_IO_FETCH_H
#define SPHICE_IO_FETCH_H

#include <signal.h>
#include <stddef.h>
#include "util/err.h"

typedef struct fetch_options {
    double timeout_s;         /* whole transfer (default 600) */
    double connect_timeout_s; /* default 30 */
    double stall_timeout_s;   /* abort below low_speed_bytes/s for this long (default 60; >= 1) */
    long low_speed_bytes;     /* bytes/s of the low-speed limit (default 1024; >= 1) */
    const volatile sig_atomic_t *cancel; /* non-zero: abort (NULL: never) */
    int retries;              /* extra attempts on transient failures (default 3) */
    double backoff_s;         /* first wait between attempts, doubled each time (default 5) */
    const char *cache_dir;    /* required for remote URLs; created if missing */
    const char *const *expect_vars; /* variables the file must have */
    size_t n_expect;
    int check_netcdf;         /* 1 (default): the file must be NetCDF; 0: any bytes */
} fetch_options;

void fetch_options_default(fetch_options *o);

/* Statistics of the last fetch_url_ex call. */
typedef struct fetch_result {
    int attempts;       /* network attempts made (0 for local files) */
    long http_status;   /* last HTTP/FTP response code, 0 if none */
    int not_modified;   /* 1 if the server answered 304 / condition unmet */
    int downloaded;     /* 1 if new bytes were stored in the cache */
    long long bytes;    /* size of the file returned */
} fetch_result;

/* Fetches `url` (see above) and returns the local path and its SHA-256.
 * sha256_hex may be NULL. */
int fetch_url(const char *url, const fetch_options *opt, char *local_path, size_t len,
              char sha256_hex[65], sph_error *err);
int fetch_url_ex(const char *url, const fetch_options *opt, char *local_path, size_t len,
                 char sha256_hex[65], fetch_result *result, sph_error *err);

/* The cached copy of `url` (fetch_cache_path in opt->cache_dir) without
 * any network access, if it is there and passes the same check as a new
 * download (opt->check_netcdf, opt->expect_vars); else an error naming
 * the URL. For a cycle that may run on the last good download when the
 * server fails. */
int fetch_cached_copy(const char *url, const fetch_options *opt, char *local_path, size_t len,
                      char sha256_hex[65], sph_error *err);

/* Removes "*.part.<pid>.*" files in cache_dir left by processes that no
 * longer run (kill -9 during a download). Parts of live processes stay.
 * Returns the number removed (0 if cache_dir does not exist). */
int fetch_sweep_parts(const char *cache_dir);

/* The cache file name fetch_url uses for `url` (no I/O). */
int fetch_cache_path(const char *url, const char *cache_dir, char *path, size_t len,
                     sph_error *err);

/* Checks that `path` is a complete NetCDF file holding every variable in
 * vars: nc_open succeeds and, for the classic formats (CDF-1/2/5, where
 * netcdf-c reads missing bytes past the end as fill values), the file is
 * at least as long as its header says. `label` (a URL, or NULL for the
 * path) names the file in messages. */
int fetch_check_netcdf(const char *path, const char *label, const char *const *vars,
                       size_t nvars, sph_error *err);

/* GET url into memory (a status page, a small JSON answer): *body, which
 * the caller frees, holds the answer NUL-terminated, *len (may be NULL)
 * its length, *http_status the response code whatever it is. At most
 * max_bytes are kept and timeout_s bounds the whole transfer. A transfer
 * that fails (no server, timeout, more than max_bytes) is SPH_ERR_DOWNLOAD
 * with "url: what went wrong"; *body is then NULL. */
int fetch_http_get(const char *url, double timeout_s, size_t max_bytes, char **body, size_t *len,
                   long *http_status, sph_error *err);

#endif
