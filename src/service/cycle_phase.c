/* Phase changes of a cycle (service/cycle_phase.h). */
#include "service/cycle_phase.h"

#include "service/schedule.h"
#include "util/log.h"

const char *cycle_phase_name(int phase)
{
    static const char *const names[] = {"idle", "fetching", "initialising", "running",
                                        "writing", "done", "failed"};
    return phase >= 0 && phase < (int)(sizeof names / sizeof names[0]) ? names[phase] : "unknown";
}

void cycle_set_phase(forecast_progress *prog, double cycle_time, int phase, const char *why)
{
    int old = prog ? prog->phase : FC_PHASE_IDLE;
    if (prog)
        prog->phase = phase;
    if (old == phase || LOG_LVL_DEBUG > sph_log_level)
        return;
    char name[32];
    cycle_name(cycle_time, name, sizeof name);
    log_debug("cycle %s: %s -> %s (%s)", name, cycle_phase_name(old), cycle_phase_name(phase),
              why && *why ? why : "no reason given");
}
