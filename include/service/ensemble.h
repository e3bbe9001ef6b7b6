/* Ensembles (issue 24): N members of the forecast engine, member 0 the
 * unperturbed control, the others perturbed in wind, current, the initial
 * ice, ice strength and drag (docs/ensemble.md); their gridded fields
 * reduced to the ensemble products (io/ensemble.h).
 *
 * The perturbations of member m are drawn from (ensemble.seed, m) alone,
 * so the same seed gives the same members bit for bit whatever runs them
 * (one process in turn, or ranks). */
#ifndef SPHICE_SERVICE_ENSEMBLE_H
#define SPHICE_SERVICE_ENSEMBLE_H

#include <signal.h>
#include "core/params.h"
#include "core/particles.h"
#include "core/perturb.h"
#include "service/forecast.h"

struct sph_config;

/* Perturbation streams: one per perturbed quantity. */
enum { ENS_S_WIND_U = 1, ENS_S_WIND_V, ENS_S_CUR_U, ENS_S_CUR_V, ENS_S_CONC, ENS_S_THICK, ENS_S_STRENGTH,
       ENS_S_CA, ENS_S_CW };

typedef struct fc_member {
    int index;                      /* 0: the control (nothing perturbed) */
    unsigned long long seed;
    sph_rfield wind_u, wind_v, cur_u, cur_v, conc, thick;
    double thick_sigma;             /* for the clip at +-3 sigma */
    double p0_factor, ca_factor, cw_factor;
} fc_member;

/* Draws member `index`'s perturbations from cfg->ensemble. */
int fc_member_init(fc_member *m, const struct sph_config *cfg, int index, sph_error *err);
void fc_member_free(fc_member *m);
/* Strength and drag coefficients. */
void fc_member_perturb_params(const fc_member *m, sph_params *p);
/* Adds the wind and current perturbations at the particles' plane
 * positions, t seconds after the cycle start. */
void fc_member_perturb_forcing(const fc_member *m, sph_particles *P, double t);
/* The initial ice: concentration + f_A (clipped to 0.01..1), thickness
 * h (1 + f_h) (f_h clipped to +-3 sigma); mass follows A h. */
void fc_member_perturb_initial(const fc_member *m, sph_particles *P);

/* The configuration a perturbed member runs with: cfg, or (without
 * ensemble.member_products, when its products are thrown away after the
 * reduction) a shallow copy in *lite without maps and GIS products. */
const struct sph_config *fc_member_config(const struct sph_config *cfg, struct sph_config *lite);

/* The cycle engine: forecast_run when ensemble.members is 1, else the
 * members in turn and the ensemble products. The control's products are
 * the cycle's own; res describes the control plus the ensemble block. */
int ensemble_run(const struct sph_config *cfg, const forecast_request *req, forecast_progress *prog,
                 const volatile sig_atomic_t *cancel, forecast_result *res, sph_error *err);

/* ---- MPI (make MPI=1): members over ranks, member m on rank m % size.
 * Without MPI: size 1, rank 0, and the rest is never reached. */
int ens_mpi_init(int *argc, char ***argv);
int ens_mpi_rank(void);
int ens_mpi_size(void);
void ens_mpi_finalize(void);
/* Ranks > 0: run the member jobs rank 0 sends until it says stop; 0 when
 * stopped. */
int ens_mpi_worker(const struct sph_config *cfg, const volatile sig_atomic_t *cancel);
void ens_mpi_stop_workers(void); /* rank 0, once at the end */
/* Rank 0: sends member's job (req with the member's stage directory) to
 * its rank; *handle until ens_mpi_collect. */
int ens_mpi_dispatch(const forecast_request *req, int member, const char *stage, void **handle, sph_error *err);
/* The control (member 0) to one worker rank (parallel.decomposition "domain"). */
int ens_mpi_dispatch_rank(const forecast_request *req, int rank, const char *stage, void **handle, sph_error *err);
/* Rank 0: completes the n sends and waits for n answers; adds the
 * members' wall times to *wall; the first failure in err. */
int ens_mpi_collect(void **handles, int n, double *wall, sph_error *err);

#endif
