/* Restart (warm-start) particle files: the complete particle state and
 * the model's clock, so that a run read back continues bit for bit.
 *
 * One netCDF-4 file, written atomically (util/fileio.h: temporary name,
 * fsync, rename). Dimensions `particle` (n) and `layer` (nlayers).
 * Variables: the fields of SPH_PARTICLE_FIELDS (core/particles.h) with
 * restart YES or OPT, in list order, named, typed (double, int64, ubyte)
 * and described as there; particles in slot order (the order matters for
 * bit-for-bit continuation: the neighbour sort is stable). Today:
 *   x, y (m, model plane), u, v (m/s, plane components), mass (kg),
 *   thick (h_i, m), conc, sml, sml0 (m), dens, dens0 (kg/m^2), snow (m),
 *   tsurf (deg C), s11, s22, s12 (N/m), coastc, enth(particle, layer)
 *   (J/m^3), id (int64), regime (ubyte flags).
 * Optional: the mixed layer's state (restart_write_ocean: ocean_* on the
 * dimension ocean_cell, docs/ocean.md).
 * Global attributes: sphice_restart_format = "sphice-restart-1", valid
 * time (`time`, seconds since 1970 and `time_iso`), the forecast cycle that
 * wrote it, the PROJ definition of the plane (`projection`), nlayers, and
 * the model clock (time since init, steps, thermodynamic accumulator,
 * density calibration, mass budget).
 *
 * Reading checks the format, the sizes, the layer count and (when asked)
 * that the projection is the one of the running model: positions in
 * metres mean nothing on another plane. Every attribute read is present,
 * of a numeric type (text for the format and projection) with one value,
 * finite (cycle_time may be NaN: unknown) and in range (nlayers
 * 1..SPH_MAX_LAYERS, particles 0..RESTART_MAX_PARTICLES and equal to the
 * particle dimension, steps and removed particles >= 0); every variable
 * is checked before any is read: present (coastc may be absent), of a
 * NetCDF type that converts without loss (double: double or float; id:
 * an integer type up to int64; regime: ubyte) and on the dimensions
 * (particle) or (particle, layer). Any other file is refused with one
 * line naming the file, the variable or attribute and the problem, and
 * the particle set is left as it was.
 */
#ifndef SPHICE_IO_RESTART_H
#define SPHICE_IO_RESTART_H

#include <stddef.h>
#include "core/model.h"
#include "core/ocean.h"
#include "core/particles.h"
#include "util/err.h"

#define RESTART_FORMAT "sphice-restart-1"
/* The most particles a restart header may declare (the engine sizes the
 * model from it before reading): 1e8, about 25 GB of particle arrays. */
#define RESTART_MAX_PARTICLES 100000000LL

typedef struct restart_header {
    double time;             /* valid time of the state, seconds since 1970 */
    double cycle_time;       /* forecast cycle that wrote it (NaN: unknown) */
    char projection[2048];   /* geo_proj_definition of the model plane */
    int nlayers;
    size_t n;                /* particles */
    sph_model_clock clock;   /* model state outside the particle arrays */
} restart_header;

/* Writes the first P->n particles (all state, slot order) and the header
 * (h->n and h->nlayers are taken from P). */
int restart_write(const char *path, const sph_particles *P, const restart_header *h,
                  sph_error *err);

/* restart_write with the mixed layer's state (o not NULL): its temperature,
 * salinity, depth, water, salt, waiting frazil and its enthalpy, the
 * open water's flux accumulators and (when not all zero; absent reads as
 * zero) the removed particles' ones, variables ocean_* on the dimension
 * ocean_cell, and its grid (attributes ocean_x0, ocean_y0, ocean_dx,
 * ocean_dy, ocean_nx, ocean_ny), so that a restart continues it bit for bit. */
int restart_write_ocean(const char *path, const sph_particles *P, const restart_header *h, const sph_ocean *o,
                        sph_error *err);
/* Reads the mixed layer's state into o when the file has it (*found = 1);
 * a file without the dimension ocean_cell leaves o alone (*found = 0,
 * SPH_OK). A grid other than o's is refused (SPH_ERR_CONFIG, naming
 * model.ocean.cell), so is a missing, misshapen or non-finite variable;
 * every variable is checked before o changes. */
int restart_read_ocean(const char *path, sph_ocean *o, int *found, sph_error *err);
/* Reads the header only (to size the model before reading the particles). */
int restart_read_header(const char *path, restart_header *h, sph_error *err);

/* Reads the particles into P (P->n is set; P->cap must hold them and
 * P->nlayers must equal the file's). expect_projection, when not NULL,
 * must equal the file's projection. Forcing arrays are left alone;
 * diagnosed arrays other than dens are zeroed. */
int restart_read(const char *path, const char *expect_projection, restart_header *h,
                 sph_particles *P, sph_error *err);

#endif
