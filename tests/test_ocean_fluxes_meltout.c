/* Particles that melt out in the middle of a fluxes record (issue 20;
 * docs/ocean-coupling.md): four ice particles 0.02, 0.04, 0.08 and 1 m
 * thick over a slab mixed layer at +1 C (20 m, 32 psu) under -5 C air
 * with a water current, one 12 h record of 30 min steps. The thin ones
 * melt through from below before the record ends; what they gave the
 * ocean until then must stay in the record (their accumulators go to
 * their cell, sph_ocean_take_particle). Regridded the way the engine does
 * it (ofx_add_particles for the live particles, ofx_add_ocean_cells for
 * the cells) onto a projected 3 km grid, the file's integrals over the
 * record equal the conserved quantities' changes, computed here from the
 * state, not from the accumulators:
 *  - hfds: the slab's enthalpy change rho_w c_w d sum(A_c dT_c) (warm water:
 *    no frazil, no restoring);
 *  - siflfwbot + siflsaltbot: the slab's water change, and minus the
 *    ice's mass change;
 *  - siflsaltbot: the slab's salt change, and minus the ice's mass change
 *    times the Bitz-Lipscomb mean salinity written out in
 *    tests/ocean_column.h;
 * each within 1e-10 relative. Before the fix the melted particles'
 * fluxes left with them and the integrals fell short by their share. */
#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "core/model.h"
#include "core/ocean.h"
#include "io/ocean_fluxes.h"
#include "io/restart.h"
#include "lattice.h"
#include "ocean_column.h"
#include "ofx_plane.h"


static char dir[] = "/tmp/sphice-ofxmelt-XXXXXX";


/* Record 0 of name integrated over the file's water. */
static double oi(const char *path, const char *name) { return ofx_plane_integral(path, name, 0, NULL); }

static void rel_near(double got, double want, double tol, const char *what)
{
    double r = fabs(got - want) / fmax(fabs(want), 1e-300);
    CHECK(isfinite(got) && r <= tol, "%s: file %.12e, state %.12e (relative %.2e)", what, got, want, r);
    printf("%s: file %.12e, state %.12e (relative %.2e)\n", what, got, want, r);
}

int main(void)
{
    if (!mkdtemp(dir)) {
        perror("mkdtemp");
        return 1;
    }
    char path[1024];
    long to[3];
    sph_error err;
    sph_params p;
    const double T0[3] = {1.0, 1.0, 1.0};
    sph_model *m = oc_row_model(&p, 1800.0, T0);
    CHECK(m != NULL, "model");
    if (!m)
        return check_summary("test_ocean_fluxes_meltout");
    const int nl = p.thermo.nlayers;
    const sph_ocean_grid g = sph_model_ocean(m)->g;
    sph_ocean *o = sph_model_ocean(m);
    sph_particles *P = sph_model_particles(m);
    const double h0[4] = {0.02, 0.04, 0.08, 1.0};
    for (size_t k = 0; k < P->n; k++) {
        P->thick[k] = h0[k];
        P->mass[k] = p.rho_i * 0.9 * h0[k] * 2000.0 * 2000.0;
        P->uw[k] = 0.10; /* a current under the ice: stress to hand over too */
        P->vw[k] = 0.05;
        sph_thermo_init_particle(&p.thermo, P, k, -5.0);
    }
    oc_fill_atm(m, -5.0, 2e-3, 3.0, 0.0, 0.0, 250.0, 40.0);
    sph_status st;
    CHECK(sph_model_init(m, &st) == SPH_STEP_OK, "init: %s", st.what);
    const double area = 1e8, H = SPH_OCEAN_RHO_WATER * SPH_OCEAN_CP_WATER * 20.0;
    double E0 = 0.0, W0 = 0.0, S0 = 0.0, M0 = 0.0;
    for (size_t c = 0; c < 3; c++) {
        E0 += H * area * o->temp[c];
        W0 += o->water[c];
        S0 += o->salt[c];
    }
    for (size_t k = 0; k < P->n; k++)
        M0 += P->mass[k];
    const int nstep = 24;
    size_t n_mid = 0;
    for (int s = 0; s < nstep; s++) {
        CHECK(sph_model_step(m, &st) == SPH_STEP_OK, "step %d: %s %s", s, st.quantity, st.what);
        if (s == nstep / 2)
            n_mid = P->n;
    }
    CHECK(n_mid < 4 && P->n >= 1, "particles melt out in the middle of the record (%zu at 6 h, %zu at 12 h)", n_mid,
          P->n);
    double E1 = 0.0, W1 = 0.0, S1 = 0.0, M1 = 0.0, frz = 0.0;
    for (size_t c = 0; c < 3; c++) {
        E1 += H * area * o->temp[c];
        W1 += o->water[c];
        S1 += o->salt[c];
        frz += o->frazil[c];
        CHECK(o->temp[c] > 0.5, "cell %zu stays warm (%g C)", c, o->temp[c]);
    }
    for (size_t k = 0; k < P->n; k++)
        M1 += P->mass[k];
    CHECK(frz == 0.0, "no frazil (%g kg)", frz);
    const double sb = bl_mean_salinity(nl) / 1000.0;
    printf("slab: %.6e J, %.6e kg water, %.6e kg salt; ice %.6e kg; %zu particles left\n", E1 - E0, W1 - W0,
           S1 - S0, M1 - M0, P->n);
    CHECK(E1 - E0 < -1e12 && M1 - M0 < -1e6, "the record is not trivial: %g J, %g kg of ice melted", E1 - E0,
          M0 - M1);

    /* the file: a projected grid of 3 km cells, cell (5, 1) land */
    ofx_writer *w = ofx_plane_open(dir, path, sizeof path, to, &err);
    CHECK(w != NULL, "open: %s", err.msg);
    if (!w)
        return check_summary("test_ocean_fluxes_meltout");
    double rad[4], ia[4], iv[4], taux = 0.0, ctaux = 0.0;
    ofx_particles op = ofx_plane_particles(P, p.rho_i, rad, ia, iv, P->ofx_taux, P->ofx_tauy);
    for (size_t k = 0; k < P->n; k++)
        taux += P->ofx_taux[k];
    for (size_t c = 0; c < 3; c++)
        ctaux += o->ofx_taux[c];
    const double dt = nstep * p.dt;
    double lost[3];
    CHECK(ofx_add_particles(w, &op, &err) == SPH_OK, "particles: %s", err.msg);
    CHECK(ofx_add_ocean_cells(w, 3, to, NULL, o->ofx_heat, o->ofx_water, o->ofx_salt, o->ofx_heat_ice, o->ofx_taux,
                              o->ofx_tauy, o->ofx_swbase, dt, lost, &err) == SPH_OK,
          "cells: %s", err.msg);
    CHECK(lost[0] == 0.0 && lost[1] == 0.0 && lost[2] == 0.0, "nothing lost");
    CHECK(ofx_write_record(w, 1e9, 1e9 + dt, &err) == SPH_OK, "record: %s", err.msg);
    CHECK(ofx_close(w, &err) == SPH_OK, "close: %s", err.msg);

    double hf = oi(path, "hfds") * dt, hi = oi(path, "hfsithermds") * dt;
    double fw = oi(path, "siflfwbot") * dt, sa = oi(path, "siflsaltbot") * dt;
    rel_near(hf, E1 - E0, 1e-10, "hfds = the slab's enthalpy change");
    rel_near(fw + sa, W1 - W0, 1e-10, "siflfwbot + siflsaltbot = the slab's water change");
    rel_near(fw + sa, -(M1 - M0), 1e-10, "siflfwbot + siflsaltbot = minus the ice's mass change");
    rel_near(sa, S1 - S0, 1e-10, "siflsaltbot = the slab's salt change");
    rel_near(sa, -(M1 - M0) * sb, 1e-10, "siflsaltbot = minus the ice's mass change x S_i");
    CHECK(hi < 0.0 && hi >= hf * (1.0 + 1e-12), "hfsithermds is the under-ice part of hfds (%g of %g J)", hi, hf);
    /* the stress of the removed particles is in the record too */
    double tu = oi(path, "tauuo") * dt, su = oi(path, "sistrxubot") * dt;
    CHECK(ctaux != 0.0, "the melted particles' stress went to their cell (%g N s)", ctaux);
    rel_near(tu, taux + ctaux, 1e-10, "tauuo = the live particles' and the cells' stress");
    CHECK(fabs(su + tu) <= 1e-12 * fabs(tu), "sistrxubot = -tauuo");
    /* the removed particles' accumulators across a restart file, and a
     * file without them (all zero: not written) reads them as zero */
    restart_header rh;
    memset(&rh, 0, sizeof rh);
    snprintf(rh.projection, sizeof rh.projection, "+proj=test");
    char rpath[1100];
    snprintf(rpath, sizeof rpath, "%s/restart.nc", dir);
    sph_ocean *o2 = sph_ocean_create(&g, 64, 20.0, 32.0, 1.0);
    int found = 0;
    CHECK(o2 && restart_write_ocean(rpath, P, &rh, o, &err) == SPH_OK &&
              restart_read_ocean(rpath, o2, &found, &err) == SPH_OK && found,
          "restart: %s", err.msg);
    for (size_t c = 0; o2 && c < 3; c++)
        CHECK(o2->ofx_heat_ice[c] == o->ofx_heat_ice[c] && o2->ofx_taux[c] == o->ofx_taux[c] &&
                  o2->ofx_tauy[c] == o->ofx_tauy[c] && o2->ofx_swbase[c] == o->ofx_swbase[c],
              "restart: cell %zu's removed particles' accumulators read back", c);
    sph_ocean_clear_fluxes(o);
    CHECK(o2 && restart_write_ocean(rpath, P, &rh, o, &err) == SPH_OK &&
              restart_read_ocean(rpath, o2, &found, &err) == SPH_OK && o2->ofx_taux[2] == 0.0,
          "restart without them: %s", err.msg);
    sph_ocean_free(o2);
    unlink(rpath);
    CHECK(o->ofx_heat_ice[2] == 0.0 && o->ofx_taux[2] == 0.0 && o->ofx_water[2] == 0.0, "cleared");
    sph_model_free(m);
    unlink(path);
    rmdir(dir);
    return check_summary("test_ocean_fluxes_meltout");
}
