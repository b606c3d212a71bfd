/* fuzz_mesh.c — a model reader through sg_mesh_read, as the programs read
 * models, built once per format (CMake defines SG_FUZZ_EXT: ".ply",
 * ".obj", ".xyz", ".pcd"), plus the header-only counts of the memory
 * estimate where the format has them: any bytes give SG_OK with a valid
 * mesh, or an error; never a crash, a hang or a leak. */
#include <stdint.h>
#include <string.h>

#include "fuzz_support.h"
#include "io/mesh.h"
#include "io/pcd.h"
#include "io/ply.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = sg_fuzz_file(data, size, SG_FUZZ_EXT);
    sg_mesh m = {0};
    sg_error err;
    if (sg_mesh_read(path, &m, &err) == SG_OK) {
        /* mesh.h's contract: every index in range, positions present. */
        for (size_t t = 0; t < 3 * m.triangle_count; ++t)
            if (m.triangles[t] >= m.vertex_count)
                __builtin_trap();
        if (m.vertex_count && !m.positions)
            __builtin_trap();
    }
    sg_mesh_free(&m);
    uint64_t a = 0, b = 0;
    if (!strcmp(SG_FUZZ_EXT, ".ply"))
        sg_ply_read_counts(path, &a, &b, &err);
    else if (!strcmp(SG_FUZZ_EXT, ".pcd"))
        sg_pcd_read_count(path, &a, &err);
    return 0;
}
