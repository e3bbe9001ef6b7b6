/* ESRI ASCII raster header values beyond the range of long (issue 21 item
 * 14: a fuzzer found `(long)v` with v = 1e30, undefined behaviour): the
 * reader must refuse them with one line that gives the value as written,
 * not a wrapped count. Run under `make sanitize` the old cast aborts. */
#include "io/raster.h"

#include <unistd.h>

#include "check.h"

static void expect_refused(const char *dir, const char *name, const char *header,
                           const char *want)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s.asc", dir, name);
    FILE *f = fopen(path, "w");
    CHECK(f != NULL, "create %s", path);
    if (!f)
        return;
    fprintf(f, "%s0.5 0.5\n0.5 0.5\n", header);
    fclose(f);
    ice_raster *r = NULL;
    sph_error err;
    sph_error_clear(&err);
    int rc = ice_raster_read(path, NULL, &r, &err);
    CHECK(rc != SPH_OK && r == NULL, "%s: accepted", name);
    CHECK(strstr(err.msg, path) && strstr(err.msg, want) && !strchr(err.msg, '\n'),
          "%s: message \"%s\" lacks \"%s\" or is not one line", name, err.msg, want);
    unlink(path);
}

int main(void)
{
    char dir[] = "/tmp/sphice-test-raster-esri-XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    expect_refused(dir, "hugecols",
                   "ncols 1e30\nnrows 2\nxllcenter 121\nyllcenter 40\ncellsize 0.1\n",
                   "ncols 1e+30");
    expect_refused(dir, "hugerows",
                   "ncols 2\nnrows -1e300\nxllcenter 121\nyllcenter 40\ncellsize 0.1\n",
                   "nrows -1e+300");
    expect_refused(dir, "nanrows",
                   "ncols 2\nnrows nan\nxllcenter 121\nyllcenter 40\ncellsize 0.1\n",
                   "nrows nan");
    /* a good 2 x 2 grid still reads */
    char path[512];
    snprintf(path, sizeof path, "%s/good.asc", dir);
    FILE *f = fopen(path, "w");
    fprintf(f, "ncols 2\nnrows 2\nxllcenter 121\nyllcenter 40\ncellsize 0.1\n50 60\n70 80\n");
    fclose(f);
    ice_raster *r = NULL;
    sph_error err;
    sph_error_clear(&err);
    CHECK(ice_raster_read(path, NULL, &r, &err) == SPH_OK, "good grid: %s", err.msg);
    if (r)
        CHECK(r->nlon == 2 && r->nlat == 2 && fabs(r->conc[0] - 0.7) < 1e-12,
              "good grid: %d x %d, conc[0] %g (want 0.7, south-west)", r->nlon, r->nlat,
              r->conc[0]);
    ice_raster_free(r);
    unlink(path);
    rmdir(dir);
    return check_summary("test_raster_esri");
}
