/* Land/sea masks: see io/landmask.h.
 *
 * GSHHG binned format (GMT's coastline files, as read by gmt_shore.c):
 * the globe is cut into square bins of Bin_size_in_minutes (120 for the
 * high-resolution file), numbered row by row from the north-west:
 *   bin b: column b % nx (west edge (b % nx) * size, 0..360 E),
 *          row b / nx   (south edge 90 - (b / nx + 1) * size).
 * Embedded_node_levels_in_a_bin packs the GSHHG level (0 ocean, 1 land,
 * 2 lake, 3 island in lake, 4 pond) of the four bin corners in 3-bit
 * groups, SW in bits 9-11, then SE, NE, NW (counter-clockwise). A bin's
 * segments are Id_of_first_segment_in_a_bin .. + N_segments_in_a_bin - 1;
 * Embedded_npts_levels_exit_entry_for_a_segment packs the point count
 * (bits 9..), the level (bits 6-8), the side the segment enters by (bits
 * 3-5) and leaves by (bits 0-2): 0 south, 1 east, 2 north, 3 west, 4 none
 * (a closed polygon inside the bin). Points are unsigned 16-bit offsets
 * from the bin's SW corner in 1/65535 of the bin size.
 * (The corner order was confirmed on the file itself: the parity of
 * level-1 segment ends on each side equals the land/sea change between
 * that side's two corners in every bin.)
 *
 * Classification of a point P in a bin: start at the SW corner, whose
 * land/sea state is known, and walk up the west side to P's latitude, then
 * east to P. Every level-1 boundary crossed flips land <-> sea: the
 * level-1 segment ends lying on the west side below P, plus the level-1
 * edges crossing P's parallel west of P (half-open rule: an edge crosses if
 * exactly one end lies strictly above P, which treats P as infinitesimally
 * higher and makes vertices on the parallel count once). Other levels
 * (lake shores, Antarctic grounding lines) separate land from land and are
 * ignored. One scan line per grid row with sorted crossings makes the cost
 * O(edges + cells) per row. Antarctic ice-shelf variants are not handled.
 */
#include "io/landmask.h"
#include "io/raster.h"

#include <math.h>
#include <netcdf.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "util/fileio.h"
#include "util/log.h"

struct landmask {
    int nlon, nlat; /* native: nx, ny */
    double lon0, lat0, dlon, dlat; /* south-west corner of cell (0,0), cell size */
    unsigned char *land;
    /* native grid (see "native grids" below) */
    int native;
    float *xyz;       /* unit vectors of the cell centres, 3 per cell */
    float *reach2;    /* squared chord to the farthest neighbouring centre */
    double bmin[3], bsize, spacing; /* spacing: mean chord between neighbours */
    int nb[3];
    uint32_t *bstart, *bidx;
    struct landmask *also; /* land as well where this one says so (landmask_add) */
};

static landmask *mask_alloc(int nlon, int nlat, double lon0, double lat0, double dlon,
                            double dlat, sph_error *err)
{
    if (nlon <= 0 || nlat <= 0 || !(dlon > 0) || !(dlat > 0) || (double)nlon * nlat > 2e9) {
        sph_err_set(err, SPH_ERR_PARAM, "land mask: bad grid %d x %d cells of %g x %g degrees",
                    nlon, nlat, dlon, dlat);
        return NULL;
    }
    landmask *m = calloc(1, sizeof *m);
    if (m)
        m->land = calloc((size_t)nlon * nlat, 1);
    if (!m || !m->land) {
        free(m);
        sph_err_set(err, SPH_ERR_NOMEM, "land mask: out of memory for %d x %d cells", nlon, nlat);
        return NULL;
    }
    m->nlon = nlon;
    m->nlat = nlat;
    m->lon0 = lon0;
    m->lat0 = lat0;
    m->dlon = dlon;
    m->dlat = dlat;
    return m;
}

void landmask_free(landmask *m)
{
    if (!m)
        return;
    free(m->land);
    free(m->xyz);
    free(m->reach2);
    free(m->bstart);
    free(m->bidx);
    landmask_free(m->also);
    free(m);
}

landmask *landmask_create_array(int nlon, int nlat, double lon0, double lat0, double dlon,
                                double dlat, const unsigned char *land, sph_error *err)
{
    landmask *m = mask_alloc(nlon, nlat, lon0, lat0, dlon, dlat, err);
    if (m)
        for (size_t k = 0; k < (size_t)nlon * nlat; k++)
            m->land[k] = land[k] ? 1 : 0;
    return m;
}

static long native_nearest(const landmask *m, double lon, double lat);
static landmask *native_create(size_t nx, size_t ny, const double *lon, const double *lat,
                               const unsigned char *land, const char *path, sph_error *err);

static int is_land_one(const landmask *m, double lon, double lat);

int landmask_is_land(const landmask *m, double lon, double lat)
{
    int r = is_land_one(m, lon, lat);
    if (r == 1 || !m || !m->also)
        return r;
    int a = landmask_is_land(m->also, lon, lat);
    return a == 1 ? 1 : r == -1 && a == -1 ? -1 : 0;
}

void landmask_add(landmask *m, landmask *also)
{
    while (m->also)
        m = m->also;
    m->also = also;
}

landmask *landmask_from_raster(const ice_raster *r, const char *key, sph_error *err)
{
    if (!r->land || !r->nland) {
        sph_err_set(err, SPH_ERR_CONFIG, "%s: initial raster %s flags no land (no land, coast or lake in its "
                    "flag_values/flag_meanings or status_flag)", key, r->path);
        return NULL;
    }
    size_t n = (size_t)r->nlon * r->nlat;
    unsigned char *land = malloc(n ? n : 1);
    if (!land) {
        sph_err_set(err, SPH_ERR_NOMEM, "land mask %s: out of memory", r->path);
        return NULL;
    }
    for (size_t k = 0; k < n; k++)
        land[k] = r->land[k] == 1;
    landmask *m = r->kind == ICE_RASTER_LONLAT
                      ? landmask_create_array(r->nlon, r->nlat, r->lon[0] - r->dlon / 2, r->lat[0] - r->dlat / 2,
                                              r->dlon, r->dlat, land, err)
                      : native_create((size_t)r->nlon, (size_t)r->nlat, r->cell_lon, r->cell_lat, land, r->path, err);
    free(land);
    return m;
}

static int is_land_one(const landmask *m, double lon, double lat)
{
    if (!m || !isfinite(lon) || !isfinite(lat))
        return -1;
    if (m->native) {
        long k = native_nearest(m, lon, lat);
        return k < 0 ? -1 : m->land[k];
    }
    double u = lon - m->lon0;
    u -= 360.0 * floor(u / 360.0); /* 0..360 east of the grid's west edge */
    double fi = u / m->dlon, fj = (lat - m->lat0) / m->dlat;
    if (fi >= m->nlon || fj < 0 || fj >= m->nlat)
        return -1;
    return m->land[(size_t)fj * m->nlon + (size_t)fi];
}

void landmask_get_grid(const landmask *m, int *nlon, int *nlat, double *lon0, double *lat0,
                       double *dlon, double *dlat)
{
    if (nlon) *nlon = m->nlon;
    if (nlat) *nlat = m->nlat;
    if (lon0) *lon0 = m->lon0;
    if (lat0) *lat0 = m->lat0;
    if (dlon) *dlon = m->dlon;
    if (dlat) *dlat = m->dlat;
}

const unsigned char *landmask_data(const landmask *m) { return m ? m->land : NULL; }

int landmask_is_native(const landmask *m) { return m && m->native; }

double landmask_native_spacing_m(const landmask *m)
{
    double s = m && m->native ? m->spacing * 6371000.0 : NAN, a = m && m->also ? landmask_native_spacing_m(m->also) : NAN;
    return isnan(s) || a < s ? a : s;
}

/* ---------------------------------------------------------------- GSHHG */

const char *landmask_gshhg_default_path(void)
{
    const char *env = getenv("SPHICE_GSHHG");
    if (env && *env)
        return env;
    static const char *const candidates[] = {"/usr/share/gmt-gshhg/binned_GSHHS_f.nc",
                                             "/usr/share/gmt-gshhg/binned_GSHHS_h.nc",
                                             "/usr/share/gshhg-gmt-nc4/binned_GSHHS_f.nc",
                                             "/usr/share/gshhg-gmt-nc4/binned_GSHHS_h.nc"};
    for (size_t k = 0; k < sizeof candidates / sizeof candidates[0]; k++)
        if (access(candidates[k], R_OK) == 0)
            return candidates[k];
    return NULL;
}

typedef struct {
    int ncid;
    const char *path;
    sph_error *err;
} nc_ctx;

static int nc_fail(nc_ctx *c, int status, const char *what)
{
    return sph_err_set(c->err, SPH_ERR_NETCDF, "land mask %s: %s: %s", c->path, what,
                       nc_strerror(status));
}

/* Reads start..start+count-1 of an int/short variable as int. */
static int read_ints(nc_ctx *c, const char *name, size_t start, size_t count, int *out)
{
    int varid, status = nc_inq_varid(c->ncid, name, &varid);
    if (status != NC_NOERR)
        return sph_err_set(c->err, SPH_ERR_MISSING_VAR,
                           "land mask %s: not a GSHHG binned file: no variable %s", c->path, name);
    if (count == 0)
        return SPH_OK;
    status = nc_get_vara_int(c->ncid, varid, &start, &count, out);
    if (status != NC_NOERR)
        return nc_fail(c, status, name);
    return SPH_OK;
}

typedef struct {
    double x0, y0, x1, y1;
} edge;

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

landmask *landmask_create_gshhg(const char *path, const landmask_grid *g, sph_error *err)
{
    if (!path)
        path = landmask_gshhg_default_path();
    if (!path) {
        sph_err_set(err, SPH_ERR_IO, "land mask: no GSHHG file configured and none installed "
                    "(install gmt-gshhg-high or set SPHICE_GSHHG)");
        return NULL;
    }
    if (!g || !(g->resolution > 0) || !(g->lon_max > g->lon_min) || !(g->lat_max > g->lat_min) ||
        g->lat_min < -90 || g->lat_max > 90 || g->lon_max - g->lon_min > 360) {
        sph_err_set(err, SPH_ERR_PARAM, "land mask %s: bad region or resolution", path);
        return NULL;
    }
    int nlon = (int)ceil((g->lon_max - g->lon_min) / g->resolution - 1e-9);
    int nlat = (int)ceil((g->lat_max - g->lat_min) / g->resolution - 1e-9);
    landmask *m = mask_alloc(nlon, nlat, g->lon_min, g->lat_min, g->resolution, g->resolution,
                             err);
    if (!m)
        return NULL;

    nc_ctx c = {-1, path, err};
    int status = nc_open(path, NC_NOWRITE, &c.ncid);
    if (status != NC_NOERR) {
        nc_fail(&c, status, "open");
        landmask_free(m);
        return NULL;
    }
    int bin_minutes = 0, nbx = 0, nby = 0, nbins = 0;
    int *first_seg = NULL, *nseg = NULL, *node_levels = NULL, *seg_info = NULL, *seg_first = NULL;
    int *px = NULL, *py = NULL;
    edge *edges = NULL;
    double *wests = NULL, *xs = NULL;
    size_t edges_cap = 0, xs_cap = 0, pts_cap = 0, segs_cap = 0, wests_cap = 0;
    int rc = read_ints(&c, "Bin_size_in_minutes", 0, 1, &bin_minutes);
    if (rc == SPH_OK) rc = read_ints(&c, "N_bins_in_360_longitude_range", 0, 1, &nbx);
    if (rc == SPH_OK) rc = read_ints(&c, "N_bins_in_180_degree_latitude_range", 0, 1, &nby);
    if (rc == SPH_OK) rc = read_ints(&c, "N_bins_in_file", 0, 1, &nbins);
    if (rc == SPH_OK && (bin_minutes <= 0 || nbx <= 0 || nby <= 0 || nbins != nbx * nby))
        rc = sph_err_set(err, SPH_ERR_BAD_DATA, "land mask %s: inconsistent bin layout "
                         "(%d minutes, %d x %d bins, %d in file)", path, bin_minutes, nbx, nby, nbins);
    if (rc == SPH_OK) {
        first_seg = malloc(sizeof(int) * (size_t)nbins);
        nseg = malloc(sizeof(int) * (size_t)nbins);
        node_levels = malloc(sizeof(int) * (size_t)nbins);
        if (!first_seg || !nseg || !node_levels)
            rc = sph_err_set(err, SPH_ERR_NOMEM, "land mask %s: out of memory", path);
    }
    if (rc == SPH_OK) rc = read_ints(&c, "Id_of_first_segment_in_a_bin", 0, (size_t)nbins, first_seg);
    if (rc == SPH_OK) rc = read_ints(&c, "N_segments_in_a_bin", 0, (size_t)nbins, nseg);
    if (rc == SPH_OK) rc = read_ints(&c, "Embedded_node_levels_in_a_bin", 0, (size_t)nbins, node_levels);

    const double bsize = bin_minutes / 60.0;
    /* Bins touched by the region: rows from the north, columns from 0 E. */
    int row_n = rc == SPH_OK ? (int)floor((90.0 - g->lat_max) / bsize) : 0;
    int row_s = rc == SPH_OK ? (int)floor((90.0 - (g->lat_min + 1e-12)) / bsize) : -1;
    if (row_n < 0) row_n = 0;
    if (row_s >= nby) row_s = nby - 1;
    double west_bins = floor(g->lon_min / bsize);
    int ncols = rc == SPH_OK ? (int)ceil(g->lon_max / bsize) - (int)west_bins : 0;
    for (int row = row_n; rc == SPH_OK && row <= row_s; row++) {
        double south = 90.0 - (row + 1) * bsize;
        /* grid rows whose centre lies in [south, south + bsize) */
        int j0 = (int)ceil((south - m->lat0) / m->dlat - 0.5);
        int j1 = (int)ceil((south + bsize - m->lat0) / m->dlat - 0.5) - 1;
        if (j0 < 0) j0 = 0;
        if (j1 >= m->nlat) j1 = m->nlat - 1;
        if (j0 > j1)
            continue;
        for (int cc = 0; rc == SPH_OK && cc < ncols; cc++) {
            double west = (west_bins + cc) * bsize; /* may be < 0 or >= 360 */
            int col = (int)(west_bins + cc) % nbx;
            if (col < 0) col += nbx;
            int b = row * nbx + col;
            int i0 = (int)ceil((west - m->lon0) / m->dlon - 0.5);
            int i1 = (int)ceil((west + bsize - m->lon0) / m->dlon - 0.5) - 1;
            if (i0 < 0) i0 = 0;
            if (i1 >= m->nlon) i1 = m->nlon - 1;
            if (i0 > i1)
                continue;
            int sw_land = ((node_levels[b] >> 9) & 7) >= 1;
            size_t ns = nseg[b] > 0 ? (size_t)nseg[b] : 0, nedges = 0, nwest = 0;
            if (ns > segs_cap) {
                free(seg_info);
                free(seg_first);
                seg_info = malloc(sizeof(int) * ns);
                seg_first = malloc(sizeof(int) * ns);
                segs_cap = ns;
                if (!seg_info || !seg_first) {
                    segs_cap = 0;
                    rc = sph_err_set(err, SPH_ERR_NOMEM, "land mask %s: out of memory", path);
                    break;
                }
            }
            if (ns) {
                rc = read_ints(&c, "Embedded_npts_levels_exit_entry_for_a_segment",
                               (size_t)first_seg[b], ns, seg_info);
                if (rc == SPH_OK)
                    rc = read_ints(&c, "Id_of_first_point_in_a_segment", (size_t)first_seg[b], ns,
                                   seg_first);
            }
            for (size_t s = 0; rc == SPH_OK && s < ns; s++) {
                int info = seg_info[s];
                size_t npts = (size_t)(info >> 9);
                int level = (info >> 6) & 7, entry = (info >> 3) & 7, exit_side = info & 7;
                if (level != 1 || npts < 2)
                    continue;
                if (npts > pts_cap) {
                    free(px);
                    free(py);
                    px = malloc(sizeof(int) * npts);
                    py = malloc(sizeof(int) * npts);
                    pts_cap = npts;
                    if (!px || !py) {
                        pts_cap = 0;
                        rc = sph_err_set(err, SPH_ERR_NOMEM, "land mask %s: out of memory", path);
                        break;
                    }
                }
                rc = read_ints(&c, "Relative_longitude_from_SW_corner_of_bin", (size_t)seg_first[s],
                               npts, px);
                if (rc == SPH_OK)
                    rc = read_ints(&c, "Relative_latitude_from_SW_corner_of_bin",
                                   (size_t)seg_first[s], npts, py);
                if (rc != SPH_OK)
                    break;
                int closed = entry == 4 || exit_side == 4;
                size_t ne = npts - 1 + (closed ? 1 : 0);
                if (nedges + ne > edges_cap) {
                    size_t cap = 2 * (nedges + ne);
                    edge *ne_ = realloc(edges, cap * sizeof *edges);
                    if (!ne_) {
                        rc = sph_err_set(err, SPH_ERR_NOMEM, "land mask %s: out of memory", path);
                        break;
                    }
                    edges = ne_;
                    edges_cap = cap;
                }
                for (size_t k = 0; k < ne; k++) {
                    size_t k1 = (k + 1) % npts;
                    /* stored as signed 16 bits, meaning 0..65535 */
                    edges[nedges].x0 = (uint16_t)px[k];
                    edges[nedges].y0 = (uint16_t)py[k];
                    edges[nedges].x1 = (uint16_t)px[k1];
                    edges[nedges].y1 = (uint16_t)py[k1];
                    nedges++;
                }
                if (nwest + 2 > wests_cap) {
                    size_t cap = 2 * (nwest + 2);
                    double *nw = realloc(wests, cap * sizeof *wests);
                    if (!nw) {
                        rc = sph_err_set(err, SPH_ERR_NOMEM, "land mask %s: out of memory", path);
                        break;
                    }
                    wests = nw;
                    wests_cap = cap;
                }
                if (entry == 3)
                    wests[nwest++] = (uint16_t)py[0];
                if (exit_side == 3)
                    wests[nwest++] = (uint16_t)py[npts - 1];
            }
            if (rc != SPH_OK)
                break;
            if (nedges > xs_cap) {
                double *nx_ = realloc(xs, sizeof *xs * edges_cap);
                if (!nx_) {
                    rc = sph_err_set(err, SPH_ERR_NOMEM, "land mask %s: out of memory", path);
                    break;
                }
                xs = nx_;
                xs_cap = edges_cap;
            }
            const double scale = 65535.0 / bsize; /* bin units per degree */
            for (int j = j0; j <= j1; j++) {
                double pyv = (m->lat0 + (j + 0.5) * m->dlat - south) * scale;
                size_t nx = 0, nw = 0;
                for (size_t k = 0; k < nwest; k++)
                    if (wests[k] > 0 && wests[k] <= pyv)
                        nw++;
                for (size_t k = 0; k < nedges; k++) {
                    const edge *e = &edges[k];
                    if ((e->y0 > pyv) != (e->y1 > pyv))
                        xs[nx++] = e->x0 + (pyv - e->y0) * (e->x1 - e->x0) / (e->y1 - e->y0);
                }
                if (nx > 1)
                    qsort(xs, nx, sizeof *xs, cmp_double);
                size_t q = 0;
                for (int i = i0; i <= i1; i++) {
                    double pxv = (m->lon0 + (i + 0.5) * m->dlon - west) * scale;
                    while (q < nx && xs[q] < pxv)
                        q++;
                    m->land[(size_t)j * m->nlon + i] = (unsigned char)(sw_land ^ ((nw + q) & 1));
                }
            }
        }
    }
    nc_close(c.ncid);
    free(first_seg);
    free(nseg);
    free(node_levels);
    free(seg_info);
    free(seg_first);
    free(px);
    free(py);
    free(edges);
    free(wests);
    free(xs);
    if (rc != SPH_OK) {
        landmask_free(m);
        return NULL;
    }
    log_debug("land mask: %d x %d cells at %g deg from %s", m->nlon, m->nlat, m->dlon, path);
    return m;
}

/* ------------------------------------------------------ NetCDF masks */

/* ------------------------------------------------------ native grids
 *
 * A mask on the model's own grid (curvilinear with 2-D lon/lat, or 1-D
 * axes that are not regular): a point is land where the cell whose centre
 * is nearest (on the sphere) is land. Centres are unit vectors bucketed in
 * a 3-D grid; a point farther from the nearest centre than that cell's
 * reach (its largest distance to a neighbouring centre) is outside the
 * grid (-1). */

static void unit_vec(double lon, double lat, double v[3])
{
    double a = lon * M_PI / 180.0, b = lat * M_PI / 180.0;
    v[0] = cos(b) * cos(a);
    v[1] = cos(b) * sin(a);
    v[2] = sin(b);
}

static double chord2(const float *a, const double *b)
{
    double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return dx * dx + dy * dy + dz * dz;
}

static int bucket_coord(const landmask *m, double x, int d)
{
    int c = (int)floor((x - m->bmin[d]) / m->bsize);
    return c < 0 ? 0 : c >= m->nb[d] ? m->nb[d] - 1 : c;
}

/* Takes lon/lat (nx*ny, row-major j*nx+i) and the land flags. */
static landmask *native_create(size_t nx, size_t ny, const double *lon, const double *lat,
                               const unsigned char *land, const char *path, sph_error *err)
{
    size_t n = nx * ny;
    if (n == 0 || n > 200000000u) {
        sph_err_set(err, SPH_ERR_PARAM, "land mask %s: bad native grid %zu x %zu", path, nx, ny);
        return NULL;
    }
    landmask *m = calloc(1, sizeof *m);
    if (!m) {
        sph_err_set(err, SPH_ERR_NOMEM, "land mask %s: out of memory", path);
        return NULL;
    }
    m->native = 1;
    m->nlon = (int)nx;
    m->nlat = (int)ny;
    m->lon0 = m->lat0 = m->dlon = m->dlat = NAN;
    m->land = malloc(n);
    m->xyz = malloc(sizeof *m->xyz * 3 * n);
    m->reach2 = malloc(sizeof *m->reach2 * n);
    m->bidx = malloc(sizeof *m->bidx * n);
    if (!m->land || !m->xyz || !m->reach2 || !m->bidx)
        goto nomem;
    double lo[3] = {2, 2, 2}, hi[3] = {-2, -2, -2}, sum = 0;
    size_t nsum = 0;
    for (size_t k = 0; k < n; k++) {
        double v[3];
        m->land[k] = land[k] ? 1 : 0;
        if (!isfinite(lon[k]) || !isfinite(lat[k]) || fabs(lat[k]) > 90) {
            m->xyz[3 * k] = m->xyz[3 * k + 1] = m->xyz[3 * k + 2] = NAN;
            continue;
        }
        unit_vec(lon[k], lat[k], v);
        for (int d = 0; d < 3; d++) {
            m->xyz[3 * k + d] = (float)v[d];
            lo[d] = fmin(lo[d], v[d]);
            hi[d] = fmax(hi[d], v[d]);
        }
    }
    for (size_t j = 0; j < ny; j++)
        for (size_t i = 0; i < nx; i++) {
            size_t k = j * nx + i;
            double r2 = 0, c[3] = {m->xyz[3 * k], m->xyz[3 * k + 1], m->xyz[3 * k + 2]};
            const long di[8] = {-1, 1, 0, 0, -1, -1, 1, 1}, dj[8] = {0, 0, -1, 1, -1, 1, -1, 1};
            for (int q = 0; q < 8; q++) {
                long ii = (long)i + di[q], jj = (long)j + dj[q];
                if (ii < 0 || jj < 0 || ii >= (long)nx || jj >= (long)ny)
                    continue;
                double d2 = chord2(&m->xyz[3 * ((size_t)jj * nx + (size_t)ii)], c);
                if (isfinite(d2) && d2 > r2)
                    r2 = d2;
                if (q < 4 && isfinite(d2) && d2 > 0) {
                    sum += sqrt(d2);
                    nsum++;
                }
            }
            /* a single row or column: reach from its one direction */
            m->reach2[k] = (float)(r2 * 1.0001);
        }
    if (nsum == 0 || !(hi[0] >= lo[0])) {
        sph_err_set(err, SPH_ERR_BAD_DATA, "land mask %s: native grid has no valid neighbouring "
                    "cell centres", path);
        landmask_free(m);
        return NULL;
    }
    double spacing = sum / (double)nsum;
    m->spacing = spacing;
    m->bsize = 2 * spacing;
    for (;;) {
        double nb = 1;
        for (int d = 0; d < 3; d++)
            nb *= floor((hi[d] - lo[d]) / m->bsize) + 1;
        if (nb <= 4.0 * (double)n + 64 && nb <= 3e7)
            break;
        m->bsize *= 1.26;
    }
    size_t nbt = 1;
    for (int d = 0; d < 3; d++) {
        m->bmin[d] = lo[d];
        m->nb[d] = (int)floor((hi[d] - lo[d]) / m->bsize) + 1;
        nbt *= (size_t)m->nb[d];
    }
    m->bstart = calloc(nbt + 1, sizeof *m->bstart);
    if (!m->bstart)
        goto nomem;
    for (int pass = 0; pass < 2; pass++) {
        for (size_t k = 0; k < n; k++) {
            if (isnan(m->xyz[3 * k]))
                continue;
            size_t b = ((size_t)bucket_coord(m, m->xyz[3 * k + 2], 2) * (size_t)m->nb[1] +
                        (size_t)bucket_coord(m, m->xyz[3 * k + 1], 1)) * (size_t)m->nb[0] +
                       (size_t)bucket_coord(m, m->xyz[3 * k], 0);
            if (pass == 0)
                m->bstart[b + 1]++;
            else
                m->bidx[m->bstart[b]++] = (uint32_t)k;
        }
        if (pass == 0)
            for (size_t q = 0; q < nbt; q++)
                m->bstart[q + 1] += m->bstart[q];
    }
    /* the second pass advanced each start to the next bucket's: shift back */
    for (size_t q = nbt; q > 0; q--)
        m->bstart[q] = m->bstart[q - 1];
    m->bstart[0] = 0;
    return m;
nomem:
    sph_err_set(err, SPH_ERR_NOMEM, "land mask %s: out of memory for %zu x %zu cells", path, nx, ny);
    landmask_free(m);
    return NULL;
}

/* Index of the nearest native centre, or -1 if none lies within its reach. */
static long native_nearest(const landmask *m, double lon, double lat)
{
    double q[3];
    unit_vec(lon, lat, q);
    int c[3];
    for (int d = 0; d < 3; d++) {
        if (q[d] < m->bmin[d] - m->bsize || q[d] > m->bmin[d] + (m->nb[d] + 1) * m->bsize)
            return -1;
        c[d] = bucket_coord(m, q[d], d);
    }
    double best = INFINITY;
    long bk = -1;
    int rmax = m->nb[0] + m->nb[1] + m->nb[2];
    for (int r = 0; r <= rmax; r++) {
        for (int z = c[2] - r; z <= c[2] + r; z++) {
            if (z < 0 || z >= m->nb[2])
                continue;
            for (int y = c[1] - r; y <= c[1] + r; y++) {
                if (y < 0 || y >= m->nb[1])
                    continue;
                for (int x = c[0] - r; x <= c[0] + r; x++) {
                    if (x < 0 || x >= m->nb[0])
                        continue;
                    if (abs(x - c[0]) != r && abs(y - c[1]) != r && abs(z - c[2]) != r)
                        continue; /* inside: seen in an earlier shell */
                    size_t b = ((size_t)z * (size_t)m->nb[1] + (size_t)y) * (size_t)m->nb[0] + (size_t)x;
                    for (uint32_t t = m->bstart[b]; t < m->bstart[b + 1]; t++) {
                        uint32_t k = m->bidx[t];
                        double d2 = chord2(&m->xyz[3 * (size_t)k], q);
                        if (d2 < best || (d2 == best && (long)k < bk)) {
                            best = d2;
                            bk = (long)k;
                        }
                    }
                }
            }
        }
        /* every centre not yet seen is farther than r bucket widths */
        double reach = (double)r * m->bsize;
        if (bk >= 0 && best <= reach * reach)
            break;
        if (bk < 0 && reach > 4 * m->bsize)
            return -1;
    }
    if (bk < 0 || !(best <= m->reach2[bk]))
        return -1;
    return bk;
}

/* ------------------------------------------------------ NetCDF masks */

/* Text attribute into buf ("" when absent or too long). */
static const char *att_text(int ncid, int varid, const char *att, char *buf, size_t cap)
{
    size_t len;
    buf[0] = '\0';
    if (nc_inq_attlen(ncid, varid, att, &len) != NC_NOERR || len >= cap)
        return buf;
    nc_type t;
    if (nc_inq_atttype(ncid, varid, att, &t) != NC_NOERR || t != NC_CHAR)
        return buf;
    if (nc_get_att_text(ncid, varid, att, buf) != NC_NOERR)
        len = 0;
    buf[len] = '\0';
    return buf;
}

static int att_is(int ncid, int varid, const char *att, const char *want)
{
    char buf[256];
    return strcmp(att_text(ncid, varid, att, buf, sizeof buf), want) == 0;
}

static const char *var_name(int ncid, int varid, char *buf)
{
    if (nc_inq_varname(ncid, varid, buf) != NC_NOERR)
        strcpy(buf, "?");
    return buf;
}

/* 1 longitude, 2 latitude, 0 neither (standard_name, then units). */
static int lonlat_kind(int ncid, int varid)
{
    char sn[64], u[64];
    att_text(ncid, varid, "standard_name", sn, sizeof sn);
    if (!strcmp(sn, "longitude") || !strcmp(sn, "grid_longitude"))
        return strcmp(sn, "longitude") ? 0 : 1;
    if (!strcmp(sn, "latitude"))
        return 2;
    if (sn[0])
        return 0;
    att_text(ncid, varid, "units", u, sizeof u);
    if (!strcmp(u, "degrees_east") || !strcmp(u, "degree_east") || !strcmp(u, "degrees_E") ||
        !strcmp(u, "degree_E") || !strcmp(u, "degreesE") || !strcmp(u, "degreeE"))
        return 1;
    if (!strcmp(u, "degrees_north") || !strcmp(u, "degree_north") || !strcmp(u, "degrees_N") ||
        !strcmp(u, "degree_N") || !strcmp(u, "degreesN") || !strcmp(u, "degreeN"))
        return 2;
    return 0;
}

static int word_in(const char *list, const char *const *words)
{
    for (size_t k = 0; words[k]; k++)
        if (strstr(list, words[k]))
            return 1;
    return 0;
}

/* A flag meaning: 1 land, 0 sea, -1 no information. */
static int meaning_class(const char *w)
{
    static const char *const land[] = {"land", "coast", "lake", "pond", "shore", NULL};
    static const char *const sea[] = {"sea", "ocean", "water", "wet", NULL};
    char low[128];
    size_t k;
    for (k = 0; w[k] && k + 1 < sizeof low; k++)
        low[k] = (char)((w[k] >= 'A' && w[k] <= 'Z') ? w[k] + 32 : w[k]);
    low[k] = '\0';
    if (word_in(low, land))
        return 1;
    if (word_in(low, sea))
        return 0;
    return -1;
}

enum { CLS_EQ, CLS_GT_HALF, CLS_LT_HALF, CLS_FLAGS, CLS_FILL };
#define MAX_FLAGS 32

typedef struct {
    int kind;
    double land_value;
    size_t nflags;
    double flag[MAX_FLAGS];
    int flag_land[MAX_FLAGS]; /* 1 land, 0 sea, -1 no information (sea) */
    char why[512];
} classifier;

static int is_mask_standard_name(int ncid, int v)
{
    return att_is(ncid, v, "standard_name", "land_binary_mask") ||
           att_is(ncid, v, "standard_name", "sea_binary_mask") ||
           att_is(ncid, v, "standard_name", "land_area_fraction") ||
           att_is(ncid, v, "standard_name", "sea_area_fraction");
}

static int has_flag_land(int ncid, int v)
{
    char fm[1024];
    att_text(ncid, v, "flag_meanings", fm, sizeof fm);
    char *save = NULL;
    for (char *w = strtok_r(fm, " ", &save); w; w = strtok_r(NULL, " ", &save))
        if (meaning_class(w) == 1)
            return 1;
    return 0;
}

/* How a mask variable says land; refuses what it does not say. */
static int classify_mask(nc_ctx *c, int v, const landmask_read_opts *o, classifier *cl)
{
    char name[NC_MAX_NAME + 1], sn[128];
    var_name(c->ncid, v, name);
    att_text(c->ncid, v, "standard_name", sn, sizeof sn);
    memset(cl, 0, sizeof *cl);
    if (isfinite(o->land_value)) {
        cl->kind = CLS_EQ;
        cl->land_value = o->land_value;
        snprintf(cl->why, sizeof cl->why, "land where %s = %g (landmask.land_value)", name,
                 o->land_value);
        return SPH_OK;
    }
    if (o->polarity == LANDMASK_POL_LAND_IS_1 || o->polarity == LANDMASK_POL_WATER_IS_1) {
        cl->kind = o->polarity == LANDMASK_POL_LAND_IS_1 ? CLS_GT_HALF : CLS_LT_HALF;
        snprintf(cl->why, sizeof cl->why, "land where %s is %s (landmask.polarity)", name,
                 o->polarity == LANDMASK_POL_LAND_IS_1 ? "1" : "0");
        return SPH_OK;
    }
    size_t nfv = 0;
    nc_type ft;
    if (nc_inq_att(c->ncid, v, "flag_values", &ft, &nfv) == NC_NOERR && nfv > 0) {
        char fm[1024];
        att_text(c->ncid, v, "flag_meanings", fm, sizeof fm);
        if (!fm[0])
            return sph_err_set(c->err, SPH_ERR_BAD_DATA,
                               "land mask %s: variable %s has flag_values but no flag_meanings: "
                               "set landmask.land_value", c->path, name);
        if (nfv > MAX_FLAGS)
            return sph_err_set(c->err, SPH_ERR_BAD_DATA,
                               "land mask %s: variable %s has %zu flag_values (at most %d): set "
                               "landmask.land_value", c->path, name, nfv, MAX_FLAGS);
        nc_get_att_double(c->ncid, v, "flag_values", cl->flag);
        char *save = NULL, *w = strtok_r(fm, " ", &save);
        size_t k = 0, nland = 0;
        for (; w && k < nfv; k++, w = strtok_r(NULL, " ", &save)) {
            cl->flag_land[k] = meaning_class(w);
            nland += cl->flag_land[k] == 1;
        }
        if (k != nfv || w)
            return sph_err_set(c->err, SPH_ERR_BAD_DATA,
                               "land mask %s: variable %s has %zu flag_values but a different "
                               "number of flag_meanings: set landmask.land_value", c->path, name, nfv);
        if (nland == 0)
            return sph_err_set(c->err, SPH_ERR_BAD_DATA,
                               "land mask %s: variable %s: no flag_meanings name land: set "
                               "landmask.land_value", c->path, name);
        cl->nflags = nfv;
        cl->kind = CLS_FLAGS;
        snprintf(cl->why, sizeof cl->why, "land from the flag_meanings of %s", name);
        return SPH_OK;
    }
    /* older ROMS files: option_0 = "land", option_1 = "water" */
    for (int k = 0; k < 10 && cl->nflags < MAX_FLAGS; k++) {
        char att[32], text[128];
        snprintf(att, sizeof att, "option_%d", k);
        if (!att_text(c->ncid, v, att, text, sizeof text)[0])
            continue;
        cl->flag[cl->nflags] = k;
        cl->flag_land[cl->nflags++] = meaning_class(text);
    }
    if (cl->nflags) {
        size_t nland = 0;
        for (size_t k = 0; k < cl->nflags; k++)
            nland += cl->flag_land[k] == 1;
        if (nland == 0)
            return sph_err_set(c->err, SPH_ERR_BAD_DATA,
                               "land mask %s: variable %s: no option_N attribute names land: set "
                               "landmask.land_value", c->path, name);
        cl->kind = CLS_FLAGS;
        snprintf(cl->why, sizeof cl->why, "land from the option_N attributes of %s", name);
        return SPH_OK;
    }
    if (!strcmp(sn, "land_binary_mask") || !strcmp(sn, "land_area_fraction") ||
        !strcmp(name, "lsm") || !strcmp(name, "LSM")) {
        cl->kind = CLS_GT_HALF;
        snprintf(cl->why, sizeof cl->why, "land where %s > 0.5 (%s)", name, sn[0] ? sn : "ERA5 lsm");
        return SPH_OK;
    }
    if (!strcmp(sn, "sea_binary_mask") || !strcmp(sn, "sea_area_fraction")) {
        cl->kind = CLS_LT_HALF;
        snprintf(cl->why, sizeof cl->why, "land where %s < 0.5 (%s)", name, sn);
        return SPH_OK;
    }
    if (!strcmp(name, "mask_rho") || !strcmp(name, "mask_u") || !strcmp(name, "mask_v") ||
        !strcmp(name, "mask_psi")) {
        cl->kind = CLS_LT_HALF; /* ROMS: 1 water, 0 land */
        snprintf(cl->why, sizeof cl->why, "land where %s = 0 (ROMS)", name);
        return SPH_OK;
    }
    return sph_err_set(c->err, SPH_ERR_BAD_DATA,
                       "land mask %s: variable %s does not say which value is land (no flag_meanings, "
                       "no land/sea standard_name): set landmask.land_value or landmask.polarity",
                       c->path, name);
}

static int looks_like_mask(int ncid, int v)
{
    char name[NC_MAX_NAME + 1];
    var_name(ncid, v, name);
    return is_mask_standard_name(ncid, v) || has_flag_land(ncid, v) || strstr(name, "mask") ||
           !strcmp(name, "lsm") || !strcmp(name, "LSM");
}

/* The mask variable of a file, -1 if none. */
static int find_mask_var(int ncid)
{
    int nvars = 0;
    nc_inq_nvars(ncid, &nvars);
    for (int pass = 0; pass < 4; pass++)
        for (int v = 0; v < nvars; v++) {
            int nd = 0;
            nc_inq_varndims(ncid, v, &nd);
            if (nd < 2)
                continue;
            char name[NC_MAX_NAME + 1];
            var_name(ncid, v, name);
            if ((pass == 0 && is_mask_standard_name(ncid, v)) ||
                (pass == 1 && has_flag_land(ncid, v)) || (pass == 2 && !strcmp(name, "mask_rho")) ||
                (pass == 3 && looks_like_mask(ncid, v)))
                return v;
        }
    return -1;
}

/* A current (or sea-surface height) whose fill marks land, -1 if none. */
static int find_fill_var(int ncid)
{
    static const char *const sns[] = {"eastward_sea_water_velocity", "sea_water_x_velocity",
                                      "x_sea_water_velocity", "surface_eastward_sea_water_velocity",
                                      "northward_sea_water_velocity", "sea_water_y_velocity",
                                      "y_sea_water_velocity", "sea_surface_height_above_geoid",
                                      "sea_surface_elevation", "sea_surface_height", NULL};
    static const char *const names[] = {"uo", "u", "vozocrtx", "u_eastward", "water_u", "uos",
                                        "zeta", "zos", "ssh", "sossheig", NULL};
    int nvars = 0;
    nc_inq_nvars(ncid, &nvars);
    for (size_t k = 0; sns[k]; k++)
        for (int v = 0; v < nvars; v++)
            if (att_is(ncid, v, "standard_name", sns[k]))
                return v;
    for (size_t k = 0; names[k]; k++) {
        int v;
        if (nc_inq_varid(ncid, names[k], &v) == NC_NOERR)
            return v;
    }
    return -1;
}

/* The index to read along a leading dimension: time-like or of size 1: 0;
 * vertical: the level nearest the surface; anything else is refused. */
static int leading_index(nc_ctx *c, int v, int dimid, size_t *index)
{
    char dname[NC_MAX_NAME + 1], vname[NC_MAX_NAME + 1];
    size_t len = 0;
    nc_inq_dim(c->ncid, dimid, dname, &len);
    var_name(c->ncid, v, vname);
    *index = 0;
    int unlim[NC_MAX_DIMS], nunlim = 0;
    nc_inq_unlimdims(c->ncid, &nunlim, unlim);
    for (int k = 0; k < nunlim; k++)
        if (unlim[k] == dimid)
            return SPH_OK;
    if (len <= 1)
        return SPH_OK;
    int cv;
    if (nc_inq_varid(c->ncid, dname, &cv) != NC_NOERR)
        return sph_err_set(c->err, SPH_ERR_BAD_DATA,
                           "land mask %s: variable %s: dimension %s (%zu) has no coordinate variable "
                           "to tell time or depth: set landmask.variable to a 2-D variable",
                           c->path, vname, dname, len);
    char units[128], pos[32], sn[128], axis[8];
    att_text(c->ncid, cv, "units", units, sizeof units);
    att_text(c->ncid, cv, "positive", pos, sizeof pos);
    att_text(c->ncid, cv, "standard_name", sn, sizeof sn);
    att_text(c->ncid, cv, "axis", axis, sizeof axis);
    if (strstr(units, " since ") || !strcmp(axis, "T") || !strcmp(sn, "time"))
        return SPH_OK;
    int down = !strcmp(pos, "down") || !strcmp(pos, "DOWN");
    int up = !strcmp(pos, "up") || !strcmp(pos, "UP");
    if (!down && !up && !strcmp(sn, "depth"))
        down = 1; /* CF: depth is positive down */
    if (!down && !up)
        return sph_err_set(c->err, SPH_ERR_BAD_DATA,
                           "land mask %s: variable %s: cannot tell which level of dimension %s is "
                           "nearest the surface (no positive attribute): set landmask.variable to a "
                           "2-D variable", c->path, vname, dname);
    double *z = malloc(sizeof *z * len);
    if (!z)
        return sph_err_set(c->err, SPH_ERR_NOMEM, "land mask %s: out of memory", c->path);
    int status = nc_get_var_double(c->ncid, cv, z);
    if (status != NC_NOERR) {
        free(z);
        return nc_fail(c, status, dname);
    }
    for (size_t k = 1; k < len; k++)
        if (down ? fabs(z[k]) < fabs(z[*index]) : z[k] > z[*index])
            *index = k;
    free(z);
    return SPH_OK;
}

/* 1-D coordinate of a dimension with the given lon/lat kind, -1 if none. */
static int axis_var(int ncid, int dimid, int kind)
{
    char dname[NC_MAX_NAME + 1];
    int cv, nd = 0;
    if (nc_inq_dimname(ncid, dimid, dname) != NC_NOERR || nc_inq_varid(ncid, dname, &cv) != NC_NOERR)
        return -1;
    nc_inq_varndims(ncid, cv, &nd);
    if (nd != 1)
        return -1;
    int k = lonlat_kind(ncid, cv);
    if (k == kind)
        return cv;
    /* no units or standard name: the old convention, names lon/lat */
    if (k == 0 && ((kind == 1 && (!strcmp(dname, "lon") || !strcmp(dname, "longitude"))) ||
                   (kind == 2 && (!strcmp(dname, "lat") || !strcmp(dname, "latitude")))))
        return cv;
    return -1;
}

/* 2-D lon or lat on dims (ydim, xdim): from `coordinates`, else any. */
static int coord2d_var(int ncid, int v, int ydim, int xdim, int kind)
{
    char coords[1024];
    att_text(ncid, v, "coordinates", coords, sizeof coords);
    int nvars = 0;
    nc_inq_nvars(ncid, &nvars);
    for (int pass = 0; pass < 2; pass++)
        for (int w = 0; w < nvars; w++) {
            char wn[NC_MAX_NAME + 1];
            var_name(ncid, w, wn);
            int nd = 0, d[NC_MAX_VAR_DIMS];
            nc_inq_varndims(ncid, w, &nd);
            if (nd != 2 || lonlat_kind(ncid, w) != kind)
                continue;
            nc_inq_vardimid(ncid, w, d);
            if (d[0] != ydim || d[1] != xdim)
                continue;
            if (pass == 1)
                return w;
            char tmp[1024], *save = NULL;
            snprintf(tmp, sizeof tmp, "%s", coords);
            for (char *t = strtok_r(tmp, " ", &save); t; t = strtok_r(NULL, " ", &save))
                if (!strcmp(t, wn))
                    return w;
        }
    return -1;
}

static double *read_all(nc_ctx *c, int v, size_t n)
{
    double *a = malloc(sizeof *a * (n ? n : 1));
    if (!a) {
        sph_err_set(c->err, SPH_ERR_NOMEM, "land mask %s: out of memory", c->path);
        return NULL;
    }
    int status = nc_get_var_double(c->ncid, v, a);
    if (status != NC_NOERR) {
        nc_fail(c, status, "read coordinates");
        free(a);
        return NULL;
    }
    return a;
}

/* Regular within 1e-3 of a step: the step, else 0. */
static double regular_step(const double *v, size_t n)
{
    if (n < 2)
        return 0;
    double step = (v[n - 1] - v[0]) / (double)(n - 1);
    if (step == 0)
        return 0;
    for (size_t k = 1; k < n; k++)
        if (!(fabs(v[k] - v[k - 1] - step) <= 1e-3 * fabs(step)))
            return 0;
    return step;
}

static int classify_value(const classifier *cl, double raw, int is_missing, double v)
{
    if (cl->kind == CLS_FILL)
        return is_missing;
    if (is_missing)
        return 0; /* no information: sea, so no ice is lost */
    switch (cl->kind) {
    case CLS_EQ: return fabs(v - cl->land_value) <= 1e-6 * fmax(1, fabs(cl->land_value));
    case CLS_GT_HALF: return v > 0.5;
    case CLS_LT_HALF: return v < 0.5;
    default:
        for (size_t k = 0; k < cl->nflags; k++)
            if (raw == cl->flag[k] || v == cl->flag[k])
                return cl->flag_land[k] == 1;
        return 0; /* a value no flag names: no information */
    }
}

landmask *landmask_read_model(const char *path, const landmask_read_opts *opts, sph_error *err)
{
    sph_error local;
    if (!err) {
        sph_error_clear(&local);
        err = &local;
    }
    landmask_read_opts o;
    if (opts)
        o = *opts;
    else
        o = (landmask_read_opts){NULL, LANDMASK_FROM_AUTO, LANDMASK_POL_AUTO, NAN, 0, NULL, NULL, 0, 0};
    nc_ctx c = {-1, path, err};
    int status = nc_open(path, NC_NOWRITE, &c.ncid);
    if (status != NC_NOERR) {
        nc_fail(&c, status, "open");
        return NULL;
    }
    int v = -1, fill = o.from == LANDMASK_FROM_FILL;
    char vname[NC_MAX_NAME + 1] = "";
    if (o.variable && o.variable[0]) {
        if (nc_inq_varid(c.ncid, o.variable, &v) != NC_NOERR) {
            sph_err_set(err, SPH_ERR_MISSING_VAR, "land mask %s: no variable \"%s\" "
                        "(landmask.variable)", path, o.variable);
            v = -1;
        } else if (o.from == LANDMASK_FROM_AUTO) {
            fill = !(looks_like_mask(c.ncid, v) || isfinite(o.land_value) ||
                     o.polarity != LANDMASK_POL_AUTO);
        }
    } else {
        if (!fill)
            v = find_mask_var(c.ncid);
        if (v < 0 && (fill || (o.from == LANDMASK_FROM_AUTO && o.fill_fallback))) {
            fill = 1;
            v = find_fill_var(c.ncid);
            if (v < 0)
                sph_err_set(err, SPH_ERR_MISSING_VAR,
                            "land mask %s: no mask variable and no current or sea-surface height "
                            "whose fill marks land: set landmask.variable", path);
        } else if (v < 0) {
            sph_err_set(err, SPH_ERR_MISSING_VAR,
                        "land mask %s: no land_binary_mask, sea_binary_mask, land_area_fraction, "
                        "flag_meanings land, mask_rho, lsm or mask variable: set landmask.variable",
                        path);
        }
    }
    classifier cl;
    memset(&cl, 0, sizeof cl);
    if (v >= 0) {
        var_name(c.ncid, v, vname);
        if (fill) {
            cl.kind = CLS_FILL;
            snprintf(cl.why, sizeof cl.why, "land where %s is fill", vname);
        } else if (classify_mask(&c, v, &o, &cl) != SPH_OK) {
            v = -1;
        }
    }
    int nd = 0, dims[NC_MAX_VAR_DIMS];
    size_t start[NC_MAX_VAR_DIMS] = {0}, count[NC_MAX_VAR_DIMS];
    if (v >= 0) {
        nc_inq_varndims(c.ncid, v, &nd);
        nc_inq_vardimid(c.ncid, v, dims);
        if (nd < 2) {
            sph_err_set(err, SPH_ERR_BAD_DATA, "land mask %s: variable %s has %d dimension(s), "
                        "need (y, x)", path, vname, nd);
            v = -1;
        }
        for (int d = 0; v >= 0 && d < nd - 2; d++) {
            count[d] = 1;
            if (leading_index(&c, v, dims[d], &start[d]) != SPH_OK)
                v = -1;
        }
    }
    size_t nx = 0, ny = 0;
    double *lon = NULL, *lat = NULL, *vals = NULL;
    int regular = 0;
    double lon_first = 0, dlon = 0, lat_first = 0, dlat = 0;
    if (v >= 0) {
        int xd = dims[nd - 1], yd = dims[nd - 2];
        nc_inq_dimlen(c.ncid, xd, &nx);
        nc_inq_dimlen(c.ncid, yd, &ny);
        count[nd - 1] = nx;
        count[nd - 2] = ny;
        int ax = axis_var(c.ncid, xd, 1), ay = axis_var(c.ncid, yd, 2);
        int cx = coord2d_var(c.ncid, v, yd, xd, 1), cy = coord2d_var(c.ncid, v, yd, xd, 2);
        lon = malloc(sizeof *lon * nx * ny);
        lat = malloc(sizeof *lat * nx * ny);
        if (!lon || !lat) {
            sph_err_set(err, SPH_ERR_NOMEM, "land mask %s: out of memory", path);
            v = -1;
        } else if (ax >= 0 && ay >= 0) {
            double *x1 = read_all(&c, ax, nx), *y1 = x1 ? read_all(&c, ay, ny) : NULL;
            if (!x1 || !y1) {
                v = -1;
            } else {
                dlon = regular_step(x1, nx);
                dlat = regular_step(y1, ny);
                lon_first = x1[0];
                lat_first = y1[0];
                regular = dlon > 0 && dlat != 0;
                for (size_t j = 0; j < ny; j++)
                    for (size_t i = 0; i < nx; i++) {
                        lon[j * nx + i] = x1[i];
                        lat[j * nx + i] = y1[j];
                    }
            }
            free(x1);
            free(y1);
        } else if (cx >= 0 && cy >= 0) {
            if ((status = nc_get_var_double(c.ncid, cx, lon)) != NC_NOERR ||
                (status = nc_get_var_double(c.ncid, cy, lat)) != NC_NOERR) {
                nc_fail(&c, status, "read 2-D longitude/latitude");
                v = -1;
            }
        } else if (o.cell_lon && o.cell_lat && o.cell_nx == nx && o.cell_ny == ny) {
            memcpy(lon, o.cell_lon, sizeof *lon * nx * ny);
            memcpy(lat, o.cell_lat, sizeof *lat * nx * ny);
        } else {
            sph_err_set(err, SPH_ERR_BAD_DATA, "land mask %s: variable %s: no longitude/latitude "
                        "for its grid (1-D axes or 2-D coordinates): set landmask.variable to a "
                        "variable on a longitude/latitude grid", path, vname);
            v = -1;
        }
    }
    landmask *m = NULL;
    unsigned char *land = NULL;
    if (v >= 0) {
        vals = malloc(sizeof *vals * nx * ny);
        land = malloc(nx * ny);
        if (!vals || !land)
            sph_err_set(err, SPH_ERR_NOMEM, "land mask %s: out of memory", path);
        else if ((status = nc_get_vara_double(c.ncid, v, start, count, vals)) != NC_NOERR)
            nc_fail(&c, status, "read mask variable");
        else {
            double fv = NAN, missing = NAN, scale = 1, offset = 0;
            int has_fill = nc_get_att_double(c.ncid, v, "_FillValue", &fv) == NC_NOERR;
            int has_missing = nc_get_att_double(c.ncid, v, "missing_value", &missing) == NC_NOERR;
            if (!has_fill && cl.kind == CLS_FILL) {
                /* the library's default fill marks unwritten values */
                nc_type t;
                nc_inq_vartype(c.ncid, v, &t);
                fv = t == NC_FLOAT ? NC_FILL_FLOAT : t == NC_DOUBLE ? NC_FILL_DOUBLE
                   : t == NC_SHORT ? NC_FILL_SHORT : t == NC_INT ? NC_FILL_INT
                   : t == NC_BYTE ? NC_FILL_BYTE : NAN;
                has_fill = isfinite(fv);
            }
            nc_get_att_double(c.ncid, v, "scale_factor", &scale);
            nc_get_att_double(c.ncid, v, "add_offset", &offset);
            size_t nland = 0;
            for (size_t k = 0; k < nx * ny; k++) {
                double raw = vals[k];
                int is_missing = isnan(raw) || (has_fill && raw == fv) ||
                                 (has_missing && raw == missing);
                land[k] = (unsigned char)classify_value(&cl, raw, is_missing, raw * scale + offset);
                nland += land[k];
            }
            if (cl.kind == CLS_FILL && nland == nx * ny)
                sph_err_set(err, SPH_ERR_BAD_DATA, "land mask %s: variable %s is fill everywhere "
                            "(no water): set landmask.variable", path, vname);
            else if (regular) {
                m = mask_alloc((int)nx, (int)ny, lon_first - dlon / 2,
                               (dlat > 0 ? lat_first : lat_first + dlat * (double)(ny - 1)) -
                                   fabs(dlat) / 2, dlon, fabs(dlat), err);
                for (size_t j = 0; m && j < ny; j++) {
                    size_t row = dlat > 0 ? j : ny - 1 - j;
                    memcpy(&m->land[row * nx], &land[j * nx], nx);
                }
            } else {
                m = native_create(nx, ny, lon, lat, land, path, err);
            }
            if (m && cl.kind == CLS_FILL && nland == 0)
                log_warn("land mask %s: variable %s has no fill anywhere: no land (if the model "
                         "writes land as a value, set landmask.variable to its mask)", path, vname);
            if (m)
                log_info("land mask %s: %s, %zu of %zu cells land (%s grid %zu x %zu)", path, cl.why,
                         nland, nx * ny, regular ? "regular lon/lat" : "native", nx, ny);
        }
    }
    free(vals);
    free(land);
    free(lon);
    free(lat);
    nc_close(c.ncid);
    return m;
}

landmask *landmask_read_netcdf(const char *path, const char *variable, landmask_nc_mode mode,
                               sph_error *err)
{
    landmask_read_opts o = {variable, mode == LANDMASK_NC_FILL ? LANDMASK_FROM_FILL
                                                                : LANDMASK_FROM_MASK,
                            LANDMASK_POL_AUTO, NAN, 0, NULL, NULL, 0, 0};
    if (mode == LANDMASK_NC_FILL && !(variable && *variable)) {
        sph_err_set(err, SPH_ERR_CONFIG, "land mask %s: fill-pattern mask needs a variable name "
                    "(landmask.variable)", path);
        return NULL;
    }
    return landmask_read_model(path, &o, err);
}

int landmask_write_netcdf(const landmask *m, const char *path, const char *source, sph_error *err)
{
    if (m->native)
        return sph_err_set(err, SPH_ERR_PARAM, "land mask %s: a mask on a native model grid is "
                           "not written as a lon/lat mask", path);
    char tmp[4096];
    atomic_tmp_name(path, tmp, sizeof tmp);
    int ncid, status, dims[2], vlon, vlat, vmask;
    nc_ctx c = {-1, path, err};
    if ((status = nc_create(tmp, NC_NETCDF4 | NC_CLOBBER, &ncid)) != NC_NOERR)
        return nc_fail(&c, status, "create");
    c.ncid = ncid;
#define TRY(call)                                   \
    do {                                            \
        if ((status = (call)) != NC_NOERR)          \
            goto fail;                              \
    } while (0)
    TRY(nc_def_dim(ncid, "lat", (size_t)m->nlat, &dims[0]));
    TRY(nc_def_dim(ncid, "lon", (size_t)m->nlon, &dims[1]));
    TRY(nc_def_var(ncid, "lat", NC_DOUBLE, 1, &dims[0], &vlat));
    TRY(nc_def_var(ncid, "lon", NC_DOUBLE, 1, &dims[1], &vlon));
    TRY(nc_def_var(ncid, "land_binary_mask", NC_BYTE, 2, dims, &vmask));
    TRY(nc_def_var_deflate(ncid, vmask, 1, 1, 4));
    TRY(nc_put_att_text(ncid, vlat, "standard_name", 8, "latitude"));
    TRY(nc_put_att_text(ncid, vlat, "units", 13, "degrees_north"));
    TRY(nc_put_att_text(ncid, vlon, "standard_name", 9, "longitude"));
    TRY(nc_put_att_text(ncid, vlon, "units", 12, "degrees_east"));
    TRY(nc_put_att_text(ncid, vmask, "standard_name", 16, "land_binary_mask"));
    TRY(nc_put_att_text(ncid, vmask, "long_name", 30, "land (1) or sea (0) at centre"));
    TRY(nc_put_att_text(ncid, vmask, "units", 1, "1"));
    TRY(nc_put_att_text(ncid, NC_GLOBAL, "Conventions", 6, "CF-1.8"));
    if (source)
        TRY(nc_put_att_text(ncid, NC_GLOBAL, "source", strlen(source), source));
    TRY(nc_enddef(ncid));
    {
        double *axis = malloc(sizeof *axis * (size_t)(m->nlon > m->nlat ? m->nlon : m->nlat));
        if (!axis) {
            nc_close(ncid);
            unlink(tmp);
            return sph_err_set(err, SPH_ERR_NOMEM, "land mask %s: out of memory", path);
        }
        for (int j = 0; j < m->nlat; j++)
            axis[j] = m->lat0 + (j + 0.5) * m->dlat;
        status = nc_put_var_double(ncid, vlat, axis);
        for (int i = 0; status == NC_NOERR && i < m->nlon; i++)
            axis[i] = m->lon0 + (i + 0.5) * m->dlon;
        if (status == NC_NOERR)
            status = nc_put_var_double(ncid, vlon, axis);
        free(axis);
        if (status != NC_NOERR)
            goto fail;
    }
    TRY(nc_put_var_uchar(ncid, vmask, m->land));
    TRY(nc_close(ncid));
#undef TRY
    return atomic_commit(tmp, path, err);
fail:
    nc_close(ncid);
    unlink(tmp);
    return nc_fail(&c, status, "write");
}

/* ------------------------------------------------------ model plane */

int landmask_to_plane(const landmask *m, const geo_proj *p, double x0, double y0, double dx,
                      double dy, int nx, int ny, unsigned char *out, sph_error *err)
{
    if (!m || !p || nx <= 0 || ny <= 0 || !(dx > 0) || !(dy > 0))
        return sph_err_set(err, SPH_ERR_PARAM, "land mask to plane: bad grid %d x %d", nx, ny);
    double *x = malloc(sizeof *x * (size_t)nx * 4);
    if (!x)
        return sph_err_set(err, SPH_ERR_NOMEM, "land mask to plane: out of memory");
    double *y = x + nx, *lon = y + nx, *lat = lon + nx;
    int rc = SPH_OK;
    for (int j = 0; j < ny && rc == SPH_OK; j++) {
        for (int i = 0; i < nx; i++) {
            x[i] = x0 + (i + 0.5) * dx;
            y[i] = y0 + (j + 0.5) * dy;
        }
        sph_error local;
        sph_error_clear(&local);
        geo_inverse(p, (size_t)nx, x, y, lon, lat, &local); /* NaN where it fails: sea */
        for (int i = 0; i < nx; i++)
            out[(size_t)j * nx + i] = landmask_is_land(m, lon[i], lat[i]) == 1;
    }
    free(x);
    /* a native land cell is never lost between plane centres: the plane
     * cell that contains its centre is land as well */
    for (; m; m = m->also) /* every mask of a union (landmask_add) */
    for (size_t k = 0; m->native && k < (size_t)m->nlon * (size_t)m->nlat; k++) {
        if (!m->land[k] || isnan(m->xyz[3 * k]))
            continue;
        double vx = m->xyz[3 * k], vy = m->xyz[3 * k + 1], vz = m->xyz[3 * k + 2];
        double clon = atan2(vy, vx) * 180.0 / M_PI, clat = asin(fmax(-1, fmin(1, vz))) * 180.0 / M_PI;
        double px, py;
        sph_error local;
        sph_error_clear(&local);
        if (geo_forward(p, 1, &clon, &clat, &px, &py, &local) != SPH_OK || !isfinite(px) || !isfinite(py))
            continue;
        double fi = floor((px - x0) / dx), fj = floor((py - y0) / dy);
        if (fi >= 0 && fj >= 0 && fi < nx && fj < ny)
            out[(size_t)fj * nx + (size_t)fi] = 1;
    }
    return rc;
}
