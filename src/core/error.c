/* error.c — see error.h.
 *
 * A message that does not fit SG_ERROR_MESSAGE_MAX keeps its head and its
 * tail with "..." between: messages read "<file>: <element>: <fault>", so a
 * cut at the end would drop the fault (and a path's extension) exactly when
 * a long path or value makes the message long.
 */
#include "core/error.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Bytes of the head kept when a message is cut; the tail gets the rest. */
#define CUT_HEAD 200
#define CUT_MARK "..."

static int utf8_continuation(char c) { return ((unsigned char)c & 0xC0u) == 0x80u; }

/* Head and tail of full (length n >= SG_ERROR_MESSAGE_MAX) into out, cut
 * on UTF-8 character boundaries. */
static void cut_middle(const char *full, size_t n, char *out)
{
    size_t mark = sizeof CUT_MARK - 1;
    size_t head = CUT_HEAD, tail = SG_ERROR_MESSAGE_MAX - 1 - CUT_HEAD - mark;
    while (head > 0 && utf8_continuation(full[head]))
        --head; /* full[head] is the first byte not kept */
    size_t from = n - tail;
    while (from < n && utf8_continuation(full[from]))
        ++from;
    memcpy(out, full, head);
    memcpy(out + head, CUT_MARK, mark);
    memcpy(out + head + mark, full + from, n - from + 1);
}

sg_status sg_error_set(sg_error *err, sg_status status, const char *fmt, ...)
{
    if (!err)
        return status;
    va_list ap, ap2;
    va_start(ap, fmt);
    va_copy(ap2, ap);
    int n = vsnprintf(err->message, sizeof err->message, fmt, ap);
    va_end(ap);
    if (n >= (int)sizeof err->message) {
        /* Format the whole message once more to keep its tail; without
         * memory for that, the head alone (vsnprintf's cut) stays. */
        char *full = malloc((size_t)n + 1);
        if (full && vsnprintf(full, (size_t)n + 1, fmt, ap2) == n)
            cut_middle(full, (size_t)n, err->message);
        free(full);
    }
    va_end(ap2);
    err->status = status;
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
