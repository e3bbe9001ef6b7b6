/* Run history in SQLite (service/history.h). Several processes (the daemon,
 * a `sphice run` from a timer) may share the file: WAL mode plus a busy
 * timeout serialise writers; the UNIQUE cycle column makes every write an
 * upsert, so no cycle ever has two rows. */
#include "service/history.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <pthread.h>
#include <sqlite3.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "util/jsonutil.h"
#include "util/timeutil.h"

struct history {
    sqlite3 *db;
    pthread_mutex_t lock;
    char path[1024];
};

static const char *schema =
    "CREATE TABLE IF NOT EXISTS runs ("
    " cycle REAL NOT NULL UNIQUE, started REAL, ended REAL, result TEXT NOT NULL,"
    " message TEXT, area REAL, volume REAL, edge_nm REAL, scores TEXT, products TEXT,"
    " stale INTEGER NOT NULL DEFAULT 0, mode TEXT);";

int history_open(history **out, const char *path, sph_error *err)
{
    *out = NULL;
    history *h = calloc(1, sizeof *h);
    if (!h)
        return sph_err_set(err, SPH_ERR_NOMEM, "history %s: out of memory", path);
    snprintf(h->path, sizeof h->path, "%s", path);
    pthread_mutex_init(&h->lock, NULL);
    int rc = sqlite3_open_v2(path, &h->db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX,
                             NULL);
    if (rc != SQLITE_OK) {
        sph_err_set(err, SPH_ERR_IO, "history %s: open: %s", path, h->db ? sqlite3_errmsg(h->db) : "out of memory");
        history_close(h);
        return SPH_ERR_IO;
    }
    sqlite3_busy_timeout(h->db, 10000);
    char *msg = NULL;
    rc = sqlite3_exec(h->db, "PRAGMA journal_mode=WAL;", NULL, NULL, NULL);
    if (rc == SQLITE_OK)
        rc = sqlite3_exec(h->db, schema, NULL, NULL, &msg);
    if (rc != SQLITE_OK) {
        sph_err_set(err, SPH_ERR_IO, "history %s: create table: %s", path, msg ? msg : sqlite3_errmsg(h->db));
        sqlite3_free(msg);
        history_close(h);
        return SPH_ERR_IO;
    }
    *out = h;
    return SPH_OK;
}

void history_close(history *h)
{
    if (!h)
        return;
    if (h->db)
        sqlite3_close(h->db);
    pthread_mutex_destroy(&h->lock);
    free(h);
}

int history_mark_interrupted(history *h, sph_error *err)
{
    pthread_mutex_lock(&h->lock);
    int rc = sqlite3_exec(h->db,
                          "UPDATE runs SET result='interrupted', message='process ended during the run'"
                          " WHERE result='running';",
                          NULL, NULL, NULL);
    int n = rc == SQLITE_OK ? sqlite3_changes(h->db) : -1;
    if (rc != SQLITE_OK)
        sph_err_set(err, SPH_ERR_IO, "history %s: %s", h->path, sqlite3_errmsg(h->db));
    pthread_mutex_unlock(&h->lock);
    return n;
}

static void bind_num(sqlite3_stmt *s, int i, double v)
{
    if (isfinite(v))
        sqlite3_bind_double(s, i, v);
    else
        sqlite3_bind_null(s, i);
}

int history_put(history *h, const history_run *r, sph_error *err)
{
    static const char *sql =
        "INSERT INTO runs(cycle, started, ended, result, message, area, volume, edge_nm, scores, products,"
        " stale, mode) VALUES(?1,?2,?3,?4,?5,?6,?7,?8,?9,?10,?11,?12)"
        " ON CONFLICT(cycle) DO UPDATE SET started=?2, ended=?3, result=?4, message=?5, area=?6,"
        " volume=?7, edge_nm=?8, scores=?9, products=?10, stale=?11, mode=?12;";
    pthread_mutex_lock(&h->lock);
    sqlite3_stmt *s = NULL;
    int rc = sqlite3_prepare_v2(h->db, sql, -1, &s, NULL);
    if (rc == SQLITE_OK) {
        sqlite3_bind_double(s, 1, r->cycle);
        bind_num(s, 2, r->started);
        bind_num(s, 3, r->ended);
        sqlite3_bind_text(s, 4, r->result, -1, SQLITE_TRANSIENT);
        sqlite3_bind_text(s, 5, r->message, -1, SQLITE_TRANSIENT);
        bind_num(s, 6, r->area_km2);
        bind_num(s, 7, r->volume_km3);
        bind_num(s, 8, r->edge_nm);
        if (r->scores_json) sqlite3_bind_text(s, 9, r->scores_json, -1, SQLITE_TRANSIENT);
        else sqlite3_bind_null(s, 9);
        if (r->products_json) sqlite3_bind_text(s, 10, r->products_json, -1, SQLITE_TRANSIENT);
        else sqlite3_bind_null(s, 10);
        sqlite3_bind_int(s, 11, r->stale);
        sqlite3_bind_text(s, 12, r->mode, -1, SQLITE_TRANSIENT);
        rc = sqlite3_step(s);
    }
    int ok = rc == SQLITE_DONE;
    if (!ok)
        sph_err_set(err, SPH_ERR_IO, "history %s: write: %s", h->path, sqlite3_errmsg(h->db));
    sqlite3_finalize(s);
    pthread_mutex_unlock(&h->lock);
    return ok ? SPH_OK : SPH_ERR_IO;
}

static double col_num(sqlite3_stmt *s, int i)
{
    return sqlite3_column_type(s, i) == SQLITE_NULL ? NAN : sqlite3_column_double(s, i);
}

static char *col_dup(sqlite3_stmt *s, int i)
{
    const unsigned char *t = sqlite3_column_text(s, i);
    return t ? strdup((const char *)t) : NULL;
}

static void col_copy(sqlite3_stmt *s, int i, char *dst, size_t len)
{
    const unsigned char *t = sqlite3_column_text(s, i);
    snprintf(dst, len, "%s", t ? (const char *)t : "");
}

#define COLS "cycle, started, ended, result, message, area, volume, edge_nm, scores, products, stale, mode"

static void row_read(sqlite3_stmt *s, history_run *r)
{
    memset(r, 0, sizeof *r);
    r->cycle = sqlite3_column_double(s, 0);
    r->started = col_num(s, 1);
    r->ended = col_num(s, 2);
    col_copy(s, 3, r->result, sizeof r->result);
    col_copy(s, 4, r->message, sizeof r->message);
    r->area_km2 = col_num(s, 5);
    r->volume_km3 = col_num(s, 6);
    r->edge_nm = col_num(s, 7);
    r->scores_json = col_dup(s, 8);
    r->products_json = col_dup(s, 9);
    r->stale = sqlite3_column_int(s, 10);
    col_copy(s, 11, r->mode, sizeof r->mode);
}

void history_run_clear(history_run *r)
{
    free(r->scores_json);
    free(r->products_json);
    r->scores_json = r->products_json = NULL;
}

int history_get(history *h, double cycle, history_run *r, sph_error *err)
{
    pthread_mutex_lock(&h->lock);
    sqlite3_stmt *s = NULL;
    int found = -1;
    if (sqlite3_prepare_v2(h->db, "SELECT " COLS " FROM runs WHERE cycle = ?1;", -1, &s, NULL) == SQLITE_OK) {
        sqlite3_bind_double(s, 1, cycle);
        int rc = sqlite3_step(s);
        if (rc == SQLITE_ROW) {
            row_read(s, r);
            found = 1;
        } else if (rc == SQLITE_DONE) {
            found = 0;
        }
    }
    if (found < 0)
        sph_err_set(err, SPH_ERR_IO, "history %s: read: %s", h->path, sqlite3_errmsg(h->db));
    sqlite3_finalize(s);
    pthread_mutex_unlock(&h->lock);
    return found;
}

double history_last_done(history *h)
{
    double t = NAN;
    pthread_mutex_lock(&h->lock);
    sqlite3_stmt *s = NULL;
    if (sqlite3_prepare_v2(h->db, "SELECT max(cycle) FROM runs WHERE result IN ('ok','failed');", -1, &s,
                           NULL) == SQLITE_OK &&
        sqlite3_step(s) == SQLITE_ROW)
        t = col_num(s, 0);
    sqlite3_finalize(s);
    pthread_mutex_unlock(&h->lock);
    return t;
}

int history_latest(history *h, history_run *r)
{
    int found = 0;
    pthread_mutex_lock(&h->lock);
    sqlite3_stmt *s = NULL;
    if (sqlite3_prepare_v2(h->db, "SELECT " COLS " FROM runs ORDER BY started DESC, cycle DESC LIMIT 1;", -1,
                           &s, NULL) == SQLITE_OK &&
        sqlite3_step(s) == SQLITE_ROW) {
        row_read(s, r);
        found = 1;
    }
    sqlite3_finalize(s);
    pthread_mutex_unlock(&h->lock);
    return found;
}

static void add_raw(cJSON *o, const char *k, const char *json)
{
    cJSON *v = json ? cJSON_Parse(json) : NULL;
    cJSON_AddItemToObject(o, k, v ? v : cJSON_CreateNull());
}

static cJSON *row_json(const history_run *r)
{
    cJSON *o = cJSON_CreateObject();
    json_add_time(o, "cycle", r->cycle);
    json_add_time(o, "started", r->started);
    json_add_time(o, "ended", r->ended);
    json_add_num(o, "duration_s", isfinite(r->ended) && isfinite(r->started) ? r->ended - r->started : NAN);
    cJSON_AddStringToObject(o, "result", r->result);
    cJSON_AddStringToObject(o, "message", r->message);
    json_add_num(o, "ice_area_km2", r->area_km2);
    json_add_num(o, "ice_volume_km3", r->volume_km3);
    json_add_num(o, "edge_distance_nm", r->edge_nm);
    add_raw(o, "scores", r->scores_json);
    add_raw(o, "products", r->products_json);
    cJSON_AddBoolToObject(o, "stale", r->stale);
    cJSON_AddStringToObject(o, "start_mode", r->mode);
    return o;
}

char *history_last_finished_json(history *h, history_run *out)
{
    char *text = NULL;
    pthread_mutex_lock(&h->lock);
    sqlite3_stmt *s = NULL;
    if (sqlite3_prepare_v2(h->db, "SELECT " COLS " FROM runs WHERE result != 'running'"
                           " ORDER BY ended DESC, cycle DESC LIMIT 1;", -1, &s, NULL) == SQLITE_OK &&
        sqlite3_step(s) == SQLITE_ROW) {
        history_run r;
        row_read(s, &r);
        cJSON *o = row_json(&r);
        text = cJSON_Print(o);
        cJSON_Delete(o);
        if (out)
            *out = r;
        else
            history_run_clear(&r);
    }
    sqlite3_finalize(s);
    pthread_mutex_unlock(&h->lock);
    return text;
}

char *history_recent_json(history *h, int n)
{
    cJSON *a = cJSON_CreateArray();
    pthread_mutex_lock(&h->lock);
    sqlite3_stmt *s = NULL;
    if (sqlite3_prepare_v2(h->db, "SELECT " COLS " FROM runs ORDER BY cycle DESC LIMIT ?1;", -1, &s, NULL) ==
        SQLITE_OK) {
        sqlite3_bind_int(s, 1, n);
        while (sqlite3_step(s) == SQLITE_ROW) {
            history_run r;
            row_read(s, &r);
            cJSON *o = row_json(&r);
            cJSON_AddItemToArray(a, o);
            history_run_clear(&r);
        }
    }
    sqlite3_finalize(s);
    pthread_mutex_unlock(&h->lock);
    char *text = cJSON_Print(a);
    cJSON_Delete(a);
    return text;
}

long history_count(history *h, const char *result)
{
    long n = 0;
    pthread_mutex_lock(&h->lock);
    sqlite3_stmt *s = NULL;
    if (sqlite3_prepare_v2(h->db, "SELECT count(*) FROM runs WHERE result = ?1;", -1, &s, NULL) == SQLITE_OK) {
        sqlite3_bind_text(s, 1, result, -1, SQLITE_TRANSIENT);
        if (sqlite3_step(s) == SQLITE_ROW)
            n = sqlite3_column_int64(s, 0);
    }
    sqlite3_finalize(s);
    pthread_mutex_unlock(&h->lock);
    return n;
}
