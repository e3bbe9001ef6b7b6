/* `sphice check` (service/check.h): every configured file for one cycle,
 * and what the forcing files hold. */
#include "service/check.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "io/forcing.h"
#include "io/landmask.h"
#include "io/raster.h"
#include "service/config.h"
#include "service/cycle_name.h"
#include "service/forecast.h"
#include "forecast_impl.h"
#include "io/seed.h"
#include "util/fileio.h"
#include "util/limits.h"
#include "util/timeutil.h"

/* The raster seeded exactly as a cold start of this cycle seeds it
 * (fc_seed: the same options, plane box and land mask, built from the
 * local files the cycle would use): the particles' ice area and volume
 * against the raster's over the model's plane box, the fraction seeded on
 * land, and whether initial.gate's 5 % would hold. */
static void check_seeding(const struct sph_config *cfg, ice_raster *r, double t, int json, FILE *out, cJSON *j)
{
    sph_error e;
    sph_error_clear(&e);
    /* the forcing files the cycle would take its land from (source forcing) */
    char files[SPHICE_MAX_SOURCES][4096];
    const char *lists[SPHICE_MAX_SOURCES][2];
    forecast_request req;
    memset(&req, 0, sizeof req);
    req.cycle_time = t;
    for (size_t s = 0; s < cfg->nforcing && s < SPHICE_MAX_SOURCES; s++) {
        struct stat st;
        const char *f = files[s];
        files[s][0] = 0;
        if (cfg->forcing[s].urls.n && cycle_expand_template(cfg->forcing[s].urls.v[0], t, files[s],
                                                            sizeof files[s], &e) == SPH_OK)
            f = !strncmp(files[s], "file://", 7) ? files[s] + 7 : files[s];
        sph_error_clear(&e);
        lists[s][0] = f[0] && !strstr(f, "://") && stat(f, &st) == 0 ? f : NULL;
        lists[s][1] = NULL;
        req.forcing_files[s] = lists[s];
    }
    engine eng;
    memset(&eng, 0, sizeof eng);
    eng.cfg = cfg;
    eng.req = &req;
    eng.raster = r;
    snprintf(eng.raster_path, sizeof eng.raster_path, "%s", r->path);
    eng.proj = geo_proj_create(cfg->domain.projection, 0.5 * (cfg->domain.lon_min + cfg->domain.lon_max),
                               0.5 * (cfg->domain.lat_min + cfg->domain.lat_max), &e);
    double b[4] = {0, 0, 0, 0};
    seed_options so;
    size_t n = 0, on = 0;
    sph_particles *P = NULL;
    fc_seeded sd;
    memset(&sd, 0, sizeof sd);
    int rc = eng.proj ? fc_plane_box(&eng, &b[0], &b[1], &b[2], &b[3], &e) : SPH_ERR_CONFIG;
    if (rc == SPH_OK)
        rc = fc_build_landmask(&eng, b[0], b[1], b[2], b[3], 0.5 * fc_spacing_m(&eng), &e);
    fc_seed_options(&eng, &so);
    if (rc == SPH_OK)
        rc = seed_count(r, eng.proj, eng.lm, &so, &n, &e);
    if (rc == SPH_OK && !(P = sph_particles_create(n ? n : 1, 1)))
        rc = sph_err_set(&e, SPH_ERR_NOMEM, "check: out of memory");
    if (rc == SPH_OK)
        rc = fc_seed(&eng, &so, P, &sd, &e);
    double fland = rc == SPH_OK ? fc_land_fraction(&eng.plane, P, &on) : 0.0;
    sph_particles_free(P);
    landmask_free(eng.lm);
    free(eng.plane_land);
    geo_proj_free(eng.proj);
    if (rc != SPH_OK) {
        cJSON_AddStringToObject(j, "seeding_problem", e.msg);
        if (!json)
            fprintf(out, "PROBLEM      seeding: %s\n", e.msg);
        return;
    }
    /* the lattice's totals before its scaling, as the cycle's gate */
    double ra = sd.raster_area, rv = sd.raster_volume;
    double da = ra > 0 ? sd.raw_area / ra - 1 : 0, dv = rv > 0 ? sd.raw_volume / rv - 1 : 0;
    int ok = ra > 0 ? sd.n > 0 && fabs(da) <= 0.05 && fabs(dv) <= 0.05 : 1;
    cJSON_AddNumberToObject(j, "seeded_particles", (double)sd.n);
    cJSON_AddNumberToObject(j, "domain_raster_ice_area_km2", ra / 1e6);
    cJSON_AddNumberToObject(j, "domain_raster_ice_volume_km3", rv / 1e9);
    cJSON_AddNumberToObject(j, "seeded_ice_area_km2", sd.area / 1e6);
    cJSON_AddNumberToObject(j, "seeded_ice_volume_km3", sd.volume / 1e9);
    cJSON_AddNumberToObject(j, "seeded_on_land_fraction", fland);
    cJSON_AddBoolToObject(j, "seeding_gate_ok", ok);
    if (!json) {
        fprintf(out, "raster       initial        seeded as the cycle seeds (land mask applied) %zu particles: "
                "area %.6g km2, volume %.6g km3, %zu on land; the raster over the model's box %.6g km2, "
                "%.6g km3\n", sd.n, sd.area / 1e6, sd.volume / 1e9, on, ra / 1e6, rv / 1e9);
        if (!ok)
            fprintf(out, "PROBLEM      seeding: the %s seeds %+.1f %% of the raster's ice area and %+.1f %% "
                    "of its volume (more than 5 %%: initial.gate)\n", sd.rescaled ? "lattice" : "raster's cells",
                    100 * da, 100 * dv);
    }
}

/* The initial raster: read as the cycle would, its grid and the ice in
 * the domain (area sum A x cell area, volume sum A h x cell area, cells
 * above initial.threshold). Returns 1 when it cannot be read. */
static int check_raster(const struct sph_config *cfg, double t, int json, FILE *out, cJSON *root)
{
    char path[4096], thick[4096] = "";
    sph_error e;
    sph_error_clear(&e);
    if (!cfg->initial.path[0] || cycle_expand_template(cfg->initial.path, t, path, sizeof path, &e))
        return 0;
    const char *p = !strncmp(path, "file://", 7) ? path + 7 : path;
    struct stat st;
    if (strstr(p, "://") || stat(p, &st) != 0)
        return 0;
    ice_raster_options o;
    ice_raster_options_default(&o);
    o.default_thickness = cfg->initial.default_thickness;
    o.thickness_kind = cfg->initial.thickness_kind;
    fc_raster_options(cfg, &o);
    if (cfg->initial.format == CFG_INIT_ESRI) {
        o.valid_time = t;
        if (cfg->initial.thick_var && cfg->initial.thick_var[0] &&
            cycle_expand_template(cfg->initial.thick_var, t, thick, sizeof thick, &e) == 0)
            o.thickness_path = thick;
    } else {
        o.conc_variable = cfg->initial.conc_var && cfg->initial.conc_var[0] ? cfg->initial.conc_var : NULL;
        o.thick_variable = cfg->initial.thick_var && cfg->initial.thick_var[0] ? cfg->initial.thick_var : NULL;
    }
    ice_raster *r = NULL;
    int rc = ice_raster_read(p, &o, &r, &e);
    if (rc == SPH_ERR_MISSING_VAR && o.conc_variable && !strcmp(o.conc_variable, "sea_ice_concentration")) {
        o.conc_variable = NULL;
        sph_error_clear(&e);
        rc = ice_raster_read(p, &o, &r, &e);
    }
    cJSON *j = cJSON_AddObjectToObject(root, "initial_raster");
    cJSON_AddStringToObject(j, "path", p);
    if (rc) {
        cJSON_AddStringToObject(j, "problem", e.msg);
        if (!json)
            fprintf(out, "PROBLEM      %s\n", e.msg);
        return 1;
    }
    double area = 0, vol = 0;
    for (int jj = 0; jj < r->nlat; jj++)
        for (int i = 0; i < r->nlon; i++) {
            double lon, lat, c = r->conc[(size_t)jj * r->nlon + i];
            ice_raster_cell_lonlat(r, i, jj, &lon, &lat);
            if (!(c > cfg->initial.threshold) || lat < cfg->domain.lat_min ||
                lat > cfg->domain.lat_max || lon < cfg->domain.lon_min || lon > cfg->domain.lon_max)
                continue;
            double a = ice_raster_area(r, i, jj);
            area += c * a;
            vol += c * r->thick[(size_t)jj * r->nlon + i] * a;
        }
    cJSON_AddStringToObject(j, "grid", r->grid);
    const char *tk = !r->thickness_why[0] ? "none (initial.default_thickness)"
                     : r->thickness_kind == ICE_THICK_CELL_MEAN ? "cell_mean" : "ice";
    cJSON_AddStringToObject(j, "thickness_kind", tk);
    cJSON_AddStringToObject(j, "thickness_kind_from", r->thickness_why);
    if (r->assumed[0])
        cJSON_AddStringToObject(j, "assumed", r->assumed);
    cJSON_AddNumberToObject(j, "land_cells", (double)r->nland);
    cJSON_AddNumberToObject(j, "no_information_cells", (double)r->nnoinfo);
    cJSON_AddNumberToObject(j, "ice_area_km2", area / 1e6);
    cJSON_AddNumberToObject(j, "ice_volume_km3", vol / 1e9);
    if (!json) {
        fprintf(out, "raster       initial        %s: %d x %d cells, %s\n", p, r->nlon, r->nlat, r->grid);
        fprintf(out, "raster       initial        thickness %s%s%s; flagged land %zu, no information %zu cells\n",
                tk, r->thickness_why[0] ? " from " : "", r->thickness_why, r->nland, r->nnoinfo);
        if (r->assumed[0])
            fprintf(out, "raster       initial        assumed from the configuration: %s\n", r->assumed);
        if (area > 0)
            fprintf(out, "raster       initial        ice in the domain: area %.6g km2, volume %.6g km3\n",
                    area / 1e6, vol / 1e9);
        else
            fprintf(out, "raster       initial        no ice in the domain: an open-water start\n");
    }
    check_seeding(cfg, r, t, json, out, j);
    ice_raster_free(r);
    return 0;
}

int service_check(const struct sph_config *cfg, double t, int json, FILE *out)
{
    char iso[32];
    time_format_iso(t, iso, sizeof iso);
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "config", cfg->file);
    cJSON_AddStringToObject(root, "cycle", iso);
    cJSON *rows = cJSON_AddArrayToObject(root, "files");
    int missing_required = 0;
    /* forcing: each template of each source; then the other inputs */
    typedef struct { const char *what, *name, *tmpl; int required; double at; } check_item;
    check_item items[SPHICE_MAX_SOURCES * SPHICE_MAX_FILES + 3];
    size_t n = 0;
    for (size_t s = 0; s < cfg->nforcing; s++)
        for (size_t i = 0; i < cfg->forcing[s].urls.n && i < SPHICE_MAX_FILES; i++)
            items[n++] = (check_item){"forcing", cfg->forcing[s].name, cfg->forcing[s].urls.v[i],
                                            !cfg->forcing[s].optional_source, t};
    if (cfg->initial.path[0])
        items[n++] = (check_item){"initial", "initial", cfg->initial.path, 0, t};
    if (cfg->landmask.path[0])
        items[n++] = (check_item){"landmask", "landmask", cfg->landmask.path, 0, t};
    if (cfg->observations.path[0])
        items[n++] = (check_item){"observations", "observations", cfg->observations.path, 0,
                                        t + cfg->schedule.forecast_hours * 3600};
    for (size_t i = 0; i < n; i++) {
        char path[4096] = "", sha[65] = "";
        sph_error e;
        sph_error_clear(&e);
        int rc = cycle_expand_template(items[i].tmpl, items[i].at, path, sizeof path, &e);
        const char *p = !strncmp(path, "file://", 7) ? path + 7 : path;
        struct stat st;
        int found = 0;
        if (!rc) {
            if (strstr(p, "://"))
                sph_err_set(&e, SPH_ERR_DOWNLOAD, "%s: remote (checked when fetched)", p);
            else if (stat(p, &st) != 0)
                sph_err_set(&e, SPH_ERR_IO, "%s: %s", p, strerror(errno));
            else if (sha256_file(p, sha, &e) == 0)
                found = 1;
        }
        if (!found && items[i].required)
            missing_required++;
        cJSON *r = cJSON_CreateObject();
        cJSON_AddStringToObject(r, "kind", items[i].what);
        cJSON_AddStringToObject(r, "name", items[i].name);
        cJSON_AddStringToObject(r, "template", items[i].tmpl);
        cJSON_AddStringToObject(r, "path", p);
        cJSON_AddBoolToObject(r, "found", found);
        if (found) {
            cJSON_AddNumberToObject(r, "bytes", (double)st.st_size);
            cJSON_AddNumberToObject(r, "age_hours", (time_now() - (double)st.st_mtim.tv_sec) / 3600.0);
            cJSON_AddStringToObject(r, "sha256", sha);
        } else {
            cJSON_AddStringToObject(r, "problem", e.msg);
        }
        cJSON_AddItemToArray(rows, r);
        if (!json)
            fprintf(out, "%-12s %-14s %-8s %s\n", items[i].what, items[i].name, found ? "found" : "MISSING",
                   found ? p : e.msg);
    }
    /* open every source whose files were found and describe what is in them */
    cJSON *vars = cJSON_AddArrayToObject(root, "variables");
    int problems = 0;
    char (*paths)[4096] = malloc(SPHICE_MAX_FILES * sizeof *paths); /* every file of a source */
    if (!paths) {
        cJSON_Delete(root);
        fprintf(stderr, "check: out of memory\n");
        return 1;
    }
    for (size_t s = 0; s < cfg->nforcing; s++) {
        const char *files[SPHICE_MAX_FILES + 1];
        size_t nf = 0;
        for (size_t i = 0; i < cfg->forcing[s].urls.n && nf < SPHICE_MAX_FILES; i++) {
            sph_error e;
            sph_error_clear(&e);
            if (cycle_expand_template(cfg->forcing[s].urls.v[i], t, paths[nf], sizeof paths[nf], &e))
                continue;
            const char *p = !strncmp(paths[nf], "file://", 7) ? paths[nf] + 7 : paths[nf];
            struct stat st;
            if (!strstr(p, "://") && stat(p, &st) == 0)
                files[nf++] = p;
        }
        files[nf] = NULL;
        if (nf == 0)
            continue;
        forcing_source_spec spec;
        forcing_name_map *map = NULL;
        forcing *f = NULL;
        sph_error e;
        sph_error_clear(&e);
        int rc = forecast_source_spec(cfg, s, files, &spec, &map, &e);
        if (!rc)
            rc = forcing_open(&f, &spec, 1, t, t + cfg->schedule.forecast_hours * 3600.0,
                              cfg->domain.lon_min, cfg->domain.lon_max, cfg->domain.lat_min,
                              cfg->domain.lat_max, &e);
        if (rc) {
            problems++;
            cJSON *r = cJSON_CreateObject();
            cJSON_AddStringToObject(r, "source", cfg->forcing[s].name);
            cJSON_AddStringToObject(r, "problem", e.msg);
            cJSON_AddItemToArray(vars, r);
            if (!json)
                fprintf(out, "PROBLEM      %s\n", e.msg);
        } else {
            forcing_var_info info[32];
            size_t ni = forcing_describe(f, info, 32);
            int second = 0; /* 1 between the two components of a vector pair */
            for (size_t i = 0; i < ni && i < 32; i++) {
                char t0[32] = "harmonic", t1[32] = "any time";
                if (isfinite(info[i].t_first) && fabs(info[i].t_first) < 1e13) {
                    time_format_iso(info[i].t_first, t0, sizeof t0);
                    time_format_iso(info[i].t_last, t1, sizeof t1);
                }
                cJSON *r = cJSON_CreateObject();
                cJSON_AddStringToObject(r, "source", info[i].source);
                cJSON_AddStringToObject(r, "standard_name", info[i].standard_name);
                cJSON_AddStringToObject(r, "variable", info[i].variable);
                cJSON_AddStringToObject(r, "file", info[i].file);
                cJSON_AddStringToObject(r, "units", info[i].units);
                cJSON_AddStringToObject(r, "grid", info[i].grid);
                cJSON_AddStringToObject(r, "time_first", t0);
                cJSON_AddStringToObject(r, "time_last", t1);
                cJSON_AddNumberToObject(r, "fill_fraction", info[i].fill_fraction);
                if (info[i].orientation[0])
                    cJSON_AddStringToObject(r, "orientation", info[i].orientation);
                cJSON_AddItemToArray(vars, r);
                if (!json)
                    fprintf(out, "variable     %-10s %-44s %-8s %-12s %-30s %s..%s fill %.3f\n",
                           info[i].source, info[i].standard_name, info[i].variable, info[i].units,
                           info[i].grid, t0, t1, info[i].fill_fraction);
                /* one line per vector quantity, after its second component
                 * (forcing_describe lists the two components together) */
                if (info[i].orientation[0])
                    second = !second;
                if (!json && info[i].orientation[0] && second == 0)
                    fprintf(out, "vectors      %-10s %-44s %s\n", info[i].source,
                            strstr(info[i].standard_name, "wind") ? "wind" : "current",
                            info[i].orientation);
            }
        }
        forcing_close(f);
        free(map);
    }
    free(paths);
    /* landmask: read it as the cycle will, so that a mask whose polarity
     * the file does not say is reported here, not at the cycle */
    if (cfg->landmask.source == CFG_LAND_NETCDF || cfg->landmask.source == CFG_LAND_FORCING) {
        char lpath[4096] = "", why[512] = "";
        const char *tmpl = cfg->landmask.path[0] ? cfg->landmask.path : NULL;
        for (size_t s = 0; !tmpl && cfg->landmask.source == CFG_LAND_FORCING && s < cfg->nforcing; s++)
            if (cfg->forcing[s].kind == FORCING_OCEAN && cfg->forcing[s].urls.n)
                tmpl = cfg->forcing[s].urls.v[0];
        sph_error e;
        sph_error_clear(&e);
        int rc = tmpl ? cycle_expand_template(tmpl, t, lpath, sizeof lpath, &e) : SPH_OK;
        const char *lp = !strncmp(lpath, "file://", 7) ? lpath + 7 : lpath;
        struct stat st;
        if (!rc && (!lp[0] || (!strstr(lp, "://") && stat(lp, &st) == 0))) {
            struct landmask *lm = NULL;
            rc = forecast_landmask_read(cfg, lp, &lm, why, sizeof why, &e);
            landmask_free(lm);
        } else if (!rc) {
            rc = -1; /* remote or missing: listed above */
        }
        if (rc >= 0) {
            cJSON *r = cJSON_CreateObject();
            cJSON_AddStringToObject(r, "source", "landmask");
            cJSON_AddStringToObject(r, rc ? "problem" : "land", rc ? e.msg : why);
            cJSON_AddItemToArray(vars, r);
            if (rc)
                problems++;
            if (!json)
                fprintf(out, rc ? "PROBLEM      %s\n" : "landmask     %s\n", rc ? e.msg : why);
        }
    }
    problems += check_raster(cfg, t, json, out, root);
    if (problems)
        missing_required++;
    cJSON_AddBoolToObject(root, "ok", missing_required == 0);
    if (json) {
        char *txt = cJSON_Print(root);
        fprintf(out, "%s\n", txt);
        free(txt);
    } else {
        fprintf(out, "cycle %s: %s\n", iso, missing_required ? "required forcing missing" : "all required forcing found");
    }
    cJSON_Delete(root);
    return missing_required ? 1 : 0;
}
