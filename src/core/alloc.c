/* alloc.c — see alloc.h.
 *
 * Invariant: live_allocations counts the blocks sg_alloc_array handed out
 * and sg_free has not yet taken back (NULL frees do not count). The fault
 * countdown and that counter are the only mutable file-scope state of the
 * library; they exist for the allocation-failure tests (alloc.h) and cost
 * one relaxed atomic operation per call.
 */
#include "core/alloc.h"

#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

enum { SG_ALIGN = 64 };

static atomic_long fail_countdown = -1; /* < 0: never fail               */
static atomic_long live_allocations = 0;

long sg_alloc__fail_after(long n) { return atomic_exchange_explicit(&fail_countdown, n, memory_order_relaxed); }

long sg_alloc__live(void) { return atomic_load_explicit(&live_allocations, memory_order_relaxed); }

/* True when the injected fault says this allocation must fail. */
static bool injected_failure(void)
{
    long c = atomic_load_explicit(&fail_countdown, memory_order_relaxed);
    while (c >= 0) {
        /* c == 0: fail this one, and every one after it until reset. */
        if (c == 0)
            return true;
        if (atomic_compare_exchange_weak_explicit(&fail_countdown, &c, c - 1, memory_order_relaxed,
                                                  memory_order_relaxed))
            return false;
    }
    return false;
}

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
    if (injected_failure())
        return NULL;
    void *p = aligned_alloc(SG_ALIGN, rounded);
    if (p)
        atomic_fetch_add_explicit(&live_allocations, 1, memory_order_relaxed);
    return p;
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

void sg_free(void *ptr)
{
    if (!ptr)
        return;
    atomic_fetch_sub_explicit(&live_allocations, 1, memory_order_relaxed);
    free(ptr);
}
