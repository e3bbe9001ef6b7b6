/* Closing NetCDF files that may not close (io/ncfile.h). */
#include "io/ncfile.h"

#include <hdf5.h>
#include <malloc.h>
#include <netcdf.h>
#include <stdatomic.h>

static atomic_int abandoned;

int ncfile_close(int *ncid)
{
    int nc = *ncid;
    *ncid = -1;
    if (nc < 0)
        return NC_NOERR;
    int st = nc_close(nc);
    if (st == NC_NOERR)
        return st;
    /* Release what netCDF holds, without a flush (the caller discards the
     * temporary file anyway). Whether HDF5 let go cannot be told from
     * here (nc_abort may even succeed while HDF5 keeps the file): count
     * it either way. */
    (void)nc_abort(nc);
    atomic_fetch_add(&abandoned, 1);
    return st;
}

int ncfile_abandoned(void) { return atomic_load(&abandoned); }

void ncfile_thread_quiet(void) { (void)H5Eset_auto2(H5E_DEFAULT, NULL, NULL); }

void ncfile_release_memory(void)
{
    /* Only with nothing of HDF5's open (an abandoned file counts): closing
     * the library closes every file and object. */
    if (H5Fget_obj_count((hid_t)H5F_OBJ_ALL, H5F_OBJ_ALL) == 0) {
        (void)H5close();
        /* netCDF-4 turns HDF5's error printing off once, when it first
         * initialises HDF5; the library starts again on its next call with
         * printing on, so it is turned off again here */
        (void)H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
    } else {
        (void)H5garbage_collect();
    }
    (void)malloc_trim(0);
}
