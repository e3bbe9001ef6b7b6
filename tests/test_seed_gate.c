/* Cold-start conservation and sanity gates end to end (issue 19 items 4,
 * 7) on the engine's synthetic case (tests/engine_case.h):
 *  - the raster's ice area and volume over the domain (computed here:
 *    sum A dA and A h dA with the spherical cell area) and the seeded
 *    particles' are in the result (cycle.json) and the fields file's
 *    global attributes, and agree within 1 %, for the lattice and per cell;
 *  - a raster without ice in the domain is an open-water start: the run
 *    succeeds with no particle and is flagged "open_water";
 *  - a raster with ice in the domain that the lattice does not seed
 *    fails with one line naming the raster, nothing written; with
 *    initial.gate "flag" it is published flagged. */
#include <math.h>
#include <netcdf.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "engine_case.h"
#include "io/restart.h"
#include "service/check.h"
#include "service/config.h"
#include "service/forecast.h"
#include "util/log.h"

static char dir[] = "/tmp/sphice-seedgate-XXXXXX";
static const char *atm_files[2];

/* the case's configuration with `from` replaced by `to` (twice at most) */
static struct sph_config *load(const char *ice, const char *from, const char *to, const char *from2,
                               const char *to2)
{
    char text[8192], out[8192];
    ec_config(text, sizeof text, dir, 300, "[\"wind\", \"tair\"]", ice, "");
    const char *f[2] = {from, from2}, *t[2] = {to, to2};
    for (int q = 0; q < 2; q++) {
        char *at = f[q] ? strstr(text, f[q]) : NULL;
        if (!at)
            continue;
        snprintf(out, sizeof out, "%.*s%s%s", (int)(at - text), text, t[q], at + strlen(f[q]));
        memcpy(text, out, sizeof text);
    }
    struct sph_config *cfg = NULL;
    sph_error err;
    sph_error_clear(&err);
    CHECK(sph_config_parse(text, "test", &cfg, &err) == SPH_OK, "config: %s", err.msg);
    return cfg;
}

static int run_warm(const struct sph_config *cfg, const char *stage_name, const char *warm,
                    forecast_result *res, sph_error *err, char *stage, size_t len)
{
    snprintf(stage, len, "%s/%s", dir, stage_name);
    forecast_request req;
    memset(&req, 0, sizeof req);
    req.cycle_time = EC_CYCLE;
    req.hours = 2;
    req.stage_dir = stage;
    req.warm_start = warm;
    req.forcing_files[0] = atm_files;
    forecast_progress prog;
    memset((void *)&prog, 0, sizeof prog);
    sph_error_clear(err);
    return forecast_run(cfg, &req, &prog, NULL, res, err);
}

static int run(const struct sph_config *cfg, const char *stage_name, forecast_result *res, sph_error *err,
               char *stage, size_t len)
{
    return run_warm(cfg, stage_name, NULL, res, err, stage, len);
}

/* The lattice run's restart file with every 20th particle (5 %) moved to
 * 37-38.4 km east of the domain's centre (121.5 E): about 121.94-121.96 E,
 * east of the case's coast at EC_LAND_LON and inside the domain. */
static int write_on_land(const char *from, const char *to)
{
    restart_header h;
    sph_error err;
    sph_error_clear(&err);
    if (restart_read_header(from, &h, &err) != SPH_OK)
        return -1;
    sph_particles *P = sph_particles_create(h.n, h.nlayers);
    int rc = P ? restart_read(from, NULL, &h, P, &err) : -1;
    for (size_t k = 0; rc == SPH_OK && k < P->n; k += 20)
        P->x[k] = 37000.0 + 150.0 * (double)(k / 20 % 10);
    if (rc == SPH_OK)
        rc = restart_write(to, P, &h, &err);
    CHECK(rc == SPH_OK, "restart %s: %s", from, err.msg);
    sph_particles_free(P);
    return rc;
}

static double global_num(const char *stage, const char *name)
{
    char p[1200];
    snprintf(p, sizeof p, "%s/sphice_fields.nc", stage);
    int nc;
    double v = NAN;
    if (nc_open(p, NC_NOWRITE, &nc) != NC_NOERR)
        return NAN;
    if (nc_get_att_double(nc, NC_GLOBAL, name, &v) != NC_NOERR)
        v = NAN;
    nc_close(nc);
    return v;
}

static void global_text(const char *stage, const char *name, char *buf, size_t len)
{
    char p[1200];
    snprintf(p, sizeof p, "%s/sphice_fields.nc", stage);
    int nc;
    size_t n = 0;
    buf[0] = 0;
    if (nc_open(p, NC_NOWRITE, &nc) != NC_NOERR)
        return;
    if (nc_inq_attlen(nc, NC_GLOBAL, name, &n) == NC_NOERR && n < len &&
        nc_get_att_text(nc, NC_GLOBAL, name, buf) == NC_NOERR)
        buf[n] = 0;
    nc_close(nc);
}

int main(int argc, char **argv)
{
    (void)argc;
    ec_passive_openmp(argv);
    sph_log_level = LOG_LVL_WARN;
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    ec_write_inputs(dir);
    char atm[1024], p[1024], stage[1100];
    snprintf(atm, sizeof atm, "%s/atm.nc", dir);
    atm_files[0] = atm;
    atm_files[1] = NULL;
    snprintf(p, sizeof p, "%s/open.nc", dir);
    ec_write_ice_at(p, 31, 21, 121.2, 40.1, 0.02, 0.02, 0.0, 0.0, -1);
    snprintf(p, sizeof p, "%s/speck.nc", dir);
    ec_write_ice_at(p, 3, 3, 121.5, 40.3, 0.001, 0.001, 0.9, 0.5, -1);

    /* the case's raster: 31 x 21 cells of 0.02 deg from 121.2 E, 40.1 N,
     * all in the domain and east of no land, conc EC_CONC, EC_THICK m */
    const double deg = M_PI / 180, R = 6371000.0, d = 0.02;
    double want_a = 0;
    for (int j = 0; j < 21; j++) {
        double lat = 40.1 + d * j;
        want_a += 31 * EC_CONC * R * R * d * deg * (sin((lat + d / 2) * deg) - sin((lat - d / 2) * deg));
    }
    double want_v = want_a * EC_THICK;
    char onland[1100] = "";
    const char *spacing[2] = {"\"spacing\": 0.02", "\"spacing\": 0"};
    for (int s = 0; s < 2; s++) {
        struct sph_config *cfg = load("ice.nc", "\"spacing\": 0.02", spacing[s], NULL, NULL);
        forecast_result res;
        sph_error err;
        int rc = cfg ? run(cfg, s ? "cells" : "lattice", &res, &err, stage, sizeof stage) : -1;
        CHECK(rc == SPH_OK, "%s: %s", spacing[s], err.msg);
        if (rc == SPH_OK) {
            printf("%s: raster %.6g km2 %.6g km3 (want %.6g, %.6g), seeded %.6g km2 %.6g km3, %zu "
                   "particles, %.3f %% on land at the end\n", spacing[s], res.raster_ice_area_km2,
                   res.raster_ice_volume_km3, want_a / 1e6, want_v / 1e9, res.seeded_ice_area_km2,
                   res.seeded_ice_volume_km3, (size_t)res.run.particles_start, 100 * res.land_fraction);
            CHECK_CLOSE(res.raster_ice_area_km2, want_a / 1e6, 0.001, 0, "raster ice area over the domain");
            CHECK_CLOSE(res.raster_ice_volume_km3, want_v / 1e9, 0.001, 0, "raster ice volume over the domain");
            CHECK_CLOSE(res.seeded_ice_area_km2, want_a / 1e6, 0.01, 0, "seeded ice area within 1 %");
            CHECK_CLOSE(res.seeded_ice_volume_km3, want_v / 1e9, 0.01, 0, "seeded ice volume within 1 %");
            CHECK(res.quality_flag[0] == 0 && !res.open_water, "no flag: \"%s\"", res.quality_flag);
            CHECK(res.land_fraction >= 0 && res.land_fraction <= 0.01, "on land %g", res.land_fraction);
            CHECK_CLOSE(global_num(stage, "sphice_raster_ice_area_km2"), res.raster_ice_area_km2, 1e-12, 0,
                        "attribute sphice_raster_ice_area_km2");
            CHECK_CLOSE(global_num(stage, "sphice_seeded_ice_volume_km3"), res.seeded_ice_volume_km3, 1e-12,
                        0, "attribute sphice_seeded_ice_volume_km3");
            char flag[300];
            global_text(stage, "sphice_quality_flag", flag, sizeof flag);
            CHECK(!strcmp(flag, "none"), "attribute sphice_quality_flag \"%s\"", flag);
            if (s == 0) {
                char from[1300];
                snprintf(from, sizeof from, "%s/restart-19990208T12Z.nc", stage);
                snprintf(onland, sizeof onland, "%s/onland.nc", dir);
                write_on_land(from, onland);
            }
        }
        sph_config_free(cfg);
    }

    /* open water: not an error, no particle, flagged open_water */
    {
        struct sph_config *cfg = load("open.nc", NULL, NULL, NULL, NULL);
        forecast_result res;
        sph_error err;
        int rc = cfg ? run(cfg, "open", &res, &err, stage, sizeof stage) : -1;
        CHECK(rc == SPH_OK, "open water start: %s", err.msg);
        CHECK(rc != SPH_OK || (res.open_water && res.run.particles_start == 0 &&
                               !strcmp(res.quality_flag, "open_water") && res.raster_ice_area_km2 == 0),
              "open water: flag \"%s\", %ld particles, raster %g km2", res.quality_flag,
              (long)res.run.particles_start, res.raster_ice_area_km2);
        char flag[300];
        global_text(stage, "sphice_quality_flag", flag, sizeof flag);
        CHECK(!strcmp(flag, "open_water"), "open water: attribute sphice_quality_flag \"%s\"", flag);
        sph_config_free(cfg);
    }

    /* ice in the domain but the 2 km lattice misses the 300 m speck */
    {
        struct sph_config *cfg = load("speck.nc", NULL, NULL, NULL, NULL);
        forecast_result res;
        sph_error err;
        int rc = cfg ? run(cfg, "speck", &res, &err, stage, sizeof stage) : -1;
        CHECK(rc == SPH_ERR_BAD_DATA, "speck: rc %d: %s", rc, err.msg);
        CHECK(strstr(err.msg, "speck.nc") && strstr(err.msg, "initial.gate") && !strchr(err.msg, '\n'),
              "speck: one line naming the raster and initial.gate: %s", err.msg);
        int n = ec_count_entries(stage);
        CHECK(n <= 0, "speck: nothing written (%d entries)", n);
        printf("  speck -> %s\n", err.msg);
        sph_config_free(cfg);
        cfg = load("speck.nc", "\"threshold\": 0.15", "\"threshold\": 0.15, \"gate\": \"flag\"", NULL, NULL);
        rc = cfg ? run(cfg, "speck_flag", &res, &err, stage, sizeof stage) : -1;
        CHECK(rc == SPH_OK, "speck, gate flag: %s", err.msg);
        CHECK(rc != SPH_OK || strstr(res.quality_flag, "speck.nc"), "speck: flag \"%s\"", res.quality_flag);
        char flag[300];
        global_text(stage, "sphice_quality_flag", flag, sizeof flag);
        CHECK(strstr(flag, "speck.nc") != NULL, "speck: attribute sphice_quality_flag \"%s\"", flag);
        sph_config_free(cfg);
    }

    /* sphice check: the seeded totals beside the raster's, and the gate */
    {
        struct sph_config *cfg = load("ice.nc", NULL, NULL, NULL, NULL);
        char *buf = NULL;
        size_t len = 0;
        FILE *f = open_memstream(&buf, &len);
        if (cfg && f) {
            service_check(cfg, EC_CYCLE, 1, f);
            fclose(f);
            f = NULL;
            char *at = strstr(buf, "\"seeded_ice_volume_km3\":");
            double v = at ? strtod(at + strlen("\"seeded_ice_volume_km3\":"), NULL) : NAN;
            CHECK_CLOSE(v, want_v / 1e9, 0.01, 0, "check: seeded ice volume within 1 % of the raster's");
            char *g = strstr(buf, "\"seeding_gate_ok\":");
            g = g ? g + strlen("\"seeding_gate_ok\":") : NULL;
            while (g && (*g == ' ' || *g == '\t'))
                g++;
            CHECK(g && !strncmp(g, "true", 4), "check: the gate holds");
        }
        if (f)
            fclose(f);
        free(buf);
        sph_config_free(cfg);
        cfg = load("speck.nc", NULL, NULL, NULL, NULL);
        buf = NULL;
        f = open_memstream(&buf, &len);
        if (cfg && f) {
            service_check(cfg, EC_CYCLE, 0, f);
            fclose(f);
            f = NULL;
            CHECK(strstr(buf, "PROBLEM      seeding:") != NULL, "check names the seeding problem:\n%s", buf);
        }
        if (f)
            fclose(f);
        free(buf);
        sph_config_free(cfg);
    }

    /* more than 1 % of the particles on land at the end: fails, or flagged */
    for (int flagged = 0; onland[0] && flagged < 2; flagged++) {
        struct sph_config *cfg = flagged ? load("ice.nc", "\"threshold\": 0.15",
                                                "\"threshold\": 0.15, \"gate\": \"flag\"", NULL, NULL)
                                         : load("ice.nc", NULL, NULL, NULL, NULL);
        forecast_result res;
        sph_error err;
        int rc = cfg ? run_warm(cfg, flagged ? "land_flag" : "land", onland, &res, &err, stage, sizeof stage)
                     : -1;
        if (!flagged) {
            CHECK(rc == SPH_ERR_BAD_DATA && strstr(err.msg, "on land") && strstr(err.msg, "initial.gate") &&
                  !strchr(err.msg, '\n'), "on land: rc %d, one line: %s", rc, err.msg);
            int n = ec_count_entries(stage);
            CHECK(n <= 0, "on land: nothing written (%d entries)", n);
            printf("  on land -> %s\n", err.msg);
        } else {
            CHECK(rc == SPH_OK && strstr(res.quality_flag, "on land") && res.land_fraction > 0.01,
                  "on land, gate flag: rc %d %s, flag \"%s\", %g on land", rc, err.msg, res.quality_flag,
                  res.land_fraction);
            char flag[300];
            global_text(stage, "sphice_quality_flag", flag, sizeof flag);
            CHECK(strstr(flag, "on land") != NULL, "on land: attribute sphice_quality_flag \"%s\"", flag);
            CHECK(global_num(stage, "sphice_particles_on_land_fraction") > 0.01, "on land: attribute");
        }
        sph_config_free(cfg);
    }
    return check_summary("test_seed_gate");
}
