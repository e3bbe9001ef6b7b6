/* Quick-look PNG maps with cairo: concentration (left panel) and, when a
 * thickness field is given, ice thickness (right panel), each with a
 * colour bar (ticks and units); land in grey, the ice edge as a red line,
 * stations as black dots with their names; the title gives the valid time.
 *
 * Colours (documented so a reader, and the test, can rely on them):
 *   page background white (255,255,255); land grey (170,170,170);
 *   open water below the edge threshold (24,52,92);
 *   concentration threshold..1: (120,160,205) -> (245,250,255);
 *   thickness 0..thick_max: (40,60,150) -> (240,230,40) (linear);
 *   ice edge red (220,30,30); fill/undefined cells white.
 * The map keeps the lon/lat aspect of the area (x scaled by cos(mean lat)).
 */
#ifndef SPHICE_IO_QUICKLOOK_H
#define SPHICE_IO_QUICKLOOK_H

#include "io/edge.h"
#include "util/err.h"

typedef struct quicklook_opts {
    int width, height;     /* pixels (900 x 700) */
    double threshold;      /* edge threshold, fraction (0.15) */
    double thick_max;      /* top of the thickness scale, m (0.6) */
    const char *title;     /* prefix before the valid time; NULL: "sphice sea ice" */
} quicklook_opts;

void quicklook_opts_default(quicklook_opts *o);

/* conc (required), thick (may be NULL: one panel), land (may be NULL):
 * nlat*nlon, NaN = fill. edge may be NULL. Station names/positions may be
 * NULL when nst = 0. Written atomically to path. */
int quicklook_write_png(const char *path, const prod_grid *g, const double *conc,
                        const double *thick, const unsigned char *land, const edge_set *edge,
                        const char *const *st_names, const double *st_lon, const double *st_lat,
                        int nst, double valid_time, const quicklook_opts *o, sph_error *err);

/* Frees cairo's and fontconfig's one-time caches (for leak checkers);
 * call once at program exit, after the last map. */
void quicklook_release_caches(void);

#endif
