/* ncfile_release_memory (io/ncfile.h): the heap a long-running process
 * keeps over NetCDF cycles.
 *
 * A "cycle" here writes a netCDF-4 file the way the products do (an
 * unlimited time, deflated float variables, text and string attributes,
 * one record), closes it, opens it again and reads it back. With libnetcdf
 * 4.9.0 and HDF5 1.10.8 the heap in use (mallinfo2) grows by kilobytes per
 * such cycle although every file is closed (the control loop measures it);
 * with ncfile_release_memory after each cycle it must stay flat: under
 * 1 kB per cycle between cycles 20 and 80. Each cycle checks the values
 * read back, and a bad file after the release still fails with netCDF's
 * error and prints nothing (HDF5's error printing stays off). With a file
 * still open the release must leave it usable. */
#include <fcntl.h>
#include <hdf5.h>
#include <malloc.h>
#include <netcdf.h>
#include <sys/stat.h>
#include <unistd.h>

#include "io/ncfile.h"

#include "check.h"

static char path[256];

static int one_cycle(int k)
{
    int nc, d[2], v[3];
    if (nc_create(path, NC_CLOBBER | NC_NETCDF4, &nc) || nc_def_dim(nc, "time", NC_UNLIMITED, &d[0]) ||
        nc_def_dim(nc, "x", 50, &d[1]))
        return -1;
    for (int j = 0; j < 3; j++) {
        char n[8];
        snprintf(n, sizeof n, "v%d", j);
        if (nc_def_var(nc, n, NC_FLOAT, 2, d, &v[j]) || nc_def_var_deflate(nc, v[j], 1, 1, 4) ||
            nc_put_att_text(nc, v[j], "units", 1, "m"))
            return -1;
    }
    const char *s = "sphice";
    if (nc_put_att_string(nc, NC_GLOBAL, "note", 1, &s) || nc_enddef(nc))
        return -1;
    float x[50], y[50];
    for (int i = 0; i < 50; i++)
        x[i] = (float)(k + i);
    size_t st[2] = {0, 0}, ct[2] = {1, 50};
    for (int j = 0; j < 3; j++)
        if (nc_put_vara_float(nc, v[j], st, ct, x))
            return -1;
    if (nc_close(nc) || nc_open(path, NC_NOWRITE, &nc) || nc_get_vara_float(nc, 1, st, ct, y))
        return -1;
    char *got[1] = {NULL};
    int ok = y[7] == (float)(k + 7) && nc_get_att_string(nc, NC_GLOBAL, "note", got) == NC_NOERR &&
             got[0] && !strcmp(got[0], "sphice");
    if (got[0])
        nc_free_string(1, got);
    return nc_close(nc) == NC_NOERR && ok ? 0 : -1;
}

static size_t in_use(void)
{
    struct mallinfo2 m = mallinfo2();
    return m.uordblks + m.hblkhd;
}

/* kB per cycle between cycles 20 and 80; fails counts bad cycles */
static double growth(int release, int *fails)
{
    size_t at20 = 0;
    *fails = 0;
    for (int k = 0; k <= 80; k++) {
        *fails += one_cycle(k) != 0;
        if (release)
            ncfile_release_memory();
        if (k == 20)
            at20 = in_use();
    }
    return ((double)in_use() - (double)at20) / 60.0 / 1024.0;
}

int main(void)
{
    snprintf(path, sizeof path, "/tmp/test_ncfile_memory.%d.nc", (int)getpid());
    int fails;
    double without = growth(0, &fails);
    CHECK(fails == 0, "control: %d cycles failed", fails);
    double with = growth(1, &fails);
    CHECK(fails == 0, "with the release: %d cycles failed", fails);
    printf("heap growth per cycle: %.2f kB without ncfile_release_memory, %.2f kB with it\n", without, with);
    CHECK(with < 1.0, "flat with the release: %.2f kB per cycle", with);

    /* after a release, a bad file fails quietly, with netCDF's error */
    char bad[300];
    snprintf(bad, sizeof bad, "%s.bad", path);
    FILE *f = fopen(bad, "wb");
    CHECK(f && fwrite("\211HDF\r\n\032\nnot really HDF5 at all, just bytes.......", 1, 48, f) == 48 &&
              fclose(f) == 0, "bad file written");
    char errp[300];
    snprintf(errp, sizeof errp, "%s.stderr", path);
    fflush(stderr);
    int saved = dup(2), fd = open(errp, O_WRONLY | O_CREAT | O_TRUNC, 0600);
    dup2(fd, 2);
    close(fd);
    ncfile_release_memory();
    int nc, st = nc_open(bad, NC_NOWRITE, &nc);
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    struct stat sb;
    CHECK(st != NC_NOERR, "the bad file is refused (%s)", nc_strerror(st));
    CHECK(stat(errp, &sb) == 0 && sb.st_size == 0, "and HDF5 printed nothing (%lld bytes)",
          (long long)sb.st_size);

    /* an open file survives a release */
    CHECK(one_cycle(5) == 0, "a file written");
    int vid;
    float y[50];
    size_t s0[2] = {0, 0}, c0[2] = {1, 50};
    CHECK(nc_open(path, NC_NOWRITE, &nc) == NC_NOERR, "opened");
    ncfile_release_memory();
    CHECK(nc_inq_varid(nc, "v2", &vid) == NC_NOERR && nc_get_vara_float(nc, vid, s0, c0, y) == NC_NOERR &&
              y[49] == 54.0f, "still readable after a release with the file open (%g)", y[49]);
    CHECK(nc_close(nc) == NC_NOERR, "and closes");
    unlink(path);
    unlink(bad);
    unlink(errp);
    return check_summary("test_ncfile_memory");
}
