/* POV-Ray 3.7's noise (private header): the lattice noise of its three `noise_generator`s, its
 * gradient, turbulence, and the tables its cell patterns draw from.
 *
 * Every value here is POV-Ray's own, re-derived from its documented behaviour and matched to the
 * tables and conventions of its source (source/backend/texture/texture.cpp and
 * source/backend/support/randomsequences.cpp of POV-Ray 3.7, read, not copied):
 *   - generator 1 ("original") and 2 ("range corrected", POV-Ray's default) share Perlin's 1989
 *     "Hypertexture" value-gradient noise over a 4096-periodic integer lattice: each corner
 *     contributes a + b dx + c dy + d dz with four coefficients read from a table of 267 numbers
 *     at an offset hashed from the corner, blended by the cubic s-curve 3t^2 - 2t^3. The sum is
 *     mapped to [0, 1] by +0.5 (generator 1) or by (sum + 1.05242) * 0.48985582 (generator 2),
 *     then clamped;
 *   - generator 3 is gradient noise (Perlin 1985 as in "improved" implementations' layout) over
 *     2048 random unit gradients, mapped by 0.5 (1.59 n + 0.985) and clamped;
 *   - the hash is a permutation of 0..4095 shuffled by the LCG x' = 1812433253 x + 12345
 *     (32-bit), duplicated to 8192 entries;
 *   - the "pattern random numbers" (cells, crackle, facets, black holes) are the first 32768
 *     outputs of MT19937 with its default seed 5489, each divided by 2^32.
 * All arithmetic is double precision, as in POV-Ray. The tables are built once per process
 * (vbi_noise_tables, thread-safe) and never change afterwards. */
#ifndef VBI_TEXTURE_NOISE_H
#define VBI_TEXTURE_NOISE_H

#include <stdint.h>

#include "dvec.h"
#include "vbnl/scene.h"

#define VBI_NOISE_HASH_SIZE 8192
#define VBI_NOISE_RTABLE_SIZE 267
#define VBI_NOISE_SOLID_SIZE 2048
#define VBI_PATTERN_RANDS 32768
#define VBI_NOISE_MAX_WAVES VBNL_NOISE_WAVES_MAX /* sources of ripples / waves (vbnl/scene.h) */

typedef struct vbi_noise_tables {
    uint16_t hash[VBI_NOISE_HASH_SIZE];
    double rtable[2 * VBI_NOISE_RTABLE_SIZE];             /* value, value / 2 interleaved */
    int solid_perm[2 * (VBI_NOISE_SOLID_SIZE + 1)];
    double solid_grad[2 * (VBI_NOISE_SOLID_SIZE + 1)][3];
    double rands[VBI_PATTERN_RANDS];                      /* MT19937 / 2^32 */
    dvec3 wave_source[VBI_NOISE_MAX_WAVES];               /* ripples / waves centres (unit) */
    double wave_frequency[VBI_NOISE_MAX_WAVES];
} vbi_noise_tables;

/* POV-Ray's turbulence parameters (octaves 1..10, default 6; omega 0.5; lambda 2). */
typedef struct vbi_turb {
    dvec3 amount;
    int octaves;
    double omega, lambda;
} vbi_turb;

/* The tables, built on the first call (pthread_once; any thread). Never NULL. */
const vbi_noise_tables *vbi_noise_tables_get(void);

/* Noise in [0, 1] at p for generator 1, 2 or 3 (anything else counts as 2). */
double vbi_noise(const vbi_noise_tables *t, dvec3 p, int generator);
/* The vector noise POV-Ray's bumps, wrinkles, dents and turbulence warps use (each component in
 * about [-1, 1]; the same for every generator, as in POV-Ray). */
dvec3 vbi_dnoise(const vbi_noise_tables *t, dvec3 p);
/* Scalar turbulence: octaves of noise at p * lambda^k weighted omega^k (generators 2 and 3 use
 * 2 n - 0.5 per octave, the first clamped to [0, 1]). */
double vbi_turbulence(const vbi_noise_tables *t, dvec3 p, const vbi_turb *turb, int generator);
/* Vector turbulence: the same octaves of vbi_dnoise. */
dvec3 vbi_dturbulence(const vbi_noise_tables *t, dvec3 p, const vbi_turb *turb);

/* POV-Ray's hash of an integer cell (each coordinate taken mod 4096): 0..4095. */
static inline unsigned vbi_noise_hash3(const vbi_noise_tables *t, int a, int b, int c)
{
    return t->hash[t->hash[t->hash[a & 0xfff] ^ (b & 0xfff)] ^ (c & 0xfff)];
}
/* Pattern random number i (taken mod 32768), in [0, 1). */
static inline double vbi_pattern_rand(const vbi_noise_tables *t, unsigned i)
{
    return t->rands[i % VBI_PATTERN_RANDS];
}

/* sin(2 pi v) as POV-Ray evaluates it (its "cycloidal" function). */
double vbi_cycloidal(double v);
/* The triangle wave of period 1: 2 frac(v) below one half, 2 (1 - frac(v)) above. */
double vbi_triangle_wave(double v);

#endif
