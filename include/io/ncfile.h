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

/* Hands back the memory HDF5 and the allocator keep between cycles.
 * With libnetcdf 4.9.0 and HDF5 1.10.8 every nc_create/nc_enddef/nc_open
 * leaves HDF5-internal allocations that no close and no H5garbage_collect
 * frees (2.5 to 8 kB per file and cycle; in the soak 26 kB per cycle, by
 * valgrind's reachable-increase between cycles): HDF5 frees them only when
 * the library is closed. So when no HDF5 file or object is open, this
 * closes the library (H5close; the next NetCDF call starts it again) and
 * turns HDF5's error printing off again as netCDF-4 does; otherwise it
 * only empties HDF5's free lists (H5garbage_collect). Then malloc_trim
 * returns the allocator's free pages (the cycle runs in a thread whose
 * arena otherwise keeps them). A long-running process calls this once per
 * cycle, from the thread that runs the cycles, with no other thread in
 * NetCDF (test_ncfile_memory, make soak). */
void ncfile_release_memory(void);

/* Turns HDF5's error printing off for the calling thread. netCDF-4 turns it
 * off when it first initialises HDF5, but a thread-safe HDF5 keeps the
 * setting per thread: without this every other thread that opens a file
 * prints HDF5-DIAG stacks on stderr for the attributes netCDF probes and
 * does not find (netCDF 4.9's _Quantize* on every variable). Every thread
 * that makes NetCDF calls (the daemon's cycle worker, the products' writer)
 * calls it first (test_hdf5_quiet). */
void ncfile_thread_quiet(void);

#endif
