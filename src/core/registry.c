/* The registries: rheologies indexed by sph_params.rheology, stress
 * solvers by sph_params.solver; the configuration names them by the
 * tables' names. A new rheology is one file in src/core/rheology/
 * defining a const sph_rheology_ops and one line in `rheologies`; a new
 * solver likewise in src/core/solver/ and `solvers` (docs/architecture.md). */
#include "model_impl.h"

#include <string.h>

#include "core/registry.h"

static const sph_rheology_ops *const rheologies[] = {
    &sph_rheology_vp,        /* SPH_RHEOLOGY_VP */
    &sph_rheology_collision, /* SPH_RHEOLOGY_COLLISION */
};

static const sph_solver_ops *const solvers[] = {
    &sph_solver_explicit, /* SPH_SOLVER_EXPLICIT */
    &sph_solver_mevp,     /* SPH_SOLVER_MEVP */
    &sph_solver_implicit, /* SPH_SOLVER_IMPLICIT */
};

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
