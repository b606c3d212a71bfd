/* fuzz_pcd.c — the .pcd reader (through sg_mesh_read, as the programs
 * read models) and the model pipeline's header count where there is one:
 * any bytes give SG_OK with a valid mesh, or an error; never a crash, a
 * hang or a leak (ASan, libFuzzer's -rss_limit). */
#include <stdint.h>
#include <string.h>

#include "fuzz_support.h"
#include "io/mesh.h"
#include "io/pcd.h"
#include "io/ply.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = sg_fuzz_file(data, size, ".pcd");
    sg_mesh m = {0};
    sg_error err;
    if (sg_mesh_read(path, &m, &err) == SG_OK) {
        /* The contract of mesh.h: every index in range, positions present. */
        for (size_t t = 0; t < 3 * m.triangle_count; ++t)
            if (m.triangles[t] >= m.vertex_count)
                __builtin_trap();
        if (m.vertex_count && !m.positions)
            __builtin_trap();
    }
    sg_mesh_free(&m);
    uint64_t a = 0, b = 0;
    (void)a, (void)b;
    sg_pcd_read_count(path, &a, &err);
    return 0;
}
