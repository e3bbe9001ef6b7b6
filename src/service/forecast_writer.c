/* The products' background writer (output.writer_thread, docs/engine.md
 * "The products' writer thread"): products_add_time of one output time runs
 * on a thread of its own while the model steps on.
 *
 * What the job reads: the engine's output arrays (e->olon, e->olat,
 * e->pue, e->pvn and the gridded e->g_*), which only fc_write_output
 * writes, and a copy of the particles' own fields the products carry
 * (mass, thickness, concentration, snow, id), which the steps change. So
 * one snapshot is enough: fc_write_output waits for the previous job
 * before it overwrites the arrays. The job is prepared at the output time
 * and started at the second forcing fill after it (fc_bgw_kick counts
 * down BGW_KICK_FILLS): a forcing interval is (t_lo, t_hi], so with
 * outputs on forcing times the first fill after an output still reads
 * the interval that ends there and the second one reads the next slice;
 * started after that read, the job does not hold the NetCDF lock while
 * the step loop waits for a slice.
 *
 * NetCDF: the job holds the process's NetCDF/HDF5 lock (io/nc_guard.h)
 * for its whole products_add_time; the only NetCDF calls of the step loop
 * meanwhile are the forcing's slice reads (locked there) and the restart
 * file and closing, before which the engine waits for the job. A failed
 * job fails the run at the next wait, with the writer's own line. */
#include "forecast_impl.h"

#include <pthread.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "io/nc_guard.h"
#include "io/ncfile.h"

enum { BGW_IDLE, BGW_PREPARED, BGW_RUNNING, BGW_DONE };

/* the forcing fills after an output time before its job starts */
enum { BGW_KICK_FILLS = 2 };

struct fc_bgw {
    pthread_t th;
    pthread_mutex_t mu;
    pthread_cond_t cv;
    int state;   /* BGW_*, under mu */
    int fills;   /* BGW_PREPARED: fc_bgw_kick calls before it starts the job */
    int quit;
    int nice;    /* output.writer_nice */
    prod_writer *pw;
    /* the job */
    double t;
    prod_fields f;
    prod_particles_view pv;
    int with_particles;
    size_t cap;  /* of the copies below */
    double *mass, *thick, *conc, *snow;
    long *id;
    int rc;
    sph_error err;
};

static void *bgw_main(void *arg)
{
    fc_bgw *w = arg;
    ncfile_thread_quiet(); /* HDF5's error printing is per thread */
    /* Linux: a nice value is the thread's own (this tid); raising it needs
     * no privilege, and a failure changes only the scheduling */
    if (w->nice > 0)
        (void)setpriority(PRIO_PROCESS, (id_t)gettid(), w->nice);
    pthread_mutex_lock(&w->mu);
    for (;;) {
        while (w->state != BGW_RUNNING && !w->quit)
            pthread_cond_wait(&w->cv, &w->mu);
        if (w->state != BGW_RUNNING)
            break;
        pthread_mutex_unlock(&w->mu);
        sph_error er;
        sph_error_clear(&er);
        nc_guard_lock();
        int rc = products_add_time(w->pw, w->t, &w->f, w->with_particles ? &w->pv : NULL, &er);
        nc_guard_unlock();
        pthread_mutex_lock(&w->mu);
        w->rc = rc;
        w->err = er;
        w->state = BGW_DONE;
        pthread_cond_broadcast(&w->cv);
    }
    pthread_mutex_unlock(&w->mu);
    return NULL;
}

int fc_max_threads(void)
{
#ifdef _OPENMP
    return omp_get_max_threads();
#else
    return 1;
#endif
}

int fc_bgw_wanted(const engine *e)
{
    const struct sph_config *cfg = e->cfg;
    if (cfg->output.writer_thread == CFG_WRITER_OFF || e->ofx || e->dd || !e->pw)
        return 0;
    return cfg->output.writer_thread == CFG_WRITER_ON || fc_max_threads() > 1;
}

int fc_bgw_start(engine *e, sph_error *err)
{
    if (!fc_bgw_wanted(e))
        return SPH_OK;
    fc_bgw *w = calloc(1, sizeof *w);
    if (!w)
        return sph_err_set(err, SPH_ERR_NOMEM, "output.writer_thread: out of memory");
    w->pw = e->pw;
    w->nice = e->cfg->output.writer_nice;
    if (pthread_mutex_init(&w->mu, NULL) != 0) {
        free(w);
        return sph_err_set(err, SPH_ERR_INTERNAL, "output.writer_thread: cannot create its lock");
    }
    if (pthread_cond_init(&w->cv, NULL) != 0) {
        pthread_mutex_destroy(&w->mu);
        free(w);
        return sph_err_set(err, SPH_ERR_INTERNAL, "output.writer_thread: cannot create its condition");
    }
    int prc = pthread_create(&w->th, NULL, bgw_main, w);
    if (prc != 0) {
        pthread_cond_destroy(&w->cv);
        pthread_mutex_destroy(&w->mu);
        free(w);
        return sph_err_set(err, SPH_ERR_INTERNAL, "output.writer_thread: cannot start the thread: %s; "
                           "set output.writer_thread \"off\"", strerror(prc));
    }
    /* its name in /proc/PID/task/TID/comm, top -H and perf (bench/thread_cpu.sh
     * tells its CPU from the OpenMP team's by it); a failure changes nothing */
    (void)pthread_setname_np(w->th, "sphice-writer");
    e->bgw = w;
    return SPH_OK;
}

/* Starts a prepared job (caller holds mu). */
static void kick_locked(fc_bgw *w)
{
    if (w->state == BGW_PREPARED) {
        w->state = BGW_RUNNING;
        pthread_cond_broadcast(&w->cv);
    }
}

void fc_bgw_kick(engine *e)
{
    fc_bgw *w = e->bgw;
    if (!w)
        return;
    pthread_mutex_lock(&w->mu);
    if (w->state == BGW_PREPARED && --w->fills <= 0)
        kick_locked(w);
    pthread_mutex_unlock(&w->mu);
}

int fc_bgw_wait(engine *e, sph_error *err)
{
    fc_bgw *w = e->bgw;
    if (!w)
        return SPH_OK;
    pthread_mutex_lock(&w->mu);
    kick_locked(w);
    while (w->state == BGW_RUNNING)
        pthread_cond_wait(&w->cv, &w->mu);
    int rc = SPH_OK;
    if (w->state == BGW_DONE) {
        rc = w->rc;
        if (rc)
            sph_err_set(err, rc, "%s", w->err.msg);
    }
    w->state = BGW_IDLE;
    pthread_mutex_unlock(&w->mu);
    return rc;
}

/* Grows the particle copies to n (the caller has waited: the thread is idle). */
static int bgw_reserve(fc_bgw *w, size_t n)
{
    if (n <= w->cap)
        return 0;
    size_t c = n + n / 4 + 1024;
    double **d[] = {&w->mass, &w->thick, &w->conc, &w->snow};
    for (size_t k = 0; k < sizeof d / sizeof d[0]; k++) {
        double *p = realloc(*d[k], c * sizeof(double));
        if (!p)
            return -1;
        *d[k] = p;
    }
    long *p = realloc(w->id, c * sizeof(long));
    if (!p)
        return -1;
    w->id = p;
    w->cap = c;
    return 0;
}

int fc_bgw_submit(engine *e, double t, const prod_fields *f, const prod_particles_view *pv, sph_error *err)
{
    fc_bgw *w = e->bgw;
    int rc = fc_bgw_wait(e, err);
    if (rc)
        return rc;
    w->t = t;
    w->f = *f; /* the engine's own arrays: unchanged until the next output */
    w->with_particles = pv != NULL;
    if (pv) {
        size_t n = pv->n;
        if (bgw_reserve(w, n) != 0)
            return sph_err_set(err, SPH_ERR_NOMEM, "output.writer_thread: out of memory (%zu particles)", n);
        /* the model's fields the steps change: copied (none with no
         * particle: the copies may not exist, and memcpy takes no NULL) */
        if (n > 0) {
            memcpy(w->mass, pv->mass, n * sizeof(double));
            memcpy(w->thick, pv->thick, n * sizeof(double));
            memcpy(w->conc, pv->conc, n * sizeof(double));
            if (pv->snow)
                memcpy(w->snow, pv->snow, n * sizeof(double));
            memcpy(w->id, pv->id, n * sizeof(long));
        }
        w->pv = *pv;
        w->pv.mass = w->mass;
        w->pv.thick = w->thick;
        w->pv.conc = w->conc;
        w->pv.snow = pv->snow ? w->snow : NULL;
        w->pv.id = w->id;
    }
    pthread_mutex_lock(&w->mu);
    w->state = BGW_PREPARED;
    w->fills = BGW_KICK_FILLS;
    pthread_mutex_unlock(&w->mu);
    return SPH_OK;
}

void fc_bgw_stop(engine *e)
{
    fc_bgw *w = e->bgw;
    if (!w)
        return;
    pthread_mutex_lock(&w->mu);
    if (w->state == BGW_PREPARED) /* never started: dropped with the run */
        w->state = BGW_IDLE;
    while (w->state == BGW_RUNNING)
        pthread_cond_wait(&w->cv, &w->mu);
    w->quit = 1;
    pthread_cond_broadcast(&w->cv);
    pthread_mutex_unlock(&w->mu);
    pthread_join(w->th, NULL);
    pthread_cond_destroy(&w->cv);
    pthread_mutex_destroy(&w->mu);
    free(w->mass);
    free(w->thick);
    free(w->conc);
    free(w->snow);
    free(w->id);
    free(w);
    e->bgw = NULL;
}
