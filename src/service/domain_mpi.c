/* Spatial domain decomposition of one model over MPI ranks
 * (service/domain_mpi.h; docs/domain.md). MPI build only (dd_sort_by_id: both). */
#include "service/domain_mpi.h"

#ifdef SPHICE_MPI
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { TAG_ITER = 71 };
enum { NREFRESH = 5 }; /* u, v, s11, s22, s12 per halo particle and iteration */

struct dd_ctx {
    MPI_Comm comm;
    int rank, size;
    sph_model *m;
    dd_options o;
    int ncx, ncy;
    double cs;
    long ncells;
    long *by_curve;  /* cells in Hilbert order */
    int *owner;      /* [ncells] */
    int64_t *cost;   /* [ncells] */
    size_t rowbytes; /* one particle, every field */
    long steps;
    /* halo of this step: ids sent to / received from each rank */
    int *hs_count, *hr_count, *hs_off, *hr_off;
    long *hs_ids, *hr_ids, *hr_sorted;
    long *hs_slot, *hr_slot;
    size_t hs_n, hr_n, hs_cap, hr_cap;
    double *sbuf, *rbuf;
    MPI_Request *req;
    int nreq;  /* requests in flight */
    int *mark; /* per rank: the last particle that chose it (halo) */
    sph_dd_hooks hooks;
    MPI_Op op;       /* red_op */
    double hmax;     /* largest smoothing length over the ranks, after the last step */
    /* the mask cells within zone_r of land (core/dd.h), where the halo
     * reaches through mirror ghosts; NULL without a land mask */
    unsigned char *zone;
    double zone_r;
    double gmass, gcount; /* global exact mass and particle count after the last step */
    /* the budget's sources (core/dd.h), exact over every rank's owned
     * particles, since the scatter; on top of base, the scattered clock's
     * budget; the global exact mass and snow mass at the scatter */
    sph_xsum gsrc[SPH_DD_NSRC];
    sph_budget base;
    double gmass0, gsnow0;
    dd_stats stats;  /* this rank's, summed over the run */
    /* packing scratch */
    unsigned char *pk, *upk;
    size_t pk_cap, upk_cap;
    int *scount, *rcount, *sdisp, *rdisp;
    long *pairs;
    size_t pairs_cap;
};

/* ------------------------------------------------------------------ */
/* helpers                                                             */

static int grow(void **p, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap)
        return 0;
    size_t c = *cap ? *cap : 256;
    while (c < need)
        c *= 2;
    void *q = realloc(*p, c * elem);
    if (!q)
        return -1;
    *p = q;
    *cap = c;
    return 0;
}

/* Hilbert index of (x, y) on an n x n grid, n a power of two. */
static long hilbert(long n, long x, long y)
{
    long d = 0;
    for (long s = n / 2; s > 0; s /= 2) {
        long rx = (x & s) > 0, ry = (y & s) > 0;
        d += s * s * ((3 * rx) ^ ry);
        if (ry == 0) {
            if (rx == 1) {
                x = s - 1 - x;
                y = s - 1 - y;
            }
            long t = x;
            x = y;
            y = t;
        }
    }
    return d;
}

static long cell_ix(const dd_ctx *d, double x, int nx, double x0)
{
    double f = (x - x0) / d->cs;
    if (!(f >= 0.0))
        return 0;
    if (f >= nx)
        return nx - 1;
    return (long)f;
}

static long cell_of(const dd_ctx *d, double x, double y)
{
    return cell_ix(d, y, d->ncy, d->o.y0) * d->ncx + cell_ix(d, x, d->ncx, d->o.x0);
}

static size_t row_bytes(const sph_particles *P)
{
    size_t b = 0;
    for (int f = 0; f < SPH_PARTICLE_NFIELDS; f++)
        b += sph_particle_fields[f].size * sph_particles_field_count(P, f);
    return b;
}

static void pack_row(const sph_particles *P, size_t k, unsigned char *out)
{
    for (int f = 0; f < SPH_PARTICLE_NFIELDS; f++) {
        size_t sz = sph_particle_fields[f].size * sph_particles_field_count(P, f);
        memcpy(out, (const unsigned char *)sph_particles_field(P, f) + k * sz, sz);
        out += sz;
    }
}

static void unpack_row(sph_particles *P, size_t k, const unsigned char *in)
{
    for (int f = 0; f < SPH_PARTICLE_NFIELDS; f++) {
        size_t sz = sph_particle_fields[f].size * sph_particles_field_count(P, f);
        memcpy((unsigned char *)sph_particles_field(P, f) + k * sz, in, sz);
        in += sz;
    }
}

static int cmp_long(const void *a, const void *b)
{
    long x = *(const long *)a, y = *(const long *)b;
    return (x > y) - (x < y);
}

static int cmp_pair(const void *a, const void *b) { return cmp_long(a, b); } /* (key, value) pairs */

static int is_halo(const dd_ctx *d, long id)
{
    return d->hr_n > 0 && bsearch(&id, d->hr_sorted, d->hr_n, sizeof(long), cmp_long) != NULL;
}

/* ------------------------------------------------------------------ */
/* partition                                                           */

/* Cells along the curve, cut where the cumulated cost crosses r/size of
 * the total (at a cell's middle): the same on every rank. */
static void partition(dd_ctx *d)
{
    MPI_Allreduce(MPI_IN_PLACE, d->cost, (int)d->ncells, MPI_INT64_T, MPI_SUM, d->comm);
    int64_t total = 0;
    for (long c = 0; c < d->ncells; c++)
        total += d->cost[c] + 1; /* +1: empty cells are spread too */
    int64_t cum = 0;
    for (long i = 0; i < d->ncells; i++) {
        long c = d->by_curve[i];
        int64_t w = d->cost[c] + 1;
        long r = (long)(((__int128)(2 * cum + w) * d->size) / (2 * (__int128)total));
        d->owner[c] = (int)(r < d->size ? r : d->size - 1);
        cum += w;
    }
}

static void measure_cost(dd_ctx *d, const sph_particles *P, size_t n)
{
    memset(d->cost, 0, (size_t)d->ncells * sizeof *d->cost);
    for (size_t k = 0; k < n; k++)
        d->cost[cell_of(d, P->x[k], P->y[k])]++;
}

/* ------------------------------------------------------------------ */
/* all-to-all of particle rows                                         */

/* Sends rows listed as (dest, slot) in d->pairs [np] from P; received rows
 * are appended to P after its n. Returns the received count or -1. */
static long exchange_rows(dd_ctx *d, const sph_particles *P, size_t np, sph_particles *into,
                          double *bytes)
{
    int S = d->size;
    memset(d->scount, 0, (size_t)S * sizeof(int));
    for (size_t i = 0; i < np; i++)
        d->scount[d->pairs[2 * i]]++;
    MPI_Alltoall(d->scount, 1, MPI_INT, d->rcount, 1, MPI_INT, d->comm);
    long rtot = 0;
    int so = 0;
    for (int r = 0; r < S; r++) {
        d->sdisp[r] = so;
        so += d->scount[r];
        rtot += d->rcount[r];
    }
    if (grow((void **)&d->pk, &d->pk_cap, (np + 1) * d->rowbytes, 1) ||
        grow((void **)&d->upk, &d->upk_cap, ((size_t)rtot + 1) * d->rowbytes, 1))
        return -1;
    int *fill = d->rdisp; /* as a cursor first */
    memcpy(fill, d->sdisp, (size_t)S * sizeof(int));
    for (size_t i = 0; i < np; i++) {
        int r = (int)d->pairs[2 * i];
        pack_row(P, (size_t)d->pairs[2 * i + 1], d->pk + (size_t)fill[r]++ * d->rowbytes);
    }
    /* in bytes */
    int *sc = malloc((size_t)S * 4 * sizeof(int));
    if (!sc)
        return -1;
    int *sd = sc + S, *rc = sc + 2 * S, *rd = sc + 3 * S;
    int ro = 0;
    for (int r = 0; r < S; r++) {
        sc[r] = d->scount[r] * (int)d->rowbytes;
        sd[r] = d->sdisp[r] * (int)d->rowbytes;
        rc[r] = d->rcount[r] * (int)d->rowbytes;
        rd[r] = ro * (int)d->rowbytes;
        d->rdisp[r] = ro;
        ro += d->rcount[r];
    }
    MPI_Alltoallv(d->pk, sc, sd, MPI_BYTE, d->upk, rc, rd, MPI_BYTE, d->comm);
    free(sc);
    if (bytes)
        *bytes += (double)np * (double)d->rowbytes;
    if (into->n + (size_t)rtot > into->cap)
        return -1;
    for (long i = 0; i < rtot; i++)
        unpack_row(into, into->n + (size_t)i, d->upk + (size_t)i * d->rowbytes);
    into->n += (size_t)rtot;
    return rtot;
}

/* Particles whose cell another rank owns go there. */
static int migrate(dd_ctx *d)
{
    sph_particles *P = sph_model_particles(d->m);
    size_t np = 0, n = P->n;
    if (grow((void **)&d->pairs, &d->pairs_cap, 2 * (n + 1), sizeof(long)))
        return -1;
    for (size_t k = 0; k < n; k++) {
        int o = d->owner[cell_of(d, P->x[k], P->y[k])];
        if (o != d->rank) {
            d->pairs[2 * np] = o;
            d->pairs[2 * np + 1] = (long)k;
            np++;
        }
    }
    /* sent from their current slots, the arrivals appended after them;
     * then the gaps of the sent ones closed (the order does not matter:
     * canonical mode) */
    size_t keep_n = n;
    double bytes = 0;
    long got = exchange_rows(d, P, np, P, &bytes);
    if (got < 0)
        return -1;
    unsigned char *gone = calloc(P->n + 1, 1);
    if (!gone)
        return -1;
    for (size_t i = 0; i < np; i++)
        gone[d->pairs[2 * i + 1]] = 1;
    size_t w = 0;
    for (size_t k = 0; k < P->n; k++) {
        if (k < keep_n && gone[k])
            continue;
        if (w != k)
            sph_particles_copy_one(P, w, P, k);
        w++;
    }
    P->n = w;
    free(gone);
    d->stats.migrated += (long)np;
    d->stats.migrate_bytes += bytes;
    return 0;
}

/* Copies of owned particles within the halo width of another rank's cells:
 * H0, or Hc in the coast zone. */
static int build_halo(dd_ctx *d, double H0, double Hc)
{
    sph_particles *P = sph_model_particles(d->m);
    size_t n = P->n, np = 0;
    for (size_t k = 0; k < n; k++) {
        double x = P->x[k], y = P->y[k];
        double H = d->zone && sph_model_dd_in_zone(d->m, d->zone, x, y) ? Hc : H0;
        long i0 = cell_ix(d, x - H, d->ncx, d->o.x0), i1 = cell_ix(d, x + H, d->ncx, d->o.x0);
        long j0 = cell_ix(d, y - H, d->ncy, d->o.y0), j1 = cell_ix(d, y + H, d->ncy, d->o.y0);
        for (long j = j0; j <= j1; j++)
            for (long i = i0; i <= i1; i++) {
                int o = d->owner[j * d->ncx + i];
                if (o == d->rank || d->mark[o] == (int)k + 1)
                    continue;
                d->mark[o] = (int)k + 1;
                if (grow((void **)&d->pairs, &d->pairs_cap, 2 * (np + 1), sizeof(long)))
                    return -1;
                d->pairs[2 * np] = o;
                d->pairs[2 * np + 1] = (long)k;
                np++;
            }
    }
    for (int r = 0; r < d->size; r++)
        d->mark[r] = 0;
    /* the ids sent, in send order (exchange_rows packs by rank, pairs in order) */
    if (grow((void **)&d->hs_ids, &d->hs_cap, np + 1, sizeof(long)))
        return -1;
    free(d->hs_slot);
    d->hs_slot = malloc((np + 1) * sizeof(long));
    double bytes = 0;
    long got = exchange_rows(d, P, np, P, &bytes);
    if (got < 0 || !d->hs_slot)
        return -1;
    {
        int *cur = malloc((size_t)d->size * sizeof(int));
        if (!cur)
            return -1;
        memcpy(cur, d->sdisp, (size_t)d->size * sizeof(int));
        for (size_t i = 0; i < np; i++)
            d->hs_ids[cur[d->pairs[2 * i]]++] = P->id[d->pairs[2 * i + 1]];
        free(cur);
    }
    memcpy(d->hs_count, d->scount, (size_t)d->size * sizeof(int));
    memcpy(d->hs_off, d->sdisp, (size_t)d->size * sizeof(int));
    memcpy(d->hr_count, d->rcount, (size_t)d->size * sizeof(int));
    memcpy(d->hr_off, d->rdisp, (size_t)d->size * sizeof(int));
    d->hs_n = np;
    d->hr_n = (size_t)got;
    free(d->hr_ids);
    free(d->hr_sorted);
    free(d->hr_slot);
    free(d->sbuf);
    free(d->rbuf);
    d->hr_ids = malloc(((size_t)got + 1) * sizeof(long));
    d->hr_sorted = malloc(((size_t)got + 1) * sizeof(long));
    d->hr_slot = malloc(((size_t)got + 1) * sizeof(long));
    d->sbuf = malloc((np + 1) * NREFRESH * sizeof(double));
    d->rbuf = malloc(((size_t)got + 1) * NREFRESH * sizeof(double));
    if (!d->hr_ids || !d->hr_sorted || !d->hr_slot || !d->sbuf || !d->rbuf)
        return -1;
    for (long i = 0; i < got; i++)
        d->hr_ids[i] = d->hr_sorted[i] = P->id[n + (size_t)i];
    qsort(d->hr_sorted, (size_t)got, sizeof(long), cmp_long);
    d->stats.halo += got;
    d->stats.halo_bytes += bytes;
    return 0;
}

/* ------------------------------------------------------------------ */
/* hooks                                                               */

static void map_slots(dd_ctx *d, sph_model *m)
{
    sph_particles *P = sph_model_particles(m);
    size_t n = P->n;
    unsigned char *own = sph_model_dd_owned(m);
    long *pr = malloc((2 * n + 2) * sizeof(long));
    if (!pr)
        abort(); /* no way to fail a hook; a step allocates here only in the MPI driver */
    for (size_t k = 0; k < n; k++) {
        pr[2 * k] = P->id[k];
        pr[2 * k + 1] = (long)k;
        own[k] = 1;
    }
    qsort(pr, n, 2 * sizeof(long), cmp_pair);
    for (size_t i = 0; i < d->hs_n + d->hr_n; i++) {
        int send = i < d->hs_n;
        long id = send ? d->hs_ids[i] : d->hr_ids[i - d->hs_n];
        long *hit = bsearch(&id, pr, n, 2 * sizeof(long), cmp_pair);
        long slot = hit ? hit[1] : -1;
        if (send)
            d->hs_slot[i] = slot;
        else {
            d->hr_slot[i - d->hs_n] = slot;
            if (slot >= 0)
                own[slot] = 0;
        }
    }
    free(pr);
}

static void iter_post(dd_ctx *d, sph_model *m)
{
    const sph_particles *P = sph_model_particles(m);
    const double *f[NREFRESH] = {P->u, P->v, P->s11, P->s22, P->s12};
    for (size_t i = 0; i < d->hs_n; i++) {
        long s = d->hs_slot[i];
        for (int q = 0; q < NREFRESH; q++)
            d->sbuf[NREFRESH * i + q] = s >= 0 ? f[q][s] : 0.0;
    }
    int nr = 0;
    for (int r = 0; r < d->size; r++) {
        if (d->hr_count[r] > 0)
            MPI_Irecv(d->rbuf + (size_t)NREFRESH * d->hr_off[r], NREFRESH * d->hr_count[r], MPI_DOUBLE, r,
                      TAG_ITER, d->comm, &d->req[nr++]);
    }
    for (int r = 0; r < d->size; r++) {
        if (d->hs_count[r] > 0)
            MPI_Isend(d->sbuf + (size_t)NREFRESH * d->hs_off[r], NREFRESH * d->hs_count[r], MPI_DOUBLE, r,
                      TAG_ITER, d->comm, &d->req[nr++]);
    }
    d->stats.iterations++;
    d->stats.halo_bytes += (double)d->hs_n * NREFRESH * sizeof(double);
    d->nreq = nr;
}

static void iter_wait(dd_ctx *d, sph_model *m)
{
    sph_particles *P = sph_model_particles(m);
    double t0 = MPI_Wtime();
    MPI_Waitall(d->nreq, d->req, MPI_STATUSES_IGNORE);
    d->stats.wait_s += MPI_Wtime() - t0;
    d->nreq = 0;
    double *f[NREFRESH] = {P->u, P->v, P->s11, P->s22, P->s12};
    for (size_t i = 0; i < d->hr_n; i++) {
        long s = d->hr_slot[i];
        if (s < 0)
            continue;
        for (int q = 0; q < NREFRESH; q++)
            f[q][s] = d->rbuf[NREFRESH * i + q];
    }
}

/* SPH_DD_OCEAN (core/dd.h): every rank's owned particles, each row with
 * its atmospheric energy, gathered on every rank into the model's view,
 * and the worst status over the ranks. */
static void ocean_view(dd_ctx *d, sph_model *m)
{
    double *ea;
    int *rcp;
    sph_particles *V = sph_model_dd_view(m, &ea, &rcp);
    const sph_particles *P = sph_model_particles(m);
    const unsigned char *own = sph_model_dd_owned(m);
    const double *lea = sph_model_dd_local_ea(m);
    const size_t rb = d->rowbytes + sizeof(double);
    int S = d->size, n = 0;
    if (grow((void **)&d->pk, &d->pk_cap, (P->n + 1) * rb, 1))
        abort(); /* no way to fail a hook (map_slots) */
    for (size_t k = 0; k < P->n; k++) {
        if (!own[k])
            continue;
        unsigned char *row = d->pk + (size_t)n * rb;
        pack_row(P, k, row);
        memcpy(row + d->rowbytes, &lea[k], sizeof(double));
        n++;
    }
    int mine[2] = {n, *rcp};
    int *all = malloc(4 * (size_t)S * sizeof(int));
    if (!all)
        abort();
    MPI_Allgather(mine, 2, MPI_INT, all, 2, MPI_INT, d->comm);
    long tot = 0;
    int worst_rc = 0;
    int *cnt = all + 2 * S, *disp = all + 3 * S;
    for (int r = 0; r < S; r++) {
        int q = all[2 * r + 1]; /* any failure; a fatal one first */
        if (q == SPH_STEP_FATAL || (q != SPH_STEP_OK && worst_rc == SPH_STEP_OK))
            worst_rc = q;
        cnt[r] = all[2 * r] * (int)rb;
        disp[r] = (int)(tot * (long)rb);
        tot += all[2 * r];
    }
    if ((size_t)tot > V->cap || grow((void **)&d->upk, &d->upk_cap, (size_t)tot * rb + 1, 1)) {
        fprintf(stderr, "sphice: domain decomposition: the mixed layer's view of %ld particles exceeds the "
                        "capacity %zu on rank %d\n", tot, V->cap, d->rank);
        MPI_Abort(d->comm, 3);
    }
    MPI_Allgatherv(d->pk, n * (int)rb, MPI_BYTE, d->upk, cnt, disp, MPI_BYTE, d->comm);
    for (long i = 0; i < tot; i++) {
        const unsigned char *row = d->upk + (size_t)i * rb;
        unpack_row(V, (size_t)i, row);
        memcpy(&ea[i], row + d->rowbytes, sizeof(double));
    }
    V->n = (size_t)tot;
    *rcp = worst_rc;
    free(all);
}

/* SPH_DD_OUTFLOW (core/dd.h): every rank's rows of the particles that
 * left at an open boundary in this step, gathered on every rank. */
static void outflow_rows(dd_ctx *d, sph_model *m)
{
    enum { ROW = 11 };
    size_t nl = 0, *nall = NULL, cap = 0;
    double *all = NULL;
    const double *mine = sph_model_dd_outflow(m, &nl, &all, &nall, &cap);
    int S = d->size, n = (int)nl;
    int *cnt = malloc(2 * (size_t)S * sizeof(int));
    if (!cnt)
        abort(); /* no way to fail a hook (map_slots) */
    int *disp = cnt + S;
    MPI_Allgather(&n, 1, MPI_INT, cnt, 1, MPI_INT, d->comm);
    long tot = 0;
    for (int r = 0; r < S; r++) {
        disp[r] = (int)(tot * ROW);
        tot += cnt[r];
        cnt[r] *= ROW;
    }
    if ((size_t)tot > cap) {
        fprintf(stderr, "sphice: domain decomposition: %ld particles left at open boundaries, more than the "
                        "capacity %zu on rank %d\n", tot, cap, d->rank);
        MPI_Abort(d->comm, 3);
    }
    if (tot > 0)
        MPI_Allgatherv(mine, n * ROW, MPI_DOUBLE, all, cnt, disp, MPI_DOUBLE, d->comm);
    *nall = (size_t)tot;
    free(cnt);
}

static void hook_exchange(void *ctx, sph_model *m, int stage)
{
    dd_ctx *d = ctx;
    if (stage == SPH_DD_LISTS)
        map_slots(d, m);
    else if (stage == SPH_DD_ITER_POST)
        iter_post(d, m);
    else if (stage == SPH_DD_ITER_WAIT)
        iter_wait(d, m);
    else if (stage == SPH_DD_OCEAN)
        ocean_view(d, m);
    else if (stage == SPH_DD_OUTFLOW)
        outflow_rows(d, m);
}

/* One reduction per call: the accumulators' digits summed and the maxima
 * (non-negative doubles, whose bit patterns order like int64) taken, by
 * one user operation over int64. */
static int red_nmax; /* maxima at the end of the buffer (the operation has no context) */
static int64_t *red_buf;
static size_t red_cap;

static void red_op(void *in, void *inout, int *len, MPI_Datatype *type)
{
    (void)type;
    const int64_t *a = in;
    int64_t *b = inout;
    int ns = *len - red_nmax;
    for (int i = 0; i < ns; i++)
        b[i] += a[i];
    for (int i = ns; i < *len; i++)
        b[i] = a[i] > b[i] ? a[i] : b[i];
}

static void hook_reduce(void *ctx, sph_xsum *sums, int nsum, double *maxes, int nmax)
{
    dd_ctx *d = ctx;
    int per = (int)(sizeof(sph_xsum) / sizeof(int64_t));
    int len = nsum * per + nmax;
    if (grow((void **)&red_buf, &red_cap, (size_t)len, sizeof(int64_t)))
        MPI_Abort(d->comm, 3);
    memcpy(red_buf, sums, (size_t)nsum * sizeof(sph_xsum));
    for (int i = 0; i < nmax; i++) {
        double v = maxes[i] > 0.0 ? maxes[i] : 0.0; /* NaN or -0 as 0: fmax's own rule */
        memcpy(&red_buf[nsum * per + i], &v, sizeof v);
    }
    red_nmax = nmax;
    double t0 = MPI_Wtime();
    MPI_Allreduce(MPI_IN_PLACE, red_buf, len, MPI_INT64_T, d->op, d->comm);
    d->stats.reduce_s += MPI_Wtime() - t0;
    memcpy(sums, red_buf, (size_t)nsum * sizeof(sph_xsum));
    for (int i = 0; i < nmax; i++)
        memcpy(&maxes[i], &red_buf[nsum * per + i], sizeof(double));
}

/* ------------------------------------------------------------------ */
/* API                                                                 */

dd_ctx *dd_create(MPI_Comm comm, sph_model *m, const dd_options *o)
{
    dd_ctx *d = calloc(1, sizeof *d);
    if (!d)
        return NULL;
    d->comm = comm;
    MPI_Comm_rank(comm, &d->rank);
    MPI_Comm_size(comm, &d->size);
    d->m = m;
    d->o = *o;
    d->cs = o->cell;
    if (!(d->cs > 0.0) || !(o->x1 > o->x0) || !(o->y1 > o->y0) || sph_model_set_canonical(m, 1)) {
        free(d);
        return NULL;
    }
    d->ncx = (int)fmax(1.0, ceil((o->x1 - o->x0) / d->cs));
    d->ncy = (int)fmax(1.0, ceil((o->y1 - o->y0) / d->cs));
    d->ncells = (long)d->ncx * d->ncy;
    long side = 1;
    while (side < d->ncx || side < d->ncy)
        side *= 2;
    int S = d->size;
    d->by_curve = malloc(2 * (size_t)d->ncells * sizeof(long));
    d->owner = calloc((size_t)d->ncells, sizeof(int));
    d->cost = calloc((size_t)d->ncells, sizeof(int64_t));
    d->hs_count = calloc((size_t)S, sizeof(int));
    d->hr_count = calloc((size_t)S, sizeof(int));
    d->hs_off = calloc((size_t)S, sizeof(int));
    d->hr_off = calloc((size_t)S, sizeof(int));
    d->scount = calloc((size_t)S, sizeof(int));
    d->rcount = calloc((size_t)S, sizeof(int));
    d->sdisp = calloc((size_t)S, sizeof(int));
    d->rdisp = calloc((size_t)S, sizeof(int));
    d->mark = calloc((size_t)S + 1, sizeof(int));
    d->req = malloc((2 * (size_t)S + 1) * sizeof(MPI_Request));
    size_t zc = sph_model_dd_zone_cells(m);
    d->zone = zc ? calloc(zc, 1) : NULL;
    if ((zc && !d->zone) || !d->by_curve || !d->owner || !d->cost || !d->hs_count || !d->hr_count || !d->hs_off ||
        !d->hr_off || !d->scount || !d->rcount || !d->sdisp || !d->rdisp || !d->mark || !d->req) {
        dd_free(d);
        return NULL;
    }
    for (long c = 0; c < d->ncells; c++) {
        d->by_curve[2 * c] = hilbert(side, c % d->ncx, c / d->ncx);
        d->by_curve[2 * c + 1] = c;
    }
    qsort(d->by_curve, (size_t)d->ncells, 2 * sizeof(long), cmp_pair);
    for (long c = 0; c < d->ncells; c++)
        d->by_curve[c] = d->by_curve[2 * c + 1];
    d->rowbytes = row_bytes(sph_model_particles(m));
    MPI_Op_create(red_op, 1, &d->op);
    d->hooks.ctx = d;
    d->hooks.exchange = hook_exchange;
    d->hooks.reduce = hook_reduce;
    d->hooks.lead = d->rank == 0;
    sph_model_set_dd(m, &d->hooks);
    return d;
}

void dd_free(dd_ctx *d)
{
    if (!d)
        return;
    if (d->m)
        sph_model_set_dd(d->m, NULL);
    if (d->op != MPI_OP_NULL && d->op != 0)
        MPI_Op_free(&d->op);
    void *bufs[] = {d->by_curve, d->owner, d->cost, d->hs_count, d->hr_count, d->hs_off, d->hr_off,
                    d->hs_ids, d->hr_ids, d->hr_sorted, d->hs_slot, d->hr_slot, d->sbuf, d->rbuf,
                    d->req, d->mark, d->zone, d->pk, d->upk, d->scount, d->rcount, d->sdisp, d->rdisp};
    for (size_t i = 0; i < sizeof bufs / sizeof bufs[0]; i++)
        free(bufs[i]);
    free(d->pairs);
    free(d);
}

static int worst(dd_ctx *d, int rc, sph_status *st)
{
    int w = rc;
    MPI_Allreduce(&rc, &w, 1, MPI_INT, MPI_MAX, d->comm);
    if (w != SPH_STEP_OK && rc == SPH_STEP_OK)
        sph_status_set(st, w, SPH_FAULT_INVALID, -1, "domain decomposition", (double)w, 0.0,
                       "another rank's step failed");
    return w;
}

static double local_hmax(const sph_particles *P)
{
    double h = 0.0;
    for (size_t k = 0; k < P->n; k++)
        h = fmax(h, P->sml[k]);
    return h;
}

/* acc[0] the mass, [1] the count, [2] the snow mass of P; [3 ...] this
 * rank's cumulative sources (core/dd.h) */
#define DD_NACC (3 + SPH_DD_NSRC)
static void mass_count(const sph_model *m, const sph_particles *P, sph_xsum acc[DD_NACC])
{
    const sph_thermo_params *th = &sph_model_params(m)->thermo;
    for (int q = 0; q < 3; q++)
        sph_xsum_clear(&acc[q]);
    for (size_t k = 0; k < P->n; k++) {
        sph_xsum_add(&acc[0], P->mass[k]);
        sph_xsum_add(&acc[1], 1.0);
        sph_xsum_add(&acc[2], sph_particle_snow_mass(th, P, k));
    }
    memcpy(acc + 3, sph_model_dd_sources(m), SPH_DD_NSRC * sizeof *acc);
}

void dd_sources(const dd_ctx *d, sph_budget *b) { sph_dd_budget_sources(b, &d->base, d->gsrc); }

int dd_scatter(dd_ctx *d, const sph_particles *all, const sph_model_clock *c, sph_status *st)
{
    sph_particles *P = sph_model_particles(d->m);
    sph_status_clear(st);
    memset(d->cost, 0, (size_t)d->ncells * sizeof *d->cost);
    size_t np = 0;
    if (d->rank == 0)
        measure_cost(d, all, all->n);
    partition(d);
    if (d->rank == 0) {
        if (grow((void **)&d->pairs, &d->pairs_cap, 2 * (all->n + 1), sizeof(long)))
            return worst(d, SPH_STEP_FATAL, st);
        for (size_t k = 0; k < all->n; k++) {
            d->pairs[2 * np] = d->owner[cell_of(d, all->x[k], all->y[k])];
            d->pairs[2 * np + 1] = (long)k;
            np++;
        }
    }
    P->n = 0;
    long got = exchange_rows(d, d->rank == 0 ? all : P, np, P, NULL);
    sph_model_clock clk;
    if (d->rank == 0)
        clk = *c;
    MPI_Bcast(&clk, (int)sizeof clk, MPI_BYTE, 0, d->comm);
    double s0 = 0.0;
    for (size_t k = 0; k < P->n; k++)
        s0 = fmax(s0, P->sml0[k]);
    MPI_Allreduce(MPI_IN_PLACE, &s0, 1, MPI_DOUBLE, MPI_MAX, d->comm);
    int rc = got < 0 ? SPH_STEP_FATAL : sph_model_resume(d->m, &clk, st);
    if (rc == SPH_STEP_OK)
        sph_model_dd_coast(d->m, s0);
    d->steps = 0;
    sph_xsum acc[DD_NACC];
    double v[1] = {local_hmax(P)};
    mass_count(d->m, P, acc);
    hook_reduce(d, acc, DD_NACC, v, 1);
    d->hmax = v[0];
    d->gmass = d->gmass0 = sph_xsum_value(&acc[0]);
    d->gcount = sph_xsum_value(&acc[1]);
    d->gsnow0 = sph_xsum_value(&acc[2]);
    memcpy(d->gsrc, acc + 3, sizeof d->gsrc);
    d->base = clk.budget;
    dd_reset_stats(d);
    return worst(d, rc, st);
}

int dd_step(dd_ctx *d, sph_status *st)
{
    sph_model *m = d->m;
    sph_particles *P = sph_model_particles(m);
    sph_status_clear(st);
    /* the halo depth in kernel supports (docs/domain.md, "Halo depth"):
     * an owned particle's divergence reads its neighbours' stress (depth
     * 1), computed here from their density, loose flag and strain rates,
     * which read their own neighbours (depth 2); with the gradient
     * correction also their neighbours' correction matrices, which read
     * the densities one support further (depth 3). Measured: 2 supports
     * bit-identical in test_mpi_dd and test_mpi_run, 1.5 not. A neighbour
     * may be a mirror ghost, whose source (the particle read) lies up to
     * sph_model_dd_ghost_reach() supports beyond it when the reader is on
     * the far side of the wall: within `depth` supports of land (a ghost
     * source is within one support of it, and `depth` - 1 plain hops
     * follow) the halo reaches depth x (1 + reach) supports. */
    const double depth = sph_model_params(m)->gradient_correction ? 3.0 : 2.0;
    const double S = sph_model_kernel_radius(m) * d->hmax;
    double H = depth * S, Hc = depth * (1.0 + sph_model_dd_ghost_reach()) * S;
    if (d->zone && !(d->zone_r >= depth * S)) {
        d->zone_r = 1.25 * depth * S; /* hmax grows slowly: marked again rarely */
        sph_model_dd_zone(m, d->zone_r, d->zone);
    }
    if (d->o.rebalance_every > 0 && d->steps > 0 && d->steps % d->o.rebalance_every == 0) {
        measure_cost(d, P, P->n);
        partition(d);
    }
    if (migrate(d) || build_halo(d, H, Hc)) {
        fprintf(stderr, "sphice: domain decomposition: out of memory or capacity on rank %d "
                        "(%zu particles, capacity %zu)\n", d->rank, P->n, P->cap);
        MPI_Abort(d->comm, 3);
    }
    int rc = sph_model_step(m, st);
    for (size_t k = P->n; k-- > 0;)
        if (is_halo(d, P->id[k]))
            sph_particles_remove(P, k);
    d->steps++;
    d->stats.owned = (long)P->n;
    d->stats.ghosts_merging |= sph_model_ghosts_merging(m);
    /* the worst status, the next step's halo width and the global mass
     * and count (exact), in one reduction */
    sph_xsum acc[DD_NACC];
    double v[2] = {(double)rc, local_hmax(P)};
    mass_count(m, P, acc);
    hook_reduce(d, acc, DD_NACC, v, 2);
    memcpy(d->gsrc, acc + 3, sizeof d->gsrc);
    d->hmax = v[1];
    int w = (int)v[0];
    if (w != SPH_STEP_OK && rc == SPH_STEP_OK)
        sph_status_set(st, w, SPH_FAULT_INVALID, -1, "domain decomposition", (double)w, 0.0,
                       "another rank's step failed");
    /* the dynamics never changes mass: with no particle removed (open
     * boundary) and no thermodynamics the global sum stays exactly */
    double gm = sph_xsum_value(&acc[0]), gc = sph_xsum_value(&acc[1]);
    const sph_params *p = sph_model_params(m);
    int thermo = p->thermo_dt > 0.0 && p->thermo.model != SPH_THERMO_OFF;
    if (w == SPH_STEP_OK && !thermo && gc == d->gcount && gm != d->gmass)
        w = sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_MASS, -1, "total mass", gm, d->gmass,
                           "changed with no source or sink to explain it (domain decomposition)");
    /* with sources (thermodynamics, open boundaries): the serial core's
     * rule (model.c check_health), on the global exact sums: mass = initial
     * + sources within model.mass_tolerance of the scale */
    sph_budget bb = d->base;
    sph_dd_budget_sources(&bb, &d->base, d->gsrc);
    bb.mass_initial = d->gmass0;
    bb.mass = gm;
    bb.snow_initial = d->gsnow0;
    bb.snow = sph_xsum_value(&acc[2]);
    double expect = sph_budget_expected(&bb);
    double scale = fmax(fmax(fabs(expect), fabs(gm)), bb.mass_initial + bb.growth + bb.new_ice);
    double sexp = sph_budget_snow_expected(&bb);
    double sscale = fmax(fmax(fabs(sexp), fabs(bb.snow)), bb.snow_initial + bb.snowfall);
    if (w == SPH_STEP_OK && !(fabs(gm - expect) <= p->mass_tolerance * scale + 1e-300))
        w = sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_MASS, -1, "total mass", gm, expect,
                           "changed beyond round-off with no source or sink to explain it (domain "
                           "decomposition)");
    if (w == SPH_STEP_OK && !(fabs(bb.snow - sexp) <= p->mass_tolerance * sscale + 1e-300))
        w = sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_MASS, -1, "total snow mass", bb.snow, sexp,
                           "changed beyond round-off with no source or sink to explain it (domain "
                           "decomposition)");
    d->gmass = gm;
    d->gcount = gc;
    return w;
}

void dd_run_stats(dd_ctx *d, dd_stats *out)
{
    long l[5] = {d->stats.owned, d->stats.halo, d->stats.migrated, d->stats.iterations,
                 d->stats.ghosts_merging};
    long g[5];
    MPI_Allreduce(l, g, 5, MPI_LONG, MPI_SUM, d->comm);
    double b[2] = {d->stats.halo_bytes, d->stats.migrate_bytes}, wt[3] = {d->stats.wait_s, -d->stats.wait_s,
                                                                       d->stats.reduce_s};
    MPI_Allreduce(MPI_IN_PLACE, b, 2, MPI_DOUBLE, MPI_SUM, d->comm);
    MPI_Allreduce(MPI_IN_PLACE, wt, 3, MPI_DOUBLE, MPI_MAX, d->comm);
    long mx = d->stats.owned;
    MPI_Allreduce(MPI_IN_PLACE, &mx, 1, MPI_LONG, MPI_MAX, d->comm);
    out->owned = g[0];
    out->halo = g[1];
    out->migrated = g[2];
    out->iterations = g[3] / d->size; /* every rank counts each refresh */
    out->ghosts_merging = g[4] > 0;
    out->halo_bytes = b[0];
    out->migrate_bytes = b[1];
    out->owned_max = mx;
    out->wait_s = wt[0];
    out->wait_min_s = -wt[1];
    out->reduce_s = wt[2];
}

void dd_set_overlap(dd_ctx *d, int on) { d->hooks.no_overlap = !on; }

void dd_reset_stats(dd_ctx *d) { memset(&d->stats, 0, sizeof d->stats); }

static void budget_acc(const sph_particles *P, size_t n, double rho_i, sph_xsum acc[6])
{
    for (int q = 0; q < 6; q++)
        sph_xsum_clear(&acc[q]);
    for (size_t k = 0; k < n; k++) {
        double mk = P->mass[k];
        sph_xsum_add(&acc[0], mk);
        sph_xsum_add(&acc[1], mk / (rho_i * P->thick[k]));
        sph_xsum_add(&acc[2], mk / rho_i);
        sph_xsum_add(&acc[3], mk * P->u[k]);
        sph_xsum_add(&acc[4], mk * P->v[k]);
        sph_xsum_add(&acc[5], 0.5 * mk * (P->u[k] * P->u[k] + P->v[k] * P->v[k]));
    }
}

static void budget_out(const sph_xsum acc[6], dd_budget *b)
{
    b->mass = sph_xsum_value(&acc[0]);
    b->area = sph_xsum_value(&acc[1]);
    b->volume = sph_xsum_value(&acc[2]);
    b->momentum_x = sph_xsum_value(&acc[3]);
    b->momentum_y = sph_xsum_value(&acc[4]);
    b->kinetic_energy = sph_xsum_value(&acc[5]);
}

void dd_budget_of(const sph_particles *P, size_t n, double rho_i, dd_budget *b)
{
    sph_xsum acc[6];
    budget_acc(P, n, rho_i, acc);
    budget_out(acc, b);
}

void dd_budget_global(dd_ctx *d, dd_budget *b)
{
    const sph_particles *P = sph_model_particles(d->m);
    sph_xsum acc[6];
    budget_acc(P, P->n, sph_model_params(d->m)->rho_i, acc);
    hook_reduce(d, acc, 6, NULL, 0);
    budget_out(acc, b);
}

int dd_gather(dd_ctx *d, sph_particles *out)
{
    const sph_particles *P = sph_model_particles(d->m);
    int n = (int)P->n, S = d->size;
    if (grow((void **)&d->pk, &d->pk_cap, ((size_t)n + 1) * d->rowbytes, 1))
        return -1;
    for (int k = 0; k < n; k++)
        pack_row(P, (size_t)k, d->pk + (size_t)k * d->rowbytes);
    int nb = n * (int)d->rowbytes;
    int *cnt = calloc((size_t)S * 2, sizeof(int));
    if (!cnt)
        return -1;
    MPI_Gather(&nb, 1, MPI_INT, cnt, 1, MPI_INT, 0, d->comm);
    long tot = 0;
    if (d->rank == 0)
        for (int r = 0; r < S; r++) {
            cnt[S + r] = (int)tot;
            tot += cnt[r];
        }
    int rc = 0;
    if (d->rank == 0 && (grow((void **)&d->upk, &d->upk_cap, (size_t)tot + 1, 1) ||
                         (size_t)tot / d->rowbytes > out->cap))
        rc = -1;
    MPI_Bcast(&rc, 1, MPI_INT, 0, d->comm);
    if (rc) {
        free(cnt);
        return -1;
    }
    MPI_Gatherv(d->pk, nb, MPI_BYTE, d->upk, cnt, cnt + S, MPI_BYTE, 0, d->comm);
    if (d->rank == 0) {
        size_t np = (size_t)tot / d->rowbytes;
        for (size_t k = 0; k < np; k++)
            unpack_row(out, k, d->upk + k * d->rowbytes);
        out->n = np;
        dd_sort_by_id(out);
    }
    free(cnt);
    return 0;
}

#endif

#include <stdlib.h>

/* In both builds: the serial canonical run of parallel.decomposition "domain"
 * writes its products from particles in this order too (forecast_domain.c). */
static int cmp_id(const void *a, const void *b)
{
    long x = *(const long *)a, y = *(const long *)b;
    return (x > y) - (x < y);
}

void dd_sort_by_id(sph_particles *P)
{
    size_t n = P->n;
    long *pr = malloc((2 * n + 2) * sizeof(long));
    int *order = malloc((n + 1) * sizeof(int));
    double *scratch = malloc((n + 1) * (size_t)P->nlayers * sizeof(double));
    if (pr && order && scratch) {
        for (size_t k = 0; k < n; k++) {
            pr[2 * k] = P->id[k];
            pr[2 * k + 1] = (long)k;
        }
        qsort(pr, n, 2 * sizeof(long), cmp_id);
        for (size_t k = 0; k < n; k++)
            order[k] = (int)pr[2 * k + 1];
        sph_particles_permute(P, order, scratch);
    }
    free(pr);
    free(order);
    free(scratch);
}

