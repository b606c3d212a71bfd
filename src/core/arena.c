/* arena.c — see arena.h.
 *
 * Invariant: each arena is a list of blocks, newest first; only the thread
 * whose number indexes it allocates from it. */
#include "core/arena.h"

#include <omp.h>

#include "core/alloc.h"

/* Large enough that a build of tens of millions of nodes needs a few
 * thousand blocks. */
static const size_t BLOCK_BYTES = (size_t)1 << 20;

typedef struct arena_block {
    struct arena_block *next;
    size_t used, cap;
    _Alignas(16) unsigned char data[];
} arena_block;

typedef struct arena {
    arena_block *head;
    unsigned char pad[56]; /* one cache line per thread's arena */
} arena;

struct sg_arena_set {
    int count;
    arena *arenas;
};

sg_arena_set *sg_arena_set_create(int threads)
{
    if (threads < 1)
        threads = 1;
    sg_arena_set *s = sg_calloc_array(1, sizeof *s);
    if (!s)
        return NULL;
    s->arenas = sg_calloc_array((size_t)threads, sizeof *s->arenas);
    if (!s->arenas) {
        sg_free(s);
        return NULL;
    }
    s->count = threads;
    return s;
}

void *sg_arena_alloc(sg_arena_set *s, size_t bytes)
{
    int t = omp_get_thread_num();
    if (t >= s->count || bytes > ((size_t)-1) / 4)
        return NULL;
    arena *a = &s->arenas[t];
    bytes = (bytes + 15) & ~(size_t)15;
    arena_block *b = a->head;
    if (!b || b->cap - b->used < bytes) {
        size_t cap = bytes > BLOCK_BYTES ? bytes : BLOCK_BYTES;
        b = sg_alloc_array(1, sizeof *b + cap);
        if (!b)
            return NULL;
        b->next = a->head;
        b->used = 0;
        b->cap = cap;
        a->head = b;
    }
    void *p = b->data + b->used;
    b->used += bytes;
    return p;
}

void sg_arena_set_destroy(sg_arena_set *s)
{
    if (!s)
        return;
    for (int t = 0; t < s->count; ++t)
        for (arena_block *b = s->arenas[t].head, *next; b; b = next) {
            next = b->next;
            sg_free(b);
        }
    sg_free(s->arenas);
    sg_free(s);
}
