#include "util/err.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

static const char *const messages[] = {
#define SPH_ERR_MSG_(name, msg) msg,
    SPH_ERR_LIST(SPH_ERR_MSG_)
#undef SPH_ERR_MSG_
};

const char *sph_strerror(int code)
{
    if (code < 0 || code >= SPH_ERR_COUNT_)
        return "unknown error";
    return messages[code];
}

void sph_error_clear(sph_error *e)
{
    if (!e)
        return;
    e->code = SPH_OK;
    e->msg[0] = '\0';
}

int sph_err_set(sph_error *e, int code, const char *fmt, ...)
{
    if (!e || e->code != SPH_OK)
        return code;
    e->code = code;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(e->msg, sizeof e->msg, fmt, ap);
    va_end(ap);
    return code;
}
