/* Deterministic random streams (private header).
 *
 * PCG32 (O'Neill 2014, the XSH-RR output of a 64-bit LCG). Every random decision of a render
 * draws from a stream seeded by a hash of (render seed, pixel or work-item index, sample index),
 * so an image does not depend on which thread rendered which tile. */
#ifndef VBI_RNG_H
#define VBI_RNG_H

#include <stdint.h>

#include "vmath.h"

typedef struct vbi_rng {
    uint64_t state;
    uint64_t inc;
} vbi_rng;

/* SplitMix64 finaliser: a bijective 64-bit mix used to turn indices into well-spread seeds. */
static inline uint64_t vbi_hash64(uint64_t x)
{
    x += 0x9e3779b97f4a7c15ull;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
}

static inline uint64_t vbi_hash3(uint64_t a, uint64_t b, uint64_t c)
{
    return vbi_hash64(a ^ vbi_hash64(b ^ vbi_hash64(c)));
}

static inline uint32_t vbi_rng_next_u32(vbi_rng *r)
{
    uint64_t old = r->state;
    r->state = old * 6364136223846793005ull + r->inc;
    uint32_t xorshifted = (uint32_t)(((old >> 18u) ^ old) >> 27u);
    uint32_t rot = (uint32_t)(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((-rot) & 31));
}

/* Seeds a stream: `seed` picks the state, `stream` the LCG increment (any value). */
static inline vbi_rng vbi_rng_make(uint64_t seed, uint64_t stream)
{
    vbi_rng r;
    r.state = 0u;
    r.inc = (stream << 1u) | 1u;
    vbi_rng_next_u32(&r);
    r.state += seed;
    vbi_rng_next_u32(&r);
    return r;
}

/* Stream for work item `index`, sample `sample` of a render with `seed`. */
static inline vbi_rng vbi_rng_for(uint64_t seed, uint64_t index, uint64_t sample)
{
    return vbi_rng_make(vbi_hash3(seed, index, sample), vbi_hash64(index ^ (sample << 32) ^ 0x5bd1e995u));
}

/* Uniform float in [0, 1): the top 24 bits scaled exactly, so the largest value is
 * VBI_ONE_MINUS_EPS (1 - 2^-24) without a clamp. */
static inline float vbi_rng_next(vbi_rng *r)
{
    return (float)(vbi_rng_next_u32(r) >> 8) * 0x1p-24f;
}

static inline vec2 vbi_rng_next2(vbi_rng *r)
{
    vec2 v;
    v.x = vbi_rng_next(r);
    v.y = vbi_rng_next(r);
    return v;
}

/* Uniform integer in [0, n) without modulo bias (Lemire's method). */
static inline uint32_t vbi_rng_uniform_u32(vbi_rng *r, uint32_t n)
{
    uint64_t m = (uint64_t)vbi_rng_next_u32(r) * n;
    uint32_t l = (uint32_t)m;
    if (l < n) {
        uint32_t t = (-n) % n;
        while (l < t) {
            m = (uint64_t)vbi_rng_next_u32(r) * n;
            l = (uint32_t)m;
        }
    }
    return (uint32_t)(m >> 32);
}

#endif
