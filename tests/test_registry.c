/* The rheology and solver registries (include/core/registry.h) and the
 * structured kind of the core's errors (sph_status.kind): the registries
 * hold the configuration's names in the order of the enums, and the
 * errors a caller decides on carry their kind, not only prose. */
#include <math.h>
#include <string.h>

#include "check.h"
#include "core/model.h"
#include "core/registry.h"
#include "lattice.h"

static int init_with(const sph_params *p, void (*spoil)(sph_particles *), sph_status *st)
{
    sph_model *m = sph_model_create(p, 16, NULL);
    if (!m)
        return 99;
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, p, 4, 4, 0.0, 0.0, 1000.0, 0.9, 0.5, 40.0);
    if (spoil)
        spoil(P);
    int rc = sph_model_init(m, st);
    sph_model_free(m);
    return rc;
}

static void bad_conc(sph_particles *P) { P->conc[3] = 1.5; }
static void bad_mass(sph_particles *P) { P->mass[2] = -1.0; }

int main(void)
{
    CHECK(sph_rheology_count() == 2, "two rheologies (%d)", sph_rheology_count());
    CHECK(sph_rheology_lookup("vp") == SPH_RHEOLOGY_VP, "vp");
    CHECK(sph_rheology_lookup("collision") == SPH_RHEOLOGY_COLLISION, "collision");
    CHECK(sph_rheology_lookup("nope") == -1 && sph_rheology_lookup(NULL) == -1, "unknown rheology");
    CHECK(sph_rheology_name(2) == NULL && sph_rheology_name(-1) == NULL, "out of range");
    CHECK(sph_solver_count() == 4, "four solvers (%d)", sph_solver_count());
    CHECK(sph_solver_lookup("explicit") == SPH_SOLVER_EXPLICIT, "explicit");
    CHECK(sph_solver_lookup("mevp") == SPH_SOLVER_MEVP, "mevp");
    CHECK(sph_solver_lookup("implicit") == SPH_SOLVER_IMPLICIT, "implicit");
    CHECK(sph_solver_lookup("jfnk") == SPH_SOLVER_JFNK, "jfnk");
    CHECK(!strcmp(sph_solver_name(SPH_SOLVER_MEVP), "mevp"), "solver name");

    sph_params p;
    sph_params_default(&p);
    p.thermo_dt = 0;
    sph_status st;
    CHECK(init_with(&p, NULL, &st) == SPH_STEP_OK && st.kind == SPH_FAULT_NONE, "clean init");
    CHECK(init_with(&p, bad_conc, &st) == SPH_STEP_FATAL && st.kind == SPH_FAULT_INVALID,
          "concentration 1.5: kind %d", (int)st.kind);
    CHECK(init_with(&p, bad_mass, &st) == SPH_STEP_FATAL && st.kind == SPH_FAULT_INVALID,
          "negative mass: kind %d", (int)st.kind);
    /* adaptive EVP at 1 km spacing: refused above 200 s */
    p.dt = 600.0;
    p.thermo_dt = 0;
    CHECK(init_with(&p, NULL, &st) == SPH_STEP_RECOVERABLE && st.kind == SPH_FAULT_TIMESTEP &&
              st.particle < 0 && fabs(st.limit - 200.0) < 1e-9,
          "dt 600 s refused: kind %d limit %g", (int)st.kind, st.limit);
    p.evp_adaptive = 0; /* fixed-parameter mEVP below 2 km: 60 s */
    CHECK(init_with(&p, NULL, &st) == SPH_STEP_RECOVERABLE && st.kind == SPH_FAULT_TIMESTEP &&
              st.limit == 60.0,
          "fixed mEVP bound: %g", st.limit);
    p.evp_adaptive = 1;
    p.dt = 60.0;

    /* a model switched to another solver or rheology at reload still steps */
    sph_model *m = sph_model_create(&p, 16, NULL);
    CHECK(m != NULL, "model");
    if (m) {
        sph_particles *P = sph_model_particles(m);
        lattice_fill(P, &p, 4, 4, 0.0, 0.0, 1000.0, 0.95, 0.5, 40.0);
        lattice_set_forcing(P, 10.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        CHECK(sph_model_init(m, &st) == SPH_STEP_OK, "init");
        sph_params q = p;
        q.physics = SPH_PHYSICS_FULL;
        const sph_solver_kind solvers[] = {SPH_SOLVER_IMPLICIT, SPH_SOLVER_EXPLICIT, SPH_SOLVER_MEVP, SPH_SOLVER_JFNK};
        for (int i = 0; i < 4; i++) {
            q.solver = solvers[i];
            q.rheology = i == 1 ? SPH_RHEOLOGY_COLLISION : SPH_RHEOLOGY_VP;
            CHECK(sph_model_set_params(m, &q) == SPH_STEP_OK, "set_params to solver %d", (int)q.solver);
            int rc = sph_model_step(m, &st);
            CHECK(rc == SPH_STEP_OK, "step with solver %d rheology %d: %s %s", (int)q.solver,
                  (int)q.rheology, st.quantity, st.what);
        }
        sph_model_free(m);
    }
    return check_summary("test_registry");
}
