/* Emission profiles of VBNL virtual lights (private header).
 *
 * Photon splitting (Li et al. 2022, Section 3.3) deposits, at every photon hit, a share w_i of
 * the photon's power into each nearby virtual light (VL). A VL accumulates the *incident* power
 * it receives, binned by incident direction; after all photons the incident field is converted
 * into the outgoing emission profile I_j^e of Eq. 3 with the VL's BSDF. This module stores both
 * and does the conversion, eagerly or lazily (Section 5.3).
 *
 * ---- Quantities (all directions in the VL's local frame, z = VL normal, pointing away) -------
 *
 * Phi_i   [W]     incident power deposited by photons arriving from directions around incident
 *                 texel i (photon flux: it already contains the incident cosine). A glossy VL
 *                 keeps Phi_i for the R x R texels of a hemi-oct map (octahedral.h), filled by
 *                 bilinear splats of each photon's incident direction; a Lambertian VL keeps only
 *                 Phi_in = sum_i Phi_i (its emission does not depend on the incident direction).
 *
 * J(wo)   [W/sr]  STORED QUANTITY: the cosine-free radiant intensity
 *                     J(wo) = sum_i f(wo, w_i) Phi_i,
 *                 f the BSDF without any cosine (f = vbnl_bsdf_eval(wo, w_i) / cos theta_i) and
 *                 w_i the centre direction of incident texel i. The profile stores J at the centre
 *                 direction of every outgoing texel t (R x R, same map); J between centres is the
 *                 bilinear interpolation of the stored texels (octahedral.h footprint).
 *                 Lambertian: J = rho / pi * Phi_in for every wo (nothing is stored per texel).
 *                 This is the Rich-VPL table quantity "sum w f_r Phi" (baselines notes, Section 7
 *                 item 5) and, divided by the area A of the surface patch the VL stands for, the
 *                 outgoing radiance L = J / A of that patch (the density-estimation radiance).
 *
 * I(wo)   [W/sr]  radiant intensity of the VL as a surface patch:
 *                     I(wo) = J(wo) cos theta_o = sum_i f(wo, w_i) |cos theta_o| Phi_i,
 *                 Lambertian: I = rho / pi * Phi_in * cos theta_o.
 *
 * P_j     [W]     emitted power = integral of I over the hemisphere. For the bilinear profile
 *                 this is exactly sum_t J_t C_t (C_t: bilinear projected solid angle of texel t,
 *                 octahedral.h) = sum_i Phi_i A_i with A_i = sum_t f(w_t, w_i) C_t, the discrete
 *                 directional albedo of incident texel i, which the kernel precomputes; so P_j
 *                 needs no conversion of the profile. Lambertian: P_j = rho Phi_in.
 *
 * Which one the renderer uses. Eq. 3 treats a VL as a photon light: a point y within r_j of the
 * VL centre emits L_j^e(y, w) = I_j^e(w). The cone-sampling estimator (Eq. 4) hits the surface
 * at y and needs the patch's outgoing radiance, L(y, w) = J(w) / A_j, with A_j the surface area
 * the VL stands for (pi r_j^2 for the disk of Eq. 3; with the partition-of-unity splitting
 * weights that is right on average when about as many VLs cover a point as share its photons;
 * the renderer owns this choice). No VL-side cosine appears: the hit point is on the surface.
 * A VPL/VSL-style point connection instead uses I(w) / d^2 (= J cos theta_o / d^2): keep the VL
 * cosine exactly once (baselines notes, Section 7 item 5). Interpolating J (not I) and then
 * multiplying by the exact cos theta_o keeps the horizon fall-off exact.
 *
 * Storage (measured by vbnl_profile_set_bytes): J texels are packed as RGBE (Ward 1991, the
 * Radiance .hdr format: three 8-bit mantissas sharing one 8-bit exponent, rounded to nearest;
 * error <= 1/256 of the largest channel, full float range, so no per-scene scale is needed). A
 * channel much smaller than the largest keeps only that absolute precision (0.2 next to 0.8 may
 * be off by 1.6 % of itself). Per VL: 16 bytes (incident power sum + slot index); per glossy VL
 * additionally R^2 x 4 bytes of profile (1024 B at 16 x 16, a third of RGB float) plus R^2 x 12
 * bytes of float incident map (3072 B at 16 x 16) until vbnl_profile_set_release_incident()
 * frees all incident maps after an eager conversion. Lambertian VLs store no map (Section 5).
 *
 * Conversion operator: a vbnl_profile_kernel holds one BSDF (in the VL frame) at one resolution,
 * its discrete albedos A_i, and optionally the whole R^2 x R^2 RGB transfer matrix
 * f(w_t, w_i) (786 KB at 16 x 16, 12.6 MB at 32 x 32), which turns a conversion into a
 * matrix-vector product instead of R^4 BSDF evaluations. Build one kernel per material and share
 * it between all VLs with that material (once textures vary the BSDF per VL, use uncached
 * kernels per VL). Cached and uncached kernels give the same texels (same products, same order;
 * tested bit-identical). Measured on one core, GGX conductor, -O2: kernel creation 10 ms at
 * 16 x 16 (130 ms at 32 x 32); eager conversion of one glossy VL 0.08 ms cached / 7 ms uncached
 * at 16 x 16 (1.8 ms / 113 ms at 32 x 32); a lazily converted texel costs 1/R^2 of that.
 *
 * Quantisation (Section 5.3: "minor error due to quantization of the directional
 * information"): incident power is moved to texel centres by the bilinear splat and f is point-
 * sampled at centre pairs. For narrow lobes (GGX alpha below about 0.1 at 16 x 16) the profile
 * aliases; use 32 x 32 there (the paper does for caustics, Fig. 16).
 *
 * ---- Threads ---------------------------------------------------------------------------------
 *
 * Phase 1 (photon splitting): vbnl_profile_deposit is lock-free (atomic float adds) and may be
 * called concurrently for any VLs. Phase 2 (conversion / rendering) must start after every
 * deposit has returned (the caller's thread join or pool barrier orders them); from then on the
 * incident data are read-only. Lazy conversion is per texel and lock-free: a texel's code starts
 * as a sentinel; a reader that finds the sentinel computes the texel (a pure function of the
 * incident map and the kernel) and publishes it with an atomic release store. Two threads racing
 * on one texel compute and store the same bits, so results are deterministic and lazy and eager
 * conversion are bit-identical. The caller must pass the same kernel for a VL on every call. */
#ifndef VBNL_PROFILES_H
#define VBNL_PROFILES_H

#include <stddef.h>
#include <stdint.h>

#include "bsdf.h"
#include "octahedral.h"
#include "vbnl/result.h"
#include "vmath.h"

/* ---- conversion kernel (one per material and resolution) ------------------------------------ */

typedef struct vbnl_profile_kernel vbnl_profile_kernel;

/* Evaluates the BSDF on all R^2 x R^2 centre pairs once (about 65k evaluations at 16 x 16, 1M at
 * 32 x 32) to get the discrete albedos A_i; with cache_matrix != 0 it also keeps the transfer
 * matrix (12 R^4 bytes). `map` and a copy of `bsdf` are kept; the map must outlive the kernel.
 * A Lambertian BSDF gives a closed-form kernel (no matrix, no evaluations). Delta BSDFs (mirror,
 * glass) give an all-zero kernel: VLs should not sit on them. */
vbnl_result vbnl_profile_kernel_create(const vbnl_hemioct *map, const vbnl_bsdf *bsdf, int cache_matrix,
                                       vbnl_profile_kernel **out);
void vbnl_profile_kernel_destroy(vbnl_profile_kernel *k);
/* A_i (RGB) of incident texel i: the fraction of power arriving through texel i that the
 * bilinear profile emits. */
vec3 vbnl_profile_kernel_albedo(const vbnl_profile_kernel *k, uint32_t i);
/* Cosine-weighted average albedo (sum_i A_i C_i / pi): the rho of the diffuse approximation
 * used when a VL without a map (Lambertian slot) is given a non-Lambertian kernel. For a
 * Lambertian kernel it is exactly the BSDF colour. */
vec3 vbnl_profile_kernel_diffuse_albedo(const vbnl_profile_kernel *k);
size_t vbnl_profile_kernel_bytes(const vbnl_profile_kernel *k);

/* ---- profile storage for a set of VLs -------------------------------------------------------- */

typedef struct vbnl_profile_set vbnl_profile_set;

/* count VLs; glossy[v] != 0 gives VL v an R x R map (R from `map`), 0 makes it Lambertian (one
 * RGB sum). glossy may be NULL (all Lambertian). The map must outlive the set. */
vbnl_result vbnl_profile_set_create(const vbnl_hemioct *map, uint32_t count, const uint8_t *glossy,
                                    vbnl_profile_set **out);
void vbnl_profile_set_destroy(vbnl_profile_set *s);
uint32_t vbnl_profile_set_count(const vbnl_profile_set *s);
int vbnl_profile_is_glossy(const vbnl_profile_set *s, uint32_t vl);
/* Bytes currently allocated by the set (including its incident maps while they exist). */
size_t vbnl_profile_set_bytes(const vbnl_profile_set *s);

/* Photon splitting (Section 3.3): adds `power` (the photon power times its splitting weight w_i,
 * in W) arriving at VL `vl` from local direction `wi` (pointing away from the surface, towards
 * where the photon came from). Directions below the horizon are projected onto it. Thread-safe. */
void vbnl_profile_deposit(vbnl_profile_set *s, uint32_t vl, vec3 wi, vec3 power);
/* Phi_in: total incident power received by the VL. */
vec3 vbnl_profile_incident_power(const vbnl_profile_set *s, uint32_t vl);
/* The R^2 x 3 incident map Phi_i of a glossy VL (NULL for Lambertian VLs or after release). */
const float *vbnl_profile_incident_map(const vbnl_profile_set *s, uint32_t vl);

/* Eager conversion of every texel of one VL (no-op for Lambertian VLs and converted texels).
 * Thread-safe, also concurrently with lazy readers. */
void vbnl_profile_convert(vbnl_profile_set *s, uint32_t vl, const vbnl_profile_kernel *k);
/* Frees every incident map. VBNL_ERR_STATE (nothing freed) if some glossy texel has not been
 * converted. Not thread-safe: call between phases. */
vbnl_result vbnl_profile_set_release_incident(vbnl_profile_set *s);

/* J at the centre of outgoing texel t, converting it first if needed (lazy). */
vec3 vbnl_profile_texel(vbnl_profile_set *s, uint32_t vl, const vbnl_profile_kernel *k, uint32_t t);
/* Bilinearly interpolated J(wo); 0 for wo.z <= 0. Converts the (up to four) texels it reads. */
vec3 vbnl_profile_eval(vbnl_profile_set *s, uint32_t vl, const vbnl_profile_kernel *k, vec3 wo);
/* I(wo) = J(wo) cos theta_o (0 below the horizon). */
vec3 vbnl_profile_intensity(vbnl_profile_set *s, uint32_t vl, const vbnl_profile_kernel *k, vec3 wo);
/* P_j = integral of I over the hemisphere (see above); needs no conversion. Feed its luminance
 * (or max component) to the power-based selection of Eq. 4. */
vec3 vbnl_profile_power(const vbnl_profile_set *s, uint32_t vl, const vbnl_profile_kernel *k);
/* True when texel t of a glossy VL has been converted (always true for Lambertian VLs). */
int vbnl_profile_texel_converted(const vbnl_profile_set *s, uint32_t vl, uint32_t t);

#endif
