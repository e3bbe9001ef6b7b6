/* The ocean-fluxes file on a curvilinear ocean grid (OFX_GRID_CURV,
 * io/ocean_fluxes.h, docs/ocean-coupling.md): each cell is the polygon of
 * its four corners on the model plane; a particle's footprint, the disc
 * of area pi R^2 / 3 that the gridding kernel integrates to, drawn as a
 * regular 32-gon of that area, is clipped to each cell polygon near it
 * (Sutherland-Hodgman against the convex footprint), and the overlaps
 * with the water cells, normalised to 1 (the rounding remainder to the
 * largest), are the particle's weights. The grid's i axis on the plane,
 * per cell, turns the plane stress to the grid's own i/j components. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ocean_fluxes_impl.h"

#define NFOOT 32       /* vertices of a footprint */
#define MAXV (NFOOT + 8) /* vertices of a clipped cell: at most 4 + NFOOT */
#define MAX_SKEW_DEG 10.0 /* the j axis within this of 90 degrees anticlockwise from i */

void ofxc_free(ofx_writer *w)
{
    free(w->bx);
    free(w->by);
    free(w->blon);
    free(w->blat);
    free(w->beta);
    free(w->alpha);
    free(w->cbstart);
    free(w->cbcell);
    free(w->seen);
}

static int corners_on_plane(const ofx_writer *w, size_t c)
{
    for (int v = 0; v < 4; v++)
        if (!isfinite(w->bx[4 * c + v]) || !isfinite(w->by[4 * c + v]))
            return 0;
    return isfinite(w->cx[c]) && isfinite(w->cy[c]);
}

/* Signed area of a polygon (shoelace), anticlockwise positive. */
static double poly_area(const double *x, const double *y, int n)
{
    double s = 0.0;
    for (int k = 0, m = n - 1; k < n; m = k++)
        s += x[m] * y[k] - x[k] * y[m];
    return 0.5 * s;
}

/* Direction (angle on the plane) from centre a to centre b, or from the
 * cell's own edge midpoints when a neighbour is missing. */
static double axis_angle(const ofx_writer *w, size_t c, int along_i)
{
    size_t i = c % (size_t)w->nx, j = c / (size_t)w->nx;
    size_t lo = c, hi = c;
    if (along_i) {
        if (i > 0 && isfinite(w->cx[c - 1]) && isfinite(w->cy[c - 1]))
            lo = c - 1;
        if (i + 1 < (size_t)w->nx && isfinite(w->cx[c + 1]) && isfinite(w->cy[c + 1]))
            hi = c + 1;
    } else {
        if (j > 0 && isfinite(w->cx[c - (size_t)w->nx]) && isfinite(w->cy[c - (size_t)w->nx]))
            lo = c - (size_t)w->nx;
        if (j + 1 < (size_t)w->ny && isfinite(w->cx[c + (size_t)w->nx]) && isfinite(w->cy[c + (size_t)w->nx]))
            hi = c + (size_t)w->nx;
    }
    if (lo != hi)
        return atan2(w->cy[hi] - w->cy[lo], w->cx[hi] - w->cx[lo]);
    /* corners 0 (i-, j-), 1 (i+, j-), 2 (i+, j+), 3 (i-, j+) */
    const double *X = w->bx + 4 * c, *Y = w->by + 4 * c;
    if (along_i)
        return atan2(Y[1] + Y[2] - Y[0] - Y[3], X[1] + X[2] - X[0] - X[3]);
    return atan2(Y[2] + Y[3] - Y[0] - Y[1], X[2] + X[3] - X[0] - X[1]);
}

int ofxc_setup(ofx_writer *w, const ofx_grid *g, sph_error *err)
{
    size_t n = w->n, b4 = 4 * n * sizeof(double);
    int ok = (w->bx = malloc(b4)) != NULL;
    ok &= (w->by = malloc(b4)) != NULL;
    ok &= (w->blon = malloc(b4)) != NULL;
    ok &= (w->blat = malloc(b4)) != NULL;
    ok &= (w->beta = calloc(n, sizeof(double))) != NULL;
    ok &= (w->alpha = calloc(n, sizeof(double))) != NULL;
    ok &= (w->seen = calloc(n, sizeof(size_t))) != NULL;
    if (!ok)
        return sph_err_set(err, SPH_ERR_NOMEM, "ocean fluxes %s: out of memory (%zu cells)", w->path, n);
    memcpy(w->bx, g->bx, b4);
    memcpy(w->by, g->by, b4);
    memcpy(w->blon, g->blon, b4);
    memcpy(w->blat, g->blat, b4);
    const char *src = g->grid_source ? g->grid_source : "the ocean grid";
    double side = 0.0, x0 = HUGE_VAL, x1 = -HUGE_VAL, y0 = HUGE_VAL, y1 = -HUGE_VAL;
    size_t nin = 0;
    for (size_t c = 0; c < n; c++) {
        if (!corners_on_plane(w, c)) {
            w->cx[c] = w->cy[c] = NAN; /* never reached */
            continue;
        }
        double a = poly_area(w->bx + 4 * c, w->by + 4 * c, 4);
        if (!(a > 0.0))
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ocean fluxes: %s: cell (i %zu, j %zu): its corners (%s) are not anticlockwise "
                               "on the plane (a left-handed or folded grid): set output.ocean_fluxes_grid to "
                               "\"output\"", src, c % (size_t)w->nx, c / (size_t)w->nx, g->corners);
        side += sqrt(a);
        nin++;
        for (int v = 0; v < 4; v++) {
            x0 = fmin(x0, w->bx[4 * c + v]);
            x1 = fmax(x1, w->bx[4 * c + v]);
            y0 = fmin(y0, w->by[4 * c + v]);
            y1 = fmax(y1, w->by[4 * c + v]);
        }
    }
    for (size_t c = 0; c < n; c++) {
        if (!isfinite(w->cx[c]))
            continue;
        double bi = axis_angle(w, c, 1), bj = axis_angle(w, c, 0), d = bj - bi;
        if (!(sin(d) >= cos(MAX_SKEW_DEG * M_PI / 180.0)))
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ocean fluxes: %s: cell (i %zu, j %zu): the grid's j axis is %.1f degrees from its "
                               "i axis (an orthogonal, right-handed grid has +90): the stress components along "
                               "the grid's axes are not defined: set output.ocean_fluxes_grid to \"output\"",
                               src, c % (size_t)w->nx, c / (size_t)w->nx,
                               remainder(d, 2.0 * M_PI) * 180.0 / M_PI);
        w->beta[c] = bi;
        w->alpha[c] = remainder(bi + (g->east ? g->east[c] : 0.0), 2.0 * M_PI);
    }
    /* cells binned by their boxes, bins ~ a mean cell */
    w->cbin = nin ? side / (double)nin : 1.0;
    if (!nin)
        x0 = x1 = y0 = y1 = 0.0;
    w->cbx0 = x0;
    w->cby0 = y0;
    ofx_fit_bins(x1 - x0, y1 - y0, n, &w->cbin, &w->cnbx, &w->cnby);
    size_t nb = (size_t)w->cnbx * (size_t)w->cnby;
    w->cbstart = calloc(nb + 1, sizeof *w->cbstart);
    if (!w->cbstart)
        return sph_err_set(err, SPH_ERR_NOMEM, "ocean fluxes %s: out of memory (cell index)", w->path);
    for (int pass = 0; pass < 2; pass++) {
        size_t *fill = pass ? calloc(nb ? nb : 1, sizeof *fill) : NULL;
        if (pass && (!fill || !(w->cbcell = malloc((w->cbstart[nb] ? w->cbstart[nb] : 1) * sizeof *w->cbcell)))) {
            free(fill);
            return sph_err_set(err, SPH_ERR_NOMEM, "ocean fluxes %s: out of memory (cell index)", w->path);
        }
        for (size_t c = 0; c < n; c++) { /* cells in index order: deterministic sums */
            if (!isfinite(w->cx[c]))
                continue;
            double ax = HUGE_VAL, bx = -HUGE_VAL, ay = HUGE_VAL, by = -HUGE_VAL;
            for (int v = 0; v < 4; v++) {
                ax = fmin(ax, w->bx[4 * c + v]);
                bx = fmax(bx, w->bx[4 * c + v]);
                ay = fmin(ay, w->by[4 * c + v]);
                by = fmax(by, w->by[4 * c + v]);
            }
            int i0 = (int)((ax - x0) / w->cbin), i1 = (int)((bx - x0) / w->cbin);
            int j0 = (int)((ay - y0) / w->cbin), j1 = (int)((by - y0) / w->cbin);
            i1 = i1 >= w->cnbx ? w->cnbx - 1 : i1;
            j1 = j1 >= w->cnby ? w->cnby - 1 : j1;
            for (int j = j0; j <= j1; j++)
                for (int i = i0; i <= i1; i++) {
                    size_t b = (size_t)j * w->cnbx + i;
                    if (pass)
                        w->cbcell[w->cbstart[b] + fill[b]++] = c;
                    else
                        w->cbstart[b + 1]++;
                }
        }
        if (!pass)
            for (size_t b = 0; b < nb; b++)
                w->cbstart[b + 1] += w->cbstart[b];
        free(fill);
    }
    return SPH_OK;
}

/* The part of polygon (x, y, n) inside the convex anticlockwise polygon
 * (cxs, cys, m): its area (>= 0). */
static double clip_area(const double *x, const double *y, int n, const double *cxs, const double *cys, int m)
{
    double ax[MAXV], ay[MAXV], bx[MAXV], by[MAXV];
    int na = n;
    memcpy(ax, x, (size_t)n * sizeof *x);
    memcpy(ay, y, (size_t)n * sizeof *y);
    for (int e = 0; e < m && na > 0; e++) {
        double ex = cxs[e], ey = cys[e], fx = cxs[(e + 1) % m] - ex, fy = cys[(e + 1) % m] - ey;
        int nb = 0;
        for (int k = 0; k < na; k++) {
            int q = (k + 1) % na;
            double sp = fx * (ay[k] - ey) - fy * (ax[k] - ex), sq = fx * (ay[q] - ey) - fy * (ax[q] - ex);
            if (sp >= 0.0 && nb < MAXV) {
                bx[nb] = ax[k];
                by[nb++] = ay[k];
            }
            if ((sp >= 0.0) != (sq >= 0.0) && nb < MAXV) {
                double t = sp / (sp - sq);
                bx[nb] = ax[k] + t * (ax[q] - ax[k]);
                by[nb++] = ay[k] + t * (ay[q] - ay[k]);
            }
        }
        na = nb;
        memcpy(ax, bx, (size_t)nb * sizeof *bx);
        memcpy(ay, by, (size_t)nb * sizeof *by);
    }
    return na >= 3 ? fabs(poly_area(ax, ay, na)) : 0.0;
}

static int point_in(const double *x, const double *y, int n, double px, double py)
{
    int in = 0;
    for (int k = 0, m = n - 1; k < n; m = k++)
        if ((y[k] > py) != (y[m] > py) && px < x[m] + (x[k] - x[m]) * (py - y[m]) / (y[k] - y[m]))
            in = !in;
    return in;
}

/* The bin range covering [x - r, x + r] x [y - r, y + r]. */
static void bin_range(const ofx_writer *w, double x, double y, double r, int *i0, int *i1, int *j0, int *j1)
{
    *i0 = (int)floor((x - r - w->cbx0) / w->cbin);
    *i1 = (int)floor((x + r - w->cbx0) / w->cbin);
    *j0 = (int)floor((y - r - w->cby0) / w->cbin);
    *j1 = (int)floor((y + r - w->cby0) / w->cbin);
    *i0 = *i0 < 0 ? 0 : *i0;
    *j0 = *j0 < 0 ? 0 : *j0;
    *i1 = *i1 >= w->cnbx ? w->cnbx - 1 : *i1;
    *j1 = *j1 >= w->cnby ? w->cnby - 1 : *j1;
}

long ofxc_cell_at(const ofx_writer *w, double x, double y)
{
    int i0, i1, j0, j1;
    bin_range(w, x, y, 0.0, &i0, &i1, &j0, &j1);
    long best = -1;
    for (int j = j0; j <= j1; j++)
        for (int i = i0; i <= i1; i++) {
            size_t b = (size_t)j * w->cnbx + i;
            for (size_t q = w->cbstart[b]; q < w->cbstart[b + 1]; q++) {
                size_t c = w->cbcell[q];
                if ((best < 0 || (long)c < best) && point_in(w->bx + 4 * c, w->by + 4 * c, 4, x, y))
                    best = (long)c;
            }
        }
    return best;
}

size_t ofxc_place(ofx_writer *w, double x, double y, double R, sph_error *err, int *rc)
{
    double r = R / sqrt(3.0); /* pi r^2 = pi R^2 / 3, the kernel's integral */
    double fx[NFOOT], fy[NFOOT];
    double rho = r * sqrt(2.0 * M_PI / (NFOOT * sin(2.0 * M_PI / NFOOT))); /* the 32-gon's area pi r^2 */
    for (int k = 0; k < NFOOT; k++) {
        fx[k] = x + rho * cos(2.0 * M_PI * k / NFOOT);
        fy[k] = y + rho * sin(2.0 * M_PI * k / NFOOT);
    }
    if (++w->seen_mark == 0) { /* wrapped: restart the marks */
        memset(w->seen, 0, w->n * sizeof *w->seen);
        w->seen_mark = 1;
    }
    int i0, i1, j0, j1;
    bin_range(w, x, y, rho, &i0, &i1, &j0, &j1);
    size_t cnt = 0;
    double total = 0.0, sum = 0.0;
    long holder = -1; /* a point footprint (R = 0): the cell holding it */
    for (int j = j0; j <= j1; j++)
        for (int i = i0; i <= i1; i++) {
            size_t b = (size_t)j * w->cnbx + i;
            for (size_t q = w->cbstart[b]; q < w->cbstart[b + 1]; q++) {
                size_t c = w->cbcell[q];
                if (w->seen[c] == w->seen_mark)
                    continue;
                w->seen[c] = w->seen_mark;
                const double *X = w->bx + 4 * c, *Y = w->by + 4 * c;
                if (!(rho > 0.0)) {
                    if ((holder < 0 || (long)c < holder) && point_in(X, Y, 4, x, y))
                        holder = (long)c;
                    continue;
                }
                double ax = fmin(fmin(X[0], X[1]), fmin(X[2], X[3])), bx = fmax(fmax(X[0], X[1]), fmax(X[2], X[3]));
                double ay = fmin(fmin(Y[0], Y[1]), fmin(Y[2], Y[3])), by = fmax(fmax(Y[0], Y[1]), fmax(Y[2], Y[3]));
                if (ax > x + rho || bx < x - rho || ay > y + rho || by < y - rho)
                    continue;
                double a = clip_area(X, Y, 4, fx, fy, NFOOT);
                if (!(a > 0.0))
                    continue;
                total += a;
                if (!ofx_water_cell(w, c))
                    continue;
                if ((*rc = ofx_reserve(w, cnt + 1, err)) != SPH_OK)
                    return 0;
                w->w[cnt] = a;
                w->wc[cnt++] = c;
                sum += a;
            }
        }
    if (!(rho > 0.0) && holder >= 0) {
        total = 1.0;
        if (ofx_water_cell(w, (size_t)holder)) {
            if ((*rc = ofx_reserve(w, 1, err)) != SPH_OK)
                return 0;
            w->w[0] = 1.0;
            w->wc[0] = (size_t)holder;
            return 1;
        }
    }
    if (!(total > 0.0))
        return 0; /* outside the grid */
    if (cnt == 0 || !(sum > 0.0)) { /* on land only: the nearest water cell takes it whole */
        long c = ofx_nearest_water(w, x, y, rho + 2.0 * w->cbin);
        if (c < 0)
            return 0;
        if ((*rc = ofx_reserve(w, 1, err)) != SPH_OK)
            return 0;
        w->w[0] = 1.0;
        w->wc[0] = (size_t)c;
        return 1;
    }
    /* normalised; the rounding remainder to the largest, so they sum to 1 */
    size_t big = 0;
    for (size_t q = 0; q < cnt; q++) {
        w->w[q] /= sum;
        if (w->w[q] > w->w[big])
            big = q;
    }
    double rest = 1.0;
    for (size_t q = 0; q < cnt; q++)
        if (q != big)
            rest -= w->w[q];
    w->w[big] = rest;
    return cnt;
}
