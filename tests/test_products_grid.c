/* Particles to the output grid through the core's normalised SPH
 * interpolation (sph_model_interpolate), as the engine does, then through
 * the products writer: the ice volume on the grid equals the particles'
 * (within 1 %) and a uniform lattice gives uniform fields away from the
 * edge. The grid sits on the equator, where the local plane x = R lon,
 * y = R lat matches the sphere to 5e-5 over the domain. */
#include <dirent.h>
#include <math.h>
#include <stdlib.h>
#include <unistd.h>

#include "check.h"
#include "core/model.h"
#include "io/products.h"
#include "lattice.h"

#define R_M 6371000.0
#define D2R (M_PI / 180)

static void rm_dir(const char *dir)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    char p[1024];
    while (d && (e = readdir(d)))
        if (e->d_name[0] != '.') {
            snprintf(p, sizeof p, "%s/%s", dir, e->d_name);
            unlink(p);
        }
    if (d)
        closedir(d);
    rmdir(dir);
}

int main(void)
{
    sph_params prm;
    sph_params_default(&prm);
    int nside = check_quick() ? 20 : 40;
    double dx = 2000.0, h_i = 0.3, A = 0.9;
    sph_model *m = sph_model_create(&prm, (size_t)nside * nside, NULL);
    CHECK(m != NULL, "model");
    if (!m)
        return check_summary("test_products_grid");
    sph_particles *P = sph_model_particles(m);
    double x0 = -0.5 * (nside - 1) * dx;
    lattice_fill(P, &prm, nside, nside, x0, x0, dx, h_i, A, 0.0);
    sph_status st;
    CHECK(sph_model_init(m, &st) == 0, "init");
    double vol_particles = 0;
    for (size_t k = 0; k < P->n; k++)
        vol_particles += P->mass[k] / prm.rho_i;

    /* 1 km grid reaching 20 km beyond the lattice */
    double half = -x0 + 20000.0, cell = 1000.0;
    prod_grid g;
    g.nlon = g.nlat = (int)(2 * half / cell) + 1;
    g.dlon = g.dlat = cell / (R_M * D2R);
    g.lon0 = g.lat0 = -half / (R_M * D2R);
    size_t nn = (size_t)g.nlon * g.nlat;
    double *px = malloc(nn * sizeof *px), *py = malloc(nn * sizeof *py);
    double *conc = malloc(nn * sizeof *conc), *thick = malloc(nn * sizeof *thick);
    double *dens = malloc(nn * sizeof *dens), *hbar = malloc(nn * sizeof *hbar);
    for (int j = 0; j < g.nlat; j++)
        for (int i = 0; i < g.nlon; i++) {
            size_t k = (size_t)j * g.nlon + i;
            px[k] = R_M * (g.lon0 + i * g.dlon) * D2R;
            py[k] = R_M * (g.lat0 + j * g.dlat) * D2R;
        }
    const double *fields[2] = { P->conc, P->thick };
    double *out[2] = { conc, thick };
    CHECK(sph_model_interpolate(m, nn, px, py, 2, fields, out, dens) == 0, "interpolate");
    for (size_t k = 0; k < nn; k++)
        hbar[k] = dens[k] / prm.rho_i; /* volume per area from the mass density */

    /* uniform away from the edge: 3 smoothing lengths inside the lattice */
    double inner = -x0 - 3 * prm.sml_factor * dx * fmax(prm.kernel_radius, 1.0);
    int bad_c = 0, bad_h = 0, bad_hb = 0, ninner = 0;
    for (size_t k = 0; k < nn; k++) {
        if (fabs(px[k]) > inner || fabs(py[k]) > inner)
            continue;
        ninner++;
        bad_c += fabs(conc[k] - A) > 1e-9;
        bad_h += fabs(thick[k] - h_i) > 1e-9;
        bad_hb += fabs(hbar[k] - A * h_i) > 0.01 * A * h_i;
    }
    CHECK(ninner > (check_quick() ? 0 : 100), "interior points %d", ninner);
    CHECK(bad_c == 0 && bad_h == 0, "normalised interpolation uniform: %d conc, %d thick off",
          bad_c, bad_h);
    CHECK(bad_hb == 0, "mean thickness uniform within 1 %% inside: %d off", bad_hb);

    /* through the writer: volume on the grid = particles' volume */
    char dir[] = "/tmp/sphice-pgrid-XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    prod_options o;
    products_options_default(&o);
    prod_meta meta = { 0 };
    meta.cycle_time = 0;
    prod_writer *w = NULL;
    sph_error err;
    sph_error_clear(&err);
    CHECK(products_open(&w, &o, &g, &meta, dir, &err) == SPH_OK, "%s", err.msg);
    prod_fields f = { conc, hbar, thick, NULL, NULL, NULL, NULL, NULL, NULL, NULL };
    prod_summary sum;
    if (w) {
        CHECK(products_add_time(w, 0.0, &f, NULL, &err) == SPH_OK, "%s", err.msg);
        CHECK(products_close(w, &sum, &err) == SPH_OK, "%s", err.msg);
        CHECK_CLOSE(sum.ice_volume_km3, vol_particles * 1e-9, 0.01, 0,
                    "grid ice volume vs particles");
        /* the normalised concentration keeps its value out to the kernel
         * support, so the area is at least A times the lattice footprint */
        CHECK(sum.ice_area_km2 >= A * P->n * dx * dx * 1e-6, "ice area %g km2", sum.ice_area_km2);
    }
    rm_dir(dir);
    free(px);
    free(py);
    free(conc);
    free(thick);
    free(dens);
    free(hbar);
    sph_model_free(m);
    return check_summary("test_products_grid");
}
