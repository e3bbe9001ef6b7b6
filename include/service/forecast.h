/* One forecast run: the engine that `run`, `serve` and `hindcast` share.
 *
 * forecast_run reads already-fetched local forcing, initialises particles
 * (warm start from a particle file of the previous cycle, or cold start
 * from the initial raster), steps the model, and writes every product into
 * req->stage_dir (a private directory). Publishing (renaming the staged
 * directory into place and switching `latest`) is the caller's job, so a
 * failed or cancelled run never touches the previous products.
 */
#ifndef SPHICE_SERVICE_FORECAST_H
#define SPHICE_SERVICE_FORECAST_H

#include <signal.h>
#include <stddef.h>
#include "core/model.h"
#include "util/err.h"
#include "util/limits.h"
#include "io/products.h"

struct sph_config;

enum { FC_PHASE_IDLE = 0, FC_PHASE_FETCHING, FC_PHASE_INITIALISING, FC_PHASE_RUNNING,
       FC_PHASE_WRITING, FC_PHASE_DONE, FC_PHASE_FAILED };

/* Progress, written by the engine thread and read by the status server.
 * Plain doubles/longs written whole; readers tolerate a torn snapshot. */
typedef struct forecast_progress {
    volatile int phase;          /* FC_PHASE_* */
    volatile double model_time;  /* seconds since 1970 reached */
    volatile double percent;     /* 0..100 */
    volatile long particles;
    volatile double frac_free_drift, frac_rheology, frac_zero_layer, frac_multi_layer;
    volatile double dt;          /* dynamic step in use, s (auto or configured) */
    volatile int dt_auto;
} forecast_progress;

typedef struct forecast_request {
    double cycle_time;        /* seconds since 1970 UTC: forecast start */
    double hours;             /* forecast length */
    const char *stage_dir;    /* where products are written */
    const char *warm_start;   /* particle file of the previous cycle, or NULL */
    const char *const *forcing_files[SPHICE_MAX_SOURCES]; /* per configured source: local files
                                                             (NULL-terminated) */
    /* "path sha256" strings for provenance, NULL-terminated: room for every
     * file of every source */
    const char *forcing_sha256[SPHICE_MAX_PROVENANCE + 1];
    int stale;                /* forcing older than wanted: flag products */
    const char *observation;  /* observed concentration raster for verification, or NULL */
    const struct fc_member *member; /* an ensemble member's perturbations (service/ensemble.h),
                                       or NULL: the unperturbed run */
} forecast_request;

#define FC_MAX_PRODUCTS 32
typedef struct forecast_result {
    double wall_seconds;
    sph_run_stats run;           /* the core's run statistics: particles, regimes, solver,
                                    budget residual, time step */
    double ice_area_km2, ice_volume_km3, ice_mass_kg;
    double edge_distance_nm;     /* NaN if not configured */
    int has_scores;
    double iiee_km2, aee_km2, me_km2, edge_displacement_km, conc_bias, conc_rmse, skill_persistence;
    char start_mode[16];         /* "cold", "warm", "reinit" */
    /* cold start: the raster's ice over the domain's sea cells and the
     * seeded particles' (NaN on a warm start); the particles on land at
     * the end (0..1); why the forecast is flagged ("" none: issue 19 item
     * 7, initial.gate flag, or "open_water" for an ice-free raster) */
    double raster_ice_area_km2, raster_ice_volume_km3, seeded_ice_area_km2, seeded_ice_volume_km3;
    /* a lattice start: what its sampling gave before its scaling to the
     * raster's (NaN otherwise); the raster's figures are then over the
     * plane area the lattice's footprints tile */
    double lattice_raw_area_km2, lattice_raw_volume_km3;
    double land_fraction;
    int open_water;              /* cold start from a raster without ice in the domain */
    char quality_flag[256];
    char raster_assumed[256];    /* the raster's values taken from configuration (IMS ice cell) */
    int nproducts;
    char products[FC_MAX_PRODUCTS][512]; /* file names relative to stage_dir */
    prod_loads_summary loads;    /* the ice-load product: cost, latest load per station (on = 0: none) */
    struct {                     /* service/ensemble.h; members 0: a single run */
        int members;
        unsigned long long seed;
        int has_scores;
        double sps_km2, iiee_median_km2, mean_spread_conc;
    } ensemble;
} forecast_result;

#include "io/forcing.h"
/* The forcing_source_spec of configured source s over the given local
 * files (NULL-terminated); *map (caller frees) holds its name map. */
int forecast_source_spec(const struct sph_config *cfg, size_t s, const char *const *files,
                         forcing_source_spec *sp, forcing_name_map **map, sph_error *err);

/* The land mask of a netcdf or forcing landmask source read from path
 * (the landmask.path, or the ocean source's first file) with the
 * landmask.* keys; why (may be NULL) gets a line of what was found.
 * Returns SPH_OK, or an error with one line naming the file, the
 * variable and the key. *out is freed with landmask_free. */
struct landmask;
int forecast_landmask_read(const struct sph_config *cfg, const char *path, struct landmask **out,
                           char *why, size_t why_len, sph_error *err);

/* Returns SPH_OK, or an error code with one clear line in err. Checks
 * *cancel between steps; when set, stops and returns SPH_ERR_CANCELLED. */
int forecast_run(const struct sph_config *cfg, const forecast_request *req,
                 forecast_progress *prog, const volatile sig_atomic_t *cancel,
                 forecast_result *res, sph_error *err);

#endif
