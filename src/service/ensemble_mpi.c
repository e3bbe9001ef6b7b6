/* Ensemble members over MPI ranks (make MPI=1; docs/ensemble.md).
 *
 * Every rank parses the same command line and configuration. Rank 0 runs
 * the cycle (fetching, the control, the reduction, publishing); member m
 * runs on rank m % size. Rank 0 sends a member's job -- the cycle's
 * request as JSON: times, the member's stage directory, the local forcing
 * files -- and the worker answers with its result once the member's
 * products are in that directory (a file system all ranks share). A
 * member's perturbations depend on (seed, member) alone, so the ensemble
 * is the same bit for bit on any number of ranks. Without MPI the size is
 * 1 and everything here is a no-op. */
#include "service/ensemble.h"

#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "service/config.h"
#include "util/log.h"

#ifdef SPHICE_MPI
#include <mpi.h>

enum { TAG_JOB = 1, TAG_STOP = 2, TAG_DONE = 3 };
static int mpi_on;

int ens_mpi_init(int *argc, char ***argv)
{
    if (MPI_Init(argc, argv) != MPI_SUCCESS)
        return -1;
    mpi_on = 1;
    return 0;
}

int ens_mpi_rank(void)
{
    int r = 0;
    if (mpi_on)
        MPI_Comm_rank(MPI_COMM_WORLD, &r);
    return r;
}

int ens_mpi_size(void)
{
    int s = 1;
    if (mpi_on)
        MPI_Comm_size(MPI_COMM_WORLD, &s);
    return s;
}

void ens_mpi_finalize(void)
{
    if (mpi_on)
        MPI_Finalize();
    mpi_on = 0;
}

static char *job_json(const forecast_request *req, int member, const char *stage)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddNumberToObject(j, "member", member);
    cJSON_AddNumberToObject(j, "cycle_time", req->cycle_time);
    cJSON_AddNumberToObject(j, "hours", req->hours);
    cJSON_AddStringToObject(j, "stage", stage);
    if (req->warm_start)
        cJSON_AddStringToObject(j, "warm_start", req->warm_start);
    cJSON_AddBoolToObject(j, "stale", req->stale);
    cJSON *src = cJSON_AddArrayToObject(j, "forcing");
    for (int s = 0; s < SPHICE_MAX_SOURCES; s++) {
        cJSON *a = cJSON_CreateArray();
        for (int k = 0; req->forcing_files[s] && req->forcing_files[s][k]; k++)
            cJSON_AddItemToArray(a, cJSON_CreateString(req->forcing_files[s][k]));
        cJSON_AddItemToArray(src, a);
    }
    cJSON *sha = cJSON_AddArrayToObject(j, "sha256");
    for (int k = 0; k < SPHICE_MAX_PROVENANCE && req->forcing_sha256[k]; k++)
        cJSON_AddItemToArray(sha, cJSON_CreateString(req->forcing_sha256[k]));
    char *t = cJSON_PrintUnformatted(j);
    cJSON_Delete(j);
    return t;
}

/* The worker's side of one job: the request rebuilt from the JSON, the
 * member run, the answer. */
static void serve_job(const struct sph_config *cfg, const char *text, const volatile sig_atomic_t *cancel)
{
    cJSON *j = cJSON_Parse(text);
    int member = -1, rc = SPH_ERR_INTERNAL;
    sph_error err;
    sph_error_clear(&err);
    forecast_result *res = calloc(1, sizeof *res);
    const char *files[SPHICE_MAX_SOURCES][SPHICE_MAX_FILES + 1];
    memset(files, 0, sizeof files);
    forecast_request req;
    memset(&req, 0, sizeof req);
    const cJSON *m = j ? cJSON_GetObjectItemCaseSensitive(j, "member") : NULL;
    if (!j || !cJSON_IsNumber(m) || !res) {
        sph_err_set(&err, SPH_ERR_INTERNAL, "ensemble worker %d: bad job", ens_mpi_rank());
    } else {
        member = m->valueint;
        req.cycle_time = cJSON_GetObjectItemCaseSensitive(j, "cycle_time")->valuedouble;
        req.hours = cJSON_GetObjectItemCaseSensitive(j, "hours")->valuedouble;
        req.stage_dir = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(j, "stage"));
        req.warm_start = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(j, "warm_start"));
        req.stale = cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(j, "stale"));
        const cJSON *src = cJSON_GetObjectItemCaseSensitive(j, "forcing"), *a;
        int s = 0;
        cJSON_ArrayForEach(a, src)
        {
            if (s >= SPHICE_MAX_SOURCES)
                break;
            int k = 0;
            const cJSON *f;
            cJSON_ArrayForEach(f, a) if (k < SPHICE_MAX_FILES) files[s][k++] = cJSON_GetStringValue(f);
            req.forcing_files[s] = cJSON_GetArraySize(a) ? files[s] : NULL;
            s++;
        }
        int k = 0;
        const cJSON *h;
        cJSON_ArrayForEach(h, cJSON_GetObjectItemCaseSensitive(j, "sha256")) if (k < SPHICE_MAX_PROVENANCE)
            req.forcing_sha256[k++] = cJSON_GetStringValue(h);
        fc_member mem;
        if (!(rc = fc_member_init(&mem, cfg, member, &err))) {
            req.member = member ? &mem : NULL;
            struct sph_config lite;
            rc = forecast_run(fc_member_config(cfg, &lite), &req, NULL, cancel, res, &err);
            fc_member_free(&mem);
        }
    }
    cJSON *out = cJSON_CreateObject();
    cJSON_AddNumberToObject(out, "member", member);
    cJSON_AddNumberToObject(out, "rc", rc);
    cJSON_AddStringToObject(out, "message", err.msg);
    cJSON_AddNumberToObject(out, "wall_seconds", res ? res->wall_seconds : 0.0);
    char *t = cJSON_PrintUnformatted(out);
    cJSON_Delete(out);
    cJSON_Delete(j);
    free(res);
    MPI_Send(t ? t : "{}", t ? (int)strlen(t) + 1 : 3, MPI_CHAR, 0, TAG_DONE, MPI_COMM_WORLD);
    free(t);
}

int ens_mpi_worker(const struct sph_config *cfg, const volatile sig_atomic_t *cancel)
{
    for (;;) {
        MPI_Status st;
        MPI_Probe(0, MPI_ANY_TAG, MPI_COMM_WORLD, &st);
        int n = 0;
        MPI_Get_count(&st, MPI_CHAR, &n);
        char *buf = malloc(n > 0 ? (size_t)n : 1);
        if (!buf)
            return 1;
        MPI_Recv(buf, n, MPI_CHAR, 0, st.MPI_TAG, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        if (st.MPI_TAG == TAG_STOP) {
            free(buf);
            return 0;
        }
        serve_job(cfg, buf, cancel);
        free(buf);
    }
}

void ens_mpi_stop_workers(void)
{
    for (int r = 1; r < ens_mpi_size(); r++)
        MPI_Send("", 1, MPI_CHAR, r, TAG_STOP, MPI_COMM_WORLD);
}

static int send_job(const forecast_request *req, int member, int rank, const char *stage, void **handle,
                    sph_error *err)
{
    char *t = job_json(req, member, stage);
    MPI_Request *r = malloc(sizeof *r);
    if (!t || !r) {
        free(t);
        free(r);
        return sph_err_set(err, SPH_ERR_NOMEM, "ensemble: out of memory");
    }
    MPI_Isend(t, (int)strlen(t) + 1, MPI_CHAR, rank, TAG_JOB, MPI_COMM_WORLD, r);
    /* the text must live until the send completes: ens_mpi_collect frees both */
    void **h = malloc(2 * sizeof *h);
    if (!h) {
        MPI_Wait(r, MPI_STATUS_IGNORE);
        free(t);
        free(r);
        return sph_err_set(err, SPH_ERR_NOMEM, "ensemble: out of memory");
    }
    h[0] = r;
    h[1] = t;
    *handle = h;
    return SPH_OK;
}

int ens_mpi_dispatch(const forecast_request *req, int member, const char *stage, void **handle, sph_error *err)
{
    return send_job(req, member, member % ens_mpi_size(), stage, handle, err);
}

/* parallel.decomposition "domain": the control's job to every worker rank,
 * whose forecast_run then joins rank 0's decomposed run (forecast_domain.c). */
int ens_mpi_dispatch_rank(const forecast_request *req, int rank, const char *stage, void **handle, sph_error *err)
{
    return send_job(req, 0, rank, stage, handle, err);
}

int ens_mpi_collect(void **handles, int n, double *wall, sph_error *err)
{
    int rc = SPH_OK;
    for (int i = 0; i < n; i++) {
        void **h = handles[i];
        if (!h)
            continue;
        MPI_Wait(h[0], MPI_STATUS_IGNORE);
        free(h[0]);
        free(h[1]);
        free(h);
        handles[i] = NULL;
    }
    for (int i = 0; i < n; i++) {
        MPI_Status st;
        MPI_Probe(MPI_ANY_SOURCE, TAG_DONE, MPI_COMM_WORLD, &st);
        int len = 0;
        MPI_Get_count(&st, MPI_CHAR, &len);
        char *buf = malloc(len > 0 ? (size_t)len : 1);
        if (!buf)
            return sph_err_set(err, SPH_ERR_NOMEM, "ensemble: out of memory");
        MPI_Recv(buf, len, MPI_CHAR, st.MPI_SOURCE, TAG_DONE, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        cJSON *j = cJSON_Parse(buf);
        free(buf);
        int mrc = j ? cJSON_GetObjectItemCaseSensitive(j, "rc")->valueint : SPH_ERR_INTERNAL;
        int member = j ? cJSON_GetObjectItemCaseSensitive(j, "member")->valueint : -1;
        *wall += j ? cJSON_GetObjectItemCaseSensitive(j, "wall_seconds")->valuedouble : 0.0;
        if (mrc && rc == SPH_OK)
            rc = sph_err_set(err, mrc, "ensemble member %d (rank %d): %s", member, st.MPI_SOURCE,
                             j ? cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(j, "message")) : "no answer");
        else if (!mrc)
            log_info("ensemble: member %d done on rank %d", member, st.MPI_SOURCE);
        cJSON_Delete(j);
    }
    return rc;
}

#else /* no MPI: one process */

int ens_mpi_init(int *argc, char ***argv) { (void)argc; (void)argv; return 0; }
int ens_mpi_rank(void) { return 0; }
int ens_mpi_size(void) { return 1; }
void ens_mpi_finalize(void) {}
int ens_mpi_worker(const struct sph_config *cfg, const volatile sig_atomic_t *cancel)
{
    (void)cfg;
    (void)cancel;
    return 0;
}
void ens_mpi_stop_workers(void) {}
int ens_mpi_dispatch(const forecast_request *req, int member, const char *stage, void **handle, sph_error *err)
{
    (void)req;
    (void)member;
    (void)stage;
    *handle = NULL;
    return sph_err_set(err, SPH_ERR_INTERNAL, "ensemble: built without MPI");
}
int ens_mpi_dispatch_rank(const forecast_request *req, int rank, const char *stage, void **handle, sph_error *err)
{
    (void)rank;
    return ens_mpi_dispatch(req, 0, stage, handle, err);
}
int ens_mpi_collect(void **handles, int n, double *wall, sph_error *err)
{
    (void)handles;
    (void)wall;
    return n ? sph_err_set(err, SPH_ERR_INTERNAL, "ensemble: built without MPI") : SPH_OK;
}

#endif
