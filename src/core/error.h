/* error.h — status codes and error messages shared by the whole library.
 *
 * Every fallible call returns an sg_status and, when given a non-NULL
 * sg_error, fills it with a message that names the file, the element and the
 * fault ("bunny.ply: vertex 1042: radius is NaN"). The library never prints,
 * never exits and keeps no error in a global: the caller owns the sg_error.
 * Out-parameters are written only when the call returns SG_OK.
 */
#ifndef SG_CORE_ERROR_H
#define SG_CORE_ERROR_H

typedef enum sg_status {
    SG_OK = 0,
    SG_ERR_IO = 1,          /* open/read/write failed (errno-level)          */
    SG_ERR_CORRUPT = 2,     /* file bytes are malformed, truncated, invalid  */
    SG_ERR_INVALID_ARG = 3, /* caller passed something out of contract       */
    SG_ERR_NOMEM = 4,       /* allocation failed or a size overflowed        */
    SG_ERR_UNSUPPORTED = 5, /* valid input that we do not handle             */
    SG_ERR_CANCELLED = 6    /* a callback asked to stop                      */
} sg_status;

#define SG_ERROR_MESSAGE_MAX 512

typedef struct sg_error {
    sg_status status;                    /* copy of the returned status    */
    char message[SG_ERROR_MESSAGE_MAX];  /* NUL-terminated, human readable */
} sg_error;

/* Fills err (if non-NULL) with status and a printf-style message; returns
 * status so that error paths read `return sg_error_set(err, ...);`. A
 * message longer than SG_ERROR_MESSAGE_MAX - 1 bytes keeps its first 200
 * bytes and its end, joined by "...", cut on UTF-8 character boundaries:
 * the fault at the end of "<very long path>: cannot open: ..." survives. */
sg_status sg_error_set(sg_error *err, sg_status status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Resets err to SG_OK with an empty message. err may be NULL. */
void sg_error_clear(sg_error *err);

/* "SG_ERR_CORRUPT" etc.; never NULL. */
const char *sg_status_name(sg_status status);

#endif
