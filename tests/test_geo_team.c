/* Long transforms on the OpenMP threads (io/inputs/geo.c: 512 points or
 * more, each thread through its own PJ). Asserted against the serial path
 * (one thread, and the same points one call per point): forward and
 * inverse of 20000 points over the Liaodong plane (aeqd) and an Arctic
 * one (polar stereographic) are bit-identical with 1, 2 and 3 threads; a
 * point that does not project (a NaN, a latitude beyond the pole) gives
 * NaN at its own index only, and the error line names the first of them
 * whatever the thread count. */
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "io/geo.h"

enum { N = 20000 };

static int same_bits(const double *a, const double *b, size_t n)
{
    return memcmp(a, b, n * sizeof *a) == 0;
}

int main(void)
{
    static double lon[N], lat[N], x1[N], y1[N], xt[N], yt[N], lo1[N], la1[N], lot[N], lat2[N], xs[N], ys[N];
    const char *kind[2] = {"auto", "polar"};
    const double c0[2][2] = {{121.0, 40.0}, {-45.0, 78.0}};
    for (int k = 0; k < 2; k++) {
        sph_error err;
        sph_error_clear(&err);
        geo_proj *p = geo_proj_create(kind[k], c0[k][0], c0[k][1], &err);
        CHECK(p != NULL, "%s: %s", kind[k], err.msg);
        if (!p)
            continue;
        for (int i = 0; i < N; i++) {
            lon[i] = c0[k][0] - 4.0 + 8.0 * (i % 200) / 199.0 + 1e-7 * i;
            lat[i] = c0[k][1] - 3.0 + 6.0 * (i / 200) / 99.0;
        }
        omp_set_num_threads(1);
        CHECK(geo_forward(p, N, lon, lat, x1, y1, &err) == SPH_OK, "%s forward, 1 thread: %s", kind[k], err.msg);
        CHECK(geo_inverse(p, N, x1, y1, lo1, la1, &err) == SPH_OK, "%s inverse, 1 thread", kind[k]);
        for (int i = 0; i < N; i++) /* one point per call: never the team */
            geo_forward(p, 1, lon + i, lat + i, xs + i, ys + i, NULL);
        CHECK(same_bits(x1, xs, N) && same_bits(y1, ys, N), "%s: a long call = one call per point", kind[k]);
        for (int th = 2; th <= 3; th++) {
            omp_set_num_threads(th);
            CHECK(geo_forward(p, N, lon, lat, xt, yt, &err) == SPH_OK, "%s forward, %d threads", kind[k], th);
            CHECK(same_bits(x1, xt, N) && same_bits(y1, yt, N), "%s forward: %d threads = 1", kind[k], th);
            CHECK(geo_inverse(p, N, x1, y1, lot, lat2, &err) == SPH_OK, "%s inverse, %d threads", kind[k], th);
            CHECK(same_bits(lo1, lot, N) && same_bits(la1, lat2, N), "%s inverse: %d threads = 1", kind[k], th);
        }
        /* points that do not project: the first named, NaN at each */
        lat[15001] = NAN;
        lat[777] = 95.0;
        lon[19999] = NAN;
        char first[2][1100];
        for (int th = 1; th <= 2; th++) {
            omp_set_num_threads(th);
            sph_error_clear(&err);
            int rc = geo_forward(p, N, lon, lat, xt, yt, &err);
            CHECK(rc != SPH_OK, "%s: bad points refused (%d threads)", kind[k], th);
            CHECK(strstr(err.msg, "3 of 20000 points") != NULL, "%s, %d threads: %s", kind[k], th, err.msg);
            snprintf(first[th - 1], sizeof first[0], "%s", err.msg);
            int nan_ok = isnan(xt[777]) && isnan(xt[15001]) && isnan(xt[19999]);
            size_t others = 0;
            for (int i = 0; i < N; i++)
                others += i != 777 && i != 15001 && i != 19999 && (xt[i] != x1[i] || yt[i] != y1[i]);
            CHECK(nan_ok && others == 0, "%s, %d threads: NaN at the 3 points only (%zu others differ)", kind[k], th,
                  others);
        }
        CHECK(strcmp(first[0], first[1]) == 0, "%s: the same line with 1 and 2 threads: %s | %s", kind[k], first[0],
              first[1]);
        CHECK(strstr(first[0], "(first: ") != NULL && strstr(first[0], ", 95)") != NULL,
              "%s: the first bad point (index 777, lat 95) named: %s", kind[k], first[0]);
        geo_proj_free(p);
    }
    return check_summary("test_geo_team");
}
