/* The service configuration: one JSON file, one declarative key table.
 *
 * Every key has a path ("model.rheology.P0"), a type, a default (or is
 * required), bounds, a reloadable flag and one documentation line. That one
 * table (config.c: the service's own keys, and the model.* keys from the
 * core's parameter table, core/params.h) drives parsing, validation,
 * defaults, the key reference (`sphice config-doc`) and the effective
 * configuration shown by GET /status. Unknown keys and wrong types are
 * errors naming the key.
 *
 * The parsed struct keeps its members plain: numbers, enums, malloc'd
 * strings and arrays, all freed by sph_config_free. The engine reads:
 *   cfg->model            the sph_params of the model, ready for sph_model_create
 *   cfg->domain           bounding box and projection
 *   cfg->forcing[i]       sources (their local files come in forecast_request)
 *   cfg->initial          the initial raster
 *   cfg->landmask         the land mask source
 *   cfg->output           output grid, products, edge reference
 *   cfg->stations[i]      time series points
 */
#ifndef SPHICE_SERVICE_CONFIG_H
#define SPHICE_SERVICE_CONFIG_H

#include <stddef.h>
#include <stdio.h>
#include "core/model.h"
#include "io/forcing.h"
#include "util/err.h"
#include "util/limits.h"

#define CFG_MAX_CYCLES 48

typedef struct cfg_strlist { char **v; size_t n; } cfg_strlist;
typedef struct cfg_dbllist { double *v; size_t n; } cfg_dbllist;
typedef struct cfg_strmap { char **key, **val; size_t n; } cfg_strmap;
/* Times of day, seconds after 00:00 UTC, sorted ascending, distinct. */
typedef struct cfg_todlist { int sec[CFG_MAX_CYCLES]; size_t n; } cfg_todlist;

typedef struct cfg_forcing_source {
    char *name;
    int kind;               /* forcing_kind */
    cfg_strlist urls;       /* at most SPHICE_MAX_FILES templates: local path, file://,
                               http(s)://; strftime %Y %m %d %H %M %j */
    cfg_strmap variables;   /* standard_name -> variable in the file */
    cfg_strlist required;   /* quantity names (see config_quantity_flags) */
    cfg_strlist optional_q; /* key "optional" */
    double max_age_hours;   /* how old the newest forcing may be (stale policy) */
    double issue_hours;     /* how often the provider issues new files */
    int optional_source;    /* key "optional_source": a missing source is not an error */
    int vectors;            /* FORCING_VECTORS_*: orientation of wind and current pairs */
    int accumulation;       /* FORCING_ACCUMULATION_*: how accumulated fields are read */
    double margin_km;       /* read window: the domain plus this margin */
} cfg_forcing_source;

typedef struct cfg_station { char *name; double lon, lat; int structure_kind; double structure_diameter, structure_c_r;
    double structure_mass, structure_stiffness, structure_damping; /* the DEM's oscillator: t, kN/m, ratio */
    double structure_cone_angle, structure_waterline_diameter, structure_neck_diameter, structure_flexural_strength,
        structure_friction;
} cfg_station;

enum { CFG_INIT_NETCDF = 0, CFG_INIT_ESRI };
enum { CFG_REINIT_WARM = 0, CFG_REINIT_COLD, CFG_REINIT_NEWER_RASTER };
enum { CFG_THICK_AUTO = 0, CFG_THICK_ICE, CFG_THICK_CELL_MEAN }; /* = ICE_THICK_* */
enum { CFG_GATE_FAIL = 0, CFG_GATE_FLAG };
enum { CFG_LAND_NONE = 0, CFG_LAND_GSHHG, CFG_LAND_NETCDF, CFG_LAND_FORCING, CFG_LAND_RASTER };
enum { CFG_LAND_RES_CRUDE = 0, CFG_LAND_RES_LOW, CFG_LAND_RES_INTERMEDIATE, CFG_LAND_RES_HIGH,
       CFG_LAND_RES_FULL };
enum { CFG_GRID_REGULAR = 0, CFG_GRID_RASTER };
enum { CFG_OFX_GRID_AUTO = 0, CFG_OFX_GRID_OUTPUT, CFG_OFX_GRID_OCEAN }; /* output.ocean_fluxes_grid */
enum { CFG_WRITER_AUTO = 0, CFG_WRITER_ON, CFG_WRITER_OFF }; /* output.writer_thread */
enum { CFG_TABLES_AUTO = 0, CFG_TABLES_TRUE, CFG_TABLES_FALSE }; /* domain.plane_tables */
enum { CFG_LATE_FAIL = 0, CFG_LATE_STALE };
enum { CFG_DECOMP_MEMBERS = 0, CFG_DECOMP_DOMAIN }; /* parallel.decomposition */
enum { CFG_ENGINE_FORECAST = 0, CFG_ENGINE_TEST_DOUBLE };
enum { CFG_LOG_ERROR = 0, CFG_LOG_WARN, CFG_LOG_INFO, CFG_LOG_DEBUG };

struct sph_config {
    char *file;                 /* where it was read from ("<string>" if parsed from text) */
    char sha256[65];            /* of the file's text, for provenance */
    int log_level;              /* CFG_LOG_* */
    int engine;                 /* CFG_ENGINE_*: test-double only for tests */
    double test_engine_seconds; /* test double: run time */

    struct {
        char *name;
        double lon_min, lon_max, lat_min, lat_max;
        char *projection;       /* "auto" or a PROJ string */
        int plane_tables;       /* CFG_TABLES_*: lon/lat and grid angle from tables (io/geo.h) */
    } domain;

    sph_params model;           /* every field has a key under model. */

    cfg_forcing_source *forcing; /* at most SPHICE_MAX_SOURCES */
    size_t nforcing;

    struct {
        char *path;             /* template */
        int format;             /* CFG_INIT_* */
        char *conc_var, *thick_var;
        double default_thickness, threshold, spacing_deg;
        int reinit;             /* CFG_REINIT_* */
        int thickness_kind;     /* CFG_THICK_* */
        int gate;               /* CFG_GATE_* */
        double ims_ice_conc, ims_ice_thick; /* IMS ice cells; 0: unset */
        int gdal_conc_band, gdal_thick_band; /* GeoTIFF bands; 0: from metadata */
        int gdal_conc_units;    /* ICE_CONC_UNITS_* */
        int cell_particles;     /* n > 0: n x n particles per raster cell */
    } initial;

    struct {
        int source;             /* CFG_LAND_* */
        char *path, *variable;
        int resolution;         /* CFG_LAND_RES_* */
        int from;               /* landmask_from: auto, mask, fill */
        int polarity;           /* landmask_polarity: auto, land_is_1, water_is_1 */
        char *land_value;       /* "" or a number: the value that is land */
        int raster_land;        /* the initial raster's flagged land too */
    } landmask;

    struct {
        char *dir;
        struct { int mode; double lon0, lat0, dlon, dlat; int nlon, nlat; } grid;
        double interval_hours;
        struct { int fields, edge, geojson, particles, stations, maps, verification; } products;
        double edge_threshold;
        struct { double lon, lat; char *name; } edge_reference;
        cfg_dbllist map_times;  /* hours after the cycle time */
        int map_drift;          /* drift vectors on the concentration map */
        int retention_cycles;
        int ocean_fluxes;       /* <prefix>_ocean_fluxes.nc (docs/ocean-coupling.md) */
        int ocean_fluxes_grid;  /* CFG_OFX_GRID_* */
        int writer_thread;      /* CFG_WRITER_*: the products written on a thread of their own */
        int writer_nice;        /* that thread's nice increment (0..19) */
        int deflate_level;      /* zlib level of the NetCDF products, 0: uncompressed */
    } output;

    struct { char *path, *conc_var; int format; } observations;

    struct {
        int members, seed, modes;
        struct { double sigma, length_km, time_hours; } wind, current;
        struct { double conc_sigma, thick_sigma, length_km; } initial;
        double strength_sigma, drag_sigma;
        cfg_dbllist levels;
        int member_products;
    } ensemble;
    struct {
        int decomposition;      /* CFG_DECOMP_*: MPI ranks share members or one domain (docs/domain.md) */
    } parallel;

    cfg_station *stations;
    size_t nstations;
    struct {                    /* the ice-load product's model choice and DEM (io/products.h prod_loads_options) */
        int model;              /* PROD_LOADS_* */
        double dem_min_speed, dem_min_thickness, dem_duration, dem_particle_diameter, dem_sheet_length,
            dem_sheet_width, dem_dt, dem_cache_thickness, dem_cache_speed, map_threshold_kn;
        double dem_elastic_modulus, dem_bond_tensile, dem_bond_shear; /* GPa, MPa, MPa */
        int dem_max_particles;
    } loads;

    struct {
        cfg_todlist cycles;
        double every_hours;     /* >0 overrides cycles */
        double every_seconds;   /* tests only: >0 overrides both */
        double forecast_hours;
        int catch_up;
        double catch_up_hours;
        struct { double wait_minutes, poll_seconds; int policy; } late_data;
    } schedule;

    struct { char *listen; int enabled, max_connections, per_ip_limit; } status;
    struct { char *state_dir, *cache_dir, *hindcast_dir; } paths;
    struct {
        double connect_timeout_s, timeout_s, low_speed_s, backoff_s;
        int low_speed_bytes, retries;
    } fetch;                    /* downloads (io/fetch.h) */
    struct {
        char *command;          /* "" : serve runs cycles in its own process */
        char *program;          /* "" : this executable */
        double grace_s;         /* SIGTERM to SIGKILL on cancel */
    } launcher;                 /* serve: cycles as a launched job (service/launch.h) */
};

/* Reads and validates a configuration file. On failure *out is NULL and err
 * holds one line "config FILE: KEY: problem". */
int sph_config_load(const char *path, struct sph_config **out, sph_error *err);
/* The same from text; origin names it in messages. */
int sph_config_parse(const char *text, const char *origin, struct sph_config **out, sph_error *err);
void sph_config_free(struct sph_config *c);

/* Markdown reference of every key, generated from the table. */
void sph_config_doc(FILE *f);
/* The effective configuration as JSON text (caller frees). */
char *sph_config_to_json(const struct sph_config *c);
/* For a reload: copies every non-reloadable key from old into fresh and
 * lists the keys that differed (comma-separated) in changed. Returns their count. */
int sph_config_keep_unreloadable(struct sph_config *fresh, const struct sph_config *old,
                                 char *changed, size_t len);

/* forcing_quantity flags from names ("wind", "tair", "humidity", "swdn",
 * "lwdn", "current", "ssh", "sst", "ocean_flux"). -1 on an unknown name. */
int config_quantity_flag(const char *name);
/* log_level as util/log.h level. */
int config_log_level(const struct sph_config *c);

#endif
