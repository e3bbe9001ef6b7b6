/* Run history: one SQLite table, one row per cycle (UNIQUE), upserted.
 *
 *   runs(cycle UNIQUE, started, ended, result, message, area, volume,
 *        edge_nm, scores json, products json, stale, mode)
 *
 * Times are seconds since 1970 UTC. result is one of "running", "ok",
 * "failed", "cancelled", "interrupted". A process killed mid-run leaves a
 * "running" row; the next start marks it "interrupted" and the scheduler
 * runs that cycle again (the same row is updated: never a duplicate).
 * Thread-safe: one connection behind a mutex. */
#ifndef SPHICE_SERVICE_HISTORY_H
#define SPHICE_SERVICE_HISTORY_H

#include "util/err.h"

typedef struct history history;

typedef struct history_run {
    double cycle, started, ended;   /* ended NaN while running */
    char result[16];
    char message[1024];
    double area_km2, volume_km3, edge_nm; /* NaN when unknown */
    char *scores_json;   /* malloc'd or NULL */
    char *products_json; /* malloc'd or NULL */
    int stale;
    char mode[16];       /* "cold", "warm", "reinit" */
} history_run;

int history_open(history **out, const char *path, sph_error *err);
void history_close(history *h);

/* Rows left "running" by a dead process become "interrupted"; returns how many. */
int history_mark_interrupted(history *h, sph_error *err);
/* Upserts the row of r->cycle with every field of r. */
int history_put(history *h, const history_run *r, sph_error *err);
/* 1 found, 0 not found, <0 error. Caller frees with history_run_clear. */
int history_get(history *h, double cycle, history_run *r, sph_error *err);
void history_run_clear(history_run *r);
/* The newest cycle whose result is final (ok or failed); NaN if none. */
double history_last_done(history *h);
/* The newest row of any result; 1 found, 0 none. */
int history_latest(history *h, history_run *r);
/* The most recent n rows as a JSON array text (caller frees), newest first. */
char *history_recent_json(history *h, int n);
/* The newest finished row (any result but "running") as a JSON object
 * text (caller frees), or NULL if none. */
char *history_last_finished_json(history *h, history_run *r);
/* Number of rows with the given result. */
long history_count(history *h, const char *result);

#endif
