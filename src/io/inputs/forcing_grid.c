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
    g->lon_wrap = nx > 1 && gap > 1e-9 && gap <= 1.5 * dlon;
    for (size_t j = 0; j < ny; j++)
        for (size_t i = 0; i < nx; i++) {
            g->lon2[j * nx + i] = fgrid_wrap180(g->lon1[i]);
            g->lat2[j * nx + i] = g->lat1[j];
        }
    snprintf(g->desc, sizeof g->desc, "regular %.6gx%.6g deg %zux%zu%s", dlon, dlat, nx, ny,
             g->lon_wrap ? " global" : "");
    return 0;
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
 * the fraction; -1 when outside. */
static int bracket(const double *a, size_t n, double x, size_t *i, double *frac)
{
    int asc = a[n - 1] > a[0];
    double lo = asc ? a[0] : a[n - 1], hi = asc ? a[n - 1] : a[0];
    if (!(x >= lo - 1e-10 && x <= hi + 1e-10))
        return -1;
    size_t l = 0, h = n - 1;
    while (h - l > 1) {
        size_t m = (l + h) / 2;
        if ((a[m] <= x) == asc)
            l = m;
        else
            h = m;
    }
    *i = l;
    double f = (x - a[l]) / (a[l + 1] - a[l]);
    *frac = f < 0 ? 0 : f > 1 ? 1 : f;
    return 0;
}

static int locate_regular(const fgrid *g, double lon, double lat, size_t idx[4], double w[4])
{
    size_t nx = g->nx, i, i1, j;
    double fx, fy;
    double x = g->lon1[0] + fmod(fmod(lon - g->lon1[0], 360.0) + 360.0, 360.0);
    if (x > g->lon1[nx - 1] + 1e-10) {
        if (g->lon_wrap) {
            i = nx - 1;
            i1 = 0;
            fx = (x - g->lon1[nx - 1]) / (g->lon1[0] + 360.0 - g->lon1[nx - 1]);
        } else {
            return -1;
        }
    } else {
        if (bracket(g->lon1, nx, x, &i, &fx))
            return -1;
        i1 = i + 1;
    }
    if (bracket(g->lat1, g->ny, lat, &j, &fy))
        return -1;
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
    double X[4], Y[4];
    for (int k = 0; k < 4; k++) {
        X[k] = lon + fgrid_wrap180(g->lon2[c[k]] - lon);
        Y[k] = g->lat2[c[k]];
    }
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
            if (xmin > 1e-9 || xmax < -1e-9 || lat < ymin - 1e-9 || lat > ymax + 1e-9)
                continue;
            if (cell_invert(g, bi, bj, lon, lat, &fx, &fy) == 0 && in_unit(fx) && in_unit(fy)) {
                found = 1;
                ci = bi;
                cj = bj;
            }
        }
    if (!found)
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
                          : locate_regular(g, lon, lat, idx, w) == 0;
}

size_t fgrid_stencils(fgrid *g, unsigned long stamp, size_t n, const double *lon,
                      const double *lat)
{
    size_t outside = 0;
    if (g->stamp == stamp) {
        for (size_t p = 0; p < n; p++)
            outside += !g->ok[p];
        return outside;
    }
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
        size_t *hint = realloc(g->hint, n * sizeof *hint);
        if (hint) {
            for (size_t p = g->npoints; p < n; p++)
                hint[p] = (size_t)-1;
            g->hint = hint;
        }
        if (!idx || !w || !ok || !hint)
            return n; /* out of memory: the caller reports every point as outside */
        g->npoints = n;
    }
    for (size_t p = 0; p < n; p++) {
        int rc;
        if (g->curvilinear) {
            if (g->hint[p] == (size_t)-1 && p > 0 && g->ok[p - 1])
                g->hint[p] = g->hint[p - 1];
            rc = locate_curvilinear(g, lon[p], lat[p], &g->hint[p], g->idx + 4 * p, g->w + 4 * p);
        } else {
            rc = locate_regular(g, lon[p], lat[p], g->idx + 4 * p, g->w + 4 * p);
        }
        g->ok[p] = rc == 0;
        outside += rc != 0;
    }
    g->stamp = stamp;
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
