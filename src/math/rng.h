/* rng.h — counter-based random numbers (DESIGN.md "Determinism").
 *
 * A random number is a pure function of (seed, item, bounce, dimension):
 * no state travels between threads, so results ignore the thread count and
 * the order in which work is done. The mixer is a 64-bit finaliser
 * (splitmix64/murmur3 style) applied to a combination of the four keys.
 */
#ifndef SG_MATH_RNG_H
#define SG_MATH_RNG_H

#include <stdint.h>

static inline uint64_t sg_mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* 64 random bits for key (seed, item, bounce, dim). */
static inline uint64_t sg_rng_bits(uint64_t seed, uint64_t item, uint32_t bounce, uint32_t dim)
{
    uint64_t h = sg_mix64(seed + 0x9E3779B97F4A7C15ull);
    h = sg_mix64(h ^ (item * 0xD6E8FEB86659FD93ull));
    h = sg_mix64(h ^ (((uint64_t)bounce << 32 | dim) * 0xA0761D6478BD642Full));
    return h;
}

/* Uniform float in [0,1) with 24 random bits (never returns 1.0f). */
static inline float sg_rng_float(uint64_t seed, uint64_t item, uint32_t bounce, uint32_t dim)
{
    return (float)(sg_rng_bits(seed, item, bounce, dim) >> 40) * (1.0f / 16777216.0f);
}

#endif
