/* HDF5's error printing on threads (io/ncfile.h ncfile_thread_quiet).
 *
 * netCDF-4 switches HDF5's automatic error printing off when it first
 * initialises HDF5, on that thread. A thread-safe HDF5 keeps the setting
 * per thread, so a second thread that opens a netCDF-4 file prints an
 * HDF5-DIAG stack on stderr for every attribute netCDF probes and does not
 * find (netCDF 4.9 probes _QuantizeBitGroomNumberOfSignificantDigits and
 * its siblings on every variable). The products' writer thread and the
 * daemon's cycle worker both open files. Here stderr goes to a file while a
 * thread opens a netCDF-4 file, once without and once with
 * ncfile_thread_quiet: with it, nothing may reach stderr. Without it the
 * library prints (checked, so that the test can tell), unless this HDF5 is
 * not thread-safe or this netCDF probes nothing, which is then said. */
#include <netcdf.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "io/ncfile.h"
#include "tmpdir.h"

static char path[512];

static void *opener(void *arg)
{
    if (arg)
        ncfile_thread_quiet();
    int nc, v;
    if (nc_open(path, NC_NOWRITE, &nc) == NC_NOERR) {
        float x[4];
        int natts;
        if (nc_inq_varid(nc, "t", &v) == NC_NOERR) { /* the variable's metadata and data are read lazily */
            (void)nc_inq_varnatts(nc, v, &natts);
            (void)nc_get_var_float(nc, v, x);
        }
        (void)nc_close(nc);
    }
    return NULL;
}

/* Runs opener on a thread with stderr sent to a file; returns the bytes written there. */
static long stderr_of_thread(int quiet, const char *dir)
{
    char log[600];
    snprintf(log, sizeof log, "%s/stderr.txt", dir);
    fflush(stderr);
    int saved = dup(2);
    FILE *f = fopen(log, "w");
    if (!f || saved < 0)
        return -1;
    dup2(fileno(f), 2);
    pthread_t th;
    pthread_create(&th, NULL, opener, quiet ? (void *)1 : NULL);
    pthread_join(th, NULL);
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fclose(f);
    unlink(log);
    return n;
}

int main(void)
{
    char dir[256] = "/tmp/sphice-hdf5quiet-XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "a temporary folder");
    snprintf(path, sizeof path, "%s/f.nc", dir);
    int nc, d, v;
    CHECK(nc_create(path, NC_NETCDF4 | NC_CLOBBER, &nc) == NC_NOERR && nc_def_dim(nc, "x", 4, &d) == NC_NOERR &&
              nc_def_var(nc, "t", NC_FLOAT, 1, &d, &v) == NC_NOERR && nc_close(nc) == NC_NOERR,
          "a netCDF-4 file with one variable");
    /* the main thread initialised HDF5 above (printing off here) */
    long loud = stderr_of_thread(0, dir);
    long quiet = stderr_of_thread(1, dir);
    CHECK(quiet == 0, "a thread with ncfile_thread_quiet printed %ld bytes on stderr", quiet);
    if (loud > 0)
        CHECK(loud > 0, "without it the same thread prints (%ld bytes): the check above can fail", loud);
    else
        printf("test_hdf5_quiet: this HDF5/netCDF prints nothing on a second thread anyway (%ld bytes): "
               "only the quiet case is checked\n", loud);
    tmpdir_remove(dir);
    return check_summary("test_hdf5_quiet");
}
