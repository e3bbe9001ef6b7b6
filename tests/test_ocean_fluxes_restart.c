/* The ocean-flux accumulators across a restart (docs/ocean-coupling.md):
 * a run stopped mid-interval, written to a restart file, read into a new
 * model and continued ends with the accumulators of the uninterrupted run
 * to the last bit, and with its trajectory. With output.ocean_fluxes off
 * the accumulators stay zero and the restart file holds none of them (so
 * it is the file written before they existed); a restart file without
 * them reads them as zero. */
#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "core/model.h"
#include "io/restart.h"
#include "lattice.h"

#define NX 12
#define NY 8
#define DX 1000.0

static char dir[] = "/tmp/sphice-ofxr-XXXXXX";

static void set_forcing(sph_particles *P)
{
    lattice_set_forcing(P, 4.0, 9.0, 0.15, -0.05, 0.0, 0.0);
    for (size_t k = 0; k < P->n; k++) {
        P->lat[k] = 40.0;
        P->tair[k] = -8.0;
        P->qair[k] = 1.0e-3;
        P->swdn[k] = 120.0;
        P->lwdn[k] = 220.0;
        P->sst[k] = NAN;
        P->fw[k] = 6.0;
        P->fsens[k] = P->flat[k] = NAN;
    }
}

static sph_model *fresh(const sph_params *p)
{
    sph_model *m = sph_model_create(p, NX * NY, NULL);
    if (!m)
        return NULL;
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, p, NX, NY, 0.0, 0.0, DX, 0.6, 0.85, 40.0);
    set_forcing(P);
    for (size_t k = 0; k < P->n; k++)
        sph_thermo_init_particle(&p->thermo, P, k, -8.0);
    sph_status st;
    if (sph_model_init(m, &st) != SPH_STEP_OK) {
        sph_model_free(m);
        return NULL;
    }
    return m;
}

static int steps(sph_model *m, int n)
{
    sph_status st;
    for (int s = 0; s < n; s++) {
        set_forcing(sph_model_particles(m));
        if (sph_model_step(m, &st) != SPH_STEP_OK) {
            fprintf(stderr, "step: %s %g %s\n", st.quantity, st.value, st.what);
            return -1;
        }
    }
    return 0;
}

static int has_var(const char *path, const char *name)
{
    int nc, v, ok = 0;
    if (nc_open(path, NC_NOWRITE, &nc) == NC_NOERR) {
        ok = nc_inq_varid(nc, name, &v) == NC_NOERR;
        nc_close(nc);
    }
    return ok;
}

#define SAME(field, count)                                                                        \
    CHECK(memcmp(A->field, B->field, (count) * sizeof *A->field) == 0, "%s identical after the restart", \
          #field)

static void run_case(int on)
{
    sph_params p;
    sph_params_default(&p);
    p.dt = 120.0;
    p.thermo_dt = 360.0;
    p.thermo.model = SPH_THERMO_AUTO;
    p.thermo.ocean_fluxes = on;
    const int total = 17, at = 7; /* mid-interval, between thermodynamic steps */
    sph_model *a = fresh(&p), *b = fresh(&p);
    CHECK(a && b, "models");
    if (!a || !b)
        return;
    CHECK(steps(a, total) == 0 && steps(b, at) == 0, "runs");
    char path[1024];
    snprintf(path, sizeof path, "%s/restart-%d.nc", dir, on);
    restart_header h;
    memset(&h, 0, sizeof h);
    h.time = 1000.0 + at * p.dt;
    h.cycle_time = 1000.0;
    snprintf(h.projection, sizeof h.projection, "+proj=test");
    sph_model_get_clock(b, &h.clock);
    sph_error err;
    sph_error_clear(&err);
    CHECK(restart_write(path, sph_model_particles(b), &h, &err) == SPH_OK, "write: %s", err.msg);
    sph_model_free(b);
    CHECK(has_var(path, "ofx_water") == on && has_var(path, "ofx_taux") == on && has_var(path, "coastc"),
          "restart file %s the accumulators (on = %d)", on ? "holds" : "leaves out", on);
    restart_header r;
    CHECK(restart_read_header(path, &r, &err) == SPH_OK, "header: %s", err.msg);
    sph_model *c = sph_model_create(&p, r.n, NULL);
    sph_particles *C = sph_model_particles(c);
    /* what reading must replace */
    for (size_t k = 0; k < C->cap; k++)
        C->ofx_water[k] = C->ofx_taux[k] = 7.0;
    CHECK(restart_read(path, "+proj=test", &r, C, &err) == SPH_OK, "read: %s", err.msg);
    sph_status st;
    CHECK(sph_model_resume(c, &r.clock, &st) == SPH_STEP_OK, "resume: %s", st.what);
    CHECK(steps(c, total - at) == 0, "continued run");
    const sph_particles *A = sph_model_particles(a), *B = C;
    CHECK(A->n == B->n, "particles %zu vs %zu", A->n, B->n);
    if (A->n == B->n) {
        size_t n = A->n;
        SAME(x, n);
        SAME(u, n);
        SAME(mass, n);
        SAME(enth, n * (size_t)A->nlayers);
        SAME(ofx_heat_ice, n);
        SAME(ofx_heat_lead, n);
        SAME(ofx_water, n);
        SAME(ofx_salt, n);
        SAME(ofx_taux, n);
        SAME(ofx_tauy, n);
        SAME(ofx_swbase, n);
        double s = 0.0;
        for (size_t k = 0; k < n; k++)
            s += fabs(A->ofx_taux[k]) + fabs(A->ofx_water[k]) + fabs(A->ofx_heat_ice[k]);
        if (on)
            CHECK(s > 0.0, "the accumulators hold something (%g)", s);
        else
            CHECK(s == 0.0, "off: the accumulators stay zero");
    }
    sph_model_free(a);
    sph_model_free(c);
}

int main(void)
{
    if (!mkdtemp(dir)) {
        perror("mkdtemp");
        return 1;
    }
    run_case(1);
    run_case(0);
    char cmd[256];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", dir);
    return check_summary("test_ocean_fluxes_restart");
}
