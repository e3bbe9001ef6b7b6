/* demo_compare: errors of one Liaodong Bay demo run against a reference
 * run of the same scene (bench/bench_demo.sh, issue 7), from the products
 * of both runs only.
 *
 *   build/tools/demo_compare [--hours H] [--threshold T] [--rho RHO] REF_DIR RUN_DIR
 *
 * REF_DIR and RUN_DIR are `sphice run --out` directories (or cycle
 * directories). Both fields files must be on the same output grid and
 * start at the same time. At H hours after the first output time (default
 * 96) it computes:
 *   - IIEE (Goessling et al. 2016) of the run's concentration against the
 *     reference's at threshold T (default 0.15), km^2, with the library's
 *     verify_compute (io/verify.h), land and fill cells left out;
 *   - RMSE of sivol, the grid thickness (ice volume per cell area, open
 *     water as 0), m, over the sea cells where either run has ice
 *     (sivol > 0 or siconc > 0 in either);
 *   - the distance between the thick patch's centres (tools/demo_analysis.h:
 *     the particles thicker than DEMO_PATCH_THICK at the first time,
 *     mass-weighted centre), km.
 * Prints one line "iiee_km2,hbar_rmse_m,patch_centre_error_km" on stdout
 * and a line of context on stderr (cells compared, edge lengths, the run's
 * regime fraction in free drift, both patch drifts). rho_i (default 900)
 * is only used for the patch's area weights, which the centre does not
 * depend on; it is an option for symmetry with demo_summary. */
#include <errno.h>
#include "demo_analysis.h"
#include "io/verify.h"

#define FILL_ABOVE 1e19 /* products write 1e20 as fill */

typedef struct field_slice {
    prod_grid g;
    double t0, t;         /* first time, the time read */
    double *conc, *hbar;  /* nlat*nlon, NaN at fill */
    unsigned char *land;  /* nlat*nlon */
    double free_drift_fraction;
} field_slice;

static void slice_free(field_slice *s)
{
    free(s->conc);
    free(s->hbar);
    free(s->land);
}

static int read_axis(int nc, const char *name, double **out, size_t *n, const char *path, sph_error *err)
{
    int v, d, st;
    if ((st = nc_inq_dimid(nc, name, &d)) || (st = nc_inq_dimlen(nc, d, n)) || (st = nc_inq_varid(nc, name, &v)))
        return sph_err_set(err, SPH_ERR_MISSING_VAR, "%s: %s: %s", path, name, nc_strerror(st));
    *out = malloc((*n ? *n : 1) * sizeof **out);
    if (!*out)
        return sph_err_set(err, SPH_ERR_NOMEM, "out of memory");
    if ((st = nc_get_var_double(nc, v, *out)))
        return sph_err_set(err, SPH_ERR_NETCDF, "%s: read %s: %s", path, name, nc_strerror(st));
    return SPH_OK;
}

/* Reads siconc, sivol and landmask at t0 + hours from a fields file. */
static int read_slice(const char *path, double hours, field_slice *s, sph_error *err)
{
    memset(s, 0, sizeof *s);
    int nc, st = nc_open(path, NC_NOWRITE, &nc);
    if (st != NC_NOERR)
        return sph_err_set(err, SPH_ERR_IO, "%s: %s", path, nc_strerror(st));
    double *lon = NULL, *lat = NULL, *time = NULL;
    size_t nlon = 0, nlat = 0, nt = 0;
    int rc = SPH_OK;
    if ((rc = read_axis(nc, "lon", &lon, &nlon, path, err)) || (rc = read_axis(nc, "lat", &lat, &nlat, path, err)) ||
        (rc = read_axis(nc, "time", &time, &nt, path, err)))
        goto done;
    if (nlon < 2 || nlat < 2 || nt < 1) {
        rc = sph_err_set(err, SPH_ERR_BAD_DATA, "%s: grid %zux%zu, %zu times", path, nlon, nlat, nt);
        goto done;
    }
    s->g = (prod_grid){(int)nlon, (int)nlat, lon[0], lat[0], lon[1] - lon[0], lat[1] - lat[0]};
    s->t0 = time[0];
    size_t it = nt;
    for (size_t k = 0; k < nt; k++)
        if (fabs(time[k] - (time[0] + hours * 3600.0)) < 1.0)
            it = k;
    if (it == nt) {
        rc = sph_err_set(err, SPH_ERR_COVERAGE, "%s: no output time %g h after the first (%zu times)", path, hours, nt);
        goto done;
    }
    s->t = time[it];
    size_t n = nlon * nlat;
    s->conc = malloc(n * sizeof *s->conc);
    s->hbar = malloc(n * sizeof *s->hbar);
    s->land = malloc(n);
    int *mask = malloc(n * sizeof *mask);
    if (!s->conc || !s->hbar || !s->land || !mask) {
        free(mask);
        rc = sph_err_set(err, SPH_ERR_NOMEM, "out of memory");
        goto done;
    }
    size_t start[3] = {it, 0, 0}, count[3] = {1, nlat, nlon};
    int vc, vh, vl;
    if ((st = nc_inq_varid(nc, "siconc", &vc)) || (st = nc_inq_varid(nc, "sivol", &vh)) ||
        (st = nc_inq_varid(nc, "landmask", &vl)) || (st = nc_get_vara_double(nc, vc, start, count, s->conc)) ||
        (st = nc_get_vara_double(nc, vh, start, count, s->hbar)) || (st = nc_get_var_int(nc, vl, mask))) {
        free(mask);
        rc = sph_err_set(err, SPH_ERR_NETCDF, "%s: siconc/sivol/landmask: %s", path, nc_strerror(st));
        goto done;
    }
    for (size_t k = 0; k < n; k++) {
        s->land[k] = mask[k] != 0;
        if (!(fabs(s->conc[k]) < FILL_ABOVE))
            s->conc[k] = NAN;
        if (!(fabs(s->hbar[k]) < FILL_ABOVE))
            s->hbar[k] = NAN;
    }
    free(mask);
    if (nc_get_att_double(nc, NC_GLOBAL, "sphice_regime_fraction_free_drift", &s->free_drift_fraction))
        s->free_drift_fraction = NAN;
done:
    nc_close(nc);
    free(lon);
    free(lat);
    free(time);
    if (rc)
        slice_free(s);
    return rc;
}

static int usage(void)
{
    fprintf(stderr, "usage: demo_compare [--hours H] [--threshold T] [--rho RHO] REF_DIR RUN_DIR\n");
    return 2;
}

static int parse_number(const char *s, double *out)
{
    char *end;
    errno = 0;
    *out = strtod(s, &end);
    return errno || end == s || *end || !isfinite(*out);
}

int main(int argc, char **argv)
{
    double hours = 96, thr = 0.15, rho_i = 900;
    int a = 1;
    for (; a < argc && !strncmp(argv[a], "--", 2); a++) {
        double *dst = !strcmp(argv[a], "--hours") ? &hours
                      : !strcmp(argv[a], "--threshold") ? &thr
                      : !strcmp(argv[a], "--rho") ? &rho_i
                                                   : NULL;
        if (!dst || a + 1 >= argc || parse_number(argv[++a], dst))
            return usage();
    }
    if (argc - a != 2 || !(hours >= 0) || !(thr > 0 && thr <= 1) || !(rho_i > 0))
        return usage();
    const char *dirs[2] = {argv[a], argv[a + 1]};
    sph_error err;
    sph_error_clear(&err);
    field_slice f[2];
    demo_run r[2];
    char path[4096];
    int nf = 0, nr = 0, code = 1;
    for (; nf < 2; nf++) {
        if (demo_find_file(dirs[nf], "_fields.nc", path, sizeof path)) {
            fprintf(stderr, "demo_compare: %s: no *_fields.nc\n", dirs[nf]);
            goto out;
        }
        if (read_slice(path, hours, &f[nf], &err)) {
            fprintf(stderr, "demo_compare: %s\n", err.msg);
            goto out;
        }
    }
    const prod_grid *g = &f[0].g, *h = &f[1].g;
    if (g->nlon != h->nlon || g->nlat != h->nlat || fabs(g->lon0 - h->lon0) > 1e-6 || fabs(g->lat0 - h->lat0) > 1e-6 ||
        fabs(g->dlon - h->dlon) > 1e-9 || fabs(g->dlat - h->dlat) > 1e-9 || fabs(f[0].t0 - f[1].t0) > 1.0) {
        fprintf(stderr, "demo_compare: the two runs are not on the same grid or do not start at the same time\n");
        goto out;
    }
    size_t n = (size_t)g->nlon * g->nlat;
    unsigned char *land = malloc(n);
    if (!land) {
        fprintf(stderr, "demo_compare: out of memory\n");
        goto out;
    }
    for (size_t k = 0; k < n; k++)
        land[k] = f[0].land[k] || f[1].land[k];
    verify_scores s;
    if (verify_compute(g, f[1].conc, f[0].conc, NULL, land, thr, &s, &err)) {
        free(land);
        fprintf(stderr, "demo_compare: %s\n", err.msg);
        goto out;
    }
    double sum2 = 0;
    long ncell = 0;
    for (size_t k = 0; k < n; k++) {
        if (land[k] || isnan(f[0].hbar[k]) || isnan(f[1].hbar[k]))
            continue;
        int ice = f[0].hbar[k] > 0 || f[1].hbar[k] > 0 || (f[0].conc[k] > 0) || (f[1].conc[k] > 0);
        if (!ice)
            continue;
        double d = f[1].hbar[k] - f[0].hbar[k];
        sum2 += d * d;
        ncell++;
    }
    free(land);
    double rmse = ncell ? sqrt(sum2 / (double)ncell) : NAN;
    for (; nr < 2; nr++)
        if (demo_analyse(dirs[nr], rho_i, &r[nr], &err)) {
            fprintf(stderr, "demo_compare: %s\n", err.msg);
            goto out;
        }
    const demo_time *p0 = demo_at_hours(&r[0], hours), *p1 = demo_at_hours(&r[1], hours);
    if (!p0 || !p1 || !isfinite(p0->lon_c) || !isfinite(p1->lon_c)) {
        fprintf(stderr, "demo_compare: no patch centre at %g h in both runs\n", hours);
        goto out;
    }
    double dkm, bearing;
    demo_bearing(p0->lon_c, p0->lat_c, p1->lon_c, p1->lat_c, &dkm, &bearing);
    printf("%.6g,%.6g,%.6g\n", s.iiee_km2, rmse, dkm);
    fprintf(stderr,
            "demo_compare: %g h: IIEE %.4g km^2 (O %.4g, U %.4g; edge %.1f km run, %.1f km ref), "
            "hbar RMSE %.4g m over %ld ice cells, patch centre %.3f km apart; patch drift %.2f km (run) "
            "vs %.2f km (ref); particles %ld (run) vs %ld (ref); free-drift fraction %.3f (run) vs %.3f (ref)\n",
            hours, s.iiee_km2, s.over_km2, s.under_km2, s.edge_length_fc_km, s.edge_length_obs_km, rmse, ncell, dkm,
            r[1].drift_km, r[0].drift_km, r[1].n_particles0, r[0].n_particles0, f[1].free_drift_fraction,
            f[0].free_drift_fraction);
    code = 0;
out:
    for (int k = 0; k < nf; k++)
        slice_free(&f[k]);
    for (int k = 0; k < nr; k++)
        demo_run_free(&r[k]);
    return code;
}
