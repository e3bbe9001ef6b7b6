/* The floor of a free-drift step (issue 22): what a particle-step cannot
 * do without, and nothing else. For N particles on the Liaodong demo's
 * domain box, each step: locate the particle's cell on a regular 11 x 10
 * longitude/latitude forcing grid (the demo atmosphere's) by arithmetic,
 * interpolate wind (u, v) bilinearly in two bracketing time slices and
 * linearly in time, and the water current (u, v) in one slice; solve the
 * 2x2 momentum system once (implicit water drag at the lagged speed,
 * trapezoidal Coriolis, as core/model_impl.h sph_momentum) and move the
 * particle. No I/O, no projection, no neighbours, no output.
 *
 * Usage: bench_floor [N [STEPS [DT]]]  (defaults 10000, 576, 300 s)
 * Prints "floor: N particles, STEPS steps: X ns per particle-step" and
 * the best of 5 repetitions as the last field of a line
 * "floor_ns_per_particle_step X" (bench/bench_freedrift.sh reads it).
 * One thread (the whole-run cost is compared per core). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

enum { NX = 11, NY = 10 };

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static double bilinear(const double *f, double fx, double fy)
{
    int i = (int)fx, j = (int)fy;
    i = i < 0 ? 0 : i > NX - 2 ? NX - 2 : i;
    j = j < 0 ? 0 : j > NY - 2 ? NY - 2 : j;
    double wx = fx - i, wy = fy - j;
    const double *a = f + j * NX + i;
    return (1 - wy) * ((1 - wx) * a[0] + wx * a[1]) + wy * ((1 - wx) * a[NX] + wx * a[NX + 1]);
}

int main(int argc, char **argv)
{
    size_t n = argc > 1 ? (size_t)atol(argv[1]) : 10000;
    int steps = argc > 2 ? atoi(argv[2]) : 576;
    double dt = argc > 3 ? atof(argv[3]) : 300.0;
    const double lon0 = 120.85, lon1 = 122.55, lat0 = 39.65, lat1 = 41.05;
    const double dlon = (lon1 - lon0) / (NX - 1), dlat = (lat1 - lat0) / (NY - 1);
    static double wu[2][NX * NY], wv[2][NX * NY], cu[NX * NY], cv[NX * NY];
    for (int s = 0; s < 2; s++)
        for (int q = 0; q < NX * NY; q++) {
            wu[s][q] = 6.0 + 2.0 * sin(0.3 * q + s);
            wv[s][q] = -3.0 + 2.0 * cos(0.2 * q - s);
            cu[q] = 0.1 * sin(0.1 * q);
            cv[q] = 0.05 * cos(0.13 * q);
        }
    double *lon = malloc(n * sizeof *lon), *lat = malloc(n * sizeof *lat);
    double *u = malloc(n * sizeof *u), *v = malloc(n * sizeof *v), *M = malloc(n * sizeof *M);
    if (!lon || !lat || !u || !v || !M)
        return 1;
    const double rho_a = 1.3, Ca = 1.2e-3, rho_w = 1026, Cw = 5.5e-3, f = 9.4e-5;
    const double cw = cos(25 * M_PI / 180), sw = sin(25 * M_PI / 180);
    const double m_per_deg = 111195.0, ilat = 1.0 / m_per_deg;
    double best = HUGE_VAL, check = 0.0;
    for (int rep = 0; rep < 5; rep++) {
        for (size_t k = 0; k < n; k++) {
            lon[k] = 121.2 + 1.0 * (double)(k % 1000) / 1000.0;
            lat[k] = 39.9 + 0.9 * (double)(k / 1000 % 1000) / 1000.0;
            u[k] = v[k] = 0.0;
            M[k] = 900.0 * 0.5 * (0.2 + 0.1 * (double)(k % 7));
        }
        double t0 = now();
        for (int s = 0; s < steps; s++) {
            double alpha = fmod(s * dt / 3600.0, 1.0);
            for (size_t k = 0; k < n; k++) {
                double fx = (lon[k] - lon0) / dlon, fy = (lat[k] - lat0) / dlat;
                double ua = (1 - alpha) * bilinear(wu[0], fx, fy) + alpha * bilinear(wu[1], fx, fy);
                double va = (1 - alpha) * bilinear(wv[0], fx, fy) + alpha * bilinear(wv[1], fx, fy);
                double uw = bilinear(cu, fx, fy), vw = bilinear(cv, fx, fy);
                double sa = sqrt(ua * ua + va * va), iM = 1.0 / M[k];
                double un = u[k], vn = v[k], dux = uw - un, duy = vw - vn;
                double c = rho_w * Cw * sqrt(dux * dux + duy * duy) * iM;
                double rx = un + dt * (rho_a * Ca * sa * ua * iM + c * (cw * uw - sw * vw) + 0.5 * f * vn);
                double ry = vn + dt * (rho_a * Ca * sa * va * iM + c * (sw * uw + cw * vw) - 0.5 * f * un);
                double d11 = 1.0 + dt * c * cw, d12 = -dt * (c * sw + 0.5 * f), det = d11 * d11 + d12 * d12;
                double uo = (d11 * rx - d12 * ry) / det, vo = (d11 * ry + d12 * rx) / det;
                lon[k] += 0.5 * dt * (un + uo) * ilat / cos(0.7);
                lat[k] += 0.5 * dt * (vn + vo) * ilat;
                u[k] = uo;
                v[k] = vo;
            }
        }
        double el = now() - t0;
        if (el < best)
            best = el;
        for (size_t k = 0; k < n; k++)
            check += lon[k] + lat[k];
    }
    double ns = 1e9 * best / ((double)n * steps);
    printf("floor: %zu particles, %d steps: %.1f ns per particle-step (checksum %.6g)\n", n, steps, ns,
           check);
    printf("floor_ns_per_particle_step %.3f\n", ns);
    free(lon);
    free(lat);
    free(u);
    free(v);
    free(M);
    return 0;
}
