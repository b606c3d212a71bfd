/* error.c — see error.h. */
#include "core/error.h"

#include <stdarg.h>
#include <stdio.h>

sg_status sg_error_set(sg_error *err, sg_status status, const char *fmt, ...)
{
    if (err) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->message, sizeof err->message, fmt, ap);
        va_end(ap);
        err->status = status;
    }
    return status;
}

void sg_error_clear(sg_error *err)
{
    if (err) {
        err->status = SG_OK;
        err->message[0] = '\0';
    }
}

const char *sg_status_name(sg_status status)
{
    switch (status) {
    case SG_OK: return "SG_OK";
    case SG_ERR_IO: return "SG_ERR_IO";
    case SG_ERR_CORRUPT: return "SG_ERR_CORRUPT";
    case SG_ERR_INVALID_ARG: return "SG_ERR_INVALID_ARG";
    case SG_ERR_NOMEM: return "SG_ERR_NOMEM";
    case SG_ERR_UNSUPPORTED: return "SG_ERR_UNSUPPORTED";
    case SG_ERR_CANCELLED: return "SG_ERR_CANCELLED";
    }
    return "SG_ERR_UNKNOWN";
}
