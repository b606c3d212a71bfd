/* arena.h — per-thread bump allocation for parallel builds: many small
 * blocks (tree nodes) taken in large chunks and freed together, so that a
 * build makes a few hundred allocations instead of one per node.
 *
 * Use (inside an OpenMP parallel region of at most `threads` threads):
 *     sg_arena_set *a = sg_arena_set_create(threads);
 *     void *p = sg_arena_alloc(a, bytes);   NULL when out of memory
 *     sg_arena_set_destroy(a);              frees every block
 *
 * Thread-safety: each thread allocates from its own arena, chosen by
 * omp_get_thread_num(); OpenMP tasks must be tied (the default), so a
 * thread runs one at a time. Memory comes 16-byte aligned, uninitialised.
 */
#ifndef SG_CORE_ARENA_H
#define SG_CORE_ARENA_H

#include <stddef.h>

typedef struct sg_arena_set sg_arena_set; /* opaque */

/* An arena per thread for a region of at most `threads` threads; NULL when
 * out of memory. */
sg_arena_set *sg_arena_set_create(int threads);

/* `bytes` from the calling thread's arena (16-byte aligned); NULL when out
 * of memory. */
void *sg_arena_alloc(sg_arena_set *set, size_t bytes);

/* Frees every block of every arena; NULL is a no-op. */
void sg_arena_set_destroy(sg_arena_set *set);

#endif
