/* `sphice check`: validates a loaded configuration against the files of
 * one cycle. Every forcing template of every source, the initial raster,
 * the land mask and the observations are expanded for cycle time t and
 * looked for (local files: size, age, sha256; remote URLs are checked when
 * fetched); every source whose files were found is opened and what it
 * holds (variables, units, grid, times, fill fraction) is described. */
#ifndef SPHICE_SERVICE_CHECK_H
#define SPHICE_SERVICE_CHECK_H

#include <stdio.h>

struct sph_config;

/* Writes a table (json 0) or one JSON document (json 1) to out. Returns 0
 * when every required source was found and opened, 1 otherwise. */
int service_check(const struct sph_config *cfg, double t, int json, FILE *out);

#endif
