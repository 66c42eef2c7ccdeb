/* The random numbers of one camera sample (private header).
 *
 * Two samplers, chosen by name with the render setting `sampler`:
 *
 * - `random`: every number from the PCG stream of (render seed, pixel, sample index).
 * - `sobol` (default): the first VBI_SOBOL_SLOTS draws of a sample are low-discrepancy points,
 *   the rest come from the same PCG stream. Each draw (one or two numbers) is a *slot* with its
 *   own sequence, "padded" as pbrt's PaddedSobolSampler pads: slot k of a pixel takes its 1D
 *   points from the first Sobol' dimension (van der Corput) or its 2D points from the first two
 *   (a (0,2)-sequence), Owen-scrambled by hashing (Laine and Karras 2011; Burley 2020, "Practical
 *   Hash-based Owen Scrambling") with seeds of its own, and the sample index is itself
 *   Owen-scrambled per slot (Burley's shuffling), which decorrelates the slots from one another.
 *   Every number is uniform on [0, 1) and the slots are independent, so estimators stay
 *   unbiased; within a slot the first 2^m samples of a pixel are a (0,m,1)- or (0,m,2)-net, and
 *   any prefix is well spread, so progressive passes of any length keep the stratification.
 *
 * The numbers depend only on (seed, pixel, sample index, draw number): an image does not depend
 * on which thread rendered which tile. */
#ifndef VBI_SAMPLER_H
#define VBI_SAMPLER_H

#include <stdint.h>
#if defined(__GFNI__)
#include <immintrin.h>
#endif

#include "rng.h"
#include "vbnl/render.h"

/* Draws per sample served by the low-discrepancy sequences. Stratification pays at the first
 * vertex: the pixel position, next-event estimation and, most, the first BSDF direction (`vbnl`
 * draws it in its 7th slot, `path` in its 5th). Measured on the glossy-floor box at 64 spp
 * (README, Samplers): 8 slots give all of `vbnl`'s gain and nearly all of `path`'s; 16, 32 and
 * 64 change the error by under 3%, and every slot costs its draws some 20-40 instructions. */
#define VBI_SOBOL_SLOTS 8u

typedef struct vbi_sampler {
    vbi_rng rng;         /* the draws past the slots (all draws of the random sampler); made on
                             first use (rng.inc is odd once it is) */
    uint64_t seed;        /* the pixel's scramble seed */
    uint64_t render_seed; /* with pixel and sample: the PCG stream's origin */
    uint64_t pixel;
    uint32_t sample;
    uint32_t rev_index;   /* the sample index, bits reversed */
    uint32_t slot;        /* the next draw's number */
    uint32_t slots;       /* draws served by Sobol' points: VBI_SOBOL_SLOTS, or 0 (random) */
} vbi_sampler;

static inline uint32_t vbi_reverse_bits32(uint32_t x)
{
#if defined(__GFNI__) && defined(__SSE2__)
    /* one affine transform over GF(2) reverses the bits of every byte, then the bytes swap */
    __m128i v = _mm_gf2p8affine_epi64_epi8(_mm_cvtsi32_si128((int)x), _mm_set1_epi64x(0x8040201008040201ll), 0);
    return __builtin_bswap32((uint32_t)_mm_cvtsi128_si32(v));
#else
    x = __builtin_bswap32(x);
    x = ((x & 0x0f0f0f0fu) << 4) | ((x >> 4) & 0x0f0f0f0fu);
    x = ((x & 0x33333333u) << 2) | ((x >> 2) & 0x33333333u);
    return ((x & 0x55555555u) << 1) | ((x >> 1) & 0x55555555u);
#endif
}

/* A bijection of 32-bit words in which bit b of the result depends only on bits 0..b of x and on
 * the seed: Laine and Karras's hash with Vegdahl's constants (multiplications by even constants
 * xored in, an addition, a multiplication by an odd number). Applied to bit-reversed values it
 * is a nested uniform (Owen) scramble. */
static inline uint32_t vbi_lk_permute(uint32_t x, uint32_t seed)
{
    x ^= x * 0x3d20adeau;
    x += seed;
    x *= (seed >> 16) | 1u;
    x ^= x * 0x05526c56u;
    x ^= x * 0x53a22864u;
    return x;
}

/* Sobol's second dimension with its bits reversed: the generator matrix is Pascal's triangle
 * mod 2, so bit j of the reversed point is the parity of the index bits k whose bit set contains
 * j's (Lucas), a superset sum over five bit planes. */
static inline uint32_t vbi_sobol1_reversed(uint32_t i)
{
    i ^= (i >> 1) & 0x55555555u;
    i ^= (i >> 2) & 0x33333333u;
    i ^= (i >> 4) & 0x0f0f0f0fu;
    i ^= (i >> 8) & 0x00ff00ffu;
    i ^= (i >> 16) & 0x0000ffffu;
    return i;
}

static inline float vbi_u32_to_unit(uint32_t x) { return (float)(x >> 8) * 0x1p-24f; }

/* The sampler of sample `sample` of pixel `pixel` (y * width + x) of a render with `seed`. */
static inline vbi_sampler vbi_sampler_make(vbnl_sampler_kind kind, uint64_t seed, uint64_t pixel, uint32_t sample)
{
    vbi_sampler s;
    s.rng.state = 0;
    s.rng.inc = 0; /* not made yet: most samples of VBNL never draw past the slots */
    s.render_seed = seed;
    s.pixel = pixel;
    s.sample = sample;
    s.slot = 0;
    if (kind == VBNL_SAMPLER_SOBOL) {
        s.seed = vbi_hash64(seed ^ vbi_hash64(pixel ^ 0x50b01u));
        s.rev_index = vbi_reverse_bits32(sample);
        s.slots = VBI_SOBOL_SLOTS;
    } else { /* every draw from the PCG stream: no scramble seed needed */
        s.seed = 0;
        s.rev_index = 0;
        s.slots = 0;
    }
    return s;
}

/* A sampler that draws every number from `rng` (the random sampler's stream). */
static inline vbi_sampler vbi_sampler_from_rng(vbi_rng rng)
{
    vbi_sampler s;
    s.rng = rng;
    s.seed = s.render_seed = s.pixel = 0;
    s.sample = 0;
    s.rev_index = 0;
    s.slot = 0;
    s.slots = 0;
    return s;
}

/* The PCG stream of (render seed, pixel, sample), made on first use. */
static inline vbi_rng *vbi_sampler_rng(vbi_sampler *s)
{
    if (__builtin_expect(!(s->rng.inc & 1u), 0))
        s->rng = vbi_rng_for(s->render_seed, s->pixel, s->sample);
    return &s->rng;
}

/* Slot k's seeds: the index shuffle, then one per dimension. */
static inline uint64_t vbi_sampler_slot_hash(const vbi_sampler *s, uint32_t slot)
{
    /* the pixel's seed is already a full-avalanche hash: one multiply-xorshift round suffices */
    uint64_t h = (s->seed ^ ((uint64_t)slot * 0x9e3779b97f4a7c15ull)) * 0xbf58476d1ce4e5b9ull;
    return h ^ (h >> 31);
}

/* The slot's shuffled index: an Owen scramble of the sample index, which maps the first 2^m
 * indices onto an aligned block of 2^m Sobol' indices (itself a net). */
static inline uint32_t vbi_sampler_shuffled(const vbi_sampler *s, uint32_t h)
{
    return vbi_reverse_bits32(vbi_lk_permute(s->rev_index, h));
}

static inline float vbi_sampler_next(vbi_sampler *s)
{
    if (s->slot >= s->slots)
        return vbi_rng_next(vbi_sampler_rng(s));
    uint64_t h = vbi_sampler_slot_hash(s, s->slot++);
    uint32_t j = vbi_sampler_shuffled(s, (uint32_t)h);
    /* van der Corput point reverse(j), Owen-scrambled: reverse(permute(reverse(reverse(j)))) */
    return vbi_u32_to_unit(vbi_reverse_bits32(vbi_lk_permute(j, (uint32_t)(h >> 32))));
}

static inline vec2 vbi_sampler_next2(vbi_sampler *s)
{
    if (s->slot >= s->slots)
        return vbi_rng_next2(vbi_sampler_rng(s));
    uint64_t h = vbi_sampler_slot_hash(s, s->slot++);
    uint32_t j = vbi_sampler_shuffled(s, (uint32_t)h);
    uint32_t h2 = (uint32_t)((h * 0x9e3779b97f4a7c15ull) >> 32);
    vec2 v;
    v.x = vbi_u32_to_unit(vbi_reverse_bits32(vbi_lk_permute(j, (uint32_t)(h >> 32))));
    v.y = vbi_u32_to_unit(vbi_reverse_bits32(vbi_lk_permute(vbi_sobol1_reversed(j), h2)));
    return v;
}

#endif
