#include "core/neighbours.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <omp.h>

sph_nbr *sph_nbr_create(size_t cap, size_t cap_all, int max_nb)
{
    if (cap_all < cap)
        cap_all = cap;
    sph_nbr *nb = calloc(1, sizeof *nb);
    if (!nb)
        return NULL;
    nb->cap = cap;
    nb->max_nb = max_nb;
    nb->cap_all = cap_all;
    nb->keep_w = 1;
    nb->max_cells = 4 * cap_all + 64;
    size_t pairs = cap * (size_t)max_nb;
    nb->count = calloc(cap, sizeof(int));
    nb->off = calloc(cap ? cap : 1, sizeof(size_t));
    nb->idx = malloc(pairs * sizeof(int));
    nb->w = malloc(pairs * sizeof(double));
    nb->gx = malloc(pairs * sizeof(double));
    nb->gy = malloc(pairs * sizeof(double));
    nb->xy = aligned_alloc(16, (cap_all ? cap_all : 1) * 2 * sizeof(double));
    nb->cell_start = calloc(nb->max_cells + 1, sizeof(int));
    nb->sorted = calloc(cap_all, sizeof(int));
    nb->cell_of = calloc(cap_all, sizeof(int));
    /* pages touched only as slots come into use (memory at 1e6 particles) */
    nb->pk = aligned_alloc(32, (cap_all ? cap_all : 1) * 4 * sizeof(double));
    if (!nb->count || !nb->off || !nb->idx || !nb->w || !nb->gx || !nb->gy || !nb->xy || !nb->cell_start ||
        !nb->sorted || !nb->cell_of || !nb->pk) {
        sph_nbr_free(nb);
        return NULL;
    }
    return nb;
}

void sph_nbr_free(sph_nbr *nb)
{
    if (!nb)
        return;
    free(nb->count);
    free(nb->off);
    free(nb->idx);
    free(nb->w);
    free(nb->gx);
    free(nb->gy);
    free(nb->xy);
    free(nb->cell_start);
    free(nb->sorted);
    free(nb->cell_of);
    free(nb->pk);
    free(nb);
}

void sph_nbr_grid(sph_nbr *nb, size_t n, const double *x, const double *y, double cell)
{
    double xmin = HUGE_VAL, ymin = HUGE_VAL, xmax = -HUGE_VAL, ymax = -HUGE_VAL;
    for (size_t i = 0; i < n; i++) {
        xmin = fmin(xmin, x[i]);
        xmax = fmax(xmax, x[i]);
        ymin = fmin(ymin, y[i]);
        ymax = fmax(ymax, y[i]);
    }
    if (n == 0) {
        xmin = ymin = 0.0;
        xmax = ymax = 1.0;
    }
    if (!(cell > 0.0))
        cell = 1.0;
    /* Coarsen until the grid fits the preallocated cell table. */
    for (;;) {
        double fx = floor((xmax - xmin) / cell) + 1.0, fy = floor((ymax - ymin) / cell) + 1.0;
        if (fx * fy <= (double)nb->max_cells) {
            nb->ncx = (int)fx;
            nb->ncy = (int)fy;
            break;
        }
        cell *= 1.5;
    }
    nb->x0 = xmin;
    nb->y0 = ymin;
    nb->nxy = n;
    nb->cell = cell;
    nb->ncells = (size_t)nb->ncx * (size_t)nb->ncy;
    int *start = nb->cell_start;
    memset(start, 0, (nb->ncells + 1) * sizeof(int));
    for (size_t i = 0; i < n; i++) {
        int cx = (int)((x[i] - xmin) / cell), cy = (int)((y[i] - ymin) / cell);
        if (cx >= nb->ncx) cx = nb->ncx - 1;
        if (cy >= nb->ncy) cy = nb->ncy - 1;
        int c = cy * nb->ncx + cx;
        nb->cell_of[i] = c;
        start[c + 1]++;
    }
    for (size_t c = 0; c < nb->ncells; c++)
        start[c + 1] += start[c];
    /* Stable counting sort: within a cell, particles stay in index order.
     * cell_of is reused as the running insertion cursor's source. */
    for (size_t i = 0; i < n; i++) {
        int c = nb->cell_of[i];
        nb->sorted[start[c]++] = (int)i;
    }
    /* start[c] now holds the end of cell c: shift back to starts. */
    for (size_t c = nb->ncells; c > 0; c--)
        start[c] = start[c - 1];
    start[0] = 0;
}

/* The calling thread's block of query particles [*q0, *q1) (the static
 * schedule's contiguous split) and the first slot of its storage: the
 * block owns max_nb slots per particle, so its lists, packed one after
 * another, never reach the next block's. Outside a parallel region the
 * block is everything. */
static void block_range(const sph_nbr *nb, size_t nq, size_t *q0, size_t *q1, size_t *slot)
{
    size_t nth = (size_t)omp_get_num_threads(), t = (size_t)omp_get_thread_num();
    size_t chunk = nq / nth, rem = nq % nth;
    *q0 = t * chunk + (t < rem ? t : rem);
    *q1 = *q0 + chunk + (t < rem ? 1 : 0);
    *slot = *q0 * (size_t)nb->max_nb;
}

/* With factor, the build's positions of the n gridded particles into
 * nb->xy (inside the build's parallel region: a worksharing loop, its
 * barrier before the lists). */
static void keep_positions(sph_nbr *nb, size_t n, const double *x, const double *y)
{
    if (!nb->factor)
        return;
    double *restrict xy = nb->xy;
#pragma omp for schedule(static)
    for (size_t i = 0; i < n; i++) {
        xy[2 * i] = x[i];
        xy[2 * i + 1] = y[i];
    }
}

static inline void add_pair(sph_nbr *nb, const sph_kernel *k, size_t q, int j, const double *x,
                            const double *y, const double *h, size_t base, int *cnt, int *over)
{
    double dx = x[q] - x[j], dy = y[q] - y[j];
    double r2 = dx * dx + dy * dy;
    double hh = 0.5 * (h[q] + h[j]);
    double R = k->radius * hh;
    if (r2 >= R * R)
        return;
    if (*cnt >= nb->max_nb) {
        *over = 1;
        return;
    }
    double W, F;
    sph_kernel_eval(k, r2, hh, &W, &F);
    size_t s = base + (size_t)*cnt;
    nb->idx[s] = j;
    if (nb->keep_w)
        nb->w[s] = W;
    if (nb->factor) {
        nb->gx[s] = F; /* grad = (F * dx, F * dy): sph_nbr_grad */
    } else {
        nb->gx[s] = F * dx;
        nb->gy[s] = F * dy;
    }
    (*cnt)++;
}

/* A query's list is complete: its count, the next query's offset, the
 * pair total, and the first query that overflowed its capacity. */
static inline void end_query(sph_nbr *nb, size_t q, int cnt, int over, size_t *cursor, long *pairs,
                             long *first_over)
{
    nb->count[q] = cnt;
    *cursor += (size_t)cnt;
    *pairs += cnt;
    if (over) {
#pragma omp critical(sph_nbr_over)
        if (*first_over < 0 || (long)q < *first_over)
            *first_over = (long)q;
    }
}

static int end_build(sph_nbr *nb, long pairs, long first_over, long *overflow)
{
    nb->pairs = pairs;
    if (overflow)
        *overflow = first_over;
    return first_over >= 0;
}

int sph_nbr_build(sph_nbr *nb, const sph_kernel *k, size_t nq, const double *x,
                  const double *y, const double *h, long *overflow)
{
    long first_over = -1;
    long pairs = 0;
    const size_t nxy = nb->nxy;
#pragma omp parallel reduction(+ : pairs) if (nq >= 4096)
    {
    keep_positions(nb, nxy, x, y);
    size_t q0, q1, cursor;
    block_range(nb, nq, &q0, &q1, &cursor);
    for (size_t q = q0; q < q1; q++) {
        int cx = (int)((x[q] - nb->x0) / nb->cell), cy = (int)((y[q] - nb->y0) / nb->cell);
        int cnt = 0, over = 0;
        nb->off[q] = cursor;
        for (int oy = -1; oy <= 1; oy++) {
            int yy = cy + oy;
            if (yy < 0 || yy >= nb->ncy)
                continue;
            for (int ox = -1; ox <= 1; ox++) {
                int xx = cx + ox;
                if (xx < 0 || xx >= nb->ncx)
                    continue;
                int c = yy * nb->ncx + xx;
                for (int s = nb->cell_start[c]; s < nb->cell_start[c + 1]; s++)
                    add_pair(nb, k, q, nb->sorted[s], x, y, h, cursor, &cnt, &over);
            }
        }
        end_query(nb, q, cnt, over, &cursor, &pairs, &first_over);
    }
    if (omp_get_thread_num() == 0)
        nb->lead = cursor;
    }
    return end_build(nb, pairs, first_over, overflow);
}

int sph_nbr_build_brute(sph_nbr *nb, const sph_kernel *k, size_t nq, size_t n,
                        const double *x, const double *y, const double *h, long *overflow)
{
    long first_over = -1;
    long pairs = 0;
    nb->nxy = n;
#pragma omp parallel reduction(+ : pairs)
    {
    keep_positions(nb, n, x, y);
    size_t q0, q1, cursor;
    block_range(nb, nq, &q0, &q1, &cursor);
    for (size_t q = q0; q < q1; q++) {
        int cnt = 0, over = 0;
        nb->off[q] = cursor;
        for (size_t j = 0; j < n; j++)
            add_pair(nb, k, q, (int)j, x, y, h, cursor, &cnt, &over);
        end_query(nb, q, cnt, over, &cursor, &pairs, &first_over);
    }
    if (omp_get_thread_num() == 0)
        nb->lead = cursor;
    }
    return end_build(nb, pairs, first_over, overflow);
}

int sph_nbr_candidates(const sph_nbr *nb, double px, double py, int *out, int max)
{
    int cx = (int)floor((px - nb->x0) / nb->cell), cy = (int)floor((py - nb->y0) / nb->cell);
    int n = 0;
    for (int yy = cy - 1; yy <= cy + 1; yy++) {
        if (yy < 0 || yy >= nb->ncy)
            continue;
        for (int xx = cx - 1; xx <= cx + 1; xx++) {
            if (xx < 0 || xx >= nb->ncx)
                continue;
            int c = yy * nb->ncx + xx;
            for (int s = nb->cell_start[c]; s < nb->cell_start[c + 1] && n < max; s++)
                out[n++] = nb->sorted[s];
        }
    }
    return n;
}
