/* Station time-series plot (PNG, cairo): stacked panels sharing the lead
 * time axis (hours after the cycle time): (1) sea ice concentration
 * (0..1), (2) ice thickness h_i (solid) and volume per area (dashed), m,
 * (3) drift speed, m/s. A missing value (land, no ice) breaks the line.
 * Written beside the stations CSV as <prefix>_station_<name>.png (name
 * with every character outside [A-Za-z0-9_-] replaced by '_').
 *
 * Layout (for readers and the tests): width x height pixels; panel k of
 * n spans x in [PLOT_LEFT, width - PLOT_RIGHT] and y in [top_k, top_k +
 * ph] with ph = (height - PLOT_TOP - PLOT_BOTTOM - (n-1) * PLOT_GAP) / n,
 * top_k = PLOT_TOP + k * (ph + PLOT_GAP); x is linear in the lead time
 * from the first to the last time, y linear from the panel's minimum
 * (bottom) to its maximum (top). Lines: concentration (30,90,200),
 * thickness (200,60,30), volume per area the same dashed, speed (20,130,60).
 */
#ifndef SPHICE_IO_STATIONPLOT_H
#define SPHICE_IO_STATIONPLOT_H

#include <stddef.h>
#include "util/err.h"

#define PLOT_LEFT 70.0
#define PLOT_RIGHT 20.0
#define PLOT_TOP 62.0
#define PLOT_BOTTOM 46.0
#define PLOT_GAP 28.0

typedef struct stationplot_series {
    const char *name;
    double lon, lat;
    size_t n;
    const double *time;               /* seconds since 1970, increasing */
    const double *conc, *thick, *hbar, *speed; /* NaN = missing; hbar may be NULL */
    double cycle_time;
    int width, height;                /* 0: 900 x 640 */
} stationplot_series;

int stationplot_write_png(const char *path, const stationplot_series *s, sph_error *err);

/* The panel's y range as drawn: concentration 0..1; thickness 0..a nice
 * number at or above the largest value (at least 0.1 m); speed likewise
 * (at least 0.05 m/s). */
double stationplot_axis_max(double vmax, double floor_value);

#endif
