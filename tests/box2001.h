/* CICE's box2001 (Hunke 2001) in sphice, shared by tests/test_box2001.c and
 * bench/bench_box2001.c: the case as defined in
 * ../shared/reference/cice-box2001/README.md (CICE 6.6.3's set_nml.box2001,
 * ice_forcing.F90 box2001_data_atm/ocn, ice_init.F90), the reading of CICE's
 * solution, and the side-by-side scores.
 *
 * The box on a plane centred on it: 80 x 80 T cells of 16 km, T(a, b) (array
 * indices 0..79) at x = (a - 39.5) dx, U(a, b) at x = (a - 39) dx; the
 * outer two rows of T cells are land (the land mask), the particles sit on
 * the 76 x 76 ocean T centres (5776). Ice A = (a + 0.5) / 80, 2 m thick;
 * rho_i 950 so that the mass per area 1900 A kg/m2 is CICE's ice (917 x 2 A)
 * plus snow (330 x 0.2 A). Wind and ocean are CICE's formulas evaluated at
 * the particle, in CICE's continuous U-point index i = x / dx + 40 (1-based),
 * the geostrophic tilt g grad xi = -f k x U_w. Header-only: links nothing
 * beyond the core and NetCDF. */
#ifndef SPHICE_TESTS_BOX2001_H
#define SPHICE_TESTS_BOX2001_H

#include <math.h>
#include <netcdf.h>
#include <stdlib.h>
#include <string.h>

#include "core/model.h"

#define B01_N 80
#define B01_DX 16000.0
#define B01_F 1.46e-4
#define B01_REF "/work/shared/reference/cice-box2001/cice-6.6.3-box2001-evp.nc"

/* sphice's parameters for the case: CICE's, and the comparison options
 * (fixed state, CICE's drag form, constant f). */
static inline void b01_params(sph_params *p, double dt)
{
    /* by the configuration's model.* keys (core/params.h's table) */
    static const struct {
        const char *key;
        double v;
    } rows[] = {
        {"physics", SPH_PHYSICS_FULL}, {"solver", SPH_SOLVER_MEVP}, {"rheology.kind", SPH_RHEOLOGY_VP},
        {"rheology.pressure_form", SPH_PRESSURE_HIBLER}, {"rheology.P0", 2.75e4}, {"rheology.C", 20},
        {"rheology.e", 2}, {"rheology.replacement_pressure", 1}, {"rheology.delta_min", 2e-9},
        {"momentum.rho_ice", 950}, {"momentum.rho_air", 1.3}, {"momentum.Ca", 1.2e-3},
        {"momentum.rho_water", 1026}, {"momentum.Cw", 5.36e-3}, {"momentum.turn_air", 0},
        {"momentum.turn_water", 0}, {"coast_no_slip", 1}, {"thermo.dt", 0}, {"thermo.model", SPH_THERMO_OFF},
        {"fixed_state", 1}, {"momentum.drag_scaling", SPH_DRAG_CONCENTRATION}, {"momentum.coriolis", 1},
        {"momentum.coriolis_f", B01_F},
    };
    sph_params_default(p);
    p->dt = dt;
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        const sph_param *r = sph_param_find(rows[i].key);
        if (!r || sph_param_set(r, p, rows[i].v) != SPH_STEP_OK)
            abort(); /* a key or value the table does not have: the case is wrong */
    }
}

typedef struct b01_case {
    sph_model *model;
    unsigned char land[B01_N * B01_N];
} b01_case;

static inline int b01_ocean(int a) { return a >= 2 && a <= B01_N - 3; }

/* The model with its particles on the ocean T centres; 0 on success. The
 * particle id is a + 80 b. */
static inline int b01_create(b01_case *c, const sph_params *p)
{
    for (int b = 0; b < B01_N; b++)
        for (int a = 0; a < B01_N; a++)
            c->land[b * B01_N + a] = !(b01_ocean(a) && b01_ocean(b));
    sph_landmask mk = {.nx = B01_N, .ny = B01_N, .x0 = -40 * B01_DX, .y0 = -40 * B01_DX,
                       .dx = B01_DX, .dy = B01_DX, .land = c->land, .closed_outside = 1};
    c->model = sph_model_create(p, 76 * 76, &mk);
    if (!c->model)
        return -1;
    sph_particles *P = sph_model_particles(c->model);
    size_t n = 0;
    for (int b = 2; b <= B01_N - 3; b++)
        for (int a = 2; a <= B01_N - 3; a++, n++) {
            double A = (a + 0.5) / B01_N;
            P->x[n] = (a - 39.5) * B01_DX;
            P->y[n] = (b - 39.5) * B01_DX;
            P->u[n] = P->v[n] = 0.0;
            P->conc[n] = A;
            P->thick[n] = 2.0;
            P->mass[n] = p->rho_i * A * 2.0 * B01_DX * B01_DX;
            P->sml[n] = P->sml0[n] = p->sml_factor * B01_DX;
            P->id[n] = a + B01_N * b;
            P->lat[n] = 90.0;
            P->tsurf[n] = -10.0;
        }
    P->n = n;
    return 0;
}

/* CICE's analytic wind (at time t, s) and ocean at each particle, and the
 * geostrophic tilt. */
static inline void b01_forcing(sph_model *m, double t)
{
    sph_particles *P = sph_model_particles(m);
    const double g = sph_model_params(m)->gravity, N = B01_N;
    double s = sin(2.0 * M_PI * t / (4.0 * 86400.0)) - 3.0;
    for (size_t k = 0; k < P->n; k++) {
        double i = P->x[k] / B01_DX + 40.0, j = P->y[k] / B01_DX + 40.0;
        P->ua[k] = 5.0 + s * sin(2.0 * M_PI * i / N) * sin(M_PI * j / N);
        P->va[k] = 5.0 + s * sin(M_PI * i / N) * sin(2.0 * M_PI * j / N);
        P->uw[k] = 0.2 * j / N - 0.1;
        P->vw[k] = -0.2 * i / N + 0.1;
        /* -g grad xi = f k x U_w */
        P->sshx[k] = B01_F * P->vw[k] / g;
        P->sshy[k] = -B01_F * P->uw[k] / g;
    }
}

/* Runs the model from its state at time t0 to t1 (s); returns the number of
 * steps (negative on a failed step). */
static inline long b01_run(sph_model *m, double t1, double *iters)
{
    sph_status st;
    const double dt = sph_model_params(m)->dt;
    long n = 0;
    while (sph_model_time(m) < t1 - 1e-6 * dt) {
        b01_forcing(m, sph_model_time(m));
        if (sph_model_step(m, &st) != SPH_STEP_OK)
            return -1;
        if (iters)
            *iters += sph_model_stats(m)->iterations;
        n++;
    }
    return n;
}

/* A field on the 80 x 80 points: [b * 80 + a]. */
typedef struct b01_fields {
    double u[B01_N * B01_N], v[B01_N * B01_N];         /* U points */
    double div[B01_N * B01_N], shear[B01_N * B01_N];   /* T points, % per day */
    double aice[B01_N * B01_N];                        /* T points */
} b01_fields;

/* An interior ocean U point (four ocean T cells around it). */
static inline int b01_u_ocean(int a, int b) { return a >= 2 && a <= 76 && b >= 2 && b <= 76; }

/* CICE's B-grid strain rates at the T points from the U velocities (the
 * wall U points are zero): divergence and sqrt(tension^2 + shearing^2),
 * in % per day, on a uniform grid. */
static inline void b01_strain(b01_fields *f)
{
    for (int b = 0; b < B01_N; b++)
        for (int a = 0; a < B01_N; a++) {
            int t = b * B01_N + a;
            f->div[t] = f->shear[t] = NAN;
            if (!(b01_ocean(a) && b01_ocean(b)))
                continue;
            int ne = t, nw = t - 1, se = t - B01_N, sw = t - B01_N - 1;
            double h = 0.5 / B01_DX;
            double dudx = h * (f->u[ne] + f->u[se] - f->u[nw] - f->u[sw]);
            double dvdy = h * (f->v[ne] + f->v[nw] - f->v[se] - f->v[sw]);
            double dudy = h * (f->u[ne] + f->u[nw] - f->u[se] - f->u[sw]);
            double dvdx = h * (f->v[ne] + f->v[se] - f->v[nw] - f->v[sw]);
            double pd = 100.0 * 86400.0;
            f->div[t] = pd * (dudx + dvdy);
            f->shear[t] = pd * sqrt((dudx - dvdy) * (dudx - dvdy) + (dudy + dvdx) * (dudy + dvdx));
        }
}

/* sphice's velocities on CICE's U points: the mean of the four particles
 * on the surrounding T centres (the state is fixed, so they are there),
 * zero on the wall U points; then the strain rates; aice on T points. */
static inline int b01_grid(sph_model *m, b01_fields *f)
{
    const sph_particles *P = sph_model_particles(m);
    static double tu[B01_N * B01_N], tv[B01_N * B01_N];
    int seen = 0;
    memset(f, 0, sizeof *f);
    for (size_t k = 0; k < P->n; k++) {
        long id = P->id[k];
        int a = (int)(id % B01_N), b = (int)(id / B01_N);
        if (fabs(P->x[k] - (a - 39.5) * B01_DX) > 1e-6 || fabs(P->y[k] - (b - 39.5) * B01_DX) > 1e-6)
            return -1; /* moved: not a fixed state */
        tu[id] = P->u[k];
        tv[id] = P->v[k];
        f->aice[id] = P->conc[k];
        seen++;
    }
    if (seen != 76 * 76)
        return -1;
    for (int b = 0; b < B01_N; b++)
        for (int a = 0; a < B01_N; a++) {
            int q = b * B01_N + a;
            if (!b01_u_ocean(a, b))
                continue;
            f->u[q] = 0.25 * (tu[q] + tu[q + 1] + tu[q + B01_N] + tu[q + B01_N + 1]);
            f->v[q] = 0.25 * (tv[q] + tv[q + 1] + tv[q + B01_N] + tv[q + B01_N + 1]);
        }
    b01_strain(f);
    return 0;
}

/* CICE's solution at time index it (0: 6 h, 1: 24 h); fill values (land)
 * become 0 for the velocities and NaN for the T fields. divu and shear are
 * the file's own. 0 on success. */
static inline int b01_read_ref(const char *path, int it, b01_fields *f)
{
    int nc, id;
    static float buf[B01_N * B01_N];
    if (nc_open(path, NC_NOWRITE, &nc) != NC_NOERR)
        return -1;
    size_t start[3] = {(size_t)it, 0, 0}, count[3] = {1, B01_N, B01_N};
    const char *names[5] = {"uvel", "vvel", "divu", "shear", "aice"};
    double *dst[5] = {f->u, f->v, f->div, f->shear, f->aice};
    int rc = 0;
    for (int q = 0; q < 5 && rc == 0; q++) {
        if (nc_inq_varid(nc, names[q], &id) != NC_NOERR ||
            nc_get_vara_float(nc, id, start, count, buf) != NC_NOERR) {
            rc = -1;
            break;
        }
        for (int t = 0; t < B01_N * B01_N; t++)
            dst[q][t] = buf[t] > 1e29f ? (q < 2 ? 0.0 : NAN) : (double)buf[t];
    }
    nc_close(nc);
    return rc;
}

/* The side-by-side scores of sphice (s) against CICE (c). */
typedef struct b01_scores {
    double rms_cice, rel_all, rel_packed, rel_loose;  /* RMS |s - c| / CICE's RMS speed */
    double dir_all, dir_packed;                       /* mean direction of s from c, degrees (+: anticlockwise) */
    double speed_ratio_packed;                        /* RMS speed s / c in packed ice */
    double corr_div, corr_shear;                      /* Pearson over ocean T cells */
    double rms_div_c, rms_div_s, rms_shear_c, rms_shear_s; /* % per day */
    double rel_wall_band; /* RMS |s - c| of packed ice within 3 cells of the east wall over
                             CICE's RMS speed of all packed ice */
} b01_scores;

static inline double b01_corr(const double *x, const double *y)
{
    double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
    int n = 0;
    for (int t = 0; t < B01_N * B01_N; t++) {
        if (!isfinite(x[t]) || !isfinite(y[t]))
            continue;
        sx += x[t];
        sy += y[t];
        sxx += x[t] * x[t];
        syy += y[t] * y[t];
        sxy += x[t] * y[t];
        n++;
    }
    double cxy = sxy - sx * sy / n, cxx = sxx - sx * sx / n, cyy = syy - sy * sy / n;
    return cxy / sqrt(cxx * cyy);
}

static inline double b01_rms(const double *x)
{
    double s = 0;
    int n = 0;
    for (int t = 0; t < B01_N * B01_N; t++)
        if (isfinite(x[t])) {
            s += x[t] * x[t];
            n++;
        }
    return sqrt(s / n);
}

/* Scores over the interior ocean U points (the wall U points are zero in
 * both); packed: CICE's U-point concentration (mean of the four T cells)
 * at least 0.8. Each ratio is over CICE's RMS speed of the same set. */
static inline void b01_score(const b01_fields *s, const b01_fields *c, b01_scores *o)
{
    double d2[4] = {0}, c2[4] = {0}, s2[4] = {0}, cr[4] = {0}, dt[4] = {0};
    int n[4] = {0};
    for (int b = 0; b < B01_N; b++)
        for (int a = 0; a < B01_N; a++) {
            if (!b01_u_ocean(a, b))
                continue;
            int q = b * B01_N + a;
            double A = 0.25 * (c->aice[q] + c->aice[q + 1] + c->aice[q + B01_N] + c->aice[q + B01_N + 1]);
            double du = s->u[q] - c->u[q], dv = s->v[q] - c->v[q];
            int sets[4] = {1, A >= 0.8, A < 0.8, A >= 0.8 && a >= 74};
            for (int g = 0; g < 4; g++) {
                if (!sets[g])
                    continue;
                d2[g] += du * du + dv * dv;
                c2[g] += c->u[q] * c->u[q] + c->v[q] * c->v[q];
                s2[g] += s->u[q] * s->u[q] + s->v[q] * s->v[q];
                cr[g] += c->u[q] * s->v[q] - c->v[q] * s->u[q];
                dt[g] += c->u[q] * s->u[q] + c->v[q] * s->v[q];
                n[g]++;
            }
        }
    o->rms_cice = sqrt(c2[0] / n[0]);
    o->rel_all = sqrt(d2[0] / c2[0]);
    o->rel_packed = sqrt(d2[1] / c2[1]);
    o->rel_loose = sqrt(d2[2] / c2[2]);
    o->rel_wall_band = sqrt(d2[3] / n[3]) / sqrt(c2[1] / n[1]);
    o->dir_all = atan2(cr[0], dt[0]) * 180.0 / M_PI;
    o->dir_packed = atan2(cr[1], dt[1]) * 180.0 / M_PI;
    o->speed_ratio_packed = sqrt(s2[1] / c2[1]);
    o->corr_div = b01_corr(s->div, c->div);
    o->corr_shear = b01_corr(s->shear, c->shear);
    o->rms_div_c = b01_rms(c->div);
    o->rms_div_s = b01_rms(s->div);
    o->rms_shear_c = b01_rms(c->shear);
    o->rms_shear_s = b01_rms(s->shear);
}

#endif
