/* Private to the ocean-fluxes writer (ocean_fluxes.c) and its
 * curvilinear remap (ocean_fluxes_curv.c). */
#ifndef SPHICE_IO_OCEAN_FLUXES_IMPL_H
#define SPHICE_IO_OCEAN_FLUXES_IMPL_H

#include <stddef.h>
#include "io/ocean_fluxes.h"

#define OFX_FILL 1.0e20
#define OFX_PATH 4200

/* The extensive amounts gathered from the particles. */
enum { ACC_HEAT_ICE, ACC_HEAT_LEAD, ACC_WATER, ACC_SALT, ACC_TAUX, ACC_TAUY, ACC_SWBASE,
       ACC_ICE_AREA, ACC_ICE_VOLUME, NACC };

struct ofx_writer {
    ofx_grid_kind kind;
    int nx, ny;
    size_t n;
    double *cx, *cy, *area;
    double *xaxis, *yaxis;      /* copies of the grid's axes (ofx_locate) */
    unsigned char *land;
    double *acc[NACC];          /* extensive amounts of the current record */
    double *add[OFX_NFIELDS];   /* per-cell fluxes added by ofx_add_cells */
    double *out;                /* one field of a record */
    /* index of the water cells on the plane: bins of side `bin` */
    double bx0, by0, bin;
    int nbx, nby;
    size_t *bstart, *bcell;
    double *w;                  /* weights of one particle's cells */
    size_t *wc;
    size_t wcap;
    size_t lost, lost_record, nrec;
    char path[OFX_PATH], tmp[OFX_PATH];
    /* OFX_GRID_CURV (ocean_fluxes_curv.c): corners [4 n] on the plane and
     * in degrees, the grid's i axis on the plane (beta) and from east
     * (alpha), per cell; cells binned by their polygons' boxes */
    double *bx, *by, *blon, *blat, *beta, *alpha;
    double cbx0, cby0, cbin;
    int cnbx, cnby;
    size_t *cbstart, *cbcell, *seen, seen_mark;
    int nc, v_time, v_bnds, v_lost, v_data[OFX_NFIELDS];
};

/* 1 if cell c is water and on the plane. */
int ofx_water_cell(const ofx_writer *w, size_t c);
/* Room for n weights in w->w / w->wc; SPH_OK or an error. */
int ofx_reserve(ofx_writer *w, size_t n, sph_error *err);
/* Bins of side *bin (doubled until at most ~4 per cell) over a wx x wy
 * box of n cells: *nbx x *nby. */
void ofx_fit_bins(double wx, double wy, size_t n, double *bin, int *nbx, int *nby);
/* The water cell whose plane centre is nearest (x, y) within reach, -1: none. */
long ofx_nearest_water(const ofx_writer *w, double x, double y, double reach);

/* ocean_fluxes_curv.c */
int ofxc_setup(ofx_writer *w, const ofx_grid *g, sph_error *err);
void ofxc_free(ofx_writer *w);
/* The weights of a footprint of radius R / sqrt(3) at (x, y), as place() */
size_t ofxc_place(ofx_writer *w, double x, double y, double R, sph_error *err, int *rc);
/* The cell whose polygon holds (x, y), -1 none. */
long ofxc_cell_at(const ofx_writer *w, double x, double y);

#endif
