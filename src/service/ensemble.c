/* Ensembles: see service/ensemble.h and docs/ensemble.md. */
#include "service/ensemble.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "io/ensemble.h"
#include "service/config.h"
#include "service/cycle.h"
#include "forecast_impl.h"
#include "util/log.h"

int fc_member_init(fc_member *m, const struct sph_config *cfg, int index, sph_error *err)
{
    memset(m, 0, sizeof *m);
    m->index = index;
    m->seed = (unsigned long long)cfg->ensemble.seed;
    m->p0_factor = m->ca_factor = m->cw_factor = 1.0;
    if (index == 0)
        return SPH_OK; /* the control */
    const int M = cfg->ensemble.modes;
    const double H = 3600.0, KM = 1000.0;
    struct { sph_rfield *f; double sigma, length_km, time_h; int stream; } fl[6] = {
        {&m->wind_u, cfg->ensemble.wind.sigma, cfg->ensemble.wind.length_km, cfg->ensemble.wind.time_hours,
         ENS_S_WIND_U},
        {&m->wind_v, cfg->ensemble.wind.sigma, cfg->ensemble.wind.length_km, cfg->ensemble.wind.time_hours,
         ENS_S_WIND_V},
        {&m->cur_u, cfg->ensemble.current.sigma, cfg->ensemble.current.length_km,
         cfg->ensemble.current.time_hours, ENS_S_CUR_U},
        {&m->cur_v, cfg->ensemble.current.sigma, cfg->ensemble.current.length_km,
         cfg->ensemble.current.time_hours, ENS_S_CUR_V},
        {&m->conc, cfg->ensemble.initial.conc_sigma, cfg->ensemble.initial.length_km, 0.0, ENS_S_CONC},
        {&m->thick, cfg->ensemble.initial.thick_sigma, cfg->ensemble.initial.length_km, 0.0, ENS_S_THICK},
    };
    for (int i = 0; i < 6; i++)
        if (sph_rfield_init(fl[i].f, M, fl[i].sigma, fl[i].length_km * KM, fl[i].time_h * H,
                            sph_perturb_seed(m->seed, index, fl[i].stream))) {
            fc_member_free(m);
            return sph_err_set(err, SPH_ERR_NOMEM, "ensemble: member %d: out of memory", index);
        }
    m->thick_sigma = cfg->ensemble.initial.thick_sigma;
    double g;
    if (cfg->ensemble.strength_sigma > 0) {
        if (sph_perturb_normal(m->seed, index, ENS_S_STRENGTH, &g))
            return sph_err_set(err, SPH_ERR_NOMEM, "ensemble: member %d: out of memory", index);
        m->p0_factor = exp(cfg->ensemble.strength_sigma * g);
    }
    if (cfg->ensemble.drag_sigma > 0) {
        if (sph_perturb_normal(m->seed, index, ENS_S_CA, &g))
            return sph_err_set(err, SPH_ERR_NOMEM, "ensemble: member %d: out of memory", index);
        m->ca_factor = exp(cfg->ensemble.drag_sigma * g);
        if (sph_perturb_normal(m->seed, index, ENS_S_CW, &g))
            return sph_err_set(err, SPH_ERR_NOMEM, "ensemble: member %d: out of memory", index);
        m->cw_factor = exp(cfg->ensemble.drag_sigma * g);
    }
    return SPH_OK;
}

void fc_member_free(fc_member *m)
{
    if (!m)
        return;
    sph_rfield *f[6] = {&m->wind_u, &m->wind_v, &m->cur_u, &m->cur_v, &m->conc, &m->thick};
    for (int i = 0; i < 6; i++)
        sph_rfield_free(f[i]);
}

void fc_member_perturb_params(const fc_member *m, sph_params *p)
{
    p->P0 *= m->p0_factor;
    p->Ca *= m->ca_factor;
    p->Cw *= m->cw_factor;
}

void fc_member_perturb_forcing(const fc_member *m, sph_particles *P, double t)
{
    if (m->wind_u.nmodes == 0 && m->cur_u.nmodes == 0)
        return;
    const long n = (long)P->n;
#pragma omp parallel for schedule(static)
    for (long k = 0; k < n; k++) {
        double x = P->x[k], y = P->y[k];
        P->ua[k] += sph_rfield_eval(&m->wind_u, x, y, t);
        P->va[k] += sph_rfield_eval(&m->wind_v, x, y, t);
        P->uw[k] += sph_rfield_eval(&m->cur_u, x, y, t);
        P->vw[k] += sph_rfield_eval(&m->cur_v, x, y, t);
    }
}

void fc_member_perturb_initial(const fc_member *m, sph_particles *P)
{
    if (m->conc.nmodes == 0 && m->thick.nmodes == 0)
        return;
    const double lim = 3.0 * m->thick_sigma;
    for (size_t k = 0; k < P->n; k++) {
        double A = P->conc[k], h = P->thick[k];
        double An = A + sph_rfield_eval(&m->conc, P->x[k], P->y[k], 0.0);
        An = An < 0.01 ? 0.01 : An > 1.0 ? 1.0 : An;
        double fh = sph_rfield_eval(&m->thick, P->x[k], P->y[k], 0.0);
        fh = fh < -lim ? -lim : fh > lim ? lim : fh;
        double hn = h * (1.0 + fh);
        P->mass[k] *= (An * hn) / (A * h);
        P->conc[k] = An;
        P->thick[k] = hn;
    }
}

const struct sph_config *fc_member_config(const struct sph_config *cfg, struct sph_config *lite)
{
    if (cfg->ensemble.member_products)
        return cfg;
    *lite = *cfg; /* shallow: read only, its strings stay cfg's */
    lite->output.products.maps = 0;
    lite->loads.model = PROD_LOADS_CHEAP; /* the station DEM runs for the control only (its products are the cycle's) */
    return lite;
}

/* ---- the ensemble engine ---- */

/* Progress of the whole ensemble from a member's. */
static void relay(forecast_progress *to, const forecast_progress *from, int member, int n)
{
    to->phase = from->phase == FC_PHASE_DONE && member < n - 1 ? FC_PHASE_RUNNING : from->phase;
    to->model_time = from->model_time;
    to->percent = (100.0 * member + from->percent) / n;
    to->particles = from->particles;
    to->frac_free_drift = from->frac_free_drift;
    to->frac_rheology = from->frac_rheology;
    to->frac_zero_layer = from->frac_zero_layer;
    to->frac_multi_layer = from->frac_multi_layer;
    to->dt = from->dt;
    to->dt_auto = from->dt_auto;
}

int ensemble_run(const struct sph_config *cfg, const forecast_request *req, forecast_progress *prog,
                 const volatile sig_atomic_t *cancel, forecast_result *res, sph_error *err)
{
    const int n = cfg->ensemble.members;
    if (n <= 1)
        return forecast_run(cfg, req, prog, cancel, res, err);
    forecast_progress local_prog = {0};
    if (!prog)
        prog = &local_prog;
    forecast_result local_res;
    if (!res)
        res = &local_res;
    char (*dirs)[4400] = calloc((size_t)n, sizeof *dirs);
    char (*fields)[4500] = calloc((size_t)n, sizeof *fields);
    const char **fp = calloc((size_t)n, sizeof *fp);
    forecast_result *mres = malloc(sizeof *mres);
    double *obs = NULL;
    void **handles = calloc((size_t)n, sizeof *handles);
    int nremote = 0, rc = SPH_OK;
    char members_dir[4300];
    snprintf(members_dir, sizeof members_dir, "%s/members", req->stage_dir);
    if (!dirs || !fields || !fp || !mres || !handles) {
        rc = sph_err_set(err, SPH_ERR_NOMEM, "ensemble: out of memory");
        goto done;
    }
    if (mkdir(members_dir, 0755) != 0 && errno != EEXIST) {
        rc = sph_err_set(err, SPH_ERR_IO, "ensemble: %s: %s", members_dir, strerror(errno));
        goto done;
    }
    double wall = 0;
    const int size = ens_mpi_size();
    for (int m = 0; m < n; m++) {
        fc_member mem;
        if ((rc = fc_member_init(&mem, cfg, m, err)))
            goto done;
        forecast_request r = *req;
        r.member = m ? &mem : NULL;
        if (m == 0)
            snprintf(dirs[m], sizeof dirs[m], "%s", req->stage_dir);
        else {
            snprintf(dirs[m], sizeof dirs[m], "%s/m%03d", members_dir, m);
            if (mkdir(dirs[m], 0755) != 0 && errno != EEXIST) {
                fc_member_free(&mem);
                rc = sph_err_set(err, SPH_ERR_IO, "ensemble: %s: %s", dirs[m], strerror(errno));
                goto done;
            }
            r.stage_dir = dirs[m];
            r.observation = NULL; /* the members' own scores are not needed: the ensemble's are */
        }
        if (size > 1 && m % size != 0) { /* another rank's member */
            fc_member_free(&mem);
            if ((rc = ens_mpi_dispatch(&r, m, dirs[m], &handles[nremote], err)))
                goto done;
            nremote++;
            snprintf(fields[m], sizeof fields[m], "%s/sphice_fields.nc", dirs[m]);
            fp[m] = fields[m];
            continue;
        }
        forecast_progress mp = {0};
        forecast_result *out = m ? mres : res;
        sph_error me;
        sph_error_clear(&me);
        struct sph_config lite;
        rc = forecast_run(m ? fc_member_config(cfg, &lite) : cfg, &r, &mp, cancel, out, &me);
        relay(prog, &mp, m, n);
        fc_member_free(&mem);
        if (rc) {
            if (m)
                rc = sph_err_set(err, rc, "ensemble member %d: %s", m, me.msg);
            else
                rc = sph_err_set(err, rc, "%s", me.msg);
            goto done;
        }
        wall += out->wall_seconds;
        snprintf(fields[m], sizeof fields[m], "%s/sphice_fields.nc", dirs[m]);
        fp[m] = fields[m];
        log_info("ensemble: member %d of %d done (%.1f s)", m, n, out->wall_seconds);
    }
    if (nremote) {
        int crc = ens_mpi_collect(handles, nremote, &wall, err);
        nremote = 0;
        if ((rc = crc))
            goto done;
    }
    ens_options o = {0};
    o.stage = req->stage_dir;
    o.prefix = "sphice";
    o.member_fields = fp;
    o.nmembers = n;
    o.threshold = cfg->output.edge_threshold;
    o.levels = cfg->ensemble.levels.v;
    o.nlevels = (int)cfg->ensemble.levels.n;
    o.seed = (unsigned long long)cfg->ensemble.seed;
    o.cycle_time = req->cycle_time;
    if (req->observation && cfg->output.products.verification) {
        prod_grid g;
        if ((rc = ens_fields_grid(fp[0], &g, err)) ||
            (rc = fc_read_observation(cfg, req->observation, &g, req->cycle_time + 3600.0 *
                                      (req->hours > 0 ? req->hours : cfg->schedule.forecast_hours),
                                      &obs, &o.t_obs, err)))
            goto done;
        o.obs = obs;
    }
    ens_summary s;
    if ((rc = ens_products_write(&o, &s, err)))
        goto done;
    res->ensemble.members = n;
    res->ensemble.seed = o.seed;
    res->ensemble.has_scores = s.has_scores;
    res->ensemble.sps_km2 = s.sps_km2;
    res->ensemble.iiee_median_km2 = s.iiee_median_km2;
    res->ensemble.mean_spread_conc = s.mean_spread_conc;
    res->wall_seconds = wall;
    for (int k = 0; k < s.nproducts && res->nproducts < FC_MAX_PRODUCTS; k++)
        snprintf(res->products[res->nproducts++], sizeof res->products[0], "%s", s.products[k]);
    const char *names[3] = {s.products[0], s.products[1], NULL};
    if ((rc = products_manifest_add(req->stage_dir, names, err)))
        goto done;
    log_info("ensemble: %d members, mean concentration spread %.4f%s", n, s.mean_spread_conc,
             s.has_scores ? "" : ", no observation scored");
done:
    if (nremote) { /* a local failure: the remote members still answer */
        sph_error ignored;
        sph_error_clear(&ignored);
        double w = 0;
        ens_mpi_collect(handles, nremote, &w, &ignored);
    }
    free(handles);
    if (!cfg->ensemble.member_products)
        cycle_remove_tree(members_dir);
    free(dirs);
    free(fields);
    free(fp);
    free(mres);
    free(obs);
    return rc;
}
