/* Private to the initial ice raster reader (io/raster.h): raster.c is
 * format-free (allocation, the shared checks, sampling, the choice of a
 * driver); each format is one driver file:
 *   raster_netcdf.c  CF NetCDF
 *   raster_esri.c    ESRI ASCII grid
 * A driver recognises its files by their first bytes and reads the whole
 * raster, finishing it with raster_finish. */
#ifndef SPHICE_IO_RASTER_IMPL_H
#define SPHICE_IO_RASTER_IMPL_H

#include <stddef.h>
#include "io/raster.h"
#include "util/err.h"

/* How many of a file's first bytes the probes see. */
#define RASTER_HEAD 4096

typedef struct raster_driver {
    const char *name;
    /* 1 when the file whose first `got` bytes are head is in this format. */
    int (*probe)(const unsigned char *head, size_t got);
    /* Reads the raster (conc, thick, coordinates, valid time) and checks it. */
    int (*read)(const char *path, const ice_raster_options *o, ice_raster **out, sph_error *err);
} raster_driver;

/* The table of drivers, probed in this order. Adding a format: one file
 * defining raster_driver_<name>, and its name here. */
#define RASTER_DRIVERS(X) X(netcdf) X(esri)

#define RASTER_DRIVER_DECLARE(n) extern const raster_driver raster_driver_##n;
RASTER_DRIVERS(RASTER_DRIVER_DECLARE)
#undef RASTER_DRIVER_DECLARE

/* A raster of nlon x nlat cells for path (NULL and err set when out of
 * memory); valid_time NaN. */
ice_raster *raster_alloc(const char *path, int nlon, int nlat, sph_error *err);
/* Concentration to fraction and the checks every format shares. `percent`
 * < 0 means decide from the values. Thickness NaN where ice = default. */
int raster_finish(ice_raster *r, int percent, const ice_raster_options *o, sph_error *err);

/* Grids beyond regular lon/lat (raster_grid.c). The raster's kind and
 * its x/y (PROJECTED, metres, ascending, dx/dy set) or cell_lon/cell_lat
 * (CURVILINEAR) are set by the driver first; cell_area is the file's own
 * cell-area variable (m^2, [j * nlon + i]) or NULL. `def` is a PROJ
 * string, WKT or "EPSG:n"; `var` names the variable for messages. */
int raster_set_projected(ice_raster *r, const char *def, const char *var,
                         const double *cell_area, sph_error *err);
int raster_set_curvilinear(ice_raster *r, const char *var, const double *cell_area,
                           sph_error *err);
/* lon/lat (degrees, the CRS's geodetic datum) -> x/y (m); 0 when it does
 * not project. */
int raster_crs_forward(const struct raster_crs *c, double lon, double lat, double *x, double *y);
/* x/y (m) -> lon/lat (degrees, the CRS's geodetic datum); 0 when it does
 * not unproject. */
int raster_crs_inverse(const struct raster_crs *c, double x, double y, double *lon, double *lat);
void raster_crs_free(struct raster_crs *c);

#endif
