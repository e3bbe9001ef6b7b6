/* season_summary: the freeze-up scene's numbers (docs/season.md).
 *
 * Usage: season_summary RUN_DIR OCEAN_NC
 *
 * Reads RUN_DIR/sphice_fields.nc (siarea, sivolume per output time) and
 * RUN_DIR/sphice_particles.nc (the particles per output time) and the
 * scene's bathymetry (sea_floor_depth_below_sea_surface of OCEAN_NC, read
 * by that standard name, bilinear at the particles' positions). Writes to
 * stdout one row per output time, for gnuplot:
 *
 *   hours  area_km2  volume_km3  particles  new_particles  depth_new_m  depth_ice_m
 *
 * depth_new_m: the mean water depth under the particles that appeared
 * since the previous output time (ids not seen before; NaN when none);
 * depth_ice_m: the mean depth under all particles. Then '#' lines: the
 * mean depth under the new particles by period (days 0-5, 5-10, 10-20,
 * 20-30) and the mean depth of the sea (bathymetry nodes deeper than the
 * shore value, i.e. not over land).
 */
#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int die(const char *path, const char *what, int st)
{
    fprintf(stderr, "season_summary: %s: %s: %s\n", path, what, nc_strerror(st));
    exit(1);
}

#define NC(path, what, call)                 \
    do {                                     \
        int st_ = (call);                    \
        if (st_ != NC_NOERR)                 \
            die((path), (what), st_);        \
    } while (0)

static void *xmalloc(size_t n)
{
    void *p = malloc(n ? n : 1);
    if (!p) {
        fprintf(stderr, "season_summary: out of memory\n");
        exit(1);
    }
    return p;
}

static double *read_1d(int nc, const char *path, const char *name, size_t *n)
{
    int v, d;
    NC(path, name, nc_inq_varid(nc, name, &v));
    NC(path, name, nc_inq_vardimid(nc, v, &d));
    NC(path, name, nc_inq_dimlen(nc, d, n));
    double *x = xmalloc(*n * sizeof *x);
    NC(path, name, nc_get_var_double(nc, v, x));
    return x;
}

/* The bathymetry: the variable whose standard_name is sea_floor_depth_below_sea_surface. */
static size_t bnx, bny;
static double *blon, *blat, *bdep;

static void read_bathy(const char *path)
{
    int nc, nv;
    NC(path, "open", nc_open(path, NC_NOWRITE, &nc));
    NC(path, "variables", nc_inq_nvars(nc, &nv));
    int found = -1;
    for (int v = 0; v < nv && found < 0; v++) {
        char sn[256] = "";
        size_t len = 0;
        if (nc_inq_attlen(nc, v, "standard_name", &len) == NC_NOERR && len < sizeof sn &&
            nc_get_att_text(nc, v, "standard_name", sn) == NC_NOERR) {
            sn[len] = '\0';
            if (!strcmp(sn, "sea_floor_depth_below_sea_surface"))
                found = v;
        }
    }
    if (found < 0) {
        fprintf(stderr, "season_summary: %s: no variable with standard_name sea_floor_depth_below_sea_surface\n",
                path);
        exit(1);
    }
    blon = read_1d(nc, path, "lon", &bnx);
    blat = read_1d(nc, path, "lat", &bny);
    bdep = xmalloc(bnx * bny * sizeof *bdep);
    NC(path, "depth", nc_get_var_double(nc, found, bdep));
    nc_close(nc);
}

static double depth_at(double lon, double lat)
{
    double fx = (lon - blon[0]) / (blon[1] - blon[0]), fy = (lat - blat[0]) / (blat[1] - blat[0]);
    if (fx < 0) fx = 0;
    if (fy < 0) fy = 0;
    if (fx > bnx - 1.000001) fx = bnx - 1.000001;
    if (fy > bny - 1.000001) fy = bny - 1.000001;
    size_t i = (size_t)fx, j = (size_t)fy;
    double a = fx - i, b = fy - j;
    const double *d = bdep;
    return (1 - a) * (1 - b) * d[j * bnx + i] + a * (1 - b) * d[j * bnx + i + 1] +
           (1 - a) * b * d[(j + 1) * bnx + i] + a * b * d[(j + 1) * bnx + i + 1];
}

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: %s RUN_DIR OCEAN_NC\n", argv[0]);
        return 2;
    }
    read_bathy(argv[2]);
    char fp[4096], pp[4096];
    snprintf(fp, sizeof fp, "%s/sphice_fields.nc", argv[1]);
    snprintf(pp, sizeof pp, "%s/sphice_particles.nc", argv[1]);
    int nc;
    size_t nt, n2, n3;
    NC(fp, "open", nc_open(fp, NC_NOWRITE, &nc));
    double *ft = read_1d(nc, fp, "time", &nt);
    double *area = read_1d(nc, fp, "siarea", &n2);
    double *vol = read_1d(nc, fp, "sivolume", &n3);
    nc_close(nc);
    NC(pp, "open", nc_open(pp, NC_NOWRITE, &nc));
    size_t nobs, ntraj;
    double *ot = read_1d(nc, pp, "time", &nobs);
    double *olon = read_1d(nc, pp, "lon", &nobs);
    double *olat = read_1d(nc, pp, "lat", &nobs);
    int v, d;
    NC(pp, "trajectory_index", nc_inq_varid(nc, "trajectory_index", &v));
    int *tix = xmalloc(nobs * sizeof *tix);
    if (nobs)
        NC(pp, "trajectory_index", nc_get_var_int(nc, v, tix));
    NC(pp, "trajectory", nc_inq_dimid(nc, "trajectory", &d));
    NC(pp, "trajectory", nc_inq_dimlen(nc, d, &ntraj));
    nc_close(nc);

    unsigned char *seen = calloc(ntraj ? ntraj : 1, 1);
    if (!seen)
        return 1;
    double pnew[4] = {0}, pdep[4] = {0};
    static const double edges[5] = {0, 5, 10, 20, 30};
    size_t o = 0;
    printf("# hours area_km2 volume_km3 particles new_particles depth_new_m depth_ice_m\n");
    for (size_t k = 0; k < nt && k < n2 && k < n3; k++) {
        size_t n = 0, nn = 0;
        double dn = 0, di = 0;
        while (o < nobs && fabs(ot[o] - ft[k]) < 1.0) {
            double z = depth_at(olon[o], olat[o]);
            n++;
            di += z;
            int t = tix[o];
            if (t >= 0 && (size_t)t < ntraj && !seen[t]) {
                seen[t] = 1;
                nn++;
                dn += z;
            }
            o++;
        }
        double h = (ft[k] - ft[0]) / 3600.0;
        for (int p = 0; p < 4; p++)
            if (k > 0 && h > edges[p] * 24 && h <= edges[p + 1] * 24) {
                pnew[p] += nn;
                pdep[p] += dn;
            }
        printf("%g %.6g %.6g %zu %zu %.4g %.4g\n", h, area[k], vol[k], n, nn, nn ? dn / nn : NAN,
               n ? di / n : NAN);
    }
    double sea = 0, nsea = 0;
    for (size_t j = 0; j < bny * bnx; j++)
        if (bdep[j] > 2.0001) { /* the scene writes the 2 m shore depth over land */
            sea += bdep[j];
            nsea++;
        }
    for (int p = 0; p < 4; p++)
        printf("# new particles days %g-%g: %.0f, mean depth under them %.4g m\n", edges[p], edges[p + 1],
               pnew[p], pnew[p] > 0 ? pdep[p] / pnew[p] : NAN);
    printf("# mean depth of the sea nodes of the bathymetry (deeper than the 2 m shore): %.4g m (%.0f nodes)\n",
           nsea ? sea / nsea : NAN, nsea);
    free(ft); free(area); free(vol); free(ot); free(olon); free(olat); free(tix); free(seen);
    free(blon); free(blat); free(bdep);
    return 0;
}
