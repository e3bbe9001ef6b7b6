/* gen_season: writes the synthetic Liaodong Bay freeze-up scene (docs/season.md).
 *
 * Usage: gen_season OUTDIR LANDMASK_NC [DAYS]
 *
 * A scene of DAYS (default 30) days from 2000-12-01 00:00 UTC, in the
 * seed's bay (the domain of etc/liaodong-demo.json), starting from open
 * water:
 *
 *   atmos_season.nc   3-hourly atmosphere on a 0.25 deg grid: winter
 *                     monsoon from the north with cold-air outbreaks
 *   ocean_season.nc   SST (sea_surface_temperature, 1 C: a little above
 *                     the freezing point of 30 psu water) and the
 *                     bathymetry (sea_floor_depth_below_sea_surface) at
 *                     0.05 deg: 2 m at the shore, deepening offshore to
 *                     about 30 m with the distance to the coast of LANDMASK_NC
 *   ice_season_t0.nc  the initial ice raster: no ice anywhere
 *
 * The climatology the atmosphere follows is in docs/season.md (with its
 * sources). Nothing is random: two runs write the same numbers. Times are
 * "hours since 2000-12-01 00:00:00"; the forcing covers 3 h before the
 * start to 3 h after DAYS days.
 */
#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "util/err.h"
#include "util/fileio.h"
#include "util/log.h"

#define DEG2RAD (M_PI / 180.0)
#define EARTH_RADIUS_KM 6371.0
#define TIME_UNITS "hours since 2000-12-01 00:00:00"

/* atmosphere: 0.25 deg, 120.50 .. 123.00 E, 39.25 .. 41.50 N, 3-hourly */
#define ATM_LON0 120.50
#define ATM_LAT0 39.25
#define ATM_NLON 11
#define ATM_NLAT 10
#define ATM_STEP 0.25
#define ATM_DT_H 3.0

/* ocean and ice raster: 0.05 deg, 120.80 .. 122.60 E, 39.60 .. 41.10 N */
#define OCN_LON0 120.80
#define OCN_LAT0 39.60
#define OCN_NLON 37
#define OCN_NLAT 31
#define OCN_STEP 0.05

#define SST0_C 1.0          /* initial SST, deg C */
#define SHORE_DEPTH_M 2.0   /* depth at the coast */
#define DEEP_DEPTH_M 30.0   /* depth far from the coast */
#define DEPTH_SCALE_KM 15.0 /* e-folding distance of the deepening */

static const char *const COMMENT =
    "Synthetic freeze-up scene for sphice (tools/gen_season.c, make demo-season; docs/season.md). "
    "Early-winter climatology of the Liaodong Bay: December mean air temperature about -6 C at the "
    "northern shore falling towards the January mean of about -10 C, winter monsoon from the N to NW "
    "at 4-6 m/s, cold-air outbreaks about weekly with north winds of 10-12 m/s and a drop of about "
    "8 C over a day or two. Bathymetry idealised from the distance to the GSHHG coast of the land "
    "mask. Deterministic: no random numbers, no creation date.";

static double clampd(double v, double lo, double hi) { return v < lo ? lo : v > hi ? hi : v; }

/* Cosine of the solar zenith angle; t_h hours since 2000-12-01 00:00 UTC. */
static double cos_zenith(double t_h, double lon, double lat)
{
    double doy = 336.0 + t_h / 24.0; /* 2000-12-01 is day 336 of the leap year 2000 */
    double decl = -23.44 * DEG2RAD * cos(2.0 * M_PI / 366.0 * (doy + 10.0));
    double solar_h = fmod(t_h, 24.0) + lon / 15.0;
    double H = 15.0 * (solar_h - 12.0) * DEG2RAD, phi = lat * DEG2RAD;
    return sin(phi) * sin(decl) + cos(phi) * cos(decl) * cos(H);
}

/* Dew point (deg C) from T (deg C) and RH (%), Magnus over water (WMO). */
static double dew_point(double tc, double rh)
{
    const double b = 17.62, c = 243.12;
    double g = log(rh / 100.0) + b * tc / (c + tc);
    return c * g / (b - g);
}

/* The cold-air outbreaks: centre (days after the start), strength (0..1). */
static const double OUTBREAK_DAY[] = {3.0, 10.5, 17.5, 24.0, 29.5};
static const double OUTBREAK_AMP[] = {0.8, 1.0, 0.9, 1.0, 0.7};
#define NOUTBREAK (sizeof OUTBREAK_DAY / sizeof OUTBREAK_DAY[0])

static double outbreak(double day)
{
    double s = 0.0;
    for (size_t k = 0; k < NOUTBREAK; k++) {
        double z = (day - OUTBREAK_DAY[k]) / 1.2;
        s += OUTBREAK_AMP[k] * exp(-z * z);
    }
    return clampd(s, 0.0, 1.0);
}

typedef struct {
    int ncid;
    char tmp[4096];
    const char *path;
    sph_error *err;
} ncw;

#define NC(call)                                                                              \
    do {                                                                                      \
        int st_ = (call);                                                                     \
        if (st_ != NC_NOERR) {                                                                \
            sph_err_set(w->err, SPH_ERR_NETCDF, "%s: %s: %s", w->path, #call, nc_strerror(st_)); \
            return -1;                                                                        \
        }                                                                                     \
    } while (0)

static int att(ncw *w, int varid, const char *name, const char *text)
{
    NC(nc_put_att_text(w->ncid, varid, name, strlen(text), text));
    return 0;
}

static int open_file(ncw *w, const char *path, const char *title, sph_error *err)
{
    w->path = path;
    w->err = err;
    atomic_tmp_name(path, w->tmp, sizeof w->tmp);
    NC(nc_create(w->tmp, NC_NETCDF4 | NC_CLOBBER, &w->ncid));
    if (att(w, NC_GLOBAL, "title", title) || att(w, NC_GLOBAL, "source", "synthetic") ||
        att(w, NC_GLOBAL, "comment", COMMENT) || att(w, NC_GLOBAL, "Conventions", "CF-1.8") ||
        att(w, NC_GLOBAL, "sphice_generator", "tools/gen_season.c"))
        return -1;
    return 0;
}

static int close_file(ncw *w)
{
    int st = nc_close(w->ncid);
    if (st != NC_NOERR) {
        remove(w->tmp);
        return sph_err_set(w->err, SPH_ERR_NETCDF, "%s: close: %s", w->path, nc_strerror(st));
    }
    return atomic_commit(w->tmp, w->path, w->err) == SPH_OK ? 0 : -1;
}

static int coord(ncw *w, const char *name, size_t n, const double *v, const char *sn, const char *units,
                 const char *axis, int *dim)
{
    int id;
    NC(nc_def_dim(w->ncid, name, n, dim));
    NC(nc_def_var(w->ncid, name, NC_DOUBLE, 1, dim, &id));
    if (att(w, id, "standard_name", sn) || att(w, id, "units", units) || att(w, id, "axis", axis))
        return -1;
    if (!strcmp(name, "time") && att(w, id, "calendar", "standard"))
        return -1;
    NC(nc_put_var_double(w->ncid, id, v));
    return 0;
}

static int var(ncw *w, const char *name, int nd, const int *dims, const char *sn, const char *ln,
               const char *units, int *id)
{
    NC(nc_def_var(w->ncid, name, NC_FLOAT, nd, dims, id));
    NC(nc_def_var_deflate(w->ncid, *id, 1, 1, 5));
    if (att(w, *id, "standard_name", sn) || att(w, *id, "long_name", ln) || att(w, *id, "units", units))
        return -1;
    return 0;
}

static int write_atmos(const char *path, double days, sph_error *err)
{
    size_t nt = (size_t)(days * 24.0 / ATM_DT_H + 0.5) + 3, nxy = ATM_NLON * ATM_NLAT;
    double lon[ATM_NLON], lat[ATM_NLAT], *tt = malloc(nt * sizeof *tt);
    float *f[6];
    for (int q = 0; q < 6; q++)
        f[q] = malloc(nt * nxy * sizeof(float));
    int rc = -1;
    ncw W, *w = &W;
    for (int q = 0; q < 6; q++)
        if (!f[q] || !tt) {
            sph_err_set(err, SPH_ERR_NOMEM, "gen_season: buffers");
            goto done;
        }
    for (int i = 0; i < ATM_NLON; i++) lon[i] = ATM_LON0 + ATM_STEP * i;
    for (int j = 0; j < ATM_NLAT; j++) lat[j] = ATM_LAT0 + ATM_STEP * j;
    for (size_t n = 0; n < nt; n++) {
        double t = -ATM_DT_H + ATM_DT_H * (double)n, day = t / 24.0;
        double ob = outbreak(day);
        double hl = fmod(t + 8.0 + 48.0, 24.0); /* local time, UTC+8 */
        /* background: -3 C at the start to -9 C after 30 days (the December mean about -6 C),
         * 8 C colder in an outbreak, diurnal range 5 C (3 C under the outbreak's clouds) */
        double tc = -3.0 - 6.0 * clampd(day / 30.0, 0.0, 1.2) - 8.0 * ob +
                    (2.5 - 1.0 * ob) * cos(2.0 * M_PI * (hl - 14.0) / 24.0);
        double speed = 5.0 + 6.5 * ob + 1.0 * cos(2.0 * M_PI * (hl - 15.0) / 24.0);
        double dir = 330.0 + 25.0 * ob; /* NNW in between, N to NNE in an outbreak (from) */
        double rh = 65.0 - 10.0 * ob;
        for (int j = 0; j < ATM_NLAT; j++)
            for (int i = 0; i < ATM_NLON; i++) {
                size_t k = n * nxy + (size_t)j * ATM_NLON + i;
                double tck = tc - 1.0 * (lat[j] - 40.5); /* colder inland, to the north */
                double d = dir * DEG2RAD;
                f[0][k] = (float)(-speed * sin(d));
                f[1][k] = (float)(-speed * cos(d));
                f[2][k] = (float)(tck + 273.15);
                f[3][k] = (float)(dew_point(tck, rh) + 273.15);
                double cz = cos_zenith(t, lon[i], lat[j]);
                f[4][k] = (float)(cz > 0.0 ? 1000.0 * cz * (0.7 + 0.1 * ob) : 0.0);
                double tk = tck + 273.15;
                f[5][k] = (float)((0.78 - 0.06 * ob) * 5.670374419e-8 * tk * tk * tk * tk);
            }
        tt[n] = t;
    }
    int dims[3], id[6];
    if (open_file(w, path, "Liaodong Bay 3-hourly atmosphere, December 2000 (synthetic freeze-up scene)", err) ||
        coord(w, "time", nt, tt, "time", TIME_UNITS, "T", &dims[0]) ||
        coord(w, "lat", ATM_NLAT, lat, "latitude", "degrees_north", "Y", &dims[1]) ||
        coord(w, "lon", ATM_NLON, lon, "longitude", "degrees_east", "X", &dims[2]) ||
        var(w, "u10", 3, dims, "eastward_wind", "10 m eastward wind", "m s-1", &id[0]) ||
        var(w, "v10", 3, dims, "northward_wind", "10 m northward wind", "m s-1", &id[1]) ||
        var(w, "t2m", 3, dims, "air_temperature", "2 m air temperature", "K", &id[2]) ||
        var(w, "d2m", 3, dims, "dew_point_temperature", "2 m dew point temperature", "K", &id[3]) ||
        var(w, "ssrd", 3, dims, "surface_downwelling_shortwave_flux_in_air",
            "surface downwelling shortwave flux (instantaneous)", "W m-2", &id[4]) ||
        var(w, "strd", 3, dims, "surface_downwelling_longwave_flux_in_air",
            "surface downwelling longwave flux (instantaneous)", "W m-2", &id[5]))
        goto done;
    for (int q = 0; q < 6; q++)
        if (nc_put_var_float(w->ncid, id[q], f[q]) != NC_NOERR) {
            sph_err_set(err, SPH_ERR_NETCDF, "%s: writing variable %d", path, q);
            goto done;
        }
    rc = close_file(w);
done:
    free(tt);
    for (int q = 0; q < 6; q++)
        free(f[q]);
    return rc;
}

/* The land mask (0.01 deg, land_binary_mask) from a file of gen_liaodong. */
typedef struct {
    size_t nlon, nlat;
    double *lon, *lat;
    signed char *land;
} mask;

static int read_mask(const char *path, mask *m, sph_error *err)
{
    int nc, d, v;
    memset(m, 0, sizeof *m);
    if (nc_open(path, NC_NOWRITE, &nc) != NC_NOERR)
        return sph_err_set(err, SPH_ERR_IO, "%s: cannot open the land mask", path);
    int ok = nc_inq_dimid(nc, "lon", &d) == NC_NOERR && nc_inq_dimlen(nc, d, &m->nlon) == NC_NOERR &&
             nc_inq_dimid(nc, "lat", &d) == NC_NOERR && nc_inq_dimlen(nc, d, &m->nlat) == NC_NOERR;
    if (ok) {
        m->lon = malloc(m->nlon * sizeof *m->lon);
        m->lat = malloc(m->nlat * sizeof *m->lat);
        m->land = malloc(m->nlon * m->nlat);
        ok = m->lon && m->lat && m->land && nc_inq_varid(nc, "lon", &v) == NC_NOERR &&
             nc_get_var_double(nc, v, m->lon) == NC_NOERR && nc_inq_varid(nc, "lat", &v) == NC_NOERR &&
             nc_get_var_double(nc, v, m->lat) == NC_NOERR &&
             nc_inq_varid(nc, "land_binary_mask", &v) == NC_NOERR &&
             nc_get_var_schar(nc, v, m->land) == NC_NOERR;
    }
    nc_close(nc);
    return ok ? 0 : sph_err_set(err, SPH_ERR_BAD_DATA, "%s: land_binary_mask(lat, lon) with lon, lat expected", path);
}

/* Distance (km) from (lon, lat) to the nearest land point of the mask. */
static double coast_km(const mask *m, double lon, double lat)
{
    double best = 1e30, c = cos(lat * DEG2RAD), kpd = EARTH_RADIUS_KM * DEG2RAD;
    for (size_t j = 0; j < m->nlat; j++)
        for (size_t i = 0; i < m->nlon; i++)
            if (m->land[j * m->nlon + i]) {
                double dx = (m->lon[i] - lon) * c * kpd, dy = (m->lat[j] - lat) * kpd;
                double d2 = dx * dx + dy * dy;
                if (d2 < best)
                    best = d2;
            }
    return sqrt(best);
}

/* 1 when the mask's nearest point to (lon, lat) is land. */
static int is_land(const mask *m, double lon, double lat)
{
    long i = lround((lon - m->lon[0]) / (m->lon[1] - m->lon[0]));
    long j = lround((lat - m->lat[0]) / (m->lat[1] - m->lat[0]));
    if (i < 0 || j < 0 || i >= (long)m->nlon || j >= (long)m->nlat)
        return 0;
    return m->land[(size_t)j * m->nlon + (size_t)i] != 0;
}

static int write_ocean(const char *path, const char *ice_path, const mask *m, double days, sph_error *err)
{
    double lon[OCN_NLON], lat[OCN_NLAT], tt[2] = {-3.0, days * 24.0 + 3.0};
    static float sst[2 * OCN_NLON * OCN_NLAT], dep[OCN_NLON * OCN_NLAT], zero[OCN_NLON * OCN_NLAT];
    for (int i = 0; i < OCN_NLON; i++) lon[i] = OCN_LON0 + OCN_STEP * i;
    for (int j = 0; j < OCN_NLAT; j++) lat[j] = OCN_LAT0 + OCN_STEP * j;
    for (int j = 0; j < OCN_NLAT; j++)
        for (int i = 0; i < OCN_NLON; i++) {
            size_t k = (size_t)j * OCN_NLON + i;
            /* over land the shore depth: the coupling's interpolation next to the coast
             * then never mixes a fill value into a sea cell (the land mask decides land) */
            double dist = is_land(m, lon[i], lat[j]) ? 0.0 : coast_km(m, lon[i], lat[j]);
            dep[k] = (float)(SHORE_DEPTH_M + (DEEP_DEPTH_M - SHORE_DEPTH_M) * (1.0 - exp(-dist / DEPTH_SCALE_KM)));
            sst[k] = sst[OCN_NLON * OCN_NLAT + k] = (float)SST0_C;
            zero[k] = 0.0f;
        }
    ncw W, *w = &W;
    int dims[3], id[2];
    if (open_file(w, path, "Liaodong Bay SST and bathymetry (synthetic freeze-up scene)", err) ||
        coord(w, "time", 2, tt, "time", TIME_UNITS, "T", &dims[0]) ||
        coord(w, "lat", OCN_NLAT, lat, "latitude", "degrees_north", "Y", &dims[1]) ||
        coord(w, "lon", OCN_NLON, lon, "longitude", "degrees_east", "X", &dims[2]) ||
        var(w, "tos", 3, dims, "sea_surface_temperature", "sea surface temperature", "degC", &id[0]) ||
        var(w, "depth", 2, dims + 1, "sea_floor_depth_below_sea_surface", "sea floor depth", "m", &id[1]))
        return -1;
    if (nc_put_var_float(w->ncid, id[0], sst) != NC_NOERR || nc_put_var_float(w->ncid, id[1], dep) != NC_NOERR)
        return sph_err_set(err, SPH_ERR_NETCDF, "%s: writing", path);
    if (close_file(w))
        return -1;

    ncw I, *wi = &I;
    w = wi;
    int d2[2], ic[2];
    if (open_file(wi, ice_path, "Liaodong Bay initial ice, 2000-12-01 00Z: open water (synthetic)", err) ||
        coord(wi, "lat", OCN_NLAT, lat, "latitude", "degrees_north", "Y", &d2[0]) ||
        coord(wi, "lon", OCN_NLON, lon, "longitude", "degrees_east", "X", &d2[1]) ||
        var(wi, "siconc", 2, d2, "sea_ice_area_fraction", "sea ice area fraction", "1", &ic[0]) ||
        var(wi, "sithick", 2, d2, "sea_ice_thickness", "sea ice thickness", "m", &ic[1]))
        return -1;
    if (nc_put_var_float(wi->ncid, ic[0], zero) != NC_NOERR || nc_put_var_float(wi->ncid, ic[1], zero) != NC_NOERR)
        return sph_err_set(err, SPH_ERR_NETCDF, "%s: writing", ice_path);
    return close_file(wi);
}

int main(int argc, char **argv)
{
    if (argc < 3 || argc > 4) {
        fprintf(stderr, "usage: %s OUTDIR LANDMASK_NC [DAYS]\n", argv[0]);
        return 2;
    }
    double days = argc == 4 ? atof(argv[3]) : 30.0;
    if (!(days > 0.0 && days <= 60.0)) {
        fprintf(stderr, "gen_season: DAYS \"%s\": expected 0 < DAYS <= 60\n", argv[3]);
        return 2;
    }
    sph_error err;
    sph_error_clear(&err);
    mask m;
    char p[4096], q[4096];
    int rc = 1;
    if (mkdir_p(argv[1], &err) || read_mask(argv[2], &m, &err))
        goto done;
    snprintf(p, sizeof p, "%s/atmos_season.nc", argv[1]);
    if (write_atmos(p, days, &err))
        goto done;
    snprintf(p, sizeof p, "%s/ocean_season.nc", argv[1]);
    snprintf(q, sizeof q, "%s/ice_season_t0.nc", argv[1]);
    if (write_ocean(p, q, &m, days, &err))
        goto done;
    log_info("gen_season: wrote the Liaodong Bay freeze-up scene (%g days) to %s", days, argv[1]);
    rc = 0;
done:
    if (rc)
        log_error("gen_season: %s", err.msg[0] ? err.msg : sph_strerror(err.code));
    free(m.lon);
    free(m.lat);
    free(m.land);
    return rc;
}
