/* The small synthetic forecast case shared by the engine tests
 * (test_engine, test_restart, test_daemon_engine): written with the netCDF
 * API into a directory.
 *
 *   domain      121.0-122.0 E, 40.0-40.6 N (about 85 x 67 km)
 *   ice         ice.nc: 0.02 deg raster over 121.2-121.8 E, 40.1-40.5 N,
 *               concentration EC_CONC, thickness EC_THICK (standard names)
 *   land        mask.nc: 0.01 deg, land east of EC_LAND_LON
 *   atmosphere  atm.nc: 0.25 deg, hourly from cycle - 3 h to cycle + 9 h,
 *               constant wind (EC_WIND_U, EC_WIND_V) m/s and EC_TAIR_K
 *   cycle       1999-02-08T06:00Z (EC_CYCLE), cycles every 6 h
 */
#ifndef SPHICE_TESTS_ENGINE_CASE_H
#define SPHICE_TESTS_ENGINE_CASE_H

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "test_forcing_nc.h"
#include "util/log.h"

#define EC_CYCLE 918453600.0 /* 1999-02-08T06:00:00Z */
#define EC_CONC 0.5
#define EC_THICK 0.2
#define EC_WIND_U 0.0
#define EC_WIND_V 10.0
#define EC_TAIR_K 263.15
#define EC_LAND_LON 121.9

static double ec_atm_fn(int which, double lon, double lat, size_t k)
{
    (void)lon; (void)lat; (void)k;
    return which == 0 ? EC_WIND_U : which == 1 ? EC_WIND_V : EC_TAIR_K;
}

/* An hourly atmosphere of nt slices from tv0 (time_units) on nx x ny
 * nodes every 0.25 deg from (lon0, lat0): u10, v10, t2m from fn, in the
 * NetCDF format fmt. */
static inline void ec_write_atm_grid(const char *path, const char *time_units, double tv0, size_t nt,
                                     int fmt, double lon0, double lat0, size_t nx, size_t ny,
                                     double (*fn)(int, double, double, size_t))
{
    tgrid g;
    memset(&g, 0, sizeof g);
    g.nx = nx;
    g.ny = ny;
    g.lon0 = lon0;
    g.dlon = 0.25;
    g.lat0 = lat0;
    g.dlat = 0.25;
    g.time_units = time_units;
    g.calendar = "standard";
    g.tv0 = tv0;
    g.dtv = 1.0;
    tvar v[3];
    memset(v, 0, sizeof v);
    v[0] = (tvar){"u10", "eastward_wind", "m s-1", NC_FLOAT, 0, 0, 0, 0, 0, fn, 0};
    v[1] = (tvar){"v10", "northward_wind", "m s-1", NC_FLOAT, 0, 0, 0, 0, 0, fn, 1};
    v[2] = (tvar){"t2m", "air_temperature", "K", NC_FLOAT, 0, 0, 0, 0, 0, fn, 2};
    tnc_write(path, &g, v, 3, 0, nt, fmt);
}

/* From cycle - 3 h to cycle + hours on another grid and field. */
static inline void ec_write_atm_at(const char *path, double hours, double lon0, double lat0,
                                   size_t nx, size_t ny,
                                   double (*fn)(int, double, double, size_t))
{
    ec_write_atm_grid(path, "hours since 1999-02-08 00:00:00", 3.0 /* cycle 06 - 3 h */,
                      (size_t)(hours + 3) + 1, NC_NETCDF4, lon0, lat0, nx, ny, fn);
}

/* The case's atmosphere with another time axis or file format: nt hourly
 * slices from tv0 in time_units (the fuzz seeds and the soak's wall-clock
 * axis, tests/fuzz/gen_corpus.c and tools/soak_case.c). */
static inline void ec_write_atm_axis(const char *path, const char *time_units, double tv0, size_t nt,
                                     int fmt)
{
    ec_write_atm_grid(path, time_units, tv0, nt, fmt, 120.5, 39.5, 9, 7, ec_atm_fn);
}

/* hours: forcing from cycle - 3 h to cycle + hours (hourly). */
static inline void ec_write_atm(const char *path, double hours)
{
    ec_write_atm_at(path, hours, 120.5, 39.5, 9, 7, ec_atm_fn);
}

/* format of ec_write_ocean's file (the fuzz seeds also write it classic) */
static int ec_ocean_format = NC_NETCDF4;
#define EC_CURRENT_E 0.1   /* ocean.nc: eastward current, m/s */
#define EC_OCEAN_LAND 121.7 /* ocean.nc: no water from this longitude east */

static double ec_ocean_fn(int which, double lon, double lat, size_t k)
{
    (void)lat; (void)k;
    if (lon >= EC_OCEAN_LAND - 1e-9)
        return NAN;
    return which == 0 ? EC_CURRENT_E : 0.0;
}

/* An ocean source at 0.05 deg, hourly, eastward current EC_CURRENT_E, its
 * land (fill) from EC_OCEAN_LAND east: a coast it resolves worse than the
 * land mask, so particles there have no ocean data within a cell. */
static inline void ec_ocean_grid(tgrid *gp)
{
    tgrid g;
    memset(&g, 0, sizeof g);
    g.nx = 41;
    g.ny = 25;
    g.lon0 = 120.9;
    g.dlon = 0.05;
    g.lat0 = 39.9;
    g.dlat = 0.05;
    g.time_units = "hours since 1999-02-08 00:00:00";
    g.calendar = "standard";
    g.tv0 = 3.0;
    g.dtv = 1.0;
    *gp = g;
}

/* The ocean file of ec_write_ocean with the values of fn (NAN: missing). */
static inline void ec_write_ocean_with(const char *path, double (*fn)(int, double, double, size_t))
{
    tgrid g;
    ec_ocean_grid(&g);
    tvar v[2];
    memset(v, 0, sizeof v);
    v[0] = (tvar){"uo", "eastward_sea_water_velocity", "m s-1", NC_FLOAT, 0, 0, 1, -999.0, 0, fn, 0};
    v[1] = (tvar){"vo", "northward_sea_water_velocity", "m s-1", NC_FLOAT, 0, 0, 1, -999.0, 0, fn, 1};
    tnc_write(path, &g, v, 2, 0, 13, ec_ocean_format);
}

static inline void ec_write_ocean(const char *path)
{
    ec_write_ocean_with(path, ec_ocean_fn);
}

/* Ice raster of nlon x nlat nodes from (lon0, lat0) every (dlon, dlat),
 * concentration conc, thickness thick (standard names); nan_cell >= 0
 * puts an undeclared NaN there. */
static inline void ec_write_ice_at(const char *path, int nlon, int nlat, double lon0, double lat0,
                                   double dlon_, double dlat_, double conc, double thick,
                                   int nan_cell)
{
    int nc, dlon, dlat, vlon, vlat, vc, vt;
    NCW(nc_create(path, NC_CLOBBER | NC_NETCDF4, &nc));
    NCW(nc_def_dim(nc, "lat", (size_t)nlat, &dlat));
    NCW(nc_def_dim(nc, "lon", (size_t)nlon, &dlon));
    NCW(nc_def_var(nc, "lat", NC_DOUBLE, 1, &dlat, &vlat));
    NCW(nc_def_var(nc, "lon", NC_DOUBLE, 1, &dlon, &vlon));
    NCW(nc_put_att_text(nc, vlat, "units", 13, "degrees_north"));
    NCW(nc_put_att_text(nc, vlon, "units", 12, "degrees_east"));
    int d2[2] = {dlat, dlon};
    NCW(nc_def_var(nc, "siconc", NC_DOUBLE, 2, d2, &vc));
    NCW(nc_put_att_text(nc, vc, "standard_name", 21, "sea_ice_area_fraction"));
    NCW(nc_put_att_text(nc, vc, "units", 1, "1"));
    NCW(nc_def_var(nc, "sithick", NC_DOUBLE, 2, d2, &vt));
    NCW(nc_put_att_text(nc, vt, "standard_name", 17, "sea_ice_thickness"));
    NCW(nc_put_att_text(nc, vt, "units", 1, "m"));
    NCW(nc_enddef(nc));
    double *lon = malloc(sizeof *lon * (size_t)nlon), *lat = malloc(sizeof *lat * (size_t)nlat);
    double *c = malloc(sizeof *c * (size_t)(nlat * nlon)), *t = malloc(sizeof *t * (size_t)(nlat * nlon));
    if (!lon || !lat || !c || !t)
        exit(2);
    for (int i = 0; i < nlon; i++)
        lon[i] = lon0 + dlon_ * i;
    for (int j = 0; j < nlat; j++)
        lat[j] = lat0 + dlat_ * j;
    for (int k = 0; k < nlat * nlon; k++) {
        c[k] = conc;
        t[k] = thick;
    }
    if (nan_cell >= 0)
        c[nan_cell] = NAN;
    NCW(nc_put_var_double(nc, vlon, lon));
    NCW(nc_put_var_double(nc, vlat, lat));
    NCW(nc_put_var_double(nc, vc, c));
    NCW(nc_put_var_double(nc, vt, t));
    NCW(nc_close(nc));
    free(lon);
    free(lat);
    free(c);
    free(t);
}

/* Ice raster; nan_cell >= 0 puts an undeclared NaN there. */
static inline void ec_write_ice(const char *path, int nan_cell)
{
    ec_write_ice_at(path, 31, 21, 121.2, 40.1, 0.02, 0.02, EC_CONC, EC_THICK, nan_cell);
}

static inline void ec_write_mask(const char *path)
{
    enum { NLON = 131, NLAT = 81 }; /* 120.85-122.15 E, 39.9-40.7 N */
    int nc, dlon, dlat, vlon, vlat, vm;
    NCW(nc_create(path, NC_CLOBBER | NC_NETCDF4, &nc));
    NCW(nc_def_dim(nc, "lat", NLAT, &dlat));
    NCW(nc_def_dim(nc, "lon", NLON, &dlon));
    NCW(nc_def_var(nc, "lat", NC_DOUBLE, 1, &dlat, &vlat));
    NCW(nc_def_var(nc, "lon", NC_DOUBLE, 1, &dlon, &vlon));
    NCW(nc_put_att_text(nc, vlat, "units", 13, "degrees_north"));
    NCW(nc_put_att_text(nc, vlon, "units", 12, "degrees_east"));
    int d2[2] = {dlat, dlon};
    NCW(nc_def_var(nc, "land_binary_mask", NC_BYTE, 2, d2, &vm));
    NCW(nc_put_att_text(nc, vm, "standard_name", 16, "land_binary_mask"));
    NCW(nc_enddef(nc));
    static double lon[NLON], lat[NLAT];
    static signed char m[NLAT * NLON];
    for (int i = 0; i < NLON; i++)
        lon[i] = 120.85 + 0.01 * i;
    for (int j = 0; j < NLAT; j++)
        lat[j] = 39.9 + 0.01 * j;
    for (int j = 0; j < NLAT; j++)
        for (int i = 0; i < NLON; i++)
            m[j * NLON + i] = lon[i] > EC_LAND_LON;
    NCW(nc_put_var_double(nc, vlon, lon));
    NCW(nc_put_var_double(nc, vlat, lat));
    NCW(nc_put_var_schar(nc, vm, m));
    NCW(nc_close(nc));
}

/* The configuration text for the case in dir (extra: more top-level JSON
 * members, e.g. "\"log_level\": \"warn\",", or ""). */
/* ec_config with more members in "model" (model_more, e.g.
 * ", \"ocean\": {...}") and more sources after the atmosphere
 * (forcing_more, e.g. ", {\"name\": \"ocean\", ...}"). */
static inline void ec_config_more(char *buf, size_t len, const char *dir, double dt, const char *required,
                                  const char *ice, const char *extra, const char *model_more,
                                  const char *forcing_more)
{
    snprintf(buf, len,
             "{ %s\n"
             "  \"domain\": {\"name\": \"testbox\", \"lon_min\": 121.0, \"lon_max\": 122.0,"
             " \"lat_min\": 40.0, \"lat_max\": 40.6},\n"
             "  \"model\": {\"dt\": %g, \"thermo\": {\"dt\": 600}%s},\n"
             "  \"forcing\": [{\"name\": \"atmosphere\", \"kind\": \"atmosphere\","
             " \"urls\": \"%s/atm.nc\", \"required\": %s}%s],\n"
             "  \"initial\": {\"path\": \"%s/%s\", \"spacing\": 0.02, \"threshold\": 0.15},\n"
             "  \"landmask\": {\"source\": \"netcdf\", \"path\": \"%s/mask.nc\"},\n"
             "  \"output\": {\"dir\": \"%s/out\", \"interval_hours\": 1,"
             " \"grid\": {\"lon0\": 121.0, \"lat0\": 40.0, \"dlon\": 0.01, \"dlat\": 0.01,"
             " \"nlon\": 101, \"nlat\": 61},"
             " \"edge_reference\": {\"lon\": 121.5, \"lat\": 40.6, \"name\": \"north\"}},\n"
             "  \"stations\": [{\"name\": \"centre\", \"lon\": 121.5, \"lat\": 40.3}],\n"
             "  \"schedule\": {\"every_hours\": 6, \"forecast_hours\": 6,"
             " \"late_data\": {\"wait_minutes\": 0}},\n"
             "  \"status\": {\"enabled\": false},\n"
             "  \"paths\": {\"state_dir\": \"%s/state\", \"cache_dir\": \"%s/cache\"}\n"
             "}\n",
             extra, dt, model_more, dir, required, forcing_more, dir, ice, dir, dir, dir, dir);
}

static inline void ec_config(char *buf, size_t len, const char *dir, double dt, const char *required,
                             const char *ice, const char *extra)
{
    ec_config_more(buf, len, dir, dt, required, ice, extra, "", "");
}

/* Replaces the first `from` in the configuration text (len bytes) by
 * `to`; 0 when `from` is not there. */
static inline int ec_config_replace(char *text, size_t len, const char *from, const char *to)
{
    char *at = strstr(text, from), *out = at ? malloc(len) : NULL;
    if (!out)
        return 0;
    snprintf(out, len, "%.*s%s%s", (int)(at - text), text, to, at + strlen(from));
    memcpy(text, out, len);
    free(out);
    return 1;
}

/* Writes every input file of the case into dir. */
static inline void ec_write_inputs(const char *dir)
{
    char p[1024];
    snprintf(p, sizeof p, "%s/atm.nc", dir);
    ec_write_atm(p, 9.0);
    snprintf(p, sizeof p, "%s/ice.nc", dir);
    ec_write_ice(p, -1);
    snprintf(p, sizeof p, "%s/ice_nan.nc", dir);
    ec_write_ice(p, 200);
    snprintf(p, sizeof p, "%s/mask.nc", dir);
    ec_write_mask(p);
    snprintf(p, sizeof p, "%s/ocean.nc", dir);
    ec_write_ocean(p);
}

/* libgomp's default busy-wait at every barrier turns into seconds per
 * step when the machine runs more threads than it has cores (a loaded CI
 * box): the engine's small cases then take minutes instead of a second.
 * libgomp reads OMP_WAIT_POLICY when it loads, so set it and re-execute
 * once, unless the caller chose a policy or a thread count (valgrind runs
 * set OMP_NUM_THREADS=1 and must not leave valgrind through exec). */
static inline void ec_passive_openmp(char **argv)
{
    if (getenv("OMP_WAIT_POLICY") || getenv("OMP_NUM_THREADS"))
        return;
    setenv("OMP_WAIT_POLICY", "passive", 1);
    execv("/proc/self/exe", argv);
    /* exec failed: carry on with the default policy */
}

/* The plain build's sphice and the MPI build's beside it (make mpi-build). */
static inline void ec_sphice_bins(char *ser, char *mpi, size_t len)
{
    const char *build = getenv("BUILD") ? getenv("BUILD") : "build";
    snprintf(ser, len, "%s/sphice", build);
    snprintf(mpi, len, "%s/../build-mpi/sphice", build);
}

/* A test's start: passive OpenMP, warnings only, its directory dir (a
 * mkdtemp template) made and the case's inputs written there. */
static inline int ec_start(char **argv, char *dir)
{
    ec_passive_openmp(argv);
    sph_log_level = LOG_LVL_WARN;
    if (!mkdtemp(dir))
        return -1;
    ec_write_inputs(dir);
    return 0;
}

/* Number of entries (other than . and ..) in a directory; -1 if absent. */
static inline int ec_count_entries(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return -1;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)))
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, ".."))
            n++;
    closedir(d);
    return n;
}

#endif
