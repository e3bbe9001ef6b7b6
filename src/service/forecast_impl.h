/* The forecast engine's private state, shared by its rooms:
 *   forecast.c         forecast_run: parameters, the step loop, step errors
 *   forecast_init.c    the initial state: plane box, land mask, rasters,
 *                      cold start (seeding) and warm start
 *   coupling.c         forcing -> particles (service/coupling.h)
 *   forecast_output.c  output grid, products, observation, restart file
 *   forecast_writer.c  the products' background writer (output.writer_thread)
 */
#ifndef SPHICE_SERVICE_FORECAST_IMPL_H
#define SPHICE_SERVICE_FORECAST_IMPL_H

#include <stddef.h>
#include <stdlib.h>

#include "core/model.h"
#include "io/geo.h"
#include "io/landmask.h"
#include "io/ocean_fluxes.h"
#include "io/products.h"
#include "io/raster.h"
#include "service/config.h"
#include "service/coupling.h"
#include "service/ensemble.h"
#include "service/forecast.h"
#include "util/timeutil.h"

#define DEG2RAD (M_PI / 180.0)
#define METRES_PER_DEGREE (6371000.0 * DEG2RAD) /* along a meridian, sphere R = 6371 km */

typedef struct fc_bgw fc_bgw;

typedef struct engine {
    const struct sph_config *cfg;
    const forecast_request *req;
    const volatile sig_atomic_t *cancel; /* the cycle's cancel flag (the station DEM reads it) */
    char cname[32];          /* cycle name, for messages */
    double t0, t_end;        /* forecast start and end, s since 1970 */
    geo_proj *proj;
    landmask *lm;            /* lon/lat land mask, NULL: none */
    sph_landmask plane;      /* the model's land mask on the plane */
    unsigned char *plane_land;
    fc_coupling cpl;         /* forcing -> particles */
    ice_raster *raster;      /* cold start raster (or the raster grid) */
    char raster_path[4096];
    sph_model *m;
    size_t cap;
    int thermo_on;
    sph_params prm;          /* the model's parameters: config, dt resolved */
    int dt_auto;             /* model.dt = 0: auto time stepping */
    double dt_base;          /* the interval the auto step divides, s */
    /* per-particle output arrays [cap]: position, east/north velocity, strain
     * invariants (div and shear: the coupling's cs and sn, alloc_work) */
    double *olon, *olat, *pue, *pvn, *div, *shear;
    /* output grid */
    prod_grid grid;
    size_t npts;
    double *gx, *gy, *g_conc, *g_hbar, *g_thick, *g_u, *g_v, *g_pres, *g_div, *g_shear, *g_dens;
    double *g_snow; /* snow thickness on the ice, m */
    unsigned char *g_land;
    prod_writer *pw;
    fc_bgw *bgw;             /* output.writer_thread: the products' writer thread, NULL: none */
    /* output.ocean_fluxes (forecast_output.c): the writer, the start of the
     * interval being summed, per-particle scratch (6 x cap) and the output
     * grid's cell areas and axes */
    ofx_writer *ofx;
    double ofx_t0;
    double *ofx_buf, *ofx_area, *ofx_lon, *ofx_lat;
    unsigned char *ofx_land;  /* the ocean grid's land (ocean_fluxes_grid ocean) */
    char ofx_grid_from[4200]; /* "output grid" or "ocean forcing PATH" */
    size_t ofx_ncell;         /* the file's cells */
    long *ofx_to;             /* the mixed layer's cell -> the file's cell (ofx_locate), -1: none; NULL: no layer */
    double *ofx_rot;          /* 2 x its cells: cos, sin of the plane's angle at each centre */
    struct ocean_grid *ofx_curv; /* a curvilinear ocean grid (io/ocean_grid.h), else NULL */
    double *ofx_bxy;          /* its cell corners on the plane: x [4 n], then y [4 n] */
    double *ofx_east;         /* its angle from east to the plane's x axis per cell */
    char restart_path[4200];
    int restart_written;
    char start_mode[16];
    int inline_logged;       /* the memory-bound output line was logged (forecast_output.c) */
    forecast_result *res;    /* the cold start's conservation numbers and flag go here */
    sph_particles *ocean_pts; /* the mixed layer's cell centres, for their forcing (forecast_ocean.c) */
    int ocean_fresh;          /* 1 until the first fill sets the cold start's slab from the SST */
    /* parallel.decomposition "domain" (forecast_domain.c): 0 off, 1 serial
     * canonical, 2 decomposed over MPI ranks; this rank and their count;
     * the rank's model and driver (2); the workers' jobs (rank 0); the
     * budget after init; 1 once no agreement may follow (a failure agreed,
     * or rank 0 alone after the loop) */
    int dd, dd_rank, dd_size;
    sph_model *dd_m;
    void *dd_ctx;
    void **dd_jobs;
    sph_budget dd_b0;
    int dd_failed;
} engine;

static inline void *xcalloc(size_t n, size_t size, int *ok)
{
    void *p = calloc(n ? n : 1, size);
    if (!p)
        *ok = 0;
    return p;
}

static inline void iso(double t, char *buf, size_t len) { time_format_iso(t, buf, len); }

/* forecast_ocean.c: the mixed layer (model.ocean.mixed_layer). The
 * capacity new ice needs (at most every lattice point of the plane box);
 * the grid, created on the model before sph_model_init; its cells'
 * forcing at time t (before the particles', whose messages it keeps). */
size_t fc_ocean_capacity(const engine *e, size_t count);
int fc_ocean_setup(engine *e, sph_error *err);
int fc_ocean_fill(engine *e, double t, sph_error *err);
/* The same into another model's mixed layer o (parallel.decomposition
 * "domain": every rank's decomposed model, forecast_domain.c), and the
 * cells' sample points of grid g (e->ocean_pts; a worker's, from rank 0's grid). */
int fc_ocean_fill_to(engine *e, sph_ocean *o, double t, sph_error *err);
int fc_ocean_points(engine *e, const sph_ocean_grid *g, sph_error *err);

/* The particles' forcing at time t (service/coupling.h). */
static inline int fc_fill_forcing(engine *e, double t, sph_error *err)
{
    int rc = e->ocean_pts ? fc_ocean_fill(e, t, err) : SPH_OK;
    if (rc)
        return rc;
    rc = coupling_fill(&e->cpl, e->proj, &e->cfg->model.thermo, e->thermo_on, sph_model_particles(e->m), t,
                       err);
    if (rc == SPH_OK && e->req->member) /* an ensemble member's perturbations (service/ensemble.h) */
        fc_member_perturb_forcing(e->req->member, sph_model_particles(e->m), t - e->t0);
    return rc;
}

/* forecast_writer.c: output.writer_thread. fc_bgw_start once the products
 * (and the ocean fluxes) are open: the thread when fc_bgw_wanted says so.
 * fc_bgw_submit (fc_write_output): waits for the previous output time's
 * job (its error, if it failed), copies what the steps change and prepares
 * the job; fc_bgw_kick, after each step's forcing fill, starts it at the
 * second call after the submit (the fill that reads the next slice);
 * fc_bgw_wait: until the job is written (before the restart file, before
 * closing), its rc and line; fc_bgw_stop (engine_free): waits for a
 * running job, drops a prepared one, ends the thread. Without a thread:
 * all no-ops. */
int fc_bgw_wanted(const engine *e);
int fc_bgw_start(engine *e, sph_error *err);
int fc_bgw_submit(engine *e, double t, const prod_fields *f, const prod_particles_view *pv, sph_error *err);
void fc_bgw_kick(engine *e);
int fc_bgw_wait(engine *e, sph_error *err);
void fc_bgw_stop(engine *e);
/* OpenMP's thread count for the next parallel region (1 without OpenMP) */
int fc_max_threads(void);

/* forecast_domain.c: parallel.decomposition "domain" (docs/domain.md).
 * fc_dd_begin: the refusals, the mode, rank 0's jobs to the workers (before
 * anything can fail). fc_dd_agree: collective; the worst of every rank's rc
 * (the first failing rank's line in err); the fail path calls it with its
 * rc unless a failure was already agreed. fc_dd_setup: after the start, the
 * particles scattered. fc_dd_step: forcing on the rank's particles and one
 * decomposed step, run stats added. fc_dd_sync: before an output or the
 * restart, the particles of e->m in id order (gathered on rank 0; the
 * caller agrees after writing).
 * fc_dd_budget: the budget of the synced particles (exact sums).
 * fc_dd_end: the rank's model freed, the workers' answers collected. */
int fc_dd_begin(engine *e, sph_error *err);
int fc_dd_agree(engine *e, int rc, sph_error *err);
int fc_dd_setup(engine *e, sph_error *err);
int fc_dd_step(engine *e, long s, double t, const volatile sig_atomic_t *cancel, sph_error *err);
int fc_dd_sync(engine *e, sph_error *err);
void fc_dd_budget(const engine *e, sph_budget *b);
void fc_dd_end(engine *e);

/* forecast.c */
int fc_resolve_dt(engine *e, sph_error *err);
/* More than 1 % of the particles on the plane's land: fails or flags by
 * initial.gate (forecast_init.c); sets res->land_fraction. */
int fc_land_gate(engine *e, sph_error *err);
/* The fraction of P's particles on L's land (*count: how many; may be NULL). */
double fc_land_fraction(const sph_landmask *L, const sph_particles *P, size_t *count);
void fc_fmt_status(const sph_status *st, char *buf, size_t len);
int fc_settings_fault(const sph_status *st);
/* A failed step's one line ("model step N (TIME): WHERE: WHAT; nothing written"). */
int fc_step_error(engine *e, const sph_status *st, long step, double t, sph_error *err);

/* forecast_init.c */
int fc_plane_box(engine *e, double *xmin, double *xmax, double *ymin, double *ymax, sph_error *err);
int fc_build_landmask(engine *e, double xmin, double xmax, double ymin, double ymax, double cell,
                      sph_error *err);
int fc_read_raster(engine *e, const char *tmpl, int format, const char *conc_var, double valid_time,
                   ice_raster **out, char *path, size_t plen, const char *what, sph_error *err);
/* The IMS and GeoTIFF keys (initial.ims.*, initial.gdal.*) and the domain
 * box, widened by a quarter of its span each way (at least 1 degree), for
 * the drivers that read only what covers it. */
void fc_raster_options(const struct sph_config *cfg, ice_raster_options *o);
double fc_spacing_m(const engine *e);
/* 1 when the land mask takes the initial raster's own land flags */
static inline int fc_raster_land(const struct sph_config *cfg)
{
    return cfg->landmask.source == CFG_LAND_RASTER || cfg->landmask.raster_land;
}
/* A cold start's seeding, for the cycle and `sphice check` alike: the
 * options from the configuration and the plane box; the particles seeded
 * into P (e->raster, e->proj, e->lm, e->plane set), those outside the
 * plane box dropped, and the numbers its gates and cycle.json report (m^2,
 * m^3): the raster's ice over the plane box's sea, the particles', and
 * the particles' before the lattice's scaling (raw_: = the particles' per
 * cell). */
typedef struct fc_seeded {
    double raster_area, raster_volume, area, volume, raw_area, raw_volume;
    size_t n, dropped;
    int rescaled;
} fc_seeded;
struct seed_options;
void fc_seed_options(const engine *e, struct seed_options *so);
int fc_seed(engine *e, const struct seed_options *so, sph_particles *P, fc_seeded *out, sph_error *err);
int fc_cold_start(engine *e, sph_error *err);
int fc_warm_start(engine *e, sph_error *err);

/* forecast_output.c */
int fc_setup_grid(engine *e, sph_error *err);
int fc_open_products(engine *e, prod_station *stations, sph_error *err);
int fc_set_observation(engine *e, sph_error *err);
/* The observation raster at path regridded to g (*out: nlat*nlon, caller
 * frees; NaN where it has no data), valid at *t_obs. */
int fc_read_observation(const struct sph_config *cfg, const char *path, const prod_grid *g, double t_valid,
                        double **out, double *t_obs, sph_error *err);
int fc_write_output(engine *e, double t, sph_error *err);
/* 1 when a forcing source may provide snowfall: products carry sisnthick. */
int fc_snow_possible(const struct sph_config *cfg);
int fc_write_restart(engine *e, double t, sph_error *err);
/* output.ocean_fluxes: opens the file on the output grid and zeroes the
 * particles' accumulators (the interval starts at the cycle time); the
 * records are written by fc_write_output; closing commits the file into
 * the stage directory and lists it in the manifest. Free: NULL-safe. */
int fc_open_ocean_fluxes(engine *e, sph_error *err);
/* The particles' ocean-flux accumulators (ofx_*) set to zero: at the start
 * of the file and after each of its records. */
void fc_ofx_zero(sph_particles *P);
int fc_close_ocean_fluxes(engine *e, sph_error *err);
void fc_free_ocean_fluxes(engine *e);

#endif
