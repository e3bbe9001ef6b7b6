/* Neighbour search: a cell grid with particles counting-sorted by cell
 * (row-major cell order), O(N) per build. The seed's point-by-point O(N^2)
 * search (sph_nbr_build_brute) is kept only as the reference for tests
 * and benchmarks.
 *
 * Lists are per query particle, in a fixed order (cells scanned in a fixed
 * order, particles within a cell by index), so every sum over neighbours
 * is deterministic whatever the thread count.
 *
 * Ordering rules (every pass that sums over a list relies on them; a
 * domain decomposition that must reproduce them needs the same keys):
 *   1. cells are numbered row-major, c = cy * ncx + cx, from the grid's
 *      origin (the particles' minimum x, y) and cell size;
 *   2. sph_nbr_grid sorts particles by cell with a stable counting sort:
 *      within a cell, ascending particle index;
 *   3. a query's list visits the 3 x 3 cells around its own in the order
 *      (cy-1, cx-1), (cy-1, cx), (cy-1, cx+1), (cy, cx-1), ... (cy+1, cx+1)
 *      and each cell's particles in the order of rule 2; the query itself
 *      is one of them (self pair, W(0));
 *   4. the model calls sph_reorder before each build, so particle index
 *      order is cell order of the previous reorder: the index a particle
 *      has (and so its place within a cell) depends on its history, not
 *      on its id; a decomposition-independent order would key rule 2 on
 *      (global cell, particle id) instead;
 *   5. nothing depends on the thread count: threads split the query
 *      particles into contiguous blocks and each list is built whole by
 *      one thread; the passes (operators.c) sum each particle's list in
 *      list order (two particles at a time in vector lanes, each lane in
 *      its own list's order).
 * Per pair the kernel value
 * W_kj and gradient grad_k W_kj are cached (positions do not move within
 * a dynamic step, so the solver iterations reuse them). The gradient is
 * stored as its two components (16 bytes per pair), or with `factor`
 * (model.compact_gradients) as its scalar factor F_kj alone (grad_k W_kj
 * = F_kj (x_k - x_j)) beside the build's positions (xy): sph_nbr_grad
 * then forms F * dx and F * dy, the build's own operations on the same
 * operands, so the same bits as the stored components, in 8 bytes per
 * pair plus 16 per particle (memory at 1e6 particles; the passes do two
 * more products and a gathered position per pair).
 *
 * Storage: particle k's pairs are the slots off[k] .. off[k] + count[k] - 1.
 * Lists are packed one after another within each thread's block of query
 * particles (a block of m particles owns m * max_nb slots), so the solver
 * passes stream through memory; which slots a list occupies depends on
 * the thread count, its contents and order do not.
 *
 * All memory is allocated by sph_nbr_create; builds allocate nothing.
 */
#ifndef SPHICE_CORE_NEIGHBOURS_H
#define SPHICE_CORE_NEIGHBOURS_H

#include <stddef.h>
#include "core/kernel.h"

typedef struct sph_nbr {
    size_t cap;      /* query particles the lists can hold */
    size_t cap_all;  /* particles the grid can hold (query + ghosts) */
    int max_nb;      /* list capacity per particle */
    int *count;      /* [cap] neighbours of each query particle (self included) */
    size_t *off;     /* [cap] first slot of each query particle's list */
    int *idx;        /* [cap * max_nb] */
    double *w;       /* [cap * max_nb] W_kj, written only while keep_w */
    /* 1 (sph_nbr_create's default): builds store W_kj; 0: they do not, and
     * w's pages are never touched (the model clears it where no pass reads
     * W: without summation density and the collision rheology's v';
     * 8 bytes per pair, 112 MB at 1.25e6 particles) */
    int keep_w;
    /* [cap * max_nb] grad_k W_kj: gx, gy its components; with factor, gx
     * holds F_kj (sph_kernel_eval's F at the pair's r^2 and smoothing
     * length) and gy is not used (its pages never touched). Read them
     * through sph_nbr_grad. */
    double *gx, *gy;
    /* set by the caller before a build (the model: model.compact_gradients),
     * read by the passes: the form of the last build's gradients */
    int factor;
    /* [2 * cap_all] with factor: the last build's positions (x_j, y_j) of
     * every gridded particle, interleaved, 16-byte aligned: the dx, dy of
     * the gradients (the passes after a move still use the build's) */
    double *xy;
    size_t nxy;      /* particles gridded by the last sph_nbr_grid */
    /* cell grid of the last build */
    size_t max_cells;
    size_t ncells;
    int ncx, ncy;
    double x0, y0, cell;
    int *cell_start;   /* [max_cells + 1] */
    int *sorted;       /* [cap] particle indices in cell order */
    int *cell_of;      /* [cap] */
    long pairs;        /* total pairs of the last build */
    size_t lead;       /* slots [0, lead) written by the last build (the first thread block's) */
    /* [cap_all * 4] a per-particle record the passes fill and gather
     * through the lists (operators.c: the stress divergence's S / M^2 and
     * mass), in particle order; 32-byte aligned, one cache line each */
    double *pk;
} sph_nbr;

/* grad_k W_kj of slot s (k's list, s = off[k] + q, j = idx[s]): the
 * build's F * (x_k - x_j) and F * (y_k - y_j), the same operations on the
 * same operands as the build (add_pair), so the same bits; without
 * factor the stored components. */
static inline void sph_nbr_grad(const sph_nbr *nb, size_t k, size_t j, size_t s, double *gx,
                                double *gy)
{
    if (nb->factor) {
        const double F = nb->gx[s];
        *gx = F * (nb->xy[2 * k] - nb->xy[2 * j]);
        *gy = F * (nb->xy[2 * k + 1] - nb->xy[2 * j + 1]);
    } else {
        *gx = nb->gx[s];
        *gy = nb->gy[s];
    }
}

/* Lists for up to cap_query particles among up to cap_all gridded ones. */
sph_nbr *sph_nbr_create(size_t cap_query, size_t cap_all, int max_nb);
void sph_nbr_free(sph_nbr *nb);

/* Sorts particles [0, n) into cells of size >= cell; fills the grid. */
void sph_nbr_grid(sph_nbr *nb, size_t n, const double *x, const double *y, double cell);

/* Builds lists for query particles [0, nq) among all gridded particles
 * [0, n) (call sph_nbr_grid first with a cell >= the largest support).
 * Pair smoothing length is (h_k + h_j) / 2. Returns 0, or 1 with
 * *overflow = the first particle whose list would exceed max_nb. */
int sph_nbr_build(sph_nbr *nb, const sph_kernel *k, size_t nq, const double *x,
                  const double *y, const double *h, long *overflow);

/* The O(N^2) reference: same lists (order by index), no grid needed. */
int sph_nbr_build_brute(sph_nbr *nb, const sph_kernel *k, size_t nq, size_t n,
                        const double *x, const double *y, const double *h, long *overflow);

/* Candidate particles near point (px, py): those in the 3x3 cells around
 * it (the caller filters by distance). Returns the number written (at
 * most max); uses the grid of the last sph_nbr_grid. */
int sph_nbr_candidates(const sph_nbr *nb, double px, double py, int *out, int max);

#endif
