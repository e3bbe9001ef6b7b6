/* Cycles as launched jobs: `serve` with launcher.command set runs each
 * cycle as `COMMAND PROGRAM run SNAPSHOT --cycle TIME` (for example under
 * `mpirun -np 8` or `srun -n 8`), in a process group of its own, instead of
 * in its own process. The job records the cycle in the same history (the
 * child's `sphice run` does, as a timer's would); the service reads the
 * result back from it. Cancellation (SIGTERM to serve) sends SIGTERM to the
 * whole group and SIGKILL after launcher.grace_s; a job that dies without
 * recording its end is recorded here as cancelled or failed. SNAPSHOT is
 * the configuration in force (a refused reload never reaches the job). */
#ifndef SPHICE_SERVICE_LAUNCH_H
#define SPHICE_SERVICE_LAUNCH_H

#include <signal.h>
#include <stddef.h>

#include "service/cycle.h"

struct sph_config;

/* Splits a launcher command at blanks; single or double quotes group words
 * (no escapes, no expansion). Words point into buf. Returns the count, or
 * -1 with err set (unbalanced quote, too many words, too long). */
int launch_split(const char *cmd, char *buf, size_t len, char **words, int max, sph_error *err);

/* cycle_run's contract, through cfg->launcher. o->hist is required. */
int launch_cycle(const struct sph_config *cfg, const cycle_opts *o, forecast_progress *prog,
                 const volatile sig_atomic_t *cancel, cycle_report *rep, sph_error *err);

#endif
