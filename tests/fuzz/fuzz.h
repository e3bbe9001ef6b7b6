/* Shared by the libFuzzer harnesses in tests/fuzz/ (built by `make fuzz`).
 *
 * The readers take a path, so the input goes into an anonymous in-memory
 * file (memfd) and its /proc/self/fd/N name is given to the reader: no
 * disk traffic, one file per process, rewritten for each input. */
#ifndef SPHICE_TESTS_FUZZ_H
#define SPHICE_TESTS_FUZZ_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <udunits2.h>
#include <unistd.h>

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

/* The path of a file holding exactly data[0..size). slot: one file per
 * slot (a harness that needs two files at once uses slots 0 and 1). */
static inline const char *fuzz_file(int slot, const uint8_t *data, size_t size)
{
    static int fd[2] = {-1, -1};
    static char path[2][64];
    if (fd[slot] < 0) {
        fd[slot] = memfd_create("sphice-fuzz", 0);
        if (fd[slot] < 0) {
            perror("memfd_create");
            abort();
        }
        snprintf(path[slot], sizeof path[slot], "/proc/self/fd/%d", fd[slot]);
    }
    if (ftruncate(fd[slot], 0) != 0 || pwrite(fd[slot], data, size, 0) != (ssize_t)size) {
        perror("fuzz input");
        abort();
    }
    return path[slot];
}

#endif
