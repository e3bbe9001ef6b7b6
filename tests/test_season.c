/* The freeze-up scene in small (issue 20 item 6, docs/season.md): a
 * forecast that starts from OPEN WATER (an ice raster with no ice) with the
 * mixed layer, new ice and merging on, over a sea whose depth the test
 * writes: 3 m at the coast (land east of EC_LAND_LON) deepening linearly
 * westwards to 33 m, uniform SST 0 C, a uniform atmosphere at -15 C with a
 * 6 m/s onshore (westerly) wind, no radiation files.
 *
 * What holds from outside the code: with the same air over every cell and
 * every cell at the same temperature, each slab cools at a rate inversely
 * proportional to its depth (rho c d dT/dt = -F(T), F the same function
 * of T everywhere), so a slab of depth d reaches its freezing point at
 * t = d tau (tau a constant) and the frazil then needs the same time
 * everywhere: ice must appear first over the shallowest water and spread
 * to deeper water later. Asserted: no ice at the first output time (the
 * result says an open-water start); at the first output time with ice,
 * every ice cell lies over water shallower than the sea's median depth
 * and the mean depth under the ice is below the sea's mean; later, the
 * ice reaches deeper water; the energy, water and salt budgets of ice plus
 * ocean close to 1e-10 relative; maps at map_times 0 and 48 h are drawn
 * 48 h apart (not daily). SPHICE_LONG=1: the same for 30 days, the
 * sea then almost covered (at least 90 % of the sea cells), particle count
 * at most the lattice's sea points (merging on).
 *
 * Each case runs twice: with summation density, and with continuity density
 * re-initialised by summation every 6 steps (model.density_reinit_steps,
 * docs/ocean.md): the same assertions for both, and the two compared (see
 * compare(): volume within 5 %, area within 5 % plus the share of the ice
 * at its edge). SPHICE_LONG also runs the bundled scene both ways (see
 * scene_compare()).
 */
#include <math.h>
#include <netcdf.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "engine_case.h"
#include "service/config.h"
#include "service/forecast.h"
#include "util/log.h"

static char dir[] = "/tmp/sphice-season-XXXXXX";

#define SHORE_M 3.0
#define DEEP_M 33.0
#define AIR_K 258.15 /* -15 C */

/* The test's bathymetry: linear in longitude from the coast westwards. */
static double depth_at(double lon)
{
    double d = SHORE_M + (DEEP_M - SHORE_M) * (EC_LAND_LON - lon) / (EC_LAND_LON - 121.0);
    return d < SHORE_M ? SHORE_M : d;
}

static double atm_fn(int which, double lon, double lat, size_t k)
{
    (void)lon; (void)lat; (void)k;
    return which == 0 ? 6.0 : which == 1 ? 0.0 : AIR_K;
}

static double ocn_fn(int which, double lon, double lat, size_t k)
{
    (void)lat; (void)k;
    return which == 0 ? 0.0 : depth_at(lon); /* tos (deg C), deptho (m) */
}

static void write_inputs(double hours)
{
    char p[1200];
    snprintf(p, sizeof p, "%s/atm.nc", dir);
    ec_write_atm_grid(p, "hours since 1999-02-08 00:00:00", 3.0, (size_t)hours + 7, NC_NETCDF4, 120.75, 39.75, 7, 5,
                      atm_fn);
    snprintf(p, sizeof p, "%s/mask.nc", dir);
    ec_write_mask(p);
    snprintf(p, sizeof p, "%s/ice0.nc", dir); /* open water: no ice anywhere */
    ec_write_ice_at(p, 31, 21, 121.2, 40.1, 0.02, 0.02, 0.0, 0.0, -1);
    tgrid g;
    ec_ocean_grid(&g); /* 0.05 deg over the case, from 3 h before the cycle */
    g.dtv = 24.0;   /* daily: the fields are constant */
    tvar v[2];
    v[0] = (tvar){"tos", "sea_surface_temperature", "degC", NC_FLOAT, 0, 0, 1, -999.0, 0, ocn_fn, 0};
    v[1] = (tvar){"deptho", "sea_floor_depth_below_sea_surface", "m", NC_FLOAT, 0, 0, 1, -999.0, 0, ocn_fn, 1};
    snprintf(p, sizeof p, "%s/ocean.nc", dir);
    tnc_write(p, &g, v, 2, 0, (size_t)(hours / 24.0) + 3, NC_NETCDF4);
}

/* SPHICE_LONG: the bundled scene itself (sh tools/demo_season.sh into dir/scene): the ice under
 * the first new particles lies over shallower water than the sea's mean and than the last
 * period's new ice; the budgets close to 1e-10. Its numbers: docs/season.md. */
static double dat_value(const char *text, const char *key)
{
    const char *q = strstr(text, key);
    return q ? strtod(q + strlen(key), NULL) : NAN;
}

/* The share of the ice cells of one field (sea: not land and west of lon_max) that touch a sea cell
 * without ice (4-neighbours). */
static double edge_share_of(const float *c, const signed char *land, const double *lon, size_t nx, size_t ny,
                            double lon_max)
{
    size_t edge = 0, ice = 0;
    for (size_t j = 0; j < ny; j++)
        for (size_t i = 0; i < nx; i++) {
            if (land[j * nx + i] || lon[i] >= lon_max || !(c[j * nx + i] > 0.0f))
                continue;
            ice++;
            int open = 0;
            const long di[4] = {1, -1, 0, 0}, dj[4] = {0, 0, 1, -1};
            for (int q = 0; q < 4; q++) {
                long ii = (long)i + di[q], jj = (long)j + dj[q];
                if (ii < 0 || jj < 0 || ii >= (long)nx || jj >= (long)ny)
                    continue;
                size_t w = (size_t)jj * nx + (size_t)ii;
                open |= !land[w] && lon[ii] < lon_max && !(c[w] > 0.0f);
            }
            edge += (size_t)open;
        }
    return ice ? (double)edge / (double)ice : NAN;
}

/* The edge share (edge_share_of) of the last time of a run's sphice_fields.nc; NaN if unreadable. */
static double fields_edge_share(const char *path)
{
    int nc, v, d[3];
    size_t nt, ny, nx;
    if (nc_open(path, NC_NOWRITE, &nc) != NC_NOERR)
        return NAN;
    double share = NAN;
    if (nc_inq_varid(nc, "siconc", &v) == NC_NOERR && nc_inq_vardimid(nc, v, d) == NC_NOERR &&
        nc_inq_dimlen(nc, d[0], &nt) == NC_NOERR && nc_inq_dimlen(nc, d[1], &ny) == NC_NOERR &&
        nc_inq_dimlen(nc, d[2], &nx) == NC_NOERR && nt > 0) {
        float *c = malloc(ny * nx * sizeof *c);
        double *lon = malloc(nx * sizeof *lon);
        signed char *land = malloc(ny * nx);
        size_t st[3] = {nt - 1, 0, 0}, ct[3] = {1, ny, nx};
        int lv, ov;
        if (c && lon && land && nc_get_vara_float(nc, v, st, ct, c) == NC_NOERR &&
            nc_inq_varid(nc, "lon", &ov) == NC_NOERR && nc_get_var_double(nc, ov, lon) == NC_NOERR &&
            nc_inq_varid(nc, "landmask", &lv) == NC_NOERR && nc_get_var_schar(nc, lv, land) == NC_NOERR)
            share = edge_share_of(c, land, lon, nx, ny, 1e9);
        free(c);
        free(lon);
        free(land);
    }
    nc_close(nc);
    return share;
}

/* reinit 0: the scene as bundled (summation density); N > 0: continuity re-initialised every N steps
 * (SEASON_DENSITY_REINIT). last[4]: the last output's ice area km^2, volume km^3, particles, and the
 * share of its ice cells at the ice edge (edge_share_of). */
static void bundled_scene(int reinit, double last[4])
{
    char cmd[1600], p[1300];
    last[0] = last[1] = last[2] = last[3] = NAN;
    snprintf(cmd, sizeof cmd, "SEASON_DENSITY_REINIT=%d SEASON_OUT=%s/scene%d sh tools/demo_season.sh > %s/scene%d.log 2>&1",
             reinit, dir, reinit, dir, reinit);
    int rc = system(cmd);
    CHECK(rc == 0, "the bundled scene ran (%s; log %s/scene%d.log)", cmd, dir, reinit);
    if (rc != 0)
        return;
    static char text[65536];
    snprintf(p, sizeof p, "%s/scene%d/season.dat", dir, reinit);
    FILE *f = fopen(p, "r");
    size_t n = f ? fread(text, 1, sizeof text - 1, f) : 0;
    if (f)
        fclose(f);
    text[n] = '\0';
    for (const char *line = text; *line;) { /* the last data line: hours area volume particles ... */
        const char *nl = strchr(line, '\n');
        if (*line != '#' && *line != '\n' && *line) {
            double h;
            if (sscanf(line, "%lf %lf %lf %lf", &h, &last[0], &last[1], &last[2]) != 4)
                last[0] = last[1] = last[2] = NAN;
        }
        if (!nl)
            break;
        line = nl + 1;
    }
    double d05 = dat_value(text, "days 0-5: "), d2030 = dat_value(text, "days 20-30: ");
    const char *m05 = strstr(text, "days 0-5: "), *m2030 = strstr(text, "days 20-30: ");
    double z05 = m05 ? dat_value(m05, "mean depth under them ") : NAN;
    double z2030 = m2030 ? dat_value(m2030, "mean depth under them ") : NAN;
    double sea = dat_value(text, "(deeper than the 2 m shore): ");
    printf("bundled scene: new particles days 0-5 %g at %.2f m, days 20-30 %g at %.2f m; sea %.2f m\n", d05, z05,
           d2030, z2030, sea);
    CHECK(d05 > 0 && z05 < 0.5 * sea && z05 < z2030, "first ice over shallow water: %.2f m (sea %.2f, last %.2f)",
          z05, sea, z2030);
    snprintf(p, sizeof p, "%s/scene%d/run/20001201T00Z/sphice_fields.nc", dir, reinit);
    last[3] = fields_edge_share(p);
    snprintf(p, sizeof p, "%s/scene%d/run/20001201T00Z/cycle.json", dir, reinit);
    f = fopen(p, "r");
    n = f ? fread(text, 1, sizeof text - 1, f) : 0;
    if (f)
        fclose(f);
    text[n] = '\0';
    double er = dat_value(text, "\"energy_budget_residual\":"), wr = dat_value(text, "\"water_budget_residual\":");
    double sr = dat_value(text, "\"salt_budget_residual\":");
    CHECK(er < 1e-10 && wr < 1e-10 && sr < 1e-10, "bundled scene budgets: energy %g water %g salt %g", er, wr, sr);
}

/* One run of the case: summation density (reinit 0) or continuity with
 * the density re-initialised by summation every `reinit` steps; the
 * assertions above for either, its result in *res; *edge_share: the
 * share of the last output's ice cells (the output grid's spacing is the
 * lattice's, 0.02 deg) that touch a sea cell without ice (4-neighbours). */
static void season_case(int reinit, double hours, int lng, forecast_result *res, double *edge_share)
{
    *edge_share = NAN;
    char dens_cont[512];
    snprintf(dens_cont, sizeof dens_cont,
             ", \"summation_density\": false, \"density_reinit_steps\": %d, \"ocean\": {\"mixed_layer\": true, "
             "\"depth\": 40, \"min_depth\": 3}, \"new_ice\": {\"create\": true, \"merge\": true}", reinit);
    const char *dens_sum = ", \"summation_density\": true, \"ocean\": {\"mixed_layer\": true, \"depth\": 40, "
                           "\"min_depth\": 3}, \"new_ice\": {\"create\": true, \"merge\": true}";
    printf("--- %s\n", reinit > 0 ? "continuity density, re-initialised by summation" : "summation density");
    char text[8192], src[1200];
    snprintf(src, sizeof src,
             ", {\"name\": \"ocean\", \"kind\": \"ocean\", \"urls\": \"%s/ocean.nc\", \"required\": [\"sst\"]}", dir);
    ec_config_more(text, sizeof text, dir, 300, "[\"wind\", \"tair\"]", "ice0.nc", "\"log_level\": \"warn\",",
                   reinit > 0 ? dens_cont : dens_sum, src);
    struct sph_config *cfg = NULL;
    sph_error err = {0};
    if (sph_config_parse(text, "test", &cfg, &err) != SPH_OK) {
        CHECK(0, "config: %s", err.msg);
        return;
    }
    cfg->output.interval_hours = lng ? 24 : 3;
    cfg->output.products.particles = 0;
    cfg->output.products.geojson = 0;
    /* maps at 0 and 48 h (the scene draws them 120 h apart): a gap of map_times longer than a
     * day draws maps at that gap, not daily (src/service/forecast_output.c) */
    cfg->output.products.maps = !lng;
    free(cfg->output.map_times.v);
    cfg->output.map_times.v = malloc(2 * sizeof(double));
    if (!cfg->output.map_times.v)
        { CHECK(0, "memory"); return; }
    cfg->output.map_times.v[0] = 0.0;
    cfg->output.map_times.v[1] = 48.0;
    cfg->output.map_times.n = 2;

    char atm[1024], ocn[1024], stage[1200];
    snprintf(atm, sizeof atm, "%s/atm.nc", dir);
    snprintf(ocn, sizeof ocn, "%s/ocean.nc", dir);
    const char *atm_files[2] = {atm, NULL}, *ocn_files[2] = {ocn, NULL};
    snprintf(stage, sizeof stage, "%s/run%d", dir, reinit);
    forecast_request req = {.cycle_time = EC_CYCLE, .hours = hours, .stage_dir = stage,
                            .forcing_files = {atm_files, ocn_files}};
    forecast_progress prog;
    memset((void *)&prog, 0, sizeof prog);
    memset(res, 0, sizeof *res);
    int rc = forecast_run(cfg, &req, &prog, NULL, res, &err);
    CHECK(rc == SPH_OK, "season run: %s", err.msg);
    if (rc != SPH_OK) {
        sph_config_free(cfg);
        return;
    }
    CHECK(res->open_water == 1, "the run says it started from open water");
    CHECK(res->run.particles_start == 0, "no particle at t0 (%ld)", res->run.particles_start);
    CHECK(res->run.ocean == 1, "the mixed layer's budgets are in the result");
    CHECK(res->run.energy_residual < 1e-10 && res->run.water_residual < 1e-10 && res->run.salt_residual < 1e-10,
          "budgets close: energy %.3g water %.3g salt %.3g", res->run.energy_residual, res->run.water_residual,
          res->run.salt_residual);

    /* the fields: siconc(time, lat, lon), landmask(lat, lon), lon */
    char fp[1300];
    snprintf(fp, sizeof fp, "%s/sphice_fields.nc", stage);
    int nc, v, d[3];
    size_t nt, ny, nx;
    NCW(nc_open(fp, NC_NOWRITE, &nc));
    NCW(nc_inq_varid(nc, "siconc", &v));
    NCW(nc_inq_vardimid(nc, v, d));
    NCW(nc_inq_dimlen(nc, d[0], &nt));
    NCW(nc_inq_dimlen(nc, d[1], &ny));
    NCW(nc_inq_dimlen(nc, d[2], &nx));
    float *c = malloc(nt * ny * nx * sizeof *c);
    double *lon = malloc(nx * sizeof *lon);
    signed char *land = malloc(ny * nx);
    if (!c || !lon || !land)
        { CHECK(0, "memory"); return; }
    NCW(nc_get_var_float(nc, v, c));
    NCW(nc_inq_varid(nc, "lon", &v));
    NCW(nc_get_var_double(nc, v, lon));
    NCW(nc_inq_varid(nc, "landmask", &v));
    NCW(nc_get_var_schar(nc, v, land));
    NCW(nc_close(nc));

    /* the sea's depths (the test's formula at the cells' longitudes) */
    double sum = 0;
    size_t nsea = 0;
    double *ds = malloc(ny * nx * sizeof *ds);
    if (!ds)
        { CHECK(0, "memory"); return; }
    for (size_t j = 0; j < ny; j++)
        for (size_t i = 0; i < nx; i++)
            if (!land[j * nx + i] && lon[i] < EC_LAND_LON) {
                ds[nsea++] = depth_at(lon[i]);
                sum += depth_at(lon[i]);
            }
    double mean_sea = sum / (double)nsea;
    /* median: the depth is linear in longitude over a rectangle of sea, so the middle longitude's */
    double lo = 1e9, hi = -1e9;
    for (size_t q = 0; q < nsea; q++) {
        lo = fmin(lo, ds[q]);
        hi = fmax(hi, ds[q]);
    }
    double median = 0.5 * (lo + hi);

    size_t first = nt, cells0 = 0;
    double maxd_first = 0, meand_first = 0, maxd_last = 0;
    size_t ice_last = 0;
    for (size_t k = 0; k < nt; k++) {
        size_t n = 0;
        double s = 0, mx = 0;
        for (size_t j = 0; j < ny; j++)
            for (size_t i = 0; i < nx; i++) {
                float ck = c[(k * ny + j) * nx + i];
                if (land[j * nx + i] || lon[i] >= EC_LAND_LON || !(ck > 0.0f))
                    continue;
                n++;
                s += depth_at(lon[i]);
                mx = fmax(mx, depth_at(lon[i]));
            }
        if (k == 0)
            cells0 = n;
        if (n && first == nt) {
            first = k;
            maxd_first = mx;
            meand_first = s / (double)n;
            printf("first ice at output %zu (%g h): %zu cells, depth under it mean %.2f m, max %.2f m; "
                   "sea mean %.2f m, median %.2f m\n", k, k * (double)cfg->output.interval_hours, n, meand_first,
                   maxd_first, mean_sea, median);
        }
        if (k == nt - 1) {
            maxd_last = mx;
            ice_last = n;
            *edge_share = edge_share_of(c + k * ny * nx, land, lon, nx, ny, EC_LAND_LON);
            printf("last output (%g h): %zu of %zu sea cells with ice, deepest water under ice %.2f m; "
                   "particles %ld -> %ld; residuals energy %.2e water %.2e salt %.2e\n",
                   k * (double)cfg->output.interval_hours, n, nsea, mx, res->run.particles_start,
                   res->run.particles_end,
                   res->run.energy_residual, res->run.water_residual, res->run.salt_residual);
        }
    }
    if (!lng) { /* cycle 1999-02-08 06Z: maps at 0 and 48 h, and the last time (66 h) */
        static const char *const want[] = {"19990208T0600Z", "19990210T0600Z", "19990211T0000Z"};
        static const char *const not_want[] = {"19990209T0600Z", "19990208T0900Z"};
        char q[1400];
        for (int w = 0; w < 3; w++) {
            snprintf(q, sizeof q, "%s/sphice_quicklook_%s.png", stage, want[w]);
            CHECK(access(q, F_OK) == 0, "map at %s drawn", want[w]);
        }
        for (int w = 0; w < 2; w++) {
            snprintf(q, sizeof q, "%s/sphice_quicklook_%s.png", stage, not_want[w]);
            CHECK(access(q, F_OK) != 0, "no map at %s (maps 48 h apart)", not_want[w]);
        }
    }
    CHECK(cells0 == 0, "no ice at t0 (%zu cells)", cells0);
    CHECK(first > 0 && first < nt, "ice appears during the run (first output with ice %zu of %zu)", first, nt);
    CHECK(maxd_first < median, "the first ice lies over the shallower half of the sea: deepest %.2f m < median %.2f m",
          maxd_first, median);
    CHECK(meand_first < mean_sea, "mean depth under the first ice %.2f m < the sea's mean %.2f m", meand_first,
          mean_sea);
    CHECK(maxd_last > maxd_first, "the ice reaches deeper water later: %.2f m > %.2f m", maxd_last, maxd_first);
    if (lng) {
        CHECK(ice_last >= 0.9 * (double)nsea, "after 30 days ice covers the sea: %zu of %zu cells", ice_last, nsea);
        /* the lattice's sea points: 0.02 deg spacing over the box; merging keeps the count below them */
        CHECK(res->run.particles_end <= 51 * 31, "particle count bounded: %ld", res->run.particles_end);
    }
    free(c);
    free(lon);
    free(land);
    free(ds);
    sph_config_free(cfg);
}

/* Continuity re-initialised by summation (model.density_reinit_steps) against summation density: two
 * discretisations of the same column physics over the same slabs. The volume comes from the columns and
 * the slabs' heat, which the density option does not enter: within 5 % (the tolerance of the
 * column against Icepack's Bitz-Lipscomb column). The ice area differs also by where the leads lie: at
 * the edge of the ice summation spreads a particle's mass per area over its kernel, continuity keeps it
 * on the particle, so the area may differ by the share of the ice within one lattice spacing of its edge
 * (the edge cells of the output grid, whose spacing is the lattice's) on top of the 5 %. The particle
 * counts: both bounded by the lattice's sea points. */
#define REINIT_STEPS 6
static void compare(const forecast_result *sum, const forecast_result *cont, double edge_share)
{
    double dv = fabs(cont->ice_volume_km3 - sum->ice_volume_km3) / sum->ice_volume_km3;
    double da = fabs(cont->ice_area_km2 - sum->ice_area_km2) / sum->ice_area_km2;
    double tol_a = 0.05 + edge_share;
    printf("continuity (re-initialised every %d steps) against summation: volume %.5g against %.5g km3 (%.2f %%), "
           "area %.5g against %.5g km2 (%.2f %%; tolerance %.2f %%: 5 %% + the edge share %.2f %%), particles %ld "
           "against %ld; residuals energy %.2e water %.2e salt %.2e\n",
           REINIT_STEPS, cont->ice_volume_km3, sum->ice_volume_km3, 100 * dv, cont->ice_area_km2, sum->ice_area_km2,
           100 * da, 100 * tol_a, 100 * edge_share, cont->run.particles_end, sum->run.particles_end,
           cont->run.energy_residual, cont->run.water_residual, cont->run.salt_residual);
    CHECK(sum->ice_volume_km3 > 0 && dv < 0.05, "ice volume within 5 %% of the summation run: %.2f %%", 100 * dv);
    CHECK(sum->ice_area_km2 > 0 && da < tol_a, "ice area within %.2f %% of the summation run: %.2f %%", 100 * tol_a,
          100 * da);
}

/* The bundled scene both ways: the same tolerances as compare() (volume 5 %, area 5 % plus the edge
 * share of the summation run's last field); both counts bounded by the box's lattice (85 x 70 points at
 * 0.02 deg: a new particle goes only on a free lattice point). The scene is not a column (ice leaves through
 * its open southern boundary, the coasts hold it), so this also bounds what the density option does to the
 * dynamics' outflow; the budgets are bundled_scene()'s. */
static void scene_compare(const double sl[4], const double cl[4])
{
    double dv = fabs(cl[1] - sl[1]) / sl[1], da = fabs(cl[0] - sl[0]) / sl[0], tol_a = 0.05 + sl[3];
    printf("bundled scene at 720 h: continuity (re-initialised every %d steps) area %.5g km2, volume %.5g km3, %g "
           "particles; summation %.5g km2, %.5g km3, %g particles: area %.2f %% (tolerance %.2f %%: 5 %% + the edge "
           "share %.2f %%), volume %.2f %%\n", REINIT_STEPS, cl[0], cl[1], cl[2], sl[0], sl[1], sl[2], 100 * da,
           100 * tol_a, 100 * sl[3], 100 * dv);
    CHECK(sl[1] > 0 && dv < 0.05, "scene: volume within 5 %% of the summation run: %.2f %%", 100 * dv);
    CHECK(sl[0] > 0 && da < tol_a, "scene: area within %.2f %% of the summation run: %.2f %%", 100 * tol_a,
          100 * da);
    CHECK(sl[2] <= 85 * 70 && cl[2] <= 85 * 70, "scene: particle counts bounded by the lattice: %g, %g", sl[2],
          cl[2]);
}

int main(int argc, char **argv)
{
    (void)argc;
    CHECK(ec_start(argv, dir) == 0, "mkdtemp");
    const int lng = getenv("SPHICE_LONG") != NULL;
    const double hours = lng ? 720.0 : 66.0;
    write_inputs(hours);
    forecast_result sum, cont;
    double edge_sum, edge_cont;
    season_case(0, hours, lng, &sum, &edge_sum);
    season_case(REINIT_STEPS, hours, lng, &cont, &edge_cont);
    compare(&sum, &cont, edge_sum);
    if (lng) {
        double sl[4], cl[4];
        bundled_scene(0, sl);
        bundled_scene(REINIT_STEPS, cl);
        scene_compare(sl, cl);
    }
    return check_summary("test_season");
}
