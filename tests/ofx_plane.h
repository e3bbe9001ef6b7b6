/* Test helper: the projected fluxes-file grid of tests/test_ocean_fluxes_mixed.c
 * and tests/test_ocean_fluxes_meltout.c (10 x 4 cells of 3 km on the model
 * plane from (0, 0), cell (5, 1) land, lon/lat only as attributes) and the
 * area integral of a record's field read back from the file. */
#ifndef SPHICE_TESTS_OFX_PLANE_H
#define SPHICE_TESTS_OFX_PLANE_H

#include <math.h>
#include <netcdf.h>
#include <stdio.h>

#include "core/particles.h"
#include "io/ocean_fluxes.h"

#ifndef NXG /* a test may take another size of the same layout */
#define NXG 10
#define NYG 4
#endif
#define DXG 3000.0

/* The grid (its arrays static: one grid per test program). */
static inline ofx_grid ofx_plane_grid(void)
{
    static double xa[NXG], ya[NYG], cx[NXG * NYG], cy[NXG * NYG], ar[NXG * NYG], lon[NXG * NYG],
        lat[NXG * NYG];
    static unsigned char land[NXG * NYG];
    for (int i = 0; i < NXG; i++)
        xa[i] = (i + 0.5) * DXG;
    for (int j = 0; j < NYG; j++)
        ya[j] = (j + 0.5) * DXG;
    for (size_t c = 0; c < NXG * NYG; c++) {
        cx[c] = xa[c % NXG];
        cy[c] = ya[c / NXG];
        ar[c] = DXG * DXG;
        lon[c] = 121.0 + cx[c] / 85000.0;
        lat[c] = 40.0 + cy[c] / 111000.0;
    }
    land[1 * NXG + 5] = 1;
    ofx_grid og = {.kind = OFX_GRID_PLANE, .nx = NXG, .ny = NYG, .xaxis = xa, .yaxis = ya, .lon = lon,
                   .lat = lat, .cx = cx, .cy = cy, .area = ar, .land = land, .projection = "+proj=test"};
    return og;
}

/* Opens dir/ofx.nc (path out) on that grid, and locates the three 10 km
 * slab cells of the tests (centres (5 + 10 c, 5) km) in to[3]. NULL when
 * it cannot be opened (err says why). */
static inline ofx_writer *ofx_plane_open(const char *dir, char *path, size_t len, long to[3], sph_error *err)
{
    ofx_grid og = ofx_plane_grid();
    ofx_meta meta = {.title = "test", .institution = "test", .model_version = "0", .git_revision = "0",
                     .cycle_time = 1e9};
    snprintf(path, len, "%s/ofx.nc", dir);
    sph_error_clear(err);
    ofx_writer *w = NULL;
    if (ofx_open(&w, &og, &meta, path, err) != SPH_OK)
        return NULL;
    for (size_t c = 0; c < 3; c++)
        to[c] = ofx_locate(w, NAN, NAN, (c + 0.5) * 1e4, 5000.0, hypot(1e4, 1e4) + DXG);
    return w;
}

/* The particles as the fluxes file takes them (as the engine's
 * ofx_record): disc radius sqrt(3 a / pi) of the footprint a, ice area and
 * volume, into rad, ia, iv (P->n each); stress from tx, ty. */
static inline ofx_particles ofx_plane_particles(const sph_particles *P, double rho_i, double *rad, double *ia,
                                                double *iv, const double *tx, const double *ty)
{
    for (size_t k = 0; k < P->n; k++) {
        double fp = P->mass[k] / (rho_i * P->conc[k] * P->thick[k]);
        rad[k] = sqrt(3.0 * fp / M_PI);
        ia[k] = P->conc[k] * fp;
        iv[k] = P->mass[k] / rho_i;
    }
    ofx_particles op = {.n = P->n, .x = P->x, .y = P->y, .radius = rad, .heat_ice = P->ofx_heat_ice,
                        .heat_lead = P->ofx_heat_lead, .water = P->ofx_water, .salt = P->ofx_salt,
                        .taux = tx, .tauy = ty, .swbase = P->ofx_swbase, .ice_area = ia, .ice_volume = iv};
    return op;
}

/* Record 0 of variable name: the sum of value x areacello over water, and
 * (at not NULL) the value x area of cell c. NaN when unreadable. */
static inline double ofx_plane_integral(const char *path, const char *name, size_t c, double *at)
{
    int nc, v, va;
    double s = NAN, val[NXG * NYG], area[NXG * NYG];
    if (nc_open(path, NC_NOWRITE, &nc) != NC_NOERR)
        return NAN;
    size_t start[3] = {0, 0, 0}, count[3] = {1, NYG, NXG};
    if (nc_inq_varid(nc, name, &v) == NC_NOERR && nc_inq_varid(nc, "areacello", &va) == NC_NOERR &&
        nc_get_vara_double(nc, v, start, count, val) == NC_NOERR && nc_get_var_double(nc, va, area) == NC_NOERR) {
        s = 0.0;
        for (size_t k = 0; k < NXG * NYG; k++)
            if (val[k] < 1e19)
                s += val[k] * area[k];
        if (at)
            *at = val[c] * area[c];
    }
    nc_close(nc);
    return s;
}

#endif
