/* Station time-series plots with cairo (layout in io/stationplot.h). */
#include "io/stationplot.h"

#include <cairo.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "io/quicklook.h"
#include "util/timeutil.h"

double stationplot_axis_max(double vmax, double floor_value)
{
    double v = fmax(isfinite(vmax) ? vmax : 0, floor_value);
    double mag = pow(10, floor(log10(v)));
    static const double steps[] = { 1, 1.2, 1.5, 2, 2.5, 3, 4, 5, 6, 8, 10 };
    for (size_t k = 0; k < sizeof steps / sizeof steps[0]; k++)
        if (steps[k] * mag >= v * (1 - 1e-12))
            return steps[k] * mag;
    return 10 * mag;
}

static double series_max(const double *v, size_t n)
{
    double m = 0;
    for (size_t k = 0; v && k < n; k++)
        if (isfinite(v[k]) && v[k] > m)
            m = v[k];
    return m;
}

static void line(cairo_t *cr, const stationplot_series *s, const double *v, double x0, double w,
                 double top, double ph, double vmax)
{
    double t0 = s->time[0], t1 = s->time[s->n - 1], span = t1 > t0 ? t1 - t0 : 1;
    int pen = 0;
    for (size_t k = 0; k < s->n; k++) {
        if (!isfinite(v[k])) {
            if (pen)
                cairo_stroke(cr);
            pen = 0;
            continue;
        }
        double x = x0 + w * (s->time[k] - t0) / span, y = top + ph * (1 - fmin(v[k], vmax) / vmax);
        if (!pen)
            cairo_move_to(cr, x, y);
        else
            cairo_line_to(cr, x, y);
        pen = 1;
        if (s->n == 1) { /* a single time: a dot */
            cairo_arc(cr, x, y, 2.5, 0, 2 * M_PI);
            cairo_fill(cr);
            pen = 0;
        }
    }
    if (pen)
        cairo_stroke(cr);
}

int stationplot_write_png(const char *path, const stationplot_series *s, sph_error *err)
{
    if (!s || s->n == 0 || !s->time || !s->conc || !s->thick || !s->speed)
        return sph_err_set(err, SPH_ERR_PARAM, "station plot %s: no series", path);
    int W = s->width > 0 ? s->width : 900, H = s->height > 0 ? s->height : 640;
    cairo_surface_t *sf = cairo_image_surface_create(CAIRO_FORMAT_RGB24, W, H);
    cairo_t *cr = cairo_create(sf);
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_paint(cr);
    cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_BOLD);
    cairo_set_font_size(cr, 15);
    cairo_set_source_rgb(cr, 0, 0, 0);
    char buf[256], iso[32];
    snprintf(buf, sizeof buf, "station %s (%.3f\xc2\xb0%s, %.3f\xc2\xb0%s)", s->name ? s->name : "?",
             fabs(s->lon), s->lon < 0 ? "W" : "E", fabs(s->lat), s->lat < 0 ? "S" : "N");
    cairo_move_to(cr, PLOT_LEFT, 24);
    cairo_show_text(cr, buf);
    cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_font_size(cr, 12);
    time_format_iso(s->cycle_time, iso, sizeof iso);
    snprintf(buf, sizeof buf, "cycle %.10s %.5s UTC, forecast sampled bilinearly from the gridded products", iso,
             iso + 11);
    cairo_move_to(cr, PLOT_LEFT, 44);
    cairo_show_text(cr, buf);

    const int np = 3;
    double x0 = PLOT_LEFT, w = W - PLOT_LEFT - PLOT_RIGHT;
    double ph = (H - PLOT_TOP - PLOT_BOTTOM - (np - 1) * PLOT_GAP) / np;
    double tmax = stationplot_axis_max(fmax(series_max(s->thick, s->n), series_max(s->hbar, s->n)), 0.1);
    double vmaxs[3] = { 1.0, tmax, stationplot_axis_max(series_max(s->speed, s->n), 0.05) };
    const char *labels[3] = { "concentration (1)", "thickness (m)", "drift speed (m/s)" };
    double t0 = s->time[0], t1 = s->time[s->n - 1];
    double hours = (t1 - t0) / 3600.0, lead0 = (t0 - s->cycle_time) / 3600.0;
    double hstep = hours <= 12 ? 1 : hours <= 48 ? 6 : hours <= 120 ? 12 : 24;
    for (int k = 0; k < np; k++) {
        double top = PLOT_TOP + k * (ph + PLOT_GAP);
        /* grid and axes */
        cairo_set_line_width(cr, 0.6);
        cairo_set_source_rgb(cr, 0.85, 0.85, 0.85);
        for (int q = 0; q <= 4; q++) {
            cairo_move_to(cr, x0, top + ph * q / 4);
            cairo_line_to(cr, x0 + w, top + ph * q / 4);
        }
        for (double h = 0; hours > 0 && h <= hours + 1e-9; h += hstep) {
            cairo_move_to(cr, x0 + w * h / hours, top);
            cairo_line_to(cr, x0 + w * h / hours, top + ph);
        }
        cairo_stroke(cr);
        quicklook_box(cr, x0, top, w, ph);
        cairo_set_font_size(cr, 10);
        for (int q = 0; q <= 4; q++) {
            snprintf(buf, sizeof buf, vmaxs[k] < 0.2 ? "%.3f" : "%.2f", vmaxs[k] * (4 - q) / 4);
            cairo_text_extents_t te;
            cairo_text_extents(cr, buf, &te);
            cairo_move_to(cr, x0 - te.x_advance - 5, top + ph * q / 4 + 3.5);
            cairo_show_text(cr, buf);
        }
        cairo_set_font_size(cr, 11);
        cairo_move_to(cr, x0 + 4, top - 5);
        cairo_show_text(cr, labels[k]);
        if (k == np - 1 && hours > 0) {
            cairo_set_font_size(cr, 10);
            for (double h = 0; h <= hours + 1e-9; h += hstep) {
                snprintf(buf, sizeof buf, "%+.0f", lead0 + h);
                cairo_text_extents_t te;
                cairo_text_extents(cr, buf, &te);
                cairo_move_to(cr, x0 + w * h / hours - te.x_advance / 2, top + ph + 14);
                cairo_show_text(cr, buf);
            }
            cairo_set_font_size(cr, 11);
            cairo_move_to(cr, x0 + w / 2 - 60, top + ph + 32);
            cairo_show_text(cr, "lead time (hours after the cycle time)");
        }
        cairo_save(cr);
        cairo_rectangle(cr, x0, top, w, ph);
        cairo_clip(cr);
        cairo_set_line_width(cr, 2);
        if (k == 0) {
            cairo_set_source_rgb(cr, 30 / 255.0, 90 / 255.0, 200 / 255.0);
            line(cr, s, s->conc, x0, w, top, ph, vmaxs[0]);
        } else if (k == 1) {
            cairo_set_source_rgb(cr, 200 / 255.0, 60 / 255.0, 30 / 255.0);
            line(cr, s, s->thick, x0, w, top, ph, vmaxs[1]);
            if (s->hbar) {
                double dash[2] = { 6, 4 };
                cairo_set_dash(cr, dash, 2, 0);
                line(cr, s, s->hbar, x0, w, top, ph, vmaxs[1]);
                cairo_set_dash(cr, NULL, 0, 0);
            }
        } else {
            cairo_set_source_rgb(cr, 20 / 255.0, 130 / 255.0, 60 / 255.0);
            line(cr, s, s->speed, x0, w, top, ph, vmaxs[2]);
        }
        cairo_restore(cr);
        if (k == 1 && s->hbar) {
            cairo_set_font_size(cr, 10);
            cairo_set_source_rgb(cr, 0.3, 0.3, 0.3);
            cairo_move_to(cr, x0 + w - 330, top - 5);
            cairo_show_text(cr, "solid: h_i of the ice-covered part; dashed: volume per area");
        }
    }
    return quicklook_png_commit(cr, sf, path, "station plot", err);
}
