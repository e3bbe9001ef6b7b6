/* Quick-look charts: size, the documented frame, class and ice colours
 * where ice is, clipped thickness (io/quicklook.h). */
#include <cairo.h>
#include <math.h>
#include <stdlib.h>
#include <unistd.h>

#include "check.h"
#include "io/quicklook.h"

/* pixels within 3 of colour (r,g,b) */

/* fontconfig (through cairo's toy font API) keeps a one-time cache that
 * LeakSanitizer reports at exit; it does not grow with the number of maps
 * drawn (checked with 1 and 5 renders), so it is suppressed here. */
const char *__lsan_default_suppressions(void);
const char *__lsan_default_suppressions(void) { return "leak:libfontconfig\n"; }
/* The same cache for valgrind: freed at exit when fontconfig is loaded. */
extern void FcFini(void) __attribute__((weak));
static void release_font_caches(void)
{
    cairo_debug_reset_static_data();
    if (FcFini)
        FcFini();
}

static long count_colour(cairo_surface_t *s, int r, int g, int b)
{
    int w = cairo_image_surface_get_width(s), h = cairo_image_surface_get_height(s);
    int stride = cairo_image_surface_get_stride(s);
    unsigned char *d = cairo_image_surface_get_data(s);
    long n = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            unsigned px = *(unsigned *)(d + (size_t)y * stride + 4 * (size_t)x);
            int pr = (px >> 16) & 255, pg = (px >> 8) & 255, pb = px & 255;
            if (abs(pr - r) <= 3 && abs(pg - g) <= 3 && abs(pb - b) <= 3)
                n++;
        }
    return n;
}

static long distinct_colours(cairo_surface_t *s)
{
    int w = cairo_image_surface_get_width(s), h = cairo_image_surface_get_height(s);
    int stride = cairo_image_surface_get_stride(s);
    unsigned char *d = cairo_image_surface_get_data(s);
    unsigned char *seen = calloc(1u << 21, 1); /* 24-bit colour bitmap */
    long n = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            unsigned px = *(unsigned *)(d + (size_t)y * stride + 4 * (size_t)x) & 0xffffffu;
            if (!(seen[px >> 3] & (1u << (px & 7)))) {
                seen[px >> 3] |= (unsigned char)(1u << (px & 7));
                n++;
            }
        }
    free(seen);
    return n;
}

int main(void)
{
    prod_grid g = { 80, 60, 119.5, 37.0, 0.05, 0.05 };
    size_t nn = (size_t)g.nlon * g.nlat;
    double *c = malloc(nn * sizeof *c), *h = malloc(nn * sizeof *h);
    unsigned char *land = calloc(nn, 1);
    /* disc of full ice (c = 1) in the middle, land along the west */
    double cx = g.lon0 + 45 * g.dlon, cy = g.lat0 + 30 * g.dlat, R = 15 * g.dlon;
    long nice = 0;
    for (int j = 0; j < g.nlat; j++)
        for (int i = 0; i < g.nlon; i++) {
            size_t k = (size_t)j * g.nlon + i;
            double r = hypot(g.lon0 + i * g.dlon - cx, g.lat0 + j * g.dlat - cy);
            land[k] = i < 8;
            c[k] = r < R ? 1.0 : 0.0;
            h[k] = r < R ? 0.3 : NAN;
            nice += r < R && !land[k];
        }
    edge_set e;
    sph_error err;
    sph_error_clear(&err);
    CHECK(edge_extract(&g, c, land, 0.15, &e, &err) == SPH_OK, "%s", err.msg);
    char dir[] = "/tmp/sphice-ql-XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    char path[256];
    snprintf(path, sizeof path, "%s/ql.png", dir);
    quicklook_opts o;
    quicklook_opts_default(&o);
    o.coastline = 0; /* synthetic land: the grid's mask (GSHHG in test_coastline) */
    const char *names[1] = { "Bayuquan" };
    double slon[1] = { cx }, slat[1] = { cy };
    CHECK(quicklook_write_png(path, &g, c, h, land, &e, names, slon, slat, 1, 1705276800.0, &o,
                              &err) == SPH_OK, "%s", err.msg);
    cairo_surface_t *s = cairo_image_surface_create_from_png(path);
    CHECK(cairo_surface_status(s) == CAIRO_STATUS_SUCCESS, "PNG reads back");
    if (cairo_surface_status(s) == CAIRO_STATUS_SUCCESS) {
        CHECK(cairo_image_surface_get_width(s) == 1500 && cairo_image_surface_get_height(s) == 720,
              "size %dx%d", cairo_image_surface_get_width(s), cairo_image_surface_get_height(s));
        cairo_surface_flush(s);
        long ncol = distinct_colours(s);
        CHECK(ncol >= 8, "only %ld distinct colours", ncol);
        /* map size from the documented frame (three panels) */
        quicklook_frame f;
        quicklook_frame_of(&o, &g, 1, 1, &f);
        double map_px = f.w * f.h;
        {   /* the frame from the documented formula, written here */
            double pw = (1500 - 14.0 * 4) / 3 - 44, ph = 720 - 84 - 128 - 18;
            double coslat = cos((g.lat0 + 0.5 * (g.nlat - 1) * g.dlat) * M_PI / 180);
            double wdeg = g.nlon * g.dlon * coslat, hdeg = g.nlat * g.dlat;
            double sc = fmin(pw / wdeg, ph / hdeg);
            CHECK(fabs(f.scale - sc) < 1e-9 && fabs(f.coslat - coslat) < 1e-12, "frame scale %g vs %g", f.scale, sc);
        }
        /* the ice colour (conc 1: 245,250,255) covers the disc's share of
         * the concentration map (ice inside the disc, bilinear to its rim) */
        long ice_px = count_colour(s, 245, 250, 255);
        double want = map_px * (double)nice / (double)nn;
        CHECK(ice_px > 0.8 * want && ice_px < 1.2 * want + 2000,
              "ice-coloured pixels %ld, disc area %.0f px", ice_px, want);
        /* the WMO chart: the disc in the 10/10 colour (145,0,0) */
        long cls_px = count_colour(s, 145, 0, 0);
        CHECK(cls_px > 0.8 * want && cls_px < 1.2 * want + 500, "10/10 pixels %ld, disc %.0f px", cls_px, want);
        CHECK(count_colour(s, 214, 200, 170) > 3 * 0.5 * map_px * 8 / g.nlon, "land colour on three maps");
        CHECK(count_colour(s, 24, 52, 92) > 0, "open water colour present");
        CHECK(count_colour(s, 150, 200, 255) > map_px * 0.3, "WMO open water (<1/10) present");
        CHECK(count_colour(s, 220, 30, 30) > 50, "ice edge drawn in red");
        /* thickness 0.3 m on a 0..0.6 m scale: halfway (140,145,95) */
        long th_px = count_colour(s, 140, 145, 95);
        CHECK(th_px > 0.8 * want, "thickness colour pixels %ld, disc %.0f px", th_px, want);
        /* the chart's transform: the disc's centre is ice on every panel */
        for (int q = 0; q < 3; q++) {
            quicklook_frame fq;
            quicklook_frame_of(&o, &g, 1, q, &fq);
            double x, y;
            quicklook_to_px(&fq, cx + 0.3 * R, cy - 0.3 * R, &x, &y);
            unsigned px = *(unsigned *)(void *)(cairo_image_surface_get_data(s) +
                                                (size_t)y * cairo_image_surface_get_stride(s) + 4 * (size_t)x);
            unsigned want_px[3] = { 0x910000u, 0xf5faffu, 0x8c915fu };
            CHECK(abs((int)((px >> 16) & 255) - (int)(want_px[q] >> 16)) <= 3 &&
                      abs((int)((px >> 8) & 255) - (int)((want_px[q] >> 8) & 255)) <= 3,
                  "panel %d at the disc: %06x, want %06x", q, px & 0xffffffu, want_px[q]);
        }
    }
    cairo_surface_destroy(s);

    /* thickness above the scale: drawn at the top colour (clipped) */
    for (size_t k = 0; k < nn; k++)
        if (!isnan(h[k]))
            h[k] = 0.9;
    CHECK(quicklook_write_png(path, &g, c, h, land, &e, names, slon, slat, 1, 1705276800.0, &o,
                              &err) == SPH_OK, "%s", err.msg);
    s = cairo_image_surface_create_from_png(path);
    if (cairo_surface_status(s) == CAIRO_STATUS_SUCCESS) {
        cairo_surface_flush(s);
        double want = 0;
        quicklook_frame f;
        quicklook_frame_of(&o, &g, 1, 2, &f);
        want = f.w * f.h * (double)nice / (double)nn;
        CHECK(count_colour(s, 240, 230, 40) > 0.8 * want, "clipped thickness in the top colour");
    }
    cairo_surface_destroy(s);

    /* no ice: no ice-coloured pixel, still a valid image */
    for (size_t k = 0; k < nn; k++)
        c[k] = 0.0;
    snprintf(path, sizeof path, "%s/ql0.png", dir);
    CHECK(quicklook_write_png(path, &g, c, NULL, land, NULL, NULL, NULL, NULL, 0, 0.0, &o, &err) ==
              SPH_OK, "%s", err.msg);
    s = cairo_image_surface_create_from_png(path);
    CHECK(cairo_surface_status(s) == CAIRO_STATUS_SUCCESS, "PNG reads back");
    if (cairo_surface_status(s) == CAIRO_STATUS_SUCCESS) {
        cairo_surface_flush(s);
        /* only the colour bar shows the top of the ice scale */
        long ice_px = count_colour(s, 245, 250, 255);
        CHECK(ice_px < 14 * 20, "no ice but %ld ice-coloured pixels", ice_px);
        CHECK(count_colour(s, 145, 0, 0) < 12 * 18 + 5, "no 10/10 beyond the legend");
    }
    cairo_surface_destroy(s);
    unlink(path);
    snprintf(path, sizeof path, "%s/ql.png", dir);
    if (getenv("SPHICE_KEEP_PNG"))
        printf("kept %s\n", path);
    else
        unlink(path);
    if (!getenv("SPHICE_KEEP_PNG"))
        rmdir(dir);
    edge_set_free(&e);
    free(c);
    free(h);
    free(land);
    release_font_caches();
    return check_summary("test_quicklook");
}
