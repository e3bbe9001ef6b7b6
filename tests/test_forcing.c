/* Forcing reader: files in many shapes read back to the analytic fields
 * used to write them (exact for fields linear in lon, lat and time; packed
 * shorts within half a packing step), missing-value handling, SSH gradient,
 * curvilinear rotation, multi-file time series and the slice cache. */
#include "check.h"
#include "io/forcing.h"
#include "test_forcing_nc.h"
#include "util/timeutil.h"

#include <unistd.h>

enum { UW, VW, TA, TD, SW, UC, VC, SSH, RH };
enum { C_NONE = 0, C_K = 1, C_CM = 2, C_KT = 3, C_J = 4, C_PCT = 5 };
#define W(q, c) ((q) | ((c) << 8))

static char dir[64];
static double T0; /* 2021-02-01T00:00Z */
static const double R = 6371000.0;

static double wrap(double lon)
{
    return lon >= 180.0 ? lon - 360.0 : lon;
}

/* The analytic fields in sphice units at signed longitude, latitude and
 * fractional time index k (hours after T0). */
static double phys(int q, double lon, double lat, double k)
{
    lon = wrap(lon);
    double y = lat - 65.0;
    switch (q) {
    case UW: return 3 + 0.1 * lon + 0.2 * y + 0.5 * k;
    case VW: return -2 + 0.05 * lon - 0.1 * y - 0.25 * k;
    case TA: return -10 + 0.3 * lon - 0.2 * y + k;
    case TD: return -15 + 0.1 * lon + 0.1 * y;
    case SW: return 100 + 0.5 * lon + y; /* >= 0 over the globe (physical bounds) */
    case UC: return 0.1 + 0.01 * lon + 0.02 * y;
    case VC: return -0.05 + 0.02 * lon - 0.01 * y + 0.01 * k;
    case SSH: return 0.01 * lon + 0.02 * y;
    case RH: return 0.75 + 0.001 * lon - 0.02 * y + 0.02 * k; /* 0.4 .. 1.2 over the globe */
    }
    return NAN;
}

/* Value in file units. */
static double filev(int which, double lon, double lat, size_t k)
{
    double x = phys(which & 0xff, lon, lat, (double)k);
    switch (which >> 8) {
    case C_K: return x + 273.15;
    case C_CM: return x * 100.0;
    case C_KT: return x / (1852.0 / 3600.0);
    case C_J: return x * 3600.0;
    case C_PCT: return x * 100.0;
    }
    return x;
}

/* t2m with a land patch: nodes lon 2..3, lat 63..64 missing. */
static double filev_land(int which, double lon, double lat, size_t k)
{
    if (wrap(lon) >= 1.5 && wrap(lon) <= 3.5 && lat >= 62.5 && lat <= 64.5)
        return NAN;
    return filev(which, lon, lat, k);
}

static double qsat_from_dew(double td_c, double p)
{
    /* IFS: e = 611.21 exp(17.502 (Td - 273.16) / (Td - 32.19)), q = eps e / (p - (1-eps) e) */
    double td = td_c + 273.15;
    double e = 611.21 * exp(17.502 * (td - 273.16) / (td - 32.19));
    return 0.621981 * e / (p - (1 - 0.621981) * e);
}

static tgrid regular(void)
{
    tgrid g = {.nx = 25, .ny = 15, .lon0 = -12, .dlon = 1, .lat0 = 58, .dlat = 1,
               .time_units = "hours since 1900-01-01 00:00:0.0", .calendar = "gregorian",
               .tv0 = (T0 + 2208988800.0) / 3600.0, .dtv = 1.0};
    return g;
}

static const double plon[] = {-9.3, -4.25, 0.0, 0.5, 3.71, 8.7, -1.0, 7.0};
static const double plat[] = {60.2, 62.75, 65.0, 69.9, 66.66, 61.1, 64.0, 69.0};
#define NP (sizeof plon / sizeof plon[0])

static void path(char *buf, size_t len, const char *name)
{
    snprintf(buf, len, "%s/%s", dir, name);
}

static forcing *open1(const forcing_source_spec *spec, double t1, sph_error *err)
{
    forcing *f = NULL;
    sph_error_clear(err);
    if (forcing_open(&f, spec, 1, T0, t1, -10, 9, 60, 70, err) != 0)
        return NULL;
    return f;
}

/* Atmosphere in several shapes: every shape reads to the same values. */
static void test_shapes(void)
{
    static const char *names[] = {"plain",   "lon360", "latdesc", "swapped",
                                  "depth",   "noleap", "360day",  "netcdf4",
                                  "depth-5", "s_rho",  "plev"};
    for (int variant = 0; variant < 11; variant++) {
        tgrid g = regular();
        int fmt = 0;
        switch (variant) {
        case 1: g.lon0 = 0; g.dlon = 2; g.nx = 180; g.lon360 = 1; break;
        case 2: g.lat0 = 72; g.dlat = -1; break;
        case 3: g.swap = 1; break;
        case 4: g.depth = 1; break;
        case 5: g.time_units = "days since 2021-01-01"; g.calendar = "noleap"; g.tv0 = 31;
                g.dtv = 1.0 / 24; break;
        case 6: g.time_units = "days since 2021-01-01"; g.calendar = "360_day"; g.tv0 = 30;
                g.dtv = 1.0 / 24; break;
        case 7: fmt = NC_NETCDF4; break;
        /* several levels: the reader must take the one nearest the surface
         * (the others hold the field + 50) */
        case 8: g.depth = 5; g.zkind = 1; break;
        case 9: g.depth = 4; g.zkind = 2; break;
        case 10: g.depth = 3; g.zkind = 3; break;
        }
        tvar v[] = {
            {"u", "eastward_wind", "m s-1", NC_DOUBLE, 0, 0, 0, 0, 0, filev, W(UW, C_NONE)},
            {"v", "northward_wind", "m s**-1", NC_DOUBLE, 0, 0, 0, 0, 0, filev, W(VW, C_NONE)},
            {"ta", "air_temperature", "K", NC_DOUBLE, 0, 0, 0, 0, 0, filev, W(TA, C_K)},
            {"td", "dew_point_temperature", "degC", NC_DOUBLE, 0, 0, 0, 0, 0, filev, W(TD, 0)},
        };
        char p[128];
        path(p, sizeof p, "shape.nc");
        tnc_write(p, &g, v, 4, 0, 4, fmt);
        const char *files[] = {p};
        forcing_source_spec spec = {.name = "atm", .kind = FORCING_ATMOSPHERE, .files = files,
                                    .nfiles = 1, .required = FQ_WIND | FQ_TAIR | FQ_HUMIDITY};
        sph_error err;
        forcing *f = open1(&spec, T0 + 3 * 3600, &err);
        CHECK(f != NULL, "%s: open: %s", names[variant], err.msg);
        if (!f)
            continue;
        double u[NP], vv[NP], ta[NP], q[NP];
        forcing_sample s = {.u_east = u, .v_north = vv, .tair = ta, .qair = q};
        double k = 1.5;
        int rc = forcing_sample_at(f, T0 + k * 3600, NP, plon, plat, &s, &err);
        CHECK(rc == 0, "%s: sample: %s", names[variant], err.msg);
        CHECK(s.provided == (FQ_WIND | FQ_TAIR | FQ_HUMIDITY), "%s: provided %x", names[variant],
              s.provided);
        for (size_t i = 0; rc == 0 && i < NP; i++) {
            char what[64];
            snprintf(what, sizeof what, "%s u at %zu", names[variant], i);
            CHECK_CLOSE(u[i], phys(UW, plon[i], plat[i], k), 0, 1e-9, what);
            snprintf(what, sizeof what, "%s v at %zu", names[variant], i);
            CHECK_CLOSE(vv[i], phys(VW, plon[i], plat[i], k), 0, 1e-9, what);
            snprintf(what, sizeof what, "%s tair at %zu", names[variant], i);
            CHECK_CLOSE(ta[i], phys(TA, plon[i], plat[i], k), 0, 1e-9, what);
            /* q is not linear in space: interpolation is of the dew point. */
            snprintf(what, sizeof what, "%s q at %zu", names[variant], i);
            CHECK_CLOSE(q[i], qsat_from_dew(phys(TD, plon[i], plat[i], k), 101325.0), 1e-12, 0,
                        what);
        }
        forcing_close(f);
        unlink(p);
    }
}

/* Specific humidity from relative humidity over water and air temperature
 * (IFS saturation pressure, Part IV eq. 7.5, at T instead of Td). */
static double q_from_rh(double rh, double t_c, double p)
{
    double t = t_c + 273.15;
    double e = rh * 611.21 * exp(17.502 * (t - 273.16) / (t - 32.19));
    return 0.621981 * e / (p - (1 - 0.621981) * e);
}

/* CMIP/GFS-like humidity: relative humidity in percent ("hurs"); with a
 * dew point beside it the dew point wins; without air temperature it is
 * refused. */
static void test_relative_humidity(void)
{
    tgrid g = regular();
    tvar v[] = {
        {"uas", "eastward_wind", "m s-1", NC_FLOAT, 0, 0, 0, 0, 0, filev, W(UW, 0)},
        {"vas", "northward_wind", "m s-1", NC_FLOAT, 0, 0, 0, 0, 0, filev, W(VW, 0)},
        {"tas", "air_temperature", "K", NC_DOUBLE, 0, 0, 0, 0, 0, filev, W(TA, C_K)},
        {"hurs", NULL, "%", NC_DOUBLE, 0, 0, 0, 0, 0, filev, W(RH, C_PCT)},
        {"td", "dew_point_temperature", "degC", NC_DOUBLE, 0, 0, 0, 0, 0, filev, W(TD, 0)},
    };
    char p[128];
    path(p, sizeof p, "rh.nc");
    for (int variant = 0; variant < 3; variant++) {
        /* 0: tas + hurs; 1: tas + hurs + td; 2: hurs alone (no tas) */
        tvar vv[5];
        size_t nv = 0;
        vv[nv++] = v[0];
        vv[nv++] = v[1];
        if (variant != 2)
            vv[nv++] = v[2];
        vv[nv++] = v[3];
        if (variant == 1)
            vv[nv++] = v[4];
        tnc_write(p, &g, vv, nv, 0, 4, 0);
        const char *files[] = {p};
        forcing_source_spec spec = {.name = "cmip", .kind = FORCING_ATMOSPHERE, .files = files,
                                    .nfiles = 1, .required = FQ_WIND | FQ_HUMIDITY};
        sph_error err;
        forcing *f = open1(&spec, T0 + 3 * 3600, &err);
        if (variant == 2) {
            CHECK(f == NULL && strstr(err.msg, "relative_humidity ('hurs') found but no "
                                               "air_temperature") && strstr(err.msg, p),
                  "relative humidity without air temperature: %s", err.msg);
            forcing_close(f);
            continue;
        }
        CHECK(f != NULL, "rh open: %s", err.msg);
        if (!f)
            continue;
        double q[NP];
        forcing_sample s = {.qair = q};
        double k = 1.25;
        CHECK(forcing_sample_at(f, T0 + k * 3600, NP, plon, plat, &s, &err) == 0, "%s", err.msg);
        for (size_t i = 0; i < NP; i++) {
            double want = variant == 0
                              ? q_from_rh(phys(RH, plon[i], plat[i], k), phys(TA, plon[i], plat[i], k),
                                          101325.0)
                              : qsat_from_dew(phys(TD, plon[i], plat[i], k), 101325.0);
            CHECK_CLOSE(q[i], want, 1e-12, 0, variant == 0 ? "q from rh" : "dew point over rh");
        }
        forcing_close(f);
    }
    unlink(p);
}

/* GFS from NOMADS OPeNDAP (GrADS-written): no standard_name, lower-case
 * units ("k", "w/m^2", "pa", "%"), longitudes 0..360, time in "days since
 * 1-1-1" of the standard (Julian before 1582) calendar. 2021-02-01T00Z is
 * day 737823 there: proleptic Gregorian ordinal 737822 (Python's
 * date.toordinal, day 1 = 0001-01-01) minus 1, plus the 2 days by which
 * the Julian 0001-01-01 precedes the Gregorian one. */
/* A GFS-shaped file (0..360 longitudes, no standard_name) with the given
 * time axis and variables (wind, air temperature, humidity as rh or dew
 * point, shortwave): written, read as source "gfs" and checked at hour k
 * against the analytic fields within the tolerances of its storage type. */
typedef struct gfs_case {
    const char *file, *tag, *time_units;
    double tv0, dtv, k;
    int from_dew;            /* humidity from the dew point (else relative humidity) */
    double ta_tol, sw_tol;   /* absolute: K, W m-2 */
    double q_rel;            /* relative */
} gfs_case;

static void gfs_check(const gfs_case *c, const tvar *v)
{
    tgrid g = regular();
    g.lon0 = 0;
    g.dlon = 1;
    g.nx = 360;
    g.lon360 = 1;
    g.time_units = c->time_units;
    g.calendar = NULL;
    g.tv0 = c->tv0;
    g.dtv = c->dtv;
    char p[128];
    path(p, sizeof p, c->file);
    tnc_write(p, &g, v, 5, 0, 4, 0);
    const char *files[] = {p};
    forcing_source_spec spec = {.name = "gfs", .kind = FORCING_ATMOSPHERE, .files = files,
                                .nfiles = 1,
                                .required = FQ_WIND | FQ_TAIR | FQ_HUMIDITY | FQ_SWDN};
    sph_error err;
    forcing *f = open1(&spec, T0 + 3 * 3600, &err);
    CHECK(f != NULL, "%s open: %s", c->tag, err.msg);
    if (!f)
        return;
    double u[NP], vv[NP], ta[NP], q[NP], sw[NP];
    forcing_sample s = {.u_east = u, .v_north = vv, .tair = ta, .qair = q, .swdn = sw};
    double k = c->k;
    CHECK(forcing_sample_at(f, T0 + k * 3600, NP, plon, plat, &s, &err) == 0, "%s: %s", c->tag,
          err.msg);
    for (size_t i = 0; i < NP; i++) {
        double qw = c->from_dew ? qsat_from_dew(phys(TD, plon[i], plat[i], k), 101325.0)
                                : q_from_rh(phys(RH, plon[i], plat[i], k),
                                            phys(TA, plon[i], plat[i], k), 101325.0);
        CHECK_CLOSE(u[i], phys(UW, plon[i], plat[i], k), 0, 1e-5, "gfs u (float)");
        CHECK_CLOSE(vv[i], phys(VW, plon[i], plat[i], k), 0, 1e-5, "gfs v (float)");
        CHECK_CLOSE(ta[i], phys(TA, plon[i], plat[i], k), 0, c->ta_tol, "gfs air temperature");
        CHECK_CLOSE(sw[i], phys(SW, plon[i], plat[i], k), 0, c->sw_tol, "gfs shortwave");
        CHECK_CLOSE(q[i], qw, c->q_rel, 0, "gfs specific humidity");
    }
    forcing_close(f);
    unlink(p);
}

static void test_gfs(void)
{
    tvar v[] = {
        {"ugrd10m", NULL, "m/s", NC_FLOAT, 0, 0, 0, 0, 0, filev, W(UW, 0)},
        {"vgrd10m", NULL, "m/s", NC_FLOAT, 0, 0, 0, 0, 0, filev, W(VW, 0)},
        {"tmp2m", NULL, "k", NC_DOUBLE, 0, 0, 0, 0, 0, filev, W(TA, C_K)},
        {"rh2m", NULL, "%", NC_DOUBLE, 0, 0, 0, 0, 0, filev, W(RH, C_PCT)},
        {"dswrfsfc", NULL, "w/m^2", NC_DOUBLE, 0, 0, 0, 0, 0, filev, W(SW, 0)},
    };
    gfs_case c = {.file = "gfs.nc", .tag = "gfs (GrADS)", .time_units = "days since 1-1-1 00:00:0.0",
                  .tv0 = 737823.0, .dtv = 1.0 / 24, .k = 2.5, .from_dew = 0,
                  .ta_tol = 1e-9, .sw_tol = 1e-9, .q_rel = 1e-12};
    gfs_check(&c, v);
}

/* GFS converted by wgrib2 -netcdf: NAME_LEVEL variable names without
 * standard_name (UGRD_10maboveground, TMP_2maboveground, ...), units as
 * wgrib2 writes them ("m/s", "K", "kg/kg", "W/m^2"), _FillValue
 * 9.999e+20, time in "seconds since 1970-01-01 00:00:00.0 0:00" (its
 * verftime()), longitudes 0..360. */
static void test_gfs_wgrib2(void)
{
    tvar v[] = {
        {"UGRD_10maboveground", NULL, "m/s", NC_FLOAT, 0, 0, 1, 9.999e20, 0, filev, W(UW, 0)},
        {"VGRD_10maboveground", NULL, "m/s", NC_FLOAT, 0, 0, 1, 9.999e20, 0, filev, W(VW, 0)},
        {"TMP_2maboveground", NULL, "K", NC_FLOAT, 0, 0, 1, 9.999e20, 0, filev, W(TA, C_K)},
        {"DPT_2maboveground", NULL, "K", NC_FLOAT, 0, 0, 1, 9.999e20, 0, filev, W(TD, C_K)},
        {"DSWRF_surface", NULL, "W/m^2", NC_FLOAT, 0, 0, 1, 9.999e20, 0, filev, W(SW, 0)},
    };
    /* float32 K: a dew point's ulp near 260 K is 3.1e-5 K, and q changes by
     * about 7 % per K, so 2e-6 relative per ulp (interpolating adds two) */
    gfs_case c = {.file = "gfs_wgrib2.nc", .tag = "gfs (wgrib2)",
                  .time_units = "seconds since 1970-01-01 00:00:00.0 0:00", .tv0 = T0,
                  .dtv = 3600.0, .k = 1.75, .from_dew = 1,
                  .ta_tol = 1e-4, .sw_tol = 1e-3, .q_rel = 5e-6};
    gfs_check(&c, v);
}

/* An ERA5 wind file at p read as source "era5" (built-in names u10, v10),
 * checked against the analytic wind at hours k0, k0 + dk, ... below 3
 * (float storage: 1e-5 m/s), then removed. */
static void era5_wind_check(const char *p, const char *tag, double k0, double dk)
{
    const char *files[] = {p};
    forcing_source_spec spec = {.name = "era5", .kind = FORCING_ATMOSPHERE, .files = files,
                                .nfiles = 1, .required = FQ_WIND};
    sph_error err;
    forcing *f = open1(&spec, T0 + 3 * 3600, &err);
    CHECK(f != NULL, "%s open: %s", tag, err.msg);
    if (f)
        for (double k = k0; k < 3.0; k += dk) {
            double u[NP], vv2[NP];
            forcing_sample smp = {.u_east = u, .v_north = vv2};
            CHECK(forcing_sample_at(f, T0 + k * 3600, NP, plon, plat, &smp, &err) == 0, "%s: %s",
                  tag, err.msg);
            for (size_t i = 0; i < NP; i++) {
                CHECK_CLOSE(u[i], phys(UW, plon[i], plat[i], k), 0, 1e-5, "era5 u");
                CHECK_CLOSE(vv2[i], phys(VW, plon[i], plat[i], k), 0, 1e-5, "era5 v");
            }
        }
    forcing_close(f);
    unlink(p);
}

/* ERA5 as the old CDS wrote it when a request spanned final ERA5 and
 * the preliminary ERA5T: an expver dimension (1, 5), each time valid in
 * one of the two and _FillValue in the other (here: the first two hours
 * in expver 1, the rest in expver 5). The reader merges them. */
static void test_era5_expver(void)
{
    tgrid g = regular();
    char p[128];
    path(p, sizeof p, "era5_expver.nc");
    int nc, dt, de, dy, dx, vt, ve, vy, vx, vu, vv;
    NCW(nc_create(p, NC_CLOBBER, &nc));
    NCW(nc_def_dim(nc, "time", NC_UNLIMITED, &dt));
    NCW(nc_def_dim(nc, "expver", 2, &de));
    NCW(nc_def_dim(nc, "latitude", g.ny, &dy));
    NCW(nc_def_dim(nc, "longitude", g.nx, &dx));
    NCW(nc_def_var(nc, "time", NC_DOUBLE, 1, &dt, &vt));
    NCW(nc_put_att_text(nc, vt, "units", strlen(g.time_units), g.time_units));
    NCW(nc_def_var(nc, "expver", NC_INT, 1, &de, &ve));
    NCW(nc_def_var(nc, "latitude", NC_DOUBLE, 1, &dy, &vy));
    NCW(nc_put_att_text(nc, vy, "units", 13, "degrees_north"));
    NCW(nc_def_var(nc, "longitude", NC_DOUBLE, 1, &dx, &vx));
    NCW(nc_put_att_text(nc, vx, "units", 12, "degrees_east"));
    int d4[4] = {dt, de, dy, dx};
    float fill = -32767.0f;
    NCW(nc_def_var(nc, "u10", NC_FLOAT, 4, d4, &vu));
    NCW(nc_def_var(nc, "v10", NC_FLOAT, 4, d4, &vv));
    for (int q = 0; q < 2; q++) {
        int id = q ? vv : vu;
        NCW(nc_put_att_text(nc, id, "units", 7, "m s**-1"));
        NCW(nc_put_att_float(nc, id, "_FillValue", NC_FLOAT, 1, &fill));
    }
    NCW(nc_enddef(nc));
    int ev[2] = {1, 5};
    NCW(nc_put_var_int(nc, ve, ev));
    for (size_t i = 0; i < g.nx; i++) {
        double x = g.lon0 + (double)i * g.dlon;
        NCW(nc_put_var1_double(nc, vx, &i, &x));
    }
    for (size_t j = 0; j < g.ny; j++) {
        double y = g.lat0 + (double)j * g.dlat;
        NCW(nc_put_var1_double(nc, vy, &j, &y));
    }
    float *buf = malloc(g.nx * g.ny * sizeof *buf);
    for (size_t k = 0; k < 4; k++) {
        double tv = g.tv0 + (double)k * g.dtv;
        NCW(nc_put_var1_double(nc, vt, &k, &tv));
        for (size_t e = 0; e < 2; e++)
            for (int q = 0; q < 2; q++) {
                int valid = (k < 2) == (e == 0);
                for (size_t j = 0; j < g.ny; j++)
                    for (size_t i = 0; i < g.nx; i++)
                        buf[j * g.nx + i] =
                            valid ? (float)filev(q ? VW : UW, g.lon0 + (double)i * g.dlon,
                                                 g.lat0 + (double)j * g.dlat, k)
                                  : fill;
                size_t st[4] = {k, e, 0, 0}, ct[4] = {1, 1, g.ny, g.nx};
                NCW(nc_put_vara_float(nc, q ? vv : vu, st, ct, buf));
            }
    }
    free(buf);
    NCW(nc_close(nc));
    /* 0.5: expver 1 only; 1.5: expver 1 then 5; 2.5: expver 5 only */
    era5_wind_check(p, "era5 expver", 0.5, 1.0);
}

/* ERA5 as the modernised CDS (2024 on) writes it: ECMWF's "GRIB to
 * netCDF conversion on new CDS and ADS systems" (cfgrib-based) names the
 * time dimension valid_time (int64 seconds since 1970-01-01,
 * proleptic_gregorian), keeps latitude in the GRIB's decreasing order,
 * adds a scalar ensemble "number" and an "expver" string per time (a
 * variable, no longer a dimension), stores NetCDF-4 with compression, sets
 * _FillValue to NaN and, where a parameter has no CF name, standard_name
 * "unknown" (u10, v10). The reader must take it as plain ERA5 wind. */
static void test_era5_cds2024(void)
{
    tgrid g = regular();
    char p[128];
    path(p, sizeof p, "era5_cds2024.nc");
    int nc, dt, dy, dx, vt, vn, ve, vy, vx, vu, vv;
    NCW(nc_create(p, NC_CLOBBER | NC_NETCDF4, &nc));
    NCW(nc_def_dim(nc, "valid_time", 4, &dt));
    NCW(nc_def_dim(nc, "latitude", g.ny, &dy));
    NCW(nc_def_dim(nc, "longitude", g.nx, &dx));
    NCW(nc_def_var(nc, "number", NC_INT64, 0, NULL, &vn));
    NCW(nc_put_att_text(nc, vn, "long_name", 28, "ensemble member numerical id"));
    NCW(nc_put_att_text(nc, vn, "units", 1, "1"));
    NCW(nc_put_att_text(nc, vn, "standard_name", 11, "realization"));
    NCW(nc_def_var(nc, "valid_time", NC_INT64, 1, &dt, &vt));
    NCW(nc_put_att_text(nc, vt, "long_name", 4, "time"));
    NCW(nc_put_att_text(nc, vt, "standard_name", 4, "time"));
    NCW(nc_put_att_text(nc, vt, "units", 24, "seconds since 1970-01-01"));
    NCW(nc_put_att_text(nc, vt, "calendar", 19, "proleptic_gregorian"));
    NCW(nc_def_var(nc, "latitude", NC_DOUBLE, 1, &dy, &vy));
    NCW(nc_put_att_text(nc, vy, "units", 13, "degrees_north"));
    NCW(nc_put_att_text(nc, vy, "standard_name", 8, "latitude"));
    NCW(nc_put_att_text(nc, vy, "stored_direction", 10, "decreasing"));
    NCW(nc_def_var(nc, "longitude", NC_DOUBLE, 1, &dx, &vx));
    NCW(nc_put_att_text(nc, vx, "units", 12, "degrees_east"));
    NCW(nc_put_att_text(nc, vx, "standard_name", 9, "longitude"));
    NCW(nc_def_var(nc, "expver", NC_STRING, 1, &dt, &ve));
    NCW(nc_put_att_text(nc, ve, "long_name", 25, "Experiment version number"));
    int d3[3] = {dt, dy, dx};
    float fill = NAN;
    const char *ln[2] = {"10 metre U wind component", "10 metre V wind component"};
    int pid[2] = {165, 166};
    NCW(nc_def_var(nc, "u10", NC_FLOAT, 3, d3, &vu));
    NCW(nc_def_var(nc, "v10", NC_FLOAT, 3, d3, &vv));
    for (int q = 0; q < 2; q++) {
        int id = q ? vv : vu;
        NCW(nc_def_var_deflate(nc, id, 1, 1, 1));
        NCW(nc_def_var_fill(nc, id, 0, &fill));
        NCW(nc_put_att_int(nc, id, "GRIB_paramId", NC_INT, 1, &pid[q]));
        NCW(nc_put_att_text(nc, id, "GRIB_units", 7, "m s**-1"));
        NCW(nc_put_att_text(nc, id, "long_name", strlen(ln[q]), ln[q]));
        NCW(nc_put_att_text(nc, id, "units", 7, "m s**-1"));
        NCW(nc_put_att_text(nc, id, "standard_name", 7, "unknown"));
        NCW(nc_put_att_text(nc, id, "coordinates", 39, "number valid_time latitude longitude expver"));
    }
    NCW(nc_enddef(nc));
    long long num = 0;
    NCW(nc_put_var_longlong(nc, vn, &num));
    for (size_t i = 0; i < g.nx; i++) {
        double x = g.lon0 + (double)i * g.dlon;
        NCW(nc_put_var1_double(nc, vx, &i, &x));
    }
    for (size_t j = 0; j < g.ny; j++) { /* decreasing: row j is lat0 + (ny-1-j) dlat */
        double y = g.lat0 + (double)(g.ny - 1 - j) * g.dlat;
        NCW(nc_put_var1_double(nc, vy, &j, &y));
    }
    float *buf = malloc(g.nx * g.ny * sizeof *buf);
    for (size_t k = 0; k < 4; k++) {
        long long tv = (long long)T0 + (long long)k * 3600;
        NCW(nc_put_var1_longlong(nc, vt, &k, &tv));
        const char *ev = k < 2 ? "0001" : "0005";
        NCW(nc_put_var1_string(nc, ve, &k, &ev));
        for (int q = 0; q < 2; q++) {
            for (size_t j = 0; j < g.ny; j++)
                for (size_t i = 0; i < g.nx; i++)
                    buf[j * g.nx + i] = (float)filev(q ? VW : UW, g.lon0 + (double)i * g.dlon,
                                                     g.lat0 + (double)(g.ny - 1 - j) * g.dlat, k);
            size_t st[3] = {k, 0, 0}, ct[3] = {1, g.ny, g.nx};
            NCW(nc_put_vara_float(nc, q ? vv : vu, st, ct, buf));
        }
    }
    free(buf);
    NCW(nc_close(nc));
    era5_wind_check(p, "era5 (CDS 2024)", 0.25, 0.75);
}

/* ERA5-like: packed shorts, mapped names, K, accumulated J m-2, land fill. */
static void test_era5(void)
{
    tgrid g = regular();
    tvar v[] = {
        {"u10", NULL, "m s**-1", NC_SHORT, 0.001, 3.0, 1, -32767, 0, filev, W(UW, 0)},
        {"v10", NULL, "m s**-1", NC_SHORT, 0.001, -2.0, 1, -32767, 0, filev, W(VW, 0)},
        {"t2m", NULL, "K", NC_SHORT, 0.002, 263.0, 1, -32767, 0, filev_land, W(TA, C_K)},
        {"d2m", NULL, "K", NC_SHORT, 0.002, 258.0, 1, -32767, 0, filev, W(TD, C_K)},
        {"ssrd", NULL, "J m**-2", NC_SHORT, 20.0, 360000.0, 1, -32767, 0, filev, W(SW, C_J)},
    };
    char p[128];
    path(p, sizeof p, "era5.nc");
    tnc_write(p, &g, v, 5, 0, 6, 0);
    const char *files[] = {p};
    static const forcing_name_map map[] = {{"eastward_wind", "u10"}, {"northward_wind", "v10"}};
    forcing_source_spec spec = {.name = "era5", .kind = FORCING_ATMOSPHERE, .files = files,
                                .nfiles = 1, .map = map, .nmap = 2,
                                .required = FQ_WIND | FQ_TAIR | FQ_HUMIDITY | FQ_SWDN};
    sph_error err;
    forcing *f = open1(&spec, T0 + 5 * 3600, &err);
    CHECK(f != NULL, "era5 open: %s", err.msg);
    if (!f)
        return;
    double u[NP], vv[NP], ta[NP], sw[NP];
    forcing_sample s = {.u_east = u, .v_north = vv, .tair = ta, .swdn = sw};
    double k = 2.25;
    CHECK(forcing_sample_at(f, T0 + k * 3600, NP, plon, plat, &s, &err) == 0, "%s", err.msg);
    for (size_t i = 0; i < NP; i++) {
        CHECK_CLOSE(u[i], phys(UW, plon[i], plat[i], k), 0, 0.0005 + 1e-9, "era5 u");
        CHECK_CLOSE(vv[i], phys(VW, plon[i], plat[i], k), 0, 0.0005 + 1e-9, "era5 v");
        CHECK_CLOSE(sw[i], phys(SW, plon[i], plat[i], k), 0, 10.0 / 3600 + 1e-9, "era5 ssrd");
    }
    /* Land: the point (1.5, 63.5) has two missing corners (lon 2): weights
     * renormalised over (1, 63) and (1, 64). The point (2.4, 63.45) has all
     * four missing: nearest valid node within one cell is (1, 63). */
    double lx[] = {1.5, 2.4, 0.25}, ly[] = {63.5, 63.45, 60.5}, t3[3];
    forcing_sample s3 = {.tair = t3};
    CHECK(forcing_sample_at(f, T0 + 3600, 3, lx, ly, &s3, &err) == 0, "%s", err.msg);
    CHECK_CLOSE(t3[0], 0.5 * (phys(TA, 1, 63, 1) + phys(TA, 1, 64, 1)), 0, 0.001 + 1e-9,
                "renormalised over valid corners");
    CHECK_CLOSE(t3[1], phys(TA, 1, 63, 1), 0, 0.001 + 1e-9, "nearest valid node");
    CHECK_CLOSE(t3[2], phys(TA, 0.25, 60.5, 1), 0, 0.001 + 1e-9, "away from land");

    forcing_var_info info[8];
    size_t n = forcing_describe(f, info, 8);
    CHECK(n == 5, "describe: %zu variables (u, v, t2m, d2m, ssrd)", n);
    int seen_t2m = 0;
    for (size_t i = 0; i < n && i < 8; i++) {
        CHECK(strcmp(info[i].source, "era5") == 0, "source %s", info[i].source);
        CHECK(strcmp(info[i].file, p) == 0, "file %s", info[i].file);
        CHECK(strstr(info[i].grid, "regular 1x1 deg 25x15") != NULL, "grid '%s'", info[i].grid);
        CHECK_CLOSE(info[i].t_first, T0, 0, 0, "t_first");
        CHECK_CLOSE(info[i].t_last, T0 + 5 * 3600, 0, 0, "t_last");
        if (strcmp(info[i].variable, "t2m") == 0) {
            seen_t2m = 1;
            CHECK(strcmp(info[i].standard_name, "air_temperature") == 0, "t2m standard_name");
            CHECK(strcmp(info[i].units, "K") == 0, "t2m units %s", info[i].units);
            /* 2 x 2 land nodes of 25 x 15 */
            CHECK_CLOSE(info[i].fill_fraction, 4.0 / 375.0, 0, 1e-12, "t2m fill fraction");
        }
    }
    CHECK(seen_t2m, "describe lists t2m");
    forcing_close(f);
    unlink(p);
}

/* Curvilinear rotated grid: with an angle variable (exact) and with the
 * angle computed from the coordinates. */
static double rot_deg_ = 30.0;
static double curv_angle(double lon, double lat, int use_angle_var)
{
    if (use_angle_var)
        return rot_deg_ * M_PI / 180.0;
    /* Local direction of the x axis of tgrid_node: d(lon)/di = dlon cos(a) / cos(clat),
     * d(lat)/di = dlon sin(a); angle from east with the metric cos(lat). */
    double a = rot_deg_ * M_PI / 180.0, c0 = cos(65.0 * M_PI / 180.0);
    (void)lon;
    return atan2(sin(a), cos(a) / c0 * cos(lat * M_PI / 180.0));
}
static int curv_use_angle_;
static double filev_grid(int which, double lon, double lat, size_t k)
{
    double a = curv_angle(lon, lat, curv_use_angle_);
    double ue = phys(UW, lon, lat, (double)k), vn = phys(VW, lon, lat, (double)k);
    return which == 0 ? ue * cos(a) + vn * sin(a) : -ue * sin(a) + vn * cos(a);
}

static void test_curvilinear(void)
{
    for (int use = 1; use >= 0; use--) {
        curv_use_angle_ = use;
        tgrid g = regular();
        g.curvilinear = 1;
        g.nx = 60;
        g.ny = 50;
        g.dlon = 0.5;
        g.dlat = 0.5;
        g.lon0 = 0;
        g.clat = 65;
        g.rot_deg = rot_deg_;
        g.angle_var = use;
        tvar v[] = {
            {"u", "x_wind", "m s-1", NC_DOUBLE, 0, 0, 0, 0, 0, filev_grid, 0},
            {"v", "y_wind", "m s-1", NC_DOUBLE, 0, 0, 0, 0, 0, filev_grid, 1},
            {"t", "air_temperature", "degC", NC_DOUBLE, 0, 0, 0, 0, 0, filev, W(TA, 0)},
        };
        char p[128];
        path(p, sizeof p, "curv.nc");
        tnc_write(p, &g, v, 3, 0, 3, 0);
        const char *files[] = {p};
        forcing_source_spec spec = {.name = "curv", .kind = FORCING_ATMOSPHERE, .files = files,
                                    .nfiles = 1, .required = FQ_WIND | FQ_TAIR};
        sph_error err;
        forcing *f = open1(&spec, T0 + 2 * 3600, &err);
        CHECK(f != NULL, "curvilinear open: %s", err.msg);
        if (!f)
            continue;
        double u[NP], vv[NP], ta[NP];
        forcing_sample s = {.u_east = u, .v_north = vv, .tair = ta};
        double k = 0.75;
        for (int rep = 0; rep < 2; rep++) { /* second pass uses the cell hints */
            CHECK(forcing_sample_at(f, T0 + k * 3600, NP, plon, plat, &s, &err) == 0, "%s",
                  err.msg);
            for (size_t i = 0; i < NP; i++) {
                CHECK_CLOSE(ta[i], phys(TA, plon[i], plat[i], k), 0, 1e-9, "curvilinear tair");
                double tol = use ? 1e-9 : 2e-3;
                CHECK_CLOSE(u[i], phys(UW, plon[i], plat[i], k), 0, tol, "curvilinear u east");
                CHECK_CLOSE(vv[i], phys(VW, plon[i], plat[i], k), 0, tol, "curvilinear v north");
            }
        }
        forcing_var_info info[4];
        CHECK(forcing_describe(f, info, 4) == 3, "3 variables");
        CHECK(strstr(info[0].grid, "curvilinear 60x50") != NULL, "grid %s", info[0].grid);
        forcing_close(f);
        unlink(p);
    }
}

/* Two ocean sources (currents in cm/s with SSH; currents in knots on a
 * 360_day calendar) add up; SSH gradient from centred differences. */
static void test_ocean(void)
{
    tgrid g = regular();
    g.dlon = 0.25;
    g.dlat = 0.25;
    g.nx = 97;
    g.ny = 57;
    tvar a[] = {
        {"uo", NULL, "cm s-1", NC_FLOAT, 0, 0, 1, 1e20, 0, filev, W(UC, C_CM)},
        {"vo", NULL, "cm/s", NC_FLOAT, 0, 0, 1, 1e20, 0, filev, W(VC, C_CM)},
        {"zos", "sea_surface_height_above_geoid", "m", NC_DOUBLE, 0, 0, 0, 0, 0, filev, SSH},
    };
    tvar b[] = {
        {"water_u", NULL, "knots", NC_DOUBLE, 0, 0, 1, -30000, 1, filev, W(UC, C_KT)},
        {"water_v", NULL, "kt", NC_DOUBLE, 0, 0, 1, -30000, 1, filev, W(VC, C_KT)},
    };
    char pa[128], pb[128];
    path(pa, sizeof pa, "cmems.nc");
    path(pb, sizeof pb, "hycom.nc");
    tnc_write(pa, &g, a, 3, 0, 4, 0);
    g.time_units = "hours since 2021-01-01 00:00:00";
    g.calendar = "360_day";
    g.tv0 = 30 * 24; /* Feb 1 in 360_day */
    tnc_write(pb, &g, b, 2, 0, 4, NC_NETCDF4);
    const char *fa[] = {pa}, *fb[] = {pb};
    forcing_source_spec specs[] = {
        {.name = "cmems", .kind = FORCING_OCEAN, .files = fa, .nfiles = 1,
         .required = FQ_CURRENT | FQ_SSH},
        {.name = "hycom", .kind = FORCING_OCEAN, .files = fb, .nfiles = 1,
         .required = FQ_CURRENT},
    };
    forcing *f = NULL;
    sph_error err;
    sph_error_clear(&err);
    CHECK(forcing_open(&f, specs, 2, T0, T0 + 3 * 3600, -10, 9, 60, 70, &err) == 0, "%s",
          err.msg);
    if (!f)
        return;
    double u[NP], v[NP], h[NP], hx[NP], hy[NP];
    forcing_sample s = {.uw_east = u, .vw_north = v, .ssh = h, .ssh_dx_east = hx,
                        .ssh_dy_north = hy};
    double k = 2.5;
    CHECK(forcing_sample_at(f, T0 + k * 3600, NP, plon, plat, &s, &err) == 0, "%s", err.msg);
    CHECK(s.provided == (FQ_CURRENT | FQ_SSH), "provided %x", s.provided);
    for (size_t i = 0; i < NP; i++) {
        CHECK_CLOSE(u[i], 2 * phys(UC, plon[i], plat[i], k), 0, 1e-7, "summed u current");
        CHECK_CLOSE(v[i], 2 * phys(VC, plon[i], plat[i], k), 0, 1e-7, "summed v current");
        CHECK_CLOSE(h[i], phys(SSH, plon[i], plat[i], k), 0, 1e-9, "ssh");
        /* h = 0.01 lon + 0.02 lat (degrees): dh/dE = 0.01 / (R cos(lat) pi/180) */
        double gx = 0.01 / (R * cos(plat[i] * M_PI / 180) * M_PI / 180);
        double gy = 0.02 / (R * M_PI / 180);
        CHECK_CLOSE(hx[i], gx, 1e-4, 0, "dssh/deast");
        CHECK_CLOSE(hy[i], gy, 1e-9, 0, "dssh/dnorth");
    }
    forcing_close(f);
    unlink(pa);
    unlink(pb);
}

/* A time series over two files given in reverse order; the slice cache. */
static void test_files_and_cache(void)
{
    tgrid g = regular();
    tvar v[] = {
        {"u", "eastward_wind", "m s-1", NC_FLOAT, 0, 0, 0, 0, 0, filev, W(UW, 0)},
        {"v", "northward_wind", "m s-1", NC_FLOAT, 0, 0, 0, 0, 0, filev, W(VW, 0)},
        {"t", "air_temperature", "degC", NC_FLOAT, 0, 0, 0, 0, 0, filev, W(TA, 0)},
    };
    char p1[128], p2[128];
    path(p1, sizeof p1, "part1.nc");
    path(p2, sizeof p2, "part2.nc");
    tnc_write(p1, &g, v, 3, 0, 3, 0);
    tnc_write(p2, &g, v, 3, 3, 3, 0);
    const char *files[] = {p2, p1};
    forcing_source_spec spec = {.name = "split", .kind = FORCING_ATMOSPHERE, .files = files,
                                .nfiles = 2, .required = FQ_WIND | FQ_TAIR};
    sph_error err;
    forcing *f = open1(&spec, T0 + 5 * 3600, &err);
    CHECK(f != NULL, "split open: %s", err.msg);
    if (!f)
        return;
    double u[NP], vv[NP], ta[NP];
    forcing_sample s = {.u_east = u, .v_north = vv, .tair = ta};
    size_t r0 = forcing_debug_slice_reads(f);
    CHECK(r0 == 3, "open reads one slice per variable (%zu)", r0);
    /* Inside [t0, t0 + 1 h]: the second slice once, then nothing. */
    CHECK(forcing_sample_at(f, T0 + 600, NP, plon, plat, &s, &err) == 0, "%s", err.msg);
    size_t r1 = forcing_debug_slice_reads(f);
    CHECK(r1 == 6, "first interval reads 3 more slices (%zu)", r1);
    for (int m = 2; m <= 6; m++) {
        CHECK(forcing_sample_at(f, T0 + 600.0 * m, NP, plon, plat, &s, &err) == 0, "%s",
              err.msg);
        CHECK(forcing_debug_slice_reads(f) == r1, "no new reads within the interval (%zu)",
              forcing_debug_slice_reads(f));
    }
    CHECK_CLOSE(ta[0], phys(TA, plon[0], plat[0], 1.0), 0, 1e-5, "at the interval end");
    /* Next interval: one new slice per variable. */
    CHECK(forcing_sample_at(f, T0 + 4200, NP, plon, plat, &s, &err) == 0, "%s", err.msg);
    CHECK(forcing_debug_slice_reads(f) == r1 + 3, "next interval reads 3 (%zu)",
          forcing_debug_slice_reads(f));
    /* Across the file boundary (k = 2 in part1, k = 3 in part2). */
    double k = 2.5;
    CHECK(forcing_sample_at(f, T0 + k * 3600, NP, plon, plat, &s, &err) == 0, "%s", err.msg);
    for (size_t i = 0; i < NP; i++) {
        CHECK_CLOSE(u[i], phys(UW, plon[i], plat[i], k), 0, 1e-5, "u across files");
        CHECK_CLOSE(ta[i], phys(TA, plon[i], plat[i], k), 0, 1e-5, "tair across files");
    }
    /* Linear in time exactly (float storage: values at nodes exact to 1e-5). */
    forcing_var_info info[4];
    CHECK(forcing_describe(f, info, 4) == 3, "three variables");
    CHECK(strcmp(info[0].file, p1) == 0, "first file is the earliest: %s", info[0].file);
    CHECK_CLOSE(info[0].t_last, T0 + 5 * 3600, 0, 0, "t_last over both files");
    forcing_close(f);
    unlink(p1);
    unlink(p2);
}

int main(void)
{
    time_parse_iso("2021-02-01T00:00:00Z", &T0);
    snprintf(dir, sizeof dir, "/tmp/sphice-forcing-XXXXXX");
    if (!mkdtemp(dir)) {
        perror("mkdtemp");
        return 2;
    }
    test_shapes();
    test_era5();
    test_relative_humidity();
    test_gfs();
    test_gfs_wgrib2();
    test_era5_expver();
    test_era5_cds2024();
    test_curvilinear();
    test_ocean();
    test_files_and_cache();
    rmdir(dir);
    return check_summary("test_forcing");
}
