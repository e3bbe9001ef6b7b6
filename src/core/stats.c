/* Run statistics: the sums of the steps' statistics, then their means
 * (include/core/model.h, sph_run_stats). */
#include "core/model.h"

#include <string.h>

void sph_run_stats_begin(sph_run_stats *r, sph_model *m, int dt_auto)
{
    memset(r, 0, sizeof *r);
    r->particles_start = (long)sph_model_particles(m)->n;
    r->dt = sph_model_params(m)->dt;
    r->dt_auto = dt_auto;
    const sph_params *p = sph_model_params(m);
    r->solver_rel_tol_on = p->solver == SPH_SOLVER_MEVP && p->evp_rel_tol > 0.0;
}

/* Sums until sph_run_stats_end divides them, in the order of the steps. */
void sph_run_stats_add(sph_run_stats *r, const sph_model *m) { sph_run_stats_add_step(r, sph_model_stats(m)); }

/* The same from one step's statistics (a decomposed run's, its fractions over all ranks). */
void sph_run_stats_add_step(sph_run_stats *r, const sph_step_stats *ss)
{
    r->frac_free_drift += ss->frac_free_drift;
    r->frac_rheology += ss->frac_rheology;
    r->frac_zero_layer += ss->frac_zero_layer;
    r->frac_multi_layer += ss->frac_multi_layer;
    r->solver_iterations += ss->iterations;
    r->solver_stalled += ss->stalled;
    r->solver_residual += ss->rel_residual;
    if (ss->rel_residual > r->solver_residual_max)
        r->solver_residual_max = ss->rel_residual;
    r->solver_unconverged += ss->unconverged;
    r->steps++;
}

void sph_run_stats_end(sph_run_stats *r, sph_model *m)
{
    if (r->steps > 0) {
        double n = (double)r->steps;
        r->frac_free_drift /= n;
        r->frac_rheology /= n;
        r->frac_zero_layer /= n;
        r->frac_multi_layer /= n;
        r->solver_iterations /= n;
        r->solver_stalled /= n;
        r->solver_residual /= n;
        r->solver_unconverged /= n;
    }
    r->particles_end = (long)sph_model_particles(m)->n;
    r->budget_residual = sph_budget_residual(sph_model_budget(m));
    r->ocean = sph_model_budget(m)->ocean;
    r->energy_residual = sph_budget_energy_residual(sph_model_budget(m));
    r->water_residual = sph_budget_water_residual(sph_model_budget(m));
    r->salt_residual = sph_budget_salt_residual(sph_model_budget(m));
}
