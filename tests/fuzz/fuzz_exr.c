/* fuzz_exr.c — EXR files through the reader the envmap uses (OpenEXR's C++
 * library behind sg_exr_read, with the data-window check), then the
 * envmap built from what it read. */
#include <stdint.h>

#include "envmap/envmap.h"
#include "fuzz_support.h"
#include "io/exr_read.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = sg_fuzz_file(data, size, ".exr");
    sg_image img = {0};
    sg_error err;
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
