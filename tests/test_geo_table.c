/* Plane tables (io/geo.h geo_plane_table, domain.plane_tables): the
 * bilinear longitude, latitude and grid rotation against PROJ itself
 * (geo_inverse, geo_grid_angle) at random points, within the
 * interpolation bound computed here; points outside the table take PROJ's
 * own answer; a domain at a pole is refused. */
#include "io/geo.h"

#include "check.h"

static const double deg = M_PI / 180.0;

/* A small deterministic generator (no libc rand state). */
static double urand(unsigned long *s)
{
    *s = *s * 6364136223846793005UL + 1442695040888963407UL;
    return (double)(*s >> 11) / 9007199254740992.0;
}

static void test_accuracy(void)
{
    const double lon0 = 121.7, lat0 = 40.35, half = 150e3, h = 1e3, R = 6371e3;
    sph_error err;
    sph_error_clear(&err);
    geo_proj *p = geo_proj_create("aeqd", lon0, lat0, &err);
    CHECK(p != NULL, "projection: %s", err.msg);
    if (!p)
        return;
    geo_plane_table *t = geo_plane_table_create(p, -half, half, -half, half, h, &err);
    CHECK(t != NULL, "table: %s", err.msg);
    if (!t) {
        geo_proj_free(p);
        return;
    }
    /* Bilinear error <= h^2/8 (|f_xx| + |f_yy|) + h^2/4 |f_xy|. For aeqd
     * near the centre lat = lat0 + y/R - x^2 tan(lat0) / (2 R^2) + ... and
     * lon = lon0 + x / (R cos lat) (1 + y tan(lat0) / R) + ..., so in
     * metres along the meridian |f_xx| R = tan(lat0) / R and along the
     * parallel |f_xy| R cos(lat) = tan(lat0) / R: the bound is
     * 3/8 h^2 tan(lat0) / R, about 5 cm at h = 1 km; twice that for the
     * higher-order terms at 150 km. The grid angle (meridian convergence,
     * about (lon - lon0) sin(lat)) has |alpha_yy| ~ |alpha| / R^2: error
     * below h^2/8 * 0.05 / R^2 ~ 2e-10 rad; 1e-8 allows for PROJ's own
     * finite difference in geo_grid_angle (1e-9 rad). */
    double bound_m = 2.0 * 3.0 / 8.0 * h * h * tan(lat0 * deg) / R;
    enum { N = 20000 };
    static double x[N], y[N], lon[N], lat[N], cs[N], sn[N], rl[N], rp[N];
    unsigned long seed = 12345;
    for (int k = 0; k < N; k++) {
        x[k] = (2.0 * urand(&seed) - 1.0) * (half - 1.0);
        y[k] = (2.0 * urand(&seed) - 1.0) * (half - 1.0);
    }
    CHECK(geo_plane_lookup(t, N, x, y, lon, lat, cs, sn, &err) == SPH_OK, "lookup: %s", err.msg);
    CHECK(geo_inverse(p, N, x, y, rl, rp, &err) == SPH_OK, "inverse: %s", err.msg);
    double emax = 0.0, amax = 0.0, nmax = 0.0;
    for (int k = 0; k < N; k++) {
        double ex = (lon[k] - rl[k]) * deg * R * cos(rp[k] * deg), ey = (lat[k] - rp[k]) * deg * R;
        emax = fmax(emax, hypot(ex, ey));
        double a = geo_grid_angle(p, rl[k], rp[k]);
        amax = fmax(amax, fabs(atan2(sn[k], cs[k]) - a));
        nmax = fmax(nmax, fabs(hypot(cs[k], sn[k]) - 1.0));
    }
    CHECK(emax <= bound_m, "position error %.3g m above the bound %.3g m", emax, bound_m);
    CHECK(amax <= 1e-8, "grid angle error %.3g rad", amax);
    CHECK(nmax <= 1e-15, "rotation not orthonormal: |(cos, sin)| - 1 = %.3g", nmax);
    printf("geo_table: %d points, max position error %.3g m (bound %.3g), angle %.3g rad\n", N, emax,
           bound_m, amax);
    /* outside the table: exactly PROJ's answer */
    double xo[2] = {half + 5e3, 0.0}, yo[2] = {0.0, -half - 5e3}, lo[2], la[2], co[2], so[2], rlo[2], rla[2];
    CHECK(geo_plane_lookup(t, 2, xo, yo, lo, la, co, so, &err) == SPH_OK, "outside: %s", err.msg);
    geo_inverse(p, 2, xo, yo, rlo, rla, &err);
    for (int k = 0; k < 2; k++) {
        double a = geo_grid_angle(p, rlo[k], rla[k]);
        CHECK(lo[k] == rlo[k] && la[k] == rla[k] && co[k] == cos(a) && so[k] == sin(a),
              "outside point %d: not PROJ's answer", k);
    }
    geo_plane_table_free(t);
    geo_proj_free(p);
}

static void test_pole_refused(void)
{
    sph_error err;
    sph_error_clear(&err);
    geo_proj *p = geo_proj_create("polar", 0.0, 89.0, &err);
    CHECK(p != NULL, "polar projection: %s", err.msg);
    if (!p)
        return;
    geo_plane_table *t = geo_plane_table_create(p, -300e3, 300e3, -300e3, 300e3, 1e3, &err);
    CHECK(t == NULL && err.code != SPH_OK && strstr(err.msg, "pole") && strstr(err.msg, "domain.plane_tables"),
          "a table over the pole must be refused naming the key: %s", err.msg);
    geo_plane_table_free(t);
    /* "auto" (the default): the same domain takes PROJ, with no error and the reason */
    char why[1024];
    sph_error_clear(&err);
    t = geo_plane_table_auto(p, -300e3, 300e3, -300e3, 300e3, 1e3, why, sizeof why, &err);
    CHECK(t == NULL && err.code == SPH_OK && strstr(why, "pole"),
          "auto over the pole: no table, no error, the reason kept (code %d, why \"%s\")", err.code, why);
    /* and a domain the tables take gets one */
    t = geo_plane_table_auto(p, -300e3, 300e3, -2300e3, -1700e3, 1e3, why, sizeof why, &err);
    CHECK(t != NULL && err.code == SPH_OK && why[0] == '\0', "auto 2000 km from the pole: a table (%s)", err.msg);
    geo_plane_table_free(t);
    geo_proj_free(p);
}

int main(void)
{
    test_accuracy();
    test_pole_refused();
    return check_summary("test_geo_table");
}
