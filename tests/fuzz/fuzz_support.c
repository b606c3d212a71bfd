/* fuzz_support.c — see fuzz_support.h. */
#include "fuzz_support.h"

#include <stdio.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

const char *sg_fuzz_file(const uint8_t *data, size_t size, const char *ext)
{
    static char dir[512], path[600];
    if (!dir[0]) {
        const char *t = getenv("TMPDIR");
        snprintf(dir, sizeof dir, "%s/splatgi-fuzz-%ld", t && t[0] ? t : "/tmp", (long)getpid());
        mkdir(dir, 0700);
    }
    snprintf(path, sizeof path, "%s/input%s", dir, ext);
    FILE *f = fopen(path, "wb");
    if (!f || (size && fwrite(data, 1, size, f) != size) || fclose(f) != 0)
        abort();
    return path;
}
