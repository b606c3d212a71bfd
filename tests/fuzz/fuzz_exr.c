/* fuzz_exr.c — EXR files through the reader the envmap uses (OpenEXR's C++
 * library behind sg_exr_read, with the data-window check), then the
 * envmap built from what it read.
 *
 * Decoding is skipped above SG_FUZZ_EXR_MAX_PIXELS: a mutated data window
 * can claim a legal image of up to 65536 x 65536 pixels in a file of a few
 * hundred KB (DWAB packs a constant 8x8 block into next to nothing), and
 * decoding that many pixels takes longer than the fuzzer's 10 s timeout
 * under ASan (seen in CI: studio.exr with its width raised). Time and
 * memory that grow with the size the file states are not a memory-safety
 * defect; the header of such a file is still parsed (sg_exr_read_size). */
#include <stdint.h>

#include "envmap/envmap.h"
#include "fuzz_support.h"
#include "io/exr_read.h"

/* 4M pixels: 48 MB as float RGB, about 0.5 s to decode under ASan. */
#define SG_FUZZ_EXR_MAX_PIXELS (4 << 20)

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = sg_fuzz_file(data, size, ".exr");
    sg_image img = {0};
    sg_error err;
    int w = 0, h = 0;
    if (sg_exr_read_size(path, &w, &h, &err) != SG_OK || (int64_t)w * h > SG_FUZZ_EXR_MAX_PIXELS)
        return 0;
    if (sg_exr_read(path, &img, NULL, &err) == SG_OK) {
        sg_envmap *m = NULL;
        sg_envmap_desc d = {.image = &img};
        if (img.width <= 512 && img.height <= 512 && sg_envmap_create(&d, &m, &err) == SG_OK) {
            float pdf;
            sg_envmap_sample(m, 0.3f, 0.7f, &pdf);
            sg_envmap_eval(m, sg_v3(0.2f, 0.9f, -0.1f));
            sg_envmap_destroy(m);
        }
        sg_image_free(&img);
    }
    return 0;
}
