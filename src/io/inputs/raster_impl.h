/* Private to the initial ice raster reader (io/raster.h): raster.c is
 * format-free (allocation, the shared checks, sampling, the choice of a
 * driver); each format is one driver file:
 *   raster_netcdf.c  CF NetCDF
 *   raster_ims.c     NOAA IMS snow and ice analysis, ASCII (G02156)
 *   raster_gdal.c    GeoTIFF through GDAL (any georeferenced band; IMS GeoTIFF)
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
#define RASTER_DRIVERS(X) X(netcdf) X(ims) X(gdal) X(esri)

#define RASTER_DRIVER_DECLARE(n) extern const raster_driver raster_driver_##n;
RASTER_DRIVERS(RASTER_DRIVER_DECLARE)
#undef RASTER_DRIVER_DECLARE

/* A raster of nlon x nlat cells for path (NULL and err set when out of
 * memory); valid_time NaN. */
ice_raster *raster_alloc(const char *path, int nlon, int nlat, sph_error *err);
/* A driver's end: *out = r on SPH_OK, else r freed; returns rc. */
int raster_hand_over(ice_raster *r, int rc, ice_raster **out);
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
/* A regular projected grid of r's nlon x nlat cells, centres x0 + i dx,
 * y0 + j dy (m): sets the kind and x/y, then raster_set_projected. */
int raster_set_regular_projected(ice_raster *r, const char *def, const char *var, double x0,
                                 double dx, double y0, double dy, sph_error *err);
/* lon/lat (degrees, the CRS's geodetic datum) -> x/y (m); 0 when it does
 * not project. */
int raster_crs_forward(const struct raster_crs *c, double lon, double lat, double *x, double *y);
/* x/y (m) -> lon/lat (degrees, the CRS's geodetic datum); 0 when it does
 * not unproject. */
int raster_crs_inverse(const struct raster_crs *c, double x, double y, double *lon, double *lat);
void raster_crs_free(struct raster_crs *c);

/* The cells of a regular projected grid (nx x ny centres x0 + i dx,
 * y0 + j dy, metres, dx, dy > 0) that cover o->bbox (lon_min, lon_max,
 * lat_min, lat_max) plus `margin` cells: win = {i0, i1, j0, j1}, inclusive.
 * No bbox (NaN): the whole grid. `def` as for raster_set_projected. A box
 * that covers no cell is an error naming the file. */
int raster_window(const char *path, const char *def, double x0, double dx, int nx, double y0,
                  double dy, int ny, const ice_raster_options *o, int margin, int win[4],
                  sph_error *err);

/* Shared metadata conventions (raster_meta.c). */
extern const char *const raster_conc_names[];  /* usual concentration variable names */
extern const char *const raster_thick_names[]; /* usual thickness variable names */
#define RASTER_MAX_FLAGS 64
/* flag_meanings (blank-separated; modified) for n flag values: kind[i] 1
 * for land (a meaning naming land, coast or lake), 2 for "no information".
 * Returns n, or -1 (err set, naming path, label and att) when the counts
 * differ. */
int raster_flag_meanings(const char *path, const char *label, const char *att, size_t n,
                         char *meanings, int *kind, sph_error *err);
/* The thickness kind from a variable's (band's) metadata, any may be NULL
 * (io/raster.h gives the order); `label` names it in the error, `name` in
 * `why`. */
int raster_thickness_kind(const char *path, const char *label, const char *name,
                          const char *cell_methods, const char *long_name,
                          const char *standard_name, int want, int *kind, char *why, size_t wlen,
                          sph_error *err);

/* IMS classes (raster_ims.c). The documented grids of G02156: */
typedef struct raster_ims_grid {
    int n;                 /* columns = rows */
    double xll, yll, cell; /* lower-left corner and cell size, m */
    const char *name;      /* "24 km", "4 km", "1 km" */
} raster_ims_grid;
extern const raster_ims_grid raster_ims_grids[3];
/* The IMS projection (PROJ string). */
extern const char raster_ims_proj[];
/* Fills r (conc, thick, land, counts, thickness kind) from the class of
 * each cell cls[j * nlon + i] (0 outside the hemisphere, 1 open water,
 * 2 land, 3 sea or lake ice, 4 snow-covered land; callers have checked
 * the values); the ice cell's concentration and thickness come from
 * o->ims_ice_conc / ims_ice_thick, an error naming the key when unset. */
int raster_ims_fill(ice_raster *r, const unsigned char *cls, const ice_raster_options *o,
                    sph_error *err);
/* Checks the two keys before any reading. */
int raster_ims_check_keys(const char *path, const ice_raster_options *o, sph_error *err);

#endif
