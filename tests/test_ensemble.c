/* Ensembles (issue 24 item 1): the perturbation fields against their
 * formula (variance, Gaussian correlation length, e-folding time), the
 * ensemble products against hand computations (mean, spread, probability
 * as the fraction of members, the spatial probability score of Goessling
 * & Jung 2018, the median's IIEE), and the engine: zero perturbations
 * give members equal to the control bit for bit, the same seed gives the
 * same ensemble, thread counts do not change a member. */
#include <math.h>
#include <netcdf.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "check.h"
#include "engine_case.h"
#include "core/perturb.h"
#include "io/ensemble.h"
#include "service/config.h"
#include "service/ensemble.h"
#include "service/forecast.h"
#include "service/cycle.h"
#include "util/fileio.h"
#include "util/log.h"

static char dir[] = "/tmp/sphice-ensemble-XXXXXX";

/* ---- 1. the random fields ---- */

static void test_fields(void)
{
    const double sigma = 2.0, L = 50e3, T = 86400.0;
    const int M = 64, R = 120;
    /* spatial variance of one realisation over a domain of 40 L x 40 L,
     * averaged over R realisations: sigma^2 */
    double var = 0.0, mean = 0.0;
    long cnt = 0;
    /* correlation at the lags L/2, L, 2L and at tau = T, averaged over
     * realisations and points: exp(-r^2 / (2 L^2)) and exp(-1) */
    const double lags[3] = {0.5 * L, L, 2.0 * L};
    double cr[3] = {0, 0, 0}, ct = 0.0;
    for (int r = 0; r < R; r++) {
        sph_rfield f;
        CHECK(sph_rfield_init(&f, M, sigma, L, T, sph_perturb_seed(7, r + 1, 1)) == 0, "init");
        for (int j = 0; j < 40; j++)
            for (int i = 0; i < 40; i++) {
                double x = i * L, y = j * L * 1.1;
                double v = sph_rfield_eval(&f, x, y, 0.0);
                var += v * v;
                mean += v;
                cnt++;
                for (int l = 0; l < 3; l++)
                    cr[l] += v * sph_rfield_eval(&f, x + lags[l] * 0.6, y + lags[l] * 0.8, 0.0);
                ct += v * sph_rfield_eval(&f, x, y, T);
            }
        sph_rfield_free(&f);
    }
    var /= cnt;
    mean /= cnt;
    CHECK_CLOSE(var, sigma * sigma, 0.05, 0.0, "variance = sigma^2");
    CHECK(fabs(mean) < 0.05 * sigma, "mean %g ~ 0", mean);
    for (int l = 0; l < 3; l++) {
        double rho = cr[l] / cnt / (sigma * sigma), want = exp(-lags[l] * lags[l] / (2 * L * L));
        CHECK(fabs(rho - want) < 0.04, "correlation at %.0f km: %.4f, formula %.4f", lags[l] / 1e3, rho, want);
    }
    double rt = ct / cnt / (sigma * sigma);
    CHECK(fabs(rt - exp(-1.0)) < 0.05, "time correlation at T: %.4f, formula %.4f", rt, exp(-1.0));
    /* the correlation length fitted from the lag-L correlation */
    double rho1 = cr[1] / cnt / (sigma * sigma);
    double Lfit = rho1 > 0 && rho1 < 1 ? L / sqrt(-2.0 * log(rho1)) : NAN;
    CHECK_CLOSE(Lfit, L, 0.05, 0.0, "fitted correlation length");
    printf("test_ensemble: fields: variance %.4f (sigma^2 %.4f), fitted L %.1f km (50), time correlation %.3f "
           "(exp(-1) %.3f)\n",
           var, sigma * sigma, Lfit / 1e3, rt, exp(-1.0));

    /* the same seed: the same field bit for bit; another member: another */
    sph_rfield a, b, c;
    CHECK(sph_rfield_init(&a, M, sigma, L, T, sph_perturb_seed(11, 3, 1)) == 0, "a");
    CHECK(sph_rfield_init(&b, M, sigma, L, T, sph_perturb_seed(11, 3, 1)) == 0, "b");
    CHECK(sph_rfield_init(&c, M, sigma, L, T, sph_perturb_seed(11, 4, 1)) == 0, "c");
    double va = sph_rfield_eval(&a, 1234.5, -987.0, 3600.0), vb = sph_rfield_eval(&b, 1234.5, -987.0, 3600.0);
    CHECK(memcmp(&va, &vb, sizeof va) == 0, "same seed, same value");
    CHECK(va != sph_rfield_eval(&c, 1234.5, -987.0, 3600.0), "another member differs");
    sph_rfield_free(&a);
    sph_rfield_free(&b);
    sph_rfield_free(&c);
    /* sigma 0: the zero field */
    sph_rfield z;
    CHECK(sph_rfield_init(&z, M, 0.0, L, T, 1) == 0 && z.nmodes == 0 && sph_rfield_eval(&z, 1, 2, 3) == 0.0,
          "zero field");
}

/* ---- 2. the products against hand computations ---- */

#define NLON 3
#define NLAT 2
#define NT 2

static void write_member(const char *path, const double *conc, const double *vol)
{
    int nc, dt, dy, dx, vt, vy, vx, vl, vc, vv;
    NCW(nc_create(path, NC_CLOBBER | NC_NETCDF4, &nc));
    NCW(nc_def_dim(nc, "time", NC_UNLIMITED, &dt));
    NCW(nc_def_dim(nc, "lat", NLAT, &dy));
    NCW(nc_def_dim(nc, "lon", NLON, &dx));
    NCW(nc_def_var(nc, "time", NC_DOUBLE, 1, &dt, &vt));
    NCW(nc_def_var(nc, "lat", NC_DOUBLE, 1, &dy, &vy));
    NCW(nc_def_var(nc, "lon", NC_DOUBLE, 1, &dx, &vx));
    int d2[2] = {dy, dx}, d3[3] = {dt, dy, dx};
    NCW(nc_def_var(nc, "landmask", NC_BYTE, 2, d2, &vl));
    NCW(nc_def_var(nc, "siconc", NC_FLOAT, 3, d3, &vc));
    NCW(nc_def_var(nc, "sivol", NC_FLOAT, 3, d3, &vv));
    float fill = 1e20f;
    NCW(nc_put_att_float(nc, vc, "_FillValue", NC_FLOAT, 1, &fill));
    NCW(nc_put_att_float(nc, vv, "_FillValue", NC_FLOAT, 1, &fill));
    NCW(nc_enddef(nc));
    double t[NT] = {EC_CYCLE, EC_CYCLE + 3600}, lat[NLAT] = {60.0, 60.5}, lon[NLON] = {10.0, 10.5, 11.0};
    signed char land[NLAT * NLON] = {0, 0, 0, 0, 0, 1};
    size_t st[3] = {0, 0, 0}, ct[3] = {NT, NLAT, NLON};
    NCW(nc_put_vara_double(nc, vt, st, ct, t));
    NCW(nc_put_var_double(nc, vy, lat));
    NCW(nc_put_var_double(nc, vx, lon));
    NCW(nc_put_var_schar(nc, vl, land));
    NCW(nc_put_vara_double(nc, vc, st, ct, conc));
    NCW(nc_put_vara_double(nc, vv, st, ct, vol));
    NCW(nc_close(nc));
}

static void read_var(const char *path, const char *name, float *out)
{
    int nc, v;
    NCW(nc_open(path, NC_NOWRITE, &nc));
    NCW(nc_inq_varid(nc, name, &v));
    NCW(nc_get_var_float(nc, v, out));
    NCW(nc_close(nc));
}

static void test_products(void)
{
    enum { N = 4, NC = NLAT * NLON };
    /* concentrations of four members at two times on a 3 x 2 grid, the
     * last cell land (fill) */
    double c[N][NT * NC], v[N][NT * NC];
    const double base[NC] = {0.05, 0.3, 0.9, 0.1, 0.6, 1e20};
    for (int m = 0; m < N; m++)
        for (int t = 0; t < NT; t++)
            for (int k = 0; k < NC; k++) {
                double x = base[k] >= 1e19 ? 1e20 : fmin(1.0, base[k] + 0.1 * m + 0.05 * t);
                c[m][t * NC + k] = x;
                v[m][t * NC + k] = x >= 1e19 ? 1e20 : 0.5 * x;
            }
    char paths[N][1100];
    const char *pp[N];
    for (int m = 0; m < N; m++) {
        snprintf(paths[m], sizeof paths[m], "%s/member%d.nc", dir, m);
        write_member(paths[m], c[m], v[m]);
        pp[m] = paths[m];
    }
    /* the observation at the second time: ice in cells 1, 2, 4 */
    double obs[NC] = {0.0, 0.5, 1.0, 0.0, 0.2, NAN};
    double levels[2] = {0.5, 1.0};
    ens_options o = {0};
    o.stage = dir;
    o.prefix = "t";
    o.member_fields = pp;
    o.nmembers = N;
    o.threshold = 0.15;
    o.levels = levels;
    o.nlevels = 2;
    o.obs = obs;
    o.t_obs = EC_CYCLE + 3000; /* nearest output time: the second */
    o.seed = 5;
    o.cycle_time = EC_CYCLE;
    ens_summary s;
    sph_error err;
    sph_error_clear(&err);
    CHECK(ens_products_write(&o, &s, &err) == SPH_OK, "ens_products_write: %s", err.msg);
    char path[1200];
    snprintf(path, sizeof path, "%s/t_ensemble.nc", dir);
    float mean[NT * NC], spread[NT * NC], prob[NT * NC];
    read_var(path, "siconc_mean", mean);
    read_var(path, "siconc_spread", spread);
    read_var(path, "siconc_prob", prob);
    for (int t = 0; t < NT; t++)
        for (int k = 0; k < NC; k++) {
            int i = t * NC + k;
            if (base[k] >= 1e19) {
                CHECK(mean[i] >= 1e19f && prob[i] >= 1e19f, "land is fill");
                continue;
            }
            double sum = 0, sq = 0;
            int ice = 0;
            for (int m = 0; m < N; m++) {
                sum += c[m][i];
                ice += c[m][i] >= 0.15;
            }
            double mu = sum / N;
            for (int m = 0; m < N; m++)
                sq += (c[m][i] - mu) * (c[m][i] - mu);
            CHECK_CLOSE(mean[i], mu, 1e-6, 1e-7, "ensemble mean");
            CHECK_CLOSE(spread[i], sqrt(sq / N), 1e-6, 1e-7, "ensemble spread (divisor N)");
            CHECK(prob[i] == (float)((double)ice / N), "probability = fraction of members: %g vs %d/%d",
                  prob[i], ice, N);
        }
    /* SPS by hand at the second time: sum (P - O)^2 dA over sea cells
     * with an observation; dA = R^2 dlon (sin(lat_n) - sin(lat_s)) */
    const double R = 6371.0, d2r = M_PI / 180.0;
    double sps = 0.0, iiee = 0.0;
    for (int k = 0; k < NC; k++) {
        if (base[k] >= 1e19 || !isfinite(obs[k]))
            continue;
        int j = k / NLON;
        double latc = 60.0 + 0.5 * j;
        double dA = R * R * 0.5 * d2r * (sin((latc + 0.25) * d2r) - sin((latc - 0.25) * d2r));
        int ice = 0;
        double col[N];
        for (int m = 0; m < N; m++) {
            col[m] = c[m][NC + k];
            ice += col[m] >= 0.15;
        }
        double P = (double)ice / N, O = obs[k] >= 0.15;
        sps += (P - O) * (P - O) * dA;
        /* the median of four: mean of the middle two (already sorted: c grows with m) */
        double med = 0.5 * (col[1] + col[2]);
        iiee += fabs((med >= 0.15) - O) * dA;
    }
    CHECK(s.has_scores, "scores");
    CHECK_CLOSE(s.sps_km2, sps, 1e-9, 0.0, "SPS against the hand computation");
    CHECK_CLOSE(s.iiee_median_km2, iiee, 1e-9, 0.0, "IIEE of the median");
    /* one member: SPS equals the IIEE (Goessling & Jung 2018) */
    o.nmembers = 1;
    CHECK(ens_products_write(&o, &s, &err) == SPH_OK, "one member: %s", err.msg);
    CHECK_CLOSE(s.sps_km2, s.iiee_median_km2, 1e-12, 0.0, "one member: SPS = IIEE");
    /* a member on another grid is refused, naming it */
    snprintf(paths[2], sizeof paths[2], "%s/ice.nc", dir);
    o.nmembers = N;
    sph_error_clear(&err);
    CHECK(ens_products_write(&o, &s, &err) != SPH_OK && strstr(err.msg, "ice.nc"), "bad member: %s", err.msg);
}

/* ---- 3. the engine ---- */

static const char *atm_files[2];

static struct sph_config *load(const char *extra)
{
    char text[8192];
    ec_config(text, sizeof text, dir, 300, "[\"wind\", \"tair\"]", "ice.nc", extra);
    struct sph_config *cfg = NULL;
    sph_error err;
    sph_error_clear(&err);
    int rc = sph_config_parse(text, "test", &cfg, &err);
    CHECK(rc == SPH_OK, "config: %s", err.msg);
    return cfg;
}

static int run(const struct sph_config *cfg, const char *name, forecast_result *res, sph_error *err)
{
    char stage[1100];
    snprintf(stage, sizeof stage, "%s/%s", dir, name);
    mkdir(stage, 0755);
    forecast_request req;
    memset(&req, 0, sizeof req);
    req.cycle_time = EC_CYCLE;
    req.hours = 2;
    req.stage_dir = stage;
    req.forcing_files[0] = atm_files;
    static const char *sums[] = {"atm.nc 0000", NULL};
    req.forcing_sha256[0] = sums[0];
    sph_error_clear(err);
    return ensemble_run(cfg, &req, NULL, NULL, res, err);
}

static size_t nvals(void) { return (size_t)3 * 61 * 101; }

static float *field(const char *name, const char *file, const char *var)
{
    char p[1300];
    snprintf(p, sizeof p, "%s/%s/%s", dir, name, file);
    float *f = malloc(nvals() * sizeof *f);
    int nc, v;
    size_t n;
    int dt;
    if (!f || nc_open(p, NC_NOWRITE, &nc) != NC_NOERR) {
        CHECK(0, "open %s", p);
        free(f);
        return NULL;
    }
    CHECK(nc_inq_dimid(nc, "time", &dt) == NC_NOERR && nc_inq_dimlen(nc, dt, &n) == NC_NOERR && n == 3,
          "3 output times in %s", p);
    NCW(nc_inq_varid(nc, var, &v));
    NCW(nc_get_var_float(nc, v, f));
    NCW(nc_close(nc));
    return f;
}

static void test_engine(void)
{
    forecast_result res;
    sph_error err;
    /* zero perturbations: every member is the control, bit for bit */
    struct sph_config *cfg = load("\"ensemble\": {\"members\": 3, \"member_products\": true},");
    CHECK(cfg && run(cfg, "zero", &res, &err) == SPH_OK, "zero ensemble: %s", err.msg);
    CHECK(res.ensemble.members == 3, "members in the result");
    float *c0 = field("zero", "sphice_fields.nc", "siconc");
    float *c2 = field("zero", "members/m002/sphice_fields.nc", "siconc");
    float *sp = field("zero", "sphice_ensemble.nc", "siconc_spread");
    float *mn = field("zero", "sphice_ensemble.nc", "siconc_mean");
    if (c0 && c2 && sp && mn) {
        CHECK(memcmp(c0, c2, nvals() * sizeof *c0) == 0, "member 2 equals the control bit for bit");
        size_t bad = 0, ice = 0;
        for (size_t k = 0; k < nvals(); k++) {
            if (c0[k] >= 1e19f)
                continue;
            bad += sp[k] != 0.0f || mn[k] != c0[k];
            ice += c0[k] > 0.15f;
        }
        CHECK(bad == 0 && ice > 100, "zero spread and mean = control (%zu cells differ, %zu with ice)", bad, ice);
    }
    free(c0);
    free(c2);
    free(sp);
    free(mn);
    sph_config_free(cfg);

    /* perturbed: spread appears, the same seed gives the same ensemble,
     * one thread gives the same as two */
    const char *pert = "\"ensemble\": {\"members\": 3, \"seed\": 42, \"wind\": {\"sigma\": 3, \"length_km\": 30},"
                       " \"initial\": {\"thick_sigma\": 0.2, \"conc_sigma\": 0.1}, \"strength_sigma\": 0.3,"
                       " \"drag_sigma\": 0.2},";
    cfg = load(pert);
    omp_set_num_threads(2);
    CHECK(cfg && run(cfg, "a", &res, &err) == SPH_OK, "perturbed ensemble: %s", err.msg);
    CHECK(res.ensemble.mean_spread_conc > 0, "spread %g > 0", res.ensemble.mean_spread_conc);
    omp_set_num_threads(1);
    CHECK(cfg && run(cfg, "b", &res, &err) == SPH_OK, "again, one thread: %s", err.msg);
    omp_set_num_threads(2);
    const char *vars[3] = {"siconc_mean", "siconc_spread", "sivol_mean"};
    for (int i = 0; i < 3; i++) {
        float *a = field("a", "sphice_ensemble.nc", vars[i]), *b = field("b", "sphice_ensemble.nc", vars[i]);
        CHECK(a && b && memcmp(a, b, nvals() * sizeof *a) == 0, "%s: same seed, 1 and 2 threads: identical",
              vars[i]);
        free(a);
        free(b);
    }
    char p[1200];
    struct stat st;
    snprintf(p, sizeof p, "%s/a/members", dir);
    CHECK(stat(p, &st) != 0, "member products removed without ensemble.member_products");
    snprintf(p, sizeof p, "%s/a/sphice_ensemble_edge.geojson", dir);
    CHECK(stat(p, &st) == 0 && st.st_size > 100, "probability contours written");
    snprintf(p, sizeof p, "%s/a/manifest.json", dir);
    char *text = NULL;
    size_t len = 0;
    if (read_file(p, &text, &len, &err) == SPH_OK) {
        CHECK(strstr(text, "sphice_ensemble.nc") && strstr(text, "sphice_ensemble_edge.geojson"),
              "ensemble products in the manifest");
        free(text);
    }
    sph_config_free(cfg);
    /* another seed: another ensemble */
    cfg = load("\"ensemble\": {\"members\": 3, \"seed\": 43, \"wind\": {\"sigma\": 3, \"length_km\": 30}},");
    CHECK(cfg && run(cfg, "c", &res, &err) == SPH_OK, "seed 43: %s", err.msg);
    float *a = field("a", "sphice_ensemble.nc", "siconc_spread"), *c = field("c", "sphice_ensemble.nc", "siconc_spread");
    CHECK(a && c && memcmp(a, c, nvals() * sizeof *a) != 0, "another seed, another ensemble");
    free(a);
    free(c);
    sph_config_free(cfg);

    /* bad keys: one line naming the key */
    const char *bad[2] = {"\"ensemble\": {\"members\": 2, \"levels\": [0.5, 1.5]},",
                          "\"ensemble\": {\"members\": 0},"};
    for (int i = 0; i < 2; i++) {
        char text2[8192];
        ec_config(text2, sizeof text2, dir, 300, "[\"wind\"]", "ice.nc", bad[i]);
        struct sph_config *cb = NULL;
        sph_error_clear(&err);
        CHECK(sph_config_parse(text2, "test", &cb, &err) != SPH_OK && strstr(err.msg, "ensemble.") &&
                  !strchr(err.msg, '\n'),
              "bad ensemble key refused: %s", err.msg);
        sph_config_free(cb);
    }
}

int main(int argc, char **argv)
{
    (void)argc;
    ec_passive_openmp(argv);
    sph_log_level = LOG_LVL_WARN;
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    ec_write_inputs(dir);
    char atm[1024];
    snprintf(atm, sizeof atm, "%s/atm.nc", dir);
    atm_files[0] = atm;
    atm_files[1] = NULL;
    test_fields();
    test_products();
    test_engine();
    if (!getenv("SPHICE_KEEP"))
        cycle_remove_tree(dir);
    return check_summary("test_ensemble");
}
