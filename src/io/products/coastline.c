/* GSHHG coastline reader and land test (format and rules in io/coastline.h). */
#include "io/coastline.h"

#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define COAST_MAX_DELTA 65535.0

static const char COAST_RES[] = "fhilc"; /* finest first */

double coast_res_km(char res)
{
    static const double km[] = { 0.04, 0.2, 1.0, 5.0, 25.0 };
    const char *p = res ? strchr(COAST_RES, res) : NULL;
    return p ? km[p - COAST_RES] : NAN;
}

char coast_res_for_scale(double km_per_pixel)
{
    char best = 'f';
    for (int k = 0; COAST_RES[k]; k++)
        if (coast_res_km(COAST_RES[k]) <= km_per_pixel)
            best = COAST_RES[k];
    return best;
}

void coast_free(coast_set *c)
{
    if (!c)
        return;
    for (coast_seg *sg = c->segs; sg && sg < c->segs + c->nsegs; sg++) {
        free(sg->lon);
        free(sg->lat);
    }
    free(c->bins);
    free(c->segs);
    memset(c, 0, sizeof *c);
}

static int get_int1(int nc, const char *name, int *v)
{
    int id;
    size_t z = 0;
    if (nc_inq_varid(nc, name, &id) != NC_NOERR)
        return -1;
    return nc_get_var1_int(nc, id, &z, v) == NC_NOERR ? 0 : -1;
}

/* reads count ints/shorts of `name` from start into out */
static int get_ints(int nc, const char *name, size_t start, size_t count, int *out)
{
    int id;
    if (nc_inq_varid(nc, name, &id) != NC_NOERR)
        return -1;
    return nc_get_vara_int(nc, id, &start, &count, out) == NC_NOERR ? 0 : -1;
}

static int load_bins(int nc, const char *path, double lon_min, double lon_max, double lat_min,
                     double lat_max, coast_set *out, sph_error *err)
{
    int bsize_min, nx, nbin_file, npts_file;
    if (get_int1(nc, "Bin_size_in_minutes", &bsize_min) || get_int1(nc, "N_bins_in_360_longitude_range", &nx) ||
        get_int1(nc, "N_bins_in_file", &nbin_file) || get_int1(nc, "N_points_in_file", &npts_file) ||
        bsize_min <= 0 || nx <= 0 || nx * bsize_min != 360 * 60)
        return sph_err_set(err, SPH_ERR_BAD_DATA, "coastline %s: not a GMT binned GSHHG file "
                           "(Bin_size_in_minutes, N_bins_in_360_longitude_range)", path);
    double size = bsize_min / 60.0, scale = size / COAST_MAX_DELTA;
    int c0 = (int)floor(lon_min / size), c1 = (int)floor(lon_max / size);
    int r0 = (int)floor((90.0 - lat_max) / size), r1 = (int)floor((90.0 - lat_min) / size);
    if (r0 < 0)
        r0 = 0;
    if (r1 > 180 * 60 / bsize_min - 1)
        r1 = 180 * 60 / bsize_min - 1;
    int nb = (c1 - c0 + 1) * (r1 - r0 + 1);
    if (nb <= 0 || nb > 100000)
        return sph_err_set(err, SPH_ERR_PARAM, "coastline %s: area %g..%g E, %g..%g N too large",
                           path, lon_min, lon_max, lat_min, lat_max);
    out->bins = calloc((size_t)nb, sizeof *out->bins);
    if (!out->bins)
        return sph_err_set(err, SPH_ERR_NOMEM, "coastline: out of memory");
    size_t seg_cap = 0;
    for (int r = r0; r <= r1; r++)
        for (int c = c0; c <= c1; c++) {
            int col = ((c % nx) + nx) % nx, b = r * nx + col;
            if (b < 0 || b >= nbin_file)
                continue;
            coast_bin *bin = &out->bins[out->nbins++];
            bin->size = size;
            bin->lon_sw = c * size; /* next to the area asked, not 0..360 */
            bin->lat_sw = 90.0 - (r + 1) * size;
            int info, first, nseg;
            if (get_ints(nc, "Embedded_node_levels_in_a_bin", (size_t)b, 1, &info) ||
                get_ints(nc, "Id_of_first_segment_in_a_bin", (size_t)b, 1, &first) ||
                get_ints(nc, "N_segments_in_a_bin", (size_t)b, 1, &nseg) || nseg < 0)
                return sph_err_set(err, SPH_ERR_BAD_DATA, "coastline %s: bad bin %d", path, b);
            bin->sw_level = ((unsigned)info & 0xffffu) >> 9 & 7;
            bin->first = out->nsegs;
            bin->nseg = 0;
            if (nseg == 0)
                continue;
            int *sinfo = malloc((size_t)nseg * sizeof *sinfo), *sstart = malloc((size_t)nseg * sizeof *sstart);
            int bad = !sinfo || !sstart ||
                      get_ints(nc, "Embedded_npts_levels_exit_entry_for_a_segment", (size_t)first,
                               (size_t)nseg, sinfo) ||
                      get_ints(nc, "Id_of_first_point_in_a_segment", (size_t)first, (size_t)nseg, sstart);
            for (int s = 0; s < nseg && !bad; s++) {
                if ((size_t)out->nsegs == seg_cap) {
                    size_t ncap = seg_cap ? 2 * seg_cap : 64;
                    coast_seg *ns = realloc(out->segs, ncap * sizeof *ns);
                    if (!ns) {
                        bad = 2;
                        break;
                    }
                    out->segs = ns;
                    seg_cap = ncap;
                }
                coast_seg *sg = &out->segs[out->nsegs];
                memset(sg, 0, sizeof *sg);
                sg->n = (int)((unsigned)sinfo[s] >> 9);
                sg->level = (sinfo[s] >> 6) & 7;
                sg->entry = (sinfo[s] >> 3) & 7;
                sg->exit = sinfo[s] & 7;
                if (sg->n < 1 || sstart[s] < 0 || (long)sstart[s] + sg->n > npts_file || sg->entry > 4 ||
                    sg->exit > 4) {
                    bad = 1;
                    break;
                }
                int *dx = malloc((size_t)sg->n * sizeof *dx), *dy = malloc((size_t)sg->n * sizeof *dy);
                sg->lon = malloc((size_t)sg->n * sizeof *sg->lon);
                sg->lat = malloc((size_t)sg->n * sizeof *sg->lat);
                out->nsegs++; /* freed by coast_free from here on */
                if (!dx || !dy || !sg->lon || !sg->lat)
                    bad = 2;
                else if (get_ints(nc, "Relative_longitude_from_SW_corner_of_bin", (size_t)sstart[s],
                                  (size_t)sg->n, dx) ||
                         get_ints(nc, "Relative_latitude_from_SW_corner_of_bin", (size_t)sstart[s],
                                  (size_t)sg->n, dy))
                    bad = 1;
                for (int q = 0; q < sg->n && !bad; q++) {
                    /* stored as signed shorts holding unsigned offsets */
                    sg->lon[q] = bin->lon_sw + (double)(unsigned short)dx[q] * scale;
                    sg->lat[q] = bin->lat_sw + (double)(unsigned short)dy[q] * scale;
                }
                free(dx);
                free(dy);
                bin->nseg++;
            }
            free(sinfo);
            free(sstart);
            if (bad == 2)
                return sph_err_set(err, SPH_ERR_NOMEM, "coastline: out of memory");
            if (bad)
                return sph_err_set(err, SPH_ERR_BAD_DATA, "coastline %s: bad segment in bin %d", path, b);
        }
    return SPH_OK;
}

int coast_load(const char *dir, double lon_min, double lon_max, double lat_min, double lat_max,
               double km_per_pixel, coast_set *out, sph_error *err)
{
    memset(out, 0, sizeof *out);
    if (!dir || !dir[0])
        dir = COAST_DEFAULT_DIR;
    if (!(lon_max > lon_min) || !(lat_max > lat_min) || lat_min < -90 || lat_max > 90)
        return sph_err_set(err, SPH_ERR_PARAM, "coastline: bad area %g..%g E, %g..%g N", lon_min,
                           lon_max, lat_min, lat_max);
    /* preference: the scale's resolution, then finer, then coarser */
    char want = coast_res_for_scale(km_per_pixel), order[8];
    int k0 = (int)(strchr(COAST_RES, want) - COAST_RES), n = 0;
    for (int k = k0; k >= 0; k--)
        order[n++] = COAST_RES[k];
    for (int k = k0 + 1; COAST_RES[k]; k++)
        order[n++] = COAST_RES[k];
    for (int q = 0; q < n; q++) {
        char path[sizeof out->path];
        snprintf(path, sizeof path, "%s/binned_GSHHS_%c.nc", dir, order[q]);
        if (access(path, R_OK) != 0)
            continue;
        int nc;
        if (nc_open(path, NC_NOWRITE, &nc) != NC_NOERR)
            return sph_err_set(err, SPH_ERR_NETCDF, "coastline %s: cannot open", path);
        snprintf(out->path, sizeof out->path, "%s", path);
        out->res = order[q];
        int rc = load_bins(nc, path, lon_min, lon_max, lat_min, lat_max, out, err);
        nc_close(nc);
        if (rc != SPH_OK)
            coast_free(out);
        return rc;
    }
    return sph_err_set(err, SPH_ERR_IO, "coastline: no %s/binned_GSHHS_[fhilc].nc (Debian gmt-gshhg-high)",
                       dir);
}

/* position along the bin border, counter-clockwise from the south-west
 * corner, 0..4 (one unit per side) */
static double border_pos(const coast_bin *b, int side, double lon, double lat)
{
    double u = (lon - b->lon_sw) / b->size, v = (lat - b->lat_sw) / b->size;
    switch (side) {
    case 0: return u;
    case 1: return 1 + v;
    case 2: return 2 + (1 - u);
    default: return 3 + (1 - v);
    }
}

/* does the segment separate (lon, lat) from the bin's south-west corner?
 * For a closed polygon: is the point inside. For an open one: inside the
 * segment closed along the border arc that avoids the corner. */
static int separates(const coast_bin *b, const coast_seg *s, double lon, double lat)
{
    int inside = 0;
    /* even-odd ray casting (east) over the segment's own edges ... */
    for (int q = 0; q + 1 < s->n; q++) {
        double x1 = s->lon[q], y1 = s->lat[q], x2 = s->lon[q + 1], y2 = s->lat[q + 1];
        if ((y1 > lat) != (y2 > lat) && lon < x1 + (lat - y1) * (x2 - x1) / (y2 - y1))
            inside = !inside;
    }
    double xs = s->lon[s->n - 1], ys = s->lat[s->n - 1], xe = s->lon[0], ye = s->lat[0];
    if (s->entry == 4 || s->exit == 4) {
        if ((ys > lat) != (ye > lat) && lon < xs + (lat - ys) * (xe - xs) / (ye - ys))
            inside = !inside;
        return inside;
    }
    /* ... and the closing arc along the border from the end to the start */
    double pb = border_pos(b, s->exit, xs, ys), pa = border_pos(b, s->entry, xe, ye);
    double px = xs, py = ys;
    int step = pa > pb ? 1 : -1;
    for (int corner = step > 0 ? (int)floor(pb) + 1 : (int)ceil(pb) - 1;
         step > 0 ? corner < pa : corner > pa; corner += step) {
        double cx = b->lon_sw + (corner == 1 || corner == 2 ? b->size : 0);
        double cy = b->lat_sw + (corner == 2 || corner == 3 ? b->size : 0);
        if ((py > lat) != (cy > lat) && lon < px + (lat - py) * (cx - px) / (cy - py))
            inside = !inside;
        px = cx;
        py = cy;
    }
    if ((py > lat) != (ye > lat) && lon < px + (lat - py) * (xe - px) / (ye - py))
        inside = !inside;
    return inside;
}

int coast_is_land(const coast_set *c, double lon, double lat)
{
    for (int k = 0; k < c->nbins; k++) {
        const coast_bin *b = &c->bins[k];
        if (lon < b->lon_sw || lon >= b->lon_sw + b->size || lat < b->lat_sw || lat >= b->lat_sw + b->size)
            continue;
        int parity = b->sw_level & 1;
        for (int s = b->first; s < b->first + b->nseg; s++)
            parity ^= separates(b, &c->segs[s], lon, lat);
        return parity;
    }
    return -1;
}

void coast_bin_fill_path(const coast_set *c, int bin, const coast_path_ops *ops, void *ctx)
{
    const coast_bin *b = &c->bins[bin];
    double w = b->lon_sw, s0 = b->lat_sw, e = w + b->size, n = s0 + b->size;
    if (b->sw_level & 1) {
        ops->move(ctx, w, s0);
        ops->line(ctx, e, s0);
        ops->line(ctx, e, n);
        ops->line(ctx, w, n);
        ops->close(ctx);
    }
    for (int k = b->first; k < b->first + b->nseg; k++) {
        const coast_seg *s = &c->segs[k];
        ops->move(ctx, s->lon[0], s->lat[0]);
        for (int q = 1; q < s->n; q++)
            ops->line(ctx, s->lon[q], s->lat[q]);
        if (s->entry != 4 && s->exit != 4) {
            double pb = border_pos(b, s->exit, s->lon[s->n - 1], s->lat[s->n - 1]);
            double pa = border_pos(b, s->entry, s->lon[0], s->lat[0]);
            int step = pa > pb ? 1 : -1;
            for (int corner = step > 0 ? (int)floor(pb) + 1 : (int)ceil(pb) - 1;
                 step > 0 ? corner < pa : corner > pa; corner += step)
                ops->line(ctx, corner == 1 || corner == 2 ? e : w, corner == 2 || corner == 3 ? n : s0);
        }
        ops->close(ctx);
    }
}
