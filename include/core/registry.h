/* The core's rheologies and stress solvers by name (src/core/registry.c):
 * sph_params.rheology and sph_params.solver index these lists, and the
 * names are the configuration's (model.rheology = "vp" | "collision",
 * model.solver = "explicit" | "mevp" | "implicit" | "jfnk"). The configuration and
 * the parameter table can take their enum names and ranges from here, so
 * a new rheology or solver is one file and one registry line. */
#ifndef SPHICE_CORE_REGISTRY_H
#define SPHICE_CORE_REGISTRY_H

/* One line per rheology (src/core/rheology/<name>.c defines
 * sph_rheology_<name>), in the order of sph_rheology_kind. */
#define SPH_RHEOLOGIES(X)                        \
    X(vp)        /* SPH_RHEOLOGY_VP */        \
    X(collision) /* SPH_RHEOLOGY_COLLISION */

/* One line per solver (src/core/solver/<name>.c defines sph_solver_<name>),
 * in the order of sph_solver_kind. */
#define SPH_SOLVERS(X)                         \
    X(explicit) /* SPH_SOLVER_EXPLICIT */  \
    X(mevp)     /* SPH_SOLVER_MEVP */      \
    X(implicit) /* SPH_SOLVER_IMPLICIT */  \
    X(jfnk)     /* SPH_SOLVER_JFNK */

/* The names as a NULL-terminated list, for tables that want an array
 * (the parameter table's enum rows): static const char *const n[] =
 * {SPH_RHEOLOGIES(SPH_REGISTRY_NAME) NULL}. */
#define SPH_REGISTRY_NAME(name) #name,

int sph_rheology_count(void);
const char *sph_rheology_name(int kind); /* NULL when out of range */
int sph_rheology_lookup(const char *name); /* its kind, or -1 */

int sph_solver_count(void);
const char *sph_solver_name(int kind);
int sph_solver_lookup(const char *name);

#endif
