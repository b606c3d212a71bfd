/* fuzz_hdr.c — the Radiance .hdr reader, from memory and from a file. */
#include <stdint.h>

#include "fuzz_support.h"
#include "io/hdr.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    sg_image img = {0};
    sg_error err;
    sg_hdr_read_memory(data, size, "fuzz.hdr", &img, &err);
    sg_image_free(&img);
    if (sg_hdr_read(sg_fuzz_file(data, size, ".hdr"), &img, &err) == SG_OK)
        sg_image_free(&img);
    return 0;
}
