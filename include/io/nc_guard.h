/* Guards around nc_open for NetCDF files that come from outside (forcing,
 * ice rasters, restarts, downloads). Debian 12's libnetcdf 4.9.0 and
 * HDF5 1.10.8 crash or hang on some malformed files (the classic header
 * parser allocates what a header declares before checking it; HDF5 frees
 * invalid pointers under nc_open, netcdf-c #2667). A file is checked here
 * first and refused in one line naming it, so that the library never
 * sees it in the service's process:
 *  - classic (CDF-1, CDF-2 and CDF-5): the whole header is validated
 *    against the format specification and the file's size (magic, numrecs,
 *    every list's tag and count, name lengths, types, attribute value
 *    counts, dimension ids, vsize and begin) before libnetcdf reads it;
 *  - netCDF-4 (HDF5 signature at 0, 512, 1024, ...): the file is opened
 *    first in a separate process that walks every group's dimensions,
 *    variables and attributes (and reads the variables' data when the
 *    file is at most 64 MiB), forked for this file alone so that its state
 *    is the caller's (it closes every descriptor it inherited); if it
 *    dies (a signal, a sanitizer report) or does not finish within the
 *    deadline, the file is refused. An ordinary error of the library
 *    (nc_open failing) is left to the caller, which opens the file itself
 *    and reports it. Not a proof: HDF5 1.10.8's invalid frees depend on
 *    more than the file, and the fuzzer found inputs the child survived
 *    and the caller's open then crashed on (rarer than without the check). The check costs a fork and an open per file (about
 *    2 ms on a small file here; test_nc_guard prints it).
 * Anything else is left to nc_open (which refuses an unknown format). */
#ifndef SPHICE_IO_NC_GUARD_H
#define SPHICE_IO_NC_GUARD_H

#include <stddef.h>
#include <stdint.h>

#include "util/err.h"

/* Checks `path` as above; `label` names it in messages (NULL: the path).
 * SPH_OK when the library may open it; else SPH_ERR_NETCDF (SPH_ERR_IO if
 * it cannot be read) and one line in err. */
int nc_guard_check(const char *path, const char *label, sph_error *err);

/* nc_guard_check, then nc_open(path, NC_NOWRITE, ncid); an nc_open failure
 * is one line with the library's reason. */
int nc_guard_open(const char *path, const char *label, int *ncid, sph_error *err);

/* For files the service reads whole and that are not large (restarts):
 * a netCDF-4 file is never opened by HDF5 in this process. A separate
 * process forked for the file copies it to a temporary CDF-5 file
 * (dimensions, attributes, variables; no groups, string or user types),
 * which is then validated like any classic file and opened here (and
 * unlinked: the open file stays readable). A child that dies, hangs or
 * cannot copy: the file is refused in one line. Classic files: as
 * nc_guard_open. The data are those of the file; chunking and
 * compression do not survive (the reader does not need them). */
int nc_guard_open_isolated(const char *path, const char *label, int *ncid, sph_error *err);

/* nc_open(path, NC_NOWRITE, ncid) with 128 KiB of stack below the
 * caller cleared first, as the checking child opens the file: a reader
 * opens a checked file with this, so that an uninitialised pointer HDF5
 * frees holds the same value in both (see nc_guard.c). */
int nc_guard_nc_open(const char *path, int *ncid);

/* The classic header validator on a buffer holding the file's first n
 * bytes (the whole header must be in it) of a file of file_size bytes.
 * 0 if valid, with *need the size a complete file has (0 when streaming);
 * -1 with the reason in why. */
int nc_guard_classic(const unsigned char *buf, size_t n, uint64_t file_size, uint64_t *need,
                     char *why, size_t whysz);

/* Deadline in seconds for the netCDF-4 checking child (default 20). */
void nc_guard_set_timeout(double seconds);

/* A function the checking child calls first (sanitizer builds: the fuzz
 * harnesses install one that turns a sanitizer report in the child into
 * its death, instead of the fuzzer's crash handling); NULL: none. */
void nc_guard_set_child_hook(void (*hook)(void));

/* The process's NetCDF/HDF5 lock (HDF5 as Debian builds it is not
 * thread-safe): a thread that calls NetCDF while another may (the
 * products' background writer, service/forecast_writer.c, and the forcing's
 * slice reads, io/inputs/forcing.c) holds it around its calls; the forks
 * of the checks above take it too, so that a child never starts from a
 * state another thread is changing. Recursive; a process with one thread
 * in NetCDF need not take it. */
void nc_guard_lock(void);
void nc_guard_unlock(void);

/* Statistics since the process started: netCDF-4 files checked in a child,
 * and those refused because the child died or ran past the deadline. */
void nc_guard_stats(long *probed, long *died, long *timed_out);

#endif
