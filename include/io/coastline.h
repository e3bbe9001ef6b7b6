/* Coastline from GSHHG (Wessel and Smith), read from GMT's binned netCDF
 * files binned_GSHHS_<r>.nc (Debian: gmt-gshhg-high and friends,
 * /usr/share/gmt-gshhg), r = f(ull) h(igh) i(ntermediate) l(ow) c(rude).
 *
 * File layout (as GMT's gmt_shore.c reads it): the globe is cut into
 * square bins of Bin_size_in_minutes, numbered row by row from the north
 * pole (bin b: south-west corner lon = (b % nx) * size, lat = 90 -
 * (b / nx + 1) * size). A bin lists N_segments_in_a_bin segments from
 * Id_of_first_segment_in_a_bin; a segment packs npts << 9 | level << 6 |
 * entry << 3 | exit (sides 0 south, 1 east, 2 north, 3 west, 4 = a closed
 * polygon inside the bin) and its points are unsigned 16-bit offsets from
 * the bin's south-west corner in units of size/65535. The four corner
 * levels of a bin are packed in Embedded_node_levels_in_a_bin (SW at bits
 * 9-11). Levels: 0 ocean, 1 land, 2 lake, 3 island in a lake, 4 pond.
 *
 * Land is where the level is odd. Every segment separates level L-1 from
 * L, so the level's parity at a point is the south-west corner's parity
 * plus the number of segments that separate the point from that corner:
 * coast_is_land and the map fill (even-odd rule over each bin's corner
 * square, its closed polygons, and each open segment closed along the bin
 * border on the side away from the corner) both use that rule.
 */
#ifndef SPHICE_IO_COASTLINE_H
#define SPHICE_IO_COASTLINE_H

#include "util/err.h"

#define COAST_DEFAULT_DIR "/usr/share/gmt-gshhg"

typedef struct coast_seg {
    int n, level, entry, exit;  /* entry/exit sides 0..3, 4 = closed polygon */
    double *lon, *lat;          /* degrees; lon shifted next to the area asked */
} coast_seg;

typedef struct coast_bin {
    double lon_sw, lat_sw, size; /* degrees */
    int sw_level;                /* level at the south-west corner */
    int first, nseg;             /* segments [first, first + nseg) of the set */
} coast_bin;

typedef struct coast_set {
    char res;                    /* resolution letter used */
    char path[512];
    int nbins, nsegs;
    coast_bin *bins;
    coast_seg *segs;
} coast_set;

/* Nominal feature resolution of a GSHHG level, km (f 0.04, h 0.2, i 1,
 * l 5, c 25; GSHHG README); NaN for an unknown letter. */
double coast_res_km(char res);
/* The coarsest resolution whose nominal resolution is finer than
 * km_per_pixel (the map's scale); 'f' when even 'h' is too coarse. */
char coast_res_for_scale(double km_per_pixel);

/* Loads the bins covering [lon_min, lon_max] x [lat_min, lat_max] from
 * dir/binned_GSHHS_<r>.nc, r chosen by km_per_pixel; when that file is
 * missing the nearest finer one, then the nearest coarser one is used.
 * SPH_ERR_IO with one line (the folder, the files tried) when none is there. */
int coast_load(const char *dir, double lon_min, double lon_max, double lat_min, double lat_max,
               double km_per_pixel, coast_set *out, sph_error *err);
void coast_free(coast_set *c); /* NULL-safe */

/* 1 land, 0 water, -1 outside the loaded bins. */
int coast_is_land(const coast_set *c, double lon, double lat);

/* Walks one bin's fill path for the even-odd rule (see above), degrees:
 * move() starts a sub-path, line() adds its next points, close() ends it. */
typedef struct coast_path_ops {
    void (*move)(void *ctx, double lon, double lat);
    void (*line)(void *ctx, double lon, double lat);
    void (*close)(void *ctx);
} coast_path_ops;
void coast_bin_fill_path(const coast_set *c, int bin, const coast_path_ops *ops, void *ctx);

#endif
