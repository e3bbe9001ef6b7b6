/* Projection: round trips, distances against independent geodesic
 * formulas (haversine on a sphere, Vincenty on WGS84), grid angles against
 * the analytic meridian convergence of polar stereographic. */
#include "io/geo.h"

#include "check.h"

static const double deg = M_PI / 180.0;

/* Great-circle distance on a sphere of radius R (haversine). */
static double haversine(double lon1, double lat1, double lon2, double lat2, double R)
{
    double dphi = (lat2 - lat1) * deg, dl = (lon2 - lon1) * deg;
    double a = sin(dphi / 2) * sin(dphi / 2) +
               cos(lat1 * deg) * cos(lat2 * deg) * sin(dl / 2) * sin(dl / 2);
    return 2 * R * asin(sqrt(a));
}

/* Vincenty (1975) inverse on the WGS84 ellipsoid: geodesic length, m. */
static double vincenty(double lon1, double lat1, double lon2, double lat2)
{
    const double a = 6378137.0, f = 1 / 298.257223563, b = a * (1 - f);
    double L = (lon2 - lon1) * deg;
    double U1 = atan((1 - f) * tan(lat1 * deg)), U2 = atan((1 - f) * tan(lat2 * deg));
    double sU1 = sin(U1), cU1 = cos(U1), sU2 = sin(U2), cU2 = cos(U2);
    double lambda = L, prev, sinSigma, cosSigma, sigma, cos2Alpha, cos2SigmaM;
    int iter = 0;
    do {
        double sl = sin(lambda), cl = cos(lambda);
        sinSigma = sqrt((cU2 * sl) * (cU2 * sl) + (cU1 * sU2 - sU1 * cU2 * cl) * (cU1 * sU2 - sU1 * cU2 * cl));
        cosSigma = sU1 * sU2 + cU1 * cU2 * cl;
        sigma = atan2(sinSigma, cosSigma);
        double sinAlpha = cU1 * cU2 * sl / sinSigma;
        cos2Alpha = 1 - sinAlpha * sinAlpha;
        cos2SigmaM = cos2Alpha != 0 ? cosSigma - 2 * sU1 * sU2 / cos2Alpha : 0;
        double C = f / 16 * cos2Alpha * (4 + f * (4 - 3 * cos2Alpha));
        prev = lambda;
        lambda = L + (1 - C) * f * sinAlpha *
                         (sigma + C * sinSigma * (cos2SigmaM + C * cosSigma * (-1 + 2 * cos2SigmaM * cos2SigmaM)));
    } while (fabs(lambda - prev) > 1e-13 && ++iter < 200);
    double uSq = cos2Alpha * (a * a - b * b) / (b * b);
    double A = 1 + uSq / 16384 * (4096 + uSq * (-768 + uSq * (320 - 175 * uSq)));
    double B = uSq / 1024 * (256 + uSq * (-128 + uSq * (74 - 47 * uSq)));
    double dSigma = B * sinSigma * (cos2SigmaM + B / 4 * (cosSigma * (-1 + 2 * cos2SigmaM * cos2SigmaM) -
                    B / 6 * cos2SigmaM * (-3 + 4 * sinSigma * sinSigma) * (-3 + 4 * cos2SigmaM * cos2SigmaM)));
    return b * A * (sigma - dSigma);
}

static double plane_distance(const geo_proj *p, double lon1, double lat1, double lon2, double lat2)
{
    double lo[2] = {lon1, lon2}, la[2] = {lat1, lat2}, x[2], y[2];
    geo_forward(p, 2, lo, la, x, y, NULL);
    return hypot(x[1] - x[0], y[1] - y[0]);
}

static void test_round_trip(const char *kind, double lon0, double lat0)
{
    sph_error err;
    sph_error_clear(&err);
    geo_proj *p = geo_proj_create(kind, lon0, lat0, &err);
    CHECK(p != NULL, "create %s: %s", kind, err.msg);
    if (!p)
        return;
    enum { N = 121 };
    double lon[N], lat[N], x[N], y[N], lon2[N], lat2[N], x2[N], y2[N];
    for (int k = 0; k < N; k++) {
        lon[k] = lon0 + ((k % 11) - 5) * 0.5;
        lat[k] = lat0 + ((k / 11) - 5) * 0.3;
        if (lat[k] > 89.9)
            lat[k] = 89.9;
    }
    CHECK(geo_forward(p, N, lon, lat, x, y, &err) == SPH_OK, "%s", err.msg);
    CHECK(geo_inverse(p, N, x, y, lon2, lat2, &err) == SPH_OK, "%s", err.msg);
    CHECK(geo_forward(p, N, lon2, lat2, x2, y2, &err) == SPH_OK, "%s", err.msg);
    double worst = 0;
    for (int k = 0; k < N; k++) {
        worst = fmax(worst, hypot(x2[k] - x[k], y2[k] - y[k]));
        /* 1e-6 m is 1e-11 degree */
        worst = fmax(worst, fabs(remainder(lon2[k] - lon[k], 360.0)) * 111e3 * cos(lat[k] * deg));
        worst = fmax(worst, fabs(lat2[k] - lat[k]) * 111e3);
    }
    CHECK(worst < 1e-6, "%s round trip error %g m", kind, worst);
    geo_proj_free(p);
}

int main(void)
{
    sph_error err;
    sph_error_clear(&err);

    /* Liaodong Bay, the demo domain. */
    const double lon0 = 121.0, lat0 = 40.0;
    test_round_trip("auto", lon0, lat0);
    test_round_trip("aeqd", lon0, lat0);
    test_round_trip("stere", lon0, lat0);
    test_round_trip("polar", -45.0, 75.0);
    test_round_trip("polar", 0.0, -70.0);
    test_round_trip("+proj=aeqd +lat_0=40 +lon_0=121 +R=6371008.8", lon0, lat0);

    /* aeqd on WGS84: distance on the plane between points near the centre
     * vs the ellipsoidal geodesic (Vincenty), within 0.1 % (in fact the
     * scale error is ~1e-5 at 50 km). */
    geo_proj *p = geo_proj_create("auto", lon0, lat0, &err);
    CHECK(p != NULL, "%s", err.msg);
    CHECK(strstr(geo_proj_definition(p), "aeqd") != NULL, "auto at 40N is aeqd: %s",
          geo_proj_definition(p));
    double pairs[][4] = {{120.8, 39.9, 121.3, 40.2}, {121.0, 40.0, 121.5, 40.0},
                         {120.6, 40.4, 121.2, 39.7}, {121.37, 40.47, 121.55, 40.77}};
    for (size_t k = 0; k < sizeof pairs / sizeof pairs[0]; k++) {
        double *q = pairs[k];
        double dp = plane_distance(p, q[0], q[1], q[2], q[3]);
        double dg = vincenty(q[0], q[1], q[2], q[3]);
        CHECK_CLOSE(dp, dg, 1e-3, 0, "aeqd WGS84 plane distance vs Vincenty");
        /* through the centre, aeqd distances are exact */
        double dc = plane_distance(p, lon0, lat0, q[2], q[3]);
        CHECK_CLOSE(dc, vincenty(lon0, lat0, q[2], q[3]), 1e-7, 1e-3, "aeqd distance from centre");
    }
    /* Angle 0 on the central meridian, and the conversion of a north vector. */
    CHECK_CLOSE(geo_grid_angle(p, lon0, lat0), 0, 0, 1e-9, "aeqd angle at centre");
    CHECK_CLOSE(geo_grid_angle(p, lon0, 41.5), 0, 0, 1e-9, "aeqd angle on central meridian");
    double a_east = geo_grid_angle(p, 123.0, 40.0);
    CHECK(a_east < 0 && a_east > -0.1, "aeqd angle east of centre turns clockwise: %g", a_east);
    geo_proj_free(p);

    /* Sphere aeqd vs haversine with the same radius. */
    p = geo_proj_create("+proj=aeqd +lat_0=40 +lon_0=121 +R=6371008.8 +units=m", lon0, lat0, &err);
    CHECK(p != NULL, "%s", err.msg);
    for (size_t k = 0; k < sizeof pairs / sizeof pairs[0]; k++) {
        double *q = pairs[k];
        CHECK_CLOSE(plane_distance(p, q[0], q[1], q[2], q[3]),
                    haversine(q[0], q[1], q[2], q[3], 6371008.8), 1e-3, 0,
                    "sphere aeqd plane distance vs haversine");
        CHECK_CLOSE(plane_distance(p, lon0, lat0, q[2], q[3]),
                    haversine(lon0, lat0, q[2], q[3], 6371008.8), 1e-9, 1e-3,
                    "sphere aeqd distance from centre");
    }
    geo_proj_free(p);

    /* North polar stereographic: meridian convergence is exactly the
     * longitude difference, alpha = -(lon - lon0). */
    p = geo_proj_create("auto", -45.0, 75.0, &err);
    CHECK(p != NULL, "%s", err.msg);
    CHECK(strstr(geo_proj_definition(p), "+lat_ts=70") != NULL, "auto at 75N is polar: %s",
          geo_proj_definition(p));
    for (double lon = -120; lon <= 60; lon += 30) {
        double want = -remainder((lon + 45.0) * deg, 2 * M_PI);
        CHECK_CLOSE(geo_grid_angle(p, lon, 72.0), want, 0, 1e-7, "polar grid angle");
    }
    /* Rotation of a north-pointing vector at lon0+90: x axis is 90 deg
     * clockwise... east points along +y there, north along -x. */
    double lo = 45.0, la = 72.0, ue = 0, vn = 1, ux, uy;
    CHECK(geo_rotate_to_plane(p, 1, &lo, &la, &ue, &vn, &ux, &uy, &err) == SPH_OK, "%s", err.msg);
    CHECK_CLOSE(ux, -1, 0, 1e-6, "north at lon0+90 points to -x");
    CHECK_CLOSE(uy, 0, 0, 1e-6, "north at lon0+90 has no y");
    geo_proj_free(p);

    /* Clone works independently; bad kinds give a clear error. */
    p = geo_proj_create("stere", lon0, lat0, &err);
    geo_proj *c = geo_proj_clone(p, &err);
    CHECK(c != NULL && strcmp(geo_proj_definition(c), geo_proj_definition(p)) == 0, "clone");
    CHECK_CLOSE(geo_grid_angle(c, lon0, 41), 0, 0, 1e-9, "stere angle on central meridian");
    geo_proj_free(c);
    geo_proj_free(p);
    geo_proj_free(NULL);

    sph_error_clear(&err);
    CHECK(geo_proj_create("mercator-ish", lon0, lat0, &err) == NULL, "unknown kind refused");
    CHECK(err.code == SPH_ERR_CONFIG && strstr(err.msg, "mercator-ish"), "message: %s", err.msg);
    sph_error_clear(&err);
    CHECK(geo_proj_create("+proj=nonsense", lon0, lat0, &err) == NULL, "bad PROJ string refused");
    CHECK(strstr(err.msg, "nonsense") != NULL, "message: %s", err.msg);
    return check_summary("test_geo");
}
