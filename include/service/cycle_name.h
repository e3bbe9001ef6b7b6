/* Naming by cycle time: path templates and the warm-start file name.
 * Shared by the cycle (service/cycle.h) and the forecast engine
 * (service/forecast.h), so neither needs the other for names. The cycle's
 * own name ("YYYYMMDDTHHZ") is cycle_name() in service/schedule.h. */
#ifndef SPHICE_SERVICE_CYCLE_NAME_H
#define SPHICE_SERVICE_CYCLE_NAME_H

#include <stddef.h>
#include "util/err.h"

/* strftime-style expansion with the cycle time: %Y %m %d %H %M %S %j %y %%.
 * Any other conversion is an error naming the template. */
int cycle_expand_template(const char *tmpl, double t, char *out, size_t len, sph_error *err);

/* The warm-start file an engine writes into its stage dir for a later
 * cycle at time t: "restart-<cycle name>.nc". */
void cycle_restart_name(double t, char *buf, size_t len);

#endif
