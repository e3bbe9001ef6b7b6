/* The registries: rheologies indexed by sph_params.rheology, stress
 * solvers by sph_params.solver; the configuration names them by the
 * tables' names. A new rheology is one file in src/core/rheology/
 * defining a const sph_rheology_ops and one line in SPH_RHEOLOGIES (core/registry.h); a new
 * solver likewise in src/core/solver/ and SPH_SOLVERS (docs/dynamics.md,
 * "Code layout"). */
#include "model_impl.h"

#include <string.h>

#include "core/registry.h"

#define DECLARE_RHEOLOGY(name) extern const sph_rheology_ops sph_rheology_##name;
#define DECLARE_SOLVER(name) extern const sph_solver_ops sph_solver_##name;
#define RHEOLOGY_ENTRY(name) &sph_rheology_##name,
#define SOLVER_ENTRY(name) &sph_solver_##name,
SPH_RHEOLOGIES(DECLARE_RHEOLOGY)
SPH_SOLVERS(DECLARE_SOLVER)
static const sph_rheology_ops *const rheologies[] = {SPH_RHEOLOGIES(RHEOLOGY_ENTRY)};
static const sph_solver_ops *const solvers[] = {SPH_SOLVERS(SOLVER_ENTRY)};

#define COUNT(a) ((int)(sizeof(a) / sizeof((a)[0])))

const sph_rheology_ops *sph_rheology_ops_of(int kind)
{
    return kind >= 0 && kind < COUNT(rheologies) ? rheologies[kind] : NULL;
}

const sph_solver_ops *sph_solver_ops_of(int kind)
{
    return kind >= 0 && kind < COUNT(solvers) ? solvers[kind] : NULL;
}

int sph_rheology_count(void) { return COUNT(rheologies); }
int sph_solver_count(void) { return COUNT(solvers); }

const char *sph_rheology_name(int kind)
{
    const sph_rheology_ops *r = sph_rheology_ops_of(kind);
    return r ? r->name : NULL;
}

const char *sph_solver_name(int kind)
{
    const sph_solver_ops *s = sph_solver_ops_of(kind);
    return s ? s->name : NULL;
}

static int lookup(const char *name, int n, const char *(*name_of)(int))
{
    for (int i = 0; name && i < n; i++)
        if (strcmp(name_of(i), name) == 0)
            return i;
    return -1;
}

int sph_rheology_lookup(const char *name) { return lookup(name, COUNT(rheologies), sph_rheology_name); }
int sph_solver_lookup(const char *name) { return lookup(name, COUNT(solvers), sph_solver_name); }
