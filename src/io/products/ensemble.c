/* Ensemble products: see io/ensemble.h. */
#include "io/ensemble.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "io/edge.h"
#include "io/ncfile.h"
#include "products_impl.h"
#include "io/verify.h"
#include "util/fileio.h"
#include "util/timeutil.h"

#define FILL_F 1.0e20f

double ens_sps_km2(int nlon, int nlat, double lat0, double dlon, double dlat, const double *prob,
                   const double *obs, const unsigned char *land, double thr)
{
    prod_grid g = {nlon, nlat, 0.0, lat0, dlon, dlat};
    double sum = 0.0;
    for (int j = 0; j < nlat; j++) {
        double a = prod_grid_cell_area_m2(&g, j) * 1e-6;
        for (int i = 0; i < nlon; i++) {
            size_t k = (size_t)j * nlon + i;
            if ((land && land[k]) || !isfinite(obs[k]) || !isfinite(prob[k]))
                continue;
            double o = obs[k] >= thr ? 1.0 : 0.0, d = prob[k] - o;
            sum += d * d * a;
        }
    }
    return sum;
}

/* One member's file, opened and checked against the first. */
typedef struct member_file {
    int nc, v_conc, v_vol;
    size_t nt, nlat, nlon;
} member_file;

static int nc_fail(int st, const char *what, const char *path, sph_error *err)
{
    return sph_err_set(err, SPH_ERR_IO, "ensemble: %s %s: %s", what, path, nc_strerror(st));
}

static int open_member(const char *path, member_file *f, sph_error *err)
{
    int st, d;
    f->nc = -1;
    if ((st = nc_open(path, NC_NOWRITE, &f->nc)))
        return nc_fail(st, "open", path, err);
    const char *dn[3] = {"time", "lat", "lon"};
    size_t *len[3] = {&f->nt, &f->nlat, &f->nlon};
    for (int i = 0; i < 3; i++)
        if ((st = nc_inq_dimid(f->nc, dn[i], &d)) || (st = nc_inq_dimlen(f->nc, d, len[i])))
            return nc_fail(st, dn[i], path, err);
    if ((st = nc_inq_varid(f->nc, "siconc", &f->v_conc)) || (st = nc_inq_varid(f->nc, "sivol", &f->v_vol)))
        return sph_err_set(err, SPH_ERR_MISSING_VAR,
                           "ensemble: member fields file %s has no siconc/sivol (output.products.fields must "
                           "be on for an ensemble)",
                           path);
    return SPH_OK;
}

static int read_coord(int nc, const char *name, size_t n, double *v, const char *path, sph_error *err);

int ens_fields_grid(const char *path, prod_grid *g, sph_error *err)
{
    member_file f;
    int rc = open_member(path, &f, err);
    double *lat = NULL, *lon = NULL;
    if (!rc) {
        lat = malloc(f.nlat * sizeof *lat);
        lon = malloc(f.nlon * sizeof *lon);
        if (!lat || !lon)
            rc = sph_err_set(err, SPH_ERR_NOMEM, "ensemble: out of memory");
    }
    if (!rc && !(rc = read_coord(f.nc, "lat", f.nlat, lat, path, err)) &&
        !(rc = read_coord(f.nc, "lon", f.nlon, lon, path, err))) {
        g->nlon = (int)f.nlon;
        g->nlat = (int)f.nlat;
        g->lon0 = lon[0];
        g->lat0 = lat[0];
        g->dlon = f.nlon > 1 ? lon[1] - lon[0] : 1.0;
        g->dlat = f.nlat > 1 ? lat[1] - lat[0] : 1.0;
    }
    ncfile_close(&f.nc);
    free(lat);
    free(lon);
    return rc;
}

static int read_coord(int nc, const char *name, size_t n, double *v, const char *path, sph_error *err)
{
    int id, st;
    if ((st = nc_inq_varid(nc, name, &id)) || (st = nc_get_var_double(nc, id, v)))
        return nc_fail(st, name, path, err);
    (void)n;
    return SPH_OK;
}

/* Welford accumulators per (time, cell). */
typedef struct acc {
    double *mc, *m2c, *mv, *m2v; /* mean and sum of squared deviations */
    int *count;                  /* members with conc >= threshold */
    unsigned char *bad;          /* a member had fill here */
} acc;

static void put_att_text(int nc, int v, const char *name, const char *text, int *st)
{
    if (*st == NC_NOERR)
        *st = nc_put_att_text(nc, v, name, strlen(text), text);
}

static int def_field(int nc, const int *dims, const char *name, const char *std, const char *long_name,
                     const char *units, const char *cell_methods, int *v)
{
    int st = nc_def_var(nc, name, NC_FLOAT, 3, dims, v);
    float fill = FILL_F;
    if (st == NC_NOERR)
        st = nc_put_att_float(nc, *v, "_FillValue", NC_FLOAT, 1, &fill);
    if (std)
        put_att_text(nc, *v, "standard_name", std, &st);
    put_att_text(nc, *v, "long_name", long_name, &st);
    put_att_text(nc, *v, "units", units, &st);
    if (cell_methods)
        put_att_text(nc, *v, "cell_methods", cell_methods, &st);
    put_att_text(nc, *v, "coordinates", "forecast_period forecast_reference_time", &st);
    return st;
}

static int write_nc(const ens_options *o, const char *path, const prod_grid *g, size_t nt, size_t nlat,
                    size_t nlon, const double *time, const double *lat, const double *lon, const acc *a, int n,
                    sph_error *err)
{
    char tmp[4200];
    atomic_tmp_name(path, tmp, sizeof tmp);
    unlink(tmp);
    int nc = -1, st = nc_create(tmp, NC_NETCDF4 | NC_CLOBBER, &nc);
    if (st)
        return nc_fail(st, "create", tmp, err);
    int dt = -1, dy = -1, dx = -1, db = -1, vt = -1, vy = -1, vx = -1, vyb = -1, vxb = -1, vref = -1, vper = -1;
    int vf[5] = {-1, -1, -1, -1, -1};
    if (!st) st = nc_def_dim(nc, "time", nt, &dt);
    if (!st) st = nc_def_dim(nc, "lat", nlat, &dy);
    if (!st) st = nc_def_dim(nc, "lon", nlon, &dx);
    if (!st) st = nc_def_dim(nc, "bnds", 2, &db);
    if (!st) st = nc_def_var(nc, "time", NC_DOUBLE, 1, &dt, &vt);
    put_att_text(nc, vt, "standard_name", "time", &st);
    put_att_text(nc, vt, "units", "seconds since 1970-01-01 00:00:00", &st);
    put_att_text(nc, vt, "calendar", "standard", &st);
    put_att_text(nc, vt, "axis", "T", &st);
    if (!st) st = nc_def_var(nc, "forecast_reference_time", NC_DOUBLE, 0, NULL, &vref);
    put_att_text(nc, vref, "standard_name", "forecast_reference_time", &st);
    put_att_text(nc, vref, "units", "seconds since 1970-01-01 00:00:00", &st);
    put_att_text(nc, vref, "calendar", "standard", &st);
    if (!st) st = prod_def_forecast_period(nc, dt, &vper);
    if (!st) st = prod_def_lonlat_axes(nc, dy, dx, db, &vy, &vx, &vyb, &vxb);
    int dims[3] = {dt, dy, dx};
    char prob_ln[160];
    snprintf(prob_ln, sizeof prob_ln,
             "probability that the sea ice area fraction is at least %g (fraction of the members)", o->threshold);
    if (!st) st = def_field(nc, dims, "siconc_mean", "sea_ice_area_fraction", "ensemble mean sea ice area fraction",
                            "1", "area: mean where sea time: point realization: mean", &vf[0]);
    if (!st) st = def_field(nc, dims, "siconc_spread", NULL,
                            "ensemble standard deviation of the sea ice area fraction (divisor N)", "1",
                            "area: mean where sea time: point realization: standard_deviation", &vf[1]);
    if (!st) st = def_field(nc, dims, "sivol_mean", "sea_ice_thickness",
                            "ensemble mean sea ice volume per unit cell area", "m",
                            "area: mean where sea time: point realization: mean", &vf[2]);
    if (!st) st = def_field(nc, dims, "sivol_spread", NULL,
                            "ensemble standard deviation of the sea ice volume per unit cell area (divisor N)",
                            "m", "area: mean where sea time: point realization: standard_deviation", &vf[3]);
    if (!st) st = def_field(nc, dims, "siconc_prob", NULL, prob_ln, "1", NULL, &vf[4]);
    put_att_text(nc, NC_GLOBAL, "Conventions", "CF-1.8", &st);
    put_att_text(nc, NC_GLOBAL, "title", "sphice ensemble sea ice forecast", &st);
    put_att_text(nc, NC_GLOBAL, "source", "sphice ensemble (docs/ensemble.md)", &st);
    int members = n;
    if (!st) st = nc_put_att_int(nc, NC_GLOBAL, "ensemble_members", NC_INT, 1, &members);
    char seed[32];
    snprintf(seed, sizeof seed, "%llu", o->seed);
    put_att_text(nc, NC_GLOBAL, "ensemble_seed", seed, &st);
    if (!st) st = nc_put_att_double(nc, NC_GLOBAL, "sphice_edge_threshold", NC_DOUBLE, 1, &o->threshold);
    if (!st) st = nc_enddef(nc);
    if (!st) st = nc_put_var_double(nc, vt, time);
    if (!st) st = nc_put_var_double(nc, vref, &o->cycle_time);
    if (!st) st = nc_put_var_double(nc, vy, lat);
    if (!st) st = nc_put_var_double(nc, vx, lon);
    if (!st) st = prod_put_lonlat_bnds(nc, g, vyb, vxb);
    for (size_t t = 0; t < nt && !st; t++) {
        double lead_h = (time[t] - o->cycle_time) / 3600.0;
        st = nc_put_var1_double(nc, vper, &t, &lead_h);
    }
    size_t ncell = nlat * nlon, ntot = nt * ncell;
    float *buf = st ? NULL : malloc(ntot * sizeof *buf);
    if (!st && !buf) {
        ncfile_close(&nc);
        unlink(tmp);
        return sph_err_set(err, SPH_ERR_NOMEM, "ensemble: out of memory");
    }
    for (int f = 0; f < 5 && !st; f++) {
        for (size_t k = 0; k < ntot; k++) {
            double v;
            if (a->bad[k]) {
                buf[k] = FILL_F;
                continue;
            }
            switch (f) {
            case 0: v = a->mc[k]; break;
            case 1: v = sqrt(a->m2c[k] / n); break;
            case 2: v = a->mv[k]; break;
            case 3: v = sqrt(a->m2v[k] / n); break;
            default: v = (double)a->count[k] / n; break;
            }
            buf[k] = (float)v;
        }
        st = nc_put_var_float(nc, vf[f], buf);
    }
    free(buf);
    int cst = ncfile_close(&nc);
    if (!st)
        st = cst;
    if (st) {
        unlink(tmp);
        return nc_fail(st, "write", path, err);
    }
    return atomic_commit(tmp, path, err);
}

static int write_geojson(const ens_options *o, const char *path, const prod_grid *g, size_t nt,
                         const double *time, const acc *a, int n, const unsigned char *land, sph_error *err)
{
    size_t ncell = (size_t)g->nlat * g->nlon;
    double *prob = malloc(ncell * sizeof *prob);
    cJSON *root = cJSON_CreateObject();
    cJSON *feats = root ? cJSON_AddArrayToObject(root, "features") : NULL;
    if (!prob || !feats) {
        free(prob);
        cJSON_Delete(root);
        return sph_err_set(err, SPH_ERR_NOMEM, "ensemble: out of memory");
    }
    cJSON_AddStringToObject(root, "type", "FeatureCollection");
    int rc = SPH_OK;
    for (size_t t = 0; t < nt && rc == SPH_OK; t++) {
        for (size_t k = 0; k < ncell; k++)
            prob[k] = a->bad[t * ncell + k] ? NAN : (double)a->count[t * ncell + k] / n;
        for (int l = 0; l < o->nlevels && rc == SPH_OK; l++) {
            edge_set es = {0};
            if ((rc = edge_extract(g, prob, land, o->levels[l], &es, err)) != SPH_OK)
                break;
            cJSON *f = cJSON_CreateObject(), *props = cJSON_CreateObject(), *geom = cJSON_CreateObject();
            cJSON *lines = cJSON_CreateArray();
            char iso[32];
            time_format_iso(time[t], iso, sizeof iso);
            cJSON_AddStringToObject(f, "type", "Feature");
            cJSON_AddStringToObject(props, "valid_time", iso);
            cJSON_AddNumberToObject(props, "probability", o->levels[l]);
            cJSON_AddNumberToObject(props, "threshold", o->threshold);
            cJSON_AddNumberToObject(props, "members", n);
            cJSON_AddItemToObject(f, "properties", props);
            cJSON_AddStringToObject(geom, "type", "MultiLineString");
            for (size_t li = 0; li < es.nlines; li++) {
                cJSON *line = cJSON_CreateArray();
                for (size_t p = 0; p < es.lines[li].npts; p++) {
                    cJSON *pt = cJSON_CreateArray();
                    cJSON_AddItemToArray(pt, cJSON_CreateNumber(round(es.lines[li].lon[p] * 1e6) / 1e6));
                    cJSON_AddItemToArray(pt, cJSON_CreateNumber(round(es.lines[li].lat[p] * 1e6) / 1e6));
                    cJSON_AddItemToArray(line, pt);
                }
                cJSON_AddItemToArray(lines, line);
            }
            cJSON_AddItemToObject(geom, "coordinates", lines);
            cJSON_AddItemToObject(f, "geometry", geom);
            cJSON_AddItemToArray(feats, f);
            edge_set_free(&es);
        }
    }
    free(prob);
    char *text = rc == SPH_OK ? cJSON_PrintUnformatted(root) : NULL;
    cJSON_Delete(root);
    if (rc != SPH_OK)
        return rc;
    if (!text)
        return sph_err_set(err, SPH_ERR_NOMEM, "ensemble: out of memory");
    rc = atomic_write_file(path, text, strlen(text), err);
    free(text);
    return rc;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int ens_products_write(const ens_options *o, ens_summary *s, sph_error *err)
{
    memset(s, 0, sizeof *s);
    s->sps_km2 = s->iiee_median_km2 = s->score_time = NAN;
    if (o->nmembers < 1 || !o->member_fields)
        return sph_err_set(err, SPH_ERR_PARAM, "ensemble: no members");
    member_file f0;
    int rc = open_member(o->member_fields[0], &f0, err);
    if (rc) {
        ncfile_close(&f0.nc);
        return rc;
    }
    size_t nt = f0.nt, nlat = f0.nlat, nlon = f0.nlon, ncell = nlat * nlon, ntot = nt * ncell;
    int n = o->nmembers, st;
    double *time = malloc((nt ? nt : 1) * sizeof *time), *lat = malloc(nlat * sizeof *lat);
    double *lon = malloc(nlon * sizeof *lon), *tbuf = malloc((nt ? nt : 1) * sizeof *tbuf);
    double *c = malloc(ntot * sizeof *c), *v = malloc(ntot * sizeof *v);
    unsigned char *land = calloc(ncell, 1);
    acc a = {calloc(ntot, sizeof(double)), calloc(ntot, sizeof(double)), calloc(ntot, sizeof(double)),
             calloc(ntot, sizeof(double)), calloc(ntot, sizeof(int)), calloc(ntot, 1)};
    /* the median at the score time needs every member's concentration there */
    double *cm = o->obs ? malloc((size_t)n * ncell * sizeof *cm) : NULL;
    size_t t_score = 0;
    if (!time || !lat || !lon || !tbuf || !c || !v || !land || !a.mc || !a.m2c || !a.mv || !a.m2v || !a.count ||
        !a.bad || (o->obs && !cm)) {
        rc = sph_err_set(err, SPH_ERR_NOMEM, "ensemble: out of memory");
        goto done;
    }
    if ((rc = read_coord(f0.nc, "time", nt, time, o->member_fields[0], err)) ||
        (rc = read_coord(f0.nc, "lat", nlat, lat, o->member_fields[0], err)) ||
        (rc = read_coord(f0.nc, "lon", nlon, lon, o->member_fields[0], err)))
        goto done;
    int vl;
    if (nc_inq_varid(f0.nc, "landmask", &vl) == NC_NOERR && (st = nc_get_var_uchar(f0.nc, vl, land))) {
        rc = nc_fail(st, "landmask", o->member_fields[0], err);
        goto done;
    }
    if (o->obs) {
        for (size_t t = 1; t < nt; t++)
            if (fabs(time[t] - o->t_obs) < fabs(time[t_score] - o->t_obs))
                t_score = t;
    }
    for (int m = 0; m < n; m++) {
        member_file f = f0;
        if (m > 0) {
            if ((rc = open_member(o->member_fields[m], &f, err))) {
                ncfile_close(&f.nc);
                goto done;
            }
            if (f.nt != nt || f.nlat != nlat || f.nlon != nlon ||
                read_coord(f.nc, "time", nt, tbuf, o->member_fields[m], err) ||
                memcmp(tbuf, time, nt * sizeof *tbuf)) {
                ncfile_close(&f.nc);
                rc = sph_err_set(err, SPH_ERR_BAD_DATA,
                                 "ensemble: member %d's fields file %s has other times or another grid than the "
                                 "control's %s",
                                 m, o->member_fields[m], o->member_fields[0]);
                goto done;
            }
        }
        if (ntot && ((st = nc_get_var_double(f.nc, f.v_conc, c)) || (st = nc_get_var_double(f.nc, f.v_vol, v)))) {
            rc = nc_fail(st, "read", o->member_fields[m], err);
            ncfile_close(&f.nc);
            goto done;
        }
        ncfile_close(&f.nc);
        if (m == 0)
            f0.nc = -1;
        for (size_t k = 0; k < ntot; k++) {
            if (!(fabs(c[k]) < 1e19) || !(fabs(v[k]) < 1e19)) {
                a.bad[k] = 1;
                continue;
            }
            double dc = c[k] - a.mc[k], dv = v[k] - a.mv[k];
            a.mc[k] += dc / (m + 1);
            a.m2c[k] += dc * (c[k] - a.mc[k]);
            a.mv[k] += dv / (m + 1);
            a.m2v[k] += dv * (v[k] - a.mv[k]);
            a.count[k] += c[k] >= o->threshold;
        }
        if (cm)
            for (size_t k = 0; k < ncell; k++)
                cm[(size_t)m * ncell + k] = c[t_score * ncell + k];
    }
    prod_grid g = {(int)nlon, (int)nlat, lon[0], lat[0], nlon > 1 ? lon[1] - lon[0] : 1.0,
                   nlat > 1 ? lat[1] - lat[0] : 1.0};
    char path[4200];
    snprintf(s->products[0], sizeof s->products[0], "%s_ensemble.nc", o->prefix);
    snprintf(path, sizeof path, "%s/%s", o->stage, s->products[0]);
    if ((rc = write_nc(o, path, &g, nt, nlat, nlon, time, lat, lon, &a, n, err)))
        goto done;
    snprintf(s->products[1], sizeof s->products[1], "%s_ensemble_edge.geojson", o->prefix);
    snprintf(path, sizeof path, "%s/%s", o->stage, s->products[1]);
    if ((rc = write_geojson(o, path, &g, nt, time, &a, n, land, err)))
        goto done;
    s->nproducts = 2;
    s->ntimes = (int)nt;
    s->nlat = (int)nlat;
    s->nlon = (int)nlon;
    double ssum = 0;
    long cnt = 0;
    for (size_t k = 0; k < ntot; k++)
        if (!a.bad[k] && !land[k % ncell]) {
            ssum += sqrt(a.m2c[k] / n);
            cnt++;
        }
    s->mean_spread_conc = cnt ? ssum / cnt : 0.0;
    if (o->obs && nt > 0) {
        double *prob = c, *med = v; /* reuse: one time slice each */
        double *col = malloc((size_t)n * sizeof *col);
        if (!col) {
            rc = sph_err_set(err, SPH_ERR_NOMEM, "ensemble: out of memory");
            goto done;
        }
        for (size_t k = 0; k < ncell; k++) {
            size_t kt = t_score * ncell + k;
            prob[k] = a.bad[kt] ? NAN : (double)a.count[kt] / n;
            for (int m = 0; m < n; m++)
                col[m] = cm[(size_t)m * ncell + k];
            qsort(col, (size_t)n, sizeof *col, cmp_double);
            med[k] = a.bad[kt] ? NAN : (n % 2 ? col[n / 2] : 0.5 * (col[n / 2 - 1] + col[n / 2]));
        }
        free(col);
        s->sps_km2 = ens_sps_km2(g.nlon, g.nlat, g.lat0, g.dlon, g.dlat, prob, o->obs, land, o->threshold);
        verify_scores vs;
        if ((rc = verify_compute(&g, med, o->obs, NULL, land, o->threshold, &vs, err)))
            goto done;
        s->iiee_median_km2 = vs.iiee_km2;
        s->score_time = time[t_score];
        s->has_scores = 1;
    }
done:
    ncfile_close(&f0.nc);
    free(time);
    free(lat);
    free(lon);
    free(tbuf);
    free(c);
    free(v);
    free(land);
    free(a.mc);
    free(a.m2c);
    free(a.mv);
    free(a.m2v);
    free(a.count);
    free(a.bad);
    free(cm);
    return rc;
}
