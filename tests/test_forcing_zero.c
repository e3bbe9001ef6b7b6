/* Zero is a value (issue 19 item 9): a basal ocean heat flux of exactly
 * 0 W/m2 in the forcing is used as 0; the default (fw_default, 2 W/m2)
 * applies only where the flux is absent (NaN: no source provides it, or
 * fill). Three identical columns of 1 m ice at full concentration under a
 * freezing night, for one day: fw = NaN and fw = fw_default explicitly give
 * the same ice bit for bit; fw = 0 grows more ice at the base, by about the
 * energy the default flux would have supplied, fw_default t / L_f per unit
 * area of ice (L_f = 334 kJ/kg, fresh ice; brine changes the enthalpy of
 * sea ice by a few per cent, so within 15 %). The coupling sets fw before
 * every step (NaN where no source provides it, tests/test_coupling). */
#include "check.h"
#include "core/thermo.h"

#include <math.h>
#include <string.h>

#define AREA 1.0e6 /* footprint, m^2 */

int main(void)
{
    sph_thermo_params p;
    sph_thermo_params_default(&p);
    sph_particles *P = sph_particles_create(3, p.nlayers);
    CHECK(P != NULL, "particles");
    if (!P)
        return check_summary("test_forcing_zero");
    P->n = 3;
    for (size_t k = 0; k < 3; k++) {
        P->id[k] = (long)k;
        P->thick[k] = 1.0;
        P->conc[k] = 1.0;
        P->snow[k] = 0.0;
        P->mass[k] = p.rho_i * P->conc[k] * P->thick[k] * AREA;
        P->sml[k] = 1000.0;
        P->ua[k] = 5.0;
        P->va[k] = 0.0;
        P->tair[k] = -20.0;
        P->qair[k] = 0.0005;
        P->swdn[k] = 0.0;
        P->lwdn[k] = 180.0;
        P->sst[k] = sph_freezing_point(&p);
        sph_thermo_init_particle(&p, P, k, P->tair[k]);
    }
    sph_thermo_work *w = sph_thermo_work_create(P->cap, P->nlayers);
    sph_budget b;
    sph_status st;
    memset(&b, 0, sizeof b);
    memset(&st, 0, sizeof st);
    const int steps = 24;
    const double dt = 3600.0;
    int rc = SPH_STEP_OK;
    for (int i = 0; i < steps && rc == SPH_STEP_OK; i++) {
        /* the forcing is set before every step, as the coupling does */
        P->fw[0] = 0.0;
        P->fw[1] = NAN;
        P->fw[2] = p.fw_default;
        rc = sph_thermo_step(&p, P, dt, w, &b, &st);
    }
    CHECK(rc == SPH_STEP_OK, "thermo step failed: %d", rc);
    CHECK(memcmp(&P->mass[1], &P->mass[2], sizeof(double)) == 0,
          "absent fw (%.9g kg) differs from fw_default given (%.9g kg)", P->mass[1], P->mass[2]);
    double dm = P->mass[0] - P->mass[2];
    double want = p.fw_default * steps * dt * AREA / 334000.0;
    CHECK(fabs(dm - want) < 0.15 * want,
          "fw 0 grew %.6g kg more than fw %.3g W/m2, want %.6g kg (fw t / L_f)", dm,
          p.fw_default, want);
    sph_thermo_work_free(w);
    sph_particles_free(P);
    return check_summary("test_forcing_zero");
}
