/* fuzz_sgbake.c — .sgbake files: the container (header, table, every
 * section's checksum) and the bake loader on a small world, with the
 * file's own scene hash so the loader gets past the first check. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "bake/bake_file.h"
#include "bake/bake_io.h"
#include "fuzz_support.h"
#include "io/scene_file.h"
#include "render/world.h"

static sg_world *world; /* made once: two builtin models */

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc, (void)argv;
    static const char json[] = "{\"models\": [{\"builtin\": \"sphere\", \"points\": 200},"
                               " {\"builtin\": \"ground\", \"points\": 100}]}";
    sg_scene_file sf;
    sg_error err;
    if (sg_scene_file_parse(json, sizeof json - 1, "fuzz", NULL, &sf, &err) != SG_OK ||
        sg_world_create(&sf, &world, &err) != SG_OK)
        abort();
    sg_scene_file_free(&sf);
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = sg_fuzz_file(data, size, ".sgbake");
    sg_bake_file *f = NULL;
    sg_error err;
    uint64_t scene = 0;
    if (sg_bake_file_open(path, 0, 0, &f, &err) == SG_OK) {
        const sg_bake_info *info = sg_bake_file_info(f);
        scene = info->scene_hash;
        for (uint32_t i = 0; i < info->section_count; ++i) {
            const sg_bake_section *s = sg_bake_file_section(f, i);
            if (s->size > (64u << 20))
                continue;
            void *buf = malloc(s->size ? s->size : 1);
            if (buf)
                sg_bake_file_read(f, s->tag, buf, s->size, &err);
            free(buf);
        }
        sg_bake_file_close(f);
    }
    sg_bake *b = NULL;
    if (sg_bake_load(path, world, scene, &b, &err) == SG_OK)
        sg_bake_destroy(b);
    return 0;
}
