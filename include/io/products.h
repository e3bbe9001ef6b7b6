/* Forecast products: gridded CF-1.8 NetCDF, ice edge (NetCDF geometry and
 * GeoJSON), station time series (NetCDF + CSV), particle trajectories,
 * quick-look PNG maps, verification scores and a manifest, all written into
 * a private stage directory and published atomically. docs/products.md
 * lists every file, variable and unit.
 *
 * Use (the forecast engine):
 *   products_open(&p, &opts, &grid, &meta, stage_dir, err);
 *   products_set_observation(p, t_obs, obs_conc, err);     optional
 *   for each output time: products_add_time(p, t, &fields, &particles, err);
 *   products_set_run_info(p, &info);                        optional
 *   products_close(p, &summary, err);        (frees p; on error p is aborted)
 *   on any earlier error: products_abort(p);  (removes temporary files)
 *   products_publish(stage_dir, final_dir, latest_link, err);
 *
 * Atomicity: every file is written under a temporary name beside its final
 * name (util/fileio.h) and renamed only once complete; manifest.json is
 * written last, and products_publish refuses a stage directory without it.
 *
 * Fault injection (SPHICE_FAULT=products-mid-write): products_add_time stops
 * after writing part of a time record and returns SPH_ERR_IO (the caller
 * then aborts, which removes the temporary files); with SPHICE_FAULT_EXIT
 * also set the process calls _exit(99) there instead, as a kill would.
 */
#ifndef SPHICE_IO_PRODUCTS_H
#define SPHICE_IO_PRODUCTS_H

#include <signal.h>
#include <stddef.h>
#include "core/model.h"
#include "io/edge.h"
#include "io/verify.h"
#include "util/err.h"
#include "util/limits.h"

#define PROD_MAX_PRODUCTS 32   /* as FC_MAX_PRODUCTS */
#define PROD_NAME_LEN 256
#define PROD_FILL_FLOAT 1.0e20f /* _FillValue of every float variable */

typedef struct prod_station {
    char name[SPHICE_MAX_NAME + 1];
    double lon, lat;   /* degrees; must lie inside the output grid */
} prod_station;

/* A station's structure for the ice-load product (products_loads.c). */
typedef struct prod_structure {
    double w;   /* vertical structure's waterline diameter, m; 0 = none (no load) */
    double c_r; /* its ISO 19906 C_R, Pa */
    /* the DEM's rigid structure (products_loads_dem.c): a horizontal
     * oscillator; mass 0 = fixed */
    double mass;      /* kg */
    double stiffness; /* N m-1 */
    double damping;   /* damping ratio zeta */
    /* a cone (cone_angle > 0; w is then its waterline diameter): Ralston's load */
    double cone_angle, neck, sigma_f, mu; /* degrees, m, Pa, - */
} prod_structure;

/* The ice-load product's model choice and DEM (products_loads_dem.c,
 * docs/dem.md "The station DEM"); the configuration's loads.* keys. */
enum { PROD_LOADS_AUTO = 0, PROD_LOADS_CHEAP = 1, PROD_LOADS_DEM = 2 }; /* = DEM_CHOOSE_* */
typedef struct prod_loads_options {
    int model;                /* PROD_LOADS_*: auto (the scene decides) or forced */
    double min_speed;         /* DEM threshold: drift speed, m s-1 (the concentration's is edge_threshold) */
    double min_thickness;     /* DEM threshold: thickness, m */
    double duration;          /* simulated time of one DEM run, s */
    double particle_diameter; /* nominal sphere diameter, m (the layers' count comes from it) */
    double sheet_length;      /* the ice sheet's length along the drift, m */
    double sheet_width;       /* its width across the drift, in structure diameters */
    double dt;                /* DEM step, s; 0: 0.9 dt_safety dt_critical */
    long max_particles;       /* a sheet needing more is refused */
    double cache_thickness;   /* the cache's (and the run's) thickness resolution, m; 0: exact */
    double cache_speed;       /* its speed resolution, m s-1; 0: exact */
    double map_threshold;     /* N: quick-look marks a station whose load exceeds it; 0: none */
    /* the bonded-particle ice (Potyondy & Cundall 2004; docs/dem.md "Stiffness"):
     * contact K_n = A E / L = E pi r / 2, bond k_n = E / (r_i + r_j) per area */
    double elastic_modulus;   /* E, Pa (loads.dem_elastic_modulus) */
    double bond_tensile;      /* sigma_t, Pa (loads.dem_bond_tensile) */
    double bond_shear;        /* tau_c, Pa (loads.dem_bond_shear) */
    /* the cycle's cancel flag (NULL: none): a DEM run stops at the next
     * step once it is set, with SPH_ERR_CANCELLED */
    const volatile sig_atomic_t *cancel;
} prod_loads_options;
void prod_loads_options_default(prod_loads_options *o);

/* One station DEM run's result. */
typedef struct prod_dem_result {
    double thickness, speed;  /* the DEM's ice (the forecast's, rounded to the cache resolution) */
    double mean, max, std;    /* the ice load along the drift, N, over every step */
    double freq;              /* its dominant frequency, Hz (the 1 kHz block-mean series) */
    double disp_max, disp_std; /* structure displacement along the drift: max |u|, std, m */
    double acc_max, acc_std;  /* structure acceleration: max |a|, std, m s-2 */
    long particles, bonds, steps;
    double dt;                /* step used, s */
    double seconds;           /* wall time of the run, s */
} prod_dem_result;

/* Runs the station DEM (docs/dem.md "The station DEM") for ice of
 * thickness h (m) drifting at speed u (m s-1) against structure ps.
 * Returns SPH_OK, or an error whose one line names `station` and the key
 * that settles it (loads.dem_dt beyond the stability limit,
 * loads.dem_max_particles for a sheet that cannot be built). */
int products_loads_dem_run(const prod_loads_options *o, const prod_structure *ps, const char *station, double h,
                           double u, prod_dem_result *r, sph_error *err);

/* The load product's summary (prod_summary.loads): cost and, per station
 * with a structure (the first PROD_MAX_LOAD_STATIONS), the last output
 * time's load of the model that ran. */
#define PROD_MAX_LOAD_STATIONS 32
typedef struct prod_load_latest {
    char name[SPHICE_MAX_NAME + 1];
    double time;              /* last output time */
    double load;              /* N: cheap ice_load, or the DEM's max; NaN: none */
    double max_load;          /* N: the largest such load over the forecast; NaN: none */
    char model[16];           /* "cheap", "dem", "none" */
} prod_load_latest;
typedef struct prod_loads_summary {
    int on;                   /* a load product was written */
    double dem_seconds;       /* wall time in DEM runs, s */
    long dem_runs, dem_cached, cheap_rows, dem_rows;
    long dem_steps, dem_particle_steps;
    int nstations;            /* entries in st */
    prod_load_latest st[PROD_MAX_LOAD_STATIONS];
} prod_loads_summary;

typedef struct prod_options {
    const char *prefix;         /* file-name prefix; NULL or "" -> "sphice" */
    double edge_threshold;      /* ice edge / extent threshold, fraction (0.15) */
    int has_reference;          /* edge distance from (ref_lon, ref_lat) */
    double ref_lon, ref_lat;
    const char *ref_name;       /* e.g. "head of Liaodong Bay"; may be NULL */
    const prod_station *stations;
    int nstations;
    const prod_structure *structures; /* NULL (none) or nstations entries */
    prod_loads_options loads;   /* the load model's choice and DEM */
    int write_particles;        /* trajectory file <prefix>_particles.nc */
    int write_geojson;          /* edge and areas file <prefix>_edge.geojson (default 1) */
    int quicklook_every;        /* PNG for output times 0, k, 2k, ... and the
                                   last one; 0 = none */
    int quicklook_width, quicklook_height; /* pixels (1500 x 720) */
    double quicklook_thick_max; /* top of the thickness colour scale, m (0.6) */
    int quicklook_drift;        /* drift vectors on the concentration map (0) */
    int deflate_level;          /* 0..9 (4) */
    int write_snow;             /* sisnthick on the fields and particles files (0: left out,
                                   as before snow existed; the engine sets it when a forcing
                                   source may provide snowfall) */
} prod_options;

void products_options_default(prod_options *o);

/* Provenance (copied at open). */
typedef struct prod_meta {
    const char *title, *summary, *institution, *region;
    const char *model_version;  /* NULL -> SPHICE_VERSION of this build */
    const char *git_revision;   /* NULL -> SPHICE_GIT of this build */
    const char *config_sha256;  /* sha256 of the configuration text */
    const char *const *forcing_sha256; /* "path sha256" strings, NULL-terminated */
    double cycle_time;          /* seconds since 1970: forecast reference time */
    int stale_forcing;          /* 1: forcing older than wanted */
    const char *start_mode;     /* "cold", "warm", "reinit"; may be NULL */
} prod_meta;

/* Run statistics known only at the end (written as global attributes):
 * the core's own run statistics, not a copy. */
typedef sph_run_stats prod_run_info;

/* Gridded fields at one output time: nlat*nlon doubles, row-major, south
 * to north. Only conc is required; a NULL field is written as fill.
 * Masking: land (land[k] = 1) is fill everywhere. Over sea, NaN in conc
 * and hbar means open water (0); the other fields are fill where there is
 * no ice (conc <= 0 or NaN) or the value is NaN. */
typedef struct prod_fields {
    const double *conc;        /* sea ice area fraction, 0..1 */
    const double *hbar;        /* ice volume per cell area (mean thickness), m */
    const double *thick;       /* thickness of the ice itself h_i, m */
    const double *u_east, *v_north; /* ice velocity, m/s */
    const double *pressure;    /* vertically integrated ice pressure/strength, N/m */
    const double *divergence;  /* 1/s */
    const double *shear;       /* maximum shear rate, 1/s */
    const unsigned char *land; /* 1 = land; may be NULL (all sea) */
    const double *snow;        /* snow thickness on the ice h_s, m (with write_snow) */
} prod_fields;

/* Particles at one output time (geographic positions and east/north
 * velocity: the engine converts from the model plane). */
typedef struct prod_particles_view {
    size_t n;
    const double *lon, *lat, *u_east, *v_north, *mass, *thick, *conc;
    const long *id;
    const double *snow;        /* snow depth h_s, m (with write_snow) */
} prod_particles_view;

/* Particles read back from a trajectory file (owned arrays). */
typedef struct prod_particles {
    size_t n;
    double time;
    double *lon, *lat, *u_east, *v_north, *mass, *thick, *conc;
    long *id;
    double *snow;              /* NaN when the file has none */
} prod_particles;

typedef struct prod_summary {
    int ntimes;
    double ice_area_km2;       /* last output time: sum conc dA */
    double ice_extent_km2;     /* last output time: sum dA where conc >= threshold */
    double ice_volume_km3;     /* last output time: sum hbar dA */
    double edge_length_km;     /* last output time */
    double edge_distance_nm;   /* last output time; NaN without reference or edge */
    int has_scores;
    verify_scores scores;
    int nproducts;
    char products[PROD_MAX_PRODUCTS][PROD_NAME_LEN]; /* names relative to stage_dir */
    prod_loads_summary loads;  /* the ice-load product (on = 0: none) */
} prod_summary;

typedef struct prod_writer prod_writer;

/* Creates stage_dir (mkdir -p) and the temporary files. */
int products_open(prod_writer **p, const prod_options *opts, const prod_grid *grid,
                  const prod_meta *meta, const char *stage_dir, sph_error *err);

/* Observed concentration (fraction, nlat*nlon, NaN where unknown) valid at
 * t_obs; copied. Scored against the output time equal to t_obs (within
 * 1 s); persistence is the first output time's concentration. */
int products_set_observation(prod_writer *p, double t_obs, const double *obs_conc,
                             sph_error *err);

/* Appends output time t (strictly increasing). particles may be NULL. */
int products_add_time(prod_writer *p, double t, const prod_fields *fields,
                      const prod_particles_view *particles, sph_error *err);

void products_set_run_info(prod_writer *p, const prod_run_info *info);

/* The initial state's conservation and the quality flag (issue 19 items
 * 4, 7), written at close as the global attributes
 * sphice_raster_ice_area_km2, sphice_raster_ice_volume_km3,
 * sphice_seeded_ice_area_km2, sphice_seeded_ice_volume_km3 (each only when
 * finite: a cold start), sphice_particles_on_land_fraction and
 * sphice_quality_flag ("none" or why the forecast is published flagged). */
typedef struct prod_init_info {
    double raster_area_km2, raster_volume_km3, seeded_area_km2, seeded_volume_km3;
    double land_fraction;
    const char *flag; /* copied; NULL or "": none */
} prod_init_info;
void products_set_init_info(prod_writer *p, const prod_init_info *info);
/* Lists a file another writer has committed into the stage directory
 * (name relative to it: the ocean fluxes) in the manifest and the summary. */
int products_add_file(prod_writer *p, const char *name, sph_error *err);

/* Finalises and commits every file, writes manifest.json last, fills
 * *summary (may be NULL) and frees p. On failure removes the temporary
 * files, frees p and returns the error. */
int products_close(prod_writer *p, prod_summary *summary, sph_error *err);

/* Discards an unfinished writer: closes and removes temporary files. NULL-safe. */
void products_abort(prod_writer *p);

/* Lists more files of a closed stage directory in its manifest.json (the
 * restart file, the service's cycle.json: written after products_close):
 * each of names (NULL-terminated, plain file names in stage_dir) not yet
 * listed gets its size and sha256; the manifest is rewritten atomically.
 * A name that is missing or has a '/' is an error and nothing changes. */
int products_manifest_add(const char *stage_dir, const char *const *names, sph_error *err);

/* Publishes a completed stage directory: checks manifest.json and every
 * file it lists (size), renames stage_dir to final_dir (an existing
 * final_dir is replaced: moved aside, then removed), then points
 * latest_link (may be NULL) at final_dir with an atomic symlink switch
 * (relative target when both share a directory). On any failure before
 * the rename nothing is changed; latest moves only after the rename. */
int products_publish(const char *stage_dir, const char *final_dir, const char *latest_link,
                     sph_error *err);

/* Reads the particles of output time t (NaN: the last time) from a
 * trajectory file written by products_*. For drift analysis and replay; a
 * warm start needs the full state and uses the engine's restart format. */
int products_read_particles(const char *path, double t, prod_particles *out, sph_error *err);
void prod_particles_free(prod_particles *p); /* NULL-safe */

/* Drift direction: the direction the ice moves TOWARDS, degrees clockwise
 * from true north in [0, 360) (due south = 180). NaN if either is NaN. */
double products_drift_direction_deg(double u_east, double v_north);

#endif
