/* Configuration: the shipped example parses; unknown keys, wrong types and
 * out-of-range values are errors naming the key path; defaults fill missing
 * keys (PHYSICS.md values); the generated reference lists every key and
 * matches docs/config.md; schedule arithmetic and templates. */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "service/config.h"
#include "service/cycle.h"
#include "service/schedule.h"
#include "util/fileio.h"
#include "util/timeutil.h"

static const char *minimal =
    "{\"domain\": {\"lon_min\": 119, \"lon_max\": 122, \"lat_min\": 38, \"lat_max\": 41},"
    " \"forcing\": [{\"name\": \"atm\", \"kind\": \"atmosphere\", \"urls\": \"/data/a_%Y%m%d%H.nc\"}],"
    " \"output\": {\"dir\": \"/tmp/out\"}";

/* Parses minimal + extra members; returns rc and fills msg. */
static int parse_with(const char *extra, struct sph_config **c, char *msg, size_t len)
{
    char text[4096];
    snprintf(text, sizeof text, "%s%s}", minimal, extra);
    sph_error e;
    sph_error_clear(&e);
    int rc = sph_config_parse(text, "t.json", c, &e);
    snprintf(msg, len, "%s", e.msg);
    return rc;
}

static void expect_error(const char *extra, const char *want1, const char *want2)
{
    struct sph_config *c = NULL;
    char msg[1024];
    int rc = parse_with(extra, &c, msg, sizeof msg);
    CHECK(rc == SPH_ERR_CONFIG && c == NULL, "%s: rc %d", extra, rc);
    CHECK(strstr(msg, want1) != NULL, "%s: message \"%s\" lacks \"%s\"", extra, msg, want1);
    if (want2)
        CHECK(strstr(msg, want2) != NULL, "%s: message \"%s\" lacks \"%s\"", extra, msg, want2);
    CHECK(strstr(msg, "config t.json: ") == msg, "message names the file: %s", msg);
    sph_config_free(c);
}

/* Collects every leaf key path of a JSON object ("a.b.c"; arrays of objects as "a[].b"). */
static void leaves(const cJSON *o, const char *prefix, char paths[][128], int *n, int max)
{
    const cJSON *m;
    cJSON_ArrayForEach(m, o) {
        char p[128];
        if (prefix[0])
            snprintf(p, sizeof p, "%s.%s", prefix, m->string);
        else
            snprintf(p, sizeof p, "%s", m->string);
        if (cJSON_IsObject(m) && cJSON_GetArraySize(m) > 0 && strcmp(m->string, "variables")) {
            leaves(m, p, paths, n, max);
        } else if (cJSON_IsArray(m) && cJSON_IsObject(cJSON_GetArrayItem(m, 0))) {
            if (*n < max)
                snprintf(paths[(*n)++], 128, "%s", p);
            char q[132];
            snprintf(q, sizeof q, "%s[]", p);
            leaves(cJSON_GetArrayItem(m, 0), q, paths, n, max);
        } else if (*n < max) {
            snprintf(paths[(*n)++], 128, "%s", p);
        }
    }
}

/* The key table's defaults must be the core's own defaults (one source of
 * truth for the physics: PHYSICS.md values in sph_params_default). */
static void test_defaults_match_core(void)
{
    struct sph_config *c = NULL;
    char msg[1024];
    CHECK(parse_with("", &c, msg, sizeof msg) == 0, "minimal config parses: %s", msg);
    if (!c)
        return;
    sph_params d;
    sph_params_default(&d);
    const sph_params *m = &c->model;
#define SAME(f) CHECK(m->f == d.f, "model default %s: config %g, core %g", #f, (double)m->f, (double)d.f)
    /* dt: the service's default is auto time stepping (0), resolved by the
     * engine; the core's default is the seed's 60 s */
    CHECK(m->dt == 0.0 && d.dt == 60.0, "model.dt: config default auto (0), core default 60 s");
    SAME(kernel); SAME(kernel_radius); SAME(variable_sml); SAME(gradient_correction); SAME(summation_density);
    SAME(density_reinit_steps);
    SAME(sml_factor); SAME(solver); SAME(unstable); SAME(evp_iterations); SAME(evp_adaptive);
    SAME(evp_alpha); SAME(evp_beta); SAME(evp_tol); SAME(evp_stall_window); SAME(implicit_max_picard); SAME(implicit_tol);
    SAME(max_substeps); SAME(explicit_safety); SAME(max_neighbours); SAME(physics); SAME(rheology);
    SAME(pressure_form); SAME(P0); SAME(C); SAME(ecc); SAME(zeta_max_factor); SAME(delta_min);
    SAME(replacement_pressure); SAME(auto_tolerance); SAME(coll_restitution);
    SAME(coll_floe_diameter); SAME(coll_max_conc); SAME(coll_vfluct_min); SAME(rho_i); SAME(rho_a);
    SAME(rho_w); SAME(Ca); SAME(Cw); SAME(turn_air); SAME(turn_water); SAME(gravity); SAME(coriolis);
    SAME(coast_no_slip); SAME(sml_min_factor); SAME(sml_max_factor); SAME(speed_limit);
    SAME(mass_tolerance); SAME(thermo_dt); SAME(thermo.model); SAME(thermo.nlayers);
    SAME(thermo.auto_thickness); SAME(thermo.rho_i);
#undef SAME
    sph_config_free(c);
}

/* domain.plane_tables: "auto" by default; the JSON booleans still select
 * true and false (configurations written before the key had "auto"), and
 * the dump writes them back as booleans. */
static void test_plane_tables_key(void)
{
    const char *json[] = {"", "true", "false", "\"auto\"", "\"true\""};
    const int want[] = {CFG_TABLES_AUTO, CFG_TABLES_TRUE, CFG_TABLES_FALSE, CFG_TABLES_AUTO, CFG_TABLES_TRUE};
    for (int k = 0; k < 5; k++) {
        char text[4096];
        if (k == 0)
            snprintf(text, sizeof text, "%s}", minimal);
        else
            snprintf(text, sizeof text,
                     "{\"domain\": {\"lon_min\": 119, \"lon_max\": 122, \"lat_min\": 38, \"lat_max\": 41,"
                     " \"plane_tables\": %s}, \"forcing\": [{\"name\": \"atm\", \"kind\": \"atmosphere\","
                     " \"urls\": \"/data/a.nc\"}], \"output\": {\"dir\": \"/tmp/out\"}}", json[k]);
        struct sph_config *c = NULL;
        sph_error e;
        sph_error_clear(&e);
        int rc = sph_config_parse(text, "t.json", &c, &e);
        CHECK(rc == 0 && c && c->domain.plane_tables == want[k], "domain.plane_tables %s: rc %d value %d want %d (%s)",
              k ? json[k] : "(default)", rc, c ? c->domain.plane_tables : -1, want[k], e.msg);
        if (c) {
            char *dump = sph_config_to_json(c);
            const char *w = want[k] == CFG_TABLES_AUTO ? "\"plane_tables\":\t\"auto\"" :
                            want[k] == CFG_TABLES_TRUE ? "\"plane_tables\":\ttrue" : "\"plane_tables\":\tfalse";
            CHECK(dump && strstr(dump, w), "the dump writes domain.plane_tables back as %s", w);
            free(dump);
        }
        sph_config_free(c);
    }
    struct sph_config *c = NULL;
    char text[4096];
    snprintf(text, sizeof text,
             "{\"domain\": {\"lon_min\": 119, \"lon_max\": 122, \"lat_min\": 38, \"lat_max\": 41,"
             " \"plane_tables\": 1}, \"forcing\": [{\"name\": \"atm\", \"kind\": \"atmosphere\","
             " \"urls\": \"/data/a.nc\"}], \"output\": {\"dir\": \"/tmp/out\"}}");
    sph_error e;
    sph_error_clear(&e);
    int rc = sph_config_parse(text, "t.json", &c, &e);
    CHECK(rc == SPH_ERR_CONFIG && !c && strstr(e.msg, "domain.plane_tables"),
          "a number for domain.plane_tables is refused naming the key: %s", e.msg);
    sph_config_free(c);
    /* a boolean is no value of an enum without true and false */
    snprintf(text, sizeof text,
             "{\"domain\": {\"lon_min\": 119, \"lon_max\": 122, \"lat_min\": 38, \"lat_max\": 41},"
             " \"forcing\": [{\"name\": \"atm\", \"kind\": \"atmosphere\", \"urls\": \"/data/a.nc\"}],"
             " \"output\": {\"dir\": \"/tmp/out\", \"writer_thread\": true}}");
    sph_error_clear(&e);
    rc = sph_config_parse(text, "t.json", &c, &e);
    CHECK(rc == SPH_ERR_CONFIG && !c && strstr(e.msg, "writer_thread"), "writer_thread true refused: %s", e.msg);
    sph_config_free(c);
}

int main(void)
{
    test_defaults_match_core();
    test_plane_tables_key();
    /* the shipped example */
    struct sph_config *c = NULL;
    sph_error e;
    sph_error_clear(&e);
    int rc = sph_config_load("etc/sphice.json", &c, &e);
    CHECK(rc == 0 && c, "etc/sphice.json: %s", e.msg);
    if (c) {
        CHECK(c->nforcing == 3, "3 sources, got %zu", c->nforcing);
        CHECK(c->nstations == 2, "2 stations");
        CHECK(c->forcing[2].optional_source == 1, "tides optional");
        CHECK(c->schedule.cycles.n == 2 && c->schedule.cycles.sec[1] == 12 * 3600, "cycles 00:00 12:00");
        CHECK(c->forcing[0].variables.n == 3 && !strcmp(c->forcing[0].variables.val[0], "u10"), "variables map");
        CHECK(config_quantity_flag(c->forcing[0].required.v[0]) == FQ_WIND, "wind flag");
    }

    /* defaults: values from PHYSICS.md (section 2, 3, seed settings) */
    struct sph_config *d = NULL;
    char msg[1024];
    rc = parse_with("", &d, msg, sizeof msg);
    CHECK(rc == 0 && d, "minimal config: %s", msg);
    if (d) {
        CHECK(d->model.P0 == 1.0e4, "P0 default 1e4 N/m2 (seed)");
        CHECK(d->model.C == 20, "C default 20");
        CHECK(d->model.ecc == 2, "e default 2");
        CHECK(d->model.delta_min == 2e-9, "delta_min 2e-9");
        CHECK(d->model.rho_a == 1.3 && d->model.rho_w == 1026, "densities 1.3, 1026");
        CHECK(d->model.Ca == 1.2e-3 && d->model.Cw == 5.5e-3, "drag 1.2e-3, 5.5e-3");
        CHECK(d->model.turn_air == 0 && d->model.turn_water == 0, "turning angles 0 by default");
        CHECK(d->model.dt == 0, "dynamic step auto by default (the seed's 60 s is in the demo's config)");
        CHECK(d->model.thermo_dt == 600, "seed thermodynamic step 600 s");
        CHECK(d->model.kernel == SPH_KERNEL_GAUSSIAN, "seed kernel Gaussian");
        CHECK(d->model.pressure_form == SPH_PRESSURE_SEED, "seed pressure form by default");
        CHECK(fabs(d->initial.spacing_deg - 0.02) < 1e-15, "seed spacing 0.02 deg");
        CHECK(d->schedule.cycles.n == 2 && d->schedule.cycles.sec[0] == 0, "default cycles");
        CHECK(!strcmp(d->status.listen, "127.0.0.1:8642"), "status on loopback by default");
        CHECK(d->forcing[0].urls.n == 1, "a single string is a one-entry list");
        CHECK(d->nstations == 0, "no stations");
        CHECK(d->engine == CFG_ENGINE_FORECAST, "real engine by default");
    }

    /* errors name the key path */
    expect_error(", \"model\": {\"rheology\": {\"P00\": 1}}", "model.rheology.P00: unknown key", NULL);
    /* output.products.fields / edge false: refused in one line (the fields file carries the edge,
     * the series and the scores); geojson false is accepted */
    {
        const char *cut = strstr(minimal, "\"output\"");
        const char *keys[3] = { "fields", "edge", "geojson" };
        for (int k = 0; k < 3; k++) {
            char text[4096], want[64];
            snprintf(text, sizeof text, "%.*s\"output\": {\"dir\": \"/tmp/out\", \"products\": {\"%s\": false}}}",
                     (int)(cut - minimal), minimal, keys[k]);
            struct sph_config *pc = NULL;
            sph_error pe;
            sph_error_clear(&pe);
            int prc = sph_config_parse(text, "t.json", &pc, &pe);
            snprintf(want, sizeof want, "output.products.%s: false is not supported", keys[k]);
            if (k < 2)
                CHECK(prc == SPH_ERR_CONFIG && pc == NULL && strstr(pe.msg, want) && !strchr(pe.msg, '\n'),
                      "products.%s false refused in one line: rc %d, %s", keys[k], prc, pe.msg);
            else
                CHECK(prc == SPH_OK && pc && !pc->output.products.geojson, "products.geojson false accepted: %s",
                      pe.msg);
            sph_config_free(pc);
        }
    }
    expect_error(", \"model\": {\"rheology\": {\"P0\": \"big\"}}", "model.rheology.P0: expected number, got string",
                 NULL);
    expect_error(", \"model\": {\"dt\": -1}", "model.dt: -1 out of range [0, 3600]", NULL);
    expect_error(", \"model\": {\"evp\": {\"iterations\": 2.5}}", "model.evp.iterations: expected an integer", NULL);
    expect_error(", \"model\": {\"kernel\": \"box\"}", "model.kernel: \"box\" is not one of", "gaussian");
    expect_error(", \"schedule\": {\"cycles\": [\"25:00\"]}", "schedule.cycles: entry 0", "HH:MM");
    expect_error(", \"schedule\": {\"late_data\": {\"policy\": \"maybe\"}}", "schedule.late_data.policy", "fail, stale");
    expect_error(", \"stations\": [{\"name\": \"a\", \"lon\": 1}]", "stations[0].lat: required key missing", NULL);
    expect_error(", \"stations\": [{\"name\": \"a\", \"lon\": 1, \"lat\": 95}]", "stations[0].lat: 95 out of range",
                 NULL);
    expect_error(", \"model\": 3", "model: expected object, got number", NULL);
    expect_error(", \"status\": {\"listen\": \"localhost\"}", "status.listen", NULL);
    expect_error(", \"bogus\": true", "bogus: unknown key", NULL);
    {
        struct sph_config *x = NULL;
        sph_error_clear(&e);
        rc = sph_config_parse("{\"domain\": {\"lon_min\": 1, \"lon_max\": 2, \"lat_min\": 1, \"lat_max\": 2},"
                              " \"output\": {\"dir\": \"/o\"}, \"forcing\": [{\"name\": \"a\", \"kind\": "
                              "\"atmosphere\", \"urls\": \"x\"}, {\"name\": \"b\", \"kind\": \"sky\", \"urls\": \"y\"}]}",
                              "t.json", &x, &e);
        CHECK(rc && strstr(e.msg, "forcing[1].kind"), "array element path: %s", e.msg);
        sph_error_clear(&e);
        rc = sph_config_parse("{\"output\": {\"dir\": \"/o\"}}", "t.json", &x, &e);
        CHECK(rc && strstr(e.msg, "required key missing"), "required: %s", e.msg);
        sph_error_clear(&e);
        rc = sph_config_parse("{\"domain\": \n{,}", "t.json", &x, &e);
        CHECK(rc && strstr(e.msg, "line 2") && strstr(e.msg, "not valid JSON"), "syntax error line: %s", e.msg);
    }

    /* the reference lists every key of the effective configuration */
    if (c) {
        char *doc = NULL;
        size_t doclen = 0;
        FILE *f = open_memstream(&doc, &doclen);
        sph_config_doc(f);
        fclose(f);
        char *eff = sph_config_to_json(c);
        cJSON *j = cJSON_Parse(eff);
        static char paths[400][128];
        int n = 0;
        leaves(j, "", paths, &n, 400);
        CHECK(n > 100, "effective config has %d keys", n);
        int missing = 0;
        for (int i = 0; i < n; i++) {
            char want[140];
            snprintf(want, sizeof want, "`%s`", paths[i]);
            if (!strstr(doc, want)) {
                missing++;
                fprintf(stderr, "doc lacks %s\n", want);
            }
        }
        CHECK(missing == 0, "%d keys missing from the reference", missing);
        /* the effective config parses back to the same config */
        struct sph_config *back = NULL;
        sph_error_clear(&e);
        rc = sph_config_parse(eff, "effective", &back, &e);
        CHECK(rc == 0, "effective config parses: %s", e.msg);
        if (back) {
            char *eff2 = sph_config_to_json(back);
            CHECK(!strcmp(eff, eff2), "round trip");
            free(eff2);
        }
        sph_config_free(back);
        /* docs/config.md is the generated reference */
        char *committed = NULL;
        size_t clen = 0;
        sph_error_clear(&e);
        if (read_file("docs/config.md", &committed, &clen, &e) == 0)
            CHECK(strstr(committed, doc) != NULL, "docs/config.md is stale: run `build/sphice config-doc`");
        else
            CHECK(0, "docs/config.md: %s", e.msg);
        free(committed);
        /* README.md carries the same reference (configuration section) */
        committed = NULL;
        sph_error_clear(&e);
        if (read_file("README.md", &committed, &clen, &e) == 0)
            /* the README demotes the reference's title line */
            CHECK(strstr(committed, strchr(doc, '\n')) != NULL,
                  "README.md's configuration reference is stale: run `sh tools/make-readme.sh`");
        else
            CHECK(0, "README.md: %s", e.msg);
        free(committed);
        cJSON_Delete(j);
        free(eff);
        free(doc);
    }

    /* reload: a changed restart-only key keeps its running value */
    if (c && d) {
        char changed[256];
        int k = sph_config_keep_unreloadable(d, c, changed, sizeof changed);
        CHECK(k >= 1 && strstr(changed, "output.dir") && !strcmp(d->output.dir, c->output.dir),
              "output.dir kept: %d %s %s", k, changed, d->output.dir);
        CHECK(!strcmp(d->paths.state_dir, c->paths.state_dir), "state_dir kept");
    }

    /* schedule arithmetic: 2024-02-08 is day 19761 since 1970 */
    if (d) {
        double day = 19761 * 86400.0, t;
        CHECK(time_parse_iso("2024-02-08T05:00Z", &t) == 0 && t == day + 5 * 3600, "iso parse");
        CHECK(schedule_prev(d, day + 5 * 3600) == day, "prev of 05:00 is 00:00");
        CHECK(schedule_next(d, day + 5 * 3600) == day + 12 * 3600, "next of 05:00 is 12:00");
        CHECK(schedule_next(d, day + 12 * 3600) == day + 86400, "next is strictly later");
        CHECK(schedule_prev(d, day - 1) == day - 12 * 3600, "prev before midnight is 12:00 yesterday");
        d->schedule.every_hours = 6;
        CHECK(schedule_prev(d, day + 5 * 3600) == day && schedule_next(d, day + 5 * 3600) == day + 6 * 3600,
              "every 6 h");
        d->schedule.every_seconds = 7;
        CHECK(fmod(schedule_prev(d, day + 100), 7) == 0 && schedule_next(d, day + 100) - schedule_prev(d, day + 100) == 7,
              "every 7 s");
        char name[32];
        cycle_name(day + 12 * 3600, name, sizeof name);
        CHECK(!strcmp(name, "20240208T12Z"), "cycle name %s", name);
        cycle_name(day + 12 * 3600 + 61, name, sizeof name);
        CHECK(!strcmp(name, "20240208T120101Z"), "fine cycle name %s", name);
        double back;
        CHECK(cycle_name_parse("20240208T12Z", &back) == 0 && back == day + 12 * 3600, "name parse");
        CHECK(cycle_name_parse("latest", &back) != 0, "not a cycle name");
        char out[256];
        sph_error_clear(&e);
        CHECK(cycle_expand_template("/d/%Y/%m/a_%Y%m%d_%H%M_%j.nc", day + 6 * 3600, out, sizeof out, &e) == 0 &&
                  !strcmp(out, "/d/2024/02/a_20240208_0600_039.nc"),
              "template: %s", out);
        sph_error_clear(&e);
        CHECK(cycle_expand_template("/d/%Q.nc", day, out, sizeof out, &e) == SPH_ERR_CONFIG &&
                  strstr(e.msg, "%Q"),
              "bad template field: %s", e.msg);
    }
    sph_config_free(c);
    sph_config_free(d);
    return check_summary("test_config");
}
