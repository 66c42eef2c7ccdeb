/* Hemispherical octahedral ("hemi-oct") direction maps for VBNL virtual lights (private header).
 *
 * The paper stores each virtual light's incident and outgoing radiance fields in 16 x 16 (or
 * 8 x 8, 32 x 32) octahedral maps over the hemisphere (Li et al. 2022, Section 5, after
 * Engelhardt & Dachsbacher 2008). This module is that map: the direction <-> square mapping,
 * its exact per-texel solid angles, bilinear splatting and lookup, and sampling of a direction
 * in proportion to texel weights.
 *
 * Mapping (Cigolle et al. 2014, "A Survey of Efficient Representations for Independent Unit
 * Vectors", hemi-oct encoding). Local frame, z = surface normal, hemisphere z >= 0. A direction
 * w is projected onto the upper octahedron |x| + |y| + z = 1, p = w.xy / (|x| + |y| + z); the
 * diamond |p.x| + |p.y| <= 1 is rotated by 45 degrees and scaled to fill the square,
 * e = (p.x + p.y, p.x - p.y) in [-1, 1]^2, and u = (e + 1) / 2 in [0, 1]^2. The normal z = 1
 * maps to the centre (0.5, 0.5); the horizon z = 0 maps to the square's boundary (each side is a
 * quarter of the horizon, so the boundary is continuous and has no seam). Mirroring about the
 * normal, (x, y, z) -> (-x, -y, z), maps u to 1 - u, hence texel centres to texel centres.
 *
 * Texels: an R x R grid over [0, 1)^2, texel index t = j * R + i for column i (u.x) and row
 * j (u.y); its centre direction is decode((i + 0.5) / R, (j + 0.5) / R). Any R >= 2 works; the
 * renderer uses 8, 16 (default) or 32.
 *
 * Jacobian: on each face of the octahedron the map is affine, and the central projection gives
 * d(omega) = 2 / |p|^3 du, with p = (t.x, t.y, 1 - |t.x| - |t.y|) the (unnormalised) point of
 * the octahedron and t = (p.x, p.y). It ranges from 2 at the octahedron's vertices (the square's
 * centre and corners) to 6 sqrt(3) ~ 10.4 at its face centres, so texel solid angles differ by
 * a factor of up to about 5: every splat or sum over texels must use the true solid angles
 * below (baselines notes, Section 7 item 10).
 *
 * Exact texel solid angles: inside one octahedron face the map is affine, so straight lines of
 * the square map to straight lines on the face and then to great-circle arcs on the sphere. The
 * face boundaries are the square's diagonals, which pass only through grid vertices; splitting
 * every texel into four triangles (centre + one edge each) therefore gives planar triangles on a
 * single face, i.e. exact spherical triangles, whose areas come from the Van Oosterom-Strackee
 * formula (in double precision). They sum to 2 pi to rounding.
 *
 * Bilinear footprint (shared by splat and lookup): the four texel centres around u, with the
 * indices clamped to [0, R - 1] at the border ("clamp to edge"). In the outer half-texel band
 * the clamped corners coincide and their weights add up, so the weights always sum to one and a
 * splat never loses energy. Clamping is the natural edge rule here: the border is the horizon,
 * beyond which the hemisphere has no continuation.
 *
 * Because a bilinear splat spreads a direction over neighbouring texels, the expected splat
 * value of texel t for a uniform direction on the hemisphere is B_t / (2 pi), where
 * B_t = integral over the hemisphere of texel t's bilinear basis function (the "bilinear solid
 * angle"), not Omega_t / (2 pi); B_t / Omega_t lies in [0.989, 1.033] at R = 16 ([0.963, 1.073]
 * at R = 8, [0.997, 1.015] at R = 32). B_t and the projected version
 * C_t = integral of basis_t(w) cos(theta) dw are tabulated per map by a 512 x 512 midpoint rule
 * (sum B = 2 pi and sum C = pi to 2e-8 relative). C_t turns a bilinearly interpolated
 * cosine-free intensity into emitted power exactly (profiles.h).
 *
 * Ownership and threads: a vbi_hemioct holds only immutable tables computed at creation; after
 * creation every function here is read-only and safe to call from any number of threads. The
 * map arrays that the splat/lookup functions read or write are owned by the caller. */
#ifndef VBI_OCTAHEDRAL_H
#define VBI_OCTAHEDRAL_H

#include <math.h>
#include <stdint.h>

#include "vbnl/result.h"
#include "vmath.h"

#define VBI_HEMIOCT_MIN_RES 2u
#define VBI_HEMIOCT_MAX_RES 256u
#define VBI_HEMIOCT_DEFAULT_RES 16u

typedef struct vbi_hemioct vbi_hemioct;

/* Creates the tables for an R x R map (R in [VBI_HEMIOCT_MIN_RES, VBI_HEMIOCT_MAX_RES]).
 * Cost: about 4 R^2 spherical triangles plus a 512 x 512 quadrature (a few ms). Returns
 * VBNL_ERR_INVALID_ARGUMENT for a bad R or NULL out, VBNL_ERR_OUT_OF_MEMORY. */
vbnl_result vbi_hemioct_create(uint32_t res, vbi_hemioct **out);
/* Accepts NULL. */
void vbi_hemioct_destroy(vbi_hemioct *map);

uint32_t vbi_hemioct_res(const vbi_hemioct *map);
/* R * R. */
uint32_t vbi_hemioct_texel_count(const vbi_hemioct *map);

/* ---- the mapping (no tables needed) ---------------------------------------------------------- */

/* Direction (any length > 0) -> [0, 1]^2. Directions below the horizon are first projected onto
 * it (z clamped to 0); the degenerate (0, 0, z <= 0) maps to u = (1, 1), i.e. w = (1, 0, 0). */
vec2 vbi_hemioct_encode(vec3 w);
/* [0, 1]^2 -> unit direction with z >= 0 (u outside the square is clamped into it). */
vec3 vbi_hemioct_decode(vec2 u);
/* d(omega) / d(u): solid angle per unit area of the square at u (2 / |p|^3, see above). */
float vbi_hemioct_jacobian(vec2 u);

/* ---- texels ---------------------------------------------------------------------------------- */

/* Index of the texel containing encode(w) (the right/top border belongs to the last texel). */
uint32_t vbi_hemioct_texel(const vbi_hemioct *map, vec3 w);
/* Unit direction of texel t's centre. */
vec3 vbi_hemioct_texel_dir(const vbi_hemioct *map, uint32_t t);
/* Exact solid angle Omega_t of texel t (steradians). */
float vbi_hemioct_texel_solid_angle(const vbi_hemioct *map, uint32_t t);
/* B_t: integral over the hemisphere of texel t's bilinear basis function (sr). */
float vbi_hemioct_texel_bilinear_solid_angle(const vbi_hemioct *map, uint32_t t);
/* C_t: the same integral weighted by cos(theta) (projected solid angle, sr). */
float vbi_hemioct_texel_bilinear_projected(const vbi_hemioct *map, uint32_t t);
/* Read-only arrays of R^2 entries (same values as the three functions above). */
const float *vbi_hemioct_solid_angles(const vbi_hemioct *map);
const float *vbi_hemioct_bilinear_projected(const vbi_hemioct *map);
/* Array of R^2 centre directions. */
const vec3 *vbi_hemioct_texel_dirs(const vbi_hemioct *map);

/* ---- bilinear splat and lookup --------------------------------------------------------------- */

/* The bilinear footprint of direction w: four texel indices (possibly repeated at the border)
 * and non-negative weights summing to one. */
void vbi_hemioct_bilinear(const vbi_hemioct *map, vec3 w, uint32_t idx[4], float wgt[4]);

/* vbi_hemioct_encode and vbi_hemioct_bilinear (on a map of res x res texels) inline, for
 * photon splitting's splats; the functions above are these. Neither has a product followed by a
 * sum whose contraction into a fused multiply-add could change its value (0.5 a + 0.5 is exact
 * either way, u res with res a power of two is exact), so callers compiled with or without
 * contraction get the same bits. The footprint: texel centres at (i + 0.5) / res, clamp to edge
 * (idx[1] == idx[0] or idx[0] + 1, idx[3] == idx[2] or idx[2] + 1, rows 0-1 and 2-3). */
static inline vec2 vbi_hemioct_encode_inline(vec3 w)
{
    float z = fmaxf(w.z, 0.0f);
    float l1 = fabsf(w.x) + fabsf(w.y) + z;
    if (!(l1 > 0.0f))
        return (vec2){1.0f, 1.0f};
    float px = w.x / l1, py = w.y / l1;
    /* Cigolle et al. 2014, hemi-oct: rotate the diamond |p|_1 <= 1 by 45 degrees. */
    vec2 u = {0.5f * (px + py) + 0.5f, 0.5f * (px - py) + 0.5f};
    u.x = clampf(u.x, 0.0f, 1.0f);
    u.y = clampf(u.y, 0.0f, 1.0f);
    return u;
}
static inline void vbi_hemioct_footprint(uint32_t res, vec3 w, uint32_t idx[4], float wgt[4])
{
    vec2 u = vbi_hemioct_encode_inline(w);
    float x = u.x * (float)res - 0.5f, y = u.y * (float)res - 0.5f;
    float fx0 = floorf(x), fy0 = floorf(y);
    float fx = x - fx0, fy = y - fy0;
    int last = (int)res - 1;
    int x0 = (int)fx0, y0 = (int)fy0;
    int x1 = x0 + 1, y1 = y0 + 1;
    x0 = x0 < 0 ? 0 : (x0 > last ? last : x0);
    x1 = x1 < 0 ? 0 : (x1 > last ? last : x1);
    y0 = y0 < 0 ? 0 : (y0 > last ? last : y0);
    y1 = y1 < 0 ? 0 : (y1 > last ? last : y1);
    idx[0] = (uint32_t)(y0 * (int)res + x0);
    idx[1] = (uint32_t)(y0 * (int)res + x1);
    idx[2] = (uint32_t)(y1 * (int)res + x0);
    idx[3] = (uint32_t)(y1 * (int)res + x1);
    wgt[0] = (1.0f - fx) * (1.0f - fy);
    wgt[1] = fx * (1.0f - fy);
    wgt[2] = (1.0f - fx) * fy;
    wgt[3] = fx * fy;
}

/* rgb is an R^2 x 3 float array (texel-major: rgb[3 t + c]). Adds value * weight_k to the four
 * footprint texels; the texels receive exactly `value` in total (up to rounding). Not atomic. */
void vbi_hemioct_splat(const vbi_hemioct *map, float *rgb, vec3 w, vec3 value);
/* Same, with atomic float additions (compare-and-swap): any number of threads may splat into
 * the same array concurrently. Readers must wait until every splat has finished. */
void vbi_hemioct_splat_atomic(const vbi_hemioct *map, float *rgb, vec3 w, vec3 value);
/* Bilinear interpolation of an R^2 x 3 array at direction w (same footprint as the splat). */
vec3 vbi_hemioct_lookup(const vbi_hemioct *map, const float *rgb, vec3 w);

/* ---- sampling in proportion to texel weights (optional helper for rendering) --------------- */

/* Piecewise-constant density over the square: texel t is chosen with probability
 * P_t = weight_t / sum(weight), then u is uniform inside it, so the square-domain density is
 * P_t R^2 and the solid-angle pdf is P_t R^2 / jacobian(u). To sample in proportion to a
 * function g(w) per steradian, pass weight_t = g_t * Omega_t. Immutable after creation. */
typedef struct vbi_hemioct_dist vbi_hemioct_dist;

/* weights: R^2 non-negative values. VBNL_ERR_INVALID_ARGUMENT if all are zero (or any is
 * negative or not finite). */
vbnl_result vbi_hemioct_dist_create(const vbi_hemioct *map, const float *weights, vbi_hemioct_dist **out);
void vbi_hemioct_dist_destroy(vbi_hemioct_dist *d);
/* u_texel picks the texel, u the point inside it. Returns the direction; *pdf (solid angle). */
vec3 vbi_hemioct_dist_sample(const vbi_hemioct_dist *d, float u_texel, vec2 u, float *pdf);
/* Solid-angle pdf of sampling w (0 below the horizon or in a zero-weight texel). */
float vbi_hemioct_dist_pdf(const vbi_hemioct_dist *d, vec3 w);
/* Probability of texel t. */
float vbi_hemioct_dist_pmf(const vbi_hemioct_dist *d, uint32_t t);

#endif
