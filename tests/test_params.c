/* The parameter table (core/params.h): every row's default lies in its
 * bounds and is what sph_params_default sets; sph_params_check accepts each
 * bound and rejects just outside it, naming the row's key; the
 * configuration's model.* keys are the table's rows in its order, with its
 * defaults and bounds (model.dt's service override aside), and
 * `sphice config-doc` lists every row; the automatic time step's base and
 * clamp. */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "core/params.h"
#include "service/config.h"

static const char *minimal =
    "{\"domain\": {\"lon_min\": 119, \"lon_max\": 122, \"lat_min\": 38, \"lat_max\": 41},"
    " \"forcing\": [{\"name\": \"atm\", \"kind\": \"atmosphere\", \"urls\": \"/data/a_%Y%m%d%H.nc\"}],"
    " \"output\": {\"dir\": \"/tmp/out\"}";

/* Writes v into the row's member without any check (sph_param_set refuses
 * values outside the bounds). */
static void poke(const sph_param *r, sph_params *p, double v)
{
    char *m = (char *)p + r->offset;
    if (r->type == SPH_PARAM_DOUBLE)
        memcpy(m, &v, sizeof v);
    else {
        int i = (int)v;
        memcpy(m, &i, sizeof i);
    }
}

/* Just outside [lo, hi]: a whole step for whole-number types, a relative
 * 1e-9 (at least the smallest normal number) for doubles. */
static double below(const sph_param *r)
{
    return r->type == SPH_PARAM_DOUBLE ? r->lo - fmax(fabs(r->lo) * 1e-9, 1e-300) : r->lo - 1;
}
static double above(const sph_param *r)
{
    return r->type == SPH_PARAM_DOUBLE ? r->hi + fmax(fabs(r->hi) * 1e-9, 1e-300) : r->hi + 1;
}

static void test_rows(void)
{
    size_t n;
    const sph_param *t = sph_param_table(&n);
    /* 54 + 5 of issue 20's snow (thermo.*snow*) + 12 of its ocean (model.ocean.*, model.new_ice.*)
     * + model.free_drift_parcels (issue 22) + 4 of issue 26 (fixed_state, momentum.drag_scaling,
     * momentum.coriolis_f, evp.rel_tol) + thermo.snow_heat_capacity (issue 20, the MU71 snow)
     * + new_ice.merge_max_size (issue 20, the merged particles' cap)
     * + evp.anderson, evp.change_tol (issue 22) + jfnk.tol, jfnk.max_newton (issue 22) */
    CHECK(n == 84, "84 rows (the configuration's model.* keys), got %zu", n);
    sph_params d;
    sph_params_default(&d);
    for (size_t i = 0; i < n; i++) {
        const sph_param *r = &t[i];
        CHECK(r->key && r->key[0] && r->doc && r->doc[0] && r->units, "row %zu has key, doc and units", i);
        CHECK(sph_param_find(r->key) == r, "%s: found by key", r->key);
        for (size_t j = 0; j < i; j++)
            CHECK(strcmp(t[j].key, r->key) != 0, "%s: listed twice", r->key);
        CHECK(r->lo <= r->def && r->def <= r->hi, "%s: default %g in [%g, %g]", r->key, r->def, r->lo, r->hi);
        CHECK(sph_param_get(r, &d) == r->def, "%s: sph_params_default sets %g, got %g", r->key, r->def,
              sph_param_get(r, &d));
        CHECK(r->flags & SPH_PARAM_RELOAD, "%s: reloadable", r->key);
        if (r->type == SPH_PARAM_ENUM) {
            int k = 0;
            while (r->names && r->names[k])
                k++;
            CHECK(r->lo == 0 && r->hi == k - 1, "%s: bounds 0..%d for %d names", r->key, k - 1, k);
        } else {
            CHECK(r->names == NULL, "%s: names only for enums", r->key);
        }
        if (r->type == SPH_PARAM_BOOL)
            CHECK(r->lo == 0 && r->hi == 1, "%s: bool 0..1", r->key);
        if (r->type != SPH_PARAM_DOUBLE)
            CHECK(r->def == floor(r->def) && r->lo == floor(r->lo) && r->hi == floor(r->hi),
                  "%s: whole default and bounds", r->key);
        /* the default's JSON text is the default */
        char json[64];
        int len = sph_param_default_json(r, json, sizeof json);
        CHECK(len > 0 && (size_t)len < sizeof json, "%s: default JSON fits (%d)", r->key, len);
        cJSON *j = cJSON_Parse(json);
        CHECK(j != NULL, "%s: default JSON '%s' parses", r->key, json);
        if (j) {
            if (r->type == SPH_PARAM_ENUM)
                CHECK(cJSON_IsString(j) && !strcmp(j->valuestring, r->names[(int)r->def]), "%s: '%s'", r->key,
                      json);
            else if (r->type == SPH_PARAM_BOOL)
                CHECK(cJSON_IsBool(j) && cJSON_IsTrue(j) == (r->def != 0), "%s: '%s'", r->key, json);
            else
                CHECK(cJSON_IsNumber(j) && j->valuedouble == r->def, "%s: '%s' is %g", r->key, json, r->def);
            cJSON_Delete(j);
        }
    }
    CHECK(sph_param_find("no.such.key") == NULL && sph_param_find(NULL) == NULL, "unknown key: NULL");
    /* the physical defaults (PHYSICS.md; the seed's 60 s step) */
    CHECK(d.dt == 60.0 && d.P0 == 1.0e4 && d.C == 20 && d.rho_i == 900 && d.thermo.rho_i == 900 &&
              d.thermo_dt == 600 && d.kernel == SPH_KERNEL_GAUSSIAN && d.thermo.model == SPH_THERMO_AUTO,
          "seed defaults");
    /* the column parameters without a row keep sph_thermo_params_default's */
    sph_thermo_params th;
    sph_thermo_params_default(&th);
    CHECK(d.thermo.k0 == th.k0 && d.thermo.albedo_ice == th.albedo_ice && d.thermo.picard_max_iter == th.picard_max_iter,
          "thermodynamic column defaults");
}

static void test_check(void)
{
    size_t n;
    const sph_param *t = sph_param_table(&n);
    const char *name = NULL;
    double lo = 0, hi = 0;
    sph_params d;
    sph_params_default(&d);
    CHECK(sph_params_check(&d, &name, &lo, &hi) == SPH_STEP_OK, "defaults pass: %s", name ? name : "");
    for (size_t i = 0; i < n; i++) {
        const sph_param *r = &t[i];
        sph_params p = d;
        p.thermo_dt = 0; /* no cross rule between dt and thermo.dt here */
        if (!strcmp(r->key, "thermo.dt"))
            p.thermo_dt = d.thermo_dt;
        double edge[2] = {r->lo, r->hi}, out[2] = {below(r), above(r)};
        for (int s = 0; s < 2; s++) {
            sph_params q = p;
            if (!strcmp(r->key, "thermo.dt"))
                q.dt = fmin(q.dt, fmax(edge[s], 1.0)); /* thermo.dt 0 is off; else at least dt */
            poke(r, &q, edge[s]);
            name = NULL;
            CHECK(sph_params_check(&q, &name, &lo, &hi) == SPH_STEP_OK, "%s = %g (bound) passes: %s", r->key,
                  edge[s], name ? name : "");
            q = p;
            poke(r, &q, out[s]);
            name = NULL;
            int rc = sph_params_check(&q, &name, &lo, &hi);
            CHECK(rc == SPH_STEP_FATAL && name && !strcmp(name, r->key) && lo == r->lo && hi == r->hi,
                  "%s = %.17g refused naming it (got %s [%g, %g])", r->key, out[s], name ? name : "-", lo, hi);
            q = p;
            CHECK(sph_param_set(r, &q, out[s]) == SPH_STEP_FATAL && sph_param_get(r, &q) == sph_param_get(r, &p),
                  "%s: sph_param_set refuses %g", r->key, out[s]);
            CHECK(sph_param_set(r, &q, edge[s]) == SPH_STEP_OK && sph_param_get(r, &q) == edge[s],
                  "%s: sph_param_set takes %g", r->key, edge[s]);
        }
        if (r->type == SPH_PARAM_DOUBLE) {
            sph_params q = p;
            poke(r, &q, NAN);
            CHECK(sph_params_check(&q, &name, &lo, &hi) == SPH_STEP_FATAL && !strcmp(name, r->key),
                  "%s = NaN refused", r->key);
            CHECK(sph_param_set(r, &q, NAN) == SPH_STEP_FATAL, "%s: sph_param_set refuses NaN", r->key);
        } else {
            sph_params q = p;
            CHECK(sph_param_set(r, &q, r->lo + 0.5) == SPH_STEP_FATAL, "%s: not a whole number", r->key);
        }
    }
    /* the cross rule: a thermodynamic step shorter than the dynamic one */
    sph_params q = d;
    q.dt = 120;
    q.thermo_dt = 60;
    CHECK(sph_params_check(&q, &name, &lo, &hi) == SPH_STEP_FATAL && !strcmp(name, "thermo.dt") && lo == 120,
          "thermo.dt below dt refused: %s [%g, %g]", name, lo, hi);
}

/* model.<key> = v as a configuration member ", \"model\": {...}" */
static void model_member(const char *key, double v, char *out, size_t len)
{
    cJSON *model = cJSON_CreateObject(), *o = model;
    char seg[128];
    const char *s = key, *dot;
    while ((dot = strchr(s, '.'))) {
        snprintf(seg, sizeof seg, "%.*s", (int)(dot - s), s);
        o = cJSON_AddObjectToObject(o, seg);
        s = dot + 1;
    }
    cJSON_AddItemToObject(o, s, cJSON_CreateNumber(v));
    char *txt = cJSON_PrintUnformatted(model);
    snprintf(out, len, ", \"model\": %s", txt);
    free(txt);
    cJSON_Delete(model);
}

static int parse_with(const char *extra, struct sph_config **c, sph_error *e)
{
    char text[4096];
    snprintf(text, sizeof text, "%s%s}", minimal, extra);
    sph_error_clear(e);
    return sph_config_parse(text, "t.json", c, e);
}

static void test_config(void)
{
    size_t n;
    const sph_param *t = sph_param_table(&n);
    struct sph_config *c = NULL;
    sph_error e;
    CHECK(parse_with("", &c, &e) == 0 && c, "minimal config: %s", e.msg);
    if (!c)
        return;
    /* the effective configuration's model section: the table's keys, in order */
    char *eff = sph_config_to_json(c);
    cJSON *j = cJSON_Parse(eff);
    const cJSON *model = cJSON_GetObjectItemCaseSensitive(j, "model");
    size_t k = 0;
    int order_ok = 1;
    /* depth-first leaves of the model object */
    const cJSON *stack[8];
    int depth = 0;
    char path[8][256];
    const cJSON *m = model ? model->child : NULL;
    path[0][0] = 0;
    while (m || depth > 0) {
        if (!m) {
            m = stack[--depth]->next;
            continue;
        }
        char here[300];
        snprintf(here, sizeof here, "%s%s%s", path[depth], path[depth][0] ? "." : "", m->string);
        if (cJSON_IsObject(m) && depth < 7) {
            stack[depth++] = m;
            snprintf(path[depth], sizeof path[depth], "%.255s", here);
            m = m->child;
            continue;
        }
        /* the configuration groups keys by section; the table lists them so too */
        if (k >= n || strcmp(here, t[k].key)) {
            order_ok = 0;
            fprintf(stderr, "model leaf %zu: %s, table row: %s\n", k, here, k < n ? t[k].key : "(none)");
        }
        k++;
        m = m->next;
    }
    CHECK(order_ok && k == n, "the configuration's model.* keys are the table's %zu rows in order (%zu)", n, k);
    cJSON_Delete(j);
    free(eff);
    /* defaults: the table's, except model.dt (0: automatic) */
    for (size_t i = 0; i < n; i++) {
        double v = sph_param_get(&t[i], &c->model);
        if (!strcmp(t[i].key, "dt"))
            CHECK(v == 0, "model.dt defaults to 0 (automatic), got %g", v);
        else
            CHECK(v == t[i].def, "model.%s: config default %g, table %g", t[i].key, v, t[i].def);
    }
    sph_config_free(c);

    /* bounds: the table's, except model.dt's [0, 3600] */
    for (size_t i = 0; i < n; i++) {
        const sph_param *r = &t[i];
        if (r->type == SPH_PARAM_BOOL || r->type == SPH_PARAM_ENUM)
            continue;
        int dt = !strcmp(r->key, "dt");
        double lo = dt ? 0 : r->lo, hi = dt ? 3600 : r->hi;
        double vals[4] = {lo, hi, dt ? -1e-300 : below(r), dt ? 3600.5 : above(r)};
        for (int s = 0; s < 4; s++) {
            char extra[512], want[256];
            model_member(r->key, vals[s], extra, sizeof extra);
            c = NULL;
            int rc = parse_with(extra, &c, &e);
            if (s < 2) {
                CHECK(rc == 0, "model.%s = %g accepted: %s", r->key, vals[s], e.msg);
            } else {
                snprintf(want, sizeof want, "model.%s: ", r->key);
                CHECK(rc == SPH_ERR_CONFIG && strstr(e.msg, want), "model.%s = %.17g refused: %s", r->key, vals[s],
                      e.msg);
                snprintf(want, sizeof want, "out of range [%g, %g]", lo, hi);
                CHECK(strstr(e.msg, want) != NULL, "model.%s: message names [%g, %g]: %s", r->key, lo, hi, e.msg);
            }
            sph_config_free(c);
        }
    }

    /* the reference lists every row with its type, default and range */
    char *doc = NULL;
    size_t doclen = 0;
    FILE *f = open_memstream(&doc, &doclen);
    sph_config_doc(f);
    fclose(f);
    for (size_t i = 0; i < n; i++) {
        const sph_param *r = &t[i];
        char want[256], def[64];
        sph_param_default_json(r, def, sizeof def);
        if (!strcmp(r->key, "dt"))
            snprintf(want, sizeof want, "| `model.dt` | number | `0` | 0 to 3600 | yes | %s |", r->doc);
        else if (r->type == SPH_PARAM_DOUBLE || r->type == SPH_PARAM_INT)
            snprintf(want, sizeof want, "| `model.%s` | %s | `%s` | %g to %g | yes | %s |", r->key,
                     r->type == SPH_PARAM_INT ? "int" : "number", def, r->lo, r->hi, r->doc);
        else
            snprintf(want, sizeof want, "| `model.%s` | %s | `%s` |", r->key,
                     r->type == SPH_PARAM_BOOL ? "bool" : "enum", def);
        CHECK(strstr(doc, want) != NULL, "config-doc lists %s", want);
    }
    free(doc);
}

static void test_auto_dt(void)
{
    sph_params p;
    sph_params_default(&p);
    /* thermodynamics on (600 s): gcd(600, 3600, 21600) */
    const double iv[2] = {3600.0, 21600.0};
    CHECK(sph_params_dt_base(&p, iv, 2) == 600.0, "base with thermodynamics: %g", sph_params_dt_base(&p, iv, 2));
    const double iv2[2] = {5400.0, 7200.0};
    p.thermo_dt = 0;
    CHECK(sph_params_dt_base(&p, iv2, 2) == 1800.0, "base without thermodynamics: gcd(5400, 7200) = %g",
          sph_params_dt_base(&p, iv2, 2));
    p.thermo_dt = 600;
    p.thermo.model = SPH_THERMO_OFF;
    CHECK(sph_params_dt_base(&p, iv2, 2) == 1800.0, "thermodynamics off by its model");
    const double odd[2] = {0.5, 1000.25};
    CHECK(sph_params_dt_base(&p, odd, 2) == 0.0, "no whole interval: 0");
    CHECK(sph_params_dt_base(&p, NULL, 0) == 0.0, "no interval: 0");

    /* free drift at 1 km: only the Coriolis bound 0.1 / (2 Omega) = 685.7 s;
     * base 3600 gives 3600 / 6 = 600 s; a thermodynamic step of 100.5 s
     * (not whole, so not in the base) caps it */
    sph_params_default(&p);
    p.physics = SPH_PHYSICS_FREE_DRIFT;
    p.thermo_dt = 0;
    const char *why = NULL;
    CHECK(fabs(sph_params_resolve_dt(&p, 1000.0, 3600.0, &why) - 600.0) < 1e-9 && why,
          "free drift, base 3600: 600 s");
    p.thermo_dt = 100.5;
    why = NULL;
    double dt = sph_params_resolve_dt(&p, 1000.0, 3600.0, &why);
    CHECK(dt == 100.5 && why && strstr(why, "thermodynamic"), "capped at the thermodynamic step: %g (%s)", dt,
          why ? why : "-");
}

int main(void)
{
    test_rows();
    test_check();
    test_config();
    test_auto_dt();
    return check_summary("test_params");
}
