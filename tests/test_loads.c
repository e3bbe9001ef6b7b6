/* The ice-load product (issue 25 item 3, cheap model): the products API
 * with stations with and without a structure on uniform fields; the load
 * against ISO 19906's formula written out here from docs/dem.md; the
 * model choice and its reason; no file without a structure; the refusal
 * of a structure outside the domain (config). */
#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "check.h"
#include "core/dem.h"
#include "io/products.h"
#include "service/config.h"

/* the station plots' fontconfig cache, as in test_products */
const char *__lsan_default_suppressions(void);
const char *__lsan_default_suppressions(void) { return "leak:libfontconfig\n"; }

#define T0 1705276800.0 /* 2024-01-15T00:00:00Z */
#define NT 3

static prod_grid G = { 20, 20, 120.0, 38.0, 0.05, 0.05 };

/* docs/dem.md: p_G = C_R (h/h1)^n (w/h)^m, h1 = 1 m, n = -0.5 + h/5 for
 * h < 1 m else -0.3, m = -0.16; F = p_G w h. */
static double iso_force(double c_r, double h, double w)
{
    double n = h < 1.0 ? -0.5 + h / 5.0 : -0.3;
    return c_r * pow(h / 1.0, n) * pow(w / h, -0.16) * w * h;
}

/* per output time: concentration, thickness, northward drift */
static const double CONC[NT] = { 0.9, 0.9, 0.1 };
static const double THICK[NT] = { 0.26, 0.3, 0.2 };
static const double VN[NT] = { -0.2, 0.0, -0.2 };

static int run(const char *stage, const prod_station *st, const prod_structure *ps, int ns, prod_summary *sum)
{
    prod_options o;
    products_options_default(&o);
    o.prefix = "t";
    o.stations = st;
    o.nstations = ns;
    o.structures = ps;
    /* a short, small DEM where the scene needs it (t0): test_loads_dem checks its numbers */
    o.loads.duration = 0.003;
    o.loads.sheet_length = 0.4;
    o.loads.sheet_width = 0.5;
    prod_meta m = { .title = "loads test", .config_sha256 = "abc", .cycle_time = T0, .start_mode = "cold" };
    sph_error err = { 0 };
    prod_writer *p = NULL;
    int rc = products_open(&p, &o, &G, &m, stage, &err);
    if (rc != SPH_OK) {
        CHECK(0, "open: %s", err.msg);
        return rc;
    }
    size_t nn = (size_t)G.nlon * G.nlat;
    double *f = malloc(8 * nn * sizeof *f);
    for (int t = 0; t < NT && rc == SPH_OK; t++) {
        for (size_t k = 0; k < nn; k++) {
            f[k] = CONC[t];
            f[nn + k] = CONC[t] * THICK[t];
            f[2 * nn + k] = THICK[t];
            f[3 * nn + k] = 0.0;
            f[4 * nn + k] = VN[t];
            f[5 * nn + k] = 1000.0;
            f[6 * nn + k] = 0.0;
            f[7 * nn + k] = 0.0;
        }
        prod_fields pf = { f, f + nn, f + 2 * nn, f + 3 * nn, f + 4 * nn, f + 5 * nn, f + 6 * nn, f + 7 * nn,
                           NULL, NULL };
        rc = products_add_time(p, T0 + t * 3600.0, &pf, NULL, &err);
        CHECK(rc == SPH_OK, "add_time %d: %s", t, err.msg);
    }
    if (rc == SPH_OK) {
        rc = products_close(p, sum, &err);
        CHECK(rc == SPH_OK, "close: %s", err.msg);
    } else {
        products_abort(p);
    }
    free(f);
    return rc;
}

static int listed(const prod_summary *s, const char *name)
{
    for (int i = 0; i < s->nproducts; i++)
        if (!strcmp(s->products[i], name))
            return 1;
    return 0;
}

static int exists(const char *dir, const char *name)
{
    char p[1024];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    struct stat sb;
    return stat(p, &sb) == 0;
}

static void test_product(const char *root)
{
    /* A: the seed's leg (1.6 m, sub-Arctic C_R); B: no structure; C: 10 m, Arctic */
    prod_station st[3] = { { "A", 120.3, 38.3 }, { "B", 120.5, 38.5 }, { "C", 120.7, 38.7 } };
    prod_structure ps[3] = { { 1.6, 1.8e6, 300e3, 5e8, 0.03, 0, 0, 0, 0 }, { 0, 0, 0, 0, 0, 0, 0, 0, 0 },
                             { 10.0, 2.8e6, 300e3, 5e8, 0.03, 0, 0, 0, 0 } };
    char stage[512];
    snprintf(stage, sizeof stage, "%s/with", root);
    prod_summary sum;
    if (run(stage, st, ps, 3, &sum) != SPH_OK)
        return;
    CHECK(listed(&sum, "t_loads.nc") && listed(&sum, "t_loads.csv"), "the load files are in the manifest list");
    char path[1024];
    snprintf(path, sizeof path, "%s/t_loads.nc", stage);
    int nc, d, v;
    CHECK(nc_open(path, NC_NOWRITE, &nc) == NC_NOERR, "open %s", path);
    size_t nst = 0, nt = 0;
    nc_inq_dimid(nc, "station", &d);
    nc_inq_dimlen(nc, d, &nst);
    nc_inq_dimid(nc, "time", &d);
    nc_inq_dimlen(nc, d, &nt);
    CHECK(nst == 2 && nt == NT, "2 stations with a structure, %d times (got %zu, %zu)", NT, nst, nt);
    double load[2][NT], thick[2][NT];
    CHECK(nc_inq_varid(nc, "ice_load", &v) == NC_NOERR && nc_get_var_double(nc, v, &load[0][0]) == NC_NOERR,
          "read ice_load");
    CHECK(nc_inq_varid(nc, "sithick", &v) == NC_NOERR && nc_get_var_double(nc, v, &thick[0][0]) == NC_NOERR,
          "read sithick");
    char *model[2 * NT], *why[2 * NT];
    CHECK(nc_inq_varid(nc, "load_model", &v) == NC_NOERR && nc_get_var_string(nc, v, model) == NC_NOERR,
          "read load_model");
    CHECK(nc_inq_varid(nc, "load_model_reason", &v) == NC_NOERR && nc_get_var_string(nc, v, why) == NC_NOERR,
          "read load_model_reason");
    const double w[2] = { 1.6, 10.0 }, cr[2] = { 1.8e6, 2.8e6 };
    for (int k = 0; k < 2; k++)
        for (int t = 0; t < NT; t++) {
            CHECK(fabs(thick[k][t] - THICK[t]) < 1e-12, "thickness %d %d: %g", k, t, thick[k][t]);
            double want = CONC[t] >= 0.15 ? iso_force(cr[k], THICK[t], w[k]) : 0.0;
            CHECK(fabs(load[k][t] - want) <= 1e-9 * (want > 1 ? want : 1), "load %d %d: %.6f N, ISO %.6f N", k,
                  t, load[k][t], want);
        }
    /* the seed's leg at 0.26 m (docs/dem.md: 1024 kN) */
    CHECK(fabs(load[0][0] / 1e3 - 1024) < 1, "ISO leg load %.1f kN", load[0][0] / 1e3);
    /* t0: present, moving, thick: the DEM runs (issue 25 item 3: it was "dem_needed", not run); t1: still;
     * t2: loose ice */
    CHECK(!strcmp(model[0], "dem") && strstr(why[0], "all DEM thresholds"), "t0: %s (%s)", model[0], why[0]);
    CHECK(!strcmp(model[1], "cheap") && strstr(why[1], "speed"), "t1: %s (%s)", model[1], why[1]);
    CHECK(!strcmp(model[2], "cheap") && strstr(why[2], "concentration"), "t2: %s (%s)", model[2], why[2]);
    nc_free_string(2 * NT, model);
    nc_free_string(2 * NT, why);
    nc_close(nc);
    /* CSV: header + 2 x NT rows, the load in kN */
    snprintf(path, sizeof path, "%s/t_loads.csv", stage);
    FILE *f = fopen(path, "r");
    CHECK(f != NULL, "open %s", path);
    int rows = 0;
    char line[1024], first[1024] = "";
    while (f && fgets(line, sizeof line, f))
        if (rows++ == 1)
            snprintf(first, sizeof first, "%s", line);
    if (f)
        fclose(f);
    CHECK(rows == 1 + 2 * NT, "CSV rows %d", rows);
    char want[64];
    snprintf(want, sizeof want, ",%.3f,", iso_force(1.8e6, 0.26, 1.6) / 1e3);
    CHECK(strstr(first, want) != NULL && strstr(first, ",0,dem,\"ice present"), "CSV row %s has %s and the DEM",
          first, want);

    /* no structure: no file */
    snprintf(stage, sizeof stage, "%s/without", root);
    if (run(stage, st, ps + 1, 1, &sum) != SPH_OK) /* A without its structure */
        return;
    CHECK(!exists(stage, "t_loads.nc") && !exists(stage, "t_loads.csv") && !listed(&sum, "t_loads.nc"),
          "no load files without a structure");
    CHECK(exists(stage, "t_stations.nc"), "the station product is still written");
}

/* A cone (45 deg, D 4 m, neck 2 m, sigma_f 0.6 MPa, mu 0.15): the load is
 * Ralston's (dem_ralston_cone, tested against the formula in
 * test_dem_cone) for the sampled thickness, ride-up thickness = thickness;
 * 0 below the concentration threshold; the station's cone angle written. */
static void test_cone_product(const char *root)
{
    prod_station st[1] = { { "K", 120.3, 38.3 } };
    prod_structure ps[1] = { { .w = 4.0, .c_r = 0.0, .cone_angle = 45.0, .neck = 2.0, .sigma_f = 0.6e6, .mu = 0.15 } };
    char stage[512], path[1024];
    snprintf(stage, sizeof stage, "%s/cone", root);
    prod_summary sum;
    if (run(stage, st, ps, 1, &sum) != SPH_OK)
        return;
    snprintf(path, sizeof path, "%s/t_loads.nc", stage);
    int nc, v;
    double load[NT], angle = 0;
    CHECK(nc_open(path, NC_NOWRITE, &nc) == NC_NOERR, "open %s", path);
    CHECK(nc_inq_varid(nc, "ice_load", &v) == NC_NOERR && nc_get_var_double(nc, v, load) == NC_NOERR, "read ice_load");
    CHECK(nc_inq_varid(nc, "structure_cone_angle", &v) == NC_NOERR && nc_get_var_double(nc, v, &angle) == NC_NOERR &&
              angle == 45.0,
          "cone angle %g", angle);
    nc_close(nc);
    for (int t = 0; t < NT; t++) {
        dem_cone_ice c = { 0.6e6, THICK[t], THICK[t], 900.0, 0.15, 45.0, 4.0, 2.0 };
        dem_cone_load L;
        const char *why;
        double want = CONC[t] >= 0.15 && dem_ralston_cone(&c, &L, &why) == 0 ? L.h : 0.0;
        CHECK(fabs(load[t] - want) <= 1e-9 * (want > 1 ? want : 1), "cone load %d: %.6f N, Ralston %.6f N", t,
              load[t], want);
    }
    CHECK(load[0] > 0 && load[2] == 0.0, "ice present gives a load, loose ice none");
    printf("cone product: 0.26 m on a 45 deg, 4 m cone: %.1f kN\n", load[0] / 1e3);
}

static void test_config(void)
{
#define BASE "{\"domain\": {\"lon_min\": 119, \"lon_max\": 122, \"lat_min\": 38, \"lat_max\": 41}," \
                       " \"forcing\": [{\"name\": \"atm\", \"kind\": \"atmosphere\", \"urls\": \"/a.nc\"}]," \
                       " \"output\": {\"dir\": \"/tmp/out\"}, \"stations\": [%s]}"
    char text[2048];
    sph_error e;
    struct sph_config *c = NULL;
    snprintf(text, sizeof text, BASE,
             "{\"name\": \"JZ20-2\", \"lon\": 121.37, \"lat\": 40.47, \"structure\": {\"kind\": \"vertical\", "
             "\"diameter\": 2.5, \"c_r\": 2.8}}, {\"name\": \"plain\", \"lon\": 121, \"lat\": 40}");
    sph_error_clear(&e);
    CHECK(sph_config_parse(text, "t.json", &c, &e) == SPH_OK, "structure parses: %s", e.msg);
    if (c) {
        CHECK(c->nstations == 2 && c->stations[0].structure_kind == 1 && c->stations[0].structure_diameter == 2.5 &&
                  c->stations[0].structure_c_r == 2.8,
              "structure keys read");
        CHECK(c->stations[1].structure_kind == 0 && c->stations[1].structure_c_r == 1.8, "defaults: none, 1.8 MPa");
        sph_config_free(c);
    }
    c = NULL;
    snprintf(text, sizeof text, BASE,
             "{\"name\": \"Far\", \"lon\": 125, \"lat\": 40, \"structure\": {\"kind\": \"vertical\"}}");
    sph_error_clear(&e);
    int rc = sph_config_parse(text, "t.json", &c, &e);
    CHECK(rc == SPH_ERR_CONFIG && c == NULL && strstr(e.msg, "\"Far\"") && strstr(e.msg, "stations[0].structure.kind") &&
              !strchr(e.msg, '\n'),
          "a structure outside the domain refused in one line: %s", e.msg);
    /* a cone: its keys read; without its geometry, or outside Ralston's range, refused naming the key */
    snprintf(text, sizeof text, BASE,
             "{\"name\": \"JZ9-3\", \"lon\": 121, \"lat\": 40, \"structure\": {\"kind\": \"cone\", "
             "\"cone_angle\": 60, \"waterline_diameter\": 4.0, \"neck_diameter\": 2.0}}");
    sph_error_clear(&e);
    c = NULL;
    CHECK(sph_config_parse(text, "t.json", &c, &e) == SPH_OK, "cone parses: %s", e.msg);
    if (c) {
        CHECK(c->stations[0].structure_kind == 2 && c->stations[0].structure_cone_angle == 60 &&
                  c->stations[0].structure_waterline_diameter == 4.0 && c->stations[0].structure_neck_diameter == 2.0 &&
                  c->stations[0].structure_flexural_strength == 0.6 && c->stations[0].structure_friction == 0.15,
              "cone keys and defaults read");
        sph_config_free(c);
    }
    const char *bad[3][2] = {
        { "\"cone_angle\": 75, \"waterline_diameter\": 4.0, \"neck_diameter\": 2.0", "structure.cone_angle" },
        { "\"cone_angle\": 60, \"neck_diameter\": 2.0", "structure.waterline_diameter" },
        { "\"cone_angle\": 60, \"waterline_diameter\": 4.0, \"neck_diameter\": 4.0", "structure.neck_diameter" },
    };
    for (int k = 0; k < 3; k++) {
        char st[512];
        snprintf(st, sizeof st,
                 "{\"name\": \"JZ9-3\", \"lon\": 121, \"lat\": 40, \"structure\": {\"kind\": \"cone\", %s}}",
                 bad[k][0]);
        snprintf(text, sizeof text, BASE, st);
        sph_error_clear(&e);
        c = NULL;
        rc = sph_config_parse(text, "t.json", &c, &e);
        CHECK(rc == SPH_ERR_CONFIG && c == NULL && strstr(e.msg, bad[k][1]) && strstr(e.msg, "\"JZ9-3\"") &&
                  !strchr(e.msg, '\n'),
              "cone %d refused naming %s: %s", k, bad[k][1], e.msg);
    }
    /* a station outside the domain without a structure stays accepted as before */
    snprintf(text, sizeof text, BASE, "{\"name\": \"Far\", \"lon\": 125, \"lat\": 40}");
    sph_error_clear(&e);
    rc = sph_config_parse(text, "t.json", &c, &e);
    CHECK(rc == SPH_OK, "no structure, no domain check: %s", e.msg);
    sph_config_free(c);
#undef BASE
}

int main(void)
{
    char root[] = "/tmp/test_loads_XXXXXX", cmd[600];
    if (mkdtemp(root)) {
        test_product(root);
        test_cone_product(root);
        snprintf(cmd, sizeof cmd, "rm -rf '%s'", root);
        CHECK(system(cmd) == 0, "cleanup of %s", root);
    } else {
        CHECK(0, "mkdtemp");
    }
    test_config();
    return check_summary("test_loads");
}
