/* fuzz_support.h — what the harnesses share: the fuzzer's bytes as a file
 * with a given extension (the readers take paths and choose by extension),
 * in a per-process folder under $TMPDIR (tmpfs on CI runners). */
#ifndef SG_FUZZ_SUPPORT_H
#define SG_FUZZ_SUPPORT_H

#include <stddef.h>
#include <stdint.h>

/* Writes data to "<tmp>/input<ext>" and returns that path (static storage).
 * Aborts on I/O failure: a harness that cannot write its input is broken. */
const char *sg_fuzz_file(const uint8_t *data, size_t size, const char *ext);

#endif
