/* CF-1.8 cleanliness of every NetCDF product (issue 23 item 3): each
 * standard_name is an entry of the CF standard-name table (version 83,
 * tests/data/cf-standard-name-table-v83.txt, copied from the table) and its
 * units convert to the entry's canonical units through udunits2; every
 * units attribute parses; Conventions names CF-1.8 in every file, the
 * restart included; lon/lat carry cell bounds; the lead time is a
 * forecast_period variable next to forecast_reference_time; the manifest
 * lists the files written after it. Expected bounds and lead times are
 * computed here from the grid and the output times the test chose. When
 * the NCAS checker (cfchecks) is installed it must report no error. */
#include <dirent.h>
#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "check.h"
#include "core/particles.h"
#include "io/cf.h"
#include "io/ensemble.h"
#include "io/ocean_fluxes.h"
#include "io/products.h"
#include "io/restart.h"
#include "service/cycle.h"
#include "util/fileio.h"
#include "util/jsonutil.h"

#define TABLE "tests/data/cf-standard-name-table-v83.txt"
#define CYCLE 917820000.0 /* 1999-02-01T00:00:00Z */

typedef struct entry { char name[128], units[64]; } entry;
static entry table[256];
static int ntable;
static cf_units *U;

static int load_table(const char *path)
{
    FILE *f = fopen(path, "r");
    if (!f)
        return -1;
    char line[512];
    int version = 0;
    while (fgets(line, sizeof line, f) && ntable < 256) {
        line[strcspn(line, "\r\n")] = 0;
        if (line[0] == '#') {
            sscanf(line, "# version: %d", &version);
            continue;
        }
        char *tab = strchr(line, '\t');
        if (!tab || tab == line)
            continue;
        *tab = 0;
        snprintf(table[ntable].name, sizeof table[ntable].name, "%.127s", line);
        snprintf(table[ntable].units, sizeof table[ntable].units, "%.63s", tab + 1);
        ntable++;
    }
    fclose(f);
    return version;
}

static const entry *lookup(const char *name)
{
    for (int k = 0; k < ntable; k++)
        if (!strcmp(table[k].name, name))
            return &table[k];
    return NULL;
}

static int att_text(int nc, int v, const char *name, char *buf, size_t len)
{
    size_t n;
    nc_type t;
    if (nc_inq_att(nc, v, name, &t, &n) != NC_NOERR || t != NC_CHAR || n >= len)
        return 0;
    nc_get_att_text(nc, v, name, buf);
    buf[n] = 0;
    return 1;
}

/* Standard names, units and Conventions of one file; returns the number
 * of standard names checked. */
static int check_file(const char *path)
{
    int nc, nvars = 0, checked = 0;
    CHECK(nc_open(path, NC_NOWRITE, &nc) == NC_NOERR, "open %s", path);
    if (nc_inq_nvars(nc, &nvars) != NC_NOERR)
        return 0;
    char buf[512];
    CHECK(att_text(nc, NC_GLOBAL, "Conventions", buf, sizeof buf) && strstr(buf, "CF-1.8"),
          "%s: no Conventions naming CF-1.8", path);
    for (int v = 0; v < nvars; v++) {
        char name[NC_MAX_NAME + 1], sn[256], units[256];
        nc_inq_varname(nc, v, name);
        int has_units = att_text(nc, v, "units", units, sizeof units);
        /* "<unit> since <date>" is a CF time coordinate (CF 4.4): parsed as
         * such; its unit is a time, so it converts to the canonical "s" */
        int is_time = has_units && strstr(units, " since ") != NULL;
        if (is_time) {
            cf_calendar cal;
            cf_time_units tu;
            char calendar[64] = "";
            att_text(nc, v, "calendar", calendar, sizeof calendar);
            CHECK(cf_calendar_parse(calendar, &cal) == 0 && cf_time_parse(units, cal, &tu) == 0,
                  "%s: %s: time units '%s' (calendar '%s') are not CF", path, name, units, calendar);
        } else if (has_units) {
            CHECK(cf_units_convertible(U, units, units), "%s: %s: units '%s' do not parse (udunits2)",
                  path, name, units);
        }
        if (!att_text(nc, v, "standard_name", sn, sizeof sn))
            continue;
        checked++;
        const entry *e = lookup(sn);
        CHECK(e != NULL, "%s: %s: standard_name '%s' is not in the CF table v83", path, name, sn);
        if (e && e->units[0]) {
            CHECK(has_units, "%s: %s: no units (canonical '%s')", path, name, e->units);
            CHECK(has_units && cf_units_convertible(U, is_time ? "s" : units, e->units),
                  "%s: %s: units '%s' not convertible to the canonical '%s' of %s", path, name,
                  has_units ? units : "", e->units, sn);
        }
    }
    nc_close(nc);
    return checked;
}

/* ------------------------------------------------------------ products */

enum { NLON = 6, NLAT = 5, NT = 3 };
static const prod_grid GRID = { NLON, NLAT, 121.0, 39.5, 0.25, 0.2 };

static int write_products(const char *stage)
{
    double conc[NLON * NLAT], hbar[NLON * NLAT], thick[NLON * NLAT], u[NLON * NLAT],
        v[NLON * NLAT], p[NLON * NLAT], div[NLON * NLAT], shear[NLON * NLAT], snow[NLON * NLAT];
    unsigned char land[NLON * NLAT];
    for (int k = 0; k < NLON * NLAT; k++) {
        land[k] = k % NLON == 0;             /* the west column is land */
        conc[k] = 0.2 + 0.1 * (k % NLON);    /* an edge inside the grid */
        thick[k] = 0.4;
        hbar[k] = conc[k] * thick[k];
        u[k] = 0.1;
        v[k] = -0.05;
        p[k] = 1500.0;
        div[k] = 1e-6;
        shear[k] = 2e-6;
        snow[k] = 0.1;
    }
    prod_options o;
    products_options_default(&o);
    o.edge_threshold = 0.2;
    prod_station st = { "Centre", 121.6, 39.9 };
    o.stations = &st;
    o.nstations = 1;
    o.write_particles = 1;
    o.write_snow = 1; /* sisnthick (surface_snow_thickness) checked too */
    prod_meta m;
    memset(&m, 0, sizeof m);
    m.cycle_time = CYCLE;
    m.start_mode = "cold";
    sph_error err;
    sph_error_clear(&err);
    prod_writer *w = NULL;
    int rc = products_open(&w, &o, &GRID, &m, stage, &err);
    CHECK(rc == SPH_OK, "products_open: %s", err.msg);
    if (rc)
        return rc;
    double plon[2] = { 121.5, 121.7 }, plat[2] = { 39.8, 39.9 }, pu[2] = { 0.1, 0.1 },
           pv[2] = { 0, 0 }, pm[2] = { 1e5, 2e5 }, ph[2] = { 0.4, 0.4 }, pc[2] = { 0.8, 0.9 };
    long ids[2] = { 1, 2 };
    prod_particles_view pview = { 2, plon, plat, pu, pv, pm, ph, pc, ids, NULL };
    prod_fields f = { conc, hbar, thick, u, v, p, div, shear, land, snow };
    for (int t = 0; t < NT && rc == SPH_OK; t++)
        rc = products_add_time(w, CYCLE + 3 * 3600.0 * t, &f, &pview, &err);
    CHECK(rc == SPH_OK, "add_time: %s", err.msg);
    if (rc == SPH_OK) {
        rc = products_close(w, NULL, &err);
        CHECK(rc == SPH_OK, "close: %s", err.msg);
    } else {
        products_abort(w);
    }
    return rc;
}

static int write_restart(const char *path)
{
    sph_particles *P = sph_particles_create(4, 2);
    if (!P)
        return -1;
    P->n = 4;
    for (size_t k = 0; k < 4; k++) {
        P->x[k] = 1000.0 * k;
        P->mass[k] = 1e5;
        P->thick[k] = 0.3;
        P->conc[k] = 0.9;
        P->id[k] = (long)k;
    }
    restart_header h;
    memset(&h, 0, sizeof h);
    h.time = CYCLE + 86400.0;
    h.cycle_time = CYCLE;
    snprintf(h.projection, sizeof h.projection, "+proj=laea +lat_0=40 +lon_0=121");
    sph_error err;
    sph_error_clear(&err);
    int rc = restart_write(path, P, &h, &err);
    CHECK(rc == SPH_OK, "restart_write: %s", err.msg);
    sph_particles_free(P);
    return rc;
}

/* The ensemble file of two members, each the fields file written above
 * (a real member file: same grid, times and variables). */
static int write_ensemble(const char *stage, const char *fields)
{
    const char *members[2] = { fields, fields };
    double levels[1] = { 0.5 };
    ens_options o = { 0 };
    o.stage = stage;
    o.prefix = "sphice";
    o.member_fields = members;
    o.nmembers = 2;
    o.threshold = 0.2;
    o.levels = levels;
    o.nlevels = 1;
    o.seed = 7;
    o.cycle_time = CYCLE;
    ens_summary s;
    sph_error err;
    sph_error_clear(&err);
    int rc = ens_products_write(&o, &s, &err);
    CHECK(rc == SPH_OK, "ens_products_write: %s", err.msg);
    return rc;
}

/* An ocean-fluxes file with one record on a 3 x 2 grid: lon/lat axes
 * (plane = 0) or plane x/y axes with 2-D lat/lon (plane = 1). */
static int write_ocean_fluxes(const char *path, int plane)
{
    enum { NX = 3, NY = 2, NC = NX * NY };
    const double cell = 10e3;
    double xa[NX], ya[NY], lon[NC], lat[NC], cx[NC], cy[NC], area[NC];
    for (int i = 0; i < NX; i++)
        xa[i] = plane ? i * cell : 121.0 + 0.1 * i;
    for (int j = 0; j < NY; j++)
        ya[j] = plane ? j * cell : 39.5 + 0.1 * j;
    for (int c = 0; c < NC; c++) {
        cx[c] = (c % NX) * cell;
        cy[c] = (c / NX) * cell;
        lon[c] = 121.0 + 0.1 * (c % NX);
        lat[c] = 39.5 + 0.1 * (c / NX);
        area[c] = cell * cell;
    }
    ofx_grid g = { .kind = plane ? OFX_GRID_PLANE : OFX_GRID_LONLAT, .nx = NX, .ny = NY, .xaxis = xa,
                   .yaxis = ya, .lon = plane ? lon : NULL, .lat = plane ? lat : NULL, .cx = cx, .cy = cy,
                   .area = area, .projection = "+proj=laea +lat_0=40 +lon_0=121" };
    ofx_meta m = { .title = "test", .institution = "test", .model_version = "0", .git_revision = "0",
                   .cycle_time = CYCLE };
    double px = cell, py = 0.0, r = cell, heat = 1e9, water = 1e3, salt = 10.0, tx = 1e6, ty = -1e6, sw = 1e8,
           ia = 5e7, iv = 2e7;
    ofx_particles pa = { 1, &px, &py, &r, &heat, &heat, &water, &salt, &tx, &ty, &sw, &ia, &iv };
    sph_error err;
    sph_error_clear(&err);
    ofx_writer *w = NULL;
    int rc = ofx_open(&w, &g, &m, path, &err);
    if (rc == SPH_OK)
        rc = ofx_add_particles(w, &pa, &err);
    if (rc == SPH_OK)
        rc = ofx_write_record(w, CYCLE, CYCLE + 3600.0, &err);
    if (rc == SPH_OK)
        rc = ofx_close(w, &err);
    else
        ofx_abort(w);
    CHECK(rc == SPH_OK, "ocean fluxes (%s): %s", plane ? "plane" : "lonlat", err.msg);
    return rc;
}

/* lat/lon bounds: the centre -+ half a step, from the grid chosen above. */
static void check_bounds(const char *path)
{
    int nc;
    if (nc_open(path, NC_NOWRITE, &nc) != NC_NOERR)
        return;
    const struct { const char *coord; int n; double x0, dx; } ax[2] = {
        { "lat", NLAT, 39.5, 0.2 }, { "lon", NLON, 121.0, 0.25 } };
    for (int a = 0; a < 2; a++) {
        int v, vb, nd, dims[2];
        char bname[NC_MAX_NAME + 1] = "";
        CHECK(nc_inq_varid(nc, ax[a].coord, &v) == NC_NOERR &&
                  att_text(nc, v, "bounds", bname, sizeof bname),
              "%s: %s has no bounds attribute", path, ax[a].coord);
        if (!bname[0] || nc_inq_varid(nc, bname, &vb) != NC_NOERR) {
            CHECK(0, "%s: bounds variable '%s' of %s missing", path, bname, ax[a].coord);
            continue;
        }
        size_t n0 = 0, n1 = 0;
        nc_inq_varndims(nc, vb, &nd);
        if (nd == 2) {
            nc_inq_vardimid(nc, vb, dims);
            nc_inq_dimlen(nc, dims[0], &n0);
            nc_inq_dimlen(nc, dims[1], &n1);
        }
        CHECK(nd == 2 && n0 == (size_t)ax[a].n && n1 == 2, "%s: %s is not (%d, 2)", path, bname,
              ax[a].n);
        if (!(nd == 2 && n0 == (size_t)ax[a].n && n1 == 2))
            continue;
        double b[2 * NLON + 2 * NLAT];
        nc_get_var_double(nc, vb, b);
        for (int j = 0; j < ax[a].n; j++) {
            double c = ax[a].x0 + j * ax[a].dx;
            CHECK_CLOSE(b[2 * j], c - ax[a].dx / 2, 0, 1e-12, bname);
            CHECK_CLOSE(b[2 * j + 1], c + ax[a].dx / 2, 0, 1e-12, bname);
        }
    }
    nc_close(nc);
}

/* forecast_period(time) in hours = valid time minus the cycle; every
 * time-dependent data variable names it and forecast_reference_time. */
static void check_forecast_period(const char *path, const char *const *series, size_t nseries, int fields)
{
    int nc, vp, vr, vs;
    if (nc_open(path, NC_NOWRITE, &nc) != NC_NOERR)
        return;
    CHECK(nc_inq_varid(nc, "forecast_period", &vp) == NC_NOERR, "%s: no forecast_period", path);
    CHECK(nc_inq_varid(nc, "forecast_reference_time", &vr) == NC_NOERR, "%s: no forecast_reference_time",
          path);
    char units[128] = "", sn[128] = "";
    double fp[NT] = { 0 }, ref = NAN;
    if (nc_get_var_double(nc, vp, fp) == NC_NOERR && att_text(nc, vp, "units", units, sizeof units)) {
        double a = NAN, b = NAN;
        CHECK(cf_units_linear(U, units, "s", &a, &b) == 0, "%s: forecast_period units '%s'", path, units);
        for (int t = 0; t < NT; t++)
            CHECK_CLOSE(a * fp[t] + b, 3 * 3600.0 * t, 0, 1e-9, "forecast_period in seconds");
    }
    CHECK(att_text(nc, vp, "standard_name", sn, sizeof sn) && !strcmp(sn, "forecast_period"),
          "%s: forecast_period standard_name '%s'", path, sn);
    CHECK(nc_get_var_double(nc, vr, &ref) == NC_NOERR && ref == CYCLE, "%s: forecast_reference_time %g",
          path, ref);
    for (size_t k = 0; k < nseries; k++) {
        char co[256] = "";
        CHECK(nc_inq_varid(nc, series[k], &vs) == NC_NOERR && att_text(nc, vs, "coordinates", co, sizeof co) &&
                  strstr(co, "forecast_period") && strstr(co, "forecast_reference_time"),
              "%s: %s coordinates '%s'", path, series[k], co);
    }
    if (!fields) {
        nc_close(nc);
        return;
    }
    /* sea_ice_extent with its threshold as a scalar coordinate (CF table) */
    char co[256] = "";
    int vt;
    double thr = NAN;
    CHECK(nc_inq_varid(nc, "siextent", &vs) == NC_NOERR && att_text(nc, vs, "coordinates", co, sizeof co) &&
              strstr(co, "extent_threshold") && nc_inq_varid(nc, "extent_threshold", &vt) == NC_NOERR &&
              nc_get_var_double(nc, vt, &thr) == NC_NOERR && thr == 0.2,
          "%s: siextent coordinates '%s', threshold %g (0.2 asked)", path, co, thr);
    /* SIMIP's name stays, with a long_name and no invented standard name */
    char ln[256];
    CHECK(nc_inq_varid(nc, "sishearvel", &vs) == NC_NOERR && att_text(nc, vs, "long_name", ln, sizeof ln),
          "%s: sishearvel keeps a long_name", path);
    nc_close(nc);
}

/* The manifest entry named name, or NULL. */
static const cJSON *entry_named(const cJSON *files, const char *name)
{
    for (const cJSON *f = files ? files->child : NULL; f; f = f->next) {
        const char *n = cJSON_GetStringValue(cJSON_GetObjectItem(f, "name"));
        if (n && !strcmp(n, name))
            return f;
    }
    return NULL;
}

static int listed(const cJSON *files, const char *name, double bytes)
{
    const cJSON *b = cJSON_GetObjectItem(entry_named(files, name), "bytes");
    return cJSON_IsNumber(b) && b->valuedouble == bytes;
}

/* manifest.json gains the restart file and cycle.json (sizes from stat,
 * checksums from sha256sum); a missing or outside name changes nothing. */
static void check_manifest_add(const char *stage, const char *restart_name)
{
    sph_error e;
    sph_error_clear(&e);
    char p[1200], mpath[1200];
    snprintf(mpath, sizeof mpath, "%s/manifest.json", stage);
    snprintf(p, sizeof p, "%s/cycle.json", stage);
    CHECK(atomic_write_file(p, "{}\n", 3, &e) == SPH_OK, "cycle.json: %s", e.msg);
    const char *bad1[] = { "no-such-file.nc", NULL }, *bad2[] = { "../manifest.json", NULL };
    cJSON *before = json_read_file(mpath, &e);
    char *btext = before ? cJSON_PrintUnformatted(before) : NULL;
    CHECK(products_manifest_add(stage, bad1, &e) != SPH_OK && strstr(e.msg, "no-such-file.nc"),
          "missing file refused: %s", e.msg);
    CHECK(products_manifest_add(stage, bad2, &e) != SPH_OK, "a name with '/' refused");
    cJSON *same = json_read_file(mpath, &e);
    char *stext = same ? cJSON_PrintUnformatted(same) : NULL;
    CHECK(btext && stext && !strcmp(btext, stext), "a refused addition leaves manifest.json as it was");
    free(btext);
    free(stext);
    cJSON_Delete(before);
    cJSON_Delete(same);

    const char *names[] = { restart_name, "cycle.json", restart_name, NULL };
    CHECK(products_manifest_add(stage, names, &e) == SPH_OK, "manifest add: %s", e.msg);
    cJSON *m = json_read_file(mpath, &e);
    const cJSON *files = cJSON_GetObjectItem(m, "files");
    struct stat sr, sc;
    char rp[1200];
    snprintf(rp, sizeof rp, "%s/%s", stage, restart_name);
    CHECK(stat(rp, &sr) == 0 && listed(files, restart_name, (double)sr.st_size), "restart listed with its size");
    CHECK(stat(p, &sc) == 0 && listed(files, "cycle.json", (double)sc.st_size), "cycle.json listed with its size");
    int count = 0;
    const cJSON *f;
    cJSON_ArrayForEach(f, files) {
        const char *n = cJSON_GetStringValue(cJSON_GetObjectItem(f, "name"));
        count += n && !strcmp(n, restart_name);
        if (n && !strcmp(n, restart_name)) {
            char cmd[1400], out[128] = "";
            snprintf(cmd, sizeof cmd, "sha256sum '%s'", rp);
            FILE *pp = popen(cmd, "r");
            if (pp && fgets(out, sizeof out, pp))
                out[64] = 0;
            if (pp)
                pclose(pp);
            const char *sha = cJSON_GetStringValue(cJSON_GetObjectItem(f, "sha256"));
            CHECK(sha && !strcmp(sha, out), "restart sha256 %s, sha256sum %s", sha ? sha : "-", out);
        }
    }
    CHECK(count == 1, "the restart is listed once (%d)", count);
    CHECK(cJSON_IsTrue(cJSON_GetObjectItem(m, "complete")), "manifest still complete");
    cJSON_Delete(m);
}

static void run_cfchecks(const char *const *paths, int n)
{
    if (system("command -v cfchecks >/dev/null 2>&1") != 0) {
        printf("test_cf_names: cfchecks (the NCAS CF checker) is not installed (Debian does not package it): "
               "skipped\n");
        return;
    }
    for (int k = 0; k < n; k++) {
        char cmd[1400], line[1024];
        snprintf(cmd, sizeof cmd, "cfchecks -v 1.8 '%s' 2>&1", paths[k]);
        FILE *pp = popen(cmd, "r");
        int errors = 0;
        while (pp && fgets(line, sizeof line, pp))
            if (strstr(line, "ERROR")) {
                errors++;
                fprintf(stderr, "%s: %s", paths[k], line);
            }
        if (pp)
            pclose(pp);
        CHECK(errors == 0, "cfchecks: %d errors in %s", errors, paths[k]);
    }
}

int main(void)
{
    int version = load_table(TABLE);
    CHECK(version == 83, "%s: version %d", TABLE, version);
    CHECK(ntable >= 40, "%s: %d entries", TABLE, ntable);
    sph_error err;
    sph_error_clear(&err);
    CHECK(cf_units_create(&U, &err) == SPH_OK, "udunits: %s", err.msg);
    if (!U)
        return check_summary("test_cf_names");
    /* the table's own canonical units parse */
    for (int k = 0; k < ntable; k++)
        if (table[k].units[0])
            CHECK(cf_units_convertible(U, table[k].units, table[k].units), "table units '%s' of %s",
                  table[k].units, table[k].name);
    CHECK(lookup("maximum_shear_of_sea_ice_velocity") == NULL && lookup("sea_ice_area_fraction") != NULL,
          "the table is the table");

    char tmpl[] = "/tmp/sphice-cfnames-XXXXXX";
    char *dir = mkdtemp(tmpl);
    CHECK(dir != NULL, "mkdtemp");
    if (!dir)
        return check_summary("test_cf_names");
    char stage[600], restart[800];
    snprintf(stage, sizeof stage, "%s/stage", dir);
    snprintf(restart, sizeof restart, "%s/restart-19990202T00Z.nc", stage);
    if (write_products(stage) == SPH_OK && write_restart(restart) == SPH_OK) {
        char paths[7][800];
        const char *list[7];
        static const char *const files[] = { "sphice_fields.nc", "sphice_stations.nc", "sphice_particles.nc" };
        int total = 0;
        for (int k = 0; k < 3; k++) {
            snprintf(paths[k], sizeof paths[k], "%s/%s", stage, files[k]);
            list[k] = paths[k];
            total += check_file(paths[k]);
        }
        snprintf(paths[3], sizeof paths[3], "%s", restart);
        list[3] = paths[3];
        check_file(restart);
        CHECK(total >= 20, "%d standard names checked", total);
        check_bounds(paths[0]);
        static const char *const series[] = { "siconc", "sithick", "sishearvel", "siarea", "sivolume",
                                               "sisnthick" };
        check_forecast_period(paths[0], series, sizeof series / sizeof series[0], 1);
        check_manifest_add(stage, "restart-19990202T00Z.nc");
        /* the ensemble file (two members: the fields file above) */
        snprintf(paths[4], sizeof paths[4], "%s/sphice_ensemble.nc", stage);
        list[4] = paths[4];
        if (write_ensemble(stage, paths[0]) == SPH_OK) {
            CHECK(check_file(paths[4]) >= 6, "ensemble: standard names checked");
            check_bounds(paths[4]);
            static const char *const eseries[] = { "siconc_mean", "siconc_spread", "sivol_mean",
                                                   "sivol_spread", "siconc_prob" };
            check_forecast_period(paths[4], eseries, sizeof eseries / sizeof eseries[0], 0);
        }
        /* the ocean-fluxes file on both grid kinds */
        snprintf(paths[5], sizeof paths[5], "%s/sphice_ocean_fluxes.nc", dir);
        snprintf(paths[6], sizeof paths[6], "%s/sphice_ocean_fluxes_plane.nc", dir);
        list[5] = paths[5];
        list[6] = paths[6];
        if (write_ocean_fluxes(paths[5], 0) == SPH_OK)
            CHECK(check_file(paths[5]) >= 15, "ocean fluxes (lon/lat): standard names checked");
        if (write_ocean_fluxes(paths[6], 1) == SPH_OK)
            CHECK(check_file(paths[6]) >= 17, "ocean fluxes (plane): standard names checked");
        run_cfchecks(list, 7);
    }
    cf_units_free(U);
    if (!check_failed_)
        cycle_remove_tree(dir);
    else
        fprintf(stderr, "files kept in %s\n", dir);
    return check_summary("test_cf_names");
}
