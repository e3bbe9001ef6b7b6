/* The chart's coastline lies where GSHHG says (io/coastline.h,
 * io/quicklook.h). Points of the Liaodong Bay coast are read here from
 * GSHHG's binned file with this test's own decoding of the documented
 * layout (GMT's gmt_shore.c: 2-degree bins of the high resolution, points
 * as 16-bit offsets from the bin's south-west corner), taken to pixels with
 * the chart's documented transform, and the pixels a few pixels to either
 * side of the coast along its normal must be land on one side and sea on
 * the other. Two places of known geography fix which side is which: the
 * middle of the bay (121.5 E, 40.5 N) is sea and inland Liaoning at
 * (122.25 E, 41.0 N) is land. Skipped (with a line) without GSHHG. */
#include <cairo.h>
#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "io/coastline.h"
#include "io/quicklook.h"

const char *__lsan_default_suppressions(void);
const char *__lsan_default_suppressions(void) { return "leak:libfontconfig\n"; }

#define GSHHG_H "/usr/share/gmt-gshhg/binned_GSHHS_h.nc"

static int pixel(cairo_surface_t *s, double x, double y, int *r, int *g, int *b)
{
    int w = cairo_image_surface_get_width(s), h = cairo_image_surface_get_height(s);
    int ix = (int)floor(x), iy = (int)floor(y);
    if (ix < 0 || iy < 0 || ix >= w || iy >= h)
        return -1;
    unsigned px = *(unsigned *)(void *)(cairo_image_surface_get_data(s) + (size_t)iy * cairo_image_surface_get_stride(s) +
                                       4 * (size_t)ix);
    *r = (px >> 16) & 255;
    *g = (px >> 8) & 255;
    *b = px & 255;
    return 0;
}

/* 1 land colour, 0 the sea colour of this test (class 4-6/10), -1 other */
static int kind_at(cairo_surface_t *s, double x, double y)
{
    int r, g, b;
    if (pixel(s, x, y, &r, &g, &b))
        return -1;
    if (abs(r - 214) <= 2 && abs(g - 200) <= 2 && abs(b - 170) <= 2)
        return 1;
    if (r == 255 && g == 255 && b == 0)
        return 0;
    return -1;
}

int main(void)
{
    if (access(GSHHG_H, R_OK) != 0) {
        printf("test_coastline: skipped, no %s (Debian gmt-gshhg-high)\n", GSHHG_H);
        return 0;
    }
    /* resolution by scale, from GSHHG's nominal resolutions */
    CHECK(coast_res_for_scale(0.35) == 'h', "0.35 km/px -> h");
    CHECK(coast_res_for_scale(3.0) == 'i', "3 km/px -> i");
    CHECK(coast_res_for_scale(30.0) == 'c', "30 km/px -> c");
    CHECK(coast_res_for_scale(0.1) == 'f', "0.1 km/px -> f");

    /* GSHHG points of the bay, read with this test's decoding */
    int nc, id;
    CHECK(nc_open(GSHHG_H, NC_NOWRITE, &nc) == NC_NOERR, "open %s", GSHHG_H);
    int bin = ((90 - 42) / 2) * 180 + 120 / 2; /* SW corner 120 E, 40 N */
    size_t b = (size_t)bin;
    int first = 0, nseg = 0;
    nc_inq_varid(nc, "Id_of_first_segment_in_a_bin", &id);
    nc_get_var1_int(nc, id, &b, &first);
    nc_inq_varid(nc, "N_segments_in_a_bin", &id);
    nc_get_var1_int(nc, id, &b, &nseg);
    CHECK(nseg > 0, "bin %d has %d segments", bin, nseg);
    double plon[64], plat[64], nlon[64], nlat[64];
    int np = 0;
    int vinfo, vstart, vdx, vdy;
    nc_inq_varid(nc, "Embedded_npts_levels_exit_entry_for_a_segment", &vinfo);
    nc_inq_varid(nc, "Id_of_first_point_in_a_segment", &vstart);
    nc_inq_varid(nc, "Relative_longitude_from_SW_corner_of_bin", &vdx);
    nc_inq_varid(nc, "Relative_latitude_from_SW_corner_of_bin", &vdy);
    for (int s = 0; s < nseg && np < 64; s++) {
        size_t si = (size_t)(first + s);
        int info, start;
        nc_get_var1_int(nc, vinfo, &si, &info);
        nc_get_var1_int(nc, vstart, &si, &start);
        int n = (int)((unsigned)info >> 9), level = (info >> 6) & 7;
        if (level != 1 || n < 20)
            continue; /* the mainland coast and big islands */
        short *dx = malloc((size_t)n * sizeof *dx), *dy = malloc((size_t)n * sizeof *dy);
        size_t st = (size_t)start, cnt = (size_t)n;
        nc_get_vara_short(nc, vdx, &st, &cnt, dx);
        nc_get_vara_short(nc, vdy, &st, &cnt, dy);
        for (int q = 5; q + 5 < n && np < 64; q += n / 30 + 1) {
            double lon = 120 + (unsigned short)dx[q] * 2.0 / 65535, lat = 40 + (unsigned short)dy[q] * 2.0 / 65535;
            double l0 = 120 + (unsigned short)dx[q - 5] * 2.0 / 65535, a0 = 40 + (unsigned short)dy[q - 5] * 2.0 / 65535;
            double l1 = 120 + (unsigned short)dx[q + 5] * 2.0 / 65535, a1 = 40 + (unsigned short)dy[q + 5] * 2.0 / 65535;
            if (lon < 121.05 || lon > 122.25 || lat < 40.05 || lat > 41.0)
                continue;
            /* a straight stretch: the chords before and after within 30 degrees */
            double ax = (lon - l0) * cos(40.5 * M_PI / 180), ay = lat - a0;
            double bx = (l1 - lon) * cos(40.5 * M_PI / 180), by = a1 - lat;
            double cosang = (ax * bx + ay * by) / (hypot(ax, ay) * hypot(bx, by) + 1e-300);
            if (!(cosang > cos(30 * M_PI / 180)))
                continue;
            plon[np] = lon;
            plat[np] = lat;
            nlon[np] = l1 - l0; /* tangent, turned to a normal in pixels below */
            nlat[np] = a1 - a0;
            np++;
        }
        free(dx);
        free(dy);
    }
    nc_close(nc);
    CHECK(np >= 8, "%d coast points of the bay from GSHHG", np);

    /* a chart of the demo's grid: concentration 0.5 everywhere */
    prod_grid g = { 131, 106, 121.0, 40.0, 0.01, 0.01 };
    size_t nn = (size_t)g.nlon * g.nlat;
    double *c = malloc(nn * sizeof *c);
    for (size_t k = 0; k < nn; k++)
        c[k] = 0.5;
    char dir[] = "/tmp/sphice-coast-XXXXXX", path[256];
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    snprintf(path, sizeof path, "%s/map.png", dir);
    quicklook_opts o;
    quicklook_opts_default(&o);
    sph_error err;
    sph_error_clear(&err);
    CHECK(quicklook_write_png(path, &g, c, NULL, NULL, NULL, NULL, NULL, NULL, 0, 918424800.0, &o, &err) == SPH_OK,
          "%s", err.msg);
    cairo_surface_t *s = cairo_image_surface_create_from_png(path);
    CHECK(cairo_surface_status(s) == CAIRO_STATUS_SUCCESS, "PNG reads back");
    if (cairo_surface_status(s) == CAIRO_STATUS_SUCCESS) {
        cairo_surface_flush(s);
        quicklook_frame f;
        quicklook_frame_of(&o, &g, 0, 0, &f);
        /* the frame as documented: the grid's outer cell edges, cos(mid lat) */
        CHECK(fabs(f.lonmin - 120.995) < 1e-12 && fabs(f.latmax - 41.055) < 1e-12 &&
                  fabs(f.coslat - cos(40.525 * M_PI / 180)) < 1e-12,
              "frame lonmin %.4f latmax %.4f", f.lonmin, f.latmax);
        double x, y;
        quicklook_to_px(&f, 121.55, 40.45, &x, &y);
        CHECK(kind_at(s, x, y) == 0, "(121.55 E, 40.45 N), the middle of the bay, is sea");
        quicklook_to_px(&f, 122.28, 40.97, &x, &y);
        CHECK(kind_at(s, x, y) == 1, "(122.28 E, 40.97 N), inland Liaoning, is land");
        int good = 0;
        for (int k = 0; k < np; k++) {
            double px, py;
            quicklook_to_px(&f, plon[k], plat[k], &px, &py);
            double tx = nlon[k] * f.coslat, ty = -nlat[k], tl = hypot(tx, ty);
            if (tl == 0)
                continue;
            double ux = -ty / tl, uy = tx / tl; /* unit normal in pixels */
            /* the first land or sea pixel 2..6 px out on each side (the
             * coastline's stroke and the graticule are neither) */
            int a = -1, bb = -1;
            for (int d = 2; d <= 6 && a < 0; d++)
                a = kind_at(s, px + d * ux, py + d * uy);
            for (int d = 2; d <= 6 && bb < 0; d++)
                bb = kind_at(s, px - d * ux, py - d * uy);
            int ok = (a == 1 && bb == 0) || (a == 0 && bb == 1);
            good += ok;
            if (!ok)
                printf("  coast point %.4f E %.4f N: sides %d / %d\n", plon[k], plat[k], a, bb);
        }
        /* a spit or a creek narrower than the offsets shows the same on
         * both sides: nine in ten must be clean */
        CHECK(good >= 0.9 * np, "%d of %d GSHHG coast points have land on one side and sea on the other", good,
              np);
        printf("coast points with land/sea on the two sides: %d of %d\n", good, np);
    }
    cairo_surface_destroy(s);
    unlink(path);
    rmdir(dir);
    free(c);
    quicklook_release_caches();
    return check_summary("test_coastline");
}
