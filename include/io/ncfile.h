/* Closing a NetCDF file that may not close.
 *
 * nc_close fails when HDF5 cannot flush the file (a full disk, a file-size
 * limit). The file then stays open inside HDF5 -- with HDF5 1.10 even
 * nc_abort and H5Fclose leave it -- and HDF5's exit handler crashes
 * (SIGSEGV, exit status 139) trying to flush it once more. ncfile_close
 * closes, on failure aborts, and counts the file as abandoned; a program
 * that abandoned one leaves without running the exit handlers (main.c),
 * so that it exits with its own status. The file itself is a temporary one
 * that the writer removes, so nothing published is affected. */
#ifndef SPHICE_IO_NCFILE_H
#define SPHICE_IO_NCFILE_H

/* Closes *ncid (nothing when it is < 0) and sets it to -1. Returns the
 * NetCDF status of nc_close (NC_NOERR when closed). */
int ncfile_close(int *ncid);
/* How many files this process could not close (see above). */
int ncfile_abandoned(void);

/* Hands the memory HDF5 keeps on its free lists back to the allocator
 * (H5garbage_collect). netCDF-4 leaves the blocks each nc_enddef and
 * nc_close freed on HDF5's free lists, which grow up to tens of MiB by
 * default; a long-running process calls this once per cycle, with no
 * NetCDF file open, so that its resident memory stays flat. */
void ncfile_release_memory(void);

#endif
