/* alloc.h — overflow-checked, 64-byte aligned array allocation.
 *
 * Every count*size in the library goes through sg_mul_size so that absurd
 * counts from a file become SG_ERR_NOMEM instead of a short allocation.
 * Memory from sg_alloc_array must be released with sg_free.
 */
#ifndef SG_CORE_ALLOC_H
#define SG_CORE_ALLOC_H

#include <stdbool.h>
#include <stddef.h>

/* *out = a*b; returns false (and leaves *out untouched) on overflow. */
static inline bool sg_mul_size(size_t a, size_t b, size_t *out)
{
    if (a != 0 && b > (size_t)-1 / a)
        return false;
    *out = a * b;
    return true;
}

/* count*size bytes, 64-byte aligned, uninitialised; NULL on overflow or
 * failure. count == 0 returns a valid minimal allocation. */
void *sg_alloc_array(size_t count, size_t size);

/* Same, zero-filled. */
void *sg_calloc_array(size_t count, size_t size);

/* Grows *ptr (from sg_alloc_array, or NULL: a first allocation) to
 * new_count elements, keeping the first old_count; returns false (leaving
 * *ptr valid) on failure. */
bool sg_realloc_array(void **ptr, size_t old_count, size_t new_count, size_t size);

/* The capacity of an array that must grow to hold need elements: half as
 * much again as cap, at least need, at least 1 (appends in amortised
 * constant time). */
static inline size_t sg_grown_capacity(size_t cap, size_t need)
{
    size_t grown = cap + cap / 2;
    if (grown < need)
        grown = need;
    return grown ? grown : 1;
}

void sg_free(void *ptr);

/* Test hooks (double underscore: not for programs). Fault injection, as
 * SQLite's tests do it: after sg_alloc__fail_after(n) the next n
 * allocations succeed and every later one fails (returns NULL) until
 * sg_alloc__fail_after(-1) switches failures off again; it returns the
 * countdown it replaces, so fail_after(N) ... fail_after(-1) tells how many
 * allocations happened in between (N minus the answer). sg_alloc__live()
 * is the number of blocks allocated and not yet freed, so a test can check
 * that an error path frees all it took. Both are process-wide and atomic;
 * a test that uses them must not run library calls on other threads of
 * its own at the same time. */
long sg_alloc__fail_after(long n);
long sg_alloc__live(void);

#endif
