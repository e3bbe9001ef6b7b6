/* Cycle times: a list of times of day (UTC), or every N hours from 00:00
 * UTC, or (tests) every N seconds from the epoch. Pure functions of the
 * configuration and a time; seconds since 1970 UTC. */
#ifndef SPHICE_SERVICE_SCHEDULE_H
#define SPHICE_SERVICE_SCHEDULE_H

#include <stddef.h>

struct sph_config;

/* The latest cycle time <= t. */
double schedule_prev(const struct sph_config *cfg, double t);
/* The earliest cycle time > t. */
double schedule_next(const struct sph_config *cfg, double t);
/* Cycle name: "YYYYMMDDTHHZ" (or "YYYYMMDDTHHMMSSZ" when minutes or seconds
 * are not zero). */
void cycle_name(double t, char *buf, size_t len);
/* Parses a cycle name back; 0 on success. */
int cycle_name_parse(const char *name, double *t);

#endif
