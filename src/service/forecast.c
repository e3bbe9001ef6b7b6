/* The forecast engine (service/forecast.h): configuration -> projection,
 * land mask, forcing, initial particles -> model steps -> products and the
 * restart file of the next cycle. docs/engine.md describes every choice.
 *
 * Invariants:
 *  - nothing in the stage dir survives a failed or cancelled run (the
 *    product writer is aborted, a restart file already written is removed);
 *  - nothing depends on the wall clock or on uninitialised memory: a run
 *    is a function of the configuration, the request and the input files
 *    (for a fixed OpenMP thread count), so `run` and `hindcast` of one
 *    cycle write identical data variables.
 *
 * This file is the run itself: parameters, the step loop and its errors.
 * The engine's other rooms share forecast_impl.h: forecast_init.c (the
 * initial state), coupling.c (forcing -> particles, service/coupling.h)
 * and forecast_output.c (grid, products, restart file).
 */
#include "service/forecast.h"
#include "forecast_impl.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "service/config.h"
#include "service/cycle_phase.h"
#include "service/cycle_name.h"
#include "service/schedule.h"
#include "util/log.h"
#include "util/timeutil.h"

/* --------------------------------------------------------------- helpers */

/* "speed 12.3 exceeds the speed limit 10 (numerical blow-up)": the limit
 * goes before a parenthesised remark of the core's sentence for a bound the
 * value crossed, after it as "(limit L)" for a range, and nowhere else. */
static void fmt_status(const sph_status *st, char *buf, size_t len)
{
    const char *what = st->what && *st->what ? st->what : "failed";
    switch (st->kind) {
    case SPH_FAULT_SPEED:
    case SPH_FAULT_THICKNESS:
    case SPH_FAULT_SUBSTEPS: {
        if (st->limit == 0.0)
            break;
        const char *paren = strstr(what, " (");
        if (paren)
            snprintf(buf, len, "%s %.6g %.*s %.6g%s", st->quantity, st->value, (int)(paren - what), what,
                     st->limit, paren);
        else
            snprintf(buf, len, "%s %.6g %s %.6g", st->quantity, st->value, what, st->limit);
        return;
    }
    case SPH_FAULT_TIMESTEP:
    case SPH_FAULT_RANGE:
    case SPH_FAULT_PARAMETER:
        snprintf(buf, len, "%s %.6g %s (limit %.6g)", st->quantity, st->value, what, st->limit);
        return;
    default:
        break;
    }
    snprintf(buf, len, "%s %.6g %s", st->quantity, st->value, what);
}

static void engine_free(engine *e)
{
    fc_bgw_stop(e); /* before the writer it writes into */
    products_abort(e->pw);
    e->pw = NULL;
    fc_dd_end(e); /* parallel.decomposition "domain" (forecast_domain.c) */
    fc_free_ocean_fluxes(e);
    if (e->restart_written)
        unlink(e->restart_path);
    geo_proj_free(e->proj);
    landmask_free(e->lm);
    free(e->plane_land);
    coupling_free(&e->cpl);
    ice_raster_free(e->raster);
    sph_model_free(e->m);
    sph_particles_free(e->ocean_pts);
    double *arrays[] = {e->olon, e->olat, e->pue, e->pvn, e->gx, e->gy, e->g_conc,
                        e->g_hbar, e->g_thick, e->g_u, e->g_v, e->g_pres, e->g_div, e->g_shear,
                        e->g_dens, e->g_snow};
    for (size_t k = 0; k < sizeof arrays / sizeof arrays[0]; k++)
        free(arrays[k]);
    free(e->g_land);
}

/* ------------------------------------------------------------ parameters */

static int check_params(const struct sph_config *cfg, const sph_params *prm, sph_error *err)
{
    const char *name = "";
    double lo = 0, hi = 0;
    if (sph_params_check(prm, &name, &lo, &hi) != SPH_STEP_OK) {
        /* report the offending value: the row of the key it names */
        const sph_param *r = sph_param_find(name);
        double v = r ? sph_param_get(r, prm) : NAN;
        if (isfinite(v))
            return sph_err_set(err, SPH_ERR_PARAM, "model: parameter %s = %g outside [%g, %g]", name, v,
                               lo, hi);
        return sph_err_set(err, SPH_ERR_PARAM, "model: parameter %s outside [%g, %g]", name, lo, hi);
    }
    if (prm->free_drift_parcels && prm->physics != SPH_PHYSICS_FREE_DRIFT)
        return sph_err_set(err, SPH_ERR_PARAM,
                           "model: free_drift_parcels is true but model.physics is not free_drift "
                           "(parcels are a free-drift path; set model.physics \"free_drift\" or "
                           "model.free_drift_parcels false)");
    if (cfg->model.thermo_dt > 0 && cfg->model.thermo.model != SPH_THERMO_OFF &&
        sph_thermo_params_check(&cfg->model.thermo, &name, &lo, &hi) != SPH_STEP_OK)
        return sph_err_set(err, SPH_ERR_PARAM, "model.thermo: parameter %s outside [%g, %g]", name, lo,
                           hi);
    return SPH_OK;
}

/* Whole seconds shared by the thermodynamic step, the output interval and
 * the distance to the next cycle (its restart): the auto step divides it,
 * so none of them falls between two steps. 0 when none is whole. */
static double auto_dt_base(const engine *e, double t_next)
{
    const double iv[2] = {e->cfg->output.interval_hours * 3600.0, t_next - e->t0};
    return sph_params_dt_base(&e->cfg->model, iv, 2);
}

/* Auto time stepping: the step from the measured envelope at the placed
 * particles' spacing (the core's rule, sph_params_resolve_dt), before the
 * model's envelope check in sph_model_init / sph_model_resume. */
static int resolve_dt(engine *e, sph_error *err)
{
    if (!e->dt_auto)
        return SPH_OK;
    double spacing = sph_model_spacing(e->m);
    const char *why = "";
    double stable = sph_params_stable_dt(&e->prm, spacing, NULL);
    e->prm.dt = sph_params_resolve_dt(&e->prm, spacing, e->dt_base, &why);
    if (sph_model_set_params(e->m, &e->prm) != SPH_STEP_OK)
        return sph_err_set(err, SPH_ERR_PARAM, "model: auto time step %g s not accepted", e->prm.dt);
    if (isfinite(stable))
        log_info("forecast %s: auto time step %g s (spacing %.0f m, measured stable step %.0f s; set by %s)",
                 e->cname, e->prm.dt, spacing, stable, why);
    else
        log_info("forecast %s: auto time step %g s (spacing %.0f m, no stability bound; set by %s)", e->cname,
                 e->prm.dt, spacing, why);
    return SPH_OK;
}

/* Names a particle's problem: "particle 17 at 121.80E 40.61N". */
static void particle_where(const engine *e, long id, char *buf, size_t len)
{
    const fc_coupling *c = &e->cpl;
    for (size_t k = 0; k < c->n_before; k++)
        if (c->ids_before[k] == id) {
            char ll[64];
            coupling_format_lonlat(c->lon[k], c->lat[k], ll, sizeof ll);
            snprintf(buf, len, "particle %ld at %s", id, ll);
            return;
        }
    if (id >= 0)
        snprintf(buf, len, "particle %ld", id);
    else
        snprintf(buf, len, "all particles");
}

/* A refusal by the model that the configuration causes, not the input:
 * the step outside the measured stability envelope (no particle at fault).
 * A bad clock or particle count stays the file's fault. */
static int settings_fault(const sph_status *st)
{
    return st->particle < 0 && (st->kind == SPH_FAULT_TIMESTEP || st->kind == SPH_FAULT_SUBSTEPS);
}

/* For the other rooms of the engine (forecast_impl.h). */
int fc_resolve_dt(engine *e, sph_error *err) { return resolve_dt(e, err); }
void fc_fmt_status(const sph_status *st, char *buf, size_t len) { fmt_status(st, buf, len); }
int fc_settings_fault(const sph_status *st) { return settings_fault(st); }

/* ------------------------------------------------------------------- run */

static int step_error(engine *e, const sph_status *st, long step, double t, sph_error *err);
int fc_step_error(engine *e, const sph_status *st, long step, double t, sph_error *err)
{
    return step_error(e, st, step, t, err);
}

static int step_error(engine *e, const sph_status *st, long step, double t, sph_error *err)
{
    char when[32], where[128], what[256];
    iso(t, when, sizeof when);
    particle_where(e, st->particle, where, sizeof where);
    fmt_status(st, what, sizeof what);
    return sph_err_set(err, SPH_ERR_NUMERICS, "model step %ld (%s): %s: %s; nothing written", step, when,
                       where, what);
}

int forecast_run(const struct sph_config *cfg, const forecast_request *req, forecast_progress *prog,
                 const volatile sig_atomic_t *cancel, forecast_result *res, sph_error *err)
{
    double wall0 = time_monotonic();
    forecast_progress local_prog = {0};
    if (!prog)
        prog = &local_prog;
    forecast_result local_res;
    if (!res)
        res = &local_res;
    memset(res, 0, sizeof *res);
    res->edge_distance_nm = NAN;
    res->raster_ice_area_km2 = res->raster_ice_volume_km3 = NAN;
    res->seeded_ice_area_km2 = res->seeded_ice_volume_km3 = NAN;
    res->lattice_raw_area_km2 = res->lattice_raw_volume_km3 = NAN;
    engine eng;
    memset(&eng, 0, sizeof eng);
    engine *e = &eng;
    e->res = res;
    e->cfg = cfg;
    e->req = req;
    e->cancel = cancel;
    e->t0 = req->cycle_time;
    double hours = req->hours > 0 ? req->hours : cfg->schedule.forecast_hours;
    e->t_end = e->t0 + hours * 3600.0;
    cycle_name(e->t0, e->cname, sizeof e->cname);
    e->thermo_on = cfg->model.thermo_dt > 0 && cfg->model.thermo.model != SPH_THERMO_OFF;
    cycle_set_phase(prog, e->t0, FC_PHASE_INITIALISING, "forecast: inputs and particles");
    prog->model_time = e->t0;
    prog->percent = 0;
    int rc;
    prod_station *stations = NULL;
    sph_error e_local;
    sph_error_clear(&e_local);
    sph_error *er = &e_local;

    if (!req->stage_dir || !req->stage_dir[0]) {
        rc = sph_err_set(er, SPH_ERR_PARAM, "forecast: no stage directory");
        goto fail;
    }
    if ((rc = fc_dd_begin(e, er))) /* parallel.decomposition (forecast_domain.c) */
        goto fail;
    /* the model's parameters; model.dt = 0 is resolved once the particles
     * are placed (resolve_dt), checked meanwhile with a valid stand-in */
    e->prm = cfg->model;
    if (req->member)
        fc_member_perturb_params(req->member, &e->prm);
    e->prm.thermo.ocean_fluxes = cfg->output.ocean_fluxes; /* the accumulators (docs/ocean-coupling.md) */
    e->dt_auto = cfg->model.dt == 0.0; /* negative: refused by check_params */
    e->dt_base = auto_dt_base(e, schedule_next(cfg, e->t0));
    if (e->dt_auto)
        e->prm.dt = e->dt_base > 0.0 ? e->dt_base : 60.0;
    if ((rc = check_params(cfg, &e->prm, er)))
        goto fail;
    if (!(cfg->domain.lon_max > cfg->domain.lon_min) || !(cfg->domain.lat_max > cfg->domain.lat_min)) {
        rc = sph_err_set(er, SPH_ERR_CONFIG, "config: domain: lon_max/lat_max must exceed lon_min/lat_min");
        goto fail;
    }

    /* 1. projection and plane box */
    double lonc = 0.5 * (cfg->domain.lon_min + cfg->domain.lon_max);
    double latc = 0.5 * (cfg->domain.lat_min + cfg->domain.lat_max);
    e->proj = geo_proj_create(cfg->domain.projection, lonc, latc, er);
    if (!e->proj) {
        rc = er->code ? er->code : SPH_ERR_CONFIG;
        goto fail;
    }
    double xmin, xmax, ymin, ymax;
    if ((rc = fc_plane_box(e, &xmin, &xmax, &ymin, &ymax, er)))
        goto fail;
    if (cfg->domain.plane_tables != CFG_TABLES_FALSE) { /* 1 km nodes over the box and a margin of 2 km */
        char why[sizeof er->msg];
        if (cfg->domain.plane_tables == CFG_TABLES_AUTO) /* a polar or huge domain: PROJ, and say so */
            e->cpl.plane = geo_plane_table_auto(e->proj, xmin - 2e3, xmax + 2e3, ymin - 2e3, ymax + 2e3, 1e3,
                                                why, sizeof why, er);
        else
            e->cpl.plane = geo_plane_table_create(e->proj, xmin - 2e3, xmax + 2e3, ymin - 2e3, ymax + 2e3, 1e3, er);
        if (!e->cpl.plane && er->code) {
            rc = er->code;
            goto fail;
        }
        if (!e->cpl.plane)
            log_info("forecast %s: domain.plane_tables auto: PROJ per particle (%s)", e->cname, why);
    }

    /* 3. forcing (before anything heavier: a missing file fails fast) */
    if ((rc = coupling_open(&e->cpl, cfg, req, e->t0, e->t_end, e->cname, er)))
        goto fail;

    /* the raster is read first on a cold start: the mask cell size may depend on it;
     * on any start when the land mask takes the raster's own land */
    if (((!req->warm_start && (cfg->initial.spacing_deg <= 0 || cfg->initial.cell_particles > 0)) ||
         fc_raster_land(cfg)) && cfg->initial.path && cfg->initial.path[0] &&
        (rc = fc_read_raster(e, cfg->initial.path, cfg->initial.format, cfg->initial.conc_var, e->t0, &e->raster,
                          e->raster_path, sizeof e->raster_path, "initial field", er)))
        goto fail;

    /* 2. land mask, cell = half the initial spacing */
    if ((rc = fc_build_landmask(e, xmin, xmax, ymin, ymax, 0.5 * fc_spacing_m(e), er)))
        goto fail;

    /* 4-5. particles and model */
    if (e->dd == 2 && e->dd_rank > 0) /* rank 0 reads the initial field and seeds; fc_dd_setup scatters */
        rc = SPH_OK;
    else
        rc = req->warm_start ? fc_warm_start(e, er) : fc_cold_start(e, er);
    if (rc || (rc = fc_dd_agree(e, rc, er)) || (rc = fc_dd_setup(e, er)))
        goto fail;
    sph_particles *P = sph_model_particles(e->m);
    sph_run_stats_begin(&res->run, e->m, e->dt_auto);
    prog->particles = (long)P->n;

    /* products */
    if ((rc = fc_setup_grid(e, er)))
        goto fail;
    stations = calloc(cfg->nstations ? cfg->nstations : 1, sizeof *stations);
    if (!stations) {
        rc = sph_err_set(er, SPH_ERR_NOMEM, "forecast: out of memory");
        goto fail;
    }
    if ((rc = fc_open_products(e, stations, er)))
        goto fail;
    if (req->observation && cfg->output.products.verification && (rc = fc_set_observation(e, er)))
        goto fail;
    if (cfg->output.ocean_fluxes && (rc = fc_open_ocean_fluxes(e, er)))
        goto fail;
    if ((rc = fc_dd_agree(e, rc, er)))
        goto fail;
    if ((rc = fc_bgw_start(e, er))) /* output.writer_thread (forecast_writer.c) */
        goto fail;

    /* restart file for the next cycle */
    double t_next = schedule_next(cfg, e->t0);
    char rname[64];
    cycle_restart_name(t_next, rname, sizeof rname);
    snprintf(e->restart_path, sizeof e->restart_path, "%s/%s", req->stage_dir, rname);

    /* 6. time loop */
    /* without thermodynamics and mixed layer the steps' fills sample only
     * what the dynamics reads (service/coupling.h) */
    if (!e->thermo_on && !e->ocean_pts && !sph_model_ocean(e->m)) {
        coupling_set_dynamics_only(&e->cpl);
        /* and the particles' thermal forcing is read no more (the cold
         * start's profile has read it): its memory goes back */
        sph_model *ms[2] = {e->m, e->dd_m};
        for (int k = 0; k < 2; k++)
            if (ms[k] && sph_particles_release_thermal_forcing(sph_model_particles(ms[k])) != 0) {
                rc = sph_err_set(er, SPH_ERR_NOMEM, "forecast: out of memory (%zu particles)", e->cap);
                goto fail;
            }
    }
    const double dt = e->prm.dt;
    res->run.dt = dt;
    prog->dt = dt;
    prog->dt_auto = e->dt_auto;
    const long nsteps = (long)ceil(hours * 3600.0 / dt - 1e-9);
    const double out_dt = cfg->output.interval_hours * 3600.0;
    long restart_step = (long)ceil((t_next - e->t0) / dt - 1e-9);
    if (restart_step > nsteps || restart_step < 1)
        restart_step = nsteps;
    if (fabs(restart_step * dt - (t_next - e->t0)) > 1e-6 * dt && restart_step != nsteps)
        log_warn("forecast %s: the next cycle is not a whole number of steps away: restart written at +%g s",
                 e->cname, restart_step * dt);
    int nout = 0;
    double next_out = e->t0;
    cycle_set_phase(prog, e->t0, FC_PHASE_RUNNING, "forecast: time loop");
    if (e->dd && ((rc = fc_dd_sync(e, er)) || (rc = fc_dd_agree(e, rc, er))))
        goto fail;
    if ((rc = fc_write_output(e, e->t0, er)) || (rc = fc_dd_agree(e, rc, er)))
        goto fail;
    nout++;
    next_out = e->t0 + out_dt;
    for (long s = 0; s < nsteps; s++) {
        if (e->dd == 2) { /* decomposed over the ranks (forecast_domain.c) */
            if ((rc = fc_dd_step(e, s, e->t0 + s * dt, cancel, er)))
                goto fail;
        } else if (cancel && *cancel) {
            char when[32];
            iso(e->t0 + s * dt, when, sizeof when);
            rc = sph_err_set(er, SPH_ERR_CANCELLED, "forecast %s: cancelled at model time %s", e->cname, when);
            goto fail;
        }
        double t = e->t0 + s * dt;
        if (e->dd != 2 && s > 0 && (rc = fc_fill_forcing(e, t, er)))
            goto fail;
        fc_bgw_kick(e); /* the last output time's products, from the second fill after it (forecast_writer.c) */
        sph_status st;
        if (e->dd != 2 && sph_model_step(e->m, &st) != SPH_STEP_OK) {
            rc = step_error(e, &st, s + 1, t, er);
            goto fail;
        }
        double t1 = e->t0 + (s + 1) * dt;
        const sph_step_stats *ss = sph_model_stats(e->dd_m ? e->dd_m : e->m);
        if (e->dd != 2) /* fc_dd_step adds the decomposed step's */
            sph_run_stats_add(&res->run, e->m);
        prog->model_time = t1;
        prog->percent = 100.0 * (double)(s + 1) / (double)nsteps;
        prog->particles = (long)P->n;
        prog->frac_free_drift = ss->frac_free_drift;
        prog->frac_rheology = ss->frac_rheology;
        prog->frac_zero_layer = ss->frac_zero_layer;
        prog->frac_multi_layer = ss->frac_multi_layer;
        int last = s + 1 == nsteps;
        int out_now = t1 >= next_out - 1e-6 * dt || last;
        if (e->dd && (s + 1 == restart_step || out_now) && /* the particles in id order (on rank 0) */
            ((rc = fc_dd_sync(e, er)) || (rc = fc_dd_agree(e, rc, er))))
            goto fail;
        if (s + 1 == restart_step &&
            ((rc = fc_bgw_wait(e, er)) || (rc = fc_write_restart(e, t1, er)) || (rc = fc_dd_agree(e, rc, er))))
            goto fail;
        if (out_now) {
            if ((rc = fc_write_output(e, t1, er)) || (rc = fc_dd_agree(e, rc, er)))
                goto fail;
            nout++;
            while (next_out <= t1 + 1e-6 * dt)
                next_out += out_dt;
        }
    }
    if ((rc = fc_bgw_wait(e, er))) /* the last output time's products */
        goto fail;
    if (nsteps == 0 && ((rc = fc_write_restart(e, e->t0, er)) || (rc = fc_dd_agree(e, rc, er))))
        goto fail;
    if (e->dd == 2 && e->dd_rank > 0) { /* a worker of the decomposition: rank 0 closes and publishes */
        engine_free(e);
        free(stations);
        return SPH_OK;
    }
    if (e->dd == 2)
        e->dd_failed = 1; /* rank 0 alone from here: no further agreement */

    /* 7. close the products */
    cycle_set_phase(prog, e->t0, FC_PHASE_WRITING, "forecast: closing the products");
    const sph_budget *b = sph_model_budget(e->m);
    sph_run_stats_end(&res->run, e->m);
    sph_budget ddb;
    if (e->dd) { /* the exact budget of all particles, the same on any number of ranks */
        fc_dd_budget(e, &ddb);
        b = &ddb;
        res->run.budget_residual = sph_budget_residual(b);
        res->run.energy_residual = sph_budget_energy_residual(b); /* the mixed layer's, the stepped model's */
        res->run.water_residual = sph_budget_water_residual(b);
        res->run.salt_residual = sph_budget_salt_residual(b);
    }
    products_set_run_info(e->pw, &res->run);
    if ((rc = fc_land_gate(e, er)))
        goto fail;
    if (res->open_water && !res->quality_flag[0])
        snprintf(res->quality_flag, sizeof res->quality_flag, "open_water");
    prod_init_info ii = {res->raster_ice_area_km2, res->raster_ice_volume_km3, res->seeded_ice_area_km2,
                         res->seeded_ice_volume_km3, res->land_fraction, res->quality_flag};
    products_set_init_info(e->pw, &ii);
    if (e->ofx && (rc = fc_close_ocean_fluxes(e, er)))
        goto fail;
    prod_summary sum;
    rc = products_close(e->pw, &sum, er);
    e->pw = NULL;
    if (rc)
        goto fail;

    res->ice_area_km2 = sum.ice_area_km2;
    res->loads = sum.loads;
    res->ice_volume_km3 = sum.ice_volume_km3;
    res->ice_mass_kg = b->mass;
    res->edge_distance_nm = sum.edge_distance_nm;
    res->has_scores = sum.has_scores;
    if (sum.has_scores) {
        res->iiee_km2 = sum.scores.iiee_km2;
        res->aee_km2 = sum.scores.aee_km2;
        res->me_km2 = sum.scores.me_km2;
        res->edge_displacement_km = sum.scores.displacement_km;
        res->conc_bias = sum.scores.conc_bias;
        res->conc_rmse = sum.scores.conc_rmse;
        res->skill_persistence = sum.scores.skill_persistence;
    }
    snprintf(res->start_mode, sizeof res->start_mode, "%.15s", e->start_mode);
    int np = 0;
    for (int k = 0; k < sum.nproducts && np < FC_MAX_PRODUCTS - 1; k++)
        snprintf(res->products[np++], sizeof res->products[0], "%s", sum.products[k]);
    snprintf(res->products[np++], sizeof res->products[0], "%s", rname);
    res->nproducts = np;
    res->wall_seconds = time_monotonic() - wall0;
    log_info("forecast %s: %ld steps, %d output times, %ld -> %ld particles, budget residual %.3g, %.1f s",
             e->cname, nsteps, nout, res->run.particles_start, res->run.particles_end, res->run.budget_residual,
             res->wall_seconds);
    if (sph_model_ghosts_merging(e->m))
        log_info("forecast %s: a coast curved tighter than the kernel support piled its mirror ghosts up beyond "
                 "model.max_neighbours: crowded ghosts were merged (docs/engine.md)", e->cname);
    if (b->ocean)
        log_info("forecast %s: ice and ocean budgets: energy residual %.3g, water %.3g, salt %.3g; %ld particles "
                 "created, %ld merged", e->cname, res->run.energy_residual, res->run.water_residual,
                 res->run.salt_residual, b->created_particles, b->merged_particles);
    e->restart_written = 0; /* keep it */
    engine_free(e);
    free(stations);
    cycle_set_phase(prog, e->t0, FC_PHASE_DONE, "forecast: done");
    prog->percent = 100;
    return SPH_OK;

fail:
    fc_dd_agree(e, rc ? rc : SPH_ERR_INTERNAL, er); /* the other ranks fail too (once) */
    engine_free(e);
    free(stations);
    cycle_set_phase(prog, e->t0, FC_PHASE_FAILED, er->msg[0] ? er->msg : "forecast: failed");
    res->wall_seconds = time_monotonic() - wall0;
    return sph_err_set(err, rc ? rc : SPH_ERR_INTERNAL, "%s", er->msg[0] ? er->msg : "forecast: failed");
}
