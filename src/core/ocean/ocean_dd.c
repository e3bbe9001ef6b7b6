/* The mixed layer in canonical mode (core/dd.h, docs/domain.md "The mixed
 * layer"): the answer must not depend on which rank holds which particle,
 * nor on the slots, and the ocean's step is full of sums over particles
 * into cells (footprints, heat and water, the removed particles' fluxes),
 * of decisions that read every particle near a cell (creation: never
 * inside existing ice; merging: the first partner in index order) and of
 * ids handed out from the largest one. So in canonical mode the ocean's
 * step runs, unchanged (new_ice.c), on a view: every rank's owned
 * particles in id order, which the driver gathers on every rank
 * (SPH_DD_OCEAN; a serial canonical model copies its own). Every rank then
 * computes the same cells, the same budgets, the same removals, new
 * particles (ids, places, masses) and merges, in the same order as the
 * serial canonical run; each keeps its share of the result: the particles
 * whose ids it owned, the lead rank the new ones (the next step's
 * migration takes them to their owners). The ice totals the budget reads
 * between two such steps are exact sums over the owned particles, summed
 * over the ranks (sph_xsum). No allocation in a step: the view and its
 * workspace are allocated with canonical mode or the mixed layer. */
#include "../model_impl.h"
#include "core/dd.h"

#include <stdlib.h>
#include <string.h>

void sph_dd_ocean_free(sph_model *m)
{
    sph_particles_free(m->og);
    free(m->og_ea);
    free(m->og_lea);
    free(m->og_scratch);
    free(m->og_pair);
    free(m->og_mine);
    free(m->og_order);
    free(m->og_out);
    free(m->og_outg);
    m->og_out = m->og_outg = NULL;
    m->og_nout = m->og_noutg = 0;
    m->og = NULL;
    m->og_ea = m->og_lea = m->og_scratch = NULL;
    m->og_pair = m->og_mine = NULL;
    m->og_order = NULL;
}

int sph_dd_ocean_alloc(sph_model *m)
{
    if (!m->canonical || !m->ocean || m->og)
        return 0;
    size_t cap = m->cap, slots = sph_model_slots(m);
    m->og = sph_particles_create(cap, m->P->nlayers);
    m->og_ea = calloc(cap, sizeof(double));
    m->og_lea = calloc(slots, sizeof(double));
    m->og_scratch = calloc(cap, sizeof(double));
    m->og_pair = calloc(2 * cap, sizeof(long));
    m->og_mine = calloc(cap, sizeof(long));
    m->og_order = calloc(cap, sizeof(int));
    m->og_out = calloc(cap * SPH_OCEAN_OUT_ROW, sizeof(double));
    m->og_outg = calloc(cap * SPH_OCEAN_OUT_ROW, sizeof(double));
    m->og_nout = m->og_noutg = 0;
    if (!m->og || !m->og_ea || !m->og_lea || !m->og_scratch || !m->og_pair || !m->og_mine || !m->og_order ||
        !m->og_out || !m->og_outg) {
        sph_dd_ocean_free(m);
        return -1;
    }
    return 0;
}

sph_particles *sph_model_dd_view(sph_model *m, double **ea, int **rc)
{
    if (ea)
        *ea = m->og_ea;
    if (rc)
        *rc = &m->og_rc;
    return m->og;
}

const double *sph_model_dd_local_ea(const sph_model *m) { return m->og_lea; }

double *sph_model_dd_outflow(sph_model *m, size_t *nlocal, double **all, size_t **nall, size_t *cap)
{
    if (nlocal)
        *nlocal = m->og_nout;
    if (all)
        *all = m->og_outg;
    if (nall)
        *nall = &m->og_noutg;
    if (cap)
        *cap = m->og ? m->og->cap : 0;
    return m->og_out;
}

/* Heap sort of n longs in place (ids are unique: any sort gives the same
 * order; libc's qsort may allocate). a[2 i] the key, a[2 i + 1] its value
 * when pairs. */
static void sift(long *a, size_t w, size_t i, size_t n)
{
    for (;;) {
        size_t c = 2 * i + 1;
        if (c >= n)
            return;
        if (c + 1 < n && a[w * (c + 1)] > a[w * c])
            c++;
        if (a[w * i] >= a[w * c])
            return;
        for (size_t q = 0; q < w; q++) {
            long t = a[w * i + q];
            a[w * i + q] = a[w * c + q];
            a[w * c + q] = t;
        }
        i = c;
    }
}

static void heap_sort(long *a, size_t w, size_t n)
{
    for (size_t i = n / 2; i-- > 0;)
        sift(a, w, i, n);
    for (size_t e = n; e-- > 1;) {
        for (size_t q = 0; q < w; q++) {
            long t = a[q];
            a[q] = a[w * e + q];
            a[w * e + q] = t;
        }
        sift(a, w, 0, e);
    }
}

static int has_id(const long *s, size_t n, long id)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (s[mid] < id)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < n && s[lo] == id;
}

/* Slot of id in the view (sorted by id), or -1. */
static long view_slot(const sph_particles *V, long id)
{
    size_t lo = 0, hi = V->n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (V->id[mid] < id)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < V->n && V->id[lo] == id ? (long)lo : -1;
}

/* The view of every rank's owned particles in id order, each with its
 * og_lea value in og_ea; the ids this rank owns in og_mine. Returns the
 * worst of every rank's rc. */
static int gather(sph_model *m, int rc)
{
    sph_particles *P = m->P, *V = m->og;
    m->og_nmine = 0;
    for (size_t k = 0; k < P->n; k++)
        if (!m->dd || m->dd_owned[k])
            m->og_mine[m->og_nmine++] = P->id[k];
    heap_sort(m->og_mine, 1, m->og_nmine);
    if (m->dd) {
        m->og_rc = rc;
        m->dd->exchange(m->dd->ctx, m, SPH_DD_OCEAN);
        rc = m->og_rc;
    } else {
        for (size_t k = 0; k < P->n; k++) {
            sph_particles_copy_one(V, k, P, k);
            m->og_ea[k] = m->og_lea[k];
        }
        V->n = P->n;
    }
    size_t n = V->n;
    long *pr = m->og_pair;
    for (size_t i = 0; i < n; i++) {
        pr[2 * i] = V->id[i];
        pr[2 * i + 1] = (long)i;
    }
    heap_sort(pr, 2, n);
    for (size_t i = 0; i < n; i++)
        m->og_order[i] = (int)pr[2 * i + 1];
    sph_particles_permute(V, m->og_order, m->og_scratch);
    for (size_t i = 0; i < n; i++)
        m->og_scratch[i] = m->og_ea[m->og_order[i]];
    memcpy(m->og_ea, m->og_scratch, n * sizeof(double));
    m->og_maxid = n > 0 ? V->id[n - 1] : -1;
    return rc;
}

int sph_dd_ocean_before(sph_model *m, double dt, sph_status *st)
{
    sph_particles *P = m->P, *V = m->og;
    memset(m->og_lea, 0, P->n * sizeof(double));
    int rc = gather(m, SPH_STEP_OK);
    if (rc != SPH_STEP_OK)
        return sph_status_set(st, rc, SPH_FAULT_INVALID, -1, "domain decomposition", (double)rc, 0.0,
                              "another rank's step failed");
    m->P = V;
    m->og_on = 1;
    sph_ocean_before(m, dt);
    m->og_on = 0;
    m->P = P;
    /* every local particle, owned or a halo copy, is in the view */
    for (size_t k = 0; k < P->n; k++) {
        long i = view_slot(V, P->id[k]);
        if (i >= 0) {
            P->sst[k] = V->sst[i];
            P->fw[k] = V->fw[i];
        }
    }
    return SPH_STEP_OK;
}

int sph_dd_ocean_after(sph_model *m, double dt, int rc_in, sph_status *st)
{
    sph_particles *P = m->P, *V = m->og;
    for (size_t k = 0; k < P->n; k++)
        m->og_lea[k] = rc_in == SPH_STEP_OK ? sph_thermo_energy_atm(m->tw, k) : 0.0;
    int rc = gather(m, rc_in);
    if (rc_in != SPH_STEP_OK)
        return rc_in;
    if (rc != SPH_STEP_OK)
        return sph_status_set(st, rc, SPH_FAULT_INVALID, -1, "domain decomposition", (double)rc, 0.0,
                              "another rank's step failed");
    /* the view holds the particles of sph_dd_ocean_before's, in the same
     * order (the columns remove none): the footprints, enthalpies and
     * masses the ocean kept per slot are theirs */
    m->P = V;
    m->og_on = 1;
    rc = sph_ocean_after_ea(m, dt, NULL, m->og_ea, st);
    m->og_on = 0;
    m->P = P;
    const int lead = !m->dd || m->dd->lead;
    size_t n = 0;
    for (size_t i = 0; i < V->n; i++) {
        long id = V->id[i];
        int keep = id > m->og_maxid ? lead : has_id(m->og_mine, m->og_nmine, id);
        if (keep)
            sph_particles_copy_one(P, n++, V, i);
    }
    P->n = n;
    memset(m->dd_owned, 1, n);
    return rc;
}

void sph_dd_ice_totals(const sph_model *m, double (*enth)(const sph_model *, size_t), double *e, double *mass)
{
    const sph_particles *P = m->P;
    sph_xsum acc[2];
    sph_xsum_clear(&acc[0]);
    sph_xsum_clear(&acc[1]);
    const int all = m->og_on || !m->dd;
    for (size_t k = 0; k < P->n; k++) {
        if (!all && !m->dd_owned[k])
            continue;
        sph_xsum_add(&acc[0], enth(m, k));
        sph_xsum_add(&acc[1], P->mass[k]);
    }
    if (!all && m->dd->reduce)
        m->dd->reduce(m->dd->ctx, acc, 2, NULL, 0);
    *e = sph_xsum_value(&acc[0]);
    *mass = sph_xsum_value(&acc[1]);
}

/* The particles leaving at an open boundary (docs/domain.md "The ocean
 * fluxes"): each owner stashes its leaving particles' accumulators instead
 * of adding them to its own copy of the cells in its own order; after the
 * removals every rank books every rank's rows in id order, so every rank's
 * cells get the same additions in the same order as the serial canonical
 * run's. */
void sph_dd_ocean_stash_outflow(sph_model *m, size_t k)
{
    if (m->og_nout >= m->og->cap)
        return; /* cannot happen: at most the rank's particles leave */
    sph_ocean_stash_particle(m, k, m->og_out + m->og_nout * SPH_OCEAN_OUT_ROW);
    m->og_nout++;
}

void sph_dd_ocean_book_outflow(sph_model *m)
{
    if (m->dd) {
        m->dd->exchange(m->dd->ctx, m, SPH_DD_OUTFLOW);
    } else {
        memcpy(m->og_outg, m->og_out, m->og_nout * SPH_OCEAN_OUT_ROW * sizeof(double));
        m->og_noutg = m->og_nout;
    }
    m->og_nout = 0;
    size_t n = m->og_noutg;
    long *pr = m->og_pair;
    for (size_t i = 0; i < n; i++) {
        pr[2 * i] = (long)m->og_outg[i * SPH_OCEAN_OUT_ROW];
        pr[2 * i + 1] = (long)i;
    }
    heap_sort(pr, 2, n);
    for (size_t i = 0; i < n; i++)
        sph_ocean_book_stashed(m, m->og_outg + (size_t)pr[2 * i + 1] * SPH_OCEAN_OUT_ROW);
    m->og_noutg = 0;
}
