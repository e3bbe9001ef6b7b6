/* The configuration key table and everything it drives: parsing,
 * validation, defaults, the markdown reference and the effective config.
 *
 * Invariant: after a successful parse every member named by the table holds
 * either the file's value or the table's default; required keys (default
 * NULL) were present. Defaults are JSON text parsed by the same code as the
 * file, so a default can never bypass validation. The model.* keys are the
 * core's parameter table (core/params.h): their defaults are that table's
 * defaults written as JSON (sph_param_default_json), their bounds its
 * bounds, save the service's own overrides (model_overrides). */
#include "service/config.h"
#include "service/cycle_name.h"
#include "service/http.h"
#include "io/ensemble.h"
#include "io/products.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "util/fileio.h"
#include "util/log.h"

typedef enum { CT_BOOL, CT_INT, CT_DOUBLE, CT_STRING, CT_ENUM, CT_TODLIST, CT_STRLIST,
               CT_DBLLIST, CT_STRMAP, CT_OBJARRAY } cfg_type;

enum { CF_RELOAD = 1u << 0, /* a SIGHUP applies a change */
       CF_TEST = 1u << 1 }; /* for tests only (documented as such) */

struct cfg_table;
typedef struct cfg_key {
    const char *path;          /* dotted, relative to the table's object */
    cfg_type type;
    const char *def;           /* JSON text; NULL = required */
    double lo, hi;             /* numbers: inclusive bounds; strings: length; lists: count */
    unsigned flags;
    const char *const *names;  /* CT_ENUM: NULL-terminated, index = value */
    size_t off, off_count;     /* member offset; CT_OBJARRAY: offset of the size_t count */
    const struct cfg_table *sub; /* CT_OBJARRAY element table */
    const char *doc;
} cfg_key;

typedef struct cfg_table {
    const cfg_key *keys;
    size_t nkeys;
    size_t elem_size;
} cfg_table;

#define BIG 1e300
#define K(T, path, type, member, def, lo, hi, fl, names, doc) \
    {path, type, def, lo, hi, fl, names, offsetof(T, member), 0, NULL, doc}
#define C_(path, type, member, def, lo, hi, fl, names, doc) \
    K(struct sph_config, path, type, member, def, lo, hi, fl, names, doc)

static const char *const fkind_names[] = {"atmosphere", "ocean", "tide", NULL};
static const char *const init_format_names[] = {"netcdf", "esri", NULL};
static const char *const reinit_names[] = {"warm", "cold", "newer_raster", NULL};
static const char *const thick_kind_names[] = {"auto", "ice", "cell_mean", NULL};
static const char *const conc_units_names[] = {"auto", "fraction", "percent", NULL}; /* ICE_CONC_UNITS_* */
static const char *const gate_names[] = {"fail", "flag", NULL};
static const char *const land_names[] = {"none", "gshhg", "netcdf", "forcing", "raster", NULL};
static const char *const landres_names[] = {"crude", "low", "intermediate", "high", "full", NULL};
static const char *const landfrom_names[] = {"auto", "mask", "fill", NULL};
static const char *const landpol_names[] = {"auto", "land_is_1", "water_is_1", NULL};
static const char *const grid_names[] = {"regular", "raster", NULL};
static const char *const ofx_grid_names[] = {"auto", "output", "ocean", NULL};
static const char *const writer_names[] = {"auto", "on", "off", NULL};
/* an enum that lists "true" and "false" also takes the JSON booleans (and writes them back) */
static const char *const tables_names[] = {"auto", "true", "false", NULL}; /* CFG_TABLES_* */
static const char *const late_names[] = {"fail", "stale", NULL};
static const char *const engine_names[] = {"forecast", "test-double", NULL};
static const char *const level_names[] = {"error", "warn", "info", "debug", NULL};
static const char *const vectors_names[] = {"auto", "earth", "grid", NULL};
static const char *const accumulation_names[] = {"interval", "running", NULL};
static const char *const structure_kind_names[] = {"none", "vertical", "cone", NULL};
static const char *const decomposition_names[] = {"members", "domain", NULL}; /* CFG_DECOMP_* */
static const char *const loads_model_names[] = {"auto", "cheap", "dem", NULL};

static const cfg_key forcing_keys[] = {
    K(cfg_forcing_source, "name", CT_STRING, name, NULL, 1, SPHICE_MAX_NAME, 0, NULL,
      "Source name used in messages, status and provenance (unique)."),
    K(cfg_forcing_source, "kind", CT_ENUM, kind, NULL, 0, 0, 0, fkind_names,
      "What the source provides: atmosphere (wind, air temperature, radiation), ocean (currents, SSH, SST, heat flux) or tide."),
    K(cfg_forcing_source, "urls", CT_STRLIST, urls, NULL, 1, SPHICE_MAX_FILES, 0, NULL,
      "File templates (a string or a list): local path, file:// or http(s):// URL; strftime fields %Y %m %d %H %M %j are the cycle time."),
    K(cfg_forcing_source, "variables", CT_STRMAP, variables, "{}", 0, 64, 0, NULL,
      "Renames {standard_name: variable_in_file} for files without CF standard_name attributes."),
    K(cfg_forcing_source, "required", CT_STRLIST, required, "[]", 0, 16, 0, NULL,
      "Quantities that must be found: wind, tair, humidity, swdn, lwdn, current, ssh, sst, ocean_flux, snowfall, precipitation."),
    K(cfg_forcing_source, "optional", CT_STRLIST, optional_q, "[]", 0, 16, 0, NULL,
      "Quantities used when present (same names as required)."),
    K(cfg_forcing_source, "max_age_hours", CT_DOUBLE, max_age_hours, "24", 0, 720, 0, NULL,
      "With late_data.policy stale: the oldest issue (hours before the cycle) still usable."),
    K(cfg_forcing_source, "issue_hours", CT_DOUBLE, issue_hours, "6", 0.001, 720, 0, NULL,
      "How often the provider issues new files; older issues are looked for in these steps."),
    K(cfg_forcing_source, "optional_source", CT_BOOL, optional_source, "false", 0, 0, 0, NULL,
      "A missing optional source does not fail the cycle (e.g. tides)."),
    K(cfg_forcing_source, "vectors", CT_ENUM, vectors, "\"auto\"", 0, 0, 0, vectors_names,
      "Wind and current components: auto (from the standard_name or the file's conventions; a pair found by name on a curvilinear grid is refused), earth (east/north) or grid (along the grid axes, rotated)."),
    K(cfg_forcing_source, "accumulation", CT_ENUM, accumulation, "\"interval\"", 0, 0, 0, accumulation_names,
      "Accumulated fields (J m-2; kg m-2 or m of water of snowfall and precipitation): interval (each value is the amount over the interval ending at its time, ERA5 hourly) or running (the amount since a start that may reset, GFS and forecasts: consecutive values are differenced; a time whose grid total drops starts a new accumulation)."),
    K(cfg_forcing_source, "margin_km", CT_DOUBLE, margin_km, "300", 0, 20040, 0, NULL,
      "Read window: only the part of each grid that covers the domain plus this margin, km, is read (plus 3 nodes each side for bilinear interpolation); the default covers 72 h of drift at 1.1 m/s. A particle that leaves the window is outside the forcing. 20040 (half the circumference) reads whole grids; harmonic tide files are always read whole."),
};
static const cfg_table forcing_table = {forcing_keys, sizeof forcing_keys / sizeof forcing_keys[0],
                                        sizeof(cfg_forcing_source)};

static const cfg_key station_keys[] = {
    K(cfg_station, "name", CT_STRING, name, NULL, 1, SPHICE_MAX_NAME, 0, NULL, "Station name."),
    K(cfg_station, "lon", CT_DOUBLE, lon, NULL, -180, 360, 0, NULL, "Longitude, degrees east."),
    K(cfg_station, "lat", CT_DOUBLE, lat, NULL, -90, 90, 0, NULL, "Latitude, degrees north."),
    K(cfg_station, "structure.kind", CT_ENUM, structure_kind, "\"none\"", 0, 0, 0, structure_kind_names, "Offshore structure at the station: none, vertical (a vertical leg: the ice-load product sphice_loads.nc and .csv with ISO 19906 global crushing load, docs/dem.md) or cone (an upward-breaking cone: Ralston's bending-failure load; needs structure.cone_angle, waterline_diameter and neck_diameter); either gets the station DEM against its leg or cone where the scene needs it (loads.*)."),
    K(cfg_station, "structure.diameter", CT_DOUBLE, structure_diameter, "1.6", 0.01, 1000, 0, NULL, "The vertical structure's waterline diameter w, m (ISO 19906 valid for w/h > 2)."),
    K(cfg_station, "structure.c_r", CT_DOUBLE, structure_c_r, "1.8", 0.01, 100, 0, NULL, "ISO 19906 ice strength coefficient C_R, MPa (1.8 sub-Arctic, including the Bohai; 2.8 Arctic)."),
    K(cfg_station, "structure.mass", CT_DOUBLE, structure_mass, "300", 0, 1e9, 0, NULL, "The structure's mass in the DEM (a horizontal oscillator), t; 0: fixed (default: the seed's leg, 300 t)."),
    K(cfg_station, "structure.stiffness", CT_DOUBLE, structure_stiffness, "5e5", 0, 1e12, 0, NULL, "The structure's horizontal stiffness in the DEM, kN/m (the seed's 5.0e5); must be positive when the mass is."),
    K(cfg_station, "structure.damping", CT_DOUBLE, structure_damping, "0.03", 0, 0.99, 0, NULL, "The structure's damping ratio in the DEM (the seed's 0.03)."),
    K(cfg_station, "structure.cone_angle", CT_DOUBLE, structure_cone_angle, "0", 0, 90, 0, NULL, "A cone's angle from the horizontal, degrees; kind cone needs it within Ralston's range [20, 70] (0: not set)."),
    K(cfg_station, "structure.waterline_diameter", CT_DOUBLE, structure_waterline_diameter, "0", 0, 1000, 0, NULL, "A cone's diameter at the waterline D, m (kind cone; 0: not set)."),
    K(cfg_station, "structure.neck_diameter", CT_DOUBLE, structure_neck_diameter, "0", 0, 1000, 0, NULL, "A cone's top (neck) diameter D_T, m, where the ride-up ends; positive and below the waterline diameter (kind cone; 0: not set)."),
    K(cfg_station, "structure.flexural_strength", CT_DOUBLE, structure_flexural_strength, "0.6", 0.01, 10, 0, NULL, "Flexural strength of the ice on a cone, MPa (0.6: Bohai ice, 0.5-0.7 MPa, docs/dem.md)."),
    K(cfg_station, "structure.friction", CT_DOUBLE, structure_friction, "0.15", 0, 1, 0, NULL, "Ice-to-cone friction coefficient mu (0.15: ice on steel); Ralston needs mu <= min(tan a, cot a) - 0.01."),
};
static const cfg_table station_table = {station_keys, sizeof station_keys / sizeof station_keys[0],
                                        sizeof(cfg_station)};

#define R CF_RELOAD
static const cfg_key head_keys[] = {
    C_("log_level", CT_ENUM, log_level, "\"info\"", 0, 0, R, level_names,
       "Log level: error, warn, info, debug."),
    C_("engine", CT_ENUM, engine, "\"forecast\"", 0, 0, CF_TEST, engine_names,
       "test-double replaces the model by a stand-in that writes a small product and sleeps."),
    C_("test.engine_seconds", CT_DOUBLE, test_engine_seconds, "1", 0, 3600, CF_TEST | R, NULL,
       "How long the test-double engine runs, s."),

    C_("domain.name", CT_STRING, domain.name, "\"domain\"", 1, SPHICE_MAX_NAME, R, NULL, "Name of the domain (products, status)."),
    C_("domain.lon_min", CT_DOUBLE, domain.lon_min, NULL, -180, 360, R, NULL, "West edge, degrees east."),
    C_("domain.lon_max", CT_DOUBLE, domain.lon_max, NULL, -180, 360, R, NULL, "East edge, degrees east."),
    C_("domain.lat_min", CT_DOUBLE, domain.lat_min, NULL, -90, 90, R, NULL, "South edge, degrees north."),
    C_("domain.lat_max", CT_DOUBLE, domain.lat_max, NULL, -90, 90, R, NULL, "North edge, degrees north."),
    C_("domain.projection", CT_STRING, domain.projection, "\"auto\"", 1, 511, R, NULL,
       "\"auto\" (local transverse Mercator at the domain centre) or a PROJ string."),
    C_("domain.plane_tables", CT_ENUM, domain.plane_tables, "\"auto\"", 0, 0, R, tables_names,
       "Longitude, latitude and the east/north rotation of the particles from tables computed once per run on a 1 km plane grid (bilinear; within 2 cm and 1e-10 rad of PROJ for aeqd, docs/engine.md) instead of PROJ and trigonometry per particle and step. true: refused within 2 degrees of a pole or beyond 4e7 nodes; auto (a JSON string): tables unless the domain is such, then PROJ per particle with one log line; false: PROJ per particle."),

};

/* Between head_keys and tail_keys: model.*, one key per row of the core's
 * parameter table (core/params.h), built by config_table(). */

static const cfg_key tail_keys[] = {
    {"forcing", CT_OBJARRAY, NULL, 1, SPHICE_MAX_SOURCES, R, NULL, offsetof(struct sph_config, forcing),
     offsetof(struct sph_config, nforcing), &forcing_table,
     "Forcing sources (1 to " SPHICE_STR(SPHICE_MAX_SOURCES) "), each an object with the keys below."},

    C_("initial.path", CT_STRING, initial.path, "\"\"", 0, 4095, R, NULL,
       "Initial ice raster (template with strftime fields); empty: warm starts only."),
    C_("initial.format", CT_ENUM, initial.format, "\"netcdf\"", 0, 0, R, init_format_names,
       "Raster format: netcdf or esri (ASCII grid)."),
    C_("initial.conc_var", CT_STRING, initial.conc_var, "\"sea_ice_concentration\"", 1, 63, R, NULL,
       "Concentration variable (NetCDF)."),
    C_("initial.thick_var", CT_STRING, initial.thick_var, "\"\"", 0, 63, R, NULL,
       "Thickness variable (NetCDF); empty: default_thickness everywhere."),
    C_("initial.default_thickness", CT_DOUBLE, initial.default_thickness, "0.2", 0.001, 20, R, NULL,
       "Ice thickness where the raster has none, m."),
    C_("initial.threshold", CT_DOUBLE, initial.threshold, "0.15", 0, 1, R, NULL,
       "Concentration below which no particle is placed."),
    C_("initial.spacing", CT_DOUBLE, initial.spacing_deg, "0.02", 0, 5, R, NULL,
       "Initial particle spacing, degrees (a lattice on the model plane); 0: one particle per raster cell, at its centre with the cell's true area."),
    C_("initial.cell_particles", CT_INT, initial.cell_particles, "0", 0, 10, R, NULL,
       "n > 0: seed n x n particles per raster cell (at its sub-cells' centres, each with the cell's concentration and thickness and 1/n^2 of its true area), whatever initial.spacing says; 0: initial.spacing decides (a lattice, or one per cell)."),
    C_("initial.reinit", CT_ENUM, initial.reinit, "\"newer_raster\"", 0, 0, R, reinit_names,
       "warm: warm start from the previous cycle's particles when they exist; cold: always from the raster; newer_raster: warm unless the raster is newer than the previous cycle."),
    C_("initial.thickness_kind", CT_ENUM, initial.thickness_kind, "\"auto\"", 0, 0, R, thick_kind_names,
       "What the raster's thickness is: ice (per ice-covered area), cell_mean (volume per cell area, divided by the concentration), auto (from the variable's cell_methods, long_name, name or standard_name; an error where they do not say)."),
    C_("initial.gate", CT_ENUM, initial.gate, "\"fail\"", 0, 0, R, gate_names,
       "Sanity gates: a cold start whose raster has ice in the domain but seeds none, or whose seeded ice area or volume differs from the raster's (domain's sea cells) by more than 5 %, or a run ending with more than 1 % of its particles on land: fail (the cycle fails with one line, nothing published) or flag (published with sphice_quality_flag and cycle.json quality_flag)."),

    C_("initial.ims.ice_concentration", CT_DOUBLE, initial.ims_ice_conc, "0", 0, 1, R, NULL,
       "IMS snow and ice analysis (ASCII or GeoTIFF): the concentration given to a sea-ice cell (class 3), 0 < A <= 1; the product says only ice or no ice. 0: unset, an IMS raster is then refused naming this key."),
    C_("initial.ims.ice_thickness", CT_DOUBLE, initial.ims_ice_thick, "0", 0, 100, R, NULL,
       "IMS snow and ice analysis: the ice thickness given to a sea-ice cell, m (per ice area). 0: unset, an IMS raster is then refused naming this key."),
    C_("initial.gdal.conc_band", CT_INT, initial.gdal_conc_band, "0", 0, 100000, R, NULL,
       "GeoTIFF: the band (from 1) that holds the sea-ice concentration; 0: the band whose metadata says so (standard_name sea_ice_area_fraction, or a description such as siconc), else the file is refused naming this key."),
    C_("initial.gdal.thick_band", CT_INT, initial.gdal_thick_band, "0", -1, 100000, R, NULL,
       "GeoTIFF: the band (from 1) that holds the ice thickness; -1: none (initial.default_thickness); 0: the band whose metadata says so (standard_name sea_ice_thickness, or a description such as sithick), and a band whose role the metadata does not give is refused naming this key."),
    C_("initial.gdal.conc_units", CT_ENUM, initial.gdal_conc_units, "\"auto\"", 0, 0, R, conc_units_names,
       "GeoTIFF: the concentration band's unit: fraction (0..1), percent, or auto (the band's unit type or units metadata: %, percent, 1, fraction; where it says nothing the file is refused naming this key)."),

    C_("landmask.source", CT_ENUM, landmask.source, "\"none\"", 0, 0, R, land_names,
       "none, gshhg (shoreline polygons), netcdf (mask variable), forcing (ocean model's land), raster (the initial raster's own land, coast and lake flags)."),
    C_("landmask.path", CT_STRING, landmask.path, "\"\"", 0, 4095, R, NULL, "Land mask file."),
    C_("landmask.raster_land", CT_BOOL, landmask.raster_land, "false", 0, 0, R, NULL,
       "true: the initial raster's own land, coast and lake flags are land as well (in union with landmask.source); the raster must then be readable at every cycle."),
    C_("landmask.variable", CT_STRING, landmask.variable, "\"\"", 0, 63, R, NULL,
       "Mask variable, or (from fill) the variable whose fill marks land; empty: found in the file (a land/sea mask by standard name, flag meanings or ROMS mask_rho; for source forcing else a current's fill)."),
    C_("landmask.resolution", CT_ENUM, landmask.resolution, "\"intermediate\"", 0, 0, R, landres_names,
       "GSHHG resolution."),
    C_("landmask.from", CT_ENUM, landmask.from, "\"auto\"", 0, 0, R, landfrom_names,
       "netcdf/forcing sources: auto (a mask variable; for forcing, else the fill pattern of a current), mask (a mask variable only), fill (land where landmask.variable, or a current, is _FillValue/missing/NaN, at the level nearest the surface)."),
    C_("landmask.polarity", CT_ENUM, landmask.polarity, "\"auto\"", 0, 0, R, landpol_names,
       "Which value of a 0/1 mask is land: auto (from flag_meanings, standard name land_binary_mask/sea_binary_mask or ROMS mask_rho; a mask that says nothing is refused), land_is_1, water_is_1."),
    C_("landmask.land_value", CT_STRING, landmask.land_value, "\"\"", 0, 31, R, NULL,
       "The mask value that is land (a number, after scale_factor/add_offset); empty: see landmask.polarity. Overrides flag meanings."),

    C_("output.dir", CT_STRING, output.dir, NULL, 1, 4095, 0, NULL,
       "Product directory: one <YYYYMMDDTHHZ>/ per cycle and a `latest` symlink."),
    C_("output.grid.mode", CT_ENUM, output.grid.mode, "\"regular\"", 0, 0, R, grid_names,
       "regular (the keys below) or raster (the initial raster's grid)."),
    C_("output.grid.lon0", CT_DOUBLE, output.grid.lon0, "0", -180, 360, R, NULL, "First longitude, degrees east."),
    C_("output.grid.lat0", CT_DOUBLE, output.grid.lat0, "0", -90, 90, R, NULL, "First latitude, degrees north."),
    C_("output.grid.dlon", CT_DOUBLE, output.grid.dlon, "0.05", 1e-5, 10, R, NULL, "Longitude step, degrees."),
    C_("output.grid.dlat", CT_DOUBLE, output.grid.dlat, "0.05", 1e-5, 10, R, NULL, "Latitude step, degrees."),
    C_("output.grid.nlon", CT_INT, output.grid.nlon, "1", 1, 100000, R, NULL, "Number of longitudes."),
    C_("output.grid.nlat", CT_INT, output.grid.nlat, "1", 1, 100000, R, NULL, "Number of latitudes."),
    C_("output.interval_hours", CT_DOUBLE, output.interval_hours, "1", 0.01, 240, R, NULL,
       "Time between output fields, hours."),
    C_("output.products.fields", CT_BOOL, output.products.fields, "true", 0, 0, R, NULL,
       "Gridded CF NetCDF fields. Must be true: the fields file is the forecast's primary product and "
       "carries the edge, the area, extent and volume series and the scores; false is refused."),
    C_("output.products.edge", CT_BOOL, output.products.edge, "true", 0, 0, R, NULL,
       "Ice edge lines (in the fields file). Must be true, like output.products.fields; false is refused."),
    C_("output.products.geojson", CT_BOOL, output.products.geojson, "true", 0, 0, R, NULL, "Edge and areas as GeoJSON."),
    C_("output.products.particles", CT_BOOL, output.products.particles, "true", 0, 0, R, NULL,
       "Particle files (also the next cycle's warm start)."),
    C_("output.products.stations", CT_BOOL, output.products.stations, "true", 0, 0, R, NULL, "Station time series."),
    C_("output.products.maps", CT_BOOL, output.products.maps, "false", 0, 0, R, NULL, "PNG maps at map_times."),
    C_("output.products.verification", CT_BOOL, output.products.verification, "true", 0, 0, R, NULL,
       "Scores against observations when a raster exists."),
    C_("output.ocean_fluxes", CT_BOOL, output.ocean_fluxes, "false", 0, 0, R, NULL,
       "Fluxes into the ocean (heat, fresh water, salt, ice-ocean stress, shortwave at the ice base; ice "
       "concentration and volume) as means over each output interval on output.ocean_fluxes_grid, in "
       "sphice_ocean_fluxes.nc: what a coupled ocean model reads (docs/ocean-coupling.md)."),
    C_("output.ocean_fluxes_grid", CT_ENUM, output.ocean_fluxes_grid, "\"auto\"", 0, 0, R, ofx_grid_names,
       "Grid of the ocean-fluxes file: ocean (the first ocean forcing file's grid, regular lon/lat or "
       "curvilinear with 2-D lon/lat, and its land, the cells over the domain; on a curvilinear grid the "
       "stress is along the grid's own axes), output (the output grid) or auto (ocean when an ocean source "
       "has files, else output). A grid given by its mapping alone is placed by the mapping (a rotated pole, or a projection with its ellipsoid); one not orthogonal is refused: set output."),
    C_("output.writer_thread", CT_ENUM, output.writer_thread, "\"auto\"", 0, 0, R, writer_names,
       "Where the products of each output time are written: on (a thread of their own, while the next steps run; "
       "the same files), off (in the step loop), auto (on when OpenMP may use two threads or more, so that a "
       "one-thread run stays on one core; and an output time of 500000 particles or more written in the step "
       "loop, so that its copies do not add to the next steps' memory: docs/bench.md, Session 11). Off whatever it says with output.ocean_fluxes or "
       "parallel.decomposition \"domain\" (docs/engine.md)."),
    C_("output.writer_nice", CT_INT, output.writer_nice, "0", 0, 19, R, NULL,
       "Nice increment of the products' writer thread (output.writer_thread): above 0 the OpenMP team's "
       "threads, woken at each parallel loop, take a core from the writer at once, and the writer runs in "
       "their gaps (it has until the next output time; the engine waits for it there). The same files; "
       "0 keeps the process's priority. docs/bench.md \"Session 11: free drift (fd5)\"."),
    C_("output.deflate_level", CT_INT, output.deflate_level, "4", 0, 9, R, NULL,
       "zlib level of the variables of the fields and particles files (with the shuffle filter), 1 fastest, 9 "
       "smallest; 0: uncompressed (the same values; the files about 3.5 times larger). A product-format choice: "
       "docs/bench.md \"Free drift\" measures it."),
    C_("output.edge_threshold", CT_DOUBLE, output.edge_threshold, "0.15", 0.01, 0.99, R, NULL,
       "Concentration defining the ice edge."),
    C_("output.edge_reference.lon", CT_DOUBLE, output.edge_reference.lon, "0", -180, 360, R, NULL,
       "Reference point for the edge distance, degrees east."),
    C_("output.edge_reference.lat", CT_DOUBLE, output.edge_reference.lat, "0", -90, 90, R, NULL,
       "Reference point latitude, degrees north."),
    C_("output.edge_reference.name", CT_STRING, output.edge_reference.name, "\"\"", 0, SPHICE_MAX_NAME, R, NULL,
       "Reference point name; empty: no edge distance."),
    C_("output.map_times", CT_DBLLIST, output.map_times, "[]", 0, 10000, R, NULL,
       "Hours after the cycle time at which maps are drawn."),
    C_("output.map_drift", CT_BOOL, output.map_drift, "true", 0, 0, R, NULL,
       "Drift vectors (with a key) on the concentration map."),
    C_("output.retention_cycles", CT_INT, output.retention_cycles, "14", 0, 100000, R, NULL,
       "Published cycles kept in output.dir; 0 keeps all."),

    C_("observations.path", CT_STRING, observations.path, "\"\"", 0, 4095, R, NULL,
       "Observed concentration raster template (strftime fields = valid time); empty: no verification."),
    C_("observations.format", CT_ENUM, observations.format, "\"netcdf\"", 0, 0, R, init_format_names,
       "Observation raster format."),
    C_("observations.conc_var", CT_STRING, observations.conc_var, "\"sea_ice_concentration\"", 1, 63, R, NULL,
       "Observation concentration variable."),

    C_("ensemble.members", CT_INT, ensemble.members, "1", 1, SPHICE_MAX_MEMBERS, R, NULL,
       "Ensemble members; 1: a single deterministic run. Member 0 is the unperturbed control (docs/ensemble.md)."),
    C_("ensemble.seed", CT_INT, ensemble.seed, "1", 0, 2147483647, R, NULL,
       "Seed of the perturbations (recorded in the products): the same seed gives the same ensemble bit for bit."),
    C_("ensemble.modes", CT_INT, ensemble.modes, "64", 1, 4096, R, NULL,
       "Random Fourier modes per perturbation field."),
    C_("ensemble.wind.sigma", CT_DOUBLE, ensemble.wind.sigma, "0", 0, 50, R, NULL,
       "Standard deviation of each wind component's perturbation, m/s."),
    C_("ensemble.wind.length_km", CT_DOUBLE, ensemble.wind.length_km, "200", 0, 1e5, R, NULL,
       "Correlation length of the wind perturbation (Gaussian: correlation exp(-1/2) at this distance), km; 0: uniform."),
    C_("ensemble.wind.time_hours", CT_DOUBLE, ensemble.wind.time_hours, "24", 0, 1e5, R, NULL,
       "E-folding time of the wind perturbation, hours; 0: frozen."),
    C_("ensemble.current.sigma", CT_DOUBLE, ensemble.current.sigma, "0", 0, 5, R, NULL,
       "Standard deviation of each current component's perturbation, m/s."),
    C_("ensemble.current.length_km", CT_DOUBLE, ensemble.current.length_km, "50", 0, 1e5, R, NULL,
       "Correlation length of the current perturbation, km; 0: uniform."),
    C_("ensemble.current.time_hours", CT_DOUBLE, ensemble.current.time_hours, "48", 0, 1e5, R, NULL,
       "E-folding time of the current perturbation, hours; 0: frozen."),
    C_("ensemble.initial.conc_sigma", CT_DOUBLE, ensemble.initial.conc_sigma, "0", 0, 1, R, NULL,
       "Standard deviation of the initial concentration's additive perturbation (fraction; clipped to 0.01..1)."),
    C_("ensemble.initial.thick_sigma", CT_DOUBLE, ensemble.initial.thick_sigma, "0", 0, 0.9, R, NULL,
       "Standard deviation of the initial thickness's relative perturbation (h (1 + f), f clipped to +-3 sigma)."),
    C_("ensemble.initial.length_km", CT_DOUBLE, ensemble.initial.length_km, "50", 0, 1e5, R, NULL,
       "Correlation length of the initial perturbations, km; 0: uniform."),
    C_("ensemble.strength_sigma", CT_DOUBLE, ensemble.strength_sigma, "0", 0, 2, R, NULL,
       "Log-normal perturbation of the ice strength P0: P0 exp(sigma g), g standard normal per member."),
    C_("ensemble.drag_sigma", CT_DOUBLE, ensemble.drag_sigma, "0", 0, 2, R, NULL,
       "Log-normal perturbation of the air and water drag coefficients (independent draws)."),
    C_("ensemble.levels", CT_DBLLIST, ensemble.levels, "[0.1, 0.5, 0.9]", 0, 1, R, NULL,
       "Probability levels of the ensemble edge contours (each in (0, 1]; at most " SPHICE_STR(ENS_MAX_LEVELS) ")."),
    C_("ensemble.member_products", CT_BOOL, ensemble.member_products, "false", 0, 0, R, NULL,
       "Keep every member's products under members/mNNN of the cycle (the control's are the cycle's own)."),

    C_("parallel.decomposition", CT_ENUM, parallel.decomposition, "\"members\"", 0, 0, R, decomposition_names,
       "What MPI ranks share under mpirun/srun: members (ensemble members over ranks) or domain (one member split by space over the ranks, bit-identical to the serial canonical run; docs/domain.md)."),

    {"stations", CT_OBJARRAY, "[]", 0, 10000, R, NULL, offsetof(struct sph_config, stations),
     offsetof(struct sph_config, nstations), &station_table, "Time series points, each {name, lon, lat}."},

    C_("loads.model", CT_ENUM, loads.model, "\"auto\"", 0, 0, R, loads_model_names,
       "Ice-load model at the stations with a structure: auto (the DEM where the concentration reaches output.edge_threshold, the drift speed loads.dem_min_speed and the thickness loads.dem_min_thickness, the cheap ISO 19906 formula elsewhere), cheap or dem (forced; docs/dem.md)."),
    C_("loads.dem_min_speed", CT_DOUBLE, loads.dem_min_speed, "0.05", 0, 10, R, NULL,
       "The DEM runs only where the ice drifts at least this fast, m/s."),
    C_("loads.dem_min_thickness", CT_DOUBLE, loads.dem_min_thickness, "0.1", 0, 20, R, NULL,
       "The DEM runs only where the ice is at least this thick, m."),
    C_("loads.dem_duration", CT_DOUBLE, loads.dem_duration, "1", 1e-4, 600, R, NULL,
       "Simulated time of one station DEM run, s."),
    C_("loads.dem_particle_diameter", CT_DOUBLE, loads.dem_particle_diameter, "0.1", 0.005, 10, R, NULL,
       "Nominal sphere diameter of the DEM's ice sheet, m (the seed's 0.1 m); the layers' count comes from it, the spheres are resized so that the sheet has the forecast's thickness."),
    C_("loads.dem_sheet_length", CT_DOUBLE, loads.dem_sheet_length, "1", 0.01, 1000, R, NULL,
       "Length of the DEM's ice sheet along the drift, m."),
    C_("loads.dem_sheet_width", CT_DOUBLE, loads.dem_sheet_width, "2", 0.1, 100, R, NULL,
       "Width of the DEM's ice sheet across the drift, in structure diameters."),
    C_("loads.dem_dt", CT_DOUBLE, loads.dem_dt, "0", 0, 1, R, NULL,
       "DEM time step, s; 0: 0.9 x 0.8 x the contact's stability limit. A step beyond 0.8 x the limit is refused (one line naming the station), nothing published."),
    C_("loads.dem_max_particles", CT_INT, loads.dem_max_particles, "20000", 10, 10000000, R, NULL,
       "A station DEM sheet needing more spheres is refused (one line naming the station), nothing published."),
    C_("loads.dem_cache_thickness", CT_DOUBLE, loads.dem_cache_thickness, "0.02", 0, 10, R, NULL,
       "The DEM runs at the thickness rounded to this resolution, m, and a cycle reuses the result of an equal (thickness, speed, structure); 0: exact values only."),
    C_("loads.dem_cache_speed", CT_DOUBLE, loads.dem_cache_speed, "0.02", 0, 10, R, NULL,
       "The same rounding of the drift speed, m/s; 0: exact values only."),
    C_("loads.dem_elastic_modulus", CT_DOUBLE, loads.dem_elastic_modulus, "1", 0.001, 100, R, NULL,
       "Elastic modulus E of the DEM's bonded ice, GPa (the seed's 1 GPa). The stiffness follows Potyondy & Cundall (2004): contact K_n = A E / L = E pi r / 2 (A = pi r^2, L = 2 r), K_s = 0.6 K_n; parallel bond k_n = E / (r_i + r_j) per unit area, k_s = 0.6 k_n (docs/dem.md)."),
    C_("loads.dem_bond_tensile", CT_DOUBLE, loads.dem_bond_tensile, "0.334", 0.001, 100, R, NULL,
       "Tensile strength sigma_t of the DEM's parallel bonds, MPa: calibrated so that a close-packed three-point-bending specimen of 0.1 m spheres, 0.263 m deep, reaches the 0.6 MPa flexural strength of Bohai ice (Xiu et al. 2022) on a span of 16 depths under a roller nose (test_dem_bend, docs/dem.md). Valid for loads.dem_particle_diameter 0.1; other sizes need their own calibration."),
    C_("loads.dem_bond_shear", CT_DOUBLE, loads.dem_bond_shear, "0.558", 0.001, 100, R, NULL,
       "Shear strength tau_c of the DEM's parallel bonds, MPa: the calibrated tensile strength times 1.669 (0.222 / 0.133, session 6's ratio, itself the uncalibrated 1 MPa / 0.6 MPa; docs/dem.md)."),
    C_("loads.map_threshold_kn", CT_DOUBLE, loads.map_threshold_kn, "500", 0, 1e9, R, NULL,
       "Quick-look maps mark a station whose ice load (the model that ran) exceeds this, kN; 0: no marks."),

    C_("schedule.cycles", CT_TODLIST, schedule.cycles, "[\"00:00\", \"12:00\"]", 0, CFG_MAX_CYCLES, R, NULL,
       "Cycle times of day, \"HH:MM\" UTC."),
    C_("schedule.every_hours", CT_DOUBLE, schedule.every_hours, "0", 0, 240, R, NULL,
       "If > 0: a cycle every N hours from 00:00 UTC, instead of cycles."),
    C_("schedule.every_seconds", CT_DOUBLE, schedule.every_seconds, "0", 0, 86400, CF_TEST | R, NULL,
       "A cycle every N seconds."),
    C_("schedule.forecast_hours", CT_DOUBLE, schedule.forecast_hours, "72", 0.001, 2400, R, NULL,
       "Forecast length, hours."),
    C_("schedule.catch_up", CT_BOOL, schedule.catch_up, "true", 0, 0, R, NULL,
       "true: run missed cycles (oldest first) after downtime; false: only the latest."),
    C_("schedule.catch_up_hours", CT_DOUBLE, schedule.catch_up_hours, "24", 0, 8760, R, NULL,
       "How far back missed cycles are caught up."),
    C_("schedule.late_data.wait_minutes", CT_DOUBLE, schedule.late_data.wait_minutes, "60", 0, 1440, R, NULL,
       "How long to wait for the cycle's forcing."),
    C_("schedule.late_data.poll_seconds", CT_DOUBLE, schedule.late_data.poll_seconds, "60", 0.05, 3600, R, NULL,
       "How often to look again while waiting."),
    C_("schedule.late_data.policy", CT_ENUM, schedule.late_data.policy, "\"stale\"", 0, 0, R, late_names,
       "After the wait: fail, or stale (run with the newest forcing within max_age_hours, flagged stale)."),

    C_("status.enabled", CT_BOOL, status.enabled, "true", 0, 0, 0, NULL, "Serve HTTP status."),
    C_("status.listen", CT_STRING, status.listen, "\"127.0.0.1:8642\"", 3, 127, 0, NULL,
       "Address of the status server: IPV4:PORT, [IPV6]:PORT, or a numeric address alone (port 8642)."),
    C_("status.max_connections", CT_INT, status.max_connections, "32", 1, 1024, 0, NULL,
       "Concurrent HTTP connections."),
    C_("status.per_ip_limit", CT_INT, status.per_ip_limit, "8", 1, 1024, 0, NULL,
       "Concurrent HTTP connections from one address."),

    C_("paths.state_dir", CT_STRING, paths.state_dir, "\"/var/lib/sphice\"", 1, 4095, 0, NULL,
       "History database, locks."),
    C_("paths.cache_dir", CT_STRING, paths.cache_dir, "\"/var/cache/sphice\"", 1, 4095, R, NULL,
       "Downloaded forcing."),
    C_("paths.hindcast_dir", CT_STRING, paths.hindcast_dir, "\"\"", 0, 4095, R, NULL,
       "Hindcast products; empty: output.dir/hindcast."),

    C_("launcher.command", CT_STRING, launcher.command, "\"\"", 0, 1023, R, NULL,
       "serve only: run each cycle as a job, `COMMAND PROGRAM run CONFIG --cycle TIME`, e.g. \"mpirun -np 8\" or \"srun -n 8\" (split at blanks; quotes group words); empty: in the service's own process. The job is cancelled as a whole (its process group) on SIGTERM (docs/ensemble.md)."),
    C_("launcher.program", CT_STRING, launcher.program, "\"\"", 0, 4095, R, NULL,
       "The sphice executable the launcher starts (e.g. build-mpi/sphice for MPI); empty: the running executable."),
    C_("launcher.grace_s", CT_DOUBLE, launcher.grace_s, "30", 0, 3600, R, NULL,
       "On cancellation, seconds between SIGTERM and SIGKILL to the launched job's process group."),

    C_("fetch.connect_timeout_s", CT_DOUBLE, fetch.connect_timeout_s, "30", 0.1, 3600, R, NULL,
       "Downloads: seconds to establish a connection."),
    C_("fetch.timeout_s", CT_DOUBLE, fetch.timeout_s, "600", 1, 86400, R, NULL,
       "Downloads: seconds one attempt may take in all."),
    C_("fetch.low_speed_bytes", CT_INT, fetch.low_speed_bytes, "1024", 1, 1000000000, R, NULL,
       "Downloads: an attempt slower than this many bytes/s for fetch.low_speed_s is abandoned."),
    C_("fetch.low_speed_s", CT_DOUBLE, fetch.low_speed_s, "60", 1, 3600, R, NULL,
       "Downloads: seconds below fetch.low_speed_bytes per second before an attempt is abandoned."),
    C_("fetch.retries", CT_INT, fetch.retries, "3", 0, 20, R, NULL,
       "Downloads: extra attempts after a transient failure (HTTP 408, 429, 5xx, timeouts, resets)."),
    C_("fetch.backoff_s", CT_DOUBLE, fetch.backoff_s, "5", 0, 3600, R, NULL,
       "Downloads: seconds before the first retry, doubled for each further one."),
};
#undef R

/* The service's own overrides of core rows. model.dt: 0 (the default) is
 * the automatic step, resolved by the core once the particles are placed
 * (sph_params_resolve_dt), and a configured step is at most an hour; the
 * core's range (to 86400 s) also takes the stand-in step the engine checks
 * the parameters with until the automatic step is known. */
static const struct { const char *key, *def; double lo, hi; } model_overrides[] = {
    {"dt", "0", 0, 3600},
};

static cfg_table config_table_;
static pthread_once_t config_once = PTHREAD_ONCE_INIT;

/* head_keys, the model.* keys from the core's table, tail_keys. Built once;
 * on out of memory the table stays empty and sph_config_parse fails. */
static void config_table_build(void)
{
    static const cfg_type of_param[] = {[SPH_PARAM_DOUBLE] = CT_DOUBLE, [SPH_PARAM_INT] = CT_INT,
                                        [SPH_PARAM_BOOL] = CT_BOOL, [SPH_PARAM_ENUM] = CT_ENUM};
    const size_t nh = sizeof head_keys / sizeof head_keys[0], nt = sizeof tail_keys / sizeof tail_keys[0];
    size_t np;
    const sph_param *rows = sph_param_table(&np);
    cfg_key *keys = calloc(nh + np + nt, sizeof *keys);
    char(*text)[2][96] = calloc(np, sizeof *text); /* per row: path, default */
    if (!keys || !text) {
        free(keys);
        free(text);
        return;
    }
    memcpy(keys, head_keys, sizeof head_keys);
    for (size_t i = 0; i < np; i++) {
        const sph_param *r = &rows[i];
        cfg_key *k = &keys[nh + i];
        snprintf(text[i][0], sizeof text[i][0], "model.%s", r->key);
        sph_param_default_json(r, text[i][1], sizeof text[i][1]);
        *k = (cfg_key){text[i][0], of_param[r->type], text[i][1], r->lo, r->hi,
                       (r->flags & SPH_PARAM_RELOAD) ? CF_RELOAD : 0u, r->names,
                       offsetof(struct sph_config, model) + r->offset, 0, NULL, r->doc};
        for (size_t j = 0; j < sizeof model_overrides / sizeof model_overrides[0]; j++)
            if (!strcmp(model_overrides[j].key, r->key)) {
                k->def = model_overrides[j].def;
                k->lo = model_overrides[j].lo;
                k->hi = model_overrides[j].hi;
            }
    }
    memcpy(keys + nh + np, tail_keys, sizeof tail_keys);
    config_table_ = (cfg_table){keys, nh + np + nt, sizeof(struct sph_config)};
}

static const cfg_table *config_table(void)
{
    pthread_once(&config_once, config_table_build);
    return &config_table_;
}

/* ---------------------------------------------------------------- helpers */

static const char *json_kind(const cJSON *n)
{
    if (cJSON_IsString(n)) return "string";
    if (cJSON_IsNumber(n)) return "number";
    if (cJSON_IsBool(n)) return "boolean";
    if (cJSON_IsNull(n)) return "null";
    if (cJSON_IsArray(n)) return "array";
    if (cJSON_IsObject(n)) return "object";
    return "invalid";
}

static void *at(void *base, size_t off) { return (char *)base + off; }
static const void *cat_(const void *base, size_t off) { return (const char *)base + off; }

static char *dupstr(const char *s)
{
    size_t n = strlen(s);
    char *d = malloc(n + 1);
    if (d)
        memcpy(d, s, n + 1);
    return d;
}

static void strlist_free(cfg_strlist *l)
{
    for (size_t i = 0; i < l->n; i++)
        free(l->v[i]);
    free(l->v);
    l->v = NULL;
    l->n = 0;
}

static void strmap_free(cfg_strmap *m)
{
    for (size_t i = 0; i < m->n; i++) {
        free(m->key[i]);
        free(m->val[i]);
    }
    free(m->key);
    free(m->val);
    m->key = m->val = NULL;
    m->n = 0;
}

static void table_free(const cfg_table *t, void *base);

static void key_free(const cfg_key *k, void *base)
{
    void *p = at(base, k->off);
    switch (k->type) {
    case CT_STRING: free(*(char **)p); *(char **)p = NULL; break;
    case CT_STRLIST: strlist_free(p); break;
    case CT_STRMAP: strmap_free(p); break;
    case CT_DBLLIST: free(((cfg_dbllist *)p)->v); ((cfg_dbllist *)p)->v = NULL; ((cfg_dbllist *)p)->n = 0; break;
    case CT_OBJARRAY: {
        char *arr = *(char **)p;
        size_t *count = at(base, k->off_count);
        for (size_t i = 0; arr && i < *count; i++)
            table_free(k->sub, arr + i * k->sub->elem_size);
        free(arr);
        *(char **)p = NULL;
        *count = 0;
        break;
    }
    default: break;
    }
}

static void table_free(const cfg_table *t, void *base)
{
    for (size_t i = 0; i < t->nkeys; i++)
        key_free(&t->keys[i], base);
}

void sph_config_free(struct sph_config *c)
{
    if (!c)
        return;
    table_free(config_table(), c);
    free(c->file);
    free(c);
}

/* Parses "HH:MM" into seconds of day; -1 if malformed. */
static int parse_tod(const char *s)
{
    char *end;
    errno = 0;
    long h = strtol(s, &end, 10);
    if (end == s || *end != ':' || h < 0 || h > 23 || end - s > 2)
        return -1;
    const char *m0 = end + 1;
    long m = strtol(m0, &end, 10);
    if (end - m0 != 2 || *end || m < 0 || m > 59)
        return -1;
    return (int)(h * 3600 + m * 60);
}

static int cmp_int(const void *a, const void *b)
{
    int x = *(const int *)a, y = *(const int *)b;
    return (x > y) - (x < y);
}

static int table_parse(const cfg_table *t, void *base, const cJSON *obj, const char *prefix,
                       const char *origin, sph_error *err);

/* Sets one key from a JSON node. `where` is the full key path for messages. */
static int key_set(const cfg_key *k, void *base, const cJSON *n, const char *where,
                   const char *origin, sph_error *err)
{
    void *p = at(base, k->off);
#define BAD(fmt, ...) sph_err_set(err, SPH_ERR_CONFIG, "config %s: %s: " fmt, origin, where, ##__VA_ARGS__)
    switch (k->type) {
    case CT_BOOL:
        if (!cJSON_IsBool(n))
            return BAD("expected true or false, got %s", json_kind(n));
        *(int *)p = cJSON_IsTrue(n);
        return SPH_OK;
    case CT_INT:
    case CT_DOUBLE: {
        if (!cJSON_IsNumber(n))
            return BAD("expected number, got %s", json_kind(n));
        double v = n->valuedouble;
        if (k->type == CT_INT && v != floor(v))
            return BAD("expected an integer, got %g", v);
        if (!isfinite(v) || v < k->lo || v > k->hi)
            return BAD("%g out of range [%g, %g]", v, k->lo, k->hi);
        if (k->type == CT_INT)
            *(int *)p = (int)v;
        else
            *(double *)p = v;
        return SPH_OK;
    }
    case CT_STRING: {
        if (!cJSON_IsString(n))
            return BAD("expected string, got %s", json_kind(n));
        size_t len = strlen(n->valuestring);
        if (len < (size_t)k->lo || len > (size_t)k->hi)
            return BAD("length %zu out of range [%g, %g]", len, k->lo, k->hi);
        char *s = dupstr(n->valuestring);
        if (!s)
            return sph_err_set(err, SPH_ERR_NOMEM, "config %s: %s: out of memory", origin, where);
        free(*(char **)p);
        *(char **)p = s;
        return SPH_OK;
    }
    case CT_ENUM: {
        if (cJSON_IsBool(n)) /* only an enum that lists "true" and "false" */
            for (int i = 0; k->names[i]; i++)
                if (!strcmp(k->names[i], cJSON_IsTrue(n) ? "true" : "false")) {
                    *(int *)p = i;
                    return SPH_OK;
                }
        if (!cJSON_IsString(n))
            return BAD("expected string, got %s", json_kind(n));
        for (int i = 0; k->names[i]; i++)
            if (!strcmp(k->names[i], n->valuestring)) {
                *(int *)p = i;
                return SPH_OK;
            }
        char allowed[256] = "";
        size_t used = 0;
        for (int i = 0; k->names[i]; i++)
            used += (size_t)snprintf(allowed + used, used < sizeof allowed ? sizeof allowed - used : 0,
                                     "%s%s", i ? ", " : "", k->names[i]);
        return BAD("\"%s\" is not one of: %s", n->valuestring, allowed);
    }
    case CT_TODLIST: {
        cfg_todlist *l = p;
        if (!cJSON_IsArray(n))
            return BAD("expected array of \"HH:MM\" strings, got %s", json_kind(n));
        int cnt = cJSON_GetArraySize(n);
        if (cnt < k->lo || cnt > k->hi)
            return BAD("%d entries, allowed [%g, %g]", cnt, k->lo, k->hi);
        l->n = 0;
        const cJSON *e;
        cJSON_ArrayForEach(e, n) {
            int s = cJSON_IsString(e) ? parse_tod(e->valuestring) : -1;
            if (s < 0)
                return BAD("entry %zu: expected \"HH:MM\" (00:00 to 23:59)", l->n);
            for (size_t j = 0; j < l->n; j++)
                if (l->sec[j] == s)
                    return BAD("entry %zu: \"%s\" listed twice", l->n, e->valuestring);
            l->sec[l->n++] = s;
        }
        qsort(l->sec, l->n, sizeof l->sec[0], cmp_int);
        return SPH_OK;
    }
    case CT_STRLIST: {
        cfg_strlist fresh = {0};
        int cnt = cJSON_IsString(n) ? 1 : cJSON_IsArray(n) ? cJSON_GetArraySize(n) : -1;
        if (cnt < 0)
            return BAD("expected string or array of strings, got %s", json_kind(n));
        if (cnt < k->lo || cnt > k->hi)
            return BAD("%d entries, allowed [%g, %g]", cnt, k->lo, k->hi);
        fresh.v = calloc((size_t)cnt + 1, sizeof(char *));
        if (!fresh.v)
            return sph_err_set(err, SPH_ERR_NOMEM, "config %s: %s: out of memory", origin, where);
        if (cJSON_IsString(n)) {
            fresh.v[fresh.n++] = dupstr(n->valuestring);
        } else {
            const cJSON *e;
            cJSON_ArrayForEach(e, n) {
                if (!cJSON_IsString(e)) {
                    strlist_free(&fresh);
                    return BAD("entry %d: expected string, got %s", (int)fresh.n, json_kind(e));
                }
                fresh.v[fresh.n++] = dupstr(e->valuestring);
            }
        }
        for (size_t i = 0; i < fresh.n; i++)
            if (!fresh.v[i]) {
                strlist_free(&fresh);
                return sph_err_set(err, SPH_ERR_NOMEM, "config %s: %s: out of memory", origin, where);
            }
        strlist_free(p);
        *(cfg_strlist *)p = fresh;
        return SPH_OK;
    }
    case CT_DBLLIST: {
        if (!cJSON_IsArray(n))
            return BAD("expected array of numbers, got %s", json_kind(n));
        int cnt = cJSON_GetArraySize(n);
        double *v = calloc((size_t)cnt + 1, sizeof(double));
        if (!v)
            return sph_err_set(err, SPH_ERR_NOMEM, "config %s: %s: out of memory", origin, where);
        int i = 0;
        const cJSON *e;
        cJSON_ArrayForEach(e, n) {
            if (!cJSON_IsNumber(e) || !isfinite(e->valuedouble) || e->valuedouble < k->lo ||
                e->valuedouble > k->hi) {
                free(v);
                return BAD("entry %d: expected number in [%g, %g]", i, k->lo, k->hi);
            }
            v[i++] = e->valuedouble;
        }
        cfg_dbllist *l = p;
        free(l->v);
        l->v = v;
        l->n = (size_t)cnt;
        return SPH_OK;
    }
    case CT_STRMAP: {
        if (!cJSON_IsObject(n))
            return BAD("expected object {name: string}, got %s", json_kind(n));
        int cnt = cJSON_GetArraySize(n);
        if (cnt > k->hi)
            return BAD("%d entries, at most %g", cnt, k->hi);
        cfg_strmap fresh = {calloc((size_t)cnt + 1, sizeof(char *)), calloc((size_t)cnt + 1, sizeof(char *)), 0};
        if (!fresh.key || !fresh.val) {
            strmap_free(&fresh);
            return sph_err_set(err, SPH_ERR_NOMEM, "config %s: %s: out of memory", origin, where);
        }
        const cJSON *e;
        cJSON_ArrayForEach(e, n) {
            if (!cJSON_IsString(e)) {
                strmap_free(&fresh);
                return BAD("%s: expected string, got %s", e->string, json_kind(e));
            }
            fresh.key[fresh.n] = dupstr(e->string);
            fresh.val[fresh.n] = dupstr(e->valuestring);
            fresh.n++;
            if (!fresh.key[fresh.n - 1] || !fresh.val[fresh.n - 1]) {
                strmap_free(&fresh);
                return sph_err_set(err, SPH_ERR_NOMEM, "config %s: %s: out of memory", origin, where);
            }
        }
        strmap_free(p);
        *(cfg_strmap *)p = fresh;
        return SPH_OK;
    }
    case CT_OBJARRAY: {
        if (!cJSON_IsArray(n))
            return BAD("expected array of objects, got %s", json_kind(n));
        int cnt = cJSON_GetArraySize(n);
        if (cnt < k->lo || cnt > k->hi)
            return BAD("%d entries, allowed [%g, %g]", cnt, k->lo, k->hi);
        key_free(k, base);
        char *arr = calloc((size_t)cnt + 1, k->sub->elem_size);
        if (!arr)
            return sph_err_set(err, SPH_ERR_NOMEM, "config %s: %s: out of memory", origin, where);
        *(char **)p = arr;
        size_t *count = at(base, k->off_count);
        *count = (size_t)cnt; /* zeroed elements free cleanly if one fails */
        int i = 0;
        const cJSON *e;
        cJSON_ArrayForEach(e, n) {
            char sub[256];
            snprintf(sub, sizeof sub, "%s[%d]", where, i);
            if (!cJSON_IsObject(e))
                return sph_err_set(err, SPH_ERR_CONFIG, "config %s: %s: expected object, got %s",
                                   origin, sub, json_kind(e));
            int rc = table_parse(k->sub, arr + (size_t)i * k->sub->elem_size, e, sub, origin, err);
            if (rc)
                return rc;
            i++;
        }
        return SPH_OK;
    }
    }
#undef BAD
    return sph_err_set(err, SPH_ERR_INTERNAL, "config %s: %s: unknown key type", origin, where);
}

/* The node at a dotted path under obj, or NULL. */
static const cJSON *find_path(const cJSON *obj, const char *path)
{
    char seg[128];
    const char *s = path;
    const cJSON *n = obj;
    while (n && *s) {
        const char *dot = strchr(s, '.');
        size_t len = dot ? (size_t)(dot - s) : strlen(s);
        if (len >= sizeof seg)
            return NULL;
        memcpy(seg, s, len);
        seg[len] = 0;
        if (!cJSON_IsObject(n))
            return NULL;
        n = cJSON_GetObjectItemCaseSensitive(n, seg);
        s = dot ? dot + 1 : s + len;
    }
    return n;
}

static void join(char *out, size_t len, const char *a, const char *b)
{
    if (a && *a)
        snprintf(out, len, "%s.%s", a, b);
    else
        snprintf(out, len, "%s", b);
}

/* Every member of obj (at relative path rel) must be a key or a section. */
static int check_unknown(const cfg_table *t, const cJSON *obj, const char *rel, const char *prefix,
                         const char *origin, sph_error *err)
{
    const cJSON *m;
    cJSON_ArrayForEach(m, obj) {
        char path[256], full[320];
        join(path, sizeof path, rel, m->string);
        join(full, sizeof full, prefix, path);
        int known = 0, section = 0;
        size_t plen = strlen(path);
        for (size_t i = 0; i < t->nkeys; i++) {
            if (!strcmp(t->keys[i].path, path))
                known = 1;
            else if (!strncmp(t->keys[i].path, path, plen) && t->keys[i].path[plen] == '.')
                section = 1;
        }
        if (known)
            continue;
        if (!section)
            return sph_err_set(err, SPH_ERR_CONFIG, "config %s: %s: unknown key", origin, full);
        if (!cJSON_IsObject(m))
            return sph_err_set(err, SPH_ERR_CONFIG, "config %s: %s: expected object, got %s", origin,
                               full, json_kind(m));
        int rc = check_unknown(t, m, path, prefix, origin, err);
        if (rc)
            return rc;
    }
    return SPH_OK;
}

static int table_parse(const cfg_table *t, void *base, const cJSON *obj, const char *prefix,
                       const char *origin, sph_error *err)
{
    int rc = check_unknown(t, obj, "", prefix, origin, err);
    if (rc)
        return rc;
    for (size_t i = 0; i < t->nkeys; i++) {
        const cfg_key *k = &t->keys[i];
        char full[320];
        join(full, sizeof full, prefix, k->path);
        const cJSON *n = find_path(obj, k->path);
        if (n) {
            rc = key_set(k, base, n, full, origin, err);
        } else if (k->def) {
            cJSON *d = cJSON_Parse(k->def);
            if (!d)
                return sph_err_set(err, SPH_ERR_INTERNAL, "config: default of %s does not parse", full);
            rc = key_set(k, base, d, full, "(default)", err);
            cJSON_Delete(d);
        } else {
            rc = sph_err_set(err, SPH_ERR_CONFIG, "config %s: %s: required key missing", origin, full);
        }
        if (rc)
            return rc;
    }
    return SPH_OK;
}

int config_quantity_flag(const char *name)
{
    static const struct { const char *name; int flag; } q[] = {
        {"wind", FQ_WIND}, {"tair", FQ_TAIR}, {"humidity", FQ_HUMIDITY}, {"swdn", FQ_SWDN},
        {"lwdn", FQ_LWDN}, {"current", FQ_CURRENT}, {"ssh", FQ_SSH}, {"sst", FQ_SST},
        {"ocean_flux", FQ_OCEAN_FLUX}, {"snowfall", FQ_SNOWFALL}, {"precipitation", FQ_PRECIP}};
    for (size_t i = 0; i < sizeof q / sizeof q[0]; i++)
        if (!strcmp(q[i].name, name))
            return q[i].flag;
    return -1;
}

int config_log_level(const struct sph_config *c)
{
    static const int lv[] = {LOG_LVL_ERROR, LOG_LVL_WARN, LOG_LVL_INFO, LOG_LVL_DEBUG};
    return lv[c->log_level];
}

/* A template (strftime fields of the cycle time) with a field that
 * cycle_expand_template does not know is a configuration error now, not
 * "forcing missing" after the late-data wait. */
static int check_template(const char *tmpl, const char *origin, const char *key, sph_error *err)
{
    if (!tmpl || !tmpl[0])
        return SPH_OK;
    char out[8192];
    sph_error e;
    sph_error_clear(&e);
    if (cycle_expand_template(tmpl, 0, out, sizeof out, &e))
        return sph_err_set(err, SPH_ERR_CONFIG, "config %s: %s: %s", origin, key, e.msg);
    return SPH_OK;
}

static int check_templates(const struct sph_config *c, const char *origin, sph_error *err)
{
    char key[64];
    int rc;
    for (size_t i = 0; i < c->nforcing; i++)
        for (size_t j = 0; j < c->forcing[i].urls.n; j++) {
            snprintf(key, sizeof key, "forcing[%zu].urls[%zu]", i, j);
            if ((rc = check_template(c->forcing[i].urls.v[j], origin, key, err)))
                return rc;
        }
    if ((rc = check_template(c->initial.path, origin, "initial.path", err)) ||
        (rc = check_template(c->observations.path, origin, "observations.path", err)))
        return rc;
    /* ESRI ASCII: initial.thick_var names a file, a template too */
    if (c->initial.format == CFG_INIT_ESRI &&
        (rc = check_template(c->initial.thick_var, origin, "initial.thick_var", err)))
        return rc;
    return SPH_OK;
}

/* cJSON keeps every member of an object, also a key given twice, and the
 * reader takes the first: a duplicate is refused, naming the key, before
 * anything is read. `where` is the object's path ("" at the top). */
static int check_duplicates(const cJSON *node, const char *where, const char *origin, sph_error *err)
{
    const cJSON *m;
    size_t i = 0;
    cJSON_ArrayForEach(m, node) {
        char path[320];
        if (cJSON_IsObject(node)) {
            join(path, sizeof path, where, m->string ? m->string : "");
            for (const cJSON *q = node->child; q && q != m; q = q->next)
                if (q->string && m->string && !strcmp(q->string, m->string))
                    return sph_err_set(err, SPH_ERR_CONFIG, "config %s: %s: key given twice", origin, path);
        } else {
            snprintf(path, sizeof path, "%s[%zu]", where, i);
        }
        i++;
        if (cJSON_IsObject(m) || cJSON_IsArray(m)) {
            int rc = check_duplicates(m, path, origin, err);
            if (rc)
                return rc;
        }
    }
    return SPH_OK;
}

/* Rules between keys, after every key was read. */
static int cross_check(const struct sph_config *c, const char *origin, sph_error *err)
{
    if (c->domain.lon_min >= c->domain.lon_max)
        return sph_err_set(err, SPH_ERR_CONFIG, "config %s: domain.lon_min: %g must be below domain.lon_max %g",
                           origin, c->domain.lon_min, c->domain.lon_max);
    if (c->domain.lat_min >= c->domain.lat_max)
        return sph_err_set(err, SPH_ERR_CONFIG, "config %s: domain.lat_min: %g must be below domain.lat_max %g",
                           origin, c->domain.lat_min, c->domain.lat_max);
    for (size_t i = 0; i < c->nforcing; i++) {
        const cfg_forcing_source *s = &c->forcing[i];
        for (size_t j = 0; j < i; j++)
            if (!strcmp(c->forcing[j].name, s->name))
                return sph_err_set(err, SPH_ERR_CONFIG, "config %s: forcing[%zu].name: \"%s\" used twice",
                                   origin, i, s->name);
        const cfg_strlist *lists[2] = {&s->required, &s->optional_q};
        for (int l = 0; l < 2; l++)
            for (size_t j = 0; j < lists[l]->n; j++)
                if (config_quantity_flag(lists[l]->v[j]) < 0)
                    return sph_err_set(err, SPH_ERR_CONFIG,
                                       "config %s: forcing[%zu].%s[%zu]: unknown quantity \"%s\" (wind, tair, "
                                       "humidity, swdn, lwdn, current, ssh, sst, ocean_flux, snowfall, precipitation)",
                                       origin, i, l ? "optional" : "required", j, lists[l]->v[j]);
        for (size_t j = 0; j < s->urls.n; j++)
            if (!s->urls.v[j][0])
                return sph_err_set(err, SPH_ERR_CONFIG, "config %s: forcing[%zu].urls[%zu]: empty", origin, i, j);
    }
    for (size_t i = 0; i < c->nstations; i++) {
        const cfg_station *s = &c->stations[i];
        if (s->structure_kind && !(s->lon >= c->domain.lon_min && s->lon <= c->domain.lon_max &&
                                   s->lat >= c->domain.lat_min && s->lat <= c->domain.lat_max))
            return sph_err_set(err, SPH_ERR_CONFIG,
                               "config %s: stations[%zu].structure.kind: station \"%s\" (%g, %g) lies outside "
                               "the domain [%g, %g] x [%g, %g]: no ice load can be forecast there",
                               origin, i, s->name, s->lon, s->lat, c->domain.lon_min, c->domain.lon_max,
                               c->domain.lat_min, c->domain.lat_max);
        if (s->structure_kind == 2) { /* cone: the geometry Ralston's load needs */
            double a = s->structure_cone_angle * M_PI / 180.0;
            const char *key = NULL, *what = NULL;
            if (!(s->structure_cone_angle >= 20 && s->structure_cone_angle <= 70))
                key = "cone_angle", what = "must lie in Ralston's range [20, 70] degrees";
            else if (!(s->structure_waterline_diameter > 0))
                key = "waterline_diameter", what = "must be set (positive) for a cone";
            else if (!(s->structure_neck_diameter > 0 && s->structure_neck_diameter < s->structure_waterline_diameter))
                key = "neck_diameter", what = "must be positive and below the waterline diameter";
            else if (!(s->structure_friction <= fmin(tan(a), 1.0 / tan(a)) - 0.01))
                key = "friction", what = "must be at most min(tan a, cot a) - 0.01 for Ralston's load";
            if (key)
                return sph_err_set(err, SPH_ERR_CONFIG, "config %s: stations[%zu].structure.%s: station \"%s\": %s",
                                   origin, i, key, s->name, what);
        }
        if (s->structure_kind && s->structure_mass > 0 && !(s->structure_stiffness > 0))
            return sph_err_set(err, SPH_ERR_CONFIG,
                               "config %s: stations[%zu].structure.stiffness: station \"%s\": a structure of mass "
                               "%g t on no spring cannot be built for the DEM: give a stiffness, or mass 0 (fixed)",
                               origin, i, s->name, s->structure_mass);
    }
    {
        size_t nst = 0;
        for (size_t i = 0; i < c->nstations; i++)
            if (c->stations[i].structure_kind && ++nst > PROD_MAX_LOAD_STATIONS)
                return sph_err_set(err, SPH_ERR_CONFIG,
                                   "config %s: stations[%zu].structure.kind: station \"%s\" is the %zuth with a "
                                   "structure, at most %d may have one", origin, i, c->stations[i].name, nst,
                                   PROD_MAX_LOAD_STATIONS);
    }
    if (c->schedule.every_hours <= 0 && c->schedule.every_seconds <= 0 && c->schedule.cycles.n == 0)
        return sph_err_set(err, SPH_ERR_CONFIG,
                           "config %s: schedule.cycles: empty and schedule.every_hours is 0: no cycle would run",
                           origin);
    if (c->ensemble.levels.n > ENS_MAX_LEVELS)
        return sph_err_set(err, SPH_ERR_CONFIG, "config %s: ensemble.levels: %zu levels, at most %d", origin,
                           c->ensemble.levels.n, ENS_MAX_LEVELS);
    for (size_t i = 0; i < c->ensemble.levels.n; i++)
        if (!(c->ensemble.levels.v[i] > 0.0 && c->ensemble.levels.v[i] <= 1.0))
            return sph_err_set(err, SPH_ERR_CONFIG,
                               "config %s: ensemble.levels[%zu]: %g is not a probability in (0, 1]", origin, i,
                               c->ensemble.levels.v[i]);
    if (!c->output.products.fields || !c->output.products.edge)
        return sph_err_set(err, SPH_ERR_CONFIG,
                           "config %s: output.products.%s: false is not supported: the fields file is the "
                           "forecast's primary product and carries the ice edge, the area, extent and volume "
                           "series and the scores (set it true; output.products.particles, stations, geojson "
                           "and maps can be turned off)",
                           origin, !c->output.products.fields ? "fields" : "edge");
    int trc = check_templates(c, origin, err);
    if (trc)
        return trc;
    sph_error le;
    sph_error_clear(&le);
    if (http_check_listen(c->status.listen, &le))
        return sph_err_set(err, SPH_ERR_CONFIG, "config %s: status.listen: \"%s\" is not IPV4:PORT, [IPV6]:PORT "
                           "or a numeric address (%s)", origin, c->status.listen, le.msg);
    return SPH_OK;
}

int sph_config_parse(const char *text, const char *origin, struct sph_config **out, sph_error *err)
{
    *out = NULL;
    const char *where = origin ? origin : "<string>";
    cJSON *root = cJSON_ParseWithOpts(text, NULL, 1);
    if (!root) {
        const char *e = cJSON_GetErrorPtr();
        long line = 1;
        for (const char *p = text; e && p < e; p++)
            line += *p == '\n';
        return sph_err_set(err, SPH_ERR_CONFIG, "config %s: line %ld: not valid JSON", where, line);
    }
    if (!cJSON_IsObject(root)) {
        cJSON_Delete(root);
        return sph_err_set(err, SPH_ERR_CONFIG, "config %s: expected a JSON object at the top", where);
    }
    struct sph_config *c = calloc(1, sizeof *c);
    if (!c) {
        cJSON_Delete(root);
        return sph_err_set(err, SPH_ERR_NOMEM, "config %s: out of memory", where);
    }
    c->file = dupstr(where);
    sha256_hex(text, strlen(text), c->sha256);
    /* Model fields without a key (the thermodynamic column's) keep the
     * core's defaults; the keyed ones are then set from the table, whose
     * defaults are the core's (model.dt's override aside). */
    sph_params_default(&c->model);
    const cfg_table *t = config_table();
    int rc = c->file && t->keys ? check_duplicates(root, "", where, err)
                                : sph_err_set(err, SPH_ERR_NOMEM, "config: out of memory");
    if (!rc)
        rc = table_parse(t, c, root, "", where, err);
    cJSON_Delete(root);
    if (!rc)
        rc = cross_check(c, where, err);
    if (rc) {
        sph_config_free(c);
        return rc;
    }
    *out = c;
    return SPH_OK;
}

int sph_config_load(const char *path, struct sph_config **out, sph_error *err)
{
    char *text = NULL;
    size_t len = 0;
    *out = NULL;
    sph_error rerr;
    sph_error_clear(&rerr);
    if (read_file(path, &text, &len, &rerr))
        return sph_err_set(err, SPH_ERR_CONFIG, "config %s: cannot read: %s", path, rerr.msg);
    if (strlen(text) != len) {
        free(text);
        return sph_err_set(err, SPH_ERR_CONFIG, "config %s: contains a NUL byte", path);
    }
    int rc = sph_config_parse(text, path, out, err);
    free(text);
    return rc;
}

/* ------------------------------------------------------------- reporting */

static cJSON *key_to_json(const cfg_key *k, const void *base);

static cJSON *table_to_json(const cfg_table *t, const void *base)
{
    cJSON *root = cJSON_CreateObject();
    for (size_t i = 0; i < t->nkeys; i++) {
        const cfg_key *k = &t->keys[i];
        /* walk/create the sections of the dotted path */
        cJSON *obj = root;
        const char *s = k->path;
        const char *dot;
        while ((dot = strchr(s, '.'))) {
            char seg[128];
            size_t len = (size_t)(dot - s) < sizeof seg - 1 ? (size_t)(dot - s) : sizeof seg - 1;
            memcpy(seg, s, len);
            seg[len] = 0;
            cJSON *next = cJSON_GetObjectItemCaseSensitive(obj, seg);
            if (!next)
                next = cJSON_AddObjectToObject(obj, seg);
            obj = next;
            s = dot + 1;
        }
        cJSON_AddItemToObject(obj, s, key_to_json(k, base));
    }
    return root;
}

static cJSON *key_to_json(const cfg_key *k, const void *base)
{
    const void *p = cat_(base, k->off);
    switch (k->type) {
    case CT_BOOL: return cJSON_CreateBool(*(const int *)p);
    case CT_INT: return cJSON_CreateNumber(*(const int *)p);
    case CT_DOUBLE: return cJSON_CreateNumber(*(const double *)p);
    case CT_STRING: return cJSON_CreateString(*(char *const *)p ? *(char *const *)p : "");
    case CT_ENUM: {
        const char *v = k->names[*(const int *)p];
        if (!strcmp(v, "true") || !strcmp(v, "false")) /* the boolean values of a bool-or-auto key */
            return cJSON_CreateBool(v[0] == 't');
        return cJSON_CreateString(v);
    }
    case CT_TODLIST: {
        const cfg_todlist *l = p;
        cJSON *a = cJSON_CreateArray();
        for (size_t i = 0; i < l->n; i++) {
            char s[16];
            snprintf(s, sizeof s, "%02d:%02d", l->sec[i] / 3600, l->sec[i] / 60 % 60);
            cJSON_AddItemToArray(a, cJSON_CreateString(s));
        }
        return a;
    }
    case CT_STRLIST: {
        const cfg_strlist *l = p;
        cJSON *a = cJSON_CreateArray();
        for (size_t i = 0; i < l->n; i++)
            cJSON_AddItemToArray(a, cJSON_CreateString(l->v[i]));
        return a;
    }
    case CT_DBLLIST: {
        const cfg_dbllist *l = p;
        cJSON *a = cJSON_CreateArray();
        for (size_t i = 0; i < l->n; i++)
            cJSON_AddItemToArray(a, cJSON_CreateNumber(l->v[i]));
        return a;
    }
    case CT_STRMAP: {
        const cfg_strmap *m = p;
        cJSON *o = cJSON_CreateObject();
        for (size_t i = 0; i < m->n; i++)
            cJSON_AddStringToObject(o, m->key[i], m->val[i]);
        return o;
    }
    case CT_OBJARRAY: {
        const char *arr = *(char *const *)p;
        size_t count = *(const size_t *)cat_(base, k->off_count);
        cJSON *a = cJSON_CreateArray();
        for (size_t i = 0; arr && i < count; i++)
            cJSON_AddItemToArray(a, table_to_json(k->sub, arr + i * k->sub->elem_size));
        return a;
    }
    }
    return cJSON_CreateNull();
}

char *sph_config_to_json(const struct sph_config *c)
{
    cJSON *j = table_to_json(config_table(), c);
    char *s = cJSON_Print(j);
    cJSON_Delete(j);
    return s;
}

int sph_config_keep_unreloadable(struct sph_config *fresh, const struct sph_config *old, char *changed,
                                 size_t len)
{
    int n = 0;
    size_t used = 0;
    if (len)
        changed[0] = 0;
    const cfg_table *t = config_table();
    for (size_t i = 0; i < t->nkeys; i++) {
        const cfg_key *k = &t->keys[i];
        if (k->flags & CF_RELOAD)
            continue;
        cJSON *a = key_to_json(k, fresh), *b = key_to_json(k, old);
        int same = cJSON_Compare(a, b, 1);
        cJSON_Delete(b);
        if (!same) {
            /* put the running value back (the table marks only scalars and strings unreloadable) */
            key_free(k, fresh);
            sph_error e;
            sph_error_clear(&e);
            cJSON *oldv = key_to_json(k, old);
            if (k->type != CT_STRING || oldv)
                (void)key_set(k, fresh, oldv, k->path, "(running)", &e);
            cJSON_Delete(oldv);
            if (used < len)
                used += (size_t)snprintf(changed + used, len - used, "%s%s", n ? ", " : "", k->path);
            n++;
        }
        cJSON_Delete(a);
    }
    return n;
}

/* ------------------------------------------------------------ reference */

static const char *type_name(const cfg_key *k)
{
    switch (k->type) {
    case CT_BOOL: return "bool";
    case CT_INT: return "int";
    case CT_DOUBLE: return "number";
    case CT_STRING: return "string";
    case CT_ENUM: return "enum";
    case CT_TODLIST: return "list of \"HH:MM\"";
    case CT_STRLIST: return "string or list of strings";
    case CT_DBLLIST: return "list of numbers";
    case CT_STRMAP: return "object {string: string}";
    case CT_OBJARRAY: return "array of objects";
    }
    return "?";
}

static void doc_rows(FILE *f, const cfg_table *t, const char *prefix)
{
    for (size_t i = 0; i < t->nkeys; i++) {
        const cfg_key *k = &t->keys[i];
        char full[320], range[160] = "";
        join(full, sizeof full, prefix, k->path);
        if (k->type == CT_INT || k->type == CT_DOUBLE || k->type == CT_DBLLIST)
            snprintf(range, sizeof range, "%g to %g", k->lo, k->hi);
        else if (k->type == CT_ENUM) {
            size_t used = 0;
            for (int j = 0; k->names[j] && used < sizeof range; j++)
                used += (size_t)snprintf(range + used, sizeof range - used, "%s%s", j ? ", " : "", k->names[j]);
        } else if (k->type == CT_OBJARRAY || k->type == CT_STRLIST || k->type == CT_TODLIST)
            snprintf(range, sizeof range, "%g to %g entries", k->lo, k->hi);
        else if (k->type == CT_STRING)
            snprintf(range, sizeof range, "length %g to %g", k->lo, k->hi);
        fprintf(f, "| `%s` | %s | %s%s%s | %s | %s | %s%s |\n", full, type_name(k), k->def ? "`" : "",
                k->def ? k->def : "**required**", k->def ? "`" : "", range, (k->flags & CF_RELOAD) ? "yes" : "restart",
                (k->flags & CF_TEST) ? "*For tests only.* " : "", k->doc);
        if (k->type == CT_OBJARRAY) {
            char sub[330];
            snprintf(sub, sizeof sub, "%s[]", full);
            doc_rows(f, k->sub, sub);
        }
    }
}

void sph_config_doc(FILE *f)
{
    fprintf(f, "# sphice configuration reference\n\n"
               "Generated by `sphice config-doc` from the key table in `src/service/config.c`; the\n"
               "`model.*` keys come from the core's parameter table in `src/core/params.c`.\n"
               "The file is one JSON object; nested keys are written as objects (`model.rheology.P0` is\n"
               "`{\"model\": {\"rheology\": {\"P0\": 1e4}}}`). Unknown keys and wrong types are errors naming\n"
               "the key; every key has a default or is marked required. \"reload\" says whether SIGHUP\n"
               "applies a change (`restart`: the running value is kept until the service restarts).\n\n"
               "| key | type | default | allowed | reload | description |\n"
               "|---|---|---|---|---|---|\n");
    doc_rows(f, config_table(), "");
}
