/* The fluxes into the ocean (issue 20 item 4, docs/ocean-coupling.md):
 *  - the gridding conserves: sum over cells of flux x cell area x interval
 *    equals the particles' sum within 1e-10 relative, on a lon/lat grid
 *    (areas of the sphere, computed here) with land, and on a projected
 *    grid; cell fluxes added through ofx_add_cells add their own area
 *    integral; particles far from every water cell are counted, not placed;
 *  - the ice-ocean stress in the file is minus the water drag on the ice,
 *    rho_w C_w |U_w - u| R(theta_w) (U_w - u), computed here from the test's
 *    current and the ice velocity, and in steady free drift (no Coriolis)
 *    it equals the wind stress rho_a C_a |U_a| U_a computed here;
 *  - a column under a known ocean heat flux: heat into the ocean -F_w A
 *    area dt; fresh water and salt -rho_i dh (1 - S_i/1000) and
 *    -rho_i dh S_i/1000 per unit ice area, with S_i the mean of the
 *    Bitz-Lipscomb profile S(z) = Smax/2 (1 - cos(pi z^(a/(z+b)))) at the
 *    layer midpoints, evaluated here; a lead that freezes sends no heat;
 *  - accumulation changes nothing in the trajectory (bit for bit). */
#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "core/model.h"
#include "io/ocean_fluxes.h"
#include "lattice.h"
#include "ofx_drift.h"

#define R_EARTH 6371000.0 /* the sphere of io/edge.h's cell areas */
#define DEG (M_PI / 180.0)

static char dir[] = "/tmp/sphice-ofx-XXXXXX";
static unsigned long long rng_state = 88172645463325252ull;
static double urand(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (double)(rng_state >> 11) / 9007199254740992.0;
}

/* Reads variable `name` (all records) into a new array. */
static double *read_var(const char *path, const char *name, size_t *len)
{
    int nc, v, nd, dims[NC_MAX_VAR_DIMS];
    if (nc_open(path, NC_NOWRITE, &nc) != NC_NOERR)
        return NULL;
    double *a = NULL;
    if (nc_inq_varid(nc, name, &v) == NC_NOERR && nc_inq_varndims(nc, v, &nd) == NC_NOERR &&
        nc_inq_vardimid(nc, v, dims) == NC_NOERR) {
        size_t n = 1;
        for (int d = 0; d < nd; d++) {
            size_t l;
            nc_inq_dimlen(nc, dims[d], &l);
            n *= l;
        }
        a = malloc(n * sizeof *a);
        if (a && nc_get_var_double(nc, v, a) != NC_NOERR) {
            free(a);
            a = NULL;
        }
        *len = n;
    }
    nc_close(nc);
    return a;
}

/* sum over the cells of record r of var x area (fill values skipped) */
static double area_sum(const char *path, const char *name, int r, size_t ncell)
{
    size_t n = 0, na = 0;
    double *v = read_var(path, name, &n), *a = read_var(path, "areacello", &na), s = 0.0;
    if (v && a && na == ncell && n >= (size_t)(r + 1) * ncell)
        for (size_t c = 0; c < ncell; c++) {
            double x = v[(size_t)r * ncell + c];
            if (x < 1e19)
                s += x * a[c];
        }
    else
        s = NAN;
    free(v);
    free(a);
    return s;
}

#define NP 400

typedef struct {
    double x[NP], y[NP], rad[NP], hi[NP], hl[NP], w[NP], s[NP], tx[NP], ty[NP], sw[NP], ia[NP], iv[NP];
} pset;

/* Random particles inside [x0,x1]x[y0,y1] with random amounts of both signs
 * and radii from a tenth of a cell (nearest-cell fallback) to several cells. */
static void fill_particles(pset *p, ofx_particles *o, double x0, double x1, double y0, double y1, double cell)
{
    for (int k = 0; k < NP; k++) {
        p->x[k] = x0 + (x1 - x0) * urand();
        p->y[k] = y0 + (y1 - y0) * urand();
        p->rad[k] = cell * (k % 7 == 0 ? 0.1 : 0.5 + 4.0 * urand());
        p->hi[k] = -1e9 * urand();
        p->hl[k] = 1e9 * (urand() - 0.7);
        p->w[k] = 1e5 * (urand() - 0.5);
        p->s[k] = 1e3 * (urand() - 0.5);
        p->tx[k] = 1e7 * (urand() - 0.5);
        p->ty[k] = 1e7 * (urand() - 0.5);
        p->sw[k] = 1e8 * urand();
        p->ia[k] = 1e6 * urand();
        p->iv[k] = p->ia[k] * 0.8 * urand();
    }
    o->n = NP;
    o->x = p->x;
    o->y = p->y;
    o->radius = p->rad;
    o->heat_ice = p->hi;
    o->heat_lead = p->hl;
    o->water = p->w;
    o->salt = p->s;
    o->taux = p->tx;
    o->tauy = p->ty;
    o->swbase = p->sw;
    o->ice_area = p->ia;
    o->ice_volume = p->iv;
}

static double psum(const double *a, int n0, int n1)
{
    double s = 0.0;
    for (int k = n0; k < n1; k++)
        s += a[k];
    return s;
}

static void check_sums(const char *path, int r, size_t ncell, const pset *p, int n0, int n1, double dt,
                       double add_hfds, const char *grid)
{
    double tol = 1e-10;
    CHECK_CLOSE(area_sum(path, "hfds", r, ncell) * dt, psum(p->hi, n0, n1) + psum(p->hl, n0, n1) + add_hfds * dt,
                tol, 0, "hfds conserves");
    CHECK_CLOSE(area_sum(path, "hfsithermds", r, ncell) * dt, psum(p->hi, n0, n1), tol, 0, "hfsithermds conserves");
    CHECK_CLOSE(area_sum(path, "siflfwbot", r, ncell) * dt, psum(p->w, n0, n1), tol, 0, "siflfwbot conserves");
    CHECK_CLOSE(area_sum(path, "siflsaltbot", r, ncell) * dt, psum(p->s, n0, n1), tol, 0, "siflsaltbot conserves");
    CHECK_CLOSE(area_sum(path, "tauuo", r, ncell) * dt, psum(p->tx, n0, n1), tol, 0, "tauuo conserves");
    CHECK_CLOSE(area_sum(path, "tauvo", r, ncell) * dt, psum(p->ty, n0, n1), tol, 0, "tauvo conserves");
    CHECK_CLOSE(area_sum(path, "sistrxubot", r, ncell) * dt, -psum(p->tx, n0, n1), tol, 0, "sistrxubot = -tauuo");
    CHECK_CLOSE(area_sum(path, "siflswdbot", r, ncell) * dt, psum(p->sw, n0, n1), tol, 0, "siflswdbot conserves");
    CHECK_CLOSE(area_sum(path, "siconc", r, ncell), psum(p->ia, n0, n1), tol, 0, "ice area conserves");
    CHECK_CLOSE(area_sum(path, "sivol", r, ncell), psum(p->iv, n0, n1), tol, 0, "ice volume conserves");
    printf("  %s record %d: hfds %.17g J vs %.17g J\n", grid, r, area_sum(path, "hfds", r, ncell) * dt,
           psum(p->hi, n0, n1) + psum(p->hl, n0, n1) + add_hfds * dt);
}

static pset ps;

static ofx_writer *open_file(const ofx_grid *g, const char *name, char *path, size_t len, sph_error *err)
{
    ofx_meta m = {.title = "test", .institution = "test", .model_version = "0", .git_revision = "0",
                  .cycle_time = 1e9};
    snprintf(path, len, "%s/%s", dir, name);
    ofx_writer *w = NULL;
    sph_error_clear(err);
    CHECK(ofx_open(&w, g, &m, path, err) == SPH_OK, "open %s: %s", name, err->msg);
    return w;
}

/* Lon/lat grid 120..122 E, 39..40.5 N at 0.05 deg with a land block; the
 * plane: a local equirectangular map around (121, 39.75). */
static void lonlat_grid(void)
{
    enum { NXG = 40, NYG = 30 };
    const double lon0 = 120.025, lat0 = 39.025, d = 0.05, lonc = 121.0, latc = 39.75;
    static double lon[NXG], lat[NYG], cx[NXG * NYG], cy[NXG * NYG], area[NXG * NYG], flux[NXG * NYG];
    static unsigned char land[NXG * NYG];
    size_t ncell = NXG * NYG;
    for (int i = 0; i < NXG; i++)
        lon[i] = lon0 + i * d;
    for (int j = 0; j < NYG; j++)
        lat[j] = lat0 + j * d;
    for (int j = 0; j < NYG; j++)
        for (int i = 0; i < NXG; i++) {
            size_t c = (size_t)j * NXG + i;
            cx[c] = R_EARTH * cos(latc * DEG) * (lon[i] - lonc) * DEG;
            cy[c] = R_EARTH * (lat[j] - latc) * DEG;
            /* R^2 dlon (sin(lat_n) - sin(lat_s)) */
            area[c] = R_EARTH * R_EARTH * d * DEG * (sin((lat[j] + d / 2) * DEG) - sin((lat[j] - d / 2) * DEG));
            land[c] = i >= 38 && j >= 28; /* north-east corner: every point within reach of water */
        }
    ofx_grid g = {.kind = OFX_GRID_LONLAT, .nx = NXG, .ny = NYG, .xaxis = lon, .yaxis = lat, .cx = cx,
                  .cy = cy, .area = area, .land = land, .projection = "+proj=eqc (test)"};
    char path[1024];
    sph_error err;
    ofx_writer *w = open_file(&g, "lonlat.nc", path, sizeof path, &err);
    if (!w)
        return;
    double xmin = cx[0], xmax = cx[NXG - 1], ymin = cy[0], ymax = cy[ncell - 1];
    double cell = cy[NXG] - cy[0];
    ofx_particles o;
    fill_particles(&ps, &o, xmin, xmax, ymin, ymax, cell);
    /* the last 10 far outside the grid: counted, not placed */
    for (int k = NP - 10; k < NP; k++)
        ps.x[k] = xmax + 50.0 * cell;
    /* particles inside the land block reach the nearest water cells */
    CHECK(ofx_add_particles(w, &o, &err) == SPH_OK, "add particles: %s", err.msg);
    const double dt = 3600.0;
    CHECK(ofx_write_record(w, 1e9, 1e9 + dt, &err) == SPH_OK, "record 0: %s", err.msg);
    CHECK(ofx_lost(w) == 10, "10 particles far outside the grid are lost (%zu)", ofx_lost(w));

    /* record 1: the same particles plus open-water cell fluxes */
    double add = 0.0;
    for (size_t c = 0; c < ncell; c++) {
        flux[c] = land[c] ? 0.0 : -150.0 - 50.0 * urand(); /* W m-2 */
        add += flux[c] * area[c];
    }
    CHECK(ofx_add_particles(w, &o, &err) == SPH_OK, "add particles: %s", err.msg);
    CHECK(ofx_add_cells(w, OFX_HFDS, flux, &err) == SPH_OK, "add cells: %s", err.msg);
    flux[ncell - 1] = 5.0; /* on land */
    CHECK(ofx_add_cells(w, OFX_HFDS, flux, &err) != SPH_OK && strstr(err.msg, "on land"),
          "a cell flux on land is refused: %s", err.msg);
    sph_error_clear(&err);
    CHECK(ofx_add_cells(w, OFX_SICONC, flux, &err) != SPH_OK, "cells add fluxes only: %s", err.msg);
    sph_error_clear(&err);
    CHECK(ofx_write_record(w, 1e9 + dt, 1e9 + 3 * dt, &err) == SPH_OK, "record 1: %s", err.msg);
    CHECK(ofx_close(w, &err) == SPH_OK, "close: %s", err.msg);
    CHECK(access(path, F_OK) == 0, "file committed");

    check_sums(path, 0, ncell, &ps, 0, NP - 10, dt, 0.0, "lon/lat");
    check_sums(path, 1, ncell, &ps, 0, NP - 10, 2 * dt, add, "lon/lat + cells");
    size_t n;
    double *tb = read_var(path, "time_bnds", &n), *t = read_var(path, "time", &n);
    CHECK(tb && t && tb[2] == 1e9 + dt && tb[3] == 1e9 + 3 * dt && t[1] == 1e9 + 3 * dt,
          "time is the end of the interval, time_bnds the interval");
    free(tb);
    free(t);
    double *hf = read_var(path, "hfds", &n);
    CHECK(hf && hf[ncell - 1] > 1e19, "land cells are fill values");
    free(hf);
}

/* Projected grid: 25 x 20 cells of 2 km on the plane, true area dx dy. */
static void plane_grid(void)
{
    enum { NXG = 25, NYG = 20 };
    static double xa[NXG], ya[NYG], cx[NXG * NYG], cy[NXG * NYG], area[NXG * NYG], lon[NXG * NYG],
        lat[NXG * NYG];
    size_t ncell = NXG * NYG;
    const double dx = 2000.0;
    for (int i = 0; i < NXG; i++)
        xa[i] = -20000.0 + i * dx;
    for (int j = 0; j < NYG; j++)
        ya[j] = 5000.0 + j * dx;
    for (int j = 0; j < NYG; j++)
        for (int i = 0; i < NXG; i++) {
            size_t c = (size_t)j * NXG + i;
            cx[c] = xa[i];
            cy[c] = ya[j];
            area[c] = dx * dx;
            lon[c] = 121.0 + xa[i] / (R_EARTH * cos(40 * DEG) * DEG);
            lat[c] = 40.0 + ya[j] / (R_EARTH * DEG);
        }
    ofx_grid g = {.kind = OFX_GRID_PLANE, .nx = NXG, .ny = NYG, .xaxis = xa, .yaxis = ya, .lon = lon,
                  .lat = lat, .cx = cx, .cy = cy, .area = area, .land = NULL, .projection = "+proj=test"};
    char path[1024];
    sph_error err;
    ofx_writer *w = open_file(&g, "plane.nc", path, sizeof path, &err);
    if (!w)
        return;
    ofx_particles o;
    /* anywhere on the cells (their outer edges are half a cell beyond the
     * centres); the last 20 one to three cells beyond the grid's edge */
    fill_particles(&ps, &o, xa[0] - 0.5 * dx, xa[NXG - 1] + 0.5 * dx, ya[0] - 0.5 * dx, ya[NYG - 1] + 0.5 * dx, dx);
    for (int k = NP - 20; k < NP; k++)
        ps.y[k] = ya[NYG - 1] + dx * (1.0 + 2.0 * urand());
    CHECK(ofx_add_particles(w, &o, &err) == SPH_OK, "add: %s", err.msg);
    CHECK(ofx_write_record(w, 0.0, 600.0, &err) == SPH_OK, "record: %s", err.msg);
    CHECK(ofx_lost(w) == 20, "the 20 particles beyond the edge are left out (%zu)", ofx_lost(w));
    CHECK(ofx_close(w, &err) == SPH_OK, "close: %s", err.msg);
    check_sums(path, 0, ncell, &ps, 0, NP - 20, 600.0, 0.0, "projected");
}

/* Steady free drift without Coriolis: wind stress + water drag = 0. */
static void stress(void)
{
    const double ua = 8.0, va = -3.0, uw = 0.10, vw = 0.05;
    ofx_drift d;
    CHECK(ofx_drift_run(&d, ua, va, uw, vw, 50) == 0, "free drift");
    sph_params p = d.p;
    sph_model *m = d.m;
    sph_particles *P = d.P;
    double area = d.fp, T = d.T;
    double tx = P->ofx_taux[0] / (area * T), ty = P->ofx_tauy[0] / (area * T);
    /* the water's drag on the ice, from the formula */
    double dx_ = d.drag[0], dy_ = d.drag[1];
    CHECK_CLOSE(tx, -dx_, 1e-12, 0, "stress on the ocean x = minus the water drag");
    CHECK_CLOSE(ty, -dy_, 1e-12, 0, "stress on the ocean y = minus the water drag");
    /* steady free drift: the ocean takes the wind's stress (turn_air 0) */
    double wa = hypot(ua, va);
    CHECK_CLOSE(tx, p.rho_a * p.Ca * wa * ua, 1e-6, 0, "stress on the ocean = wind stress, x");
    CHECK_CLOSE(ty, p.rho_a * p.Ca * wa * va, 1e-6, 0, "stress on the ocean = wind stress, y");
    printf("  stress on the ocean (%.10g, %.10g) N/m2, wind stress (%.10g, %.10g)\n", tx, ty,
           p.rho_a * p.Ca * wa * ua, p.rho_a * p.Ca * wa * va);

    /* into the file on a plane grid around the particle: tauuo = -drag */
    enum { NG = 9 };
    static double xa[NG], ya[NG], cx[NG * NG], cy[NG * NG], ar[NG * NG], lo[NG * NG], la[NG * NG];
    for (int i = 0; i < NG; i++)
        {
        xa[i] = P->x[0] + (i - NG / 2) * 1000.0;
        ya[i] = P->y[0] + (i - NG / 2) * 1000.0;
    }
    for (int j = 0; j < NG; j++)
        for (int i = 0; i < NG; i++) {
            size_t c = (size_t)j * NG + i;
            cx[c] = xa[i];
            cy[c] = ya[j];
            ar[c] = 1e6;
            lo[c] = la[c] = 0.0;
        }
    ofx_grid g = {.kind = OFX_GRID_PLANE, .nx = NG, .ny = NG, .xaxis = xa, .yaxis = ya, .lon = lo, .lat = la,
                  .cx = cx, .cy = cy, .area = ar};
    ofx_meta meta = {.title = "stress", .cycle_time = 0};
    char path[1024];
    snprintf(path, sizeof path, "%s/stress.nc", dir);
    ofx_writer *w = NULL;
    sph_error err;
    sph_error_clear(&err);
    double rad = 2500.0, zero = 0.0, ia = P->mass[0] / (p.rho_i * P->thick[0]), iv = P->mass[0] / p.rho_i;
    ofx_particles o = {.n = 1, .x = P->x, .y = P->y, .radius = &rad, .heat_ice = &zero, .heat_lead = &zero,
                       .water = &zero, .salt = &zero, .taux = P->ofx_taux, .tauy = P->ofx_tauy, .swbase = &zero,
                       .ice_area = &ia, .ice_volume = &iv};
    CHECK(ofx_open(&w, &g, &meta, path, &err) == SPH_OK && ofx_add_particles(w, &o, &err) == SPH_OK &&
              ofx_write_record(w, 0.0, T, &err) == SPH_OK && ofx_close(w, &err) == SPH_OK,
          "stress file: %s", err.msg);
    CHECK_CLOSE(area_sum(path, "tauuo", 0, NG * NG) / area, -dx_, 1e-10, 0, "file: tauuo = -drag x");
    CHECK_CLOSE(area_sum(path, "tauvo", 0, NG * NG) / area, -dy_, 1e-10, 0, "file: tauvo = -drag y");
    CHECK_CLOSE(area_sum(path, "sistrxubot", 0, NG * NG) / area, dx_, 1e-10, 0, "file: sistrxubot = drag x");
    CHECK_CLOSE(area_sum(path, "siconc", 0, NG * NG), ia, 1e-10, 0, "file: the ice area");

    /* ten times the ice area in one small patch: siconc is capped at 1,
     * sivol still conserves and sithick = sivol / siconc */
    double ia10 = 10.0 * 9e6, iv10 = 0.5 * ia10, rad1 = 1000.0;
    o.ice_area = &ia10;
    o.ice_volume = &iv10;
    o.radius = &rad1;
    snprintf(path, sizeof path, "%s/stress2.nc", dir);
    CHECK(ofx_open(&w, &g, &meta, path, &err) == SPH_OK && ofx_add_particles(w, &o, &err) == SPH_OK &&
              ofx_write_record(w, 0.0, T, &err) == SPH_OK && ofx_close(w, &err) == SPH_OK,
          "capped file: %s", err.msg);
    size_t nn;
    double *cc = read_var(path, "siconc", &nn), *tk = read_var(path, "sithick", &nn), *vv = read_var(path, "sivol", &nn);
    int capped = 1;
    for (size_t c = 0; cc && tk && vv && c < NG * NG; c++)
        if (cc[c] > 1.0 || (cc[c] > 0.0 && fabs(tk[c] - vv[c] / cc[c]) > 1e-12 * tk[c]))
            capped = 0;
    CHECK(cc && capped && cc[(NG / 2) * NG + NG / 2] == 1.0, "siconc capped at 1, sithick = sivol / siconc");
    free(cc);
    free(tk);
    free(vv);
    CHECK_CLOSE(area_sum(path, "sivol", 0, NG * NG), iv10, 1e-10, 0, "sivol conserves where siconc is capped");
    sph_model_free(m);
}

/* Bitz-Lipscomb bulk salinity: mean over the layer midpoints. */
static double bl_bulk(const sph_thermo_params *p, int n)
{
    double s = 0.0;
    for (int i = 0; i < n; i++) {
        double z = (i + 0.5) / n;
        s += 0.5 * p->salinity_max * (1.0 - cos(M_PI * pow(z, p->salinity_a / (z + p->salinity_b))));
    }
    return s / n;
}

static void column(void)
{
    sph_thermo_params p;
    sph_thermo_params_default(&p);
    p.ocean_fluxes = 1;
    const double area = 1.0e6, dt = 3600.0, Fw = 15.0;
    sph_particles *P = sph_particles_create(4, p.nlayers);
    P->n = 4;
    /* 0: thick multi-layer ice in cold air, ocean heat flux 15 W/m2, no leads
     * 1: thin zero-layer ice, A = 1, melting from below (Fw 500)
     * 2: A = 0.6 with leads at the freezing point in cold air: new ice
     * 3: A = 1 melting at the top in warm sun (snow-free, multi-layer) */
    const double h0[4] = {1.2, 0.15, 0.5, 1.0}, A0[4] = {1.0, 1.0, 0.6, 1.0};
    for (size_t k = 0; k < 4; k++) {
        P->id[k] = (long)k;
        P->thick[k] = h0[k];
        P->conc[k] = A0[k];
        P->mass[k] = p.rho_i * A0[k] * h0[k] * area;
        P->sml[k] = 1000.0;
        P->ua[k] = 5.0;
        P->va[k] = 5.0;
        P->tair[k] = k == 3 ? 5.0 : -20.0;
        P->qair[k] = k == 3 ? 4e-3 : 6e-4;
        P->swdn[k] = k == 3 ? 600.0 : 0.0;
        P->lwdn[k] = k == 3 ? 320.0 : 180.0;
        P->sst[k] = sph_freezing_point(&p);
        P->fw[k] = k == 1 ? 500.0 : Fw;
        P->fsens[k] = P->flat[k] = NAN;
        sph_thermo_init_particle(&p, P, k, P->tair[k]);
    }
    double m0[4], A_0[4];
    for (int k = 0; k < 4; k++) {
        m0[k] = P->mass[k];
        A_0[k] = P->conc[k];
    }
    sph_thermo_work *w = sph_thermo_work_create(4, p.nlayers);
    sph_status st;
    sph_budget b;
    memset(&b, 0, sizeof b);
    CHECK(sph_thermo_step(&p, P, dt, w, &b, &st) == SPH_STEP_OK, "thermo step: %s", st.what);
    double Si = bl_bulk(&p, p.nlayers);
    printf("  bulk ice salinity S_i = %.6f ppt (Bitz-Lipscomb profile, %d layers)\n", Si, p.nlayers);
    for (int k = 0; k < 4; k++) {
        /* dh per unit ice area over the ice's original footprint share */
        double dm = P->mass[k] - m0[k]; /* kg of ice gained */
        double fw_want = -dm * (1.0 - Si / 1000.0), salt_want = -dm * Si / 1000.0;
        CHECK(fabs(P->ofx_water[k] - fw_want) <= 1e-12 * fabs(fw_want) + 1e-9,
              "particle %d: fresh water %.17g = -rho_i dV (1 - S_i/1000) = %.17g", k, P->ofx_water[k], fw_want);
        CHECK(fabs(P->ofx_salt[k] - salt_want) <= 1e-12 * fabs(salt_want) + 1e-12,
              "particle %d: salt %.17g = -rho_i dV S_i/1000 = %.17g", k, P->ofx_salt[k], salt_want);
        double h_want = -P->fw[k] * A_0[k] * area * dt;
        CHECK(fabs(P->ofx_heat_ice[k] - h_want) <= 1e-12 * fabs(h_want) + 1e-6 || (k == 1 && P->mass[1] == 0.0),
              "particle %d: heat under the ice %.17g = -F_w A area dt = %.17g", k, P->ofx_heat_ice[k], h_want);
        printf("  particle %d: dm %.6g kg, water %.6g kg, salt %.6g kg, heat_ice %.6g J, heat_lead %.6g J, "
               "sw_base %.6g J\n", k, dm, P->ofx_water[k], P->ofx_salt[k], P->ofx_heat_ice[k], P->ofx_heat_lead[k],
               P->ofx_swbase[k]);
    }
    CHECK(P->mass[0] > m0[0], "thick ice in -20 C air grows against 15 W/m2");
    CHECK(P->mass[1] < m0[1], "thin ice melts under 500 W/m2");
    CHECK(P->conc[2] > A_0[2] && P->ofx_heat_lead[2] == 0.0, "the freezing lead makes ice and sends no heat");
    CHECK(P->ofx_swbase[3] > 0.0 && P->ofx_swbase[0] == 0.0, "shortwave reaches the base only in sunlight");
    /* growth rate of the steady column 0: rho_i dh/dt = (F_c - F_w) / L_b
     * is what the column solved; the ocean's water is its negative */
    double dhdt = (P->mass[0] - m0[0]) / (p.rho_i * area * dt);
    CHECK_CLOSE(P->ofx_water[0] / (area * dt), -p.rho_i * dhdt * (1.0 - Si / 1000.0), 1e-12, 0,
                "fresh-water flux = -rho_i dh/dt (1 - S_i/1000)");
    CHECK_CLOSE(P->ofx_salt[0] / (area * dt), -p.rho_i * dhdt * Si / 1000.0, 1e-12, 0,
                "salt flux = -rho_i dh/dt S_i/1000");

    /* off: nothing accumulates, and the state evolves bit for bit the same */
    sph_particles *Q = sph_particles_create(4, p.nlayers), *R = sph_particles_create(4, p.nlayers);
    for (size_t k = 0; k < 4; k++) {
        sph_particles_copy_one(Q, k, P, k);
        sph_particles_copy_one(R, k, P, k);
    }
    Q->n = R->n = 4;
    sph_thermo_params off = p;
    off.ocean_fluxes = 0;
    double before = Q->ofx_water[0];
    CHECK(sph_thermo_step(&p, Q, dt, w, NULL, &st) == SPH_STEP_OK && sph_thermo_step(&off, R, dt, w, NULL, &st) == SPH_STEP_OK,
          "steps on and off");
    CHECK(R->ofx_water[0] == before && Q->ofx_water[0] != before, "off leaves the accumulators alone");
    CHECK(!memcmp(Q->mass, R->mass, 4 * sizeof(double)) && !memcmp(Q->thick, R->thick, 4 * sizeof(double)) &&
              !memcmp(Q->enth, R->enth, 4 * (size_t)p.nlayers * sizeof(double)),
          "accumulating changes nothing in the state");
    sph_particles_free(Q);
    sph_particles_free(R);
    sph_thermo_work_free(w);
    sph_particles_free(P);
}

int main(void)
{
    if (!mkdtemp(dir)) {
        perror("mkdtemp");
        return 1;
    }
    lonlat_grid();
    plane_grid();
    stress();
    column();
    char cmd[256];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", dir);
    return check_summary("test_ocean_fluxes");
}
