/* Sample warping and discrete distributions (private header).
 *
 * Every warp maps a uniform point of [0,1)^2 to a direction or point and has a matching pdf
 * function; tests/core/test_sampling.c checks each pair with a chi-square test. */
#ifndef VBI_SAMPLING_H
#define VBI_SAMPLING_H

#include <stddef.h>
#include <stdint.h>

#include "vmath.h"

/* sin and cos of x for |x| <= pi/4 (Taylor polynomials in Horner form). */
static inline void sincos_quarter(float x, float *s, float *c)
{
    float x2 = x * x;
    *s = x * (1.0f + x2 * (-1.0f / 6.0f + x2 * (1.0f / 120.0f + x2 * (-1.0f / 5040.0f + x2 * (1.0f / 362880.0f)))));
    *c = 1.0f + x2 * (-0.5f + x2 * (1.0f / 24.0f + x2 * (-1.0f / 720.0f + x2 * (1.0f / 40320.0f +
                                                                             x2 * (-1.0f / 3628800.0f)))));
}

/* Concentric mapping of the unit square to the unit disk (Shirley & Chiu 1997). */
static inline vec2 sample_concentric_disk(vec2 u)
{
    float ox = 2.0f * u.x - 1.0f, oy = 2.0f * u.y - 1.0f;
    if (ox == 0.0f && oy == 0.0f)
        return (vec2){0.0f, 0.0f};
    /* theta = phi in the first case (|ox| > |oy|), pi/2 - phi in the second, with |phi| <= pi/4:
     * both need only sin and cos of phi, whose Taylor series to x^9 / x^10 are exact in float
     * there (next terms below 2e-9), without a libm call in every Lambertian bounce. The two
     * cases differ only in which of ox, oy is r and which of sin, cos goes to x, so they are
     * selected rather than branched on: the case is a coin flip for the branch predictor. */
    int first = fabsf(ox) > fabsf(oy);
    float r = first ? ox : oy, other = first ? oy : ox;
    float phi = (VBI_PI / 4.0f) * (other / r);
    float s, c;
    sincos_quarter(phi, &s, &c);
    float rs = r * s, rc = r * c;
    return first ? (vec2){rc, rs} : (vec2){rs, rc};
}

/* Cosine-weighted hemisphere around +z; pdf = cos(theta) / pi. */
static inline vec3 sample_cosine_hemisphere(vec2 u)
{
    vec2 d = sample_concentric_disk(u);
    float z = safe_sqrtf(1.0f - d.x * d.x - d.y * d.y);
    return v3(d.x, d.y, z);
}
static inline float pdf_cosine_hemisphere(vec3 w) { return w.z > 0.0f ? w.z * VBI_INV_PI : 0.0f; }

/* Uniform sphere; pdf = 1 / (4 pi). */
static inline vec3 sample_uniform_sphere(vec2 u)
{
    float z = 1.0f - 2.0f * u.x;
    float r = safe_sqrtf(1.0f - z * z);
    float phi = 2.0f * VBI_PI * u.y;
    return v3(r * cosf(phi), r * sinf(phi), z);
}
static inline float pdf_uniform_sphere(void) { return VBI_INV_4PI; }

/* Uniform hemisphere around +z; pdf = 1 / (2 pi). */
static inline vec3 sample_uniform_hemisphere(vec2 u)
{
    float z = u.x;
    float r = safe_sqrtf(1.0f - z * z);
    float phi = 2.0f * VBI_PI * u.y;
    return v3(r * cosf(phi), r * sinf(phi), z);
}
static inline float pdf_uniform_hemisphere(void) { return VBI_INV_2PI; }

/* Uniform direction in the cone around +z with half-angle acos(cos_max);
 * pdf = 1 / (2 pi (1 - cos_max)) (the VBNL paper's Eq. 4). */
static inline vec3 sample_uniform_cone(vec2 u, float cos_max)
{
    float z = 1.0f - u.x * (1.0f - cos_max);
    float r = safe_sqrtf(1.0f - z * z);
    float phi = 2.0f * VBI_PI * u.y;
    return v3(r * cosf(phi), r * sinf(phi), z);
}
static inline float pdf_uniform_cone(float cos_max) { return 1.0f / (2.0f * VBI_PI * (1.0f - cos_max)); }

/* Uniform barycentrics on a triangle (Heitz 2019 low-distortion mapping); returns (b1, b2). */
static inline vec2 sample_uniform_triangle(vec2 u)
{
    float b0, b1;
    if (u.x < u.y) {
        b0 = u.x / 2.0f;
        b1 = u.y - b0;
    } else {
        b1 = u.y / 2.0f;
        b0 = u.x - b1;
    }
    return (vec2){b0, b1};
}

/* Power heuristic with beta = 2 (Veach 1997): weight of strategy f against g. */
static inline float power_heuristic(float pdf_f, float pdf_g)
{
    float f = pdf_f * pdf_f, g = pdf_g * pdf_g;
    if (isinf(f))
        return 1.0f;
    return f + g > 0.0f ? f / (f + g) : 0.0f;
}

/* Alias table (Walker 1977, Vose's construction): O(1) sampling of n weighted items. */
typedef struct vbi_alias_table {
    uint32_t n;
    float *prob;      /* acceptance probability of each slot */
    uint32_t *alias;  /* the other item of each slot */
    float *pmf;       /* normalised probability of each item */
    double total;     /* sum of the input weights */
} vbi_alias_table;

/* Builds the table from n >= 1 non-negative weights. Returns 0 on success, -1 when out of memory
 * or when every weight is zero (the table is then left empty). */
int vbi_alias_table_build(vbi_alias_table *t, const float *weights, uint32_t n);
void vbi_alias_table_free(vbi_alias_table *t);
/* Samples an item with one uniform number u in [0,1); *pmf receives its probability. Inline:
 * next-event estimation picks a light with it at every vertex. */
/* The slot a uniform number u in [0,1) draws among n >= 1 and its fraction within the slot (the
 * number compared with the slot's acceptance probability); shared with tables stored in other
 * layouts (the render records of VBNL's virtual lights). */
static inline uint32_t vbi_alias_slot(uint32_t n, float u, float *frac)
{
    float x = u * (float)n;
    uint32_t slot = (uint32_t)x;
    if (slot >= n)
        slot = n - 1;
    *frac = x - (float)slot;
    return slot;
}

/* A choice made with a uniform number that is then reused: returns 1 when *u < p, else 0, and
 * rescales *u to [0,1) within the chosen share ([0,p) or [p,1)), uniform and independent of the
 * choice, so that the caller can use it again for what the choice leads to. A stratified u then
 * stays stratified within each choice (with a separate number for the choice, each would get a
 * random subset of the points). */
static inline int vbi_choose_reuse(float *u, float p)
{
    float r;
    int first = *u < p;
    r = first ? *u / p : (*u - p) / (1.0f - p);
    *u = r < VBI_ONE_MINUS_EPS ? r : VBI_ONE_MINUS_EPS;
    return first;
}

/* vbi_alias_table_sample that also returns, in *rest, u rescaled to [0,1) within the part of
 * [0,1) that drew the item (vbi_choose_reuse on the slot's fraction): a light picked and its
 * point drawn with one 2D number. */
static inline uint32_t vbi_alias_table_sample_reuse(const vbi_alias_table *t, float u, float *pmf, float *rest)
{
    float frac;
    uint32_t slot = vbi_alias_slot(t->n, u, &frac);
    uint32_t item = vbi_choose_reuse(&frac, t->prob[slot]) ? slot : t->alias[slot];
    *rest = frac;
    if (pmf)
        *pmf = t->pmf[item];
    return item;
}

static inline uint32_t vbi_alias_table_sample(const vbi_alias_table *t, float u, float *pmf)
{
    float frac;
    uint32_t slot = vbi_alias_slot(t->n, u, &frac);
    uint32_t item = frac < t->prob[slot] ? slot : t->alias[slot];
    if (pmf)
        *pmf = t->pmf[item];
    return item;
}

#endif
