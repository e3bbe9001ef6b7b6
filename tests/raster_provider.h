/* Shared by the provider tests of the initial raster (tests/test_raster_*.c):
 * Snyder's (1987) forward formulas and the ice a raster holds. */
#ifndef SPHICE_TESTS_RASTER_PROVIDER_H
#define SPHICE_TESTS_RASTER_PROVIDER_H

#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <string.h>

#include "io/raster.h"
#include "io/seed.h"
#include "check.h"

static const double RP_DEG = M_PI / 180;

static inline void rp_text(int ncid, int v, const char *att, const char *text)
{
    nc_put_att_text(ncid, v, att, strlen(text), text);
}
static inline void rp_num(int ncid, int v, const char *att, double x)
{
    nc_put_att_double(ncid, v, att, NC_DOUBLE, 1, &x);
}

/* polar stereographic north, ellipsoid (a, b), true scale at latc (Snyder eq. 21-33..21-35, 21-32) */
static inline double rp_ps_t(double phi, double e)
{
    double s = sin(phi);
    return tan(M_PI / 4 - phi / 2) / pow((1 - e * s) / (1 + e * s), e / 2);
}
static inline double rp_ps_m(double phi, double e) { return cos(phi) / sqrt(1 - e * e * sin(phi) * sin(phi)); }
static inline void rp_ps_forward(double a, double b, double latc, double lon0, double lon, double lat,
                          double *x, double *y, double *k)
{
    double e = sqrt(1 - b * b / (a * a)), phi = lat * RP_DEG, pc = latc * RP_DEG;
    double rho = a * rp_ps_m(pc, e) * rp_ps_t(phi, e) / rp_ps_t(pc, e);
    *x = rho * sin((lon - lon0) * RP_DEG);
    *y = -rho * cos((lon - lon0) * RP_DEG);
    *k = rho / (a * rp_ps_m(phi, e));
}
/* its inverse (Snyder eq. 21-39 for t, 7-9 iterated for phi, 20-16 for lon) */
static inline void rp_ps_inverse(double a, double b, double latc, double lon0, double x, double y,
                                 double *lon, double *lat)
{
    double e = sqrt(1 - b * b / (a * a)), pc = latc * RP_DEG;
    double rho = hypot(x, y), t = rho * rp_ps_t(pc, e) / (a * rp_ps_m(pc, e));
    double phi = M_PI / 2 - 2 * atan(t);
    for (int it = 0; it < 100; it++) {
        double s = sin(phi);
        double next = M_PI / 2 - 2 * atan(t * pow((1 - e * s) / (1 + e * s), e / 2));
        if (fabs(next - phi) < 1e-15) {
            phi = next;
            break;
        }
        phi = next;
    }
    *lat = phi / RP_DEG;
    *lon = remainder(lon0 + atan2(x, -y) / RP_DEG, 360.0);
}
/* polar Lambert azimuthal equal-area north, ellipsoid (a, 1/rf) (eq. 3-12, 21-18/19, 24-...) */
static inline double rp_q(double phi, double e)
{
    double s = sin(phi);
    return (1 - e * e) * (s / (1 - e * e * s * s) - 1 / (2 * e) * log((1 - e * s) / (1 + e * s)));
}
static inline void rp_laea_forward(double a, double rf, double lon0, double lon, double lat, double *x,
                            double *y)
{
    double f = 1 / rf, e = sqrt(2 * f - f * f);
    double rho = a * sqrt(rp_q(M_PI / 2, e) - rp_q(lat * RP_DEG, e));
    *x = rho * sin((lon - lon0) * RP_DEG);
    *y = -rho * cos((lon - lon0) * RP_DEG);
}

/* Reads path with o (NULL: defaults), checked to succeed; NULL on failure. */
static inline ice_raster *rp_read(const char *what, const char *path, const ice_raster_options *o)
{
    ice_raster *r = NULL;
    sph_error err;
    sph_error_clear(&err);
    CHECK(ice_raster_read(path, o, &r, &err) == SPH_OK && r, "%s: %s", what, err.msg);
    return r;
}

/* Reading path with o must fail with one line naming the file and needle,
 * and give no raster. */
static inline void rp_refused(const char *what, const char *path, const ice_raster_options *o,
                              const char *needle)
{
    ice_raster *r = NULL;
    sph_error err;
    sph_error_clear(&err);
    int rc = ice_raster_read(path, o, &r, &err);
    CHECK(rc != SPH_OK && !r && strstr(err.msg, path) && strstr(err.msg, needle) &&
              !strchr(err.msg, '\n'),
          "%s: rc %d, \"%s\" (want one line naming the file and \"%s\")", what, rc, err.msg, needle);
    printf("refused as wanted (%s): %s\n", what, err.msg);
    ice_raster_free(r);
}

/* Seeds r per cell and compares the seeded ice area and volume with
 * want_area / want_vol (m^2, m^3) within 1 %. */
static inline void rp_check_seeded(const char *what, const ice_raster *r, double want_area,
                            double want_vol, double threshold)
{
    sph_error err;
    sph_error_clear(&err);
    double lon0, lat0;
    ice_raster_cell_lonlat(r, r->nlon / 2, r->nlat / 2, &lon0, &lat0);
    geo_proj *p = geo_proj_create("auto", lon0, lat0, &err);
    seed_options so;
    seed_options_default(&so);
    so.threshold = threshold;
    size_t n = 0;
    CHECK(seed_count(r, p, NULL, &so, &n, &err) == SPH_OK && n > 0, "%s: count %zu: %s", what, n,
          err.msg);
    sph_particles *P = sph_particles_create(n + 1, 1);
    CHECK(seed_from_raster(r, p, NULL, &so, P, &err) == SPH_OK, "%s: seed: %s", what, err.msg);
    double area = 0, vol = 0;
    for (size_t q = 0; q < P->n; q++) {
        vol += P->mass[q] / so.rho_ice;
        area += P->mass[q] / (so.rho_ice * P->thick[q]);
    }
    CHECK(fabs(area / want_area - 1) < 0.01, "%s: seeded ice area %g km2, raster %g km2", what,
          area / 1e6, want_area / 1e6);
    CHECK(fabs(vol / want_vol - 1) < 0.01, "%s: seeded ice volume %g km3, raster %g km3", what,
          vol / 1e9, want_vol / 1e9);
    sph_particles_free(P);
    geo_proj_free(p);
}

#endif
