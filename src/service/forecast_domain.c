/* parallel.decomposition "domain" (docs/domain.md): one member of the
 * forecast spread by space over the MPI ranks of `mpirun -np N sphice run`
 * (service/domain_mpi.c), bit-identical to the serial canonical run.
 *
 * Every rank runs forecast_run on the same request (rank 0 sends the workers
 * the job, ensemble_mpi.c) and so opens the same forcing files and builds
 * the same land mask; rank 0 alone reads the initial field, seeds and
 * initialises the particles (or, on a warm start, reads the restart file
 * and resumes them, fc_warm_start as in the serial run), which are scattered along the Hilbert curve
 * (with the capacity, the resolved step and the largest smoothing length). Each step every rank samples the
 * forcing onto the particles it owns (halo copies carry their owner's
 * forcing: dd_step copies every field), then steps. At output times and at
 * the restart the particles are gathered on rank 0 in id order into the
 * engine's model, from which the serial engine's own output code writes the
 * products; the workers write nothing. The serial run in this mode (plain
 * build, or one rank) steps in canonical mode and sorts its particles by id
 * before each output, so both write from the same particles in the same
 * order. Budgets and regime fractions are exact sums over all particles.
 *
 * Every collective is preceded by an agreement (fc_dd_agree) on every
 * rank's result, so a failure on one rank fails the run on all with that
 * rank's one line, and rank 0 publishes nothing. */
#include "forecast_impl.h"

#include <stdio.h>
#include <string.h>

#include "core/dd.h"
#include "service/domain_mpi.h"
#include "util/log.h"

#ifdef SPHICE_MPI
#include <mpi.h>
#endif

static const char *const KEY = "parallel.decomposition \"domain\"";

/* The combinations the decomposition does not support, one line each. */
static int refuse(const engine *e, sph_error *err)
{
    const struct sph_config *c = e->cfg;
    const sph_params *p = &c->model;
    if (c->ensemble.members > 1)
        return sph_err_set(err, SPH_ERR_CONFIG,
                           "config: %s runs one member over the ranks, but ensemble.members is %d (set "
                           "ensemble.members 1 or parallel.decomposition \"members\")", KEY, c->ensemble.members);
    if (p->physics != SPH_PHYSICS_FREE_DRIFT && p->solver != SPH_SOLVER_MEVP)
        return sph_err_set(err, SPH_ERR_CONFIG,
                           "config: %s supports only the mEVP stress solver (the explicit and implicit solvers "
                           "have no halo exchange): set model.solver \"mevp\" or parallel.decomposition "
                           "\"members\"", KEY);
    if (p->evp_anderson > 0 || p->evp_change_tol > 0.0)
        return sph_err_set(err, SPH_ERR_CONFIG,
                           "config: %s does not support model.evp.%s (its mixing and sums are neither reduced "
                           "over the ranks nor followed by a halo refresh): set it 0 or parallel.decomposition "
                           "\"members\"", KEY, p->evp_anderson > 0 ? "anderson" : "change_tol");
    if (p->free_drift_parcels)
        return sph_err_set(err, SPH_ERR_CONFIG,
                           "config: %s does not support free-drift parcels: set model.free_drift_parcels false "
                           "or parallel.decomposition \"members\"", KEY);
    return SPH_OK;
}

int fc_dd_begin(engine *e, sph_error *err)
{
    e->dd_rank = ens_mpi_rank();
    e->dd_size = ens_mpi_size();
    if (e->cfg->parallel.decomposition != CFG_DECOMP_DOMAIN)
        return SPH_OK;
    e->dd = e->dd_size > 1 ? 2 : 1;
    if (e->dd == 2 && e->dd_rank == 0) { /* first: the workers join whatever happens next */
        e->dd_jobs = calloc((size_t)e->dd_size, sizeof *e->dd_jobs);
        if (!e->dd_jobs)
            return sph_err_set(err, SPH_ERR_NOMEM, "forecast: out of memory");
        for (int r = 1; r < e->dd_size; r++)
            if (ens_mpi_dispatch_rank(e->req, r, e->req->stage_dir ? e->req->stage_dir : "", &e->dd_jobs[r], err)) {
                e->dd = 0; /* no collective can follow */
                return err->code ? err->code : SPH_ERR_INTERNAL;
            }
    }
    int rc = refuse(e, err);
    if (e->dd == 1 || e->dd_rank == 0) {
        if (rc == SPH_OK)
            log_info("forecast %s: %s over %d rank%s (canonical order)", e->cname, KEY, e->dd_size,
                     e->dd_size > 1 ? "s" : "");
    }
    return rc;
}

int fc_dd_agree(engine *e, int rc, sph_error *err)
{
    if (e->dd != 2 || e->dd_failed)
        return rc;
#ifdef SPHICE_MPI
    /* the lowest failing rank names the failure */
    int key[2] = {rc ? e->dd_rank : e->dd_size, e->dd_rank}, best[2];
    MPI_Allreduce(key, best, 1, MPI_2INT, MPI_MINLOC, MPI_COMM_WORLD);
    if (best[0] == e->dd_size)
        return SPH_OK;
    int who = best[0];
    char msg[sizeof err->msg];
    snprintf(msg, sizeof msg, "%s", err->msg);
    int code = rc;
    MPI_Bcast(&code, 1, MPI_INT, who, MPI_COMM_WORLD);
    MPI_Bcast(msg, (int)sizeof msg, MPI_CHAR, who, MPI_COMM_WORLD);
    e->dd_failed = 1;
    if (who == e->dd_rank)
        return rc;
    return sph_err_set(err, code ? code : SPH_ERR_INTERNAL, "rank %d: %s", who, msg);
#else
    (void)err;
    return rc;
#endif
}

/* The exact sums of the budget's diagnostics over P (core/dd.h). */
static void exact_budget(const engine *e, const sph_particles *P, sph_budget *b)
{
    sph_xsum acc[5];
    for (int k = 0; k < 5; k++)
        sph_xsum_clear(&acc[k]);
    const double rho_i = e->prm.rho_i;
    for (size_t k = 0; k < P->n; k++) {
        sph_xsum_add(&acc[0], P->mass[k]);
        sph_xsum_add(&acc[1], sph_particle_snow_mass(&e->prm.thermo, P, k));
        sph_xsum_add(&acc[2], P->mass[k] / (rho_i * P->thick[k]));
        sph_xsum_add(&acc[3], P->mass[k] / rho_i);
        sph_xsum_add(&acc[4], 0.5 * P->mass[k] * (P->u[k] * P->u[k] + P->v[k] * P->v[k]));
    }
    b->mass = sph_xsum_value(&acc[0]);
    b->snow = sph_xsum_value(&acc[1]);
    b->area = sph_xsum_value(&acc[2]);
    b->volume = sph_xsum_value(&acc[3]);
    b->kinetic_energy = sph_xsum_value(&acc[4]);
}

#ifdef SPHICE_MPI
/* The mixed layer's state: every per-cell array but the workspace. */
enum { OCEAN_NSTATE = 27 };
static void ocean_state(sph_ocean *o, double *a[OCEAN_NSTATE])
{
    double *const v[OCEAN_NSTATE] = {o->temp, o->sal, o->depth, o->water, o->salt, o->frazil, o->frazil_enth,
                                     o->seafrac, o->tair, o->qair, o->ua, o->va, o->swdn, o->lwdn, o->lat,
                                     o->sst_restore, o->sss_restore, o->ow_heat, o->ow_fresh, o->ow_salt,
                                     o->ofx_heat, o->ofx_water, o->ofx_salt, o->ofx_heat_ice, o->ofx_taux,
                                     o->ofx_tauy, o->ofx_swbase};
    memcpy(a, v, sizeof v);
}

/* dst's mixed layer takes src's state (same grid). */
static void ocean_copy(sph_ocean *dst, sph_ocean *src)
{
    double *a[OCEAN_NSTATE], *b[OCEAN_NSTATE];
    ocean_state(dst, a);
    ocean_state(src, b);
    for (int q = 0; q < OCEAN_NSTATE; q++)
        memcpy(a[q], b[q], src->ncell * sizeof(double));
}
#endif

void fc_dd_budget(const engine *e, sph_budget *b)
{
    *b = e->dd_b0;
    /* the mixed layer's budgets (energy, water, salt, the created and
     * merged counts): the stepped model's, global on every rank (core
     * ocean/ocean_dd.c) */
    const sph_budget *ob = sph_model_budget(e->dd == 2 && e->dd_m ? e->dd_m : e->m);
    if (ob->ocean) {
        b->ocean = 1;
        b->energy_initial = ob->energy_initial;
        b->energy = ob->energy;
        b->energy_surface = ob->energy_surface;
        b->energy_restoring = ob->energy_restoring;
        b->energy_outflow = ob->energy_outflow;
        b->water_initial = ob->water_initial;
        b->water = ob->water;
        b->water_outflow = ob->water_outflow;
        b->salt_initial = ob->salt_initial;
        b->salt = ob->salt;
        b->salt_restoring = ob->salt_restoring;
        b->salt_outflow = ob->salt_outflow;
        b->created_particles = ob->created_particles;
        b->merged_particles = ob->merged_particles;
    }
    /* the sources (thermodynamics, open boundaries): exact sums over the
     * owned particles (core/dd.h), over every rank when decomposed */
    if (e->dd == 1) {
        sph_budget src = *sph_model_budget(e->m);
        sph_dd_budget_sources(b, &src, (sph_xsum[SPH_DD_NSRC]){0}); /* the model's, already exact */
    }
#ifdef SPHICE_MPI
    if (e->dd == 2)
        dd_sources(e->dd_ctx, b);
#endif
    exact_budget(e, sph_model_particles(e->m), b);
}

int fc_dd_setup(engine *e, sph_error *err)
{
    if (!e->dd)
        return SPH_OK;
    /* the budget after init, its mass an exact sum (the mass budget's
     * reference; rank 0's, which writes) */
    sph_model_clock clk;
    memset(&clk, 0, sizeof clk);
    if (e->dd_rank == 0) {
        sph_model_get_clock(e->m, &clk);
        e->dd_b0 = clk.budget;
        exact_budget(e, sph_model_particles(e->m), &e->dd_b0);
        e->dd_b0.mass_initial = e->dd_b0.mass;
    }
    if (e->dd == 1)
        return SPH_OK;
#ifdef SPHICE_MPI
    /* from rank 0's start: the capacity, the resolved step and the cell side
     * (the initial halo width: 3 kernel supports of the largest smoothing
     * length) */
    double bc[3] = {0, 0, 0};
    if (e->dd_rank == 0) {
        const sph_particles *P0 = sph_model_particles(e->m);
        bc[0] = (double)e->cap;
        bc[1] = e->prm.dt;
        double hmax = 0.0;
        for (size_t k = 0; k < P0->n; k++)
            hmax = P0->sml[k] > hmax ? P0->sml[k] : hmax;
        bc[2] = 3.0 * sph_model_kernel_radius(e->m) * hmax;
    }
    MPI_Bcast(bc, 3, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    int rc = SPH_OK;
    if (e->dd_rank > 0) { /* a worker: an empty engine model (sizes, parameters) and the forcing's arrays */
        e->cap = (size_t)bc[0];
        e->prm.dt = bc[1];
        e->m = sph_model_create(&e->prm, e->cap, &e->plane);
        rc = e->m ? coupling_alloc(&e->cpl, e->cap, err)
                  : sph_err_set(err, SPH_ERR_NOMEM, "model: cannot create a model for %zu particles", e->cap);
    }
    double xmin, xmax, ymin, ymax;
    if (rc == SPH_OK)
        rc = fc_plane_box(e, &xmin, &xmax, &ymin, &ymax, err);
    if (rc == SPH_OK) {
        e->dd_m = sph_model_create(&e->prm, e->cap, &e->plane);
        dd_options o = {xmin, ymin, xmax, ymax, bc[2] > 0.0 ? bc[2] : 1e3, 10};
        e->dd_ctx = e->dd_m ? dd_create(MPI_COMM_WORLD, e->dd_m, &o) : NULL;
        if (!e->dd_ctx)
            rc = sph_err_set(err, SPH_ERR_NOMEM, "forecast: cannot create the decomposed model for %zu particles",
                             e->cap);
    }
    if ((rc = fc_dd_agree(e, rc, err)))
        return rc;
    /* the mixed layer: every rank's decomposed model gets rank 0's grid and
     * state (after its cold start's first fill, or a warm start's restart
     * file), and every rank samples the cells' forcing itself from then on */
    if (e->prm.ocean.mixed_layer) {
        sph_ocean_grid g;
        memset(&g, 0, sizeof g);
        if (e->dd_rank == 0 && sph_model_ocean(e->m))
            g = sph_model_ocean(e->m)->g;
        MPI_Bcast(&g, (int)sizeof g, MPI_BYTE, 0, MPI_COMM_WORLD);
        if (sph_model_ocean_create(e->dd_m, &g) != SPH_STEP_OK)
            rc = sph_err_set(err, SPH_ERR_NOMEM, "forecast: cannot create the mixed layer (%d x %d cells)", g.nx,
                             g.ny);
        else if (e->dd_rank > 0)
            rc = fc_ocean_points(e, &g, err);
        if ((rc = fc_dd_agree(e, rc, err)))
            return rc;
        sph_ocean *o = sph_model_ocean(e->dd_m);
        if (e->dd_rank == 0)
            ocean_copy(o, sph_model_ocean(e->m));
        double *a[OCEAN_NSTATE];
        ocean_state(o, a);
        for (int q = 0; q < OCEAN_NSTATE; q++)
            MPI_Bcast(a[q], (int)o->ncell, MPI_DOUBLE, 0, MPI_COMM_WORLD);
        /* a warm start's restart carries the last record's cell
         * accumulators, which the new ocean-fluxes file must not count (the
         * serial path clears them when it opens the file) */
        if (e->cfg->output.ocean_fluxes)
            sph_ocean_clear_fluxes(o);
        e->ocean_fresh = 0;
    }
    sph_status st;
    memset(&st, 0, sizeof st);
    if (dd_scatter(e->dd_ctx, sph_model_particles(e->m), &clk, &st) != SPH_STEP_OK)
        rc = fc_dd_agree(e, sph_err_set(err, SPH_ERR_NUMERICS, "forecast: scattering the particles: %s %s",
                                        st.quantity ? st.quantity : "", st.what ? st.what : "failed"), err);
    return rc;
#else
    return sph_err_set(err, SPH_ERR_INTERNAL, "forecast: built without MPI");
#endif
}

int fc_dd_step(engine *e, long s, double t, const volatile sig_atomic_t *cancel, sph_error *err)
{
#ifdef SPHICE_MPI
    sph_particles *P = sph_model_particles(e->dd_m);
    int rc = SPH_OK;
    if (cancel && *cancel) {
        char when[32];
        iso(t, when, sizeof when);
        rc = sph_err_set(err, SPH_ERR_CANCELLED, "forecast %s: cancelled at model time %s", e->cname, when);
    } else if (s > 0) { /* the owned particles' forcing (the halo's comes with the copies) */
        if (e->ocean_pts) /* every rank's mixed layer, first (as fc_fill_forcing) */
            rc = fc_ocean_fill_to(e, sph_model_ocean(e->dd_m), t, err);
        if (rc == SPH_OK)
            rc = coupling_fill(&e->cpl, e->proj, &e->cfg->model.thermo, e->thermo_on, P, t, err);
    }
    if ((rc = fc_dd_agree(e, rc, err)))
        return rc;
    sph_status st;
    memset(&st, 0, sizeof st);
    st.code = SPH_STEP_OK;
    if (dd_step(e->dd_ctx, &st) != SPH_STEP_OK) {
        /* the worst status over the ranks: a rank whose own step failed names it */
        int own = st.code != SPH_STEP_OK;
        rc = own ? fc_step_error(e, &st, s + 1, t, err)
                 : sph_err_set(err, SPH_ERR_NUMERICS, "model step %ld: failed on another rank; nothing written",
                               s + 1);
        int key[2] = {own ? e->dd_rank : e->dd_size + e->dd_rank, e->dd_rank}, best[2];
        MPI_Allreduce(key, best, 1, MPI_2INT, MPI_MINLOC, MPI_COMM_WORLD);
        int who = best[1];
        char msg[sizeof err->msg];
        snprintf(msg, sizeof msg, "%s", err->msg);
        MPI_Bcast(msg, (int)sizeof msg, MPI_CHAR, who, MPI_COMM_WORLD);
        e->dd_failed = 1;
        return who == e->dd_rank ? rc : sph_err_set(err, SPH_ERR_NUMERICS, "rank %d: %s", who, msg);
    }
    /* the step's regime fractions over every rank's owned particles (the
     * serial model's: counts over all particles); the solver's numbers come
     * from global norms and are the same on every rank */
    sph_step_stats ss = *sph_model_stats(e->dd_m);
    long cnt[5] = {0, 0, 0, 0, (long)P->n};
    for (size_t k = 0; k < P->n; k++) {
        cnt[0] += (P->regime[k] & SPH_REGIME_FREE_DRIFT) != 0;
        cnt[1] += (P->regime[k] & SPH_REGIME_RHEOLOGY) != 0;
        cnt[2] += (P->regime[k] & SPH_REGIME_ZERO_LAYER) != 0;
        cnt[3] += (P->regime[k] & SPH_REGIME_MULTI_LAYER) != 0;
    }
    MPI_Allreduce(MPI_IN_PLACE, cnt, 5, MPI_LONG, MPI_SUM, MPI_COMM_WORLD);
    double n = cnt[4] > 0 ? (double)cnt[4] : 1.0;
    ss.frac_free_drift = (double)cnt[0] / n;
    ss.frac_rheology = (double)cnt[1] / n;
    ss.frac_zero_layer = (double)cnt[2] / n;
    ss.frac_multi_layer = (double)cnt[3] / n;
    sph_run_stats_add_step(&e->res->run, &ss);
    return SPH_OK;
#else
    (void)s;
    (void)t;
    (void)cancel;
    return sph_err_set(err, SPH_ERR_INTERNAL, "forecast %s: built without MPI", e->cname);
#endif
}

int fc_dd_sync(engine *e, sph_error *err)
{
    if (e->dd == 1) {
        dd_sort_by_id(sph_model_particles(e->m));
        return SPH_OK;
    }
#ifdef SPHICE_MPI
    if (e->dd == 2 && dd_gather(e->dd_ctx, e->dd_rank == 0 ? sph_model_particles(e->m) : NULL) != 0)
        return sph_err_set(err, SPH_ERR_NOMEM, "forecast %s: gathering the particles failed", e->cname);
    /* the mixed layer, the same on every rank, into the engine's model (its restart file) */
    if (e->dd == 2 && e->dd_rank == 0 && sph_model_ocean(e->m) && sph_model_ocean(e->dd_m))
        ocean_copy(sph_model_ocean(e->m), sph_model_ocean(e->dd_m));
#endif
    (void)err;
    return SPH_OK;
}

void fc_dd_end(engine *e)
{
#ifdef SPHICE_MPI
    if (e->dd_ctx)
        dd_free(e->dd_ctx);
#endif
    e->dd_ctx = NULL;
    sph_model_free(e->dd_m);
    e->dd_m = NULL;
    if (e->dd_jobs) { /* the workers' answers: their failures were agreed already */
        double wall = 0;
        sph_error ignored;
        sph_error_clear(&ignored);
        ens_mpi_collect(e->dd_jobs + 1, e->dd_size - 1, &wall, &ignored);
        free(e->dd_jobs);
        e->dd_jobs = NULL;
    }
}
