/* A NaN position (a blow-up) inside a step with a land mask: the step
 * reports it (SPH_STEP_FATAL, "is not finite") instead of indexing the
 * mask with (int)NaN (a crash seen on the Liaodong demo with a GSHHG
 * mask), and does not count the particle as outflow. A parcel whose mean
 * thickness M / rho_i passes model.thickness_limit (a numerical pile-up)
 * fails the step too, naming the particle and the quantity. */
#include <math.h>

#include "check.h"
#include "core/model.h"
#include "lattice.h"

int main(void)
{
    sph_params p;
    sph_params_default(&p);
    p.thermo_dt = 0;
    static unsigned char land[20 * 20];
    for (int i = 0; i < 20; i++)
        land[19 * 20 + i] = 1; /* a coast along the top row */
    sph_landmask mask = {20, 20, -5000.0, -5000.0, 1000.0, 1000.0, land, 0};
    sph_model *m = sph_model_create(&p, 16, &mask);
    CHECK(m != NULL, "model");
    if (!m)
        return check_summary("test_model_nan");
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, &p, 4, 4, 0.0, 0.0, 1000.0, 0.3, 0.5, 40.0);
    sph_status st;
    CHECK(sph_model_init(m, &st) == SPH_STEP_OK, "init");
    lattice_set_forcing(P, 0.0, 5.0, 0.0, 0.0, 0.0, 0.0);
    P->ua[5] = NAN; /* poisons particle 5's velocity, then its position */
    int rc = sph_model_step(m, &st);
    CHECK(rc == SPH_STEP_FATAL, "step fails (rc %d)", rc);
    CHECK(st.what && strstr(st.what, "not finite"), "names a non-finite value: %s %s", st.quantity, st.what);
    CHECK(sph_model_budget(m)->outflow == 0.0, "not counted as outflow");
    sph_model_free(m);

    /* the pile-up limit: one parcel at 40 m mean thickness (limit 30 m) */
    m = sph_model_create(&p, 16, &mask);
    P = sph_model_particles(m);
    lattice_fill(P, &p, 4, 4, 0.0, 0.0, 1000.0, 0.3, 0.5, 40.0);
    CHECK(sph_model_init(m, &st) == SPH_STEP_OK, "init");
    P->dens[6] = 40.0 * p.rho_i; /* same mass on a smaller footprint */
    rc = sph_model_step(m, &st);
    CHECK(rc == SPH_STEP_FATAL && st.quantity && strcmp(st.quantity, "mean thickness") == 0,
          "pile-up fails the step (rc %d, %s)", rc, st.quantity ? st.quantity : "");
    CHECK(st.particle >= 0, "names a particle (%ld)", st.particle);
    sph_model_free(m);
    return check_summary("test_model_nan");
}
