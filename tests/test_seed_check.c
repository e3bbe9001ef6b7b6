/* `sphice check` seeds as the cycle does, and the raster's own land in the
 * cycle (issue 19 items 4, 6, 7), on the engine's synthetic case
 * (tests/engine_case.h, land east of EC_LAND_LON from mask.nc):
 *  - a raster whose ice runs onto the land: check's seeded ice area and
 *    volume, and the raster's over the domain's sea, equal the cycle's
 *    (cycle.json's seeded_ice_area_km2 ...) for the lattice, one particle
 *    per cell and 2 x 2 per cell (initial.cell_particles); check used to
 *    seed without the land mask and reported the ice on land as seeded;
 *  - initial.cell_particles 2 seeds four particles per cell (less the
 *    sub-cells on land) and keeps the raster's area and volume within 1 %;
 *  - an NSIDC-CDR-shaped raster (tests/seed_cdr.h) with a land and coast
 *    strip the case's mask does not have: with landmask.source "raster"
 *    and with landmask.raster_land (in union with mask.nc) no particle
 *    starts in a flagged cell nor, for the union, on mask.nc's land, and
 *    check agrees with the cycle; a raster without flags is refused in one
 *    line naming the key. */
#include <cjson/cJSON.h>
#include <math.h>
#include <netcdf.h>
#include <stdlib.h>
#include <string.h>

#include "engine_case.h"
#include "io/landmask.h"
#include "io/products.h"
#include "seed_cdr.h"
#include "service/check.h"
#include "service/config.h"
#include "service/forecast.h"
#include "util/log.h"

static char dir[] = "/tmp/sphice-seedcheck-XXXXXX";
static const char *atm_files[2];

/* the case's configuration (time step case_dt) with `from` replaced by
 * `to` (twice at most) */
static double case_dt = 300;
static struct sph_config *load(const char *ice, const char *from, const char *to, const char *from2,
                               const char *to2)
{
    char text[8192];
    ec_config(text, sizeof text, dir, case_dt, "[\"wind\", \"tair\"]", ice, "");
    CHECK(ec_config_replace(text, sizeof text, from, to), "the case's configuration has %s", from);
    if (from2)
        CHECK(ec_config_replace(text, sizeof text, from2, to2), "the case's configuration has %s", from2);
    struct sph_config *cfg = NULL;
    sph_error err;
    sph_error_clear(&err);
    CHECK(sph_config_parse(text, "test", &cfg, &err) == SPH_OK, "config: %s", err.msg);
    return cfg;
}

static int run(const struct sph_config *cfg, const char *stage_name, forecast_result *res, sph_error *err,
               char *stage, size_t len)
{
    snprintf(stage, len, "%s/%s", dir, stage_name);
    forecast_request req;
    memset(&req, 0, sizeof req);
    req.cycle_time = EC_CYCLE;
    req.hours = 1;
    req.stage_dir = stage;
    req.forcing_files[0] = atm_files;
    forecast_progress prog;
    memset((void *)&prog, 0, sizeof prog);
    sph_error_clear(err);
    return forecast_run(cfg, &req, &prog, NULL, res, err);
}

/* `sphice check --json`'s initial_raster object (caller deletes root) */
static cJSON *check_json(const struct sph_config *cfg, cJSON **root)
{
    char *buf = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&buf, &len);
    *root = NULL;
    if (!f)
        return NULL;
    service_check(cfg, EC_CYCLE, 1, f);
    fclose(f);
    *root = cJSON_Parse(buf);
    free(buf);
    return *root ? cJSON_GetObjectItem(*root, "initial_raster") : NULL;
}

static double num(const cJSON *o, const char *name)
{
    const cJSON *v = o ? cJSON_GetObjectItem(o, name) : NULL;
    return cJSON_IsNumber(v) ? v->valuedouble : NAN;
}

/* the cycle's numbers against check's: the same seeding */
static void same_as_check(const char *what, const struct sph_config *cfg, const forecast_result *res)
{
    cJSON *root;
    cJSON *ir = check_json(cfg, &root);
    CHECK(ir != NULL, "%s: check's initial_raster", what);
    double sa = num(ir, "seeded_ice_area_km2"), sv = num(ir, "seeded_ice_volume_km3");
    double ra = num(ir, "domain_raster_ice_area_km2"), rv = num(ir, "domain_raster_ice_volume_km3");
    double n = num(ir, "seeded_particles"), fl = num(ir, "seeded_on_land_fraction");
    printf("%s: cycle seeded %ld particles %.9g km2 %.9g km3 (raster %.9g km2); check %g particles %.9g km2 "
           "%.9g km3 (raster %.9g km2), %.3g on land; raster over the whole domain %.6g km2\n", what,
           (long)res->run.particles_start, res->seeded_ice_area_km2, res->seeded_ice_volume_km3,
           res->raster_ice_area_km2, n, sa, sv, ra, fl, num(ir, "ice_area_km2"));
    CHECK_CLOSE(sa, res->seeded_ice_area_km2, 1e-9, 0, "check's seeded ice area is the cycle's");
    CHECK_CLOSE(sv, res->seeded_ice_volume_km3, 1e-9, 0, "check's seeded ice volume is the cycle's");
    CHECK_CLOSE(ra, res->raster_ice_area_km2, 1e-9, 0, "check's raster ice area is the cycle's");
    CHECK_CLOSE(rv, res->raster_ice_volume_km3, 1e-9, 0, "check's raster ice volume is the cycle's");
    CHECK(n == (double)res->run.particles_start, "%s: check seeds %g particles, the cycle %ld", what, n,
          (long)res->run.particles_start);
    CHECK(fl == 0, "%s: check: no particle seeded on the model's own land (fraction %g)", what, fl);
    cJSON_Delete(root);
}

/* Particles of the first output time: how many in a CDR flagged cell and
 * east of the case's coast (mask.nc's land). */
static void first_particles(const char *stage, size_t *n, size_t *flagged, size_t *east)
{
    char p[1200];
    snprintf(p, sizeof p, "%s/sphice_particles.nc", stage);
    prod_particles pp;
    memset(&pp, 0, sizeof pp);
    sph_error err;
    sph_error_clear(&err);
    *n = *flagged = *east = 0;
    CHECK(products_read_particles(p, EC_CYCLE, &pp, &err) == SPH_OK, "read %s: %s", p, err.msg);
    for (size_t k = 0; k < pp.n; k++) {
        int i, jn;
        cdr_cell(pp.lon[k], pp.lat[k], &i, &jn);
        *flagged += i >= 0 && jn >= 0 && i < CX && jn < CY && cdr_raw(i, jn) > 250;
        *east += pp.lon[k] > EC_LAND_LON + 0.005; /* the mask's land cells */
    }
    *n = pp.n;
    prod_particles_free(&pp);
}

int main(int argc, char **argv)
{
    (void)argc;
    CHECK(ec_start(argv, dir) == 0, "mkdtemp %s", dir);
    char atm[1024], p[1024], stage[1100];
    snprintf(atm, sizeof atm, "%s/atm.nc", dir);
    atm_files[0] = atm;
    atm_files[1] = NULL;
    /* ice from 121.201 E to 122.001 E: over the coast at EC_LAND_LON */
    snprintf(p, sizeof p, "%s/coast.nc", dir);
    ec_write_ice_at(p, 41, 21, 121.201, 40.1, 0.02, 0.02, EC_CONC, EC_THICK, -1);
    snprintf(p, sizeof p, "%s/cdr.nc", dir);
    write_cdr(p);

    const char *modes[3] = {"\"spacing\": 0.02", "\"spacing\": 0", "\"spacing\": 0.02, \"cell_particles\": 2"};
    long n_cells = 0;
    for (int s = 0; s < 3; s++) {
        case_dt = s == 2 ? 120 : 300; /* the stable step of the finer spacing */
        struct sph_config *cfg = load("coast.nc", "\"spacing\": 0.02", modes[s], "\"threshold\": 0.15",
                                      "\"threshold\": 0.15");
        forecast_result res;
        sph_error err;
        char name[16];
        snprintf(name, sizeof name, "coast%d", s);
        int rc = cfg ? run(cfg, name, &res, &err, stage, sizeof stage) : -1;
        CHECK(rc == SPH_OK, "%s: %s", modes[s], err.msg);
        if (rc == SPH_OK) {
            printf("  %s: %.3g on land at the end, flag \"%s\"\n", modes[s], res.land_fraction, res.quality_flag);
            same_as_check(modes[s], cfg, &res);
            CHECK(!res.quality_flag[0] && res.land_fraction <= 0.01,
                  "%s: not flagged (\"%s\"), %.3g on land at the end", modes[s], res.quality_flag, res.land_fraction);
            CHECK_CLOSE(res.seeded_ice_area_km2, res.raster_ice_area_km2, 0.01, 0,
                        "seeded ice area within 1 % of the raster's over the domain's sea");
            CHECK_CLOSE(res.seeded_ice_volume_km3, res.raster_ice_volume_km3, 0.01, 0,
                        "seeded ice volume within 1 % of the raster's over the domain's sea");
            if (s == 1)
                n_cells = (long)res.run.particles_start;
            if (s == 2) /* four per cell, less the sub-cells on land */
                CHECK(res.run.particles_start > 3 * n_cells && res.run.particles_start < 4 * n_cells + 4 * 21,
                      "2 x 2 per cell: %ld particles, %ld cells", (long)res.run.particles_start, n_cells);
        }
        sph_config_free(cfg);
    }

    /* the CDR's own land: alone, and in union with mask.nc */
    const char *lm[2] = {"{\"source\": \"raster\", ", "{\"source\": \"netcdf\", \"raster_land\": true, "};
    for (int u = 0; u < 2; u++) {
        struct sph_config *cfg = load("cdr.nc", "{\"source\": \"netcdf\", ", lm[u], NULL, NULL);
        forecast_result res;
        sph_error err;
        int rc = cfg ? run(cfg, u ? "cdr_union" : "cdr_raster", &res, &err, stage, sizeof stage) : -1;
        CHECK(rc == SPH_OK, "CDR, %s: %s", u ? "raster_land" : "source raster", err.msg);
        if (rc == SPH_OK) {
            size_t n, flagged, east;
            first_particles(stage, &n, &flagged, &east);
            printf("CDR, %s: %zu particles, %zu in flagged cells, %zu on mask.nc's land\n",
                   u ? "landmask.raster_land with mask.nc" : "landmask.source raster", n, flagged, east);
            CHECK(n > 100, "CDR: particles seeded (%zu)", n);
            CHECK(flagged == 0, "CDR: no particle in a cell the raster flags land, coast or lake (%zu)", flagged);
            if (u)
                CHECK(east == 0, "CDR, union: no particle on mask.nc's land (%zu)", east);
            same_as_check(u ? "CDR, raster_land" : "CDR, source raster", cfg, &res);
        }
        sph_config_free(cfg);
    }

    /* a raster without flags and landmask.raster_land: one line, nothing published */
    {
        struct sph_config *cfg = load("ice.nc", "{\"source\": \"netcdf\", ", "{\"source\": \"netcdf\", "
                                      "\"raster_land\": true, ", NULL, NULL);
        forecast_result res;
        sph_error err;
        int rc = cfg ? run(cfg, "noflags", &res, &err, stage, sizeof stage) : -1;
        CHECK(rc != SPH_OK && strstr(err.msg, "landmask.raster_land") && strstr(err.msg, "ice.nc") &&
              !strchr(err.msg, '\n'), "no flags: rc %d, one line naming the key and the raster: %s", rc, err.msg);
        int ne = ec_count_entries(stage);
        CHECK(ne <= 0, "no flags: nothing written (%d entries)", ne);
        printf("  no flags -> %s\n", err.msg);
        sph_config_free(cfg);
    }
    return check_summary("test_seed_check");
}
