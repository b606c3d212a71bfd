/* file_mode.c — see file_mode.h. */
#include "core/file_mode.h"

#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

mode_t sg_umask(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    if (f) {
        char line[256];
        unsigned mask = 0;
        int found = 0;
        while (!found && fgets(line, sizeof line, f))
            found = sscanf(line, "Umask: %o", &mask) == 1;
        fclose(f);
        if (found)
            return (mode_t)(mask & 0777u);
    }
    mode_t old = umask(022); /* no other way to read it */
    umask(old);
    return old & 0777;
}

mode_t sg_output_file_mode(const char *path)
{
    struct stat st;
    if (path && stat(path, &st) == 0 && S_ISREG(st.st_mode))
        return st.st_mode & 07777;
    return (mode_t)(0666 & ~sg_umask());
}
