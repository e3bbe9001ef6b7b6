/* Fluxes into the ocean on the ocean's grid (issue 20 item 4): the file a
 * coupled ocean model reads, docs/ocean-coupling.md.
 *
 *   ofx_open(&w, &grid, &meta, path, err);
 *   per record: ofx_add_particles(w, &particles, err);    particle fluxes
 *               ofx_add_cells(w, OFX_HFDS, flux, err);    optional: fluxes
 *                        already on this grid (open water without ice)
 *               ofx_write_record(w, t_start, t_end, err); means, cleared
 *   ofx_close(w, err);   (commits the file atomically, frees w)
 *   on any error: ofx_abort(w);   (removes the temporary file)
 *
 * Conservative: each particle's extensive amounts (J, kg, N s, m^2, m^3)
 * are spread over the water cells whose centres lie within its radius,
 * with weights W(d) area_c / sum(W area) that sum to 1 (W = (1 - d^2/R^2)^2);
 * a particle that reaches no cell centre goes to the nearest water cell
 * within R plus two index bins. A particle outside the grid (farther than
 * 0.75 sqrt(area) from every cell centre, land included) or farther from
 * every water cell is counted in particles_lost and gives nothing. So
 * sum_c flux_c area_c dt equals the placed particles' sum to round-off.
 * Cell areas are the true ones (the sphere's for a lon/lat grid) and are
 * written as areacello.
 *
 * A curvilinear grid (OFX_GRID_CURV, ocean_fluxes_curv.c): each cell is
 * the polygon of its four corners on the model plane; a particle's
 * footprint is the disc of area pi R^2 / 3 (what the kernel above
 * integrates to), a regular 32-gon of that area, and its weights are the
 * footprint's overlap with the water cells, normalised to sum to 1 (the
 * rounding remainder to the largest weight). A footprint on land cells
 * only goes whole to the nearest water centre within R + 2 bins; one that
 * overlaps no cell is lost. Stress is accumulated in plane components and
 * written along the grid's own i/j axes (docs/ocean-coupling.md). */
#ifndef SPHICE_IO_OCEAN_FLUXES_H
#define SPHICE_IO_OCEAN_FLUXES_H

#include <stddef.h>
#include "util/err.h"

typedef enum {
    OFX_GRID_LONLAT, /* regular longitude/latitude axes */
    OFX_GRID_PLANE,  /* x/y axes on the model plane (a projected ocean grid) */
    OFX_GRID_CURV    /* curvilinear: 2-D lon/lat, cells the polygons of their corners */
} ofx_grid_kind;

typedef struct ofx_grid {
    ofx_grid_kind kind;
    int nx, ny;               /* cells; cell c = j * nx + i */
    const double *xaxis;      /* [nx]: LONLAT longitude, degrees_east; PLANE x, m; CURV unused */
    const double *yaxis;      /* [ny]: LONLAT latitude, degrees_north; PLANE y, m; CURV unused */
    const double *lon, *lat;  /* PLANE, CURV: cell-centre longitude/latitude [ny*nx]; LONLAT: unused */
    const double *cx, *cy;    /* cell centres on the model plane, m [ny*nx]; not finite: never reached */
    const double *area;       /* true cell area, m^2 [ny*nx], > 0 */
    const unsigned char *land;/* NULL, or [ny*nx] with 1 for land: receives nothing, written as fill */
    const char *projection;   /* the model plane's definition, written as an attribute; may be NULL */
    const char *grid_source;  /* where the grid comes from, written as an attribute; may be NULL */
    /* CURV only: the 4 corners of cell c at [4 c + v], anticlockwise (CF
     * bounds order), in degrees (written as lon_bnds/lat_bnds) and on the
     * model plane (m; the cell polygons the footprints are clipped to) */
    const double *blon, *blat, *bx, *by;
    const double *east;       /* CURV: angle from east to the plane's x axis at each centre, rad
                               * (geo_grid_angle); NULL: 0 */
    const char *corners;      /* CURV: how the corners were made, written as an attribute */
} ofx_grid;

/* The file's data variables, in file order. Fluxes are means over the
 * record's interval, positive down into the ocean; the last three are the
 * ice state at the record's end. */
enum {
    OFX_HFDS,        /* W m-2: net heat into the ocean, under ice and through leads */
    OFX_HFSITHERMDS, /* W m-2: the part under the ice */
    OFX_SIFLFWBOT,   /* kg m-2 s-1: fresh water from ice (salt excluded) and snow */
    OFX_SIFLSALTBOT, /* kg m-2 s-1: salt */
    OFX_TAUUO,       /* N m-2: stress of the ice on the ocean, grid x (east on a lon/lat grid) */
    OFX_TAUVO,       /* N m-2: grid y */
    OFX_SISTRXUBOT,  /* N m-2: stress of the ocean on the ice, x (= -tauuo) */
    OFX_SISTRYUBOT,  /* N m-2: y (= -tauvo) */
    OFX_SIFLSWDBOT,  /* W m-2: shortwave reaching the ice base */
    OFX_SICONC,      /* 1: ice area fraction of the cell (regridded ice area / cell area, capped at 1) */
    OFX_SIVOL,       /* m: ice volume per cell area */
    OFX_SITHICK,     /* m: ice thickness over the ice-covered part (sivol / siconc) */
    OFX_NFIELDS
};
/* The variable name of field k (OFX_*), NULL when out of range. */
const char *ofx_field_name(int k);

/* Per-particle amounts of one record, all extensive (see above). Stress
 * components are on the grid's x/y (east/north for a lon/lat grid): the
 * caller rotates the plane's components; on a CURV grid they are the
 * plane's x/y and the writer turns them to the grid's i/j per cell. */
typedef struct ofx_particles {
    size_t n;
    const double *x, *y;         /* plane position, m */
    const double *radius;        /* spreading radius, m (> 0) */
    const double *heat_ice;      /* J under the ice */
    const double *heat_lead;     /* J through the leads */
    const double *water, *salt;  /* kg */
    const double *taux, *tauy;   /* N s, of the ice on the ocean */
    const double *swbase;        /* J */
    const double *ice_area;      /* m^2: concentration x footprint, at the record's end */
    const double *ice_volume;    /* m^3: concentration x thickness x footprint */
} ofx_particles;

typedef struct ofx_meta {
    const char *title, *institution, *model_version, *git_revision;
    double cycle_time;           /* s since 1970 */
} ofx_meta;

typedef struct ofx_writer ofx_writer;

int ofx_open(ofx_writer **w, const ofx_grid *g, const ofx_meta *meta, const char *path, sph_error *err);
int ofx_add_particles(ofx_writer *w, const ofx_particles *p, sph_error *err);
/* Adds per-cell fluxes already on this grid and in field k's units (a
 * mean over the record's interval, positive down) to field k of the
 * current record: the entry for the open water of the mixed layer, where
 * no particle is. Only the flux fields (OFX_HFDS .. OFX_SIFLSWDBOT; the
 * stress pairs are kept opposite: adding to tauuo subtracts from
 * sistrxubot and the reverse). Non-finite values and land cells are
 * refused with one line. */
int ofx_add_cells(ofx_writer *w, int k, const double *flux, sph_error *err);
/* Regridding another grid's cells (the mixed layer's, on the model
 * plane) by the cell containing their centre: the file's cell that holds
 * (lon, lat) on a LONLAT grid, (x, y) on a PLANE grid (cells bounded by
 * the midpoints between the axes' centres), when it is water; else the
 * water cell whose plane centre is nearest (x, y) within reach m; -1 when
 * none. Each source cell goes whole to one file cell, so what is placed
 * is conserved exactly (docs/ocean-coupling.md). */
long ofx_locate(const ofx_writer *w, double lon, double lat, double x, double y, double reach);
/* Adds n source cells' extensive amounts of field k over the record's
 * interval dt s (J for the heat fields, kg for water and salt) to the
 * file's cells to[c] (from ofx_locate) as amount / (area dt), through
 * ofx_add_cells. *lost (may be NULL): the sum of the amounts whose to[c]
 * is -1. */
int ofx_add_cell_amounts(ofx_writer *w, int k, size_t n, const long *to, const double *amount, double dt,
                         double *lost, sph_error *err);
/* The mixed layer's cells (core/ocean.h sph_ocean, n cells): their open
 * water (ofx_heat, ofx_water, ofx_salt) and what the particles removed
 * since the last record left in them (ofx_heat_ice to hfsithermds, its
 * plane stress turned to the grid's x/y by cos/sin rot[c], rot[n + c] to
 * tauuo/tauvo (on a CURV grid rot is not used: the plane stress turns to
 * the target cell's i/j), ofx_swbase to siflswdbot), each cell whole to to[c], over
 * the record's interval dt s. lost[3] (may be NULL): the heat (J), water
 * and salt (kg) of cells with to[c] == -1. */
int ofx_add_ocean_cells(ofx_writer *w, size_t n, const long *to, const double *rot, const double *heat,
                        const double *water, const double *salt, const double *heat_ice, const double *taux,
                        const double *tauy, const double *swbase, double dt, double lost[3], sph_error *err);
/* Writes the current record: means over [t_start, t_end] (s since 1970,
 * t_end > t_start), time = t_end with bounds; then clears the record. */
int ofx_write_record(ofx_writer *w, double t_start, double t_end, sph_error *err);
/* CURV: the angle (rad, anticlockwise) from east to the grid's i axis of
 * cell c, as written in the file's `angle`; NAN for another grid. */
double ofx_grid_angle(const ofx_writer *w, size_t c);
/* Particles the last written record could not place (no water cell near). */
size_t ofx_lost(const ofx_writer *w);
size_t ofx_records(const ofx_writer *w);
int ofx_close(ofx_writer *w, sph_error *err);
void ofx_abort(ofx_writer *w); /* NULL-safe */

#endif
