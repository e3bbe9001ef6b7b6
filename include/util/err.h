/* One error enum and one message table for the whole program (except the
 * numerical core, which reports through sph_status in core/model.h).
 * 0 is success. Messages that reach an operator are built with sph_err_set,
 * which names the operation, the file or URL, and the cause. */
#ifndef SPHICE_UTIL_ERR_H
#define SPHICE_UTIL_ERR_H

#include <stddef.h>

#define SPH_ERR_LIST(X)                                              \
    X(SPH_OK, "success")                                             \
    X(SPH_ERR_NOMEM, "out of memory")                                \
    X(SPH_ERR_IO, "input/output error")                              \
    X(SPH_ERR_NETCDF, "NetCDF error")                                \
    X(SPH_ERR_MISSING_VAR, "variable not found")                     \
    X(SPH_ERR_UNITS, "unknown or incompatible units")                \
    X(SPH_ERR_COVERAGE, "data do not cover the request")             \
    X(SPH_ERR_BAD_DATA, "bad data value")                            \
    X(SPH_ERR_DOWNLOAD, "download failed")                           \
    X(SPH_ERR_CONFIG, "invalid configuration")                       \
    X(SPH_ERR_PARAM, "parameter out of range")                       \
    X(SPH_ERR_NUMERICS, "numerical failure")                         \
    X(SPH_ERR_LOCKED, "cycle locked by another process")             \
    X(SPH_ERR_CANCELLED, "cancelled")                                \
    X(SPH_ERR_STALE, "forcing is stale")                             \
    X(SPH_ERR_INTERNAL, "internal error")

typedef enum {
#define SPH_ERR_ENUM_(name, msg) name,
    SPH_ERR_LIST(SPH_ERR_ENUM_)
#undef SPH_ERR_ENUM_
    SPH_ERR_COUNT_
} sph_err;

/* The sentence for a code; never NULL. */
const char *sph_strerror(int code);

/* An error buffer: the first failure wins (later sph_err_set calls on a
 * buffer that already holds a message are ignored, as curl's error buffer). */
typedef struct {
    int code;
    char msg[1024];
} sph_error;

void sph_error_clear(sph_error *e);
/* Sets code and a printf-style message if e is empty; returns code. */
int sph_err_set(sph_error *e, int code, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

#endif
