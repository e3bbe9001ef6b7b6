/* Grids of the forcing reader, format-free (a driver finds the coordinates
 * and builds the grid with fgrid_setup_regular or fgrid_angles, then
 * fgrid_add): point location (regular: binary search; curvilinear: walk
 * from the previous hit, Newton inversion of the bilinear map), bilinear
 * interpolation that skips missing corners, grid rotation angles and SSH
 * gradients by centred differences on a spherical earth. */
#include "forcing_impl.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DEG (M_PI / 180.0)

double fgrid_wrap180(double x)
{
    x = fmod(x + 180.0, 360.0);
    if (x < 0)
        x += 360.0;
    return x - 180.0;
}

void fgrid_free(fgrid *g)
{
    if (!g)
        return;
    free(g->lon1);
    free(g->lat1);
    free(g->lon2);
    free(g->lat2);
    free(g->cosang);
    free(g->sinang);
    free(g->idx);
    free(g->w);
    free(g->ok);
    free(g->hint);
    free(g);
}

/* Angle from east to the grid x axis at every node: from an angle variable
 * when the file has one (radians, or any unit udunits converts to radian),
 * else from the node coordinates by centred differences (assumes the grid
 * is orthogonal, y axis 90 degrees anticlockwise from x). */
void fgrid_angles(fgrid *g, const double *angle)
{
    size_t nx = g->nx, ny = g->ny;
    for (size_t j = 0; j < ny; j++)
        for (size_t i = 0; i < nx; i++) {
            size_t p = j * nx + i;
            double a;
            if (angle && isfinite(angle[p])) {
                a = angle[p];
            } else {
                size_t i0 = i > 0 ? i - 1 : i, i1 = i + 1 < nx ? i + 1 : i;
                double dlon = fgrid_wrap180(g->lon2[j * nx + i1] - g->lon2[j * nx + i0]);
                double dlat = g->lat2[j * nx + i1] - g->lat2[j * nx + i0];
                a = atan2(dlat, dlon * cos(g->lat2[p] * DEG));
            }
            g->cosang[p] = cos(a);
            g->sinang[p] = sin(a);
        }
}

/* ---- read windows ---- */

#define KM_PER_DEG (FORCING_EARTH_RADIUS * DEG / 1000.0)

/* The source's box plus its margin: latitudes lat0..lat1, longitudes within hw
 * degrees of lonc (hw >= 180: every longitude). */
typedef struct wbox {
    double lat0, lat1, lonc, hw;
} wbox;

static void win_box(const fsource *s, wbox *b)
{
    double dlat = s->win_margin_km / KM_PER_DEG;
    b->lat0 = s->win_box[2] - dlat;
    b->lat1 = s->win_box[3] + dlat;
    double phi = fmax(fabs(b->lat0), fabs(b->lat1));
    b->lonc = 0.5 * (s->win_box[0] + s->win_box[1]);
    b->hw = phi >= 89.0 ? 360.0 : 0.5 * (s->win_box[1] - s->win_box[0]) + dlat / cos(phi * DEG);
}

/* 1 when the cell with these n corner longitudes reaches longitudes of the box. */
static int lon_overlap(const wbox *b, const double *lon, int n)
{
    if (b->hw >= 180.0)
        return 1;
    double x[4], mn = INFINITY, mx = -INFINITY;
    for (int k = 0; k < n; k++) {
        x[k] = fgrid_wrap180(lon[k] - b->lonc);
        mn = fmin(mn, x[k]);
        mx = fmax(mx, x[k]);
    }
    if (mx - mn <= 180.0)
        return mn <= b->hw && mx >= -b->hw;
    /* the cell spans the meridian opposite the box's centre */
    double pmin = INFINITY, nmax = -INFINITY;
    for (int k = 0; k < n; k++) {
        if (x[k] >= 0)
            pmin = fmin(pmin, x[k]);
        else
            nmax = fmax(nmax, x[k]);
    }
    return pmin <= b->hw || nmax >= -b->hw;
}

static int lat_overlap(const wbox *b, double a, double c)
{
    return fmin(a, c) <= b->lat1 && fmax(a, c) >= b->lat0;
}

/* One axis of a window from the selected nodes sel[n]: [*w0, *w0 + *wn) (mod n when
 * circular), widened by FGRID_GUARD nodes; none selected or all: the whole axis. */
static void win_axis(const unsigned char *sel, size_t n, int circular, size_t *w0, size_t *wn,
                     int *edge_lo, int *edge_hi)
{
    size_t first = n, last = 0, count = 0;
    for (size_t i = 0; i < n; i++)
        if (sel[i]) {
            if (first == n)
                first = i;
            last = i;
            count++;
        }
    *w0 = 0;
    *wn = n;
    *edge_lo = *edge_hi = 1;
    if (count == 0 || count == n)
        return;
    if (!circular) {
        size_t a = first > FGRID_GUARD ? first - FGRID_GUARD : 0;
        size_t b = last + FGRID_GUARD < n ? last + FGRID_GUARD : n - 1;
        *w0 = a;
        *wn = b - a + 1;
        *edge_lo = a == 0;
        *edge_hi = b == n - 1;
        return;
    }
    /* circular: the window is everything but the longest run of unselected nodes */
    size_t best_len = 0, best_end = 0; /* the run ends just before node best_end */
    for (size_t i = 0; i < n; i++) {
        if (!sel[i] || sel[(i + n - 1) % n])
            continue;
        /* a selected node after an unselected one: measure the run before it */
        size_t len = 0;
        while (len < n && !sel[(i + n - 1 - len) % n])
            len++;
        if (len > best_len) {
            best_len = len;
            best_end = i;
        }
    }
    size_t keep = n - best_len + 2 * FGRID_GUARD;
    if (keep >= n)
        return;
    *w0 = (best_end + n - FGRID_GUARD) % n;
    *wn = keep;
    *edge_lo = *edge_hi = 0;
}

static void win_flags(fgrid *g, const fsource *s)
{
    g->windowed = g->nx < g->fnx || g->ny < g->fny;
    g->margin_km = s->win_margin_km;
    if (!g->windowed)
        g->edge[0] = g->edge[1] = g->edge[2] = g->edge[3] = 1;
}

static void win_desc(fgrid *g)
{
    if (!g->windowed)
        return;
    size_t used = strlen(g->desc);
    if (used + 1 < sizeof g->desc)
        snprintf(g->desc + used, sizeof g->desc - used, ", window %zux%zu", g->nx, g->ny);
}

int fgrid_setup_regular(fgrid *g, const fsource *s, const char *path, sph_error *err)
{
    size_t nx = g->nx, ny = g->ny;
    /* bounded first: the unwrapping below adds 360 until a value passes its
     * neighbour, which never ends for -1e300 (found by tests/fuzz/fuzz_forcing) */
    for (size_t i = 0; i < nx; i++)
        if (!(fabs(g->lon1[i]) <= 720.0))
            return forcing_fail(err, s, path, SPH_ERR_BAD_DATA,
                                "longitude %g at index %zu is outside -720..720 degrees", g->lon1[i], i);
    for (size_t i = 1; i < nx; i++) {
        while (g->lon1[i] <= g->lon1[i - 1] - 180.0)
            g->lon1[i] += 360.0; /* longitudes that jump from 180 to -180 */
        if (!(g->lon1[i] > g->lon1[i - 1]))
            return forcing_fail(err, s, path, SPH_ERR_BAD_DATA,
                                "longitudes are not increasing at index %zu", i);
        if (g->lon1[i] - g->lon1[0] >= 360.0 + 1e-9) /* here, so that the loop above stays short */
            return forcing_fail(err, s, path, SPH_ERR_BAD_DATA, "longitudes span more than 360 degrees");
    }
    int asc = ny < 2 || g->lat1[1] > g->lat1[0];
    for (size_t j = 1; j < ny; j++)
        if (asc ? !(g->lat1[j] > g->lat1[j - 1]) : !(g->lat1[j] < g->lat1[j - 1]))
            return forcing_fail(err, s, path, SPH_ERR_BAD_DATA,
                                "latitudes are not monotonic at index %zu", j);
    double dlon = nx > 1 ? (g->lon1[nx - 1] - g->lon1[0]) / (double)(nx - 1) : 360.0;
    double dlat = ny > 1 ? fabs(g->lat1[ny - 1] - g->lat1[0]) / (double)(ny - 1) : 0.0;
    double gap = g->lon1[0] + 360.0 - g->lon1[nx - 1];
    g->fwrap = nx > 1 && gap > 1e-9 && gap <= 1.5 * dlon;
    g->fnx = nx;
    g->fny = ny;
    g->ext[0] = g->lon1[0];
    g->ext[1] = g->lon1[nx - 1];
    g->ext[2] = fmin(g->lat1[0], g->lat1[ny - 1]);
    g->ext[3] = fmax(g->lat1[0], g->lat1[ny - 1]);
    g->wi0 = g->wj0 = 0;
    if (s->win_on) {
        /* the nodes of the cells (columns, rows) that reach the box plus margin */
        wbox b;
        win_box(s, &b);
        unsigned char *sx = calloc(nx, 1), *sy = calloc(ny, 1);
        if (!sx || !sy) {
            free(sx);
            free(sy);
            return forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
        }
        for (size_t i = 0; i + 1 < nx + (size_t)g->fwrap; i++) {
            size_t i1 = (i + 1) % nx;
            double c[2] = {g->lon1[i], g->lon1[i1]};
            if (lon_overlap(&b, c, 2))
                sx[i] = sx[i1] = 1;
        }
        for (size_t j = 0; j + 1 < ny; j++)
            if (lat_overlap(&b, g->lat1[j], g->lat1[j + 1]))
                sy[j] = sy[j + 1] = 1;
        size_t wn, hn;
        win_axis(sx, nx, g->fwrap, &g->wi0, &wn, &g->edge[0], &g->edge[1]);
        win_axis(sy, ny, 0, &g->wj0, &hn, &g->edge[2], &g->edge[3]);
        free(sx);
        free(sy);
        g->nx = wn;
        g->ny = hn;
    }
    win_flags(g, s);
    g->lon_wrap = g->fwrap && g->nx == nx;
    free(g->lon2);
    free(g->lat2);
    g->lon2 = malloc(g->nx * g->ny * sizeof(double));
    g->lat2 = malloc(g->nx * g->ny * sizeof(double));
    if (!g->lon2 || !g->lat2)
        return forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
    for (size_t j = 0; j < g->ny; j++)
        for (size_t i = 0; i < g->nx; i++) {
            g->lon2[j * g->nx + i] = fgrid_wrap180(g->lon1[(g->wi0 + i) % nx]);
            g->lat2[j * g->nx + i] = g->lat1[g->wj0 + j];
        }
    size_t e = (g->wi0 + g->nx - 1) % nx;
    g->wext[0] = g->lon1[g->wi0];
    g->wext[1] = g->lon1[e] + (e < g->wi0 ? 360.0 : 0.0);
    g->wext[2] = fmin(g->lat2[0], g->lat2[(g->ny - 1) * g->nx]);
    g->wext[3] = fmax(g->lat2[0], g->lat2[(g->ny - 1) * g->nx]);
    snprintf(g->desc, sizeof g->desc, "regular %.6gx%.6g deg %zux%zu%s", dlon, dlat, nx, ny,
             g->fwrap ? " global" : "");
    win_desc(g);
    return 0;
}

/* Keeps nodes [i0, i0 + wn) x [j0, j0 + hn) of an array of fnx x fny nodes. */
static int crop(double **a, size_t fnx, size_t i0, size_t j0, size_t wn, size_t hn)
{
    if (!*a)
        return 0;
    double *b = malloc(wn * hn * sizeof *b);
    if (!b)
        return -1;
    for (size_t j = 0; j < hn; j++)
        memcpy(b + j * wn, *a + (j0 + j) * fnx + i0, wn * sizeof *b);
    free(*a);
    *a = b;
    return 0;
}

int fgrid_window(fgrid *g, const fsource *s)
{
    size_t nx = g->nx, ny = g->ny;
    g->fnx = nx;
    g->fny = ny;
    g->wi0 = g->wj0 = 0;
    g->ext[0] = g->ext[2] = INFINITY;
    g->ext[1] = g->ext[3] = -INFINITY;
    for (size_t p = 0; p < nx * ny; p++) {
        g->ext[0] = fmin(g->ext[0], g->lon2[p]);
        g->ext[1] = fmax(g->ext[1], g->lon2[p]);
        g->ext[2] = fmin(g->ext[2], g->lat2[p]);
        g->ext[3] = fmax(g->ext[3], g->lat2[p]);
    }
    if (s->win_on) {
        /* the bounding index box of the cells that reach the box plus margin */
        wbox b;
        win_box(s, &b);
        size_t i0 = nx, i1 = 0, j0 = ny, j1 = 0;
        for (size_t j = 0; j + 1 < ny; j++)
            for (size_t i = 0; i + 1 < nx; i++) {
                size_t c[4] = {j * nx + i, j * nx + i + 1, (j + 1) * nx + i, (j + 1) * nx + i + 1};
                double la0 = fmin(fmin(g->lat2[c[0]], g->lat2[c[1]]), fmin(g->lat2[c[2]], g->lat2[c[3]]));
                double la1 = fmax(fmax(g->lat2[c[0]], g->lat2[c[1]]), fmax(g->lat2[c[2]], g->lat2[c[3]]));
                if (!lat_overlap(&b, la0, la1))
                    continue;
                double lo[4] = {g->lon2[c[0]], g->lon2[c[1]], g->lon2[c[2]], g->lon2[c[3]]};
                if (!lon_overlap(&b, lo, 4))
                    continue;
                i0 = i < i0 ? i : i0;
                i1 = i + 1 > i1 ? i + 1 : i1;
                j0 = j < j0 ? j : j0;
                j1 = j + 1 > j1 ? j + 1 : j1;
            }
        if (i0 < nx) {
            i0 = i0 > FGRID_GUARD ? i0 - FGRID_GUARD : 0;
            j0 = j0 > FGRID_GUARD ? j0 - FGRID_GUARD : 0;
            i1 = i1 + FGRID_GUARD < nx ? i1 + FGRID_GUARD : nx - 1;
            j1 = j1 + FGRID_GUARD < ny ? j1 + FGRID_GUARD : ny - 1;
            size_t wn = i1 - i0 + 1, hn = j1 - j0 + 1;
            if (wn < nx || hn < ny) {
                if (crop(&g->lon2, nx, i0, j0, wn, hn) || crop(&g->lat2, nx, i0, j0, wn, hn) ||
                    crop(&g->cosang, nx, i0, j0, wn, hn) || crop(&g->sinang, nx, i0, j0, wn, hn))
                    return -1;
                g->wi0 = i0;
                g->wj0 = j0;
                g->nx = wn;
                g->ny = hn;
                g->edge[0] = i0 == 0;
                g->edge[1] = i1 == nx - 1;
                g->edge[2] = j0 == 0;
                g->edge[3] = j1 == ny - 1;
            }
        }
    }
    win_flags(g, s);
    g->wext[0] = g->wext[2] = INFINITY;
    g->wext[1] = g->wext[3] = -INFINITY;
    for (size_t p = 0; p < g->nx * g->ny; p++) {
        g->wext[0] = fmin(g->wext[0], g->lon2[p]);
        g->wext[1] = fmax(g->wext[1], g->lon2[p]);
        g->wext[2] = fmin(g->wext[2], g->lat2[p]);
        g->wext[3] = fmax(g->wext[3], g->lat2[p]);
    }
    win_desc(g);
    return 0;
}

size_t fgrid_bytes(const fgrid *g)
{
    size_t n = g->nx * g->ny, b = sizeof *g;
    if (g->lon1)
        b += (g->fnx + g->fny) * sizeof(double);
    b += (g->lon2 ? n : 0) * sizeof(double) + (g->lat2 ? n : 0) * sizeof(double);
    b += (g->cosang ? n : 0) * sizeof(double) + (g->sinang ? n : 0) * sizeof(double);
    b += g->npoints * (4 * sizeof(size_t) + 4 * sizeof(double) + sizeof(int)) + g->nhint * sizeof(size_t);
    return b;
}

/* 1 when the cell (ci, cj) of the window samples exactly as in the file's grid:
 * inside the window with the nodes the nearest-valid fallback (one node around the
 * cell) and their SSH gradient (one more) inside too, unless that side of the
 * window is the file's. */
static int usable(const fgrid *g, size_t ci, size_t cj)
{
    const size_t G = 2;
    if (!g->windowed)
        return 1;
    if (!g->lon_wrap) {
        if (ci + 1 >= g->nx || (!g->edge[0] && ci < G) || (!g->edge[1] && ci + 1 + G >= g->nx))
            return 0;
    }
    if (cj + 1 >= g->ny || (!g->edge[2] && cj < G) || (!g->edge[3] && cj + 1 + G >= g->ny))
        return 0;
    return 1;
}

fgrid *fgrid_find(const fsource *s, const char *key)
{
    for (fgrid *g = s->grids; g; g = g->next)
        if (strcmp(g->key, key) == 0)
            return g;
    return NULL;
}

void fgrid_add(fsource *s, fgrid *g)
{
    g->stamp = (unsigned long)-1;
    g->next = s->grids;
    s->grids = g;
}

/* Index i with a[i] <= x <= a[i+1] in a monotonic array (either order), and
 * the fraction; -1 when outside. The index is the binary search's: the
 * last l in 1 .. n-2 with (a[l] <= x) == ascending, else 0. A hint (the
 * point's index at the previous call; anything else: none) that is that
 * index is taken without the search: the same index, bit for bit. */
static int bracket(const double *a, size_t n, double x, size_t hint, size_t *i, double *frac)
{
    int asc = a[n - 1] > a[0];
    double lo = asc ? a[0] : a[n - 1], hi = asc ? a[n - 1] : a[0];
    if (!(x >= lo - 1e-10 && x <= hi + 1e-10))
        return -1;
    size_t l = 0, h = n - 1;
    if (hint < n - 1 && (hint == 0 || (a[hint] <= x) == asc) &&
        (hint + 2 == n || (a[hint + 1] <= x) != asc)) {
        l = hint;
    } else {
        while (h - l > 1) {
            size_t m = (l + h) / 2;
            if ((a[m] <= x) == asc)
                l = m;
            else
                h = m;
        }
    }
    *i = l;
    double f = (x - a[l]) / (a[l + 1] - a[l]);
    *frac = f < 0 ? 0 : f > 1 ? 1 : f;
    return 0;
}

/* lon0 + fmod(fmod(lon - lon0, 360) + 360, 360) without fmod where the
 * difference is within one turn (the same value bit for bit: fmod is exact,
 * and y - 360 is exact for y in [360, 720)). */
static double lon_from(double lon, double lon0)
{
    double d = lon - lon0;
    if (d >= 0.0 && d < 360.0) {
        double y = d + 360.0;
        if (y < 720.0)
            return lon0 + (y - 360.0);
    } else if (d >= -360.0 && d < 0.0) {
        double y = d + 360.0;
        if (y < 360.0)
            return lon0 + y;
    }
    return lon0 + fmod(fmod(d, 360.0) + 360.0, 360.0);
}

/* Regular grids keep the point's file column and row of the previous call
 * in its hint: row << 32 | column. */
#define REG_HINT(i, j) (((size_t)(j) << 32) | (size_t)(i))
#define REG_HINT_I(h) ((h) & 0xffffffffu)
#define REG_HINT_J(h) ((h) >> 32)

static int locate_regular(const fgrid *g, double lon, double lat, size_t *hint, size_t idx[4],
                          double w[4])
{
    /* located on the file's axes (the same arithmetic with or without a window),
     * then mapped into the window */
    size_t nx = g->fnx, i, i1, j;
    size_t hi = *hint == (size_t)-1 ? (size_t)-1 : REG_HINT_I(*hint);
    size_t hj = *hint == (size_t)-1 ? (size_t)-1 : REG_HINT_J(*hint);
    double fx, fy;
    double x = lon_from(lon, g->lon1[0]);
    if (x > g->lon1[nx - 1] + 1e-10) {
        if (g->fwrap) {
            i = nx - 1;
            i1 = 0;
            fx = (x - g->lon1[nx - 1]) / (g->lon1[0] + 360.0 - g->lon1[nx - 1]);
        } else {
            return -1;
        }
    } else {
        if (bracket(g->lon1, nx, x, hi, &i, &fx))
            return -1;
        i1 = i + 1;
    }
    if (bracket(g->lat1, g->fny, lat, hj, &j, &fy))
        return -1;
    *hint = REG_HINT(i, j);
    /* into the window: columns from wi0 (mod nx on a global grid), rows from wj0 */
    size_t wi = g->fwrap ? (i + nx - g->wi0) % nx : i - g->wi0;
    size_t wi1 = g->fwrap ? (i1 + nx - g->wi0) % nx : i1 - g->wi0;
    if (i < g->wi0 && !g->fwrap)
        return -1;
    if (j < g->wj0 || wi >= g->nx || wi1 >= g->nx)
        return -1;
    j -= g->wj0;
    if (!usable(g, wi, j))
        return -1;
    nx = g->nx;
    i = wi;
    i1 = wi1;
    idx[0] = j * nx + i;
    idx[1] = j * nx + i1;
    idx[2] = (j + 1) * nx + i;
    idx[3] = (j + 1) * nx + i1;
    w[0] = (1 - fx) * (1 - fy);
    w[1] = fx * (1 - fy);
    w[2] = (1 - fx) * fy;
    w[3] = fx * fy;
    return 0;
}

/* Inverts the bilinear map of cell (i, j) at (lon, lat) by Newton's method.
 * Corner longitudes are unwrapped to within 180 degrees of the point. */
static int cell_invert(const fgrid *g, size_t i, size_t j, double lon, double lat, double *fx,
                       double *fy)
{
    size_t nx = g->nx;
    size_t c[4] = {j * nx + i, j * nx + i + 1, (j + 1) * nx + i, (j + 1) * nx + i + 1};
    double X[4], Y[4], xmin = INFINITY, xmax = -INFINITY;
    for (int k = 0; k < 4; k++) {
        X[k] = lon + fgrid_wrap180(g->lon2[c[k]] - lon);
        Y[k] = g->lat2[c[k]];
        xmin = fmin(xmin, X[k]);
        xmax = fmax(xmax, X[k]);
    }
    /* a cell whose corners are more than 180 degrees apart seen from the point lies
     * across the meridian opposite it (or around a pole): its lon/lat map cannot hold
     * the point (it did, on the far side of the pole of a polar stereographic grid) */
    if (xmax - xmin > 180.0)
        return -1;
    double a = 0.5, b = 0.5;
    for (int it = 0; it < 30; it++) {
        double px = (1 - a) * (1 - b) * X[0] + a * (1 - b) * X[1] + (1 - a) * b * X[2] + a * b * X[3];
        double py = (1 - a) * (1 - b) * Y[0] + a * (1 - b) * Y[1] + (1 - a) * b * Y[2] + a * b * Y[3];
        double ja = (1 - b) * (X[1] - X[0]) + b * (X[3] - X[2]);
        double jb = (1 - a) * (X[2] - X[0]) + a * (X[3] - X[1]);
        double ka = (1 - b) * (Y[1] - Y[0]) + b * (Y[3] - Y[2]);
        double kb = (1 - a) * (Y[2] - Y[0]) + a * (Y[3] - Y[1]);
        double det = ja * kb - jb * ka;
        if (!(fabs(det) > 0))
            return -1;
        double rx = px - lon, ry = py - lat;
        double da = (kb * rx - jb * ry) / det, db = (-ka * rx + ja * ry) / det;
        a -= da;
        b -= db;
        if (!isfinite(a) || !isfinite(b) || fabs(a) > 1e3 || fabs(b) > 1e3)
            return -1;
        if (fabs(da) < 1e-14 && fabs(db) < 1e-14)
            break;
    }
    *fx = a;
    *fy = b;
    return 0;
}

static int in_unit(double a)
{
    return a >= -1e-9 && a <= 1 + 1e-9;
}

static double clamp01(double a)
{
    return a < 0 ? 0 : a > 1 ? 1 : a;
}

static int locate_curvilinear(const fgrid *g, double lon, double lat, size_t *hint,
                              size_t idx[4], double w[4])
{
    size_t nx = g->nx, ny = g->ny, ci, cj;
    double fx = -1, fy = -1;
    int found = 0;
    if (*hint != (size_t)-1) {
        /* Walk from the previous hit: particles move less than a cell per step. */
        ci = *hint % nx;
        cj = *hint / nx;
        for (int step = 0; step < 64; step++) {
            if (cell_invert(g, ci, cj, lon, lat, &fx, &fy))
                break;
            if (in_unit(fx) && in_unit(fy)) {
                found = 1;
                break;
            }
            size_t ni = ci, nj = cj;
            if (fx < 0 && ci > 0)
                ni--;
            else if (fx > 1 && ci + 2 < nx)
                ni++;
            if (fy < 0 && cj > 0)
                nj--;
            else if (fy > 1 && cj + 2 < ny)
                nj++;
            if (ni == ci && nj == cj)
                break;
            ci = ni;
            cj = nj;
        }
    }
    for (size_t bj = 0; !found && bj + 1 < ny; bj++)
        for (size_t bi = 0; !found && bi + 1 < nx; bi++) {
            size_t c[4] = {bj * nx + bi, bj * nx + bi + 1, (bj + 1) * nx + bi,
                           (bj + 1) * nx + bi + 1};
            double xmin = 1e9, xmax = -1e9, ymin = 1e9, ymax = -1e9;
            for (int k = 0; k < 4; k++) {
                double x = fgrid_wrap180(g->lon2[c[k]] - lon);
                xmin = fmin(xmin, x);
                xmax = fmax(xmax, x);
                ymin = fmin(ymin, g->lat2[c[k]]);
                ymax = fmax(ymax, g->lat2[c[k]]);
            }
            if (xmin > 1e-9 || xmax < -1e-9 || xmax - xmin > 180.0 || lat < ymin - 1e-9 ||
                lat > ymax + 1e-9)
                continue;
            if (cell_invert(g, bi, bj, lon, lat, &fx, &fy) == 0 && in_unit(fx) && in_unit(fy)) {
                found = 1;
                ci = bi;
                cj = bj;
            }
        }
    if (!found || !usable(g, ci, cj))
        return -1;
    fx = clamp01(fx);
    fy = clamp01(fy);
    *hint = cj * nx + ci;
    idx[0] = cj * nx + ci;
    idx[1] = cj * nx + ci + 1;
    idx[2] = (cj + 1) * nx + ci;
    idx[3] = (cj + 1) * nx + ci + 1;
    w[0] = (1 - fx) * (1 - fy);
    w[1] = fx * (1 - fy);
    w[2] = (1 - fx) * fy;
    w[3] = fx * fy;
    return 0;
}

int fgrid_covers(fgrid *g, double lon, double lat)
{
    size_t idx[4], hint = (size_t)-1;
    double w[4];
    return g->curvilinear ? locate_curvilinear(g, lon, lat, &hint, idx, w) == 0
                          : locate_regular(g, lon, lat, &hint, idx, w) == 0;
}

int fgrid_covers_file(const fgrid *g, double lon, double lat)
{
    if (!(lat >= g->ext[2] && lat <= g->ext[3]))
        return 0;
    if (g->fwrap)
        return 1;
    double x = g->ext[0] + fmod(fmod(lon - g->ext[0], 360.0) + 360.0, 360.0);
    return x <= g->ext[1];
}

size_t fgrid_stencils(fgrid *g, unsigned long stamp, size_t n, const double *lon,
                      const double *lat)
{
    size_t outside = 0;
    if (g->stamp == stamp) /* the same points: the count of that call */
        return g->stamp_outside;
    if (n > g->npoints) {
        size_t *idx = realloc(g->idx, 4 * n * sizeof *idx);
        if (idx)
            g->idx = idx;
        double *w = realloc(g->w, 4 * n * sizeof *w);
        if (w)
            g->w = w;
        int *ok = realloc(g->ok, n * sizeof *ok);
        if (ok)
            g->ok = ok;
        if (!idx || !w || !ok)
            return n; /* out of memory: the caller reports every point as outside */
        g->npoints = n;
    }
    /* the hints are per point of the whole set (forcing_set_point_base) */
    const size_t base = g->hint_base;
    if (base + n > g->nhint) {
        size_t *h = realloc(g->hint, (base + n) * sizeof *h);
        if (!h)
            return n;
        for (size_t p = g->nhint; p < base + n; p++)
            h[p] = (size_t)-1;
        g->hint = h;
        g->nhint = base + n;
    }
    size_t *hint = g->hint + base;
    if (g->curvilinear) { /* serial: a point's walk starts from its predecessor's cell */
        /* the predecessor of a chunk's first point: the previous chunk's last */
        int prev_ok = base > 0 && g->last_end == base && g->last_ok;
        for (size_t p = 0; p < n; p++) {
            if (hint[p] == (size_t)-1 && (p > 0 ? g->ok[p - 1] : prev_ok))
                hint[p] = g->hint[base + p - 1];
            int rc = locate_curvilinear(g, lon[p], lat[p], &hint[p], g->idx + 4 * p, g->w + 4 * p);
            g->ok[p] = rc == 0;
            outside += rc != 0;
        }
    } else { /* per-point writes only: the same stencils with any number of threads */
#pragma omp parallel for schedule(dynamic, FORCING_OMP_GRAB) reduction(+ : outside) if (n >= FORCING_OMP_MIN)
        for (size_t p = 0; p < n; p++) {
            int rc = locate_regular(g, lon[p], lat[p], &hint[p], g->idx + 4 * p, g->w + 4 * p);
            g->ok[p] = rc == 0;
            outside += rc != 0;
        }
    }
    g->last_end = base + n;
    g->last_ok = n > 0 && g->ok[n - 1];
    g->stamp = stamp;
    g->stamp_outside = outside;
    return outside;
}

int fgrid_interp(const fgrid *g, const double *slice, size_t p, double lon, double lat,
                 double *value)
{
    const size_t *idx = g->idx + 4 * p;
    const double *w = g->w + 4 * p;
    double sum = 0, wsum = 0;
    for (int k = 0; k < 4; k++) {
        double v = slice[idx[k]];
        if (!isnan(v) && w[k] > 0) {
            sum += w[k] * v;
            wsum += w[k];
        }
    }
    if (wsum > 1e-12) {
        *value = sum / wsum;
        return 0;
    }
    /* All corners missing (or only zero-weight ones valid): nearest valid node
     * among the cells around this one. */
    size_t nx = g->nx, ny = g->ny;
    size_t i0 = idx[0] % nx, j0 = idx[0] / nx;
    double best = INFINITY;
    double cl = cos(lat * DEG);
    for (long dj = -1; dj <= 2; dj++)
        for (long di = -1; di <= 2; di++) {
            long i = (long)i0 + di, j = (long)j0 + dj;
            if (j < 0 || j >= (long)ny)
                continue;
            if (i < 0 || i >= (long)nx) {
                if (!g->lon_wrap)
                    continue;
                i = (i + (long)nx) % (long)nx;
            }
            size_t q = (size_t)j * nx + (size_t)i;
            if (isnan(slice[q]))
                continue;
            double dx = fgrid_wrap180(g->lon2[q] - lon) * cl, dy = g->lat2[q] - lat;
            double d = dx * dx + dy * dy;
            if (d < best) {
                best = d;
                *value = slice[q];
            }
        }
    return isfinite(best) ? 0 : -1;
}

void fgrid_gradient(const fgrid *g, const double *h, double *gx, double *gy)
{
    size_t nx = g->nx, ny = g->ny;
    for (size_t j = 0; j < ny; j++)
        for (size_t i = 0; i < nx; i++) {
            size_t p = j * nx + i;
            gx[p] = gy[p] = NAN;
            if (isnan(h[p]))
                continue;
            /* Neighbours along i (wrapping on global grids) and j, falling back
             * to one-sided differences at edges and next to missing values. */
            size_t ia = i, ib = i;
            if (i > 0)
                ia = i - 1;
            else if (g->lon_wrap)
                ia = nx - 1;
            if (i + 1 < nx)
                ib = i + 1;
            else if (g->lon_wrap)
                ib = 0;
            size_t pa = j * nx + ia, pb = j * nx + ib;
            if (isnan(h[pa]))
                pa = p;
            if (isnan(h[pb]))
                pb = p;
            size_t qa = j > 0 ? p - nx : p, qb = j + 1 < ny ? p + nx : p;
            if (isnan(h[qa]))
                qa = p;
            if (isnan(h[qb]))
                qb = p;
            if (pa == pb || qa == qb)
                continue;
            double cl = cos(g->lat2[p] * DEG);
            double ex = fgrid_wrap180(g->lon2[pb] - g->lon2[pa]) * DEG * cl * FORCING_EARTH_RADIUS;
            double nxm = (g->lat2[pb] - g->lat2[pa]) * DEG * FORCING_EARTH_RADIUS;
            double ey = fgrid_wrap180(g->lon2[qb] - g->lon2[qa]) * DEG * cl * FORCING_EARTH_RADIUS;
            double nym = (g->lat2[qb] - g->lat2[qa]) * DEG * FORCING_EARTH_RADIUS;
            double hx = h[pb] - h[pa], hy = h[qb] - h[qa];
            /* [ex nxm; ey nym] [dh/dE; dh/dN] = [hx; hy] */
            double det = ex * nym - nxm * ey;
            if (!(fabs(det) > 0))
                continue;
            gx[p] = (hx * nym - nxm * hy) / det;
            gy[p] = (ex * hy - ey * hx) / det;
        }
}
