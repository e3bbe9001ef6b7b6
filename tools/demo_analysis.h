/* Analysis of the Liaodong Bay demo's particle trajectories, shared by
 * tools/demo_summary.c (the numbers `make demo` prints) and
 * tests/test_demo.c (the seed's qualitative findings asserted on them).
 *
 * Everything is computed from a run's products only (the trajectory file
 * read with products_read_particles, the fields file's global attributes,
 * cycle.json), never from the engine's internals:
 *   - the thick patch: the particles whose thickness at the first output
 *     time exceeds DEMO_PATCH_THICK (0.2 m: the patch is 0.27-0.43 m, the
 *     ice around it under 0.10 m), followed by id;
 *   - ice area of the patch: sum of mass / (rho_i h_i) (= A x particle
 *     area, since a particle's mass is rho_i A h_i times its area);
 *   - footprint of the patch: sum of mass / (rho_i A h_i), the area its
 *     particles occupy, open water between the floes included (it grows
 *     when the patch spreads even where A falls and h_i stays);
 *   - mean thickness: volume / area = sum (m / rho_i) / sum (m / (rho_i h_i))
 *     (the area-weighted mean of h_i); mean concentration: plain mean of
 *     the particles' A;
 *   - centre: mass-weighted mean position; its velocity: mass-weighted
 *     mean of the particles' (u, v);
 *   - velocity spread: sqrt(var u + var v) over the patch particles at one
 *     time (mass-weighted), averaged over the output times;
 *   - tidal reversals: sign changes of the centre velocity's component
 *     along the bay axis (bearing DEMO_AXIS_DEG) between output times.
 * Header-only (static functions), so that the tool and the test need no
 * Makefile change.
 */
#ifndef SPHICE_TOOLS_DEMO_ANALYSIS_H
#define SPHICE_TOOLS_DEMO_ANALYSIS_H

#include <dirent.h>
#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <cjson/cJSON.h>
#include "io/products.h"
#include "util/err.h"

#define DEMO_PATCH_THICK 0.2     /* m */
#define DEMO_AXIS_DEG 35.0       /* bay axis bearing (README: about 34 deg) */
#define DEMO_EARTH_R 6371.0      /* km */
#define DEMO_MAX_TIMES 2500

typedef struct demo_time {
    double t;                    /* seconds since 1970 */
    double hours;                /* since the first output time */
    long n;                      /* patch particles present */
    double area_km2, mean_thick, mean_conc;
    double footprint_km2;        /* sum m / (rho_i A h_i) */
    double lon_c, lat_c;         /* mass-weighted centre */
    double u_c, v_c;             /* mass-weighted mean velocity, m/s */
    double vel_spread;           /* m/s */
    double radius_km;            /* mass-weighted RMS distance from the centre */
} demo_time;

typedef struct demo_run {
    char particles_path[4096];
    char fields_path[4096];
    char cycle_json[4096];
    double rho_i;
    long n_patch;                /* patch particles at t0 */
    long n_particles0;           /* all particles at t0 */
    int ntimes;
    demo_time *times;            /* ntimes entries */
    double drift_km, drift_bearing_deg; /* centre, first to last time */
    double vel_spread_mean;      /* mean over the output times */
    int reversals;               /* sign changes of the along-axis centre velocity */
    double budget_residual;      /* fields attribute or cycle.json; NaN if neither */
    double budget_residual_cycle_json; /* cycle.json result.budget_residual; NaN if absent */
} demo_run;

static int demo_cmp_long(const void *a, const void *b)
{
    long x = *(const long *)a, y = *(const long *)b;
    return (x > y) - (x < y);
}

static int demo_ends_with(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a >= b && !strcmp(s + a - b, suffix);
}

/* Finds DIR/NAME ending in suffix; DIR is a cycle directory, or an --out
 * directory holding `latest` (or a single cycle directory). */
static int demo_find_file(const char *dir, const char *suffix, char *out, size_t len)
{
    char sub[4096];
    snprintf(sub, sizeof sub, "%s/latest", dir);
    struct stat sb;
    const char *look = dir;
    if (stat(sub, &sb) == 0 && S_ISDIR(sb.st_mode))
        look = sub;
    for (int pass = 0; pass < 2; pass++) {
        DIR *d = opendir(look);
        if (!d)
            return -1;
        struct dirent *e;
        int found = 0;
        char only_sub[4096] = "";
        int nsub = 0;
        while ((e = readdir(d))) {
            if (e->d_name[0] == '.')
                continue;
            if (demo_ends_with(e->d_name, suffix)) {
                int w = snprintf(out, len, "%s/%s", look, e->d_name);
                found = w > 0 && (size_t)w < len;
                break;
            }
            char p[4096];
            int w = snprintf(p, sizeof p, "%s/%s", look, e->d_name);
            if (w > 0 && (size_t)w < sizeof p && stat(p, &sb) == 0 && S_ISDIR(sb.st_mode)) {
                nsub++;
                memcpy(only_sub, p, (size_t)w + 1);
            }
        }
        closedir(d);
        if (found)
            return 0;
        if (pass == 0 && nsub == 1) {
            snprintf(sub, sizeof sub, "%s", only_sub);
            look = sub;
            continue;
        }
        break;
    }
    return -1;
}

/* Distinct observation times of a trajectory file, in file order. */
static int demo_read_times(const char *path, double *t, int max, int *n, sph_error *err)
{
    int nc, v, d, st = nc_open(path, NC_NOWRITE, &nc);
    if (st != NC_NOERR)
        return sph_err_set(err, SPH_ERR_IO, "%s: %s", path, nc_strerror(st));
    size_t nobs = 0;
    if ((st = nc_inq_varid(nc, "time", &v)) || (st = nc_inq_dimid(nc, "obs", &d)) ||
        (st = nc_inq_dimlen(nc, d, &nobs))) {
        nc_close(nc);
        return sph_err_set(err, SPH_ERR_BAD_DATA, "%s: time/obs: %s", path, nc_strerror(st));
    }
    double *all = malloc((nobs ? nobs : 1) * sizeof *all);
    if (!all) {
        nc_close(nc);
        return sph_err_set(err, SPH_ERR_NOMEM, "%s: out of memory", path);
    }
    st = nc_get_var_double(nc, v, all);
    nc_close(nc);
    if (st != NC_NOERR) {
        free(all);
        return sph_err_set(err, SPH_ERR_IO, "%s: read time: %s", path, nc_strerror(st));
    }
    *n = 0;
    for (size_t k = 0; k < nobs; k++)
        if (*n == 0 || fabs(all[k] - t[*n - 1]) > 0.5) {
            if (*n == max) {
                free(all);
                return sph_err_set(err, SPH_ERR_BAD_DATA, "%s: more than %d output times", path, max);
            }
            t[(*n)++] = all[k];
        }
    free(all);
    return *n ? SPH_OK : sph_err_set(err, SPH_ERR_BAD_DATA, "%s: no observations", path);
}

/* Initial bearing (degrees clockwise from north) and great-circle distance
 * (km) from (lon1, lat1) to (lon2, lat2). */
static void demo_bearing(double lon1, double lat1, double lon2, double lat2, double *km, double *deg)
{
    const double r = M_PI / 180;
    double p1 = lat1 * r, p2 = lat2 * r, dl = (lon2 - lon1) * r;
    double a = sin((p2 - p1) / 2) * sin((p2 - p1) / 2) + cos(p1) * cos(p2) * sin(dl / 2) * sin(dl / 2);
    *km = 2 * DEMO_EARTH_R * asin(fmin(1.0, sqrt(a)));
    double b = atan2(sin(dl) * cos(p2), cos(p1) * sin(p2) - sin(p1) * cos(p2) * cos(dl)) / r;
    *deg = fmod(b + 360.0, 360.0);
}

static double demo_attr_double(const char *path, const char *name)
{
    int nc;
    double v = NAN;
    if (nc_open(path, NC_NOWRITE, &nc) != NC_NOERR)
        return NAN;
    if (nc_get_att_double(nc, NC_GLOBAL, name, &v) != NC_NOERR)
        v = NAN;
    nc_close(nc);
    return v;
}

static double demo_cycle_json_residual(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NAN;
    char *text = NULL;
    size_t len = 0, cap = 0;
    for (;;) {
        if (len + 4096 + 1 > cap) {
            cap = cap ? 2 * cap : 65536;
            char *nt = realloc(text, cap);
            if (!nt)
                break;
            text = nt;
        }
        size_t got = fread(text + len, 1, cap - len - 1, f);
        len += got;
        if (got == 0)
            break;
    }
    fclose(f);
    if (!text)
        return NAN;
    text[len] = 0;
    double v = NAN;
    cJSON *j = cJSON_Parse(text);
    free(text);
    const cJSON *r = cJSON_GetObjectItemCaseSensitive(j, "result");
    const cJSON *b = cJSON_GetObjectItemCaseSensitive(r, "budget_residual");
    if (cJSON_IsNumber(b))
        v = b->valuedouble;
    cJSON_Delete(j);
    return v;
}

static void demo_run_free(demo_run *r)
{
    if (r) {
        free(r->times);
        r->times = NULL;
    }
}

/* Reversals of the along-axis centre velocity within [0, hours]. */
static int demo_reversals_within(const demo_run *r, double hours)
{
    const double ax = sin(DEMO_AXIS_DEG * M_PI / 180), ay = cos(DEMO_AXIS_DEG * M_PI / 180);
    int n = 0, prev = 0;
    for (int k = 0; k < r->ntimes && r->times[k].hours <= hours + 1e-6; k++) {
        double along = r->times[k].u_c * ax + r->times[k].v_c * ay;
        int s = along > 0 ? 1 : along < 0 ? -1 : 0;
        if (s && prev && s != prev)
            n++;
        if (s)
            prev = s;
    }
    return n;
}

/* Analyses the run whose products are in dir (see demo_find_file). */
static int demo_analyse(const char *dir, double rho_i, demo_run *r, sph_error *err)
{
    memset(r, 0, sizeof *r);
    r->rho_i = rho_i;
    r->budget_residual = r->budget_residual_cycle_json = NAN;
    if (demo_find_file(dir, "_particles.nc", r->particles_path, sizeof r->particles_path))
        return sph_err_set(err, SPH_ERR_IO, "%s: no *_particles.nc (particles product off, or no run?)", dir);
    if (demo_find_file(dir, "_fields.nc", r->fields_path, sizeof r->fields_path))
        r->fields_path[0] = 0;
    if (demo_find_file(dir, "cycle.json", r->cycle_json, sizeof r->cycle_json))
        r->cycle_json[0] = 0;
    double *tt = malloc(DEMO_MAX_TIMES * sizeof *tt);
    if (!tt)
        return sph_err_set(err, SPH_ERR_NOMEM, "out of memory");
    int nt = 0, rc = demo_read_times(r->particles_path, tt, DEMO_MAX_TIMES, &nt, err);
    if (rc) {
        free(tt);
        return rc;
    }
    r->times = calloc((size_t)nt, sizeof *r->times);
    long *ids = NULL;
    prod_particles p;
    memset(&p, 0, sizeof p);
    if (!r->times) {
        free(tt);
        return sph_err_set(err, SPH_ERR_NOMEM, "out of memory");
    }
    for (int k = 0; k < nt; k++) {
        if ((rc = products_read_particles(r->particles_path, tt[k], &p, err)))
            goto fail;
        if (k == 0) {
            r->n_particles0 = (long)p.n;
            ids = malloc((p.n ? p.n : 1) * sizeof *ids);
            if (!ids) {
                rc = sph_err_set(err, SPH_ERR_NOMEM, "out of memory");
                goto fail;
            }
            for (size_t i = 0; i < p.n; i++)
                if (p.thick[i] > DEMO_PATCH_THICK)
                    ids[r->n_patch++] = p.id[i];
            qsort(ids, (size_t)r->n_patch, sizeof *ids, demo_cmp_long);
            if (r->n_patch == 0) {
                rc = sph_err_set(err, SPH_ERR_BAD_DATA, "%s: no particle thicker than %g m at the first time",
                                 r->particles_path, DEMO_PATCH_THICK);
                goto fail;
            }
        }
        demo_time *d = &r->times[k];
        d->t = tt[k];
        d->hours = (tt[k] - tt[0]) / 3600.0;
        double msum = 0, area = 0, foot = 0, vol = 0, csum = 0, xs = 0, ys = 0, zs = 0, us = 0, vs = 0;
        for (size_t i = 0; i < p.n; i++) {
            if (!bsearch(&p.id[i], ids, (size_t)r->n_patch, sizeof *ids, demo_cmp_long))
                continue;
            double m = p.mass[i], h = p.thick[i];
            if (!(m > 0) || !(h > 0))
                continue;
            d->n++;
            msum += m;
            area += m / (rho_i * h);
            foot += p.conc[i] > 0 ? m / (rho_i * p.conc[i] * h) : 0.0;
            vol += m / rho_i;
            csum += p.conc[i];
            /* centre on the sphere (unit vectors), robust and exact enough */
            double la = p.lat[i] * M_PI / 180, lo = p.lon[i] * M_PI / 180;
            xs += m * cos(la) * cos(lo);
            ys += m * cos(la) * sin(lo);
            zs += m * sin(la);
            us += m * p.u_east[i];
            vs += m * p.v_north[i];
        }
        if (d->n > 0) {
            d->area_km2 = area / 1e6;
            d->footprint_km2 = foot / 1e6;
            d->mean_thick = vol / area;
            d->mean_conc = csum / (double)d->n;
            d->lon_c = atan2(ys, xs) * 180 / M_PI;
            d->lat_c = atan2(zs, hypot(xs, ys)) * 180 / M_PI;
            d->u_c = us / msum;
            d->v_c = vs / msum;
            double var = 0, r2 = 0;
            const double km = 6371.0 * M_PI / 180, cl = cos(d->lat_c * M_PI / 180);
            for (size_t i = 0; i < p.n; i++) {
                if (!bsearch(&p.id[i], ids, (size_t)r->n_patch, sizeof *ids, demo_cmp_long) ||
                    !(p.mass[i] > 0) || !(p.thick[i] > 0))
                    continue;
                double du = p.u_east[i] - d->u_c, dv = p.v_north[i] - d->v_c;
                var += p.mass[i] * (du * du + dv * dv);
                double ex = (p.lon[i] - d->lon_c) * cl * km, ny = (p.lat[i] - d->lat_c) * km;
                r2 += p.mass[i] * (ex * ex + ny * ny);
            }
            d->vel_spread = sqrt(var / msum);
            d->radius_km = sqrt(r2 / msum);
        } else {
            d->area_km2 = d->footprint_km2 = d->mean_thick = d->mean_conc = d->lon_c = d->lat_c = NAN;
            d->u_c = d->v_c = d->vel_spread = d->radius_km = NAN;
        }
        prod_particles_free(&p);
        memset(&p, 0, sizeof p);
    }
    r->ntimes = nt;
    free(tt);
    free(ids);
    tt = NULL;
    ids = NULL;
    demo_time *a = &r->times[0], *b = &r->times[nt - 1];
    demo_bearing(a->lon_c, a->lat_c, b->lon_c, b->lat_c, &r->drift_km, &r->drift_bearing_deg);
    double ssum = 0;
    int sn = 0;
    for (int k = 0; k < nt; k++)
        if (isfinite(r->times[k].vel_spread)) {
            ssum += r->times[k].vel_spread;
            sn++;
        }
    r->reversals = demo_reversals_within(r, INFINITY);
    r->vel_spread_mean = sn ? ssum / sn : NAN;
    if (r->fields_path[0])
        r->budget_residual = demo_attr_double(r->fields_path, "sphice_mass_budget_residual");
    if (r->cycle_json[0])
        r->budget_residual_cycle_json = demo_cycle_json_residual(r->cycle_json);
    if (!isfinite(r->budget_residual))
        r->budget_residual = r->budget_residual_cycle_json;
    return SPH_OK;
fail:
    prod_particles_free(&p);
    free(tt);
    free(ids);
    demo_run_free(r);
    return rc;
}

/* The output time nearest to `hours` after the first (NULL if none within 0.5 h). */
static inline const demo_time *demo_at_hours(const demo_run *r, double hours)
{
    for (int k = 0; k < r->ntimes; k++)
        if (fabs(r->times[k].hours - hours) < 0.5)
            return &r->times[k];
    return NULL;
}

#endif
