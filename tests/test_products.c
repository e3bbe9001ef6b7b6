/* Products writer end to end on analytic fields (io/products.h): CF
 * attributes, uniform fields, stations, GeoJSON, particles, scores,
 * manifest, publish, and the fault-injection / kill tests. */
#include <cairo.h>
#include <cjson/cJSON.h>
#include <dirent.h>
#include <math.h>
#include <netcdf.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <udunits2.h>
#include <unistd.h>

#include "check.h"
#include "io/products.h"
#include "util/fileio.h"
#include "util/timeutil.h"

#define R_M 6371000.0
#define T0 1705276800.0 /* 2024-01-15T00:00:00Z */


/* fontconfig (through cairo's toy font API) keeps a one-time cache that
 * LeakSanitizer reports at exit; it does not grow with the number of maps
 * drawn (checked with 1 and 5 renders), so it is suppressed here. */
const char *__lsan_default_suppressions(void);
const char *__lsan_default_suppressions(void) { return "leak:libfontconfig\n"; }
/* The same cache for valgrind: freed at exit when fontconfig is loaded. */
extern void FcFini(void) __attribute__((weak));
static void release_font_caches(void)
{
    cairo_debug_reset_static_data();
    if (FcFini)
        FcFini();
}

static prod_grid G = { 60, 40, 120.0, 38.0, 0.05, 0.05 };
static ut_system *UT;

typedef struct {
    double *conc, *hbar, *thick, *u, *v, *pres, *div, *shear;
    unsigned char *land;
} fieldset;

static void fs_alloc(fieldset *f)
{
    size_t nn = (size_t)G.nlon * G.nlat;
    double **a[8] = { &f->conc, &f->hbar, &f->thick, &f->u, &f->v, &f->pres, &f->div, &f->shear };
    for (int k = 0; k < 8; k++)
        *a[k] = malloc(nn * sizeof(double));
    f->land = calloc(nn, 1);
}

static void fs_free(fieldset *f)
{
    double *a[8] = { f->conc, f->hbar, f->thick, f->u, f->v, f->pres, f->div, f->shear };
    for (int k = 0; k < 8; k++)
        free(a[k]);
    free(f->land);
}

/* Uniform ice except land in the 4 westernmost columns; optionally a disc
 * of ice (conc 0.9) instead of uniform cover. */
static void fs_fill(fieldset *f, int disc, double shift_deg)
{
    for (int j = 0; j < G.nlat; j++)
        for (int i = 0; i < G.nlon; i++) {
            size_t k = (size_t)j * G.nlon + i;
            double lon = G.lon0 + i * G.dlon, lat = G.lat0 + j * G.dlat;
            int ice = !disc || hypot(lon - 121.5 - shift_deg, lat - 39.0) < 0.5;
            f->land[k] = i < 4;
            f->conc[k] = ice ? (disc ? 0.9 : 0.8) : NAN; /* NaN over sea = open water */
            f->hbar[k] = ice ? 0.24 : NAN;
            f->thick[k] = ice ? 0.3 : NAN;
            f->u[k] = ice ? 0.0 : NAN;
            f->v[k] = ice ? -0.2 : NAN; /* due south */
            f->pres[k] = ice ? 1000.0 : NAN;
            f->div[k] = ice ? 1e-7 : NAN;
            f->shear[k] = ice ? 2e-7 : NAN;
        }
}

static prod_fields fs_view(const fieldset *f)
{
    prod_fields pf = { f->conc, f->hbar, f->thick, f->u, f->v, f->pres, f->div, f->shear, f->land, NULL };
    return pf;
}

static int att_text(int nc, int v, const char *name, char *buf, size_t len)
{
    size_t n;
    if (nc_inq_attlen(nc, v, name, &n) != NC_NOERR || n >= len)
        return 0;
    if (nc_get_att_text(nc, v, name, buf) != NC_NOERR)
        return 0;
    buf[n] = '\0';
    return 1;
}

/* Every data variable: units (udunits-parsable) and standard_name or
 * long_name; coordinates: axis and standard_name; time: CF units. */
static void check_cf(const char *path)
{
    int nc, nvars;
    CHECK(nc_open(path, NC_NOWRITE, &nc) == NC_NOERR, "open %s", path);
    nc_inq_nvars(nc, &nvars);
    char conv[64];
    CHECK(att_text(nc, NC_GLOBAL, "Conventions", conv, sizeof conv) && strstr(conv, "CF-1.8"),
          "%s: Conventions", path);
    for (int v = 0; v < nvars; v++) {
        char name[NC_MAX_NAME + 1], buf[1024];
        nc_inq_varname(nc, v, name);
        if (att_text(nc, v, "geometry_type", buf, sizeof buf) ||
            att_text(nc, v, "cf_role", buf, sizeof buf) ||
            att_text(nc, v, "instance_dimension", buf, sizeof buf))
            continue; /* geometry container, DSG instance ids and index */
        int has_units = att_text(nc, v, "units", buf, sizeof buf);
        CHECK(has_units, "%s: %s has no units", path, name);
        if (has_units && UT) {
            ut_unit *u = ut_parse(UT, buf, UT_UTF8);
            CHECK(u != NULL, "%s: %s units '%s' do not parse", path, name, buf);
            ut_free(u);
        }
        char sn[256], ln[512];
        CHECK(att_text(nc, v, "standard_name", sn, sizeof sn) ||
                  att_text(nc, v, "long_name", ln, sizeof ln),
              "%s: %s has neither standard_name nor long_name", path, name);
        int is_coord = !strcmp(name, "lon") || !strcmp(name, "lat") || !strcmp(name, "time");
        if (is_coord) {
            CHECK(att_text(nc, v, "axis", buf, sizeof buf), "%s: %s has no axis", path, name);
            CHECK(att_text(nc, v, "standard_name", sn, sizeof sn), "%s: %s: no standard_name",
                  path, name);
        }
        if (!strcmp(name, "time")) {
            att_text(nc, v, "units", buf, sizeof buf);
            CHECK(!strcmp(buf, "seconds since 1970-01-01 00:00:00"), "%s: time units '%s'", path, buf);
            CHECK(att_text(nc, v, "calendar", buf, sizeof buf) && !strcmp(buf, "standard"),
                  "%s: calendar", path);
        }
    }
    nc_close(nc);
}

static int exists(const char *dir, const char *name)
{
    char p[1024];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    struct stat sb;
    return stat(p, &sb) == 0;
}

/* Number of entries in dir (excluding . and ..) containing `part`. */
static int count_entries(const char *dir, const char *part)
{
    DIR *d = opendir(dir);
    int n = 0;
    struct dirent *e;
    while (d && (e = readdir(d)))
        if (e->d_name[0] != '.' && strstr(e->d_name, part))
            n++;
    if (d)
        closedir(d);
    return n;
}

static void rm_tree(const char *dir)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    char p[1024];
    while (d && (e = readdir(d))) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
            continue;
        snprintf(p, sizeof p, "%s/%s", dir, e->d_name);
        struct stat sb;
        if (lstat(p, &sb) == 0 && S_ISDIR(sb.st_mode))
            rm_tree(p);
        else
            unlink(p);
    }
    if (d)
        closedir(d);
    rmdir(dir);
}

static double sea_area_m2(const unsigned char *land)
{
    double s = 0, d2r = M_PI / 180;
    for (int j = 0; j < G.nlat; j++) {
        double lat = G.lat0 + j * G.dlat;
        double a = R_M * R_M * G.dlon * d2r * (sin((lat + G.dlat / 2) * d2r) - sin((lat - G.dlat / 2) * d2r));
        for (int i = 0; i < G.nlon; i++)
            s += land[(size_t)j * G.nlon + i] ? 0 : a;
    }
    return s;
}

static const prod_station STATIONS[2] = { { "Bayuquan", 121.0, 39.0 }, { "Off \"Bay\", mouth", 122.5, 39.5 } };

static void base_options(prod_options *o)
{
    products_options_default(o);
    o->prefix = "bohai";
    o->has_reference = 1;
    o->ref_lon = 121.5;
    o->ref_lat = 39.0;
    o->ref_name = "disc centre";
    o->stations = STATIONS;
    o->nstations = 2;
    o->write_particles = 1;
    o->quicklook_every = 2;
}

static void base_meta(prod_meta *m, const char *const *forcing)
{
    memset(m, 0, sizeof *m);
    m->title = "sphice Bohai test";
    m->config_sha256 = "abc123";
    m->forcing_sha256 = forcing;
    m->cycle_time = T0;
    m->stale_forcing = 1;
    m->start_mode = "cold";
}

/* A full run of 3 output times; returns the stage directory's summary. */
static int full_run_geojson(const char *stage, prod_summary *sum, int with_obs, int geojson)
{
    prod_options o;
    base_options(&o);
    o.write_geojson = geojson;
    const char *forcing[] = { "/data/era5.nc 0123abcd", "/data/tide.nc 4567ef", NULL };
    prod_meta m;
    base_meta(&m, forcing);
    sph_error err;
    sph_error_clear(&err);
    prod_writer *p = NULL;
    int rc = products_open(&p, &o, &G, &m, stage, &err);
    CHECK(rc == SPH_OK, "open: %s", err.msg);
    if (rc != SPH_OK)
        return rc;
    fieldset f;
    fs_alloc(&f);
    long ids[3] = { 7, 42, 1000000007L };
    double plon[3] = { 121.0, 121.2, 121.4 }, plat[3] = { 39.0, 39.1, 39.2 };
    double pu[3] = { 0.1, 0.0, -0.1 }, pv[3] = { 0.0, -0.2, 0.0 };
    double pm[3] = { 1e6, 2e6, 3e6 }, ph[3] = { 0.2, 0.3, 0.4 }, pc[3] = { 0.9, 0.8, 0.7 };
    if (with_obs) {
        fs_fill(&f, 1, 0.2); /* observed disc 0.2 deg east of the forecast */
        for (int k = 0; k < G.nlon * G.nlat; k++)
            if (isnan(f.conc[k]))
                f.conc[k] = 0.0; /* observed open water (NaN would mean unknown) */
        rc = products_set_observation(p, T0 + 2 * 21600, f.conc, &err);
        CHECK(rc == SPH_OK, "observation: %s", err.msg);
    }
    for (int t = 0; t < 3 && rc == SPH_OK; t++) {
        fs_fill(&f, t > 0, 0.0);
        prod_fields pf = fs_view(&f);
        prod_particles_view pvw = { t == 2 ? 3 : 2, plon, plat, pu, pv, pm, ph, pc, ids, NULL };
        rc = products_add_time(p, T0 + t * 21600, &pf, &pvw, &err);
        CHECK(rc == SPH_OK, "add_time %d: %s", t, err.msg);
        plon[0] += 0.01;
    }
    prod_run_info ri = {.frac_free_drift = 0.6, .frac_rheology = 0.4, .frac_zero_layer = 1.0,
                         .frac_multi_layer = 0.0, .particles_start = 1000, .particles_end = 990,
                         .budget_residual = 1e-12, .dt = 150.0, .dt_auto = 1, .solver_iterations = 37.5,
                         .solver_stalled = 0.25, .solver_rel_tol_on = 1, .solver_residual = 2e-3,
                         .solver_residual_max = 5e-3, .solver_unconverged = 0.5};
    products_set_run_info(p, &ri);
    if (rc == SPH_OK) {
        rc = products_close(p, sum, &err);
        CHECK(rc == SPH_OK, "close: %s", err.msg);
    } else {
        products_abort(p);
    }
    fs_free(&f);
    return rc;
}

static int full_run(const char *stage, prod_summary *sum, int with_obs)
{
    return full_run_geojson(stage, sum, with_obs, 1);
}

static void test_full(const char *root)
{
    char stage[512], path[700];
    snprintf(stage, sizeof stage, "%s/stage1", root);
    prod_summary sum;
    if (full_run(stage, &sum, 1) != SPH_OK)
        return;
    CHECK(sum.ntimes == 3, "ntimes %d", sum.ntimes);
    const char *want[] = { "bohai_fields.nc", "bohai_stations.nc", "bohai_stations.csv",
                           "bohai_particles.nc", "bohai_edge.geojson", "bohai_scores.json",
                           "bohai_quicklook_20240115T0000Z.png", "bohai_quicklook_20240115T1200Z.png",
                           /* issue 23: GIS products at the map times, station plots */
                           "bohai_fields_20240115T0000Z.tif", "bohai_fields_20240115T1200Z.tif",
                           "bohai_ice_classes.geojson", "bohai_gis.gpkg", "bohai_station_Bayuquan.png",
                           "bohai_station_Off__Bay___mouth.png", "manifest.json" };
    for (size_t k = 0; k < sizeof want / sizeof want[0]; k++) {
        int listed = 0;
        for (int q = 0; q < sum.nproducts; q++)
            listed |= !strcmp(sum.products[q], want[k]);
        CHECK(listed && exists(stage, want[k]), "product %s listed and present", want[k]);
    }
    CHECK(count_entries(stage, ".tmp.") == 0, "no temporary files left");

    /* CF attributes in every NetCDF product */
    snprintf(path, sizeof path, "%s/bohai_fields.nc", stage);
    check_cf(path);
    char sp[700], pp[700];
    snprintf(sp, sizeof sp, "%s/bohai_stations.nc", stage);
    check_cf(sp);
    snprintf(pp, sizeof pp, "%s/bohai_particles.nc", stage);
    check_cf(pp);

    /* Uniform field at time 0: every sea cell 0.8 etc., land fill. */
    int nc, v;
    CHECK(nc_open(path, NC_NOWRITE, &nc) == NC_NOERR, "open fields");
    size_t nn = (size_t)G.nlon * G.nlat;
    float *buf = malloc(nn * sizeof *buf);
    const char *vars[] = { "siconc", "sivol", "sithick", "siu", "siv", "sicompstren", "sidivvel",
                           "sishearvel" };
    const double vals[] = { 0.8, 0.24, 0.3, 0.0, -0.2, 1000.0, 1e-7, 2e-7 };
    for (int q = 0; q < 8; q++) {
        size_t start[3] = { 0, 0, 0 }, count[3] = { 1, (size_t)G.nlat, (size_t)G.nlon };
        CHECK(nc_inq_varid(nc, vars[q], &v) == NC_NOERR && nc_get_vara_float(nc, v, start, count, buf) == NC_NOERR,
              "read %s", vars[q]);
        int bad = 0, badland = 0;
        for (size_t k = 0; k < nn; k++) {
            int land = (k % G.nlon) < 4;
            if (land)
                badland += buf[k] != PROD_FILL_FLOAT;
            else
                bad += fabs(buf[k] - vals[q]) > 1e-6 * fabs(vals[q]) + 1e-12;
        }
        CHECK(bad == 0, "%s: %d sea cells differ from the uniform %g", vars[q], bad, vals[q]);
        CHECK(badland == 0, "%s: %d land cells not fill", vars[q], badland);
        /* one time step per chunk, deflated */
        size_t ch[3];
        int storage, shuffle, deflate, level;
        nc_inq_var_chunking(nc, v, &storage, ch);
        nc_inq_var_deflate(nc, v, &shuffle, &deflate, &level);
        CHECK(storage == NC_CHUNKED && ch[0] == 1 && ch[1] == (size_t)G.nlat && ch[2] == (size_t)G.nlon,
              "%s chunking", vars[q]);
        CHECK(deflate && level == 4, "%s deflate", vars[q]);
    }
    /* time 1 (disc): open water is 0, thickness fill outside the disc */
    size_t start[3] = { 1, 0, 0 }, count[3] = { 1, (size_t)G.nlat, (size_t)G.nlon };
    nc_inq_varid(nc, "siconc", &v);
    nc_get_vara_float(nc, v, start, count, buf);
    size_t far = (size_t)2 * G.nlon + 50; /* (lon 122.5, lat 38.1): outside the disc, sea */
    CHECK(buf[far] == 0.0f, "open water siconc %g", buf[far]);
    nc_inq_varid(nc, "sithick", &v);
    nc_get_vara_float(nc, v, start, count, buf);
    CHECK(buf[far] == PROD_FILL_FLOAT, "no-ice sithick is fill");
    /* area and volume at time 0: 0.8 and 0.24 m times the sea area */
    unsigned char *land = calloc(nn, 1);
    for (size_t k = 0; k < nn; k++)
        land[k] = (k % G.nlon) < 4;
    double sea = sea_area_m2(land);
    double area0, vol0, ext0;
    size_t t0 = 0;
    nc_inq_varid(nc, "siarea", &v);
    nc_get_var1_double(nc, v, &t0, &area0);
    nc_inq_varid(nc, "sivolume", &v);
    nc_get_var1_double(nc, v, &t0, &vol0);
    nc_inq_varid(nc, "siextent", &v);
    nc_get_var1_double(nc, v, &t0, &ext0);
    CHECK_CLOSE(area0, 0.8 * sea * 1e-6, 1e-9, 0, "ice area km2 (uniform)");
    CHECK_CLOSE(ext0, sea * 1e-6, 1e-9, 0, "ice extent km2 (uniform)");
    CHECK_CLOSE(vol0, 0.24 * sea * 1e-9, 1e-9, 0, "ice volume km3 (uniform)");
    /* edge distance at the last time: disc of radius 0.5 deg around the
     * reference: distance ~ the farthest point of the disc (north-south
     * 0.5 deg = 55.6 km = 30 nm; east-west 0.5 deg * cos 39 is shorter) */
    size_t t2 = 2;
    double dist;
    nc_inq_varid(nc, "edge_distance", &v);
    nc_get_var1_double(nc, v, &t2, &dist);
    double want_nm = R_M * 0.5 * M_PI / 180 / 1852;
    CHECK_CLOSE(dist, want_nm, 0, R_M * 0.5 * G.dlat * M_PI / 180 / 1852, "edge distance nm");
    CHECK_CLOSE(sum.edge_distance_nm, dist, 1e-12, 0, "summary edge distance");
    /* edge geometry: node counts add up, parts consistent */
    int d_node, d_part, v_nc, v_pc;
    size_t nnode, npart;
    nc_inq_dimid(nc, "edge_node", &d_node);
    nc_inq_dimlen(nc, d_node, &nnode);
    nc_inq_dimid(nc, "edge_part", &d_part);
    nc_inq_dimlen(nc, d_part, &npart);
    nc_inq_varid(nc, "edge_node_count", &v_nc);
    nc_inq_varid(nc, "edge_part_node_count", &v_pc);
    int counts[3] = { 0 }, *parts = malloc((npart ? npart : 1) * sizeof(int));
    nc_get_var_int(nc, v_nc, counts);
    if (npart)
        nc_get_var_int(nc, v_pc, parts);
    long psum = 0;
    for (size_t k = 0; k < npart; k++)
        psum += parts[k];
    CHECK(counts[0] == 0, "uniform cover touching only land/boundary: no edge at t0 (%d)", counts[0]);
    CHECK((size_t)(counts[0] + counts[1] + counts[2]) == nnode && (size_t)psum == nnode,
          "edge node counts %d+%d+%d, parts %ld, nodes %zu", counts[0], counts[1], counts[2], psum, nnode);
    free(parts);
    /* provenance and scores attributes */
    char txt[1024];
    CHECK(att_text(nc, NC_GLOBAL, "sphice_config_sha256", txt, sizeof txt) && !strcmp(txt, "abc123"),
          "config sha");
    CHECK(att_text(nc, NC_GLOBAL, "sphice_forcing_sha256", txt, sizeof txt) &&
              strstr(txt, "/data/tide.nc 4567ef"), "forcing sha list");
    int stale = 0;
    CHECK(nc_get_att_int(nc, NC_GLOBAL, "sphice_stale_forcing", &stale) == NC_NOERR && stale == 1,
          "stale flag");
    double fr = 0, iiee = 0;
    CHECK(nc_get_att_double(nc, NC_GLOBAL, "sphice_regime_fraction_free_drift", &fr) == NC_NOERR &&
              fr == 0.6, "regime fraction");
    double mit = 0, stl = 0;
    CHECK(nc_get_att_double(nc, NC_GLOBAL, "sphice_solver_mean_iterations", &mit) == NC_NOERR &&
              mit == 37.5 &&
              nc_get_att_double(nc, NC_GLOBAL, "sphice_solver_stalled_fraction", &stl) == NC_NOERR &&
              stl == 0.25,
          "solver attributes %g %g", mit, stl);
    double mres = 0, unc = 0;
    size_t wl = 0;
    CHECK(nc_get_att_double(nc, NC_GLOBAL, "sphice_solver_mean_relative_residual", &mres) == NC_NOERR &&
              mres == 2e-3 &&
              nc_get_att_double(nc, NC_GLOBAL, "sphice_solver_unconverged_fraction", &unc) == NC_NOERR &&
              unc == 0.5 && nc_inq_attlen(nc, NC_GLOBAL, "sphice_solver_warning", &wl) == NC_NOERR && wl > 20,
          "residual rule attributes %g %g, warning %zu", mres, unc, wl);
    double dtv = 0;
    char pol[16] = "";
    size_t pl = 0;
    CHECK(nc_get_att_double(nc, NC_GLOBAL, "sphice_dt_dynamics", &dtv) == NC_NOERR && dtv == 150.0,
          "dynamic step attribute %g", dtv);
    CHECK(nc_inq_attlen(nc, NC_GLOBAL, "sphice_dt_policy", &pl) == NC_NOERR && pl < sizeof pol &&
              nc_get_att_text(nc, NC_GLOBAL, "sphice_dt_policy", pol) == NC_NOERR && !strcmp(pol, "auto"),
          "dt policy attribute '%s'", pol);
    CHECK(nc_get_att_double(nc, NC_GLOBAL, "sphice_score_iiee_km2", &iiee) == NC_NOERR,
          "IIEE attribute");
    CHECK(sum.has_scores && fabs(iiee - sum.scores.iiee_km2) < 1e-6 * iiee, "scores in summary");
    CHECK(sum.scores.iiee_km2 > 0 && sum.scores.skill_persistence > 0,
          "shifted disc: IIEE %g > 0, beats persistence (uniform cover) %g", sum.scores.iiee_km2,
          sum.scores.skill_persistence);
    nc_close(nc);
    free(buf);
    free(land);

    /* stations: NetCDF and CSV report the uniform values at time 0 */
    CHECK(nc_open(sp, NC_NOWRITE, &nc) == NC_NOERR, "open stations");
    const char *svars[] = { "siconc", "sithick", "sivol", "sispeed", "sidir", "sicompstren" };
    const double svals[] = { 0.8, 0.3, 0.24, 0.2, 180.0, 1000.0 };
    for (int q = 0; q < 6; q++) {
        float x = 0;
        size_t idx[2] = { 0, 0 };
        nc_inq_varid(nc, svars[q], &v);
        nc_get_var1_float(nc, v, idx, &x);
        CHECK_CLOSE(x, svals[q], 1e-6, 0, svars[q]);
    }
    char ft[64];
    CHECK(att_text(nc, NC_GLOBAL, "featureType", ft, sizeof ft) && !strcmp(ft, "timeSeries"),
          "featureType timeSeries");
    nc_close(nc);
    snprintf(path, sizeof path, "%s/bohai_stations.csv", stage);
    char *csv = NULL;
    sph_error err;
    sph_error_clear(&err);
    CHECK(read_file(path, &csv, NULL, &err) == SPH_OK, "%s", err.msg);
    if (csv) {
        CHECK(!strncmp(csv, "station,lon,lat,valid_time,siconc,", 34), "CSV header");
        int lines = 0;
        for (char *c = csv; *c; c++)
            lines += *c == '\n';
        CHECK(lines == 1 + 3 * 2, "CSV lines %d", lines);
        CHECK(strstr(csv, "\"Bayuquan\",121.000000,39.000000,2024-01-15T00:00:00Z,0.8000,0.3000,0.2400,"
                          "0.2000,180.0,0.0000,-0.2000,1000.0\n") != NULL, "CSV row of the uniform field");
        CHECK(strstr(csv, "\"Off \"\"Bay\"\", mouth\"") != NULL, "CSV quoting");
        free(csv);
    }

    /* GeoJSON */
    snprintf(path, sizeof path, "%s/bohai_edge.geojson", stage);
    char *gj = NULL;
    CHECK(read_file(path, &gj, NULL, &err) == SPH_OK, "%s", err.msg);
    cJSON *root_j = gj ? cJSON_Parse(gj) : NULL;
    CHECK(root_j != NULL, "GeoJSON parses");
    if (root_j) {
        cJSON *type = cJSON_GetObjectItem(root_j, "type"), *feats = cJSON_GetObjectItem(root_j, "features");
        CHECK(cJSON_IsString(type) && !strcmp(type->valuestring, "FeatureCollection"), "FeatureCollection");
        CHECK(cJSON_GetArraySize(feats) == 3, "one feature per time");
        int t = 0, npts = 0, bad = 0;
        cJSON *f;
        cJSON_ArrayForEach(f, feats) {
            cJSON *props = cJSON_GetObjectItem(f, "properties"), *geom = cJSON_GetObjectItem(f, "geometry");
            cJSON *vt = cJSON_GetObjectItem(props, "valid_time");
            double tv;
            CHECK(cJSON_IsString(vt) && time_parse_iso(vt->valuestring, &tv) == 0 && tv == T0 + t * 21600,
                  "feature %d valid_time", t);
            cJSON *gt = cJSON_GetObjectItem(geom, "type");
            CHECK(cJSON_IsString(gt) && (!strcmp(gt->valuestring, "MultiLineString") ||
                                         !strcmp(gt->valuestring, "LineString")), "geometry type");
            cJSON *line, *pt;
            cJSON_ArrayForEach(line, cJSON_GetObjectItem(geom, "coordinates")) {
                cJSON_ArrayForEach(pt, line) {
                    double lon = cJSON_GetArrayItem(pt, 0)->valuedouble, lat = cJSON_GetArrayItem(pt, 1)->valuedouble;
                    bad += !(lon >= G.lon0 && lon <= G.lon0 + (G.nlon - 1) * G.dlon &&
                             lat >= G.lat0 && lat <= G.lat0 + (G.nlat - 1) * G.dlat);
                    /* [lon, lat] order: the disc is at 121.5 E, 39 N; a binary
                     * field puts the edge between an ice and a water node */
                    bad += fabs(hypot(lon - 121.5, lat - 39.0) - 0.5) > G.dlon;
                    npts++;
                }
            }
            t++;
        }
        CHECK(npts > 50 && bad == 0, "GeoJSON points %d, %d out of place", npts, bad);
        cJSON_Delete(root_j);
    }
    free(gj);

    /* particles read back */
    prod_particles rp;
    CHECK(products_read_particles(pp, NAN, &rp, &err) == SPH_OK, "%s", err.msg);
    CHECK(rp.n == 3 && rp.time == T0 + 2 * 21600, "last time: %zu particles", rp.n);
    if (rp.n == 3) {
        CHECK(rp.id[0] == 7 && rp.id[1] == 42 && rp.id[2] == 1000000007L, "ids");
        CHECK_CLOSE(rp.lon[0], 121.02, 1e-12, 0, "lon moved");
        CHECK_CLOSE(rp.v_north[1], -0.2, 1e-6, 0, "v");
        CHECK_CLOSE(rp.mass[2], 3e6, 1e-6, 0, "mass");
    }
    prod_particles_free(&rp);
    CHECK(products_read_particles(pp, T0 + 21600, &rp, &err) == SPH_OK && rp.n == 2,
          "time 1 has 2 particles");
    prod_particles_free(&rp);
    CHECK(nc_open(pp, NC_NOWRITE, &nc) == NC_NOERR, "open particles");
    int d_traj;
    size_t ntraj;
    nc_inq_dimid(nc, "trajectory", &d_traj);
    nc_inq_dimlen(nc, d_traj, &ntraj);
    CHECK(ntraj == 3, "3 trajectories (%zu)", ntraj);
    CHECK(att_text(nc, NC_GLOBAL, "featureType", ft, sizeof ft) && !strcmp(ft, "trajectory"),
          "featureType trajectory");
    nc_close(nc);

    /* publish: stage -> final, latest -> final */
    char final1[512], latest[512], link[512];
    snprintf(final1, sizeof final1, "%s/2024011500", root);
    snprintf(latest, sizeof latest, "%s/latest", root);
    CHECK(products_publish(stage, final1, latest, &err) == SPH_OK, "publish: %s", err.msg);
    ssize_t n = readlink(latest, link, sizeof link - 1);
    link[n > 0 ? n : 0] = '\0';
    CHECK(!strcmp(link, "2024011500"), "latest -> %s", link);
    CHECK(exists(final1, "bohai_fields.nc") && !exists(stage, "."), "stage moved into place");
}

/* The trajectory index of a particle id is the order in which the ids are
 * first met, whatever table holds them (a dense one for ids from 0 up to
 * about twice the trajectories, a hash for the others: negative, huge, or
 * met before the dense table reaches them, then moved into it): checked
 * against the naive first-met order of the same ids. */
static void test_trajectory_ids(const char *root)
{
    char stage[512], pp[700];
    snprintf(stage, sizeof stage, "%s/stage_ids", root);
    prod_options o;
    base_options(&o);
    o.write_geojson = 0;
    o.quicklook_every = 0;
    o.nstations = 0;
    const char *forcing[] = {NULL};
    prod_meta m;
    base_meta(&m, forcing);
    sph_error err;
    sph_error_clear(&err);
    prod_writer *p = NULL;
    int rc = products_open(&p, &o, &G, &m, stage, &err);
    CHECK(rc == SPH_OK, "open: %s", err.msg);
    if (rc != SPH_OK)
        return;
    enum { NT = 3, NMAX = 12000 };
    /* time 0: ids 9000 and 5000 (hash: the dense table is not there yet),
     * 3, -4, a huge one; time 1: 0 .. 11999 backwards (the dense table grows
     * over 5000 and 9000); time 2: new ones of both kinds and old ones */
    static long ids[NT][NMAX];
    size_t n[NT] = {0, 0, 0};
    long t0[] = {9000, 5000, 3, -4, 4000000000000L};
    for (size_t k = 0; k < 5; k++)
        ids[0][n[0]++] = t0[k];
    for (long k = NMAX - 1; k >= 0; k--)
        ids[1][n[1]++] = k;
    long t2[] = {-4, 70000, 4000000000001L, 11999, 24000, -9, 5000, 9000, 3, 24001};
    for (size_t k = 0; k < sizeof t2 / sizeof t2[0]; k++)
        ids[2][n[2]++] = t2[k];
    fieldset f;
    fs_alloc(&f);
    static double plon[NMAX], plat[NMAX], zero[NMAX], one[NMAX];
    for (size_t k = 0; k < NMAX; k++) {
        plon[k] = 121.0 + 1e-5 * (double)k;
        plat[k] = 39.0;
        one[k] = 1.0;
    }
    for (int t = 0; t < NT && rc == SPH_OK; t++) {
        fs_fill(&f, 0, 0.0);
        prod_fields pf = fs_view(&f);
        prod_particles_view pvw = {n[t], plon, plat, zero, zero, one, one, one, ids[t], NULL};
        rc = products_add_time(p, T0 + t * 21600, &pf, &pvw, &err);
        CHECK(rc == SPH_OK, "add_time %d: %s", t, err.msg);
    }
    if (rc == SPH_OK) {
        prod_summary sum;
        rc = products_close(p, &sum, &err);
        CHECK(rc == SPH_OK, "close: %s", err.msg);
    } else {
        products_abort(p);
    }
    fs_free(&f);
    if (rc != SPH_OK)
        return;
    /* the naive first-met order */
    static long first[NT * NMAX], want[NT * NMAX];
    size_t nfirst = 0, nobs = 0;
    for (int t = 0; t < NT; t++)
        for (size_t k = 0; k < n[t]; k++) {
            size_t j = 0;
            while (j < nfirst && first[j] != ids[t][k])
                j++;
            if (j == nfirst)
                first[nfirst++] = ids[t][k];
            want[nobs++] = (long)j;
        }
    snprintf(pp, sizeof pp, "%s/bohai_particles.nc", stage);
    int nc, v, d;
    size_t ntraj = 0, nfile = 0;
    CHECK(nc_open(pp, NC_NOWRITE, &nc) == NC_NOERR, "open %s", pp);
    nc_inq_dimid(nc, "trajectory", &d);
    nc_inq_dimlen(nc, d, &ntraj);
    nc_inq_dimid(nc, "obs", &d);
    nc_inq_dimlen(nc, d, &nfile);
    CHECK(ntraj == nfirst && nfile == nobs, "%zu trajectories (%zu distinct ids), %zu observations (%zu)", ntraj,
          nfirst, nfile, nobs);
    if (ntraj == nfirst && nfile == nobs) {
        int *tix = malloc(nobs * sizeof *tix);
        long long *tid = malloc(ntraj * sizeof *tid);
        CHECK(nc_inq_varid(nc, "trajectory_index", &v) == NC_NOERR && nc_get_var_int(nc, v, tix) == NC_NOERR &&
                  nc_inq_varid(nc, "trajectory_id", &v) == NC_NOERR && nc_get_var_longlong(nc, v, tid) == NC_NOERR,
              "read trajectory_index and trajectory_id");
        size_t bad = 0, badid = 0;
        for (size_t k = 0; k < nobs; k++)
            bad += tix[k] != want[k];
        for (size_t j = 0; j < ntraj; j++)
            badid += tid[j] != first[j];
        CHECK(bad == 0 && badid == 0, "trajectory indices in first-met order: %zu of %zu differ, %zu ids", bad, nobs,
              badid);
        free(tix);
        free(tid);
    }
    nc_close(nc);
}

/* Fault injection: error path and kill path. */
static void test_faults(const char *root)
{
    char latest[512], before[512], after[512], stage[512];
    snprintf(latest, sizeof latest, "%s/latest", root);
    ssize_t n = readlink(latest, before, sizeof before - 1);
    before[n > 0 ? n : 0] = '\0';
    CHECK(n > 0, "latest exists before the fault tests");

    /* in-process: add_time fails, abort leaves nothing */
    snprintf(stage, sizeof stage, "%s/stage-fault", root);
    setenv("SPHICE_FAULT", "products-mid-write", 1);
    prod_summary sum;
    sph_error err;
    sph_error_clear(&err);
    prod_options o;
    base_options(&o);
    prod_meta m;
    base_meta(&m, NULL);
    prod_writer *p = NULL;
    CHECK(products_open(&p, &o, &G, &m, stage, &err) == SPH_OK, "%s", err.msg);
    fieldset f;
    fs_alloc(&f);
    fs_fill(&f, 0, 0);
    prod_fields pf = fs_view(&f);
    int rc = products_add_time(p, T0, &pf, NULL, &err);
    CHECK(rc == SPH_ERR_IO && strstr(err.msg, "fault injected"), "fault reported: %s", err.msg);
    CHECK(products_close(p, &sum, &err) != SPH_OK, "close of a failed writer fails");
    unsetenv("SPHICE_FAULT");
    CHECK(count_entries(stage, "") == 0, "no file left in the stage (%d)", count_entries(stage, ""));
    sph_error_clear(&err);
    char final2[512];
    snprintf(final2, sizeof final2, "%s/2024011506", root);
    CHECK(products_publish(stage, final2, latest, &err) != SPH_OK, "incomplete stage refused");
    n = readlink(latest, after, sizeof after - 1);
    after[n > 0 ? n : 0] = '\0';
    CHECK(!strcmp(before, after), "latest unchanged after the fault");
    rm_tree(stage);

    /* killed mid-write: child exits from inside the writer */
    snprintf(stage, sizeof stage, "%s/stage-kill", root);
    fflush(NULL);
    pid_t pid = fork();
    if (pid == 0) {
        setenv("SPHICE_FAULT", "products-mid-write", 1);
        setenv("SPHICE_FAULT_EXIT", "1", 1);
        sph_error e2;
        sph_error_clear(&e2);
        prod_writer *q = NULL;
        if (products_open(&q, &o, &G, &m, stage, &e2) != SPH_OK)
            _exit(3);
        products_add_time(q, T0, &pf, NULL, &e2);
        _exit(4); /* not reached when the fault fires */
    }
    int status = 0;
    waitpid(pid, &status, 0);
    CHECK(WIFEXITED(status) && WEXITSTATUS(status) == 99, "child died in the writer (status %d)", status);
    const char *finals[] = { "bohai_fields.nc", "bohai_stations.nc", "bohai_stations.csv",
                             "bohai_particles.nc", "bohai_edge.geojson", "manifest.json" };
    for (int k = 0; k < 6; k++)
        CHECK(!exists(stage, finals[k]), "no %s under its final name after the kill", finals[k]);
    CHECK(count_entries(stage, ".tmp.") > 0, "the killed writer left only temporary files");
    CHECK(products_publish(stage, final2, latest, &err) != SPH_OK, "killed stage refused");
    n = readlink(latest, after, sizeof after - 1);
    after[n > 0 ? n : 0] = '\0';
    CHECK(!strcmp(before, after), "latest unchanged after the kill");
    rm_tree(stage);
    fs_free(&f);

    /* republishing the same cycle replaces it; latest follows */
    snprintf(stage, sizeof stage, "%s/stage2", root);
    if (full_run(stage, &sum, 0) == SPH_OK) {
        CHECK(!sum.has_scores && !exists(stage, "bohai_scores.json"), "no observation: no scores");
        char final1[512];
        snprintf(final1, sizeof final1, "%s/2024011500", root);
        CHECK(products_publish(stage, final1, latest, &err) == SPH_OK, "republish: %s", err.msg);
        CHECK(count_entries(root, ".old.") == 0, "replaced directory removed");
        n = readlink(latest, after, sizeof after - 1);
        after[n > 0 ? n : 0] = '\0';
        CHECK(!strcmp(after, "2024011500"), "latest still -> %s", after);
    }

    /* output.products.geojson false: no GeoJSON file, the fields file as before */
    snprintf(stage, sizeof stage, "%s/stage3", root);
    if (full_run_geojson(stage, &sum, 0, 0) == SPH_OK) {
        CHECK(!exists(stage, "bohai_edge.geojson"), "write_geojson 0: no GeoJSON file");
        CHECK(exists(stage, "bohai_fields.nc"), "write_geojson 0: the fields file still written");
        rm_tree(stage);
    }
}

static void test_bad_input(const char *root)
{
    prod_options o;
    base_options(&o);
    prod_station far_st[1] = { { "Nowhere", 10.0, 10.0 } };
    o.stations = far_st;
    o.nstations = 1;
    prod_meta m;
    base_meta(&m, NULL);
    prod_writer *p = NULL;
    sph_error err;
    sph_error_clear(&err);
    char stage[512];
    snprintf(stage, sizeof stage, "%s/stage-bad", root);
    CHECK(products_open(&p, &o, &G, &m, stage, &err) == SPH_ERR_CONFIG && strstr(err.msg, "Nowhere"),
          "station outside the grid named: %s", err.msg);
    CHECK(p == NULL, "no writer on failure");
    CHECK(products_drift_direction_deg(0.0, -1.0) == 180.0, "due south = 180");
    CHECK(products_drift_direction_deg(1.0, 0.0) == 90.0, "due east = 90");
    CHECK(products_drift_direction_deg(-1.0, 0.0) == 270.0, "due west = 270");
    CHECK(products_drift_direction_deg(0.0, 1.0) == 0.0, "due north = 0");
    CHECK(products_drift_direction_deg(-0.0, -1.0) == 180.0, "signed zero: still 180");
}

int main(void)
{
    ut_set_error_message_handler(ut_ignore);
    UT = ut_read_xml(NULL);
    char root[] = "/tmp/sphice-products-XXXXXX";
    CHECK(mkdtemp(root) != NULL, "mkdtemp");
    test_full(root);
    test_trajectory_ids(root);
    test_faults(root);
    test_bad_input(root);
    if (!getenv("SPHICE_KEEP"))
        rm_tree(root);
    else
        printf("kept %s\n", root);
    ut_free_system(UT);
    release_font_caches();
    return check_summary("test_products");
}
