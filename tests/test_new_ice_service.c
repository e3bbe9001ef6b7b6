/* The mixed layer in a forecast (issue 20): the small synthetic case of
 * tests/engine_case.h with an ocean source written as Copernicus Marine
 * documents its physics product (mlotst: ocean_mixed_layer_thickness_
 * defined_by_sigma_theta, m; deptho: sea_floor_depth_below_geoid, m;
 * uo/vo currents). A good run keeps the energy, water and salt budgets of
 * ice plus ocean to round-off and reports them in the result; a negative
 * mixed-layer depth and a bathymetry that is land where the land mask says
 * sea are refused with one line naming the file and the variable, and
 * nothing is written; so is model.new_ice.create with plain continuity
 * density (one line naming model.density_reinit_steps: docs/ocean.md),
 * while continuity with the density re-initialised by summation every 6
 * steps runs and closes the same budgets. */
#include <math.h>
#include <netcdf.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "engine_case.h"
#include "service/config.h"
#include "service/forecast.h"
#include "util/log.h"

static char dir[] = "/tmp/sphice-newice-XXXXXX";
static int ocean_case; /* 0 good, 1 negative MLD, 2 bathymetry land at sea */

static double ocn_fn(int which, double lon, double lat, size_t k)
{
    (void)lat; (void)k;
    if (which < 2)
        return 0.0;
    if (which == 2)
        return ocean_case == 1 && lon < 121.4 ? -5.0 : 12.0; /* mlotst */
    return ocean_case == 2 && lon < 121.3 ? 0.0 : 8.0 + 20.0 * (lon - 120.9); /* deptho */
}

static void write_ocean(const char *path)
{
    tgrid g;
    ec_ocean_grid(&g); /* the case's ocean grid, hourly */
    tvar v[4];
    v[0] = (tvar){"uo", "eastward_sea_water_velocity", "m s-1", NC_FLOAT, 0, 0, 1, -999.0, 0, ocn_fn, 0};
    v[1] = (tvar){"vo", "northward_sea_water_velocity", "m s-1", NC_FLOAT, 0, 0, 1, -999.0, 0, ocn_fn, 1};
    v[2] = (tvar){"mlotst", "ocean_mixed_layer_thickness_defined_by_sigma_theta", "m", NC_FLOAT, 0, 0, 1,
                  -999.0, 0, ocn_fn, 2};
    v[3] = (tvar){"deptho", "sea_floor_depth_below_geoid", "m", NC_FLOAT, 0, 0, 1, -999.0, 0, ocn_fn, 3};
    tnc_write(path, &g, v, 4, 0, 13, NC_NETCDF4);
}

/* summation: 1 summation density, 0 plain continuity, 2 continuity re-initialised by summation every 6 steps */
static struct sph_config *load_density(int summation)
{
    char text[8192], src[1200];
    snprintf(src, sizeof src, ", {\"name\": \"ocean\", \"kind\": \"ocean\", \"urls\": \"%s/ocean_ml.nc\"}", dir);
    ec_config_more(text, sizeof text, dir, 300, "[\"wind\", \"tair\"]", "ice.nc", "\"log_level\": \"warn\",",
                   summation == 1 ? ", \"summation_density\": true, \"ocean\": {\"mixed_layer\": true, \"depth\": 30}, "
                                    "\"new_ice\": {\"create\": true}"
                   : summation == 2 ? ", \"density_reinit_steps\": 6, \"ocean\": {\"mixed_layer\": true, \"depth\": 30}, "
                                      "\"new_ice\": {\"create\": true}"
                                    : ", \"ocean\": {\"mixed_layer\": true, \"depth\": 30}, \"new_ice\": {\"create\": true}",
                   src);
    struct sph_config *cfg = NULL;
    sph_error err = {0};
    if (sph_config_parse(text, "test", &cfg, &err) != SPH_OK)
        CHECK(0, "config: %s", err.msg);
    return cfg;
}

static struct sph_config *load(void) { return load_density(1); }

static int run(const struct sph_config *cfg, const char *stage_name, forecast_result *res, sph_error *err,
               char *stage, size_t len)
{
    static char atm[1024], ocn[1024];
    snprintf(atm, sizeof atm, "%s/atm.nc", dir);
    snprintf(ocn, sizeof ocn, "%s/ocean_ml.nc", dir);
    static const char *atm_files[2], *ocn_files[2];
    atm_files[0] = atm;
    ocn_files[0] = ocn;
    snprintf(stage, len, "%s/%s", dir, stage_name);
    forecast_request req = {.cycle_time = EC_CYCLE, .hours = 6, .stage_dir = stage,
                            .forcing_files = {atm_files, ocn_files}};
    forecast_progress prog;
    memset((void *)&prog, 0, sizeof prog);
    sph_error_clear(err);
    return forecast_run(cfg, &req, &prog, NULL, res, err);
}

static void refused(const struct sph_config *cfg, const char *name, const char *var)
{
    forecast_result res;
    sph_error err;
    char stage[1200];
    memset(&res, 0, sizeof res);
    int rc = run(cfg, name, &res, &err, stage, sizeof stage);
    CHECK(rc != SPH_OK, "%s: refused", name);
    CHECK(strstr(err.msg, "ocean_ml.nc") && strstr(err.msg, var), "%s: names file and variable: %s", name,
          err.msg);
    CHECK(!strchr(err.msg, '\n'), "%s: one line", name);
    int n = ec_count_entries(stage);
    CHECK(n <= 0, "%s: nothing written (%d entries)", name, n);
    printf("%s: %s\n", name, err.msg);
}

int main(int argc, char **argv)
{
    (void)argc;
    CHECK(ec_start(argv, dir) == 0, "mkdtemp");
    char p[1200];
    snprintf(p, sizeof p, "%s/ocean_ml.nc", dir);
    struct sph_config *cfg = load();
    if (!cfg)
        return check_summary("test_new_ice_service");

    ocean_case = 0;
    write_ocean(p);
    forecast_result res;
    sph_error err;
    char stage[1200];
    memset(&res, 0, sizeof res);
    int rc = run(cfg, "good", &res, &err, stage, sizeof stage);
    CHECK(rc == SPH_OK, "good run: %s", err.msg);
    CHECK(res.run.ocean == 1, "the mixed layer's budgets are in the result");
    CHECK(res.run.energy_residual < 1e-12 && res.run.water_residual < 1e-12 && res.run.salt_residual < 1e-12,
          "budgets close: energy %g water %g salt %g", res.run.energy_residual, res.run.water_residual,
          res.run.salt_residual);
    printf("good run: %ld -> %ld particles, residuals energy %.2e water %.2e salt %.2e\n", res.run.particles_start,
           res.run.particles_end, res.run.energy_residual, res.run.water_residual, res.run.salt_residual);

    /* thermo.snow_heat_capacity with the mixed layer: no longer refused,
     * the slab's budget counts the snow's enthalpy (issue 20) */
    cfg->model.thermo.snow_heat_capacity = 1;
    memset(&res, 0, sizeof res);
    rc = run(cfg, "snow_heat", &res, &err, stage, sizeof stage);
    CHECK(rc == SPH_OK, "mixed layer with thermo.snow_heat_capacity runs: %s", err.msg);
    CHECK(rc != SPH_OK || (res.run.energy_residual < 1e-12 && res.run.water_residual < 1e-12),
          "snow heat capacity: budgets close: energy %g water %g", res.run.energy_residual, res.run.water_residual);
    cfg->model.thermo.snow_heat_capacity = 0;

    ocean_case = 1;
    write_ocean(p);
    refused(cfg, "negative_mld", "mlotst");
    ocean_case = 2;
    write_ocean(p);
    refused(cfg, "bathymetry_land", "deptho");
    sph_config_free(cfg);

    /* new particles with plain continuity density: refused, naming the key */
    ocean_case = 0;
    write_ocean(p);
    cfg = load_density(0);
    if (cfg) {
        memset(&res, 0, sizeof res);
        rc = run(cfg, "continuity", &res, &err, stage, sizeof stage);
        CHECK(rc != SPH_OK, "continuity density with model.new_ice.create: refused");
        CHECK(strstr(err.msg, "model.density_reinit_steps") && strstr(err.msg, "model.new_ice.create"),
              "names the keys: %s", err.msg);
        CHECK(!strchr(err.msg, '\n'), "one line");
        CHECK(ec_count_entries(stage) <= 0, "nothing written");
        printf("continuity: %s\n", err.msg);
        sph_config_free(cfg);
    }
    /* continuity re-initialised by summation every 6 steps: runs, the budgets close */
    cfg = load_density(2);
    if (cfg) {
        memset(&res, 0, sizeof res);
        rc = run(cfg, "reinit", &res, &err, stage, sizeof stage);
        CHECK(rc == SPH_OK, "continuity with model.density_reinit_steps 6 and model.new_ice.create runs: %s",
              err.msg);
        CHECK(rc != SPH_OK || (res.run.ocean == 1 && res.run.energy_residual < 1e-12 &&
                               res.run.water_residual < 1e-12 && res.run.salt_residual < 1e-12),
              "re-initialised continuity: budgets close: energy %g water %g salt %g", res.run.energy_residual,
              res.run.water_residual, res.run.salt_residual);
        sph_config_free(cfg);
    }
    return check_summary("test_new_ice_service");
}
