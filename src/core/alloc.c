/* alloc.c — see alloc.h. */
#include "core/alloc.h"

#include <stdlib.h>
#include <string.h>

enum { SG_ALIGN = 64 };

void *sg_alloc_array(size_t count, size_t size)
{
    size_t bytes;
    if (!sg_mul_size(count, size, &bytes))
        return NULL;
    /* aligned_alloc requires a size that is a multiple of the alignment. */
    size_t rounded = (bytes + SG_ALIGN - 1) & ~(size_t)(SG_ALIGN - 1);
    if (rounded < bytes)
        return NULL;
    if (rounded == 0)
        rounded = SG_ALIGN;
    return aligned_alloc(SG_ALIGN, rounded);
}

void *sg_calloc_array(size_t count, size_t size)
{
    void *p = sg_alloc_array(count, size);
    if (p)
        memset(p, 0, count * size);
    return p;
}

bool sg_realloc_array(void **ptr, size_t old_count, size_t new_count, size_t size)
{
    void *p = sg_alloc_array(new_count, size);
    if (!p)
        return false;
    if (*ptr && old_count)
        memcpy(p, *ptr, (old_count < new_count ? old_count : new_count) * size);
    sg_free(*ptr);
    *ptr = p;
    return true;
}

void sg_free(void *ptr) { free(ptr); }
