/* key_slots.h — an open-addressing table from 64-bit keys to dense indices.
 *
 * The caller keeps the keys in its own array, key[i] for index i (in the
 * order they were added, next to whatever else it stores per index); the
 * table holds only slots: slot[j] = i + 1 for the key hashed to j (linear
 * probing), 0 for empty, in a power-of-two array kept at most half full.
 *
 * Use:
 *     if (!sg_key_slots_reserve(&slots, &cap, keys, count, 4096)) nomem;
 *     size_t j;
 *     uint32_t i = sg_key_slots_find(slots, cap, keys, k, &j);
 *     if (i == UINT32_MAX) { keys[count] = k; slots[j] = count + 1; i = count++; }
 * Not thread-safe; the caller owns both arrays (sg_alloc_array, sg_free).
 */
#ifndef SG_CORE_KEY_SLOTS_H
#define SG_CORE_KEY_SLOTS_H

#include <stddef.h>
#include <stdint.h>

#include "core/alloc.h"

/* The key of integer grid coordinates of up to 21 bits each (a grid cell
 * or point: layers.c, iso_build.c). */
static inline uint64_t sg_key_grid3(uint32_t x, uint32_t y, uint32_t z)
{
    return (uint64_t)x | (uint64_t)y << 21 | (uint64_t)z << 42;
}

/* A 64-bit finaliser (MurmurHash3's fmix64 constants): grid keys differ in
 * their low bits per axis, so they are mixed before masking. */
static inline uint64_t sg_key_mix64(uint64_t k)
{
    k ^= k >> 33;
    k *= 0xff51afd7ed558ccdull;
    k ^= k >> 33;
    k *= 0xc4ceb9fe1a85ec53ull;
    k ^= k >> 33;
    return k;
}

/* Makes room for one more key among count: when the table would be more
 * than half full, rehashes keys[0..count) into one twice as large (or of
 * first_cap slots, a power of two, when there is none yet). Returns 0
 * when out of memory, with the table unchanged. */
static inline int sg_key_slots_reserve(uint32_t **slots, size_t *cap, const uint64_t *keys, size_t count,
                                       size_t first_cap)
{
    if ((count + 1) * 2 <= *cap)
        return 1;
    size_t nc = *cap ? *cap * 2 : first_cap;
    uint32_t *s = sg_calloc_array(nc, sizeof *s);
    if (!s)
        return 0;
    for (size_t i = 0; i < count; ++i) {
        size_t j = sg_key_mix64(keys[i]) & (nc - 1);
        while (s[j])
            j = (j + 1) & (nc - 1);
        s[j] = (uint32_t)i + 1;
    }
    sg_free(*slots);
    *slots = s;
    *cap = nc;
    return 1;
}

/* The index of key, or UINT32_MAX when it is not there; *slot gets the
 * slot it is in, or the empty one where it goes. The table must have an
 * empty slot (sg_key_slots_reserve). */
static inline uint32_t sg_key_slots_find(const uint32_t *slots, size_t cap, const uint64_t *keys, uint64_t key,
                                         size_t *slot)
{
    size_t j = sg_key_mix64(key) & (cap - 1);
    while (slots[j]) {
        uint32_t i = slots[j] - 1;
        if (keys[i] == key) {
            *slot = j;
            return i;
        }
        j = (j + 1) & (cap - 1);
    }
    *slot = j;
    return UINT32_MAX;
}

#endif
