/* Quick-look charts with cairo (layout, transform and colours in io/quicklook.h). */
#include "io/quicklook.h"

#include <cairo.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "io/coastline.h"
#include "io/gis.h"
#include "util/fileio.h"
#include "util/log.h"
#include "util/timeutil.h"

typedef struct { double r, g, b; } rgb;

static const rgb C_LAND = { 214, 200, 170 }, C_COAST = { 80, 80, 80 }, C_NODATA = { 200, 200, 200 },
                 C_WATER = { 24, 52, 92 }, C_ICE_LO = { 120, 160, 205 }, C_ICE_HI = { 245, 250, 255 },
                 C_TH_LO = { 40, 60, 150 }, C_TH_HI = { 240, 230, 40 }, C_EDGE = { 220, 30, 30 };

#define TOP 84.0     /* title block */
#define BOTTOM 128.0 /* legends */
#define MARGIN 14.0
#define LEFT_LABELS 44.0
#define BELOW_LABELS 18.0

void quicklook_opts_default(quicklook_opts *o)
{
    memset(o, 0, sizeof *o);
    o->width = 1500;
    o->height = 720;
    o->threshold = 0.15;
    o->thick_max = 0.6;
    o->cycle_time = NAN;
    o->coastline = 1;
}

int quicklook_npanels(int has_thick)
{
    return has_thick ? 3 : 2;
}

void quicklook_frame_of(const quicklook_opts *o, const prod_grid *g, int has_thick, int panel,
                        quicklook_frame *m)
{
    int np = quicklook_npanels(has_thick);
    double pw = (o->width - MARGIN * (np + 1)) / np, ph = o->height - TOP - BOTTOM;
    double px = MARGIN + panel * (pw + MARGIN) + LEFT_LABELS, py = TOP;
    pw -= LEFT_LABELS;
    ph -= BELOW_LABELS;
    double lonmin = g->lon0 - g->dlon / 2, lonmax = g->lon0 + (g->nlon - 0.5) * g->dlon;
    double latmin = g->lat0 - g->dlat / 2, latmax = g->lat0 + (g->nlat - 0.5) * g->dlat;
    double coslat = cos(0.5 * (latmin + latmax) * M_PI / 180);
    if (coslat < 0.1)
        coslat = 0.1;
    double sx = pw / ((lonmax - lonmin) * coslat), sy = ph / (latmax - latmin);
    m->scale = sx < sy ? sx : sy;
    m->coslat = coslat;
    m->lonmin = lonmin;
    m->latmax = latmax;
    m->w = (lonmax - lonmin) * coslat * m->scale;
    m->h = (latmax - latmin) * m->scale;
    m->ox = px + (pw - m->w) / 2;
    m->oy = py + (ph - m->h) / 2;
}

void quicklook_to_px(const quicklook_frame *m, double lon, double lat, double *x, double *y)
{
    *x = m->ox + (lon - m->lonmin) * m->coslat * m->scale;
    *y = m->oy + (m->latmax - lat) * m->scale;
}

void quicklook_box(cairo_t *cr, double x, double y, double w, double h)
{
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_set_line_width(cr, 1);
    cairo_rectangle(cr, x + 0.5, y + 0.5, w - 1, h - 1);
    cairo_stroke(cr);
}

static void set_rgb(cairo_t *cr, rgb c)
{
    cairo_set_source_rgb(cr, c.r / 255.0, c.g / 255.0, c.b / 255.0);
}

static rgb lerp(rgb a, rgb b, double t)
{
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    rgb c = { a.r + (b.r - a.r) * t, a.g + (b.g - a.g) * t, a.b + (b.b - a.b) * t };
    return c;
}

static rgb class_rgb(int k)
{
    rgb c = { gis_classes[k].r, gis_classes[k].g, gis_classes[k].b };
    return c;
}

/* bilinear between cell centres over the defined corners; NaN if none */
static double sample(const prod_grid *g, const double *f, double lon, double lat)
{
    double x = (lon - g->lon0) / g->dlon, y = (lat - g->lat0) / g->dlat;
    x = fmin(fmax(x, 0), g->nlon - 1);
    y = fmin(fmax(y, 0), g->nlat - 1);
    int i0 = (int)floor(x), j0 = (int)floor(y);
    if (i0 > g->nlon - 2)
        i0 = g->nlon - 2;
    if (j0 > g->nlat - 2)
        j0 = g->nlat - 2;
    double fx = x - i0, fy = y - j0, sum = 0, wsum = 0;
    for (int c = 0; c < 4; c++) {
        int di = c & 1, dj = c >> 1;
        double w = (di ? fx : 1 - fx) * (dj ? fy : 1 - fy);
        double v = f[(size_t)(j0 + dj) * g->nlon + i0 + di];
        if (w > 1e-9 && !isnan(v)) {
            sum += w * v;
            wsum += w;
        }
    }
    return wsum > 1e-9 ? sum / wsum : NAN;
}

static int nearest_land(const prod_grid *g, const unsigned char *land, double lon, double lat)
{
    if (!land)
        return 0;
    int i = (int)lround((lon - g->lon0) / g->dlon), j = (int)lround((lat - g->lat0) / g->dlat);
    i = i < 0 ? 0 : i >= g->nlon ? g->nlon - 1 : i;
    j = j < 0 ? 0 : j >= g->nlat ? g->nlat - 1 : j;
    return land[(size_t)j * g->nlon + i] != 0;
}

typedef struct draw_ctx {
    cairo_t *cr;
    const quicklook_frame *m;
} draw_ctx;

static void path_move(void *c, double lon, double lat)
{
    draw_ctx *d = c;
    double x, y;
    quicklook_to_px(d->m, lon, lat, &x, &y);
    cairo_move_to(d->cr, x, y);
}
static void path_line(void *c, double lon, double lat)
{
    draw_ctx *d = c;
    double x, y;
    quicklook_to_px(d->m, lon, lat, &x, &y);
    cairo_line_to(d->cr, x, y);
}
static void path_close(void *c)
{
    cairo_close_path(((draw_ctx *)c)->cr);
}

static double nice_step(double span, int want)
{
    static const double steps[] = { 0.05, 0.1, 0.2, 0.25, 0.5, 1, 2, 5, 10, 15, 30 };
    for (size_t k = 0; k < sizeof steps / sizeof steps[0]; k++)
        if (span / steps[k] <= want)
            return steps[k];
    return 30;
}

static void fmt_deg(char *buf, size_t len, double v, int lon, double step)
{
    int dec = fabs(step * 10 - round(step * 10)) > 1e-9 ? 2 : step < 1 ? 1 : 0;
    const char *hemi = lon ? (v < 0 ? "W" : "E") : (v < 0 ? "S" : "N");
    snprintf(buf, len, "%.*f\xc2\xb0%s", dec, fabs(v), hemi);
}

typedef struct panel_data {
    const prod_grid *g;
    const double *field;   /* conc or thickness */
    const double *conc;
    const unsigned char *land;
    const coast_set *coast; /* NULL: draw the grid's land mask */
    int kind;               /* 0 classes, 1 concentration, 2 thickness */
} panel_data;

static rgb pixel_colour(const panel_data *pd, const quicklook_opts *o, double lon, double lat)
{
    /* land in the grid's mask: no data where the coastline (drawn over
     * the field) says sea */
    if (nearest_land(pd->g, pd->land, lon, lat))
        return pd->coast ? C_NODATA : C_LAND;
    double v = sample(pd->g, pd->field, lon, lat);
    if (isnan(v) && pd->kind != 2)
        v = 0; /* undefined sea: open water */
    switch (pd->kind) {
    case 0:
        return class_rgb(gis_class_of(v));
    case 1:
        return v < o->threshold ? C_WATER : lerp(C_ICE_LO, C_ICE_HI, (v - o->threshold) / (1 - o->threshold));
    default: {
        double c = sample(pd->g, pd->conc, lon, lat);
        return isnan(v) || !(c >= gis_classes[1].lo) ? C_WATER : lerp(C_TH_LO, C_TH_HI, v / o->thick_max);
    }
    }
}

static void draw_field(cairo_t *cr, const quicklook_frame *m, const panel_data *pd, const quicklook_opts *o)
{
    int x0 = (int)floor(m->ox), y0 = (int)floor(m->oy);
    int w = (int)ceil(m->ox + m->w) - x0, h = (int)ceil(m->oy + m->h) - y0;
    if (w <= 0 || h <= 0)
        return;
    cairo_surface_t *img = cairo_image_surface_create(CAIRO_FORMAT_RGB24, w, h);
    if (cairo_surface_status(img) != CAIRO_STATUS_SUCCESS) {
        cairo_surface_destroy(img);
        return;
    }
    cairo_surface_flush(img);
    unsigned char *data = cairo_image_surface_get_data(img);
    int stride = cairo_image_surface_get_stride(img);
    for (int py = 0; py < h; py++) {
        double lat = m->latmax - (y0 + py + 0.5 - m->oy) / m->scale;
        unsigned *row = (unsigned *)(void *)(data + (size_t)py * stride);
        for (int px = 0; px < w; px++) {
            double lon = m->lonmin + (x0 + px + 0.5 - m->ox) / (m->coslat * m->scale);
            rgb c = pixel_colour(pd, o, lon, lat);
            row[px] = (unsigned)lround(c.r) << 16 | (unsigned)lround(c.g) << 8 | (unsigned)lround(c.b);
        }
    }
    cairo_surface_mark_dirty(img);
    cairo_save(cr);
    cairo_rectangle(cr, m->ox, m->oy, m->w, m->h);
    cairo_clip(cr);
    cairo_set_source_surface(cr, img, x0, y0);
    cairo_paint(cr);
    cairo_restore(cr);
    cairo_surface_destroy(img);
}

static void draw_coast(cairo_t *cr, const quicklook_frame *m, const coast_set *coast)
{
    draw_ctx d = { cr, m };
    coast_path_ops ops = { path_move, path_line, path_close };
    cairo_save(cr);
    cairo_rectangle(cr, m->ox, m->oy, m->w, m->h);
    cairo_clip(cr);
    cairo_new_path(cr);
    cairo_set_fill_rule(cr, CAIRO_FILL_RULE_EVEN_ODD);
    for (int b = 0; b < coast->nbins; b++)
        coast_bin_fill_path(coast, b, &ops, &d);
    set_rgb(cr, C_LAND);
    cairo_fill(cr);
    /* the coastline itself: the segments, not the bin borders */
    cairo_set_line_width(cr, 0.8);
    set_rgb(cr, C_COAST);
    for (int s = 0; s < coast->nsegs; s++) {
        const coast_seg *sg = &coast->segs[s];
        path_move(&d, sg->lon[0], sg->lat[0]);
        for (int q = 1; q < sg->n; q++)
            path_line(&d, sg->lon[q], sg->lat[q]);
        if (sg->entry == 4)
            cairo_close_path(cr);
        cairo_stroke(cr);
    }
    cairo_restore(cr);
}

static void draw_graticule(cairo_t *cr, const quicklook_frame *m, const prod_grid *g)
{
    double lonmax = m->lonmin + m->w / (m->coslat * m->scale), latmin = m->latmax - m->h / m->scale;
    double step = nice_step(fmax(lonmax - m->lonmin, m->latmax - latmin), 6);
    (void)g;
    char buf[32];
    cairo_text_extents_t te;
    cairo_save(cr);
    cairo_rectangle(cr, m->ox, m->oy, m->w, m->h);
    cairo_clip(cr);
    double dash[2] = { 3, 3 };
    cairo_set_dash(cr, dash, 2, 0);
    cairo_set_line_width(cr, 0.6);
    cairo_set_source_rgba(cr, 0, 0, 0, 0.45);
    for (double lon = ceil(m->lonmin / step) * step; lon <= lonmax + 1e-9; lon += step) {
        double x, y;
        quicklook_to_px(m, lon, 0, &x, &y);
        cairo_move_to(cr, x, m->oy);
        cairo_line_to(cr, x, m->oy + m->h);
    }
    for (double lat = ceil(latmin / step) * step; lat <= m->latmax + 1e-9; lat += step) {
        double x, y;
        quicklook_to_px(m, m->lonmin, lat, &x, &y);
        cairo_move_to(cr, m->ox, y);
        cairo_line_to(cr, m->ox + m->w, y);
    }
    cairo_stroke(cr);
    cairo_restore(cr);
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_set_font_size(cr, 10);
    for (double lon = ceil(m->lonmin / step) * step; lon <= lonmax + 1e-9; lon += step) {
        double x, y;
        quicklook_to_px(m, lon, 0, &x, &y);
        fmt_deg(buf, sizeof buf, lon, 1, step);
        cairo_text_extents(cr, buf, &te);
        cairo_move_to(cr, x - te.x_advance / 2, m->oy + m->h + 12);
        cairo_show_text(cr, buf);
    }
    for (double lat = ceil(latmin / step) * step; lat <= m->latmax + 1e-9; lat += step) {
        double x, y;
        quicklook_to_px(m, m->lonmin, lat, &x, &y);
        fmt_deg(buf, sizeof buf, lat, 0, step);
        cairo_text_extents(cr, buf, &te);
        cairo_move_to(cr, m->ox - te.x_advance - 4, y + 3.5);
        cairo_show_text(cr, buf);
    }
}

static void draw_edge(cairo_t *cr, const quicklook_frame *m, const edge_set *edge)
{
    set_rgb(cr, C_EDGE);
    cairo_set_line_width(cr, 2.0);
    for (size_t l = 0; l < edge->nlines; l++) {
        const edge_line *ln = &edge->lines[l];
        for (size_t q = 0; q < ln->npts; q++) {
            double x, y;
            quicklook_to_px(m, ln->lon[q], ln->lat[q], &x, &y);
            if (q == 0)
                cairo_move_to(cr, x, y);
            else
                cairo_line_to(cr, x, y);
        }
        cairo_stroke(cr);
    }
}

static void arrow(cairo_t *cr, double x, double y, double dx, double dy)
{
    double len = hypot(dx, dy);
    if (len < 0.5)
        return;
    double ux = dx / len, uy = dy / len, hl = fmin(5.0, 0.45 * len);
    cairo_move_to(cr, x, y);
    cairo_line_to(cr, x + dx, y + dy);
    cairo_stroke(cr);
    cairo_move_to(cr, x + dx, y + dy);
    cairo_line_to(cr, x + dx - hl * ux + 0.5 * hl * uy, y + dy - hl * uy - 0.5 * hl * ux);
    cairo_line_to(cr, x + dx - hl * ux - 0.5 * hl * uy, y + dy - hl * uy + 0.5 * hl * ux);
    cairo_close_path(cr);
    cairo_fill(cr);
}

/* drift key speed (m/s) and pixels per m/s: the key is the nice speed at
 * or above half the largest drawn speed; it is 26 px long */
static double drift_key(const prod_grid *g, const double *conc, const double *u, const double *v,
                        double thr, double *px_per_ms)
{
    double vmax = 0;
    for (size_t k = 0; k < (size_t)g->nlon * g->nlat; k++)
        if (conc[k] >= thr && isfinite(u[k]) && isfinite(v[k]))
            vmax = fmax(vmax, hypot(u[k], v[k]));
    static const double keys[] = { 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1, 2 };
    double key = 2;
    for (size_t k = 0; k < sizeof keys / sizeof keys[0]; k++)
        if (keys[k] >= 0.5 * vmax) {
            key = keys[k];
            break;
        }
    *px_per_ms = 26.0 / key;
    return key;
}

static void draw_drift(cairo_t *cr, const quicklook_frame *m, const prod_grid *g, const double *conc,
                       const quicklook_opts *o, double px_per_ms)
{
    cairo_save(cr);
    cairo_rectangle(cr, m->ox, m->oy, m->w, m->h);
    cairo_clip(cr);
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_set_line_width(cr, 1.0);
    double spacing = 30;
    for (double y = m->oy + spacing / 2; y < m->oy + m->h; y += spacing)
        for (double x = m->ox + spacing / 2; x < m->ox + m->w; x += spacing) {
            double lat = m->latmax - (y - m->oy) / m->scale;
            double lon = m->lonmin + (x - m->ox) / (m->coslat * m->scale);
            double c = sample(g, conc, lon, lat), u = sample(g, o->u_east, lon, lat),
                   v = sample(g, o->v_north, lon, lat);
            if (!(c >= o->threshold) || !isfinite(u) || !isfinite(v))
                continue;
            arrow(cr, x, y, u * px_per_ms, -v * px_per_ms);
        }
    cairo_restore(cr);
}

/* A station whose ice load exceeds the threshold: a red triangle, black outline. */
static void load_mark(cairo_t *cr, double x, double y, double r)
{
    cairo_move_to(cr, x, y - r);
    cairo_line_to(cr, x + 0.866 * r, y + 0.5 * r);
    cairo_line_to(cr, x - 0.866 * r, y + 0.5 * r);
    cairo_close_path(cr);
    cairo_set_source_rgb(cr, 0.86, 0.08, 0.08);
    cairo_fill_preserve(cr);
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_set_line_width(cr, 1.0);
    cairo_stroke(cr);
}

static void draw_stations(cairo_t *cr, const quicklook_frame *m, const char *const *names,
                          const double *slon, const double *slat, int nst, const unsigned char *mark)
{
    cairo_set_font_size(cr, 11);
    for (int s = 0; s < nst; s++) {
        double x, y;
        quicklook_to_px(m, slon[s], slat[s], &x, &y);
        if (mark && mark[s]) {
            load_mark(cr, x, y, 7.0);
        } else {
            cairo_set_source_rgb(cr, 1, 1, 1);
            cairo_arc(cr, x, y, 4.5, 0, 2 * M_PI);
            cairo_fill(cr);
            cairo_set_source_rgb(cr, 0, 0, 0);
            cairo_arc(cr, x, y, 3, 0, 2 * M_PI);
            cairo_fill(cr);
        }
        if (names && names[s]) {
            cairo_move_to(cr, x + 6, y - 4);
            cairo_text_path(cr, names[s]);
            cairo_set_source_rgb(cr, 1, 1, 1);
            cairo_set_line_width(cr, 2.5);
            cairo_stroke_preserve(cr);
            cairo_set_source_rgb(cr, 0, 0, 0);
            cairo_fill(cr);
        }
    }
}

static void legend_box(cairo_t *cr, double x, double y, rgb c, const char *label)
{
    set_rgb(cr, c);
    cairo_rectangle(cr, x, y, 18, 12);
    cairo_fill(cr);
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_set_line_width(cr, 0.8);
    cairo_rectangle(cr, x + 0.5, y + 0.5, 17, 11);
    cairo_stroke(cr);
    cairo_move_to(cr, x + 23, y + 10);
    cairo_show_text(cr, label);
}

static void centred(cairo_t *cr, double cx, double y, const char *text)
{
    cairo_text_extents_t te;
    cairo_text_extents(cr, text, &te);
    cairo_move_to(cr, cx - te.x_advance / 2, y);
    cairo_show_text(cr, text);
}

/* colour bar from lo to hi at (x, y), w x h; an arrow at the right end
 * when `clipped` */
static void colour_bar(cairo_t *cr, double x, double y, double w, double h, int kind,
                       const quicklook_opts *o, int clipped)
{
    double lo = kind == 1 ? o->threshold : 0, hi = kind == 1 ? 1 : o->thick_max;
    int n = (int)w;
    cairo_save(cr);
    cairo_set_antialias(cr, CAIRO_ANTIALIAS_NONE);
    for (int q = 0; q < n; q++) {
        double t = (q + 0.5) / n;
        set_rgb(cr, kind == 1 ? lerp(C_ICE_LO, C_ICE_HI, t) : lerp(C_TH_LO, C_TH_HI, t));
        cairo_rectangle(cr, x + q, y, 1, h);
        cairo_fill(cr);
    }
    cairo_restore(cr);
    if (clipped) { /* triangle in the top colour: values above the scale */
        set_rgb(cr, C_TH_HI);
        cairo_move_to(cr, x + w, y);
        cairo_line_to(cr, x + w + h, y + h / 2);
        cairo_line_to(cr, x + w, y + h);
        cairo_close_path(cr);
        cairo_fill_preserve(cr);
        cairo_set_source_rgb(cr, 0, 0, 0);
        cairo_set_line_width(cr, 0.8);
        cairo_stroke(cr);
    }
    quicklook_box(cr, x, y, w, h);
    cairo_set_font_size(cr, 10);
    for (int t = 0; t <= 4; t++) {
        double v = lo + (hi - lo) * t / 4, tx = x + w * t / 4;
        cairo_move_to(cr, tx, y + h);
        cairo_line_to(cr, tx, y + h + 4);
        cairo_stroke(cr);
        char buf[32];
        snprintf(buf, sizeof buf, "%.2f", v);
        centred(cr, tx, y + h + 15, buf);
    }
}

static void draw_legend(cairo_t *cr, const quicklook_frame *m, int kind, const quicklook_opts *o,
                        double thick_seen_max, int have_coast, double drift_key_ms, double px_per_ms,
                        double y0)
{
    char buf[160];
    double x = m->ox;
    cairo_set_font_size(cr, 11);
    cairo_set_source_rgb(cr, 0, 0, 0);
    if (kind == 0) {
        cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_BOLD);
        centred(cr, m->ox + m->w / 2, y0 + 4, "total concentration, WMO colour code (tenths)");
        cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
        cairo_set_font_size(cr, 10.5);
        double cw = fmax(m->w / 3, 120);
        for (int k = 0; k < GIS_NCLASSES; k++) {
            int col = k % 3, row = k / 3;
            legend_box(cr, x + col * cw, y0 + 14 + row * 18, class_rgb(k),
                       k == 0 ? "<1/10 (open water)" : gis_classes[k].name);
        }
        legend_box(cr, x, y0 + 50, C_LAND, have_coast ? "land (GSHHG)" : "land (model mask)");
        if (have_coast)
            legend_box(cr, x + cw, y0 + 50, C_NODATA, "no model data");
        return;
    }
    double bx = x + 120, bw = fmin(m->w - 150, 300);
    if (kind == 1) {
        snprintf(buf, sizeof buf, "open water (< %.2f)", o->threshold);
        cairo_set_font_size(cr, 10.5);
        legend_box(cr, x, y0 + 4, C_WATER, buf);
        colour_bar(cr, bx + 20, y0 + 24, bw - 20, 14, 1, o, 0);
        cairo_set_font_size(cr, 11);
        snprintf(buf, sizeof buf, "sea ice concentration (fraction); red line: ice edge c = %.2f", o->threshold);
        centred(cr, m->ox + m->w / 2, y0 + 68, buf);
        if (drift_key_ms > 0) {
            cairo_set_line_width(cr, 1.0);
            arrow(cr, x, y0 + 34, drift_key_ms * px_per_ms, 0);
            snprintf(buf, sizeof buf, "%g m/s drift", drift_key_ms);
            cairo_set_font_size(cr, 10.5);
            cairo_move_to(cr, x, y0 + 50);
            cairo_show_text(cr, buf);
        }
    } else {
        cairo_set_font_size(cr, 10.5);
        legend_box(cr, x, y0 + 4, C_WATER, "open water (< 1/10)");
        int clipped = thick_seen_max > o->thick_max;
        colour_bar(cr, bx, y0 + 24, bw, 14, 2, o, clipped);
        cairo_set_font_size(cr, 11);
        centred(cr, m->ox + m->w / 2, y0 + 68, "ice thickness h_i (m); red line: ice edge");
        if (clipped) {
            snprintf(buf, sizeof buf, "\xe2\x96\xb6 above %.2f m drawn as %.2f m (max %.2f m)", o->thick_max,
                     o->thick_max, thick_seen_max);
            cairo_set_font_size(cr, 10.5);
            centred(cr, m->ox + m->w / 2, y0 + 84, buf);
        }
    }
}

/* Gaussian smoothing over the defined cells (normalised; NaN stays NaN),
 * separable, sigma in cells along x and y, truncated at 3 sigma */
static double *smooth_field(const prod_grid *g, const double *f, double sx, double sy)
{
    int nx = g->nlon, ny = g->nlat;
    size_t nn = (size_t)nx * ny;
    double *out = malloc(nn * sizeof *out), *num = malloc(nn * sizeof *num), *den = malloc(nn * sizeof *den);
    int rx = (int)ceil(3 * sx), ry = (int)ceil(3 * sy);
    double *wx = malloc((size_t)(2 * rx + 1) * sizeof *wx), *wy = malloc((size_t)(2 * ry + 1) * sizeof *wy);
    if (!out || !num || !den || !wx || !wy) {
        free(out);
        out = NULL;
        goto done;
    }
    for (int d = -rx; d <= rx; d++)
        wx[d + rx] = exp(-0.5 * d * d / (sx * sx));
    for (int d = -ry; d <= ry; d++)
        wy[d + ry] = exp(-0.5 * d * d / (sy * sy));
    for (int j = 0; j < ny; j++) /* along x */
        for (int i = 0; i < nx; i++) {
            double a = 0, b = 0;
            for (int d = -rx; d <= rx; d++) {
                int ii = i + d;
                if (ii < 0 || ii >= nx)
                    continue;
                double v = f[(size_t)j * nx + ii];
                if (!isnan(v)) {
                    a += wx[d + rx] * v;
                    b += wx[d + rx];
                }
            }
            num[(size_t)j * nx + i] = a;
            den[(size_t)j * nx + i] = b;
        }
    for (int j = 0; j < ny; j++) /* along y */
        for (int i = 0; i < nx; i++) {
            size_t k = (size_t)j * nx + i;
            if (isnan(f[k])) {
                out[k] = NAN;
                continue;
            }
            double a = 0, b = 0;
            for (int d = -ry; d <= ry; d++) {
                int jj = j + d;
                if (jj < 0 || jj >= ny)
                    continue;
                a += wy[d + ry] * num[(size_t)jj * nx + i];
                b += wy[d + ry] * den[(size_t)jj * nx + i];
            }
            out[k] = b > 0 ? a / b : f[k];
        }
done:
    free(num);
    free(den);
    free(wx);
    free(wy);
    return out;
}

static void format_hm(double t, char *buf, size_t len)
{
    char iso[32];
    time_format_iso(t, iso, sizeof iso);
    /* "YYYY-MM-DDTHH:MM:SSZ" -> "YYYY-MM-DD HH:MM UTC" */
    snprintf(buf, len, "%.10s %.5s UTC", iso, iso + 11);
}

int quicklook_write_png(const char *path, const prod_grid *g, const double *conc,
                        const double *thick, const unsigned char *land, const edge_set *edge,
                        const char *const *st_names, const double *st_lon, const double *st_lat,
                        int nst, double valid_time, const quicklook_opts *o, sph_error *err)
{
    quicklook_opts def;
    if (!o) {
        quicklook_opts_default(&def);
        o = &def;
    }
    if (prod_grid_check(g, err) != SPH_OK)
        return err ? err->code : SPH_ERR_PARAM;
    if (!conc || o->width < 400 || o->height < 300 || o->width > 10000 || o->height > 10000 ||
        !(o->thick_max > 0) || !(o->threshold > 0 && o->threshold < 1))
        return sph_err_set(err, SPH_ERR_PARAM, "quick-look %s: bad field or options", path);

    quicklook_frame f0;
    quicklook_frame_of(o, g, thick != NULL, 0, &f0);
    coast_set coast;
    int have_coast = 0;
    if (o->coastline) {
        sph_error cerr;
        sph_error_clear(&cerr);
        double km_per_px = (g->nlat * g->dlat) * 111.2 / fmax(f0.h, 1);
        double pad = 0.5 * fmax(g->dlon, g->dlat);
        if (coast_load(o->coast_dir, g->lon0 - pad, g->lon0 + (g->nlon - 1) * g->dlon + pad, g->lat0 - pad,
                       g->lat0 + (g->nlat - 1) * g->dlat + pad, km_per_px, &coast, &cerr) == SPH_OK)
            have_coast = 1;
        else
            log_warn("quick-look %s: %s; land drawn from the output grid's mask", path, cerr.msg);
    }

    cairo_surface_t *s = cairo_image_surface_create(CAIRO_FORMAT_RGB24, o->width, o->height);
    cairo_t *cr = cairo_create(s);
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_paint(cr);
    cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);

    double thick_seen_max = 0, px_per_ms = 0, key = 0;
    if (thick)
        for (size_t k = 0; k < (size_t)g->nlon * g->nlat; k++)
            if (isfinite(thick[k]) && thick[k] > thick_seen_max)
                thick_seen_max = thick[k];
    if (o->u_east && o->v_north)
        key = drift_key(g, conc, o->u_east, o->v_north, o->threshold, &px_per_ms);

    /* the lattice ripple: smoothed away at the particle spacing */
    double *sconc = NULL, *sthick = NULL;
    if (o->smooth_km > 0) {
        double coslat = f0.coslat, km_deg = 111.2;
        double sx = o->smooth_km / (km_deg * coslat * g->dlon), sy = o->smooth_km / (km_deg * g->dlat);
        sconc = smooth_field(g, conc, sx, sy);
        sthick = thick ? smooth_field(g, thick, sx, sy) : NULL;
        if (sconc)
            conc = sconc;
        if (sthick)
            thick = sthick;
    }

    int np = quicklook_npanels(thick != NULL);
    for (int q = 0; q < np; q++) {
        quicklook_frame m;
        quicklook_frame_of(o, g, thick != NULL, q, &m);
        panel_data pd = { g, q == 2 ? thick : conc, conc, land, have_coast ? &coast : NULL, q };
        draw_field(cr, &m, &pd, o);
        if (have_coast)
            draw_coast(cr, &m, &coast);
        if (edge && q > 0)
            draw_edge(cr, &m, edge);
        if (q == 1 && key > 0)
            draw_drift(cr, &m, g, conc, o, px_per_ms);
        draw_graticule(cr, &m, g);
        draw_stations(cr, &m, st_names, st_lon, st_lat, nst, o->st_mark);
        quicklook_box(cr, m.ox, m.oy, m.w, m.h);
        draw_legend(cr, &m, q, o, thick_seen_max, have_coast, key, px_per_ms,
                    o->height - BOTTOM + 8);
    }
    int marked = 0;
    for (int q = 0; o->st_mark && q < nst; q++)
        marked |= o->st_mark[q];
    if (marked) { /* the marks' legend entry, bottom right */
        char note[96];
        snprintf(note, sizeof note, "station with an ice load above %g kN", o->mark_threshold_kn);
        cairo_set_font_size(cr, 10.5);
        cairo_text_extents_t te;
        cairo_text_extents(cr, note, &te);
        double lx = o->width - MARGIN - te.x_advance;
        load_mark(cr, lx - 10, o->height - 10, 6.0);
        cairo_set_source_rgb(cr, 0, 0, 0);
        cairo_move_to(cr, lx, o->height - 6);
        cairo_show_text(cr, note);
    }
    if (!have_coast) {
        cairo_set_font_size(cr, 10);
        cairo_set_source_rgb(cr, 0.6, 0, 0);
        cairo_move_to(cr, MARGIN, o->height - 6);
        cairo_show_text(cr, "land: output grid's mask (GSHHG coastline not found)");
    } else {
        char note[96];
        snprintf(note, sizeof note, "coastline: GSHHG (Wessel and Smith), resolution %c", coast.res);
        cairo_set_font_size(cr, 9);
        cairo_set_source_rgb(cr, 0.35, 0.35, 0.35);
        cairo_move_to(cr, MARGIN, o->height - 6);
        cairo_show_text(cr, note);
    }

    /* title block: title; domain and run; cycle, valid and lead time */
    char line[512], a[48], b[48];
    cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_BOLD);
    cairo_set_font_size(cr, 17);
    cairo_set_source_rgb(cr, 0, 0, 0);
    centred(cr, o->width / 2.0, 24, o->title ? o->title : "sphice sea ice");
    cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_font_size(cr, 13);
    snprintf(line, sizeof line, "domain: %s    run: %s", o->domain ? o->domain : "-", o->run ? o->run : "-");
    centred(cr, o->width / 2.0, 44, line);
    format_hm(valid_time, b, sizeof b);
    if (isfinite(o->cycle_time)) {
        format_hm(o->cycle_time, a, sizeof a);
        double lead = (valid_time - o->cycle_time) / 3600.0;
        snprintf(line, sizeof line, "cycle %s    valid %s    lead %+.0f h", a, b, lead);
    } else {
        snprintf(line, sizeof line, "valid %s", b);
    }
    cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_BOLD);
    centred(cr, o->width / 2.0, 63, line);
    cairo_surface_flush(s);
    if (have_coast)
        coast_free(&coast);
    free(sconc);
    free(sthick);

    return quicklook_png_commit(cr, s, path, "quick-look", err);
}

int quicklook_png_commit(cairo_t *cr, cairo_surface_t *s, const char *path, const char *what, sph_error *err)
{
    cairo_surface_flush(s);
    cairo_status_t cs = cairo_status(cr);
    char tmp[4096];
    atomic_tmp_name(path, tmp, sizeof tmp);
    if (cs == CAIRO_STATUS_SUCCESS)
        cs = cairo_surface_write_to_png(s, tmp);
    cairo_destroy(cr);
    cairo_surface_destroy(s);
    if (cs != CAIRO_STATUS_SUCCESS) {
        unlink(tmp);
        return sph_err_set(err, SPH_ERR_IO, "%s %s: %s", what, tmp, cairo_status_to_string(cs));
    }
    return atomic_commit(tmp, path, err);
}

/* fontconfig (under cairo's toy text API) keeps a process-wide cache;
 * FcFini is weak so the program links without fontconfig's headers. */
extern void FcFini(void) __attribute__((weak));
void quicklook_release_caches(void)
{
    cairo_debug_reset_static_data();
    if (FcFini)
        FcFini();
}
