/* The station DEM of the ice-load product (issue 25 items 3 and 4), through
 * the products API on uniform fields:
 *  - below a threshold the cheap model, with its reason, and no DEM numbers;
 *  - above them the DEM, whose statistics equal bit for bit those of the
 *    same run built here from the core's API (core/dem.h) after the recipe
 *    of docs/dem.md "The station DEM" (not by calling the product's code);
 *    and the structure within its oscillator bound 2 F_max / k; the same
 *    for a cone station (the core's cone); the ice's keys (modulus, bond
 *    strengths) and K_n = A E / L;
 *  - loads.model forcing either model;
 *  - the cycle's cache: a thickness and speed equal after rounding reuse
 *    the run (same numbers, dem_cached 1), a new thickness runs again;
 *  - a DEM step beyond the stability limit, a sheet that cannot be built:
 *    one line naming the station and the key, nothing published;
 *  - the configuration's keys and its refusals, /status's latest loads,
 *    the quick-look's mark.
 * Short DEM runs (4 ms of 150 spheres) keep it to a few seconds. */
#include <cairo.h>
#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "check.h"
#include "core/dem.h"
#include "io/products.h"
#include "io/quicklook.h"
#include "service/config.h"
#include "service/status_page.h"

const char *__lsan_default_suppressions(void);
const char *__lsan_default_suppressions(void) { return "leak:libfontconfig\n"; }

#define T0 1705276800.0 /* 2024-01-15T00:00:00Z */
#define MAXT 6

static prod_grid G = { 20, 20, 120.0, 38.0, 0.05, 0.05 };
static const prod_structure LEG = { 1.6, 1.8e6, 300e3, 5.0e8, 0.03, 0, 0, 0, 0 }; /* the seed's leg */
/* a 60 deg cone, waterline 1.2 m, neck 0.6 m (test_dem_cone's), on the seed's oscillator; mu 0.2 */
static const prod_structure CONE = { 1.2, 0.0, 300e3, 5.0e8, 0.03, 60.0, 0.6, 0.6e6, 0.2 };
static const prod_structure *RUN_STRUCTURE = &LEG; /* the structure run() gives station "A" */

typedef struct scene {
    int nt;
    double conc[MAXT], thick[MAXT], vn[MAXT];
} scene;

static void quick_dem(prod_loads_options *o)
{
    prod_loads_options_default(o);
    o->duration = 0.004;
    o->sheet_length = 0.4;
    o->sheet_width = 0.5;
}

/* Writes the scene's times for one station "A" with the leg; returns the
 * first error (the writer aborted then), err holding its line. */
static int run(const char *stage, const prod_loads_options *lo, const scene *sc, prod_summary *sum, sph_error *err)
{
    prod_station st = { "A", 120.5, 38.5 };
    prod_options o;
    products_options_default(&o);
    o.prefix = "t";
    o.stations = &st;
    o.nstations = 1;
    o.structures = RUN_STRUCTURE;
    o.loads = *lo;
    prod_meta m = { .title = "loads dem test", .config_sha256 = "abc", .cycle_time = T0, .start_mode = "cold" };
    sph_error_clear(err);
    prod_writer *p = NULL;
    int rc = products_open(&p, &o, &G, &m, stage, err);
    if (rc != SPH_OK)
        return rc;
    size_t nn = (size_t)G.nlon * G.nlat;
    double *f = calloc(8 * nn, sizeof *f);
    for (int t = 0; t < sc->nt && rc == SPH_OK; t++) {
        for (size_t k = 0; k < nn; k++) {
            f[k] = sc->conc[t];
            f[nn + k] = sc->conc[t] * sc->thick[t];
            f[2 * nn + k] = sc->thick[t];
            f[3 * nn + k] = 0.0;
            f[4 * nn + k] = sc->vn[t];
            f[5 * nn + k] = 1000.0;
        }
        prod_fields pf = { f, f + nn, f + 2 * nn, f + 3 * nn, f + 4 * nn, f + 5 * nn, f + 6 * nn, f + 7 * nn,
                           NULL, NULL };
        rc = products_add_time(p, T0 + t * 3600.0, &pf, NULL, err);
    }
    if (rc == SPH_OK)
        rc = products_close(p, sum, err);
    else
        products_abort(p);
    free(f);
    return rc;
}

/* The file's numbers for station 0 */
typedef struct rows {
    int nt;
    double conc[MAXT], thick[MAXT], speed[MAXT], load[MAXT], stload[MAXT];
    double dem[10][MAXT]; /* mean max std freq umax ustd amax astd thickness speed */
    signed char cached[MAXT];
    char model[MAXT][16], why[MAXT][128];
} rows;

static const char *const DEM_VARS[10] = { "dem_load_mean", "dem_load_max", "dem_load_std", "dem_load_frequency",
                                          "dem_displacement_max", "dem_displacement_std", "dem_acceleration_max",
                                          "dem_acceleration_std", "dem_thickness", "dem_speed" };

static int read_var(int nc, const char *name, double *v)
{
    int id;
    return nc_inq_varid(nc, name, &id) == NC_NOERR && nc_get_var_double(nc, id, v) == NC_NOERR;
}

static int read_rows(const char *stage, rows *r)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/t_loads.nc", stage);
    int nc, d, v, ok = 1;
    if (nc_open(path, NC_NOWRITE, &nc) != NC_NOERR)
        return 0;
    size_t nt = 0;
    nc_inq_dimid(nc, "time", &d);
    nc_inq_dimlen(nc, d, &nt);
    r->nt = (int)nt;
    ok &= nt <= MAXT;
    ok &= read_var(nc, "siconc", r->conc) && read_var(nc, "sithick", r->thick) && read_var(nc, "sispeed", r->speed) &&
          read_var(nc, "ice_load", r->load) && read_var(nc, "station_load", r->stload);
    for (int q = 0; q < 10; q++)
        ok &= read_var(nc, DEM_VARS[q], r->dem[q]);
    ok &= nc_inq_varid(nc, "dem_cached", &v) == NC_NOERR && nc_get_var_schar(nc, v, r->cached) == NC_NOERR;
    char *model[MAXT], *why[MAXT];
    ok &= nc_inq_varid(nc, "load_model", &v) == NC_NOERR && nc_get_var_string(nc, v, model) == NC_NOERR;
    ok &= nc_inq_varid(nc, "load_model_reason", &v) == NC_NOERR && nc_get_var_string(nc, v, why) == NC_NOERR;
    if (ok) {
        for (size_t t = 0; t < nt; t++) {
            snprintf(r->model[t], sizeof r->model[t], "%s", model[t]);
            snprintf(r->why[t], sizeof r->why[t], "%s", why[t]);
        }
        nc_free_string(nt, model);
        nc_free_string(nt, why);
    }
    nc_close(nc);
    return ok;
}

static int exists(const char *dir, const char *name)
{
    char p[1024];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    struct stat sb;
    return stat(p, &sb) == 0;
}

/* The station DEM written out from docs/dem.md with the core's API: out =
 * mean, max, std, freq, max |u|, std u, max |a|, std a of the run. */
static void direct_dem(const prod_loads_options *o, const prod_structure *ps, double h, double u, double out[8])
{
    const double c = sqrt(2.0 / 3.0), dnom = o->particle_diameter;
    long layers = lround((h - dnom) / (dnom * c)) + 1;
    layers = layers < 1 ? 1 : layers;
    const double r = h / (2.0 + 2.0 * c * (double)(layers - 1));
    const long along = (long)ceil(o->sheet_length / (2.0 * r));
    const long across = (long)ceil((o->sheet_width * ps->w - 2.0 * r) / (sqrt(3.0) * r)) + 1;
    const size_t n = (size_t)(along * across * layers);
    dem_params prm;
    dem_params_default(&prm);
    prm.bond_modulus = o->elastic_modulus;
    prm.bond_tensile = o->bond_tensile;
    prm.bond_shear = o->bond_shear;
    const int cone = ps->cone_angle > 0.0;
    if (cone)
        prm.friction = ps->mu; /* one mu for the ice and the cone, Ralston's */
    dem *d = dem_create(n, 8 * n, &prm);
    CHECK(dem_add_sheet_hcp(d, 0.0, 0.0, (int)along, (int)across, (int)layers, r, u, 0.0) == 0, "direct sheet");
    /* Potyondy & Cundall's deformability (docs/dem.md): K_n = A E / L, A = pi r^2, L = 2 r; bonds E / (2 r) */
    CHECK(fabs(d->p.kn - o->elastic_modulus * M_PI * r * r / (2.0 * r)) <= 1e-12 * d->p.kn &&
              fabs(d->bonds[0].kn - o->elastic_modulus / (2.0 * r)) <= 1e-12 * d->bonds[0].kn,
          "K_n %.6g N/m = A E / L, bond k_n %.6g Pa/m = E / (2 r)", d->p.kn, d->bonds[0].kn);
    const double top = sqrt(3.0) * r * (double)(across - 1) + r;
    double xfront = 0.0;
    for (size_t i = 0; i < d->n; i++)
        xfront = fmax(xfront, d->x[i] + r);
    for (size_t i = 0; i < d->n; i++)
        if (d->x[i] < 4.0 * r || d->y[i] < 2.0 * r || d->y[i] > top - 2.0 * r) {
            d->flags[i] = DEM_FIX_TRANSLATION | DEM_FIX_ROTATION;
            d->vx[i] = u;
            d->vy[i] = d->vz[i] = 0.0;
        }
    dem_structure *s = &d->s;
    s->kind = cone ? DEM_STRUCT_CONE : DEM_STRUCT_CYLINDER;
    s->diameter = ps->w;
    s->cone_angle = cone ? ps->cone_angle : 0.0;
    s->neck_diameter = cone ? ps->neck : 0.0;
    s->z_waterline = 0.0;
    s->y0 = 0.5 * sqrt(3.0) * r * (double)(across - 1);
    /* touching the sheet, no sphere overlapping it: a sphere at height z
     * touches the cone's face (radius R - z / tan a at z) when its centre is
     * r / sin a further out horizontally (the normal distance to a face at
     * angle a from the horizontal is the horizontal gap times sin a) */
    const double sa = cone ? sin(ps->cone_angle * M_PI / 180.0) : 1.0;
    const double ta = cone ? tan(ps->cone_angle * M_PI / 180.0) : 1.0;
    double x0 = -HUGE_VAL;
    int above_neck = 0;
    for (size_t i = 0; i < d->n; i++) {
        above_neck += cone && !(d->z[i] < (0.5 * ps->w - 0.5 * ps->neck) * ta);
        const double reach = cone ? 0.5 * ps->w - d->z[i] / ta + r / sa : 0.5 * ps->w + r;
        if (fabs(d->y[i] - s->y0) < reach)
            x0 = fmax(x0, d->x[i] + sqrt(reach * reach - (d->y[i] - s->y0) * (d->y[i] - s->y0)));
    }
    s->x0 = x0 > -HUGE_VAL ? x0 : xfront + 0.5 * ps->w;
    CHECK(above_neck == 0, "the sheet lies below the cone's neck (%d spheres above)", above_neck);
    /* no sphere starts in contact, one touches: the normal distance to the
     * leg (rho - R) or to the cone's face ((rho - (R - z / tan a)) sin a) less r */
    double gap = HUGE_VAL;
    for (size_t i = 0; i < d->n; i++) {
        const double rho = hypot(d->x[i] - s->x0, d->y[i] - s->y0);
        gap = fmin(gap, cone ? (rho - (0.5 * ps->w - d->z[i] / ta)) * sa - r : rho - 0.5 * ps->w - r);
    }
    CHECK(gap >= -1e-12 && gap <= 1e-12, "the %s touches the sheet: gap %.3g m", cone ? "cone" : "leg", gap);
    s->mass = ps->mass;
    s->stiffness = ps->stiffness;
    s->damping_ratio = ps->damping;
    const double dt = 0.9 * prm.dt_safety * dem_dt_critical(d);
    long ns = (long)ceil(o->duration / dt);
    double *F = malloc((size_t)ns * sizeof *F), *U = malloc((size_t)ns * sizeof *U), *A = malloc((size_t)ns * sizeof *A);
    sph_status st;
    long bad = -1;
    for (long k = 0; k < ns; k++) {
        if (dem_step(d, dt, &st) != SPH_STEP_OK && bad < 0)
            bad = k;
        F[k] = s->fx;
        U[k] = s->ux;
        A[k] = s->ax;
    }
    CHECK(bad < 0, "direct run: every step (first fault at %ld)", bad);
    /* two-pass moments in index order; maxima; block means of floor(1 ms / dt) steps */
    double *series[3] = { F, U, A };
    for (int q = 0; q < 3; q++) {
        double tot = 0.0, big = q ? 0.0 : -HUGE_VAL, ss = 0.0;
        for (long k = 0; k < ns; k++) {
            tot += series[q][k];
            big = q ? fmax(big, fabs(series[q][k])) : fmax(big, series[q][k]);
        }
        double mean = tot / (double)ns;
        for (long k = 0; k < ns; k++)
            ss += (series[q][k] - mean) * (series[q][k] - mean);
        double sd = ns > 1 ? sqrt(ss / (double)(ns - 1)) : 0.0;
        if (q == 0) {
            out[0] = mean;
            out[1] = big;
            out[2] = sd;
        } else {
            out[2 + 2 * q] = big;
            out[3 + 2 * q] = sd;
        }
    }
    long blk = (long)floor(1e-3 / dt);
    blk = blk < 1 ? 1 : blk;
    long nb = ns / blk;
    double *B = malloc((size_t)(nb + 1) * sizeof *B), m1, m2, m3;
    for (long b = 0; b < nb; b++) {
        double acc = 0.0;
        for (long j = b * blk; j < (b + 1) * blk; j++)
            acc += F[j];
        B[b] = acc / (double)blk;
    }
    out[3] = NAN;
    m3 = 0.0;
    if (nb > 1)
        dem_load_stats(B, (size_t)nb, dt * (double)blk, &m1, &m2, &m3, &out[3]);
    if (!(m3 > 0.0))
        out[3] = PROD_FILL_FLOAT; /* no spectrum: fill in the file */
    free(B);
    free(F);
    free(U);
    free(A);
    dem_free(d);
}

static double rounded(double x, double res) { return res > 0.0 ? res * round(x / res) : x; }

/* runs the scene into root/name (lo NULL: quick_dem's options) and reads
 * its rows: 1 when both worked */
static int run_read(const char *root, const char *name, const prod_loads_options *lo, const scene *sc,
                    prod_summary *sum, rows *r)
{
    prod_loads_options q;
    if (!lo) {
        quick_dem(&q);
        lo = &q;
    }
    char stage[600];
    snprintf(stage, sizeof stage, "%s/%s", root, name);
    sph_error e;
    int rc = run(stage, lo, sc, sum, &e);
    CHECK(rc == SPH_OK, "%s: %s", name, e.msg);
    return rc == SPH_OK && read_rows(stage, r) && r->nt == sc->nt;
}

static void test_below(const char *root)
{
    /* thin; slow; loose: each below one threshold */
    scene sc = { 3, { 0.9, 0.9, 0.1 }, { 0.05, 0.3, 0.3 }, { -0.2, -0.01, -0.2 } };
    rows r;
    prod_summary sum;
    if (!run_read(root, "below", NULL, &sc, &sum, &r))
        return;
    const char *want[3] = { "thickness", "speed", "concentration" };
    for (int t = 0; t < 3; t++) {
        CHECK(!strcmp(r.model[t], "cheap") && strstr(r.why[t], want[t]) && strstr(r.why[t], "below"),
              "below t%d: %s (%s)", t, r.model[t], r.why[t]);
        CHECK(r.cached[t] == -1 && r.dem[0][t] == PROD_FILL_FLOAT && r.dem[8][t] == PROD_FILL_FLOAT,
              "below t%d: no DEM numbers", t);
        CHECK(r.stload[t] == r.load[t], "below t%d: the station load is the cheap one", t);
    }
    CHECK(sum.loads.on && sum.loads.dem_runs == 0 && sum.loads.cheap_rows == 3 && sum.loads.dem_seconds == 0.0,
          "below: no DEM ran (runs %ld, cheap rows %ld)", sum.loads.dem_runs, sum.loads.cheap_rows);
}

static void test_above_and_cache(const char *root)
{
    /* 0.26 m at 0.2 m/s; 0.262 m (rounds to 0.26: cached); 0.30 m (a new run); 0.259 m at 0.205 m/s (cached) */
    scene sc = { 4, { 0.9, 0.9, 0.9, 0.9 }, { 0.26, 0.262, 0.30, 0.259 }, { -0.2, -0.2, -0.2, -0.205 } };
    prod_loads_options lo;
    quick_dem(&lo);
    prod_summary sum;
    rows r;
    if (!run_read(root, "above", &lo, &sc, &sum, &r))
        return;
    for (int t = 0; t < 4; t++)
        CHECK(!strcmp(r.model[t], "dem") && strstr(r.why[t], "all DEM thresholds"), "above t%d: %s (%s)", t,
              r.model[t], r.why[t]);
    /* the cache: one run per rounded (thickness, speed) */
    CHECK(r.cached[0] == 0 && r.cached[1] == 1 && r.cached[2] == 0 && r.cached[3] == 1,
          "cache flags %d %d %d %d", r.cached[0], r.cached[1], r.cached[2], r.cached[3]);
    CHECK(sum.loads.dem_runs == 2 && sum.loads.dem_cached == 2 && sum.loads.dem_rows == 4,
          "summary: %ld runs, %ld cached, %ld rows", sum.loads.dem_runs, sum.loads.dem_cached, sum.loads.dem_rows);
    CHECK(sum.loads.dem_seconds > 0.0 && sum.loads.dem_particle_steps > 0, "the DEM's cost is counted");
    for (int q = 0; q < 10; q++)
        CHECK(memcmp(&r.dem[q][0], &r.dem[q][1], sizeof(double)) == 0 &&
                  memcmp(&r.dem[q][0], &r.dem[q][3], sizeof(double)) == 0,
              "the cache returns the same %s", DEM_VARS[q]);
    CHECK(r.dem[8][2] != r.dem[8][0], "a new thickness is a new run");
    /* bit for bit against the run built here */
    for (int t = 0; t < 3; t += 2) {
        double h = rounded(r.thick[t], lo.cache_thickness), u = rounded(r.speed[t], lo.cache_speed), want[8];
        CHECK(r.dem[8][t] == h && r.dem[9][t] == u, "t%d: the DEM ran at the rounded %.17g m, %.17g m/s", t, h, u);
        direct_dem(&lo, &LEG, h, u, want);
        printf("station DEM %.2f m at %.2f m/s, %.0f ms: load mean %.3f kN, max %.3f kN, std %.3f kN, %.1f Hz; "
               "displacement max %.3g mm; acceleration max %.3g m/s2\n", h, u, lo.duration * 1e3, want[0] * 1e-3,
               want[1] * 1e-3, want[2] * 1e-3, want[3], want[4] * 1e3, want[6]);
        for (int q = 0; q < 8; q++)
            CHECK(memcmp(&r.dem[q][t], &want[q], sizeof(double)) == 0, "t%d %s: file %.17g, direct %.17g", t,
                  DEM_VARS[q], r.dem[q][t], want[q]);
        CHECK(r.dem[1][t] > 0.0 && r.stload[t] == r.dem[1][t], "t%d: the ice pushes (max %.1f kN), the station "
              "load is the DEM's max", t, r.dem[1][t] * 1e-3);
        /* a damped oscillator under loads bounded by F_max: |u| <= 2 F_max / k */
        CHECK(r.dem[4][t] <= 2.0 * r.dem[1][t] / LEG.stiffness, "t%d: displacement %.3g m within 2 F_max / k %.3g m",
              t, r.dem[4][t], 2.0 * r.dem[1][t] / LEG.stiffness);
    }
    /* the summary's latest: the last time's DEM max, its model */
    CHECK(sum.loads.nstations == 1 && !strcmp(sum.loads.st[0].name, "A") && !strcmp(sum.loads.st[0].model, "dem") &&
              sum.loads.st[0].load == r.dem[1][3] && sum.loads.st[0].max_load >= r.dem[1][2] &&
              sum.loads.st[0].time == T0 + 3 * 3600.0,
          "summary's latest load %g N (%s)", sum.loads.st[0].load, sum.loads.st[0].model);
    /* without a cache resolution the 0.262 m time runs again */
    lo.cache_thickness = 0.0;
    lo.cache_speed = 0.0;
    scene two = { 2, { 0.9, 0.9 }, { 0.26, 0.262 }, { -0.2, -0.2 } };
    CHECK(run_read(root, "nocache", &lo, &two, &sum, &r) && sum.loads.dem_runs == 2 && sum.loads.dem_cached == 0,
          "resolution 0: exact values only (%ld runs)", sum.loads.dem_runs);
}

/* A cone station in the station DEM (issue 25): the scene above the
 * thresholds runs the DEM against the cone, not Ralston's only; its
 * statistics equal bit for bit the run built here from the core's API
 * (direct_dem with the cone); the cheap load beside it stays Ralston's
 * for the same ice and cone. */
static void test_cone(const char *root)
{
    scene sc = { 1, { 0.9 }, { 0.26 }, { -0.2 } };
    prod_loads_options lo;
    quick_dem(&lo);
    lo.sheet_width = 1.0;
    prod_summary sum;
    rows r;
    RUN_STRUCTURE = &CONE;
    int ok = run_read(root, "cone", &lo, &sc, &sum, &r);
    RUN_STRUCTURE = &LEG;
    if (!ok)
        return;
    CHECK(!strcmp(r.model[0], "dem") && strstr(r.why[0], "all DEM thresholds"), "cone: %s (%s)", r.model[0],
          r.why[0]);
    CHECK(r.cached[0] == 0 && sum.loads.dem_runs == 1, "cone: the DEM ran (%ld runs)", sum.loads.dem_runs);
    double h = rounded(r.thick[0], lo.cache_thickness), u = rounded(r.speed[0], lo.cache_speed), want[8];
    direct_dem(&lo, &CONE, h, u, want);
    printf("station DEM cone %.0f deg, D %.1f m: %.2f m at %.2f m/s, %.0f ms: load mean %.3f kN, max %.3f kN\n",
           CONE.cone_angle, CONE.w, h, u, lo.duration * 1e3, want[0] * 1e-3, want[1] * 1e-3);
    for (int q = 0; q < 8; q++)
        CHECK(memcmp(&r.dem[q][0], &want[q], sizeof(double)) == 0, "cone %s: file %.17g, direct %.17g", DEM_VARS[q],
              r.dem[q][0], want[q]);
    CHECK(r.dem[1][0] > 0.0 && r.stload[0] == r.dem[1][0], "cone: the ice pushes (max %.3f kN), the station load is "
          "the DEM's max", r.dem[1][0] * 1e-3);
    dem_cone_ice ci = { CONE.sigma_f, r.thick[0], r.thick[0], 900.0, CONE.mu, CONE.cone_angle, CONE.w, CONE.neck };
    dem_cone_load cl;
    const char *why = "";
    CHECK(dem_ralston_cone(&ci, &cl, &why) == 0 && fabs(r.load[0] - cl.h) <= 1e-9 * cl.h,
          "cone: the cheap load beside it is Ralston's (%.3f kN vs %.3f kN)", r.load[0] * 1e-3, cl.h * 1e-3);
}

/* loads.dem_elastic_modulus and the bond strengths reach the station DEM:
 * a 0.1 GPa ice with 0.5 / 0.9 MPa bonds against the leg, bit for bit the
 * direct run with those parameters, and not the default ice's numbers */
static void test_ice_keys(const char *root)
{
    scene sc = { 1, { 0.9 }, { 0.26 }, { -0.2 } };
    prod_loads_options lo, def;
    quick_dem(&lo);
    quick_dem(&def);
    lo.elastic_modulus = 0.1e9;
    lo.bond_tensile = 0.5e6;
    lo.bond_shear = 0.9e6;
    prod_summary sum;
    rows r;
    if (!run_read(root, "soft", &lo, &sc, &sum, &r))
        return;
    double h = rounded(r.thick[0], lo.cache_thickness), u = rounded(r.speed[0], lo.cache_speed), want[8], stiff[8];
    direct_dem(&lo, &LEG, h, u, want);
    direct_dem(&def, &LEG, h, u, stiff);
    for (int q = 0; q < 8; q++)
        CHECK(memcmp(&r.dem[q][0], &want[q], sizeof(double)) == 0, "soft ice %s: file %.17g, direct %.17g",
              DEM_VARS[q], r.dem[q][0], want[q]);
    CHECK(want[1] != stiff[1], "the modulus changes the load (max %.3f kN at 0.1 GPa, %.3f kN at 1 GPa)",
          want[1] * 1e-3, stiff[1] * 1e-3);
}

static void test_force(const char *root)
{
    prod_loads_options lo;
    quick_dem(&lo);
    prod_summary sum;
    rows r;
    /* a DEM scene, the cheap model forced */
    scene hot = { 1, { 0.9 }, { 0.26 }, { -0.2 } };
    lo.model = PROD_LOADS_CHEAP;
    if (!run_read(root, "force_cheap", &lo, &hot, &sum, &r))
        return;
    CHECK(!strcmp(r.model[0], "cheap") && strstr(r.why[0], "forced") && r.cached[0] == -1 && sum.loads.dem_runs == 0,
          "force cheap: %s (%s)", r.model[0], r.why[0]);
    /* still ice, the DEM forced; and no ice at all: nothing to run */
    scene still = { 2, { 0.9, 0.0 }, { 0.3, 0.3 }, { 0.0, -0.2 } };
    lo.model = PROD_LOADS_DEM;
    if (!run_read(root, "force_dem", &lo, &still, &sum, &r))
        return;
    CHECK(!strcmp(r.model[0], "dem") && strstr(r.why[0], "forced") && r.cached[0] == 0 && sum.loads.dem_runs == 1,
          "force dem: %s (%s)", r.model[0], r.why[0]);
    CHECK(!strcmp(r.model[1], "none") && strstr(r.why[1], "no ice") && r.stload[1] == PROD_FILL_FLOAT,
          "force dem without ice: %s (%s)", r.model[1], r.why[1]);
}

static void test_refusals(const char *root)
{
    scene hot = { 2, { 0.9, 0.9 }, { 0.26, 0.26 }, { -0.2, -0.2 } };
    prod_loads_options lo;
    quick_dem(&lo);
    char stage[600];
    prod_summary sum;
    sph_error e;
    /* 1 ms: far beyond the limit of 0.05 m spheres (tens of microseconds) */
    lo.dt = 1e-3;
    snprintf(stage, sizeof stage, "%s/dt", root);
    int rc = run(stage, &lo, &hot, &sum, &e);
    CHECK(rc != SPH_OK && strstr(e.msg, "\"A\"") && strstr(e.msg, "loads.dem_dt") && strstr(e.msg, "stability") &&
              !strchr(e.msg, '\n'),
          "a step beyond the limit refused in one line: %s", e.msg);
    CHECK(!exists(stage, "t_loads.nc") && !exists(stage, "t_loads.csv") && !exists(stage, "manifest.json"),
          "nothing published after the refused step");
    quick_dem(&lo);
    lo.max_particles = 50;
    snprintf(stage, sizeof stage, "%s/big", root);
    rc = run(stage, &lo, &hot, &sum, &e);
    CHECK(rc != SPH_OK && strstr(e.msg, "\"A\"") && strstr(e.msg, "loads.dem_max_particles") &&
              strstr(e.msg, "cannot be built") && !strchr(e.msg, '\n'),
          "a sheet that cannot be built refused in one line: %s", e.msg);
    CHECK(!exists(stage, "t_loads.nc") && !exists(stage, "manifest.json"), "nothing published after the refusal");
    quick_dem(&lo);
    lo.sheet_length = 0.1; /* one sphere along the drift */
    snprintf(stage, sizeof stage, "%s/short", root);
    rc = run(stage, &lo, &hot, &sum, &e);
    CHECK(rc != SPH_OK && strstr(e.msg, "\"A\"") && strstr(e.msg, "loads.dem_sheet_length") && !strchr(e.msg, '\n'),
          "a sheet too short refused in one line: %s", e.msg);
}

/* parses a configuration of one domain, one forcing, the given "loads"
 * member text (may be "") and stations */
static int parse(const char *loads, const char *stations, struct sph_config **c, sph_error *e)
{
    static const char *const head =
        "{\"domain\": {\"lon_min\": 119, \"lon_max\": 122, \"lat_min\": 38, \"lat_max\": 41}, \"forcing\": "
        "[{\"name\": \"atm\", \"kind\": \"atmosphere\", \"urls\": \"/a.nc\"}], \"output\": {\"dir\": \"/tmp/o\"}";
    char text[2048];
    snprintf(text, sizeof text, "%s%s%s, \"stations\": [%s]}", head, loads[0] ? ", " : "", loads, stations);
    sph_error_clear(e);
    *c = NULL;
    return sph_config_parse(text, "t.json", c, e);
}

static void test_config(void)
{
    sph_error e;
    struct sph_config *c;
    int rc = parse("\"loads\": {\"model\": \"dem\", \"dem_min_speed\": 0.1, \"dem_duration\": 2, "
                   "\"dem_cache_thickness\": 0.05, \"dem_elastic_modulus\": 0.5, \"dem_bond_tensile\": 0.7}",
                   "{\"name\": \"JZ20-2\", \"lon\": 121.37, \"lat\": 40.47, \"structure\": {\"kind\": "
                   "\"vertical\", \"mass\": 500, \"stiffness\": 1e5, \"damping\": 0.05}}",
                   &c, &e);
    CHECK(rc == SPH_OK, "loads keys parse: %s", e.msg);
    if (c) {
        CHECK(c->loads.model == PROD_LOADS_DEM && c->loads.dem_min_speed == 0.1 && c->loads.dem_duration == 2 &&
                  c->loads.dem_cache_thickness == 0.05 && c->loads.dem_min_thickness == 0.1 &&
                  c->loads.dem_max_particles == 20000 && c->loads.map_threshold_kn == 500 &&
                  c->loads.dem_elastic_modulus == 0.5 && c->loads.dem_bond_tensile == 0.7 &&
                  c->loads.dem_bond_shear == 0.558,
              "loads keys read, defaults kept");
        CHECK(c->stations[0].structure_mass == 500 && c->stations[0].structure_stiffness == 1e5 &&
                  c->stations[0].structure_damping == 0.05,
              "structure dynamics read");
        sph_config_free(c);
    }
    rc = parse("", "{\"name\": \"Loose\", \"lon\": 121, \"lat\": 40, \"structure\": {\"kind\": \"vertical\", "
               "\"stiffness\": 0}}", &c, &e);
    CHECK(rc == SPH_ERR_CONFIG && c == NULL && strstr(e.msg, "\"Loose\"") &&
              strstr(e.msg, "stations[0].structure.stiffness") && !strchr(e.msg, '\n'),
          "a structure of mass on no spring refused in one line: %s", e.msg);
    rc = parse("\"loads\": {\"dem_elastic_modulus\": 0}", "", &c, &e);
    CHECK(rc == SPH_ERR_CONFIG && c == NULL && strstr(e.msg, "loads.dem_elastic_modulus"),
          "a zero modulus refused: %s", e.msg);
    rc = parse("\"loads\": {\"model\": \"sometimes\"}", "", &c, &e);
    CHECK(rc == SPH_ERR_CONFIG && c == NULL && strstr(e.msg, "loads.model"), "an unknown model refused: %s", e.msg);
}

static void test_status(const char *root)
{
    char dir[600], path[700], cmd[1400];
    snprintf(dir, sizeof dir, "%s/status/19990207T22Z", root);
    snprintf(cmd, sizeof cmd, "mkdir -p '%s' && ln -s 19990207T22Z '%s/status/latest'", dir, root);
    CHECK(system(cmd) == 0, "status dirs");
    snprintf(path, sizeof path, "%s/cycle.json", dir);
    FILE *f = fopen(path, "w");
    if (f) {
        fputs("{\"cycle\": \"1999-02-07T22:00:00Z\", \"loads\": [{\"station\": \"A\", \"valid_time\": "
              "\"1999-02-08T04:00:00Z\", \"load_kN\": 12.5, \"model\": \"dem\", \"max_load_kN\": 20}]}", f);
        fclose(f);
    }
    snprintf(dir, sizeof dir, "%s/status", root);
    cJSON *o = status_latest_json(dir);
    const cJSON *l = cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(o, "loads"), 0);
    CHECK(l && !strcmp(cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(l, "model")), "dem") &&
              cJSON_GetObjectItemCaseSensitive(l, "load_kN")->valuedouble == 12.5,
          "/status latest: the latest load and model per station");
    cJSON_Delete(o);
    o = status_latest_json("/nonexistent");
    CHECK(o && !cJSON_GetObjectItemCaseSensitive(o, "loads"), "no cycle: no loads in /status");
    cJSON_Delete(o);
}

/* pixels of the mark's red within 3 per channel, at or below row y0 (*below) and above it */
static long red_pixels(const char *path, int y0, long *below)
{
    cairo_surface_t *s = cairo_image_surface_create_from_png(path);
    if (cairo_surface_status(s) != CAIRO_STATUS_SUCCESS) {
        cairo_surface_destroy(s);
        return -1;
    }
    const unsigned char *d = cairo_image_surface_get_data(s);
    int w = cairo_image_surface_get_width(s), h = cairo_image_surface_get_height(s),
        stride = cairo_image_surface_get_stride(s);
    long n = 0;
    *below = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            unsigned px = *(const unsigned *)(const void *)(d + (size_t)y * stride + 4 * (size_t)x);
            int r = (px >> 16) & 255, g = (px >> 8) & 255, b = px & 255;
            int red = abs(r - 219) <= 3 && abs(g - 20) <= 3 && abs(b - 20) <= 3;
            if (y >= y0)
                *below += red;
            else
                n += red;
        }
    cairo_surface_destroy(s);
    return n;
}

static void test_quicklook_mark(const char *root)
{
    size_t nn = (size_t)G.nlon * G.nlat;
    double *conc = calloc(nn, sizeof *conc);
    const char *names[2] = { "A", "B" };
    double lon[2] = { 120.3, 120.7 }, lat[2] = { 38.3, 38.7 };
    unsigned char mark[2] = { 1, 0 };
    quicklook_opts o;
    quicklook_opts_default(&o);
    o.coastline = 0;
    char with[700], without[700];
    snprintf(with, sizeof with, "%s/mark.png", root);
    snprintf(without, sizeof without, "%s/nomark.png", root);
    sph_error e;
    sph_error_clear(&e);
    CHECK(quicklook_write_png(without, &G, conc, NULL, NULL, NULL, names, lon, lat, 2, T0, &o, &e) == SPH_OK,
          "map without marks: %s", e.msg);
    o.st_mark = mark;
    o.mark_threshold_kn = 500;
    CHECK(quicklook_write_png(with, &G, conc, NULL, NULL, NULL, names, lon, lat, 2, T0, &o, &e) == SPH_OK,
          "map with a mark: %s", e.msg);
    long la, lb, a = red_pixels(without, o.height - 24, &la), b = red_pixels(with, o.height - 24, &lb);
    /* two panels with a triangle of side 12 px each; the legend's in the bottom row */
    CHECK(a == 0 && la == 0 && b > 40 && lb > 10, "the mark's red: %ld + %ld pixels without, %ld + %ld with", a, la,
          b, lb);
    free(conc);
}

int main(void)
{
    char root[] = "/tmp/test_loads_dem_XXXXXX", cmd[600];
    if (!mkdtemp(root)) {
        CHECK(0, "mkdtemp");
        return check_summary("test_loads_dem");
    }
    test_below(root);
    test_above_and_cache(root);
    test_cone(root);
    test_ice_keys(root);
    test_force(root);
    test_refusals(root);
    test_config();
    test_status(root);
    test_quicklook_mark(root);
    quicklook_release_caches();
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", root);
    CHECK(system(cmd) == 0, "cleanup of %s", root);
    return check_summary("test_loads_dem");
}
