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
    int nlon, nlat;
    double lon0, lat0, dlon, dlat; /* south-west corner of cell (0,0), cell size */
    unsigned char *land;
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

int landmask_is_land(const landmask *m, double lon, double lat)
{
    if (!m || !isfinite(lon) || !isfinite(lat))
        return -1;
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

/* A regular 1-D coordinate: first value and step (may be negative). */
static int read_regular_axis(nc_ctx *c, int dimid, const char *what, size_t *n, double *first,
                             double *step)
{
    char name[NC_MAX_NAME + 1];
    int status = nc_inq_dim(c->ncid, dimid, name, n);
    if (status != NC_NOERR)
        return nc_fail(c, status, "dimension");
    int varid;
    if (nc_inq_varid(c->ncid, name, &varid) != NC_NOERR)
        return sph_err_set(c->err, SPH_ERR_MISSING_VAR,
                           "land mask %s: no coordinate variable for %s dimension \"%s\"", c->path,
                           what, name);
    double *v = malloc(sizeof *v * (*n ? *n : 1));
    if (!v)
        return sph_err_set(c->err, SPH_ERR_NOMEM, "land mask %s: out of memory", c->path);
    status = nc_get_var_double(c->ncid, varid, v);
    if (status != NC_NOERR) {
        free(v);
        return nc_fail(c, status, name);
    }
    int rc = SPH_OK;
    if (*n < 2) {
        rc = sph_err_set(c->err, SPH_ERR_BAD_DATA, "land mask %s: %s axis \"%s\" has %zu value(s)",
                         c->path, what, name, *n);
    } else {
        *first = v[0];
        *step = (v[*n - 1] - v[0]) / (double)(*n - 1);
        for (size_t k = 1; k < *n && rc == SPH_OK; k++)
            if (!(fabs(v[k] - v[k - 1] - *step) <= 1e-3 * fabs(*step)) || *step == 0)
                rc = sph_err_set(c->err, SPH_ERR_BAD_DATA,
                                 "land mask %s: %s axis \"%s\" is not regular at index %zu",
                                 c->path, what, name, k);
    }
    free(v);
    return rc;
}

static int att_text_equals(int ncid, int varid, const char *att, const char *want)
{
    size_t len;
    char buf[256];
    if (nc_inq_attlen(ncid, varid, att, &len) != NC_NOERR || len >= sizeof buf)
        return 0;
    if (nc_get_att_text(ncid, varid, att, buf) != NC_NOERR)
        return 0;
    buf[len] = '\0';
    while (len > 0 && buf[len - 1] == '\0')
        len--;
    buf[len] = '\0';
    return strcmp(buf, want) == 0;
}

enum { KIND_LAND_GT_HALF, KIND_LAND_LT_HALF, KIND_FILL };

landmask *landmask_read_netcdf(const char *path, const char *variable, landmask_nc_mode mode,
                               sph_error *err)
{
    sph_error local;
    if (!err) {
        sph_error_clear(&local);
        err = &local;
    }
    nc_ctx c = {-1, path, err};
    int status = nc_open(path, NC_NOWRITE, &c.ncid);
    if (status != NC_NOERR) {
        nc_fail(&c, status, "open");
        return NULL;
    }
    int varid = -1, kind = mode == LANDMASK_NC_FILL ? KIND_FILL : KIND_LAND_GT_HALF;
    if (variable && *variable) {
        if (nc_inq_varid(c.ncid, variable, &varid) != NC_NOERR)
            sph_err_set(err, SPH_ERR_MISSING_VAR, "land mask %s: no variable \"%s\"", path, variable);
        else if (mode == LANDMASK_NC_AUTO && att_text_equals(c.ncid, varid, "standard_name",
                                                             "sea_binary_mask"))
            kind = KIND_LAND_LT_HALF;
    } else if (mode == LANDMASK_NC_FILL) {
        sph_err_set(err, SPH_ERR_CONFIG, "land mask %s: fill-pattern mask needs a variable name", path);
    } else {
        int nvars = 0;
        nc_inq_nvars(c.ncid, &nvars);
        for (int v = 0; v < nvars && varid < 0; v++) {
            if (att_text_equals(c.ncid, v, "standard_name", "land_binary_mask") ||
                att_text_equals(c.ncid, v, "standard_name", "land_area_fraction"))
                varid = v;
            else if (att_text_equals(c.ncid, v, "standard_name", "sea_binary_mask"))
                varid = v, kind = KIND_LAND_LT_HALF;
        }
        static const char *const names[] = {"lsm", "LSM", "land_binary_mask", "mask", "landmask"};
        for (size_t k = 0; k < sizeof names / sizeof names[0] && varid < 0; k++)
            if (nc_inq_varid(c.ncid, names[k], &varid) != NC_NOERR)
                varid = -1;
        if (varid < 0)
            sph_err_set(err, SPH_ERR_MISSING_VAR,
                        "land mask %s: no land_binary_mask, sea_binary_mask, land_area_fraction, "
                        "lsm or mask variable", path);
    }
    landmask *m = NULL;
    double *vals = NULL;
    int ndims = 0, dimids[NC_MAX_VAR_DIMS];
    if (varid >= 0) {
        nc_inq_varndims(c.ncid, varid, &ndims);
        nc_inq_vardimid(c.ncid, varid, dimids);
        if (ndims < 2)
            sph_err_set(err, SPH_ERR_BAD_DATA, "land mask %s: variable has %d dimension(s), need lat, lon",
                        path, ndims);
    }
    size_t nlon = 0, nlat = 0;
    double lon_first = 0, dlon = 0, lat_first = 0, dlat = 0;
    if (varid >= 0 && ndims >= 2 && err->code == SPH_OK &&
        read_regular_axis(&c, dimids[ndims - 1], "longitude", &nlon, &lon_first, &dlon) == SPH_OK &&
        read_regular_axis(&c, dimids[ndims - 2], "latitude", &nlat, &lat_first, &dlat) == SPH_OK) {
        size_t start[NC_MAX_VAR_DIMS] = {0}, count[NC_MAX_VAR_DIMS];
        for (int d = 0; d < ndims; d++)
            count[d] = 1;
        count[ndims - 1] = nlon;
        count[ndims - 2] = nlat;
        vals = malloc(sizeof *vals * nlon * nlat);
        if (!vals)
            sph_err_set(err, SPH_ERR_NOMEM, "land mask %s: out of memory", path);
        else if ((status = nc_get_vara_double(c.ncid, varid, start, count, vals)) != NC_NOERR)
            nc_fail(&c, status, "read mask variable");
        else if (dlon < 0)
            sph_err_set(err, SPH_ERR_BAD_DATA, "land mask %s: longitude decreases", path);
        else
            m = mask_alloc((int)nlon, (int)nlat, lon_first - dlon / 2,
                           (dlat > 0 ? lat_first : lat_first + dlat * (double)(nlat - 1)) - fabs(dlat) / 2,
                           dlon, fabs(dlat), err);
    }
    if (m) {
        double fill = NAN, missing = NAN, scale = 1, offset = 0;
        int has_fill = nc_get_att_double(c.ncid, varid, "_FillValue", &fill) == NC_NOERR;
        int has_missing = nc_get_att_double(c.ncid, varid, "missing_value", &missing) == NC_NOERR;
        if (!has_fill) {
            /* the library's default fill marks unwritten values */
            nc_type t;
            nc_inq_vartype(c.ncid, varid, &t);
            fill = t == NC_FLOAT ? NC_FILL_FLOAT : t == NC_DOUBLE ? NC_FILL_DOUBLE
                 : t == NC_SHORT ? NC_FILL_SHORT : t == NC_INT ? NC_FILL_INT
                 : t == NC_BYTE ? NC_FILL_BYTE : NAN;
            has_fill = kind == KIND_FILL && isfinite(fill);
        }
        nc_get_att_double(c.ncid, varid, "scale_factor", &scale);
        nc_get_att_double(c.ncid, varid, "add_offset", &offset);
        for (size_t j = 0; j < nlat; j++) {
            size_t row = dlat > 0 ? j : nlat - 1 - j;
            for (size_t i = 0; i < nlon; i++) {
                double raw = vals[j * nlon + i];
                int is_missing = isnan(raw) || (has_fill && raw == fill) ||
                                 (has_missing && raw == missing);
                double v = raw * scale + offset;
                int land;
                if (kind == KIND_FILL)
                    land = is_missing;
                else if (is_missing)
                    land = 0; /* no information: sea, so no ice is lost */
                else
                    land = kind == KIND_LAND_GT_HALF ? v > 0.5 : v < 0.5;
                m->land[row * nlon + i] = (unsigned char)land;
            }
        }
    }
    free(vals);
    nc_close(c.ncid);
    return m;
}

int landmask_write_netcdf(const landmask *m, const char *path, const char *source, sph_error *err)
{
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
    return rc;
}
