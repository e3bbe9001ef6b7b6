/* Station time-series plot (io/stationplot.h): the lines lie where the
 * documented layout puts the values, a missing value breaks the line. */
#include <cairo.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include "check.h"
#include "io/quicklook.h"
#include "io/stationplot.h"

const char *__lsan_default_suppressions(void);
const char *__lsan_default_suppressions(void) { return "leak:libfontconfig\n"; }

/* is there a pixel of colour (r,g,b) within 2 px of (x, y) */
static int near_colour(cairo_surface_t *s, double x, double y, int r, int g, int b)
{
    int w = cairo_image_surface_get_width(s), h = cairo_image_surface_get_height(s);
    for (int dy = -2; dy <= 2; dy++)
        for (int dx = -2; dx <= 2; dx++) {
            int ix = (int)floor(x) + dx, iy = (int)floor(y) + dy;
            if (ix < 0 || iy < 0 || ix >= w || iy >= h)
                continue;
            unsigned px = *(unsigned *)(void *)(cairo_image_surface_get_data(s) +
                                                (size_t)iy * cairo_image_surface_get_stride(s) + 4 * (size_t)ix);
            if (abs((int)((px >> 16) & 255) - r) <= 20 && abs((int)((px >> 8) & 255) - g) <= 20 &&
                abs((int)(px & 255) - b) <= 20)
                return 1;
        }
    return 0;
}

int main(void)
{
    CHECK(stationplot_axis_max(0.37, 0.1) == 0.4, "axis 0.37 -> 0.4 (%g)", stationplot_axis_max(0.37, 0.1));
    CHECK(stationplot_axis_max(0.02, 0.05) == 0.05, "axis floor 0.05");
    CHECK(fabs(stationplot_axis_max(1.3, 0.1) - 1.5) < 1e-12, "axis 1.3 -> 1.5");

    enum { N = 25 };
    double t[N], c[N], h[N], hb[N], sp[N], t0 = 918424800.0;
    for (int k = 0; k < N; k++) {
        t[k] = t0 + 3600.0 * k;
        c[k] = 0.5;                        /* constant */
        h[k] = k >= 10 && k <= 14 ? NAN : 0.13; /* missing 10..14 h */
        hb[k] = 0.05;
        sp[k] = 0.2 * k / (N - 1);          /* ramp 0 .. 0.2 m/s */
    }
    char dir[] = "/tmp/sphice-stplot-XXXXXX", path[256];
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    snprintf(path, sizeof path, "%s/st.png", dir);
    stationplot_series ser = { "JZ20-2", 121.37, 40.47, N, t, c, h, hb, sp, t0, 0, 0 };
    sph_error err;
    sph_error_clear(&err);
    CHECK(stationplot_write_png(path, &ser, &err) == SPH_OK, "%s", err.msg);
    cairo_surface_t *s = cairo_image_surface_create_from_png(path);
    CHECK(cairo_surface_status(s) == CAIRO_STATUS_SUCCESS, "PNG reads back");
    if (cairo_surface_status(s) == CAIRO_STATUS_SUCCESS) {
        cairo_surface_flush(s);
        double W = 900, H = 640, x0 = PLOT_LEFT, w = W - PLOT_LEFT - PLOT_RIGHT;
        double ph = (H - PLOT_TOP - PLOT_BOTTOM - 2 * PLOT_GAP) / 3;
        double top[3] = { PLOT_TOP, PLOT_TOP + ph + PLOT_GAP, PLOT_TOP + 2 * (ph + PLOT_GAP) };
        double xq = x0 + w * 0.25, xm = x0 + w * 0.5;
        /* concentration 0.5 on 0..1: mid height */
        CHECK(near_colour(s, xq, top[0] + ph * 0.5, 30, 90, 200), "concentration line at 0.5");
        /* thickness 0.13 m on 0..0.15 m; missing at 12 h */
        double tmax = stationplot_axis_max(0.13, 0.1);
        CHECK(near_colour(s, xq, top[1] + ph * (1 - 0.13 / tmax), 200, 60, 30), "thickness line at 0.13 m");
        CHECK(!near_colour(s, xm, top[1] + ph * (1 - 0.13 / tmax), 200, 60, 30), "no thickness line where missing");
        /* speed ramp 0..0.2 on 0..0.2: at half the time, half the height */
        double smax = stationplot_axis_max(0.2, 0.05);
        CHECK(near_colour(s, xm, top[2] + ph * (1 - 0.1 / smax), 20, 130, 60), "speed line at 0.1 m/s at 12 h");
    }
    cairo_surface_destroy(s);
    unlink(path);
    rmdir(dir);
    ser.n = 0;
    CHECK(stationplot_write_png(path, &ser, &err) == SPH_ERR_PARAM, "empty series refused");
    quicklook_release_caches();
    return check_summary("test_stationplot");
}
