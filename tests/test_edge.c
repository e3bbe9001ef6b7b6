/* Ice edge by marching squares on analytic fields (io/edge.h). */
#include <math.h>
#include <stdlib.h>

#include "check.h"
#include "io/edge.h"

#define R_EARTH 6371000.0

static double signed_area(const edge_line *l)
{
    double a = 0;
    for (size_t p = 0; p + 1 < l->npts; p++)
        a += l->lon[p] * l->lat[p + 1] - l->lon[p + 1] * l->lat[p];
    return 0.5 * a;
}

/* Disc of ice: concentration falls linearly with radius through the
 * threshold at r = R, so the contour is the circle of radius R. */
static void test_disc(void)
{
    prod_grid g = { 101, 81, 120.0, 38.0, 0.05, 0.05 };
    double *c = malloc(sizeof(double) * g.nlon * g.nlat);
    double cx = 120.0 + 50.3 * g.dlon, cy = 38.0 + 40.6 * g.dlat, R = 25 * g.dlon;
    for (int j = 0; j < g.nlat; j++)
        for (int i = 0; i < g.nlon; i++) {
            double x = g.lon0 + i * g.dlon - cx, y = g.lat0 + j * g.dlat - cy;
            double v = 0.15 + (R - hypot(x, y)) / (10 * g.dlon);
            c[j * g.nlon + i] = fmin(1.0, fmax(0.0, v));
        }
    edge_set e;
    sph_error err;
    sph_error_clear(&err);
    CHECK(edge_extract(&g, c, NULL, 0.15, &e, &err) == SPH_OK, "%s", err.msg);
    CHECK(e.nlines == 1, "disc gives %zu lines", e.nlines);
    if (e.nlines == 1) {
        const edge_line *l = &e.lines[0];
        CHECK(l->closed, "disc edge is closed");
        CHECK(l->lon[0] == l->lon[l->npts - 1] && l->lat[0] == l->lat[l->npts - 1],
              "ring repeats its first point");
        double worst = 0;
        for (size_t p = 0; p < l->npts; p++)
            worst = fmax(worst, fabs(hypot(l->lon[p] - cx, l->lat[p] - cy) - R));
        CHECK(worst < 0.5 * g.dlon, "radius error %g deg >= half a cell", worst);
        /* ice on the left: counter-clockwise around the ice */
        double a = signed_area(l);
        CHECK(a > 0, "ring is counter-clockwise (area %g)", a);
        CHECK_CLOSE(a, M_PI * R * R, 0, 2 * M_PI * R * 0.5 * g.dlon, "enclosed area");
        CHECK(l->npts > 100, "ring has %zu points", l->npts);
    }
    edge_set_free(&e);

    /* The complement (a hole of water in ice) gives a clockwise ring. */
    for (int k = 0; k < g.nlon * g.nlat; k++)
        c[k] = 0.3 - c[k]; /* c' >= 0.15 where c <= 0.15: crossing stays at r = R */
    CHECK(edge_extract(&g, c, NULL, 0.15, &e, &err) == SPH_OK, "%s", err.msg);
    CHECK(e.nlines == 1, "hole gives %zu lines", e.nlines);
    if (e.nlines == 1) {
        const edge_line *l = &e.lines[0];
        CHECK(l->closed && signed_area(l) < 0, "water hole in ice gives a clockwise ring");
        double worst = 0;
        for (size_t p = 0; p < l->npts; p++)
            worst = fmax(worst, fabs(hypot(l->lon[p] - cx, l->lat[p] - cy) - R));
        CHECK(worst < 0.5 * g.dlon, "hole radius error %g deg", worst);
    }
    edge_set_free(&e);
    free(c);
}

/* A step in longitude and a linear ramp along a diagonal: straight lines. */
static void test_straight(void)
{
    prod_grid g = { 60, 50, 118.0, 37.0, 0.1, 0.1 };
    size_t nn = (size_t)g.nlon * g.nlat;
    double *c = malloc(sizeof(double) * nn);
    for (int j = 0; j < g.nlat; j++)
        for (int i = 0; i < g.nlon; i++)
            c[j * g.nlon + i] = i < 40 ? 1.0 : 0.0;
    edge_set e;
    sph_error err;
    sph_error_clear(&err);
    CHECK(edge_extract(&g, c, NULL, 0.15, &e, &err) == SPH_OK, "%s", err.msg);
    CHECK(e.nlines == 1, "step gives %zu lines", e.nlines);
    double want_lon = g.lon0 + (39 + 0.85) * g.dlon; /* 1 -> 0 crosses 0.15 at 85 % */
    double top = g.lat0 + (g.nlat - 1) * g.dlat;
    if (e.nlines == 1) {
        const edge_line *l = &e.lines[0];
        CHECK(!l->closed, "step edge is open");
        CHECK(l->npts == (size_t)g.nlat, "one point per row: %zu", l->npts);
        double worst = 0;
        for (size_t p = 0; p < l->npts; p++)
            worst = fmax(worst, fabs(l->lon[p] - want_lon));
        CHECK(worst < 1e-9, "straight: lon off by %g", worst);
        /* ice (west) on the left: the line runs south to north */
        CHECK_CLOSE(l->lat[0], g.lat0, 0, 1e-9, "starts at the south boundary");
        CHECK_CLOSE(l->lat[l->npts - 1], top, 0, 1e-9, "ends at the north boundary");
        /* a meridian arc: length R * dlat */
        double want_km = R_EARTH * (top - g.lat0) * M_PI / 180 / 1000;
        CHECK_CLOSE(edge_length_km(&e), want_km, 1e-9, 0, "meridian edge length");
    }
    edge_set_free(&e);

    /* Land strip along the south: the edge stops at the coast and the
     * coast itself is no ice edge. */
    unsigned char *land = calloc(nn, 1);
    for (int j = 0; j < 5; j++)
        for (int i = 0; i < g.nlon; i++)
            land[j * g.nlon + i] = 1;
    CHECK(edge_extract(&g, c, land, 0.15, &e, &err) == SPH_OK, "%s", err.msg);
    CHECK(e.nlines == 1, "land: %zu lines", e.nlines);
    if (e.nlines == 1) {
        const edge_line *l = &e.lines[0];
        double worst = 0, minlat = 1e9;
        for (size_t p = 0; p < l->npts; p++) {
            worst = fmax(worst, fabs(l->lon[p] - want_lon));
            minlat = fmin(minlat, l->lat[p]);
        }
        CHECK(worst < 1e-9, "land: edge still straight (%g)", worst);
        CHECK(minlat >= g.lat0 + 5 * g.dlat - 1e-9, "land: edge stays off the land (%g)", minlat);
        CHECK(!l->closed, "land: open line");
    }
    edge_set_free(&e);
    free(land);

    /* Diagonal linear ramp c = a (i + j) + b: contour i + j = const exactly. */
    for (int j = 0; j < g.nlat; j++)
        for (int i = 0; i < g.nlon; i++)
            c[j * g.nlon + i] = 0.02 * (i + j) - 0.5; /* 0.15 at i + j = 32.5 */
    CHECK(edge_extract(&g, c, NULL, 0.15, &e, &err) == SPH_OK, "%s", err.msg);
    CHECK(e.nlines == 1, "diagonal: %zu lines", e.nlines);
    if (e.nlines == 1) {
        double worst = 0;
        const edge_line *l = &e.lines[0];
        for (size_t p = 0; p < l->npts; p++) {
            double s = (l->lon[p] - g.lon0) / g.dlon + (l->lat[p] - g.lat0) / g.dlat;
            worst = fmax(worst, fabs(s - 32.5));
        }
        CHECK(worst < 1e-6, "diagonal: off the line by %g cells", worst);
    }
    edge_set_free(&e);
    free(c);
}

/* A value exactly at the threshold is ice (c >= thr), just below is not. */
static void test_threshold_rule(void)
{
    prod_grid g = { 30, 30, 0.0, 0.0, 1.0, 1.0 };
    double c[900];
    for (int k = 0; k < 900; k++)
        c[k] = 0.0;
    for (int j = 10; j < 20; j++)
        for (int i = 10; i < 20; i++)
            c[j * 30 + i] = 0.15;
    edge_set e;
    sph_error err;
    sph_error_clear(&err);
    CHECK(edge_extract(&g, c, NULL, 0.15, &e, &err) == SPH_OK, "%s", err.msg);
    CHECK(e.nlines == 1 && e.lines[0].closed, "block at threshold: one ring (%zu)", e.nlines);
    if (e.nlines == 1) {
        /* the ring hugs the block of nodes [10,19]^2 (within 1e-5 cell) */
        double worst = 0;
        const edge_line *l = &e.lines[0];
        for (size_t p = 0; p < l->npts; p++) {
            double dx = fmax(fmax(10 - l->lon[p], l->lon[p] - 19), 0);
            double dy = fmax(fmax(10 - l->lat[p], l->lat[p] - 19), 0);
            worst = fmax(worst, fmax(dx, dy));
        }
        CHECK(worst < 1e-5, "ring hugs the at-threshold block (%g)", worst);
    }
    edge_set_free(&e);
    for (int k = 0; k < 900; k++)
        if (c[k] > 0)
            c[k] = nextafter(0.15, 0.0);
    CHECK(edge_extract(&g, c, NULL, 0.15, &e, &err) == SPH_OK, "%s", err.msg);
    CHECK(e.nlines == 0, "just below threshold: no edge (%zu)", e.nlines);
    edge_set_free(&e);

    /* Saddle: ice on one diagonal. Mean >= thr joins the ice (one ring
     * around both cells), mean < thr separates them (two rings). */
    double s[16] = { 0 };
    prod_grid g4 = { 4, 4, 0, 0, 1, 1 };
    s[1 * 4 + 1] = 1.0;
    s[2 * 4 + 2] = 1.0; /* mean of the central square = 0.5 >= 0.15 */
    CHECK(edge_extract(&g4, s, NULL, 0.15, &e, &err) == SPH_OK, "%s", err.msg);
    CHECK(e.nlines == 1, "saddle joined: %zu lines", e.nlines);
    edge_set_free(&e);
    s[1 * 4 + 1] = 0.2;
    s[2 * 4 + 2] = 0.2; /* mean 0.1 < 0.15 */
    CHECK(edge_extract(&g4, s, NULL, 0.15, &e, &err) == SPH_OK, "%s", err.msg);
    CHECK(e.nlines == 2, "saddle split: %zu lines", e.nlines);
    edge_set_free(&e);
}

/* Distance of the outermost edge point: spherical law of cosines. */
static double cosine_law_m(double lon1, double lat1, double lon2, double lat2)
{
    double d2r = M_PI / 180;
    double c = sin(lat1 * d2r) * sin(lat2 * d2r) +
               cos(lat1 * d2r) * cos(lat2 * d2r) * cos((lon2 - lon1) * d2r);
    return R_EARTH * acos(fmin(1.0, c));
}

static void test_distance_and_area(void)
{
    /* Ice south of a latitude line; reference point below the middle. */
    prod_grid g = { 41, 31, 120.0, 38.0, 0.05, 0.05 };
    double *c = malloc(sizeof(double) * g.nlon * g.nlat);
    for (int j = 0; j < g.nlat; j++)
        for (int i = 0; i < g.nlon; i++)
            c[j * g.nlon + i] = j <= 20 ? 0.9 : 0.0;
    edge_set e;
    sph_error err;
    sph_error_clear(&err);
    CHECK(edge_extract(&g, c, NULL, 0.15, &e, &err) == SPH_OK, "%s", err.msg);
    double edge_lat = g.lat0 + (20 + (0.9 - 0.15) / 0.9) * g.dlat;
    double ref_lon = 121.0, ref_lat = 38.0;
    /* farthest edge points are the two ends (same distance by symmetry) */
    double want = cosine_law_m(ref_lon, ref_lat, g.lon0, edge_lat) / 1852.0;
    CHECK_CLOSE(edge_max_distance_nm(&e, ref_lon, ref_lat), want, 1e-6, 0, "edge distance nm");
    edge_set_free(&e);
    edge_set none = { 0, NULL, 0 };
    CHECK(isnan(edge_max_distance_nm(&none, 0, 0)), "no edge: NaN distance");
    free(c);

    /* Cell areas of a global grid add up to the sphere. */
    prod_grid gl = { 360, 180, -179.5, -89.5, 1.0, 1.0 };
    double sum = 0;
    for (int j = 0; j < gl.nlat; j++)
        sum += prod_grid_cell_area_m2(&gl, j) * gl.nlon;
    CHECK_CLOSE(sum, 4 * M_PI * R_EARTH * R_EARTH, 1e-12, 0, "global area");
    /* Bad grids are refused with a message. */
    prod_grid bad = { 1, 5, 0, 0, 1, 1 };
    sph_error_clear(&err);
    CHECK(prod_grid_check(&bad, &err) != SPH_OK && err.msg[0], "1-column grid refused");
}

int main(void)
{
    test_disc();
    test_straight();
    test_threshold_rule();
    test_distance_and_area();
    return check_summary("test_edge");
}
