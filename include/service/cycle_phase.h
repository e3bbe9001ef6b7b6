/* The phase of a running cycle (forecast_progress.phase, FC_PHASE_*), as
 * the status server reports it. Every change goes through
 * cycle_set_phase, the one place that writes it, which logs the
 * transition at debug level: "cycle <name>: <old> -> <new> (<why>)".
 * Used by the cycle (service/cycle.h) and the engine (service/forecast.h). */
#ifndef SPHICE_SERVICE_CYCLE_PHASE_H
#define SPHICE_SERVICE_CYCLE_PHASE_H

#include "service/forecast.h"

/* "idle", "fetching", "initialising", "running", "writing", "done", "failed". */
const char *cycle_phase_name(int phase);

/* Sets prog->phase (prog may be NULL: only logged) for the cycle at
 * cycle_time; why says what starts or ended. */
void cycle_set_phase(forecast_progress *prog, double cycle_time, int phase, const char *why);

#endif
