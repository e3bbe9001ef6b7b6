/* Shared by the libFuzzer harnesses in tests/fuzz/ (built by `make fuzz`).
 *
 * The readers take a path, so the input goes into a file of this process
 * in /dev/shm (tmpfs: no disk traffic; $TMPDIR or /tmp where there is
 * none), rewritten for each input and removed at exit. Not a memfd's
 * /proc/self/fd/N: HDF5 cannot open that, so netCDF-4 inputs would all
 * fail at the door. */
#ifndef SPHICE_TESTS_FUZZ_H
#define SPHICE_TESTS_FUZZ_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <fcntl.h>
#include <sanitizer/common_interface_defs.h>
#include <udunits2.h>
#include <unistd.h>

#include "io/nc_guard.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* The readers load the udunits2 database (an XML file set, some
 * milliseconds) on every read; that would hold the raster and forcing
 * harnesses to about 150 inputs a second. The harnesses are linked with
 * -Wl,--wrap=ut_read_xml,--wrap=ut_free_system (Makefile): the first read
 * loads the database, later ones get the same read-only system and "free"
 * leaves it in place. The readers' code is unchanged. */
ut_system *__real_ut_read_xml(const char *path);
void __real_ut_free_system(ut_system *system);
ut_system *__wrap_ut_read_xml(const char *path);
void __wrap_ut_free_system(ut_system *system);
static ut_system *fuzz_units_;
ut_system *__wrap_ut_read_xml(const char *path)
{
    if (path)
        return __real_ut_read_xml(path);
    if (!fuzz_units_)
        fuzz_units_ = __real_ut_read_xml(NULL);
    return fuzz_units_;
}
void __wrap_ut_free_system(ut_system *system)
{
    if (system != fuzz_units_)
        __real_ut_free_system(system);
}

static char fuzz_path_[2][512];

static void fuzz_files_remove(void)
{
    for (int k = 0; k < 2; k++)
        if (fuzz_path_[k][0])
            unlink(fuzz_path_[k]);
}

/* The path of a file holding exactly data[0..size). slot: one file per
 * slot (a harness that needs two files at once uses slots 0 and 1). */
static inline const char *fuzz_file(int slot, const uint8_t *data, size_t size)
{
    if (!fuzz_path_[slot][0]) {
        const char *dir = access("/dev/shm", W_OK) == 0 ? "/dev/shm"
                          : getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp";
        snprintf(fuzz_path_[slot], sizeof fuzz_path_[slot], "%s/sphice-fuzz-%ld-%d", dir,
                 (long)getpid(), slot);
        atexit(fuzz_files_remove);
    }
    int fd = open(fuzz_path_[slot], O_WRONLY | O_CREAT | O_TRUNC, 0600);
    if (fd < 0 || (size && write(fd, data, size) != (ssize_t)size) || close(fd) != 0) {
        perror(fuzz_path_[slot]);
        abort();
    }
    return fuzz_path_[slot];
}

/* The readers check a netCDF-4 input in a forked child first (io/nc_guard.h).
 * In the child a sanitizer report (an invalid free inside HDF5) must end
 * the child, which gets the input refused, and not run libFuzzer's crash
 * handler (which would write the input as a crash of this process); the
 * deadline stays under libFuzzer's -timeout. At exit, one line counts the
 * inputs refused that way. */
static inline void fuzz_child_died_(void) { _exit(86); }
static inline void fuzz_child_hook_(void) { __sanitizer_set_death_callback(fuzz_child_died_); }
static inline void fuzz_guard_report_(void)
{
    long probed = 0, died = 0, late = 0;
    nc_guard_stats(&probed, &died, &late);
    fprintf(stderr, "nc_guard: %ld netCDF-4 inputs checked in a child: %ld refused as the child died, "
            "%ld as it ran past the deadline\n", probed, died, late);
}
static inline void fuzz_guard_setup(void)
{
    static int done;
    if (done)
        return;
    done = 1;
    nc_guard_set_timeout(5.0);
    nc_guard_set_child_hook(fuzz_child_hook_);
    atexit(fuzz_guard_report_);
}

#endif
