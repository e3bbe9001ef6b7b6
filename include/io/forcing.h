/* Forcing from CF NetCDF files, sampled at particle positions and times.
 *
 * A source is one kind of forcing (atmosphere, ocean, tide) spread over
 * one or more local files. Variables are found by CF standard_name, or by
 * the source's name mapping. Values come back in sphice's units:
 *   wind, current: m/s (east, north components)
 *   air temperature, dew point, SST: deg C
 *   specific humidity: kg/kg
 *   shortwave, longwave, heat fluxes: W/m^2 (accumulated J/m^2 converted
 *   using the accumulation period)
 *   sea-surface height: m, and its gradient d/d(east), d/d(north) in m/m
 * Missing/land values are never used as data: a point whose bilinear
 * stencil is all missing gets the nearest valid value in the grid if one
 * lies within one cell, else is an error naming the point.
 */
#ifndef SPHICE_IO_FORCING_H
#define SPHICE_IO_FORCING_H

#include <stddef.h>
#include "util/err.h"
#include "util/limits.h"

typedef enum {
    FORCING_ATMOSPHERE = 0, /* wind, air temperature, humidity, radiation */
    FORCING_OCEAN,          /* currents, SSH, SST, ocean heat flux */
    FORCING_TIDE            /* harmonic constituents on a grid, or a time series (as OCEAN) */
} forcing_kind;

/* The quantities a sample can return (bit flags for "needed"). */
typedef enum {
    FQ_WIND = 1 << 0,      /* eastward_wind, northward_wind */
    FQ_TAIR = 1 << 1,      /* air_temperature */
    FQ_HUMIDITY = 1 << 2,  /* specific_humidity, dew_point_temperature or relative_humidity */
    FQ_SWDN = 1 << 3,      /* surface_downwelling_shortwave_flux_in_air */
    FQ_LWDN = 1 << 4,      /* surface_downwelling_longwave_flux_in_air */
    FQ_CURRENT = 1 << 5,   /* eastward/northward_sea_water_velocity */
    FQ_SSH = 1 << 6,       /* sea_surface_height(_above_geoid) and gradient */
    FQ_SST = 1 << 7,       /* sea_surface_temperature */
    FQ_OCEAN_FLUX = 1 << 8, /* upward_sea_ice_basal_heat_flux: upward at the ice base is
                              from the ocean into the ice, so the sign is kept */
    FQ_SNOWFALL = 1 << 9,  /* snowfall_flux, snowfall_amount, lwe_thickness_of_snowfall_amount */
    FQ_PRECIP = 1 << 10,   /* precipitation_flux, precipitation_amount,
                              lwe_thickness_of_precipitation_amount (split by air temperature) */
    /* read only when asked for (the mixed layer's forecast asks an ocean source) */
    FQ_MLD = 1 << 11,      /* ocean_mixed_layer_thickness(_defined_by_*) */
    FQ_BATHY = 1 << 12     /* sea_floor_depth_below_sea_surface (or _geoid, _mean_sea_level) */
} forcing_quantity;

/* How accumulated fields (an amount, J m-2 or kg m-2) are read:
 * INTERVAL: each value is the amount over the interval ending at its time
 * (ERA5 hourly reanalysis, the default); RUNNING: the amount since a start
 * that may reset (GFS, forecasts): consecutive values are differenced, and
 * a time whose grid total is below the previous one's starts a new
 * accumulation (its value is the amount since the previous time). */
enum { FORCING_ACCUMULATION_INTERVAL = 0, FORCING_ACCUMULATION_RUNNING };

enum { FORCING_VECTORS_AUTO = 0, FORCING_VECTORS_EARTH, FORCING_VECTORS_GRID };

typedef struct forcing_name_map {
    const char *standard_name; /* e.g. "eastward_wind" */
    const char *variable;      /* name in the file, e.g. "u10" */
} forcing_name_map;

typedef struct forcing_source_spec {
    const char *name;          /* for messages: "era5", "tides" */
    forcing_kind kind;
    const char *const *files;  /* local paths, any order (sorted by time when opened) */
    size_t nfiles;
    const forcing_name_map *map; /* optional renames */
    size_t nmap;
    unsigned required;         /* forcing_quantity flags that must be found */
    unsigned optional;         /* flags used when present (required == optional == 0:
                                  everything the kind can provide, as optional) */
    /* Orientation of the vector pairs (wind, current): FORCING_VECTORS_*.
     * AUTO: from the standard_name (eastward_wind ... earth; x_wind,
     * sea_water_x_velocity, x_sea_water_velocity ... grid), else from the
     * file's conventions (a ROMS `angle` variable, u and v on staggered
     * C-grid points), else earth on a regular longitude/latitude grid;
     * a pair found by name on any other grid is refused. EARTH / GRID:
     * every pair of the source, found by standard_name or by name (a
     * standard_name that says the opposite is refused). Grid-relative
     * pairs are rotated to east/north by the file's angle variable, else
     * by the angle of the grid's x axis from its 2-D latitude/longitude. */
    int vectors;
    /* Added: 1 = harmonic tides without nodal corrections (f = 1, u = 0). */
    int tide_no_nodal;
    int accumulation;          /* FORCING_ACCUMULATION_* */
    /* Read window (hyperslab): 1 = read only the part of each grid that covers the
     * domain box given to forcing_open plus margin_km (and the nodes bilinear
     * interpolation needs); 0 = whole grids. A point outside the window is outside
     * the grid (SPH_ERR_COVERAGE), like a point outside the file. Harmonic tide files
     * are read whole. */
    int window;
    double margin_km;
} forcing_source_spec;

/* Values at n points; arrays the caller owns, each of length n. A pointer
 * left NULL is not filled. Quantities not provided by any source are left
 * untouched, so the caller can pre-fill defaults. */
typedef struct forcing_sample {
    double *u_east, *v_north;       /* wind */
    double *tair;                   /* deg C */
    double *qair;                   /* kg/kg (from dew point or relative humidity if needed) */
    double *swdn, *lwdn;            /* W/m^2 */
    double *uw_east, *vw_north;     /* current (sum of ocean and tide sources) */
    double *ssh;                    /* m (sum of sources) */
    double *ssh_dx_east, *ssh_dy_north; /* m/m */
    double *sst;                    /* deg C */
    double *fw;                     /* W/m^2 into the ice */
    double *snowfall;               /* kg m-2 s-1 water equivalent */
    double *precip;                 /* kg m-2 s-1, rain and snow together */
    double *mld;                    /* m, ocean mixed-layer thickness */
    double *bathy;                  /* m, sea-floor depth (land: <= 0) */
    unsigned provided;              /* forcing_quantity flags actually filled */
} forcing_sample;

typedef struct forcing forcing; /* opaque: open sources and the slice cache */

/* Opens every source, checks variables, units, and that time covers
 * [t_start, t_end] (seconds since 1970 UTC) and space covers the box
 * [lon_min, lon_max] x [lat_min, lat_max]. One clear message in err naming
 * source, file and problem on failure. */
int forcing_open(forcing **out, const forcing_source_spec *specs, size_t nspecs,
                 double t_start, double t_end, double lon_min, double lon_max, double lat_min,
                 double lat_max, sph_error *err);
void forcing_close(forcing *f);

/* Samples every source at time t and n points (degrees). Bilinear in
 * space, linear in time; time slices are cached so a step reads nothing
 * from disk it read before. Thread-safe for distinct forcing objects. */
int forcing_sample_at(forcing *f, double t, size_t n, const double *lon, const double *lat,
                      forcing_sample *out, sph_error *err);

/* The points of the following forcing_sample_at calls are points base ..
 * base + n - 1 of a larger set (a caller that samples its points in chunks,
 * service/coupling.c): the per-point work arrays then hold one chunk, and
 * only each point's last grid cell (the search's starting guess) is kept
 * for the whole set, at index base + p. 0 (the default): the points are
 * the set. The samples do not depend on it. */
void forcing_set_point_base(forcing *f, size_t base);

/* Description of what was found, for `sphice check` (JSON or table). */
typedef struct forcing_var_info {
    char source[SPHICE_MAX_NAME + 1], standard_name[96], variable[64], file[512], units[64];
    char grid[96];            /* "regular 0.25x0.25 deg 121x81", "curvilinear 50x40" */
    double t_first, t_last;   /* seconds since 1970 */
    double fill_fraction;     /* fraction of missing values in the first slice */
    /* Vector components: "earth-relative (...why...)" or "grid-relative
     * (...why...), rotated by ..."; "" for scalars. */
    char orientation[192];
} forcing_var_info;
size_t forcing_describe(const forcing *f, forcing_var_info *info, size_t max);

/* Added. Number of time slices read from disk since forcing_open (debug
 * counter: tests assert that stepping inside one forcing interval reads
 * nothing new). */
size_t forcing_debug_slice_reads(const forcing *f);

/* Added. Bytes of the arrays the reader holds (grids, node coordinates and angles,
 * point stencils, time axes, cached slices and tide constants): with a read window
 * they follow the window, not the file. */
size_t forcing_debug_bytes(const forcing *f);

/* Added. Built-in variable names of known products (ERA5, CMEMS, HYCOM)
 * tried after the standard_name when the spec's map has no entry for the
 * quantity; *n receives the number of entries. */
const forcing_name_map *forcing_default_names(size_t *n);

/* The quantity (FQ_* flag) a CF standard name gives the reader, earth- or
 * grid-relative; 0 for a name it does not use. */
int forcing_quantity_of(const char *standard_name);

#endif
