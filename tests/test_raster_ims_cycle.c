/* A NOAA IMS analysis (24 km ASCII, tests/ims_file.h) as a cycle's initial
 * raster, end to end on the engine's case (tests/engine_case.h, Liaodong
 * Bay's 121-122 E, 40-40.6 N, land east of 121.9 E; the ice kept 0.3
 * degrees west of it so that the land gate does not decide the outcome):
 *  - with initial.ims.ice_concentration 0.8 and ice_thickness 0.4 the
 *    cycle runs (seeded per cell); the raster's ice over the domain is at
 *    0.4 m (volume over area), the seeded ice within 1 % of it, and the result (cycle.json's
 *    initial_raster_assumed) and `sphice check` say that the ice cell's
 *    values came from those keys;
 *  - without initial.ims.ice_concentration the cycle fails with one line
 *    naming the file and the key, and nothing is written. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "engine_case.h"
#include "ims_file.h"
#include "service/check.h"
#include "service/config.h"
#include "service/forecast.h"
#include "util/log.h"

static char dir[] = "/tmp/sphice-ims-cycle-XXXXXX";

/* sea ice in the map rectangle that holds the domain and 150 km more, but
 * 24 km (a cell) and more west of the case's coast, open water elsewhere */
static int bay(double x, double y, const void *ctx)
{
    const double *b = ctx;
    if (!(x > b[0] && x < b[1] && y > b[2] && y < b[3]))
        return 1;
    double lon, lat;
    rp_ps_inverse(IA, IB, 60, -80, x, y, &lon, &lat);
    return lon < EC_LAND_LON - 0.3 ? 3 : 1;
}

static struct sph_config *config_spacing(const char *ims_keys, int lattice)
{
    char ice[256], text[8192];
    snprintf(ice, sizeof ice, "ims1999039_00UTC_24km_v1.1.asc\", \"ims\": {%s}, \"format\": \"netcdf",
             ims_keys);
    ec_config(text, sizeof text, dir, 300, "[\"wind\", \"tair\"]", ice, "");
    /* per cell: 24 km cells are coarser than any lattice */
    char *at = strstr(text, "\"spacing\": 0.02");
    if (at && !lattice)
        memcpy(at, "\"spacing\": 0   ", 15);
    struct sph_config *cfg = NULL;
    sph_error err;
    sph_error_clear(&err);
    CHECK(sph_config_parse(text, "test", &cfg, &err) == SPH_OK, "config: %s", err.msg);
    return cfg;
}

static struct sph_config *config(const char *ims_keys) { return config_spacing(ims_keys, 0); }

/* A 2 h forecast of cfg into dir/name (stage) on the case's atmosphere. */
static int cycle(const struct sph_config *cfg, const char *name, forecast_result *res,
                 sph_error *err, char *stage, size_t len)
{
    static char atm_path[1100];
    static const char *atm[2] = {atm_path, NULL};
    snprintf(atm_path, sizeof atm_path, "%s/atm.nc", dir);
    snprintf(stage, len, "%s/%s", dir, name);
    forecast_request req = {.cycle_time = EC_CYCLE, .hours = 2, .stage_dir = stage,
                            .forcing_files = {atm}};
    forecast_progress prog = {0};
    sph_error_clear(err);
    return forecast_run(cfg, &req, &prog, NULL, res, err);
}

int main(int argc, char **argv)
{
    (void)argc;
    CHECK(ec_start(argv, dir) == 0, "mkdtemp");
    double box[4] = {HUGE_VAL, -HUGE_VAL, HUGE_VAL, -HUGE_VAL};
    for (int q = 0; q <= 4; q++)
        for (int p = 0; p <= 4; p++) {
            double x, y, k;
            rp_ps_forward(IA, IB, 60, -80, 121.0 + 0.25 * p, 40.0 + 0.15 * q, &x, &y, &k);
            box[0] = fmin(box[0], x - 150e3), box[1] = fmax(box[1], x + 150e3);
            box[2] = fmin(box[2], y - 150e3), box[3] = fmax(box[3], y + 150e3);
        }
    char path[1100], stage[1200];
    snprintf(path, sizeof path, "%s/ims1999039_00UTC_24km_v1.1.asc", dir);
    ims_write_ascii(path, &G24, G24.n, bay, box);

    struct sph_config *cfg = config("\"ice_concentration\": 0.8, \"ice_thickness\": 0.4");
    forecast_result res;
    sph_error err;
    int rc = cfg ? cycle(cfg, "ims", &res, &err, stage, sizeof stage) : -1;
    CHECK(rc == SPH_OK, "IMS cycle: %s", err.msg);
    if (rc == SPH_OK) {
        printf("IMS cycle: raster %.6g km2 %.6g km3, seeded %.6g km2 %.6g km3, %ld particles; "
               "assumed: %s\n", res.raster_ice_area_km2, res.raster_ice_volume_km3,
               res.seeded_ice_area_km2, res.seeded_ice_volume_km3, (long)res.run.particles_start,
               res.raster_assumed);
        CHECK(res.raster_ice_area_km2 > 1000, "raster ice area %g km2", res.raster_ice_area_km2);
        CHECK_CLOSE(res.raster_ice_volume_km3 * 1e3 / res.raster_ice_area_km2, 0.4, 1e-9, 0,
                    "the raster's ice is 0.4 m thick (initial.ims.ice_thickness)");
        CHECK_CLOSE(res.seeded_ice_area_km2, res.raster_ice_area_km2, 0.01, 0, "seeded area within 1 %");
        CHECK_CLOSE(res.seeded_ice_volume_km3, res.raster_ice_volume_km3, 0.01, 0,
                    "seeded volume within 1 %");
        CHECK(strstr(res.raster_assumed, "concentration 0.8 (initial.ims.ice_concentration)") &&
                  strstr(res.raster_assumed, "thickness 0.4 m (initial.ims.ice_thickness)"),
              "result: assumed \"%s\"", res.raster_assumed);
    }
    char *buf = NULL;
    size_t len = 0;
    FILE *f = cfg ? open_memstream(&buf, &len) : NULL;
    if (f) {
        service_check(cfg, EC_CYCLE, 0, f);
        fclose(f);
        CHECK(buf && strstr(buf, "assumed from the configuration: IMS ice cells (class 3): "
                                 "concentration 0.8"),
              "sphice check: %s", buf ? buf : "");
        free(buf);
    }
    sph_config_free(cfg);

    /* the lattice (0.02 deg, about 2 km) over 24 km cells: a cell at the
     * edge of the region the lattice tiles counts by the part of it inside
     * (the centre alone counted it whole or not at all: the raster's ice
     * came out 10.7 % below the lattice's own sample of it and the seeded
     * ice, scaled to it, 12.5 % below the raster's over the domain) */
    cfg = config_spacing("\"ice_concentration\": 0.8, \"ice_thickness\": 0.4", 1);
    rc = cfg ? cycle(cfg, "lattice", &res, &err, stage, sizeof stage) : -1;
    CHECK(rc == SPH_OK, "IMS lattice cycle: %s", err.msg);
    if (rc == SPH_OK) {
        printf("IMS lattice cycle: raster over the lattice's region %.6g km2 %.6g km3, the lattice's own sample "
               "%.6g km2 %.6g km3, seeded %.6g km2 %.6g km3, %ld particles\n", res.raster_ice_area_km2,
               res.raster_ice_volume_km3, res.lattice_raw_area_km2, res.lattice_raw_volume_km3,
               res.seeded_ice_area_km2, res.seeded_ice_volume_km3, (long)res.run.particles_start);
        CHECK_CLOSE(res.raster_ice_area_km2, res.lattice_raw_area_km2, 0.03, 0,
                    "the raster's ice over the lattice's region against the lattice's bilinear sample of it");
        CHECK_CLOSE(res.seeded_ice_area_km2, res.raster_ice_area_km2, 0.01, 0, "lattice: seeded area within 1 %");
        CHECK_CLOSE(res.seeded_ice_volume_km3, res.raster_ice_volume_km3, 0.01, 0,
                    "lattice: seeded volume within 1 %");
    }
    sph_config_free(cfg);

    /* without the ice cell's concentration: one line, nothing written */
    cfg = config("\"ice_thickness\": 0.4");
    rc = cfg ? cycle(cfg, "nokey", &res, &err, stage, sizeof stage) : -1;
    CHECK(rc != SPH_OK && strstr(err.msg, path) && strstr(err.msg, "initial.ims.ice_concentration") &&
              !strchr(err.msg, '\n'),
          "no key: rc %d: %s", rc, err.msg);
    int n = ec_count_entries(stage);
    CHECK(n <= 0, "no key: nothing written (%d entries)", n);
    printf("  no key -> %s\n", err.msg);
    sph_config_free(cfg);
    return check_summary("test_raster_ims_cycle");
}
