/* fuzz_sgworld.c — .sgworld files (render/world_file.h) and the checks
 * behind them (surface/scene_store.h), in two modes chosen by the first
 * byte:
 *  - even: the rest is a world file. Its scene and parameter hashes (bytes
 *    16..31) are set to the fuzz scene's and the header CRC fixed, so the
 *    loader gets past the hash check to the table, the sections and the
 *    arrays, as a file made for this scene would;
 *  - odd: CRCs stop a fuzzer at the file's checksums, so this mode damages
 *    the arrays of a valid world directly: byte 1 picks the model (MLS,
 *    disk, ISO, hybrid, hybrid with lattices of light sites), then each 5 bytes (offset u32, xor u8) flip bits anywhere
 *    in its scalars and arrays; sg_scene_from_store must refuse or give a
 *    scene every query runs on without a fault (rays with and without a
 *    footprint, so the hybrid's level-of-detail path runs too). */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "core/alloc.h"
#include "fuzz_support.h"
#include "io/scene_file.h"
#include "render/world.h"
#include "render/world_file.h"
#include "surface/scene_store.h"

static sg_scene_file scene;    /* the fuzz scene: one model per surface    */
static sg_world *world;        /* its world, built once                    */
static uint8_t hashes[16];     /* bytes 16..31 of its world file           */

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc, (void)argv;
    static const char json[] =
        "{\"models\": [{\"builtin\": \"sphere\", \"points\": 60},"
        " {\"builtin\": \"ground\", \"points\": 16, \"surface\": {\"model\": \"disk\"}},"
        " {\"builtin\": \"sphere\", \"points\": 60, \"surface\": {\"model\": \"iso\"}},"
        " {\"builtin\": \"sphere\", \"points\": 60, \"surface\": {\"model\": \"hybrid\"}},"
        " {\"builtin\": \"ground\", \"points\": 16, \"surface\": {\"model\": \"hybrid\"}}]}";
    sg_error err;
    if (sg_scene_file_parse(json, sizeof json - 1, "fuzz", NULL, &scene, &err) != SG_OK ||
        sg_world_create(&scene, &world, &err) != SG_OK)
        abort();
    const char *path = sg_fuzz_file((const uint8_t *)"", 0, ".sgworld");
    if (sg_world_save(world, &scene, path, &err) != SG_OK)
        abort();
    FILE *f = fopen(path, "rb");
    if (!f || fseek(f, 16, SEEK_SET) != 0 || fread(hashes, 1, sizeof hashes, f) != sizeof hashes)
        abort();
    fclose(f);
    return 0;
}

static void file_mode(const uint8_t *data, size_t size)
{
    uint8_t *buf = malloc(size ? size : 1);
    if (!buf)
        return;
    memcpy(buf, data, size);
    if (size >= 48) {
        memcpy(buf + 16, hashes, sizeof hashes);
        uint32_t crc = (uint32_t)crc32(0, buf, 44);
        for (int i = 0; i < 4; i++)
            buf[44 + i] = (uint8_t)(crc >> (8 * i));
    }
    const char *path = sg_fuzz_file(buf, size, ".sgworld");
    free(buf);
    sg_world *w = NULL;
    sg_error err;
    if (sg_world_load(path, &scene, NULL, &w, &err) == SG_OK) {
        sg_ray r = {.org = {0, 5, 5}, .dir = {0, -0.7071f, -0.7071f}, .tmin = 0, .tmax = INFINITY, .spread = 0.3f};
        sg_world_hit h;
        sg_world_intersect(w, &r, &h, NULL);
        sg_world_destroy(w);
    }
}

static void store_mode(const uint8_t *data, size_t size)
{
    if (size < 1)
        return;
    uint32_t m = data[0] % 5;
    sg_scene_store st;
    sg_scene_store_of(sg_world_scene(world, m), &st);
    /* copies of the arrays, laid end to end after the scalars for the edits */
    void *own[SG_SA_COUNT] = {0};
    size_t bytes[SG_SA_COUNT] = {0}, total = sizeof st.scalars;
    for (int a = 0; a < SG_SA_COUNT; ++a) {
        if (!st.data[a])
            continue;
        const sg_scene_array_spec *sp = sg_scene_array_spec_of((sg_scene_array_id)a);
        bytes[a] = (size_t)st.items[a] * sp->per * sg_store_elem_size(sp->elem);
        if (!(own[a] = sg_alloc_array(bytes[a] ? bytes[a] : 1, 1)))
            goto done;
        memcpy(own[a], st.data[a], bytes[a]);
        st.data[a] = own[a];
        total += bytes[a];
    }
    for (size_t k = 1; k + 5 <= size; k += 5) {
        uint32_t off = (uint32_t)data[k] | (uint32_t)data[k + 1] << 8 | (uint32_t)data[k + 2] << 16 |
                       (uint32_t)data[k + 3] << 24;
        size_t at = off % total;
        if (at < sizeof st.scalars) {
            ((uint8_t *)st.scalars)[at] ^= data[k + 4];
            continue;
        }
        at -= sizeof st.scalars;
        for (int a = 0; a < SG_SA_COUNT; ++a) {
            if (at < bytes[a]) {
                ((uint8_t *)own[a])[at] ^= data[k + 4];
                break;
            }
            at -= bytes[a];
        }
    }
    sg_scene *sc = NULL;
    sg_error err;
    if (sg_scene_from_store(&st, "fuzz", NULL, &sc, &err) == SG_OK) {
        for (int k = 0; k < 16; ++k) {
            float a = 0.39269908f * (float)k;
            sg_ray r = {.org = {4 * cosf(a), 1.5f, 4 * sinf(a)}, .tmin = 0, .tmax = INFINITY};
            r.dir = sg_v3_normalize(sg_v3_sub(sg_v3(0, 0, 0), r.org));
            r.spread = (k & 1) ? 0.3f : 0.0f;
            sg_hit h;
            if (sg_scene_intersect(sc, &r, &h, NULL)) {
                uint32_t ids[8];
                float w[8];
                sg_scene_hit_sites(sc, &h, ids, w, 8);
                sg_scene_hit_albedo(sc, &h);
            }
            sg_scene_occluded(sc, &r, NULL);
        }
        sg_scene_destroy(sc);
    }
done:
    for (int a = 0; a < SG_SA_COUNT; ++a)
        sg_free(own[a]);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size == 0)
        return 0;
    if (data[0] & 1)
        store_mode(data + 1, size - 1);
    else
        file_mode(data + 1, size - 1);
    return 0;
}
