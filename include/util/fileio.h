/* Atomic output and file helpers.
 *
 * A reader never sees half a file: writers create "<final>.tmp.<pid>",
 * write, fsync, rename() over the final name, then fsync the directory. */
#ifndef SPHICE_UTIL_FILEIO_H
#define SPHICE_UTIL_FILEIO_H

#include <stddef.h>
#include "util/err.h"

/* Temporary name beside final_path (same directory, so rename is atomic). */
void atomic_tmp_name(const char *final_path, char *tmp, size_t len);
/* fsync(tmp), rename(tmp, final), fsync(dir). On failure removes tmp. */
int atomic_commit(const char *tmp_path, const char *final_path, sph_error *err);
/* Writes a whole buffer atomically. */
int atomic_write_file(const char *path, const void *data, size_t len, sph_error *err);
/* Points symlink `link_path` at `target` atomically (symlink tmp + rename). */
int atomic_symlink(const char *target, const char *link_path, sph_error *err);
/* mkdir -p */
int mkdir_p(const char *path, sph_error *err);
/* Reads a whole file (NUL-terminated); caller frees. */
int read_file(const char *path, char **data, size_t *len, sph_error *err);
/* SHA-256 of a file as 64 lowercase hex characters plus NUL. */
int sha256_file(const char *path, char hex[65], sph_error *err);
void sha256_hex(const void *data, size_t len, char hex[65]);

/* Fault injection for tests: when the environment variable
 * SPHICE_FAULT equals `point`, returns 1 (the caller then fails or
 * exits as it would on a real fault). Points are documented where used. */
int fault_point(const char *point);

#endif
