/* Harmonic tides: astronomical arguments against Meeus' published mean
 * elements, constituent speeds, nodal factor ranges (Schureman), and a
 * harmonic-1 grid file read through the forcing reader reproducing an M2
 * cosine evaluated independently here, with period 12.4206 h. */
#include "check.h"
#include "io/forcing.h"
#include "io/tide.h"
#include "util/timeutil.h"

#include <netcdf.h>
#include <unistd.h>

#define D2R (M_PI / 180.0)

/* Independent evaluation of the documented formulas (docs/forcing.md). */
static double w360(double x)
{
    x = fmod(x, 360.0);
    return x < 0 ? x + 360 : x;
}
static void astro(double t, double *s, double *h, double *p, double *N, double *tau)
{
    double T = (t / 86400.0 + 25567.5) / 36525.0;
    *s = 270.434164 + 481267.8831 * T - 0.001133 * T * T + 0.0000019 * T * T * T;
    *h = 279.696678 + 36000.768925 * T + 0.0003025 * T * T;
    *p = 334.329556 + 4069.0340329 * T - 0.010325 * T * T - 0.000012 * T * T * T;
    *N = 259.183275 - 1934.142008 * T + 0.002078 * T * T + 0.0000022 * T * T * T;
    *tau = 180.0 + 15.0 * fmod(t / 3600.0, 24.0);
}
static void m2_fu(double t, double *f, double *u)
{
    double s, h, p, N, tau;
    astro(t, &s, &h, &p, &N, &tau);
    N = w360(N);
    if (N > 180)
        N -= 360;
    double w = 23.452 * D2R, i = 5.145 * D2R, n = N * D2R;
    double I = acos(cos(w) * cos(i) - sin(w) * sin(i) * cos(n));
    double A = atan(cos((w - i) / 2) / cos((w + i) / 2) * tan(n / 2));
    double B = atan(sin((w - i) / 2) / sin((w + i) / 2) * tan(n / 2));
    double nu = A - B, xi = n - (A + B);
    *f = pow(cos(I / 2), 4) / 0.9154;
    *u = (2 * xi - 2 * nu) / D2R;
}

static char dir[64];
static double T0;

static void write_tide(const char *path, double land_lon, const char *uunits)
{
    int nc, dc, ds, dy, dx, vc, vlat, vlon, v[6];
    size_t nx = 25, ny = 15;
    nc_create(path, NC_CLOBBER, &nc);
    nc_def_dim(nc, "constituent", 1, &dc);
    nc_def_dim(nc, "name_strlen", 4, &ds);
    nc_def_dim(nc, "lat", ny, &dy);
    nc_def_dim(nc, "lon", nx, &dx);
    int d2[2] = {dc, ds}, d3[3] = {dc, dy, dx};
    nc_def_var(nc, "constituent", NC_CHAR, 2, d2, &vc);
    nc_def_var(nc, "lat", NC_DOUBLE, 1, &dy, &vlat);
    nc_def_var(nc, "lon", NC_DOUBLE, 1, &dx, &vlon);
    nc_put_att_text(nc, vlat, "standard_name", 8, "latitude");
    nc_put_att_text(nc, vlat, "units", 13, "degrees_north");
    nc_put_att_text(nc, vlon, "standard_name", 9, "longitude");
    nc_put_att_text(nc, vlon, "units", 12, "degrees_east");
    const char *names[6] = {"h_amp", "h_phase", "u_amp", "u_phase", "v_amp", "v_phase"};
    const char *units[6] = {"m", "degrees", uunits, "degrees", uunits, "degrees"};
    float fill = 1e20f;
    for (int k = 0; k < 6; k++) {
        nc_def_var(nc, names[k], NC_FLOAT, 3, d3, &v[k]);
        nc_put_att_text(nc, v[k], "units", strlen(units[k]), units[k]);
        nc_put_att_float(nc, v[k], "_FillValue", NC_FLOAT, 1, &fill);
    }
    nc_put_att_text(nc, NC_GLOBAL, "sphice_tide_format", 10, "harmonic-1");
    nc_enddef(nc);
    nc_put_var_text(nc, vc, "m2  ");
    double lat[15], lon[25];
    for (size_t j = 0; j < ny; j++)
        lat[j] = 58 + (double)j;
    for (size_t i = 0; i < nx; i++)
        lon[i] = -12 + (double)i;
    nc_put_var_double(nc, vlat, lat);
    nc_put_var_double(nc, vlon, lon);
    const double val[6] = {1.25, 40.0, 30.0, 100.0, 10.0, 190.0};
    float buf[15 * 25];
    for (int k = 0; k < 6; k++) {
        for (size_t p = 0; p < nx * ny; p++)
            buf[p] = lon[p % nx] == land_lon && lat[p / nx] == 65 ? fill : (float)val[k];
        nc_put_var_float(nc, v[k], buf);
    }
    nc_close(nc);
}

static void test_astronomy(void)
{
    /* J2000.0 (2000-01-01 12:00): Meeus, Astronomical Algorithms (1998),
     * eq. 47.1 L' = 218.3164477, 25.2 L0 = 280.46646, 47.7 perigee
     * 83.3532465, 47.7 node 125.0445479 degrees. */
    double t;
    time_parse_iso("2000-01-01T12:00:00Z", &t);
    tide_astro a;
    tide_astro_at(t, &a);
    CHECK_CLOSE(a.s, 218.3164477, 0, 0.02, "moon mean longitude at J2000");
    CHECK_CLOSE(a.h, 280.46646, 0, 0.02, "sun mean longitude at J2000");
    CHECK_CLOSE(a.p, 83.3532465, 0, 0.02, "lunar perigee at J2000");
    CHECK_CLOSE(a.N, 125.0445479, 0, 0.02, "lunar node at J2000");
    CHECK_CLOSE(a.tau, 0.0, 0, 1e-9, "mean sun hour angle at noon");
    /* Speeds from the arguments: V0(t + 1 h) - V0(t). */
    for (int k = 0; k < TIDE_NCONST; k++) {
        double d = w360(tide_v0_deg(k, T0 + 3600) - tide_v0_deg(k, T0));
        CHECK_CLOSE(d, tide_speed_deg_per_hour(k), 0, 2e-6,
                    tide_constituent_name(k));
    }
    CHECK(tide_constituent_index("M2") == TIDE_M2 && tide_constituent_index("q1") == TIDE_Q1 &&
              tide_constituent_index("m4") == -1, "constituent names");
    /* Nodal factors over one nodal cycle (18.61 years): Schureman (1958)
     * Table 14 ranges. */
    double lo[TIDE_NCONST], hi[TIDE_NCONST];
    for (int k = 0; k < TIDE_NCONST; k++) {
        lo[k] = 9;
        hi[k] = -9;
    }
    for (int d = 0; d < 6800; d += 5)
        for (int k = 0; k < TIDE_NCONST; k++) {
            double f, u;
            tide_nodal(k, T0 + d * 86400.0, &f, &u);
            lo[k] = fmin(lo[k], f);
            hi[k] = fmax(hi[k], f);
        }
    CHECK_CLOSE(lo[TIDE_M2], 0.963, 0, 0.002, "min f M2");
    CHECK_CLOSE(hi[TIDE_M2], 1.038, 0, 0.002, "max f M2");
    CHECK_CLOSE(lo[TIDE_K1], 0.882, 0, 0.003, "min f K1");
    CHECK_CLOSE(hi[TIDE_K1], 1.113, 0, 0.003, "max f K1");
    CHECK_CLOSE(lo[TIDE_O1], 0.806, 0, 0.003, "min f O1");
    CHECK_CLOSE(hi[TIDE_O1], 1.183, 0, 0.003, "max f O1");
    CHECK(lo[TIDE_S2] == 1 && hi[TIDE_S2] == 1, "S2 has no nodal modulation");
    double f, u, fe, ue;
    tide_nodal(TIDE_M2, T0, &f, &u);
    m2_fu(T0, &fe, &ue);
    CHECK_CLOSE(f, fe, 0, 1e-12, "f M2 (independent evaluation)");
    CHECK_CLOSE(u, ue, 0, 1e-9, "u M2 (independent evaluation)");
}

static void test_grid(int nodal)
{
    char p[128];
    snprintf(p, sizeof p, "%s/tide.nc", dir);
    write_tide(p, 3.0, "cm s-1");
    const char *files[] = {p};
    forcing_source_spec spec = {.name = "tides", .kind = FORCING_TIDE, .files = files,
                                .nfiles = 1, .required = FQ_SSH | FQ_CURRENT,
                                .tide_no_nodal = !nodal};
    forcing *f = NULL;
    sph_error err;
    sph_error_clear(&err);
    double days = check_quick() ? 3 : 6;
    CHECK(forcing_open(&f, &spec, 1, T0, T0 + days * 86400, -10, 9, 60, 70, &err) == 0, "%s",
          err.msg);
    if (!f)
        return;
    /* Expected: A f cos(V0(t_ref) + u + omega (t - t_ref) - G), t_ref = 00:00 UTC of the start day. */
    double t_ref = floor(T0 / 86400) * 86400;
    double s, h, pp, N, tau, fm = 1, um = 0;
    astro(t_ref, &s, &h, &pp, &N, &tau);
    double v0 = 2 * tau - 2 * s + 2 * h;
    if (nodal)
        m2_fu(t_ref, &fm, &um);
    double om = 28.9841042 * D2R / 3600;
    double lon[3] = {0.3, -7.2, 3.4}, lat[3] = {65.5, 61.0, 65.2};
    double x[3], uu[3], vv[3], gx[3], gy[3];
    forcing_sample smp = {.ssh = x, .uw_east = uu, .vw_north = vv, .ssh_dx_east = gx,
                          .ssh_dy_north = gy};
    for (int m = 0; m < 10; m++) {
        double t = T0 + m * 3671.0;
        CHECK(forcing_sample_at(f, t, 3, lon, lat, &smp, &err) == 0, "%s", err.msg);
        double ph = (v0 + um) * D2R + om * (t - t_ref);
        for (int i = 0; i < 3; i++) { /* point 2 is next to the land node (3, 65) */
            CHECK_CLOSE(x[i], 1.25 * fm * cos(ph - 40 * D2R), 0, 1e-9, "M2 elevation");
            CHECK_CLOSE(uu[i], 0.30 * fm * cos(ph - 100 * D2R), 0, 1e-9, "M2 u (cm/s)");
            CHECK_CLOSE(vv[i], 0.10 * fm * cos(ph - 190 * D2R), 0, 1e-9, "M2 v (cm/s)");
            CHECK(fabs(gx[i]) < 1e-15 && fabs(gy[i]) < 1e-15, "uniform tide has no slope");
        }
    }
    /* Period from upward zero crossings. */
    double prev = NAN, tprev = 0, first = NAN, last = NAN;
    int ncross = 0;
    for (double t = T0; t <= T0 + days * 86400; t += 120) {
        CHECK(forcing_sample_at(f, t, 1, lon, lat, &smp, &err) == 0, "%s", err.msg);
        if (prev < 0 && x[0] >= 0) {
            double tc = tprev + (t - tprev) * (-prev) / (x[0] - prev);
            if (ncross == 0)
                first = tc;
            last = tc;
            ncross++;
        }
        prev = x[0];
        tprev = t;
    }
    CHECK(ncross >= 5, "crossings %d", ncross);
    CHECK_CLOSE((last - first) / (ncross - 1) / 3600.0, 12.4206, 0, 2e-4, "M2 period (h)");
    forcing_var_info info[4];
    size_t n = forcing_describe(f, info, 4);
    CHECK(n == 3, "describe: h, u, v (%zu)", n);
    CHECK(strcmp(info[0].source, "tides") == 0 && strstr(info[0].grid, "regular"), "%s %s",
          info[0].source, info[0].grid);
    CHECK_CLOSE(info[0].fill_fraction, 1.0 / 375.0, 0, 1e-12, "one land node");
    forcing_close(f);
    unlink(p);
}

int main(void)
{
    time_parse_iso("2021-02-01T06:00:00Z", &T0);
    snprintf(dir, sizeof dir, "/tmp/sphice-tide-XXXXXX");
    if (!mkdtemp(dir))
        return 2;
    test_astronomy();
    test_grid(0);
    test_grid(1);
    rmdir(dir);
    return check_summary("test_tide");
}
