/* The core's rheologies and stress solvers by name (src/core/registry.c):
 * sph_params.rheology and sph_params.solver index these lists, and the
 * names are the configuration's (model.rheology = "vp" | "collision",
 * model.solver = "explicit" | "mevp" | "implicit"). The configuration and
 * the parameter table can take their enum names and ranges from here, so
 * a new rheology or solver is one file and one registry line. */
#ifndef SPHICE_CORE_REGISTRY_H
#define SPHICE_CORE_REGISTRY_H

int sph_rheology_count(void);
const char *sph_rheology_name(int kind); /* NULL when out of range */
int sph_rheology_lookup(const char *name); /* its kind, or -1 */

int sph_solver_count(void);
const char *sph_solver_name(int kind);
int sph_solver_lookup(const char *name);

#endif
