/* Quick-look charts (PNG, cairo). Three panels side by side (two without
 * a thickness field): (0) total concentration in the WMO ice-chart colour
 * code, (1) continuous concentration with the ice edge and optional drift
 * vectors, (2) ice thickness with the edge. Every panel has the GSHHG
 * coastline with filled land (io/coastline.h; resolution chosen by the
 * map's scale), a labelled graticule, the stations with their names, and a
 * legend (open-water entry; a note and an arrow where a scale clips). The
 * title block gives the title, the domain and run, the cycle, valid and
 * lead time.
 *
 * Fields are drawn per pixel, bilinear between the grid's cell centres
 * (only the defined corners, weights renormalised), so the map shows no
 * cell blocks; the class chart classifies the interpolated value. The
 * gridded concentration of a particle model ripples at the particle
 * spacing (the lattice); with smooth_km > 0 the fields are first smoothed
 * by a normalised Gaussian of that sigma over the defined cells (the
 * products writer uses half the mean particle spacing, which damps a
 * ripple at the spacing by exp(-pi^2/2) ~ 0.7 %). The ice edge and the
 * GIS products stay those of the unsmoothed grid. Thickness is drawn
 * where the concentration is at least 1/10.
 *
 * Map transform (plate carree with the aspect of the mid latitude), for
 * a panel's frame f (quicklook_frame_of):
 *   x = f.ox + (lon - f.lonmin) * f.coslat * f.scale
 *   y = f.oy + (f.latmax - lat) * f.scale          (pixels, y down)
 * with lonmin/latmax the outer edges of the grid's cells and coslat the
 * cosine of the middle latitude of the grid.
 *
 * Colours (documented so a reader, and the tests, can rely on them):
 *   page white; land (GSHHG, or the model mask without GSHHG) (214,200,170),
 *   coastline (80,80,80); sea the model treats as land (grid mask, not
 *   GSHHG land) (200,200,200) "no model data".
 *   WMO total-concentration code (JCOMM Ice Chart Colour Code Standard,
 *   WMO/TD-No. 1215; the S-411 portrayal's values):
 *     < 1/10 open water (150,200,255); 1-3/10 (140,255,160);
 *     4-6/10 (255,255,0); 7-8/10 (255,125,7); 9-10/10 (255,0,0);
 *     10/10 (145,0,0).  Bounds in io/gis.h (GIS_CLASS_*).
 *   continuous concentration: below the edge threshold open water
 *     (24,52,92); threshold..1: (120,160,205) -> (245,250,255) linear;
 *   thickness 0..thick_max: (40,60,150) -> (240,230,40), clipped at
 *     thick_max (legend arrow and note); no ice (24,52,92);
 *   ice edge red (220,30,30); drift arrows black.
 */
#ifndef SPHICE_IO_QUICKLOOK_H
#define SPHICE_IO_QUICKLOOK_H

#include "io/edge.h"
#include "util/err.h"

typedef struct quicklook_opts {
    int width, height;     /* pixels (1500 x 720) */
    double threshold;      /* edge threshold, fraction (0.15) */
    double thick_max;      /* top of the thickness scale, m (0.6) */
    const char *title;     /* first title line; NULL: "sphice sea ice" */
    const char *domain;    /* domain name (NULL: not shown) */
    const char *run;       /* run description (NULL: not shown) */
    double cycle_time;     /* forecast reference time; NaN: no cycle/lead shown */
    const double *u_east, *v_north; /* drift (m/s, nlat*nlon); NULL: no vectors */
    int coastline;         /* 1: GSHHG coastline (default); 0: the grid's land mask */
    double smooth_km;      /* > 0: fields drawn after a Gaussian of this sigma, km (0) */
    const char *coast_dir; /* NULL: COAST_DEFAULT_DIR */
    /* stations whose ice load exceeds a threshold (issue 25): st_mark[s] = 1
     * draws station s as a red triangle, with a legend line naming
     * mark_threshold_kn; NULL: none */
    const unsigned char *st_mark;
    double mark_threshold_kn;
} quicklook_opts;

void quicklook_opts_default(quicklook_opts *o);

typedef struct quicklook_frame {
    double ox, oy, scale, coslat, lonmin, latmax, w, h;
} quicklook_frame;

/* Number of panels (3 with thickness, else 2) and a panel's map frame. */
int quicklook_npanels(int has_thick);
void quicklook_frame_of(const quicklook_opts *o, const prod_grid *g, int has_thick, int panel,
                        quicklook_frame *f);
void quicklook_to_px(const quicklook_frame *f, double lon, double lat, double *x, double *y);

/* conc (required), thick (may be NULL: two panels), land (may be NULL):
 * nlat*nlon, NaN = fill. edge may be NULL. Station names/positions may be
 * NULL when nst = 0. Written atomically to path. Without GSHHG files the
 * grid's land mask is drawn and the map says so (a log line, not an error). */
int quicklook_write_png(const char *path, const prod_grid *g, const double *conc,
                        const double *thick, const unsigned char *land, const edge_set *edge,
                        const char *const *st_names, const double *st_lon, const double *st_lat,
                        int nst, double valid_time, const quicklook_opts *o, sph_error *err);

/* Writes a finished cairo image atomically to path as PNG and destroys
 * cr and s (also on failure); `what` names the product in the error. */
typedef struct _cairo cairo_t;
typedef struct _cairo_surface cairo_surface_t;
int quicklook_png_commit(cairo_t *cr, cairo_surface_t *s, const char *path, const char *what, sph_error *err);
/* A black 1-pixel frame on the pixel edges of (x, y, w, h). */
void quicklook_box(cairo_t *cr, double x, double y, double w, double h);

/* Frees cairo's and fontconfig's one-time caches (for leak checkers);
 * call once at program exit, after the last map. */
void quicklook_release_caches(void);

#endif
