/* Ice-edge and concentration scores (see io/verify.h for definitions). */
#include "io/verify.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "util/fileio.h"
#include "util/timeutil.h"

/* IIEE of a against b (binary at threshold), km^2; O and U returned too. */
static void iiee(const prod_grid *g, const double *a, const double *b, const unsigned char *land,
                 double thr, double *over, double *under)
{
    double o = 0, u = 0;
    for (int j = 0; j < g->nlat; j++) {
        double area = prod_grid_cell_area_m2(g, j) * 1e-6;
        for (int i = 0; i < g->nlon; i++) {
            size_t k = (size_t)j * g->nlon + i;
            if ((land && land[k]) || isnan(a[k]) || isnan(b[k]))
                continue;
            int ca = a[k] >= thr, cb = b[k] >= thr;
            if (ca > cb)
                o += area;
            else if (cb > ca)
                u += area;
        }
    }
    *over = o;
    *under = u;
}

int verify_compute(const prod_grid *g, const double *fc, const double *obs,
                   const double *persistence, const unsigned char *land, double threshold,
                   verify_scores *s, sph_error *err)
{
    memset(s, 0, sizeof *s);
    if (prod_grid_check(g, err) != SPH_OK)
        return err ? err->code : SPH_ERR_PARAM;
    if (!fc || !obs)
        return sph_err_set(err, SPH_ERR_PARAM, "verification: missing forecast or observation");
    s->threshold = threshold;
    iiee(g, fc, obs, land, threshold, &s->over_km2, &s->under_km2);
    s->iiee_km2 = s->over_km2 + s->under_km2;
    s->aee_km2 = fabs(s->over_km2 - s->under_km2);
    s->me_km2 = 2 * fmin(s->over_km2, s->under_km2);

    double sum = 0, sum2 = 0;
    long n = 0;
    size_t nn = (size_t)g->nlon * g->nlat;
    for (size_t k = 0; k < nn; k++) {
        if ((land && land[k]) || isnan(fc[k]) || isnan(obs[k]))
            continue;
        double d = fc[k] - obs[k];
        sum += d;
        sum2 += d * d;
        n++;
    }
    s->ncells = n;
    s->conc_bias = n ? sum / n : NAN;
    s->conc_rmse = n ? sqrt(sum2 / n) : NAN;

    edge_set ef, eo;
    int rc = edge_extract(g, fc, land, threshold, &ef, err);
    if (rc != SPH_OK)
        return rc;
    rc = edge_extract(g, obs, land, threshold, &eo, err);
    if (rc != SPH_OK) {
        edge_set_free(&ef);
        return rc;
    }
    s->edge_length_fc_km = edge_length_km(&ef);
    s->edge_length_obs_km = edge_length_km(&eo);
    edge_set_free(&ef);
    edge_set_free(&eo);
    s->displacement_km = s->edge_length_obs_km > 0 ? s->iiee_km2 / s->edge_length_obs_km : NAN;

    s->iiee_persistence_km2 = NAN;
    s->skill_persistence = NAN;
    if (persistence) {
        double po, pu;
        iiee(g, persistence, obs, land, threshold, &po, &pu);
        s->iiee_persistence_km2 = po + pu;
        if (po + pu > 0)
            s->skill_persistence = 1 - s->iiee_km2 / (po + pu);
    }
    return SPH_OK;
}

static void add_num(cJSON *o, const char *name, double v)
{
    if (isfinite(v))
        cJSON_AddNumberToObject(o, name, v);
    else
        cJSON_AddNullToObject(o, name);
}

int verify_write_json(const char *path, const verify_scores *s, const char *extra_name,
                      const char *extra_value, sph_error *err)
{
    cJSON *o = cJSON_CreateObject();
    if (!o)
        return sph_err_set(err, SPH_ERR_NOMEM, "write %s: out of memory", path);
    char iso[32];
    time_format_iso(s->valid_time, iso, sizeof iso);
    cJSON_AddStringToObject(o, "valid_time", iso);
    if (extra_name && extra_value)
        cJSON_AddStringToObject(o, extra_name, extra_value);
    add_num(o, "threshold", s->threshold);
    add_num(o, "overestimate_km2", s->over_km2);
    add_num(o, "underestimate_km2", s->under_km2);
    add_num(o, "iiee_km2", s->iiee_km2);
    add_num(o, "absolute_extent_error_km2", s->aee_km2);
    add_num(o, "misplacement_error_km2", s->me_km2);
    add_num(o, "edge_length_forecast_km", s->edge_length_fc_km);
    add_num(o, "edge_length_observed_km", s->edge_length_obs_km);
    add_num(o, "edge_displacement_km", s->displacement_km);
    add_num(o, "concentration_bias", s->conc_bias);
    add_num(o, "concentration_rmse", s->conc_rmse);
    add_num(o, "cells_compared", (double)s->ncells);
    add_num(o, "iiee_persistence_km2", s->iiee_persistence_km2);
    add_num(o, "skill_vs_persistence", s->skill_persistence);
    char *text = cJSON_Print(o);
    cJSON_Delete(o);
    if (!text)
        return sph_err_set(err, SPH_ERR_NOMEM, "write %s: out of memory", path);
    size_t len = strlen(text);
    int rc = atomic_write_file(path, text, len, err);
    free(text);
    return rc;
}
