/* Quick-look maps with cairo (layout and colours in io/quicklook.h). */
#include "io/quicklook.h"

#include <cairo.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "util/fileio.h"
#include "util/timeutil.h"

typedef struct { double r, g, b; } rgb;

static const rgb C_LAND = { 170, 170, 170 }, C_WATER = { 24, 52, 92 }, C_ICE_LO = { 120, 160, 205 },
                 C_ICE_HI = { 245, 250, 255 }, C_TH_LO = { 40, 60, 150 }, C_TH_HI = { 240, 230, 40 },
                 C_UNDEF = { 255, 255, 255 }, C_EDGE = { 220, 30, 30 };

void quicklook_opts_default(quicklook_opts *o)
{
    o->width = 900;
    o->height = 700;
    o->threshold = 0.15;
    o->thick_max = 0.6;
    o->title = NULL;
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

typedef struct {
    double ox, oy, scale, coslat, lonmin, latmax, w, h;
} map_frame;

static void to_px(const map_frame *m, double lon, double lat, double *x, double *y)
{
    *x = m->ox + (lon - m->lonmin) * m->coslat * m->scale;
    *y = m->oy + (m->latmax - lat) * m->scale;
}

/* field: 0 concentration, 1 thickness */
static void draw_panel(cairo_t *cr, const prod_grid *g, const double *val,
                       const unsigned char *land, const edge_set *edge, const char *const *names,
                       const double *slon, const double *slat, int nst, double px, double py,
                       double pw, double ph, int field, const quicklook_opts *o)
{
    double lonmin = g->lon0 - g->dlon / 2, lonmax = g->lon0 + (g->nlon - 0.5) * g->dlon;
    double latmin = g->lat0 - g->dlat / 2, latmax = g->lat0 + (g->nlat - 0.5) * g->dlat;
    double coslat = cos(0.5 * (latmin + latmax) * M_PI / 180);
    if (coslat < 0.1)
        coslat = 0.1;
    double sx = pw / ((lonmax - lonmin) * coslat), sy = ph / (latmax - latmin);
    map_frame m;
    m.scale = sx < sy ? sx : sy;
    m.coslat = coslat;
    m.lonmin = lonmin;
    m.latmax = latmax;
    m.w = (lonmax - lonmin) * coslat * m.scale;
    m.h = (latmax - latmin) * m.scale;
    m.ox = px + (pw - m.w) / 2;
    m.oy = py + (ph - m.h) / 2;

    cairo_save(cr);
    cairo_set_antialias(cr, CAIRO_ANTIALIAS_NONE);
    for (int j = 0; j < g->nlat; j++)
        for (int i = 0; i < g->nlon; i++) {
            size_t k = (size_t)j * g->nlon + i;
            double v = val[k];
            rgb c;
            if (land && land[k])
                c = C_LAND;
            else if (field == 0)
                c = isnan(v) ? C_UNDEF
                    : v < o->threshold ? C_WATER
                                       : lerp(C_ICE_LO, C_ICE_HI, (v - o->threshold) / (1 - o->threshold));
            else
                c = isnan(v) ? C_WATER : lerp(C_TH_LO, C_TH_HI, v / o->thick_max);
            double x0, y0, x1, y1;
            to_px(&m, g->lon0 + (i - 0.5) * g->dlon, g->lat0 + (j + 0.5) * g->dlat, &x0, &y0);
            to_px(&m, g->lon0 + (i + 0.5) * g->dlon, g->lat0 + (j - 0.5) * g->dlat, &x1, &y1);
            set_rgb(cr, c);
            cairo_rectangle(cr, floor(x0), floor(y0), ceil(x1) - floor(x0), ceil(y1) - floor(y0));
            cairo_fill(cr);
        }
    cairo_restore(cr);

    if (edge) {
        set_rgb(cr, C_EDGE);
        cairo_set_line_width(cr, 2.0);
        for (size_t l = 0; l < edge->nlines; l++) {
            const edge_line *ln = &edge->lines[l];
            for (size_t q = 0; q < ln->npts; q++) {
                double x, y;
                to_px(&m, ln->lon[q], ln->lat[q], &x, &y);
                if (q == 0)
                    cairo_move_to(cr, x, y);
                else
                    cairo_line_to(cr, x, y);
            }
            cairo_stroke(cr);
        }
    }
    cairo_set_font_size(cr, 11);
    for (int s = 0; s < nst; s++) {
        double x, y;
        to_px(&m, slon[s], slat[s], &x, &y);
        cairo_set_source_rgb(cr, 1, 1, 1);
        cairo_arc(cr, x, y, 4.5, 0, 2 * M_PI);
        cairo_fill(cr);
        cairo_set_source_rgb(cr, 0, 0, 0);
        cairo_arc(cr, x, y, 3, 0, 2 * M_PI);
        cairo_fill(cr);
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
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_set_line_width(cr, 1);
    cairo_rectangle(cr, m.ox + 0.5, m.oy + 0.5, m.w - 1, m.h - 1);
    cairo_stroke(cr);
    /* axis labels at the corners: the map's lon/lat extent */
    char buf[64];
    cairo_set_font_size(cr, 10);
    snprintf(buf, sizeof buf, "%.2f\xc2\xb0" "E", lonmin);
    cairo_move_to(cr, m.ox, m.oy + m.h + 12);
    cairo_show_text(cr, buf);
    snprintf(buf, sizeof buf, "%.2f\xc2\xb0" "E", lonmax);
    cairo_text_extents_t te;
    cairo_text_extents(cr, buf, &te);
    cairo_move_to(cr, m.ox + m.w - te.x_advance, m.oy + m.h + 12);
    cairo_show_text(cr, buf);
    snprintf(buf, sizeof buf, "%.2f\xc2\xb0" "N", latmax);
    cairo_move_to(cr, m.ox, m.oy - 4);
    cairo_show_text(cr, buf);
}

static void draw_colourbar(cairo_t *cr, double x, double y, double w, double h, int field,
                           const quicklook_opts *o)
{
    double lo = field == 0 ? 0 : 0, hi = field == 0 ? 1 : o->thick_max;
    int n = (int)w;
    cairo_save(cr);
    cairo_set_antialias(cr, CAIRO_ANTIALIAS_NONE);
    for (int q = 0; q < n; q++) {
        double v = lo + (hi - lo) * (q + 0.5) / n;
        rgb c = field == 0 ? (v < o->threshold ? C_WATER
                                               : lerp(C_ICE_LO, C_ICE_HI,
                                                      (v - o->threshold) / (1 - o->threshold)))
                           : lerp(C_TH_LO, C_TH_HI, v / o->thick_max);
        set_rgb(cr, c);
        cairo_rectangle(cr, x + q, y, 1, h);
        cairo_fill(cr);
    }
    cairo_restore(cr);
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_set_line_width(cr, 1);
    cairo_rectangle(cr, x + 0.5, y + 0.5, w - 1, h - 1);
    cairo_stroke(cr);
    cairo_set_font_size(cr, 10);
    for (int t = 0; t <= 4; t++) {
        double v = lo + (hi - lo) * t / 4, tx = x + w * t / 4;
        cairo_move_to(cr, tx, y + h);
        cairo_line_to(cr, tx, y + h + 4);
        cairo_stroke(cr);
        char buf[32];
        snprintf(buf, sizeof buf, field == 0 ? "%.2f" : "%.2f", v);
        cairo_text_extents_t te;
        cairo_text_extents(cr, buf, &te);
        cairo_move_to(cr, tx - te.x_advance / 2, y + h + 15);
        cairo_show_text(cr, buf);
    }
    const char *label = field == 0 ? "sea ice concentration (fraction; red line: ice edge)"
                                   : "ice thickness h_i (m)";
    cairo_set_font_size(cr, 11);
    cairo_text_extents_t te;
    cairo_text_extents(cr, label, &te);
    cairo_move_to(cr, x + (w - te.x_advance) / 2, y + h + 30);
    cairo_show_text(cr, label);
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
    if (!conc || o->width < 200 || o->height < 150 || o->width > 10000 || o->height > 10000 ||
        !(o->thick_max > 0) || !(o->threshold > 0 && o->threshold < 1))
        return sph_err_set(err, SPH_ERR_PARAM, "quick-look %s: bad field or options", path);
    cairo_surface_t *s = cairo_image_surface_create(CAIRO_FORMAT_RGB24, o->width, o->height);
    cairo_t *cr = cairo_create(s);
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_paint(cr);
    cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);

    int np = thick ? 2 : 1;
    double margin = 20, top = 50, bottom = 80;
    double pw = (o->width - margin * (np + 1)) / np, ph = o->height - top - bottom - 10;
    for (int q = 0; q < np; q++) {
        double px = margin + q * (pw + margin);
        draw_panel(cr, g, q == 0 ? conc : thick, land, edge, st_names, st_lon, st_lat, nst, px,
                   top, pw, ph, q, o);
        draw_colourbar(cr, px + pw * 0.15, o->height - bottom + 15, pw * 0.7, 14, q, o);
    }
    char iso[32], title[512];
    time_format_iso(valid_time, iso, sizeof iso);
    snprintf(title, sizeof title, "%s  -  valid %s", o->title ? o->title : "sphice sea ice", iso);
    cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_BOLD);
    cairo_set_font_size(cr, 17);
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_text_extents_t te;
    cairo_text_extents(cr, title, &te);
    cairo_move_to(cr, (o->width - te.x_advance) / 2, 28);
    cairo_show_text(cr, title);
    cairo_surface_flush(s);

    int rc = SPH_OK;
    cairo_status_t cs = cairo_status(cr);
    char tmp[4096];
    atomic_tmp_name(path, tmp, sizeof tmp);
    if (cs == CAIRO_STATUS_SUCCESS)
        cs = cairo_surface_write_to_png(s, tmp);
    cairo_destroy(cr);
    cairo_surface_destroy(s);
    if (cs != CAIRO_STATUS_SUCCESS) {
        unlink(tmp);
        return sph_err_set(err, SPH_ERR_IO, "quick-look %s: %s", tmp, cairo_status_to_string(cs));
    }
    rc = atomic_commit(tmp, path, err);
    return rc;
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
