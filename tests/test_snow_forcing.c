/* Snowfall forcing (issue 20 item 3): files written from the providers'
 * documented conventions, read back against values computed here.
 *  - CF snowfall_amount (kg m-2) as a running accumulation with a reset
 *    (forcing[].accumulation "running"): consecutive amounts differenced
 *    over the interval, the reset's amount over its own interval; the
 *    same file as "interval" gives amount / interval;
 *  - ERA5 (CDS NetCDF): sf in "m of water equivalent", accumulated over
 *    the hour ending at each time: rate 1000 sf / 3600 kg m-2 s-1;
 *  - CF lwe_thickness_of_snowfall_amount in mm; snowfall_flux in mm s-1
 *    (liquid water equivalent, 1 mm = 1 kg m-2);
 *  - GFS over NOMADS: pratesfc (precipitation rate, kg/m^2/s, no
 *    standard_name) split into snow by the air temperature at the
 *    particles (coupling): snowfall = prate * CLM 4.0 fraction;
 *  - bad input: snowfall in an unknown or incompatible unit fails the
 *    forecast with one line naming the file, the variable and the key;
 *    nothing is published;
 *  - a forecast with ERA5 snowfall carries sisnthick
 *    (surface_snow_thickness) on its fields and particles files, and
 *    every particle's snow is at most the fallen F t / rho_s. */
#include <math.h>
#include <netcdf.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "check.h"
#include "core/particles.h"
#include "engine_case.h"
#include "io/forcing.h"
#include "service/config.h"
#include "service/coupling.h"
#include "service/forecast.h"
#include "util/log.h"
#include "util/timeutil.h"

static char dir[] = "/tmp/sphice-snowforc-XXXXXX";
static const double RUNNING[6] = {0.0, 1.0, 3.0, 6.0, 2.0, 5.0}; /* kg m-2; reset at index 4 */
#define ERA5_SF 0.0005                                           /* m of water per hour */
#define PRATE 2.0e-4                                             /* kg m-2 s-1 */

static double amount_fn(int which, double lon, double lat, size_t k)
{
    (void)lon; (void)lat;
    switch (which) {
    case 0: return RUNNING[k < 6 ? k : 5];
    case 1: return ERA5_SF;
    case 2: return 0.5 * (double)(k + 1); /* mm per hour */
    case 3: return 1.0e-4;                 /* mm s-1 */
    default: return 0.0;
    }
}

/* 1 deg over -12..12 E, 58..72 N, hourly from 2021-02-01 00 UTC. */
static void write_one(const char *path, const char *name, const char *std, const char *units, int which,
                      size_t nt)
{
    tgrid g = {.nx = 25, .ny = 15, .lon0 = -12, .dlon = 1, .lat0 = 58, .dlat = 1,
               .time_units = "hours since 2021-02-01", .calendar = "standard", .tv0 = 0, .dtv = 1.0};
    tvar v[1] = {{name, std, units, NC_DOUBLE, 0, 0, 0, 0, 0, amount_fn, which}};
    tnc_write(path, &g, v, 1, 0, nt, 0);
}

static int open_snow(const char *path, int accumulation, unsigned need, forcing **f, sph_error *err)
{
    const char *files[] = {path};
    forcing_source_spec spec = {.name = "snow", .kind = FORCING_ATMOSPHERE, .files = files, .nfiles = 1,
                                .required = need, .accumulation = accumulation};
    double t0;
    time_parse_iso("2021-02-01T00:00:00Z", &t0);
    sph_error_clear(err);
    return forcing_open(f, &spec, 1, t0, t0 + 5 * 3600.0, -10, 9, 60, 70, err);
}

static double sample_snow(forcing *f, double hours, int precip)
{
    double t0;
    time_parse_iso("2021-02-01T00:00:00Z", &t0);
    double lon = 0.5, lat = 65.2, v = NAN;
    forcing_sample s;
    memset(&s, 0, sizeof s);
    if (precip)
        s.precip = &v;
    else
        s.snowfall = &v;
    sph_error err;
    sph_error_clear(&err);
    if (forcing_sample_at(f, t0 + hours * 3600.0, 1, &lon, &lat, &s, &err) != 0)
        fprintf(stderr, "sample: %s\n", err.msg);
    return v;
}

static void check_reader(void)
{
    char p[256];
    sph_error err;
    forcing *f = NULL;

    snprintf(p, sizeof p, "%s/amount.nc", dir);
    write_one(p, "snow_acc", "snowfall_amount", "kg m-2", 0, 6);
    int rc = open_snow(p, FORCING_ACCUMULATION_RUNNING, FQ_SNOWFALL, &f, &err);
    CHECK(rc == 0, "running amount: %s", err.msg);
    if (rc == 0) {
        /* a_k - a_{k-1} over 3600 s; at the reset (a_4 < a_3) a_4 itself */
        const double want[6] = {1.0, 1.0, 2.0, 3.0, 2.0, 3.0};
        for (int k = 0; k < 6; k++)
            CHECK_CLOSE(sample_snow(f, k, 0), want[k] / 3600.0, 1e-12, 0, "running accumulation, differenced");
        /* between times: linear in time between the rates at the times */
        CHECK_CLOSE(sample_snow(f, 2.5, 0), 0.5 * (2.0 + 3.0) / 3600.0, 1e-12, 0, "half way");
    }
    forcing_close(f);
    rc = open_snow(p, FORCING_ACCUMULATION_INTERVAL, FQ_SNOWFALL, &f, &err);
    CHECK(rc == 0, "interval amount: %s", err.msg);
    if (rc == 0)
        for (int k = 1; k < 6; k++)
            CHECK_CLOSE(sample_snow(f, k, 0), RUNNING[k] / 3600.0, 1e-12, 0, "interval accumulation / 3600 s");
    forcing_close(f);

    /* ERA5: sf, "m of water equivalent", accumulated over the past hour */
    snprintf(p, sizeof p, "%s/era5.nc", dir);
    write_one(p, "sf", NULL, "m of water equivalent", 1, 6);
    rc = open_snow(p, FORCING_ACCUMULATION_INTERVAL, FQ_SNOWFALL, &f, &err);
    CHECK(rc == 0, "ERA5 sf: %s", err.msg);
    if (rc == 0)
        CHECK_CLOSE(sample_snow(f, 2.0, 0), 1000.0 * ERA5_SF / 3600.0, 1e-9, 0, "ERA5 sf: 1000 sf / 3600 s");
    forcing_close(f);

    /* liquid water equivalent: 1 mm of water is 1 kg m-2 */
    static const struct {
        const char *file, *name, *std, *units;
        int which;
        double hours, want;
    } lwe[] = {
        {"lwe.nc", "snow_lwe", "lwe_thickness_of_snowfall_amount", "mm", 2, 3.0, 2.0 / 3600.0},
        {"rate.nc", "snowr", "snowfall_flux", "mm s-1", 3, 1.5, 1.0e-4},
    };
    for (size_t i = 0; i < sizeof lwe / sizeof lwe[0]; i++) {
        snprintf(p, sizeof p, "%s/%s", dir, lwe[i].file);
        write_one(p, lwe[i].name, lwe[i].std, lwe[i].units, lwe[i].which, 6);
        rc = open_snow(p, FORCING_ACCUMULATION_INTERVAL, FQ_SNOWFALL, &f, &err);
        CHECK(rc == 0, "%s in %s: %s", lwe[i].std, lwe[i].units, err.msg);
        if (rc == 0)
            CHECK_CLOSE(sample_snow(f, lwe[i].hours, 0), lwe[i].want, 1e-12, 0, lwe[i].units);
        forcing_close(f);
    }

    /* unknown and incompatible units: one line naming file, variable, key */
    const char *bad[2] = {"bananas per hour", "K"};
    for (int b = 0; b < 2; b++) {
        snprintf(p, sizeof p, "%s/bad%d.nc", dir, b);
        write_one(p, "sf", NULL, bad[b], 1, 6);
        rc = open_snow(p, FORCING_ACCUMULATION_INTERVAL, FQ_SNOWFALL, &f, &err);
        CHECK(rc != 0 && err.code == SPH_ERR_UNITS, "%s: refused", bad[b]);
        CHECK(strstr(err.msg, p) && strstr(err.msg, "'sf'") && strstr(err.msg, "forcing[].variables") &&
                  strstr(err.msg, bad[b]) && !strchr(err.msg, '\n'),
              "one line naming file, variable, units and key: %s", err.msg);
    }
}

/* GFS pratesfc through the coupling: the split by the particles' air temperature. */
static double tair_fn(int which, double lon, double lat, size_t k)
{
    (void)lat; (void)k;
    switch (which) {
    case 0: return 3.0;
    case 1: return 0.0;
    case 2: return 273.15 - 3.0 + 0.5 * (lon - 110.0); /* -3 C at 110 E .. +7 C at 130 E */
    default: return PRATE;
    }
}

static void check_split(void)
{
    char path[256];
    snprintf(path, sizeof path, "%s/gfs.nc", dir);
    tgrid g = {.nx = 41, .ny = 21, .lon0 = 100.0, .dlon = 1.0, .lat0 = 30.0, .dlat = 1.0,
               .time_units = "hours since 1999-02-08 00:00:00", .calendar = "standard", .tv0 = 3.0,
               .dtv = 1.0};
    tvar v[4] = {{"ugrd10m", NULL, "m/s", NC_FLOAT, 0, 0, 0, 0, 0, tair_fn, 0},
                 {"vgrd10m", NULL, "m/s", NC_FLOAT, 0, 0, 0, 0, 0, tair_fn, 1},
                 {"tmp2m", NULL, "k", NC_FLOAT, 0, 0, 0, 0, 0, tair_fn, 2},
                 {"pratesfc", NULL, "kg/m^2/s", NC_FLOAT, 0, 0, 0, 0, 0, tair_fn, 3}};
    tnc_write(path, &g, v, 4, 0, 12, NC_NETCDF4);
    /* the engine case's configuration, on a wider box, with GFS's file */
    char text[8192], fixed[8192];
    ec_config(text, sizeof text, dir, 300, "[\"wind\", \"tair\", \"precipitation\"]", "ice.nc", "");
    const char *box = "\"lon_min\": 121.0, \"lon_max\": 122.0, \"lat_min\": 40.0, \"lat_max\": 40.6";
    char *at = strstr(text, box), *url = strstr(text, "/atm.nc");
    CHECK(at && url && at < url, "configuration template");
    if (!at || !url || at > url)
        return;
    snprintf(fixed, sizeof fixed, "%.*s\"lon_min\": 110.0, \"lon_max\": 130.0, \"lat_min\": 35.0, "
             "\"lat_max\": 45.0%.*s/gfs.nc%s", (int)(at - text), text, (int)(url - at - strlen(box)),
             at + strlen(box), url + strlen("/atm.nc"));
    struct sph_config *cfg = NULL;
    sph_error e;
    sph_error_clear(&e);
    CHECK(sph_config_parse(fixed, "test_snow_forcing", &cfg, &e) == 0 && cfg, "config: %s", e.msg);
    if (!cfg)
        return;
    geo_proj *proj = geo_proj_create("aeqd", 120.0, 40.0, &e);
    fc_coupling c;
    memset(&c, 0, sizeof c);
    forecast_request req;
    memset(&req, 0, sizeof req);
    const double T0 = 918453600.0; /* 1999-02-08T06Z */
    const char *files[2] = {path, NULL};
    req.cycle_time = T0;
    req.forcing_files[0] = files;
    int rc = coupling_open(&c, cfg, &req, T0, T0 + 3 * 3600.0, "test", &e);
    CHECK(rc == 0, "coupling: %s", e.msg);
    enum { N = 21 };
    sph_particles *P = sph_particles_create(N, 1);
    double lon[N], lat[N];
    for (int k = 0; k < N; k++) {
        lon[k] = 110.0 + k; /* -3 .. +7 C in 0.5 C steps */
        lat[k] = 40.0;
    }
    geo_forward(proj, N, lon, lat, P->x, P->y, &e);
    P->n = N;
    CHECK(coupling_alloc(&c, N, &e) == 0, "alloc");
    if (rc == 0) {
        rc = coupling_fill(&c, proj, &cfg->model.thermo, 1, P, T0 + 1800.0, &e);
        CHECK(rc == 0 && (c.provided & FQ_PRECIP), "fill: %s", e.msg);
        for (int k = 0; k < N && rc == 0; k++) {
            double T = -3.0 + 0.5 * k;
            double frac = T <= 0.0 ? 1.0 : T >= 2.0 ? 0.0 : (2.0 - T) / 2.0; /* CLM 4.0 ramp */
            CHECK_CLOSE(P->tair[k], T, 0, 1e-4, "air temperature at the particle");
            CHECK_CLOSE(P->snowfall[k], PRATE * (P->tair[k] <= 0.0 ? 1.0 : P->tair[k] >= 2.0 ? 0.0
                                                                     : (2.0 - P->tair[k]) / 2.0),
                        1e-6, 1e-12, "snowfall = prate x snow fraction");
            CHECK(fabs(P->snowfall[k] - PRATE * frac) <= 1e-3 * PRATE, "snowfall %.6g at %.1f C, want %.6g",
                  P->snowfall[k], T, PRATE * frac);
        }
    }
    coupling_free(&c);
    sph_particles_free(P);
    geo_proj_free(proj);
    sph_config_free(cfg);
}

/* The engine case's atmosphere with ERA5's sf (units uu), and a forecast. */
static double engine_fn(int which, double lon, double lat, size_t k)
{
    return which == 3 ? ERA5_SF : ec_atm_fn(which, lon, lat, k);
}

static int forecast(const char *sf_units, const char *stage_name, char *stage, size_t len, sph_error *err)
{
    char atm[1024];
    snprintf(atm, sizeof atm, "%s/atm_%s.nc", dir, stage_name);
    tgrid g = {.nx = 9, .ny = 7, .lon0 = 120.5, .dlon = 0.25, .lat0 = 39.5, .dlat = 0.25,
               .time_units = "hours since 1999-02-08 00:00:00", .calendar = "standard", .tv0 = 3.0,
               .dtv = 1.0};
    tvar v[4] = {{"u10", "eastward_wind", "m s-1", NC_FLOAT, 0, 0, 0, 0, 0, engine_fn, 0},
                 {"v10", "northward_wind", "m s-1", NC_FLOAT, 0, 0, 0, 0, 0, engine_fn, 1},
                 {"t2m", "air_temperature", "K", NC_FLOAT, 0, 0, 0, 0, 0, engine_fn, 2},
                 {"sf", NULL, sf_units, NC_FLOAT, 0, 0, 0, 0, 0, engine_fn, 3}};
    tnc_write(atm, &g, v, 4, 0, 13, NC_NETCDF4);
    char text[8192];
    ec_config(text, sizeof text, dir, 300, "[\"wind\", \"tair\", \"snowfall\"]", "ice.nc", "");
    char *at = strstr(text, "/atm.nc");
    char fixed[8192];
    snprintf(fixed, sizeof fixed, "%.*s/atm_%s.nc%s", (int)(at - text), text, stage_name, at + strlen("/atm.nc"));
    struct sph_config *cfg = NULL;
    sph_error_clear(err);
    if (sph_config_parse(fixed, "test", &cfg, err) != SPH_OK)
        return -1;
    snprintf(stage, len, "%s/%s", dir, stage_name);
    const char *files[2] = {atm, NULL};
    forecast_request req = {.cycle_time = EC_CYCLE, .hours = 2, .stage_dir = stage};
    req.forcing_files[0] = files;
    forecast_progress prog;
    memset((void *)&prog, 0, sizeof prog);
    forecast_result res;
    int rc = forecast_run(cfg, &req, &prog, NULL, &res, err);
    sph_config_free(cfg);
    return rc;
}

static int var_with_std(const char *path, const char *name, const char *std, float *vmax, size_t *nvals)
{
    int nc, v, nd, dims[4];
    if (nc_open(path, NC_NOWRITE, &nc) != NC_NOERR)
        return -1;
    int ok = nc_inq_varid(nc, name, &v) == NC_NOERR;
    char sn[128] = "";
    size_t l = 0;
    if (ok && nc_inq_attlen(nc, v, "standard_name", &l) == NC_NOERR && l < sizeof sn)
        nc_get_att_text(nc, v, "standard_name", sn);
    ok = ok && !strcmp(sn, std) && nc_inq_var(nc, v, NULL, NULL, &nd, dims, NULL) == NC_NOERR && nd <= 4;
    size_t n = 1;
    for (int d = 0; ok && d < nd; d++) {
        size_t len;
        nc_inq_dimlen(nc, dims[d], &len);
        n *= len;
    }
    float *buf = ok ? malloc(n * sizeof *buf) : NULL;
    ok = ok && buf && nc_get_var_float(nc, v, buf) == NC_NOERR;
    float fill = NC_FILL_FLOAT;
    nc_get_att_float(nc, v, "_FillValue", &fill);
    *vmax = -1.0f;
    *nvals = 0;
    for (size_t i = 0; ok && i < n; i++)
        if (buf[i] != fill && buf[i] != NC_FILL_FLOAT) {
            *vmax = buf[i] > *vmax ? buf[i] : *vmax;
            ++*nvals;
        }
    free(buf);
    nc_close(nc);
    return ok ? 0 : -1;
}

static void check_forecast(void)
{
    char stage[1200], p[1300];
    sph_error err;
    int rc = forecast("m of water equivalent", "good", stage, sizeof stage, &err);
    CHECK(rc == 0, "forecast with ERA5 snowfall: %s", err.msg);
    if (rc == 0) {
        /* the most a particle can hold after 2 h: 1000 sf per hour / rho_s */
        float fmax;
        size_t nv;
        double most = 2.0 * 1000.0 * ERA5_SF / 330.0;
        snprintf(p, sizeof p, "%s/sphice_fields.nc", stage);
        CHECK(var_with_std(p, "sisnthick", "surface_snow_thickness", &fmax, &nv) == 0 && nv > 0,
              "fields file has sisnthick (surface_snow_thickness)");
        CHECK(fmax > 0.0f && fmax <= most * (1 + 1e-5), "gridded snow %.6g m within (0, %.6g]", fmax, most);
        snprintf(p, sizeof p, "%s/sphice_particles.nc", stage);
        CHECK(var_with_std(p, "sisnthick", "surface_snow_thickness", &fmax, &nv) == 0 && nv > 0,
              "particles file has sisnthick");
        CHECK(fmax > 0.0f && fmax <= most * (1 + 1e-5), "particle snow %.6g m within (0, %.6g]", fmax, most);
        printf("forecast with ERA5 sf %.4g m/h: largest particle snow %.6g m (at most %.6g m), %zu values\n",
               ERA5_SF, fmax, most, nv);
    }
    rc = forecast("bananas per hour", "bad", stage, sizeof stage, &err);
    CHECK(rc != 0, "bad snowfall units fail the forecast");
    printf("bad snowfall units: %s\n", err.msg);
    CHECK(strstr(err.msg, "atm_bad.nc") && strstr(err.msg, "'sf'") && strstr(err.msg, "forcing[].variables") &&
              !strchr(err.msg, '\n'),
          "one line naming file, variable and key: %s", err.msg);
    snprintf(p, sizeof p, "%s/sphice_fields.nc", stage);
    struct stat sb;
    CHECK(stat(p, &sb) != 0, "nothing published in %s", stage);
}

int main(int argc, char **argv)
{
    ec_passive_openmp(argv);
    (void)argc;
    sph_log_level = LOG_LVL_WARN;
    if (!mkdtemp(dir))
        return 2;
    ec_write_inputs(dir); /* the engine case: ice, land mask, configuration */
    check_reader();
    check_split();
    check_forecast();
    return check_summary("test_snow_forcing");
}
