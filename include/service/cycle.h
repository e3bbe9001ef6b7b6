/* One forecast cycle, one state machine:
 *
 *   lock -> fetch forcing (waiting for late data) -> choose the start
 *   (warm / cold / reinit) -> run the engine into a private stage dir ->
 *   write the manifest -> publish (rename the stage dir to
 *   OUTDIR/<YYYYMMDDTHHZ>/, then switch OUTDIR/latest) -> record history.
 *
 * Invariant: published products are only ever replaced by a rename of a
 * complete directory; a failed, cancelled or killed cycle leaves them as
 * they were (its stage dir is removed, or swept by the next run).
 *
 * The engine and the fetcher are function pointers so the scheduler can
 * be tested without the model or the network. */
#ifndef SPHICE_SERVICE_CYCLE_H
#define SPHICE_SERVICE_CYCLE_H

#include <signal.h>
#include <stddef.h>
#include "service/cycle_name.h"
#include "service/forecast.h"
#include "service/history.h"
#include "util/err.h"
#include "util/limits.h"

struct sph_config;

/* Old names of the limits in util/limits.h. */
#define CYCLE_MAX_SOURCES SPHICE_MAX_SOURCES
#define CYCLE_MAX_FILES SPHICE_MAX_FILES

typedef int (*cycle_engine_fn)(const struct sph_config *cfg, const forecast_request *req,
                               forecast_progress *prog, const volatile sig_atomic_t *cancel,
                               forecast_result *res, sph_error *err);
/* NULL restores forecast_run. The test double is chosen instead when the
 * config says engine "test-double" or SPHICE_TEST_ENGINE is set:
 *   SPHICE_TEST_ENGINE=sleep:SECONDS   run that long, write a small product
 *   SPHICE_TEST_ENGINE=fail            fail with a message */
void cycle_set_engine(cycle_engine_fn fn);
/* The stand-in engine itself (exported for tests). */
int cycle_test_engine(const struct sph_config *cfg, const forecast_request *req, forecast_progress *prog,
                      const volatile sig_atomic_t *cancel, forecast_result *res, sph_error *err);

/* Makes one forcing template for cycle time t a local file: expands the
 * template, downloads it when it is a URL, and returns the local path and
 * its sha256. Returns SPH_OK, or an error (SPH_ERR_IO / SPH_ERR_DOWNLOAD)
 * when the file is not (yet) there. */
typedef struct cycle_fetch_ctx {
    const struct sph_config *cfg;        /* fetch.* keys, paths.cache_dir */
    const char *const *expect_vars;      /* variables a download must hold (the source's
                                            mapped `variables`); a file without them never
                                            replaces the cached copy */
    size_t n_expect;
    const volatile sig_atomic_t *cancel; /* aborts a download within about 0.1 s */
    int cache_only;                      /* 1: no network, the last good cached copy only */
} cycle_fetch_ctx;
typedef int (*cycle_fetch_fn)(const char *tmpl, double t, const cycle_fetch_ctx *ctx, char *local,
                              size_t len, char sha256[65], sph_error *err);
/* NULL restores the built-in fetcher (local paths, file://, and
 * http(s)/ftp downloads through io/fetch.h into paths.cache_dir). */
void cycle_set_fetcher(cycle_fetch_fn fn);

enum { CYCLE_OK = 0, CYCLE_FAILED, CYCLE_CANCELLED, CYCLE_SKIPPED };

typedef struct cycle_opts {
    double cycle_time;
    double hours;          /* 0: schedule.forecast_hours */
    const char *out_dir;   /* NULL: output.dir */
    int hindcast;          /* replay: no wait for late data, no global run lock */
    int force;             /* run even when the history says the cycle is done */
    history *hist;         /* may be NULL */
} cycle_opts;

typedef struct cycle_report {
    int result;            /* CYCLE_* */
    int skipped_failed;    /* CYCLE_SKIPPED because the history says the cycle failed */
    double cycle, started, ended;
    int stale;
    char mode[16];         /* cold, warm, reinit */
    char message[1024];    /* the error, or a summary */
    char product_dir[4096];
    size_t nsources;
    char source_name[SPHICE_MAX_SOURCES][SPHICE_MAX_NAME + 1];
    double source_age_h[CYCLE_MAX_SOURCES]; /* cycle time - issue time used; NaN if none */
    forecast_result res;
} cycle_report;

/* Runs one cycle. Returns SPH_OK when the cycle was published or skipped
 * (rep->result says which; a skipped cycle that failed before sets
 * rep->skipped_failed), otherwise the error (rep and err say why).
 * prog may be NULL; cancel may be NULL. */
int cycle_run(const struct sph_config *cfg, const cycle_opts *o, forecast_progress *prog,
              const volatile sig_atomic_t *cancel, cycle_report *rep, sph_error *err);

/* rm -rf (for stage dirs); 0 on success. */
int cycle_remove_tree(const char *path);

#endif
