/* Quick-look PNG: size, not blank, ice colour where ice is (io/quicklook.h). */
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
    const char *names[1] = { "Bayuquan" };
    double slon[1] = { cx }, slat[1] = { cy };
    CHECK(quicklook_write_png(path, &g, c, h, land, &e, names, slon, slat, 1, 1705276800.0, &o,
                              &err) == SPH_OK, "%s", err.msg);
    cairo_surface_t *s = cairo_image_surface_create_from_png(path);
    CHECK(cairo_surface_status(s) == CAIRO_STATUS_SUCCESS, "PNG reads back");
    if (cairo_surface_status(s) == CAIRO_STATUS_SUCCESS) {
        CHECK(cairo_image_surface_get_width(s) == 900 && cairo_image_surface_get_height(s) == 700,
              "size %dx%d", cairo_image_surface_get_width(s), cairo_image_surface_get_height(s));
        cairo_surface_flush(s);
        long ncol = distinct_colours(s);
        CHECK(ncol >= 8, "only %ld distinct colours", ncol);
        /* the ice colour (conc 1: 245,250,255) covers at least half the
         * disc's share of the concentration map (the map is at most a
         * panel: 430 x 560 px; the disc is nice/nn of it) */
        long ice_px = count_colour(s, 245, 250, 255);
        double map_px = 0; /* map size from the layout: width-limited or height-limited */
        {
            double pw = (900 - 60) / 2.0, ph = 700 - 50 - 80 - 10;
            double coslat = cos((g.lat0 + 0.5 * (g.nlat - 1) * g.dlat) * M_PI / 180);
            double wdeg = g.nlon * g.dlon * coslat, hdeg = g.nlat * g.dlat;
            double sc = fmin(pw / wdeg, ph / hdeg);
            map_px = wdeg * sc * hdeg * sc;
        }
        double want = map_px * (double)nice / (double)nn;
        CHECK(ice_px > 0.8 * want && ice_px < 1.2 * want + 2000,
              "ice-coloured pixels %ld, disc area %.0f px", ice_px, want);
        CHECK(count_colour(s, 170, 170, 170) > 0.5 * map_px * 8 / g.nlon, "land grey present");
        CHECK(count_colour(s, 24, 52, 92) > 0, "open water colour present");
        CHECK(count_colour(s, 220, 30, 30) > 50, "ice edge drawn in red");
        /* thickness 0.3 m on a 0..0.6 m scale: halfway (140,145,95) */
        long th_px = count_colour(s, 140, 145, 95);
        CHECK(th_px > 0.8 * want, "thickness colour pixels %ld, disc %.0f px", th_px, want);
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
