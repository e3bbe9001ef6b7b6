/* The products' background writer (output.writer_thread,
 * service/forecast_writer.c) on the engine's small case
 * (tests/engine_case.h, 6 h, hourly outputs and hourly forcing slices):
 *  - the same products as the writer in the step loop (every variable of
 *    every NetCDF file of the stage, byte for byte, and the text files);
 *  - a write that fails in the thread (SPHICE_FAULT=products-mid-write)
 *    fails the run with the writer's one line, and nothing is written;
 *  - the same with the writer on and two OpenMP threads, and with the
 *    writer at a lower priority (output.writer_nice 19). */
#include <dirent.h>
#include <ftw.h>
#include <netcdf.h>
#include <omp.h>

#include "check.h"
#include "engine_case.h"
#include "service/config.h"
#include "service/forecast.h"
#include "util/err.h"

static char dir[] = "/tmp/sphice-writer-XXXXXX";
static int writer_nice; /* output.writer_nice of the next run_case */

static int run_case(int writer, const char *stage_name, char *stage, size_t len, sph_error *err)
{
    char text[8192];
    ec_config(text, sizeof text, dir, 300, "[\"wind\", \"tair\"]", "ice.nc", "");
    struct sph_config *cfg = NULL;
    sph_error_clear(err);
    int rc = sph_config_parse(text, "test", &cfg, err);
    CHECK(rc == SPH_OK, "config: %s", err->msg);
    if (rc)
        return rc;
    cfg->output.writer_thread = writer;
    cfg->output.writer_nice = writer_nice;
    snprintf(stage, len, "%s/%s", dir, stage_name);
    char atm[1024];
    snprintf(atm, sizeof atm, "%s/atm.nc", dir);
    const char *files[2] = {atm, NULL};
    forecast_request req;
    memset(&req, 0, sizeof req);
    req.cycle_time = EC_CYCLE;
    req.hours = 6;
    req.stage_dir = stage;
    req.forcing_files[0] = files;
    static const char *sums[] = {"atm.nc 0000", NULL};
    req.forcing_sha256[0] = sums[0];
    forecast_progress prog;
    memset((void *)&prog, 0, sizeof prog);
    forecast_result res;
    sph_error_clear(err);
    rc = forecast_run(cfg, &req, &prog, NULL, &res, err);
    sph_config_free(cfg);
    return rc;
}

/* Variables of two NetCDF files that differ (names, types, shapes,
 * bytes); -1 when one cannot be read. */
static int nc_differ(const char *a, const char *b)
{
    int na, nb;
    if (nc_open(a, NC_NOWRITE, &na) != NC_NOERR)
        return -1;
    if (nc_open(b, NC_NOWRITE, &nb) != NC_NOERR) {
        nc_close(na);
        return -1;
    }
    int nva = 0, nvb = 0, bad = 0;
    nc_inq_nvars(na, &nva);
    nc_inq_nvars(nb, &nvb);
    if (nva != nvb)
        bad++;
    for (int v = 0; v < nva && v < nvb; v++) {
        char name[NC_MAX_NAME + 1], nameb[NC_MAX_NAME + 1];
        nc_type ta, tb;
        int nd, ndb, dims[NC_MAX_VAR_DIMS], dimsb[NC_MAX_VAR_DIMS];
        nc_inq_var(na, v, name, &ta, &nd, dims, NULL);
        nc_inq_var(nb, v, nameb, &tb, &ndb, dimsb, NULL);
        if (strcmp(name, nameb) || ta != tb || nd != ndb) {
            bad++;
            continue;
        }
        size_t n = 1, nbv = 1;
        for (int d = 0; d < nd; d++) {
            size_t l, lb;
            nc_inq_dimlen(na, dims[d], &l);
            nc_inq_dimlen(nb, dimsb[d], &lb);
            n *= l;
            nbv *= lb;
        }
        size_t sz = 0;
        if (n != nbv || nc_inq_type(na, ta, NULL, &sz) != NC_NOERR) {
            bad++;
            continue;
        }
        if (ta == NC_STRING || n == 0)
            continue; /* strings: the ice-load product's, not in this case */
        unsigned char *ba = malloc(n * sz), *bb = malloc(n * sz);
        if (!ba || !bb || nc_get_var(na, v, ba) != NC_NOERR || nc_get_var(nb, v, bb) != NC_NOERR ||
            memcmp(ba, bb, n * sz) != 0) {
            printf("  %s: variable %s differs\n", b, name);
            bad++;
        }
        free(ba);
        free(bb);
    }
    nc_close(na);
    nc_close(nb);
    return bad;
}

/* Every NetCDF file of stage a against its namesake in b; the count of
 * files compared in *nfiles. */
static int stage_differ(const char *a, const char *b, int *nfiles)
{
    DIR *d = opendir(a);
    *nfiles = 0;
    if (!d)
        return -1;
    int bad = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        size_t l = strlen(e->d_name);
        if (l < 4 || strcmp(e->d_name + l - 3, ".nc"))
            continue;
        char pa[2048], pb[2048];
        snprintf(pa, sizeof pa, "%s/%s", a, e->d_name);
        snprintf(pb, sizeof pb, "%s/%s", b, e->d_name);
        int r = nc_differ(pa, pb);
        CHECK(r == 0, "%s: %d variables differ (-1: unreadable)", e->d_name, r);
        bad += r != 0;
        (*nfiles)++;
    }
    closedir(d);
    return bad;
}

static int rm_entry(const char *path, const struct stat *sb, int flag, struct FTW *ftw)
{
    (void)sb;
    (void)flag;
    (void)ftw;
    remove(path);
    return 0;
}

int main(int argc, char **argv)
{
    CHECK(ec_start(argv, dir) == 0, "mkdtemp");
    char off[1024], on[1024], on2[1024], fault[1024];
    sph_error err;

    int rc = run_case(CFG_WRITER_OFF, "stage-off", off, sizeof off, &err);
    CHECK(rc == SPH_OK, "writer in the step loop: %s", err.msg);
    rc = run_case(CFG_WRITER_ON, "stage-on", on, sizeof on, &err);
    CHECK(rc == SPH_OK, "writer thread: %s", err.msg);
    int nf = 0, bad = stage_differ(off, on, &nf);
    printf("  writer thread against the step loop: %d NetCDF files, %d differ\n", nf, bad);
    CHECK(nf >= 3, "the fields, particles and restart files at least (%d)", nf);
    CHECK(bad == 0, "the same products");
    CHECK(ec_count_entries(off) == ec_count_entries(on), "the same files (%d, %d)", ec_count_entries(off),
          ec_count_entries(on));

    int nt = omp_get_max_threads();
    omp_set_num_threads(2);
    rc = run_case(CFG_WRITER_ON, "stage-on2", on2, sizeof on2, &err);
    CHECK(rc == SPH_OK, "writer thread, 2 OpenMP threads: %s", err.msg);
    bad = stage_differ(off, on2, &nf);
    CHECK(bad == 0, "the same products with 2 OpenMP threads");
    char nice2[1024];
    writer_nice = 19;
    rc = run_case(CFG_WRITER_ON, "stage-nice2", nice2, sizeof nice2, &err);
    writer_nice = 0;
    omp_set_num_threads(nt);
    CHECK(rc == SPH_OK, "writer thread at nice 19, 2 OpenMP threads: %s", err.msg);
    bad = stage_differ(off, nice2, &nf);
    CHECK(bad == 0, "the same products with the writer at nice 19");

    /* a write that fails in the thread: the run fails with its line */
    setenv("SPHICE_FAULT", "products-mid-write", 1);
    rc = run_case(CFG_WRITER_ON, "stage-fault", fault, sizeof fault, &err);
    unsetenv("SPHICE_FAULT");
    printf("  failed write in the thread -> %s\n", err.msg);
    CHECK(rc == SPH_ERR_IO, "rc %d (want SPH_ERR_IO %d)", rc, SPH_ERR_IO);
    CHECK(strstr(err.msg, "fault injected (products-mid-write)") != NULL, "the writer's line: %s", err.msg);
    CHECK(strchr(err.msg, '\n') == NULL, "one line");
    int n = ec_count_entries(fault);
    CHECK(n <= 0, "nothing written (%d entries in %s)", n, fault);
    nftw(dir, rm_entry, 16, FTW_DEPTH | FTW_PHYS);
    return check_summary("test_writer_thread");
}
