/* The mixed layer's open water in the fluxes file (issue 20 item 4 with
 * item 1; docs/ocean-coupling.md): a row of three 10 km cells of the slab
 * under -20 C air, dark, longwave 180 W/m^2, wind (5, 5), q 6e-4: cell 0
 * at +2 C cools without freezing, cell 1 at its freezing point forms
 * frazil, cell 2 holds four ice particles. Over a 6 h record:
 *  - the open water's accumulators of cells 0 and 1 equal the slab's own
 *    changes (rho_w c_w d T x sea area, water, salt) and the slab written
 *    out here from the bulk formula (tests/ocean_column.h): heat lost at
 *    F(T) while above freezing; at the freezing point no heat, the
 *    frazil's water and salt (deficit over -q_new of new ice);
 *  - regridded onto a projected file grid of 3 km cells by the cell
 *    containing each slab cell's centre (cell 1's on land: the nearest
 *    water cell), the file's area integral of hfds, siflfwbot and
 *    siflsaltbot equals the particles' plus the cells' totals within
 *    1e-10 relative, and the receiving file cells hold the slab's changes;
 *  - sph_ocean_clear_fluxes zeroes the accumulators. */
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
#include "lattice.h"
#include "ocean_column.h"
#include "ofx_plane.h"


/* |got - want| <= tol (absolute), with a printf-style message */
#define NEAR(got, want, tol, ...)                                                          \
    do {                                                                                  \
        double g_ = (got), w_ = (want);                                                   \
        CHECK(isfinite(g_) && fabs(g_ - w_) <= (tol), __VA_ARGS__);                       \
        if (!(fabs(g_ - w_) <= (tol)))                                                    \
            fprintf(stderr, "  got %.15g want %.15g (tol %.3g)\n", g_, w_, (double)(tol)); \
    } while (0)

static char dir[] = "/tmp/sphice-ofxm-XXXXXX";


int main(void)
{
    if (!mkdtemp(dir)) {
        perror("mkdtemp");
        return 1;
    }
    sph_params p;
    const double Tf = -0.054 * 32.0, T0[3] = {2.0, Tf, Tf};
    sph_model *m = oc_row_model(&p, 3600.0, T0);
    CHECK(m != NULL, "model");
    if (!m)
        return check_summary("test_ocean_fluxes_mixed");
    const int nl = p.thermo.nlayers;
    sph_ocean *o = sph_model_ocean(m);
    sph_particles *P = sph_model_particles(m);
    for (size_t k = 0; k < P->n; k++)
        sph_thermo_init_particle(&p.thermo, P, k, -20.0);
    const double ta = -20.0, q = 6e-4, ua = 5.0, va = 5.0, lw = 180.0;
    oc_fill_atm(m, ta, q, ua, va, 0.0, lw, 40.0);
    sph_status st;
    CHECK(sph_model_init(m, &st) == SPH_STEP_OK, "init: %s", st.what);
    const double area = 1e8, H = SPH_OCEAN_RHO_WATER * SPH_OCEAN_CP_WATER * 20.0;
    double E0[3], W0[3], S0[3];
    for (size_t c = 0; c < 3; c++) {
        E0[c] = H * area * o->temp[c];
        W0[c] = o->water[c];
        S0[c] = o->salt[c];
    }
    /* the slab written out, per m^2 */
    oc_slab sl[2] = {{2.0, 1026.0 * 20.0, 1026.0 * 20.0 * 32.0 / 1000.0, H},
                     {Tf, 1026.0 * 20.0, 1026.0 * 20.0 * 32.0 / 1000.0, H}};
    double frz[2] = {0.0, 0.0};
    const int nstep = 6;
    for (int s = 0; s < nstep; s++) {
        CHECK(sph_model_step(m, &st) == SPH_STEP_OK, "step %d: %s %s", s, st.quantity, st.what);
        for (int c = 0; c < 2; c++)
            frz[c] += oc_slab_step(&sl[c], ow_flux(sl[c].T, ta, q, hypot(ua, va), 0.0, lw), 3600.0, nl);
    }
    CHECK(P->n == 4, "the particles stay (%zu)", P->n);
    CHECK(o->temp[0] > Tf + 0.5 && frz[0] == 0.0, "cell 0 stays above freezing (%g C)", o->temp[0]);
    CHECK(frz[1] > 0.0 && o->frazil[1] > 0.0, "cell 1 forms frazil (%g kg)", o->frazil[1]);
    /* 1. the accumulators: the slab's own change, and the formulas' */
    const double sb = bl_mean_salinity(nl) / 1000.0;
    double want_e[2], want_w[2], want_s[2];
    for (int c = 0; c < 2; c++) {
        want_e[c] = H * (sl[c].T - T0[c]) * area;
        want_w[c] = -frz[c] * area;
        want_s[c] = -frz[c] * sb * area;
    }
    for (int c = 0; c < 2; c++) {
        NEAR(o->ofx_heat[c], H * area * o->temp[c] - E0[c], 1e-10 * fabs(E0[0] - H * area * o->temp[0]) + 1e-3, "cell %d heat = slab enthalpy change", c);
        NEAR(o->ofx_water[c], o->water[c] - W0[c], 1e-12 * W0[c], "cell %d water = slab water change", c);
        NEAR(o->ofx_salt[c], o->salt[c] - S0[c], 1e-12 * S0[c], "cell %d salt = slab salt change", c);
        NEAR(o->ofx_heat[c], want_e[c], 1e-9 * fabs(want_e[0]), "cell %d heat against the bulk formula", c);
        NEAR(o->ofx_water[c], want_w[c], 1e-9 * fabs(want_w[1]), "cell %d water against the frazil formula", c);
        NEAR(o->ofx_salt[c], want_s[c], 1e-9 * fabs(want_s[1]), "cell %d salt against the frazil formula", c);
    }
    CHECK(want_e[0] < -1e12 && want_w[1] < -1e5, "the record is not trivial: %g J, %g kg", want_e[0], want_w[1]);
    printf("cell 0: %.6e J (bulk formula %.6e); cell 1: water %.6e kg (frazil formula %.6e), heat %.3e J\n",
           o->ofx_heat[0], want_e[0], o->ofx_water[1], want_w[1], o->ofx_heat[1]);
    /* 2. the file: a projected grid of 3 km cells, cell (5, 1) land */
    char path[1024];
    long to[3];
    sph_error err;
    ofx_writer *w = ofx_plane_open(dir, path, sizeof path, to, &err);
    CHECK(w != NULL, "open: %s", err.msg);
    if (!w)
        return check_summary("test_ocean_fluxes_mixed");
    CHECK(to[0] == 1 * NXG + 1, "cell 0's centre (5, 5) km is in file cell (1, 1): %ld", to[0]);
    CHECK(to[1] == 1 * NXG + 4, "cell 1's centre (15, 5) km is on land: nearest water (4, 1): %ld", to[1]);
    CHECK(to[2] == 1 * NXG + 8, "cell 2's centre (25, 5) km is in (8, 1): %ld", to[2]);
    CHECK(ofx_locate(w, NAN, NAN, 1e6, 5000.0, 1e4) == -1, "far outside: none");
    double rad[4], tx[4] = {0}, ty[4] = {0}, ia[4], iv[4], sp_e = 0.0, sp_w = 0.0, sp_s = 0.0;
    ofx_particles op = ofx_plane_particles(P, p.rho_i, rad, ia, iv, tx, ty);
    for (size_t k = 0; k < P->n; k++) {
        sp_e += P->ofx_heat_ice[k] + P->ofx_heat_lead[k];
        sp_w += P->ofx_water[k];
        sp_s += P->ofx_salt[k];
    }
    const double dt = nstep * 3600.0;
    double lost[3];
    CHECK(ofx_add_particles(w, &op, &err) == SPH_OK, "particles: %s", err.msg);
    CHECK(ofx_add_cell_amounts(w, OFX_HFDS, 3, to, o->ofx_heat, dt, &lost[0], &err) == SPH_OK &&
              ofx_add_cell_amounts(w, OFX_SIFLFWBOT, 3, to, o->ofx_water, dt, &lost[1], &err) == SPH_OK &&
              ofx_add_cell_amounts(w, OFX_SIFLSALTBOT, 3, to, o->ofx_salt, dt, &lost[2], &err) == SPH_OK,
          "cells: %s", err.msg);
    CHECK(lost[0] == 0.0 && lost[1] == 0.0 && lost[2] == 0.0, "nothing lost");
    CHECK(ofx_write_record(w, 1e9, 1e9 + dt, &err) == SPH_OK, "record: %s", err.msg);
    CHECK(ofx_close(w, &err) == SPH_OK, "close: %s", err.msg);
    double ce = 0.0, cw = 0.0, cs = 0.0;
    for (size_t c = 0; c < 3; c++) {
        ce += o->ofx_heat[c];
        cw += o->ofx_water[c];
        cs += o->ofx_salt[c];
    }
    CHECK(sp_w != 0.0 && cw != 0.0, "particles and cells both give water: %g, %g kg", sp_w, cw);
    const char *names[3] = {"hfds", "siflfwbot", "siflsaltbot"};
    const double tot[3] = {sp_e + ce, sp_w + cw, sp_s + cs};
    const double cell0[3] = {H * area * o->temp[0] - E0[0], o->water[0] - W0[0], o->salt[0] - S0[0]};
    const double cell1[3] = {H * area * o->temp[1] - E0[1], o->water[1] - W0[1], o->salt[1] - S0[1]};
    for (int f = 0; f < 3; f++) {
        double a0 = NAN, a1 = NAN;
        double s = ofx_plane_integral(path, names[f], (size_t)to[0], &a0) * dt;
        ofx_plane_integral(path, names[f], (size_t)to[1], &a1);
        a0 *= dt;
        a1 *= dt;
        printf("%s: file %.12e, particles + cells %.12e\n", names[f], s, tot[f]);
        NEAR(s, tot[f], 1e-10 * fabs(tot[f]), "%s: the file's integral = the particles' + the cells'", names[f]);
        double scale = fabs(cell0[f]) + fabs(cell1[f]);
        NEAR(a0, cell0[f], 1e-10 * scale, "%s: file cell of slab cell 0 = its change", names[f]);
        NEAR(a1, cell1[f], 1e-10 * scale, "%s: file cell of slab cell 1 = its change", names[f]);
    }
    sph_ocean_clear_fluxes(o);
    CHECK(o->ofx_heat[0] == 0.0 && o->ofx_water[1] == 0.0 && o->ofx_salt[1] == 0.0, "cleared");
    sph_model_free(m);
    unlink(path);
    rmdir(dir);
    return check_summary("test_ocean_fluxes_mixed");
}
