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
 *                 f the BSDF without any cosine (f = vbi_bsdf_eval(wo, w_i) / cos theta_i) and
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
 * Storage (measured by vbi_profile_set_bytes): J texels are packed as RGBE (Ward 1991, the
 * Radiance .hdr format: three 8-bit mantissas sharing one 8-bit exponent, rounded to nearest;
 * error <= 1/256 of the largest channel, full float range, so no per-scene scale is needed). A
 * channel much smaller than the largest keeps only that absolute precision (0.2 next to 0.8 may
 * be off by 1.6 % of itself). Per VL: 28 bytes (fixed-point incident power sum + slot index); per
 * glossy VL additionally R^2 x 4 bytes of profile (1024 B at 16 x 16, a third of RGB float) plus
 * R^2 x 24 bytes of fixed-point incident map (6144 B at 16 x 16) until
 * vbi_profile_set_release_incident() frees all incident maps after an eager conversion.
 * Lambertian VLs store no map (Section 5).
 *
 * ---- Fixed point (incident data) -------------------------------------------------------------
 *
 * Incident power (Phi_in and every Phi_i) is accumulated as unsigned 64-bit integers counting
 * steps of `unit` watts, with atomic integer adds. Integer addition is associative, so the
 * accumulated data are bit-identical for any thread count and deposit order, and the data of
 * two runs add exactly (vbi_profile_set_merge): photon work can be split across threads,
 * processes or machines and summed. `unit` is a power of two fixed at creation (conversion to
 * watts is then exact in double). vbi_profile_unit_for_power(typical photon power) picks 2^k
 * in (2^-25, 2^-24] times the typical photon power, so a typical photon is 2^24..2^25 steps.
 *   Quantisation: a deposit is rounded once to the nearest step (error <= unit / 2 per channel,
 *   i.e. <= 2^-25 of a typical photon, about float epsilon); its splits (among VLs, among the
 *   four bilinear texels) are exact integer partitions (vbi_profile_split_fixed), so the texels
 *   of a glossy VL sum exactly to its Phi_in and the VLs' shares sum exactly to the quantised
 *   photon power. Over N deposits the total error is at most N / 2 steps, relative <= 2^-25 to
 *   a typical photon; deposits below unit / 2 (photons 2^25 times weaker than typical, or tiny
 *   bilinear shares) are lost or rounded up, and only they see a large relative error.
 *   Headroom: 2^64 steps = 2^39..2^40 typical photons (about 5e11) in one texel or VL sum, so 1e9
 *   photons all landing in one texel leave a margin of 500; single deposits are clamped to
 *   VBI_PROFILE_MAX_DEPOSIT (2^52 steps = 2^27 typical photons; guards against inf/NaN).
 *   Sums are not checked for wrap-around.
 * The default unit of vbi_profile_set_create is VBI_PROFILE_DEFAULT_UNIT (2^-40 W: photons of
 * 1e-5 .. 1e3 W keep better than float precision and 1.6e7 W of total deposits fit).
 *
 * Conversion operator: a vbi_profile_kernel holds one BSDF (in the VL frame) at one resolution,
 * its discrete albedos A_i, and optionally the whole R^2 x R^2 RGB transfer matrix
 * f(w_t, w_i) (786 KB at 16 x 16, 12.6 MB at 32 x 32), which turns a conversion into a
 * matrix-vector product instead of R^4 BSDF evaluations. Build one kernel per material and share
 * it between all VLs with that material. Textured materials: the kernel is built from the
 * material's untextured BSDF and each VL multiplies its converted profile (and power) by its own
 * texture colour (vl_set.h tint). That is exact for Lambertian materials (the profile is linear in
 * the albedo); for a textured glossy material it tints the whole lobe, specular part included,
 * an approximation (per-VL kernels would cost R^4 evaluations per VL). Cached and uncached kernels give the same texels (same products, same order;
 * tested bit-identical). Measured on one core, GGX conductor, -O2: kernel creation 10 ms at
 * 16 x 16 (130 ms at 32 x 32); eager conversion of one glossy VL 0.08 ms cached / 7 ms uncached
 * at 16 x 16 (1.8 ms / 113 ms at 32 x 32); a lazily converted texel costs 1/R^2 of that.
 *
 * Quantisation (Section 5.3: "minor error due to quantization of the directional
 * information"): incident power is moved to texel centres by the bilinear splat and f is point-
 * sampled at centre pairs, except the microfacet lobe of a BSDF whose GGX alpha is below
 * 4.8 / R (0.3 at 16 x 16), which is projected onto the outgoing texels so that it keeps its
 * energy however narrow it is (profiles.c, "Narrow lobes"); such kernels always keep the
 * matrix, whatever cache_matrix says. A lobe narrower than a texel is blurred over one; use
 * 32 x 32 where that matters (the paper does for caustics, Fig. 16).
 *
 * ---- Threads ---------------------------------------------------------------------------------
 *
 * Phase 1 (photon splitting): vbi_profile_deposit is lock-free (atomic 64-bit integer adds,
 * order-independent) and may be called concurrently for any VLs. (Photon splitting itself
 * keeps Phi_in in per-thread sums, added with vbi_profile_add_power_fixed after its threads
 * joined, and splats glossy maps with the atomic vbi_profile_deposit_map_fixed.) Phase 2
 * (conversion / rendering) must start after every deposit has returned (the caller's thread
 * join or pool barrier orders them); from then on the incident data are read-only. Lazy
 * conversion is lock-free: a texel's code starts as a sentinel; a reader that finds the sentinel
 * computes the texel (a pure function of the incident map and the kernel; with a cached matrix,
 * every unset texel of that light at once) and publishes it with an atomic release store. Two threads racing on one texel compute and
 * store the same bits, so results are deterministic and lazy and eager conversion are
 * bit-identical. The caller must pass the same kernel for a VL on every call. */
#ifndef VBI_PROFILES_H
#define VBI_PROFILES_H

#include <stddef.h>
#include <stdint.h>

#include "bsdf.h"
#include "octahedral.h"
#include "vbnl/result.h"
#include "vmath.h"

/* ---- conversion kernel (one per material and resolution) ------------------------------------ */

typedef struct vbi_profile_kernel vbi_profile_kernel;

/* Evaluates the BSDF on all R^2 x R^2 centre pairs once (about 65k evaluations at 16 x 16, 1M at
 * 32 x 32) to get the discrete albedos A_i; with cache_matrix != 0 it also keeps the transfer
 * matrix (12 R^4 bytes). `map` and a copy of `bsdf` are kept; the map must outlive the kernel.
 * A Lambertian BSDF gives a closed-form kernel (no matrix, no evaluations). Delta BSDFs (mirror,
 * glass) give an all-zero kernel: VLs should not sit on them. */
vbnl_result vbi_profile_kernel_create(const vbi_hemioct *map, const vbi_bsdf *bsdf, int cache_matrix,
                                       vbi_profile_kernel **out);
void vbi_profile_kernel_destroy(vbi_profile_kernel *k);
/* A_i (RGB) of incident texel i: the fraction of power arriving through texel i that the
 * bilinear profile emits. */
vec3 vbi_profile_kernel_albedo(const vbi_profile_kernel *k, uint32_t i);
/* Cosine-weighted average albedo (sum_i A_i C_i / pi): the rho of the diffuse approximation
 * used when a VL without a map (Lambertian slot) is given a non-Lambertian kernel. For a
 * Lambertian kernel it is exactly the BSDF colour. */
vec3 vbi_profile_kernel_diffuse_albedo(const vbi_profile_kernel *k);
size_t vbi_profile_kernel_bytes(const vbi_profile_kernel *k);

/* ---- profile storage for a set of VLs -------------------------------------------------------- */

typedef struct vbi_profile_set vbi_profile_set;

#define VBI_PROFILE_DEFAULT_UNIT 0x1p-40
#define VBI_PROFILE_MAX_DEPOSIT 0x1p52

/* count VLs; glossy[v] != 0 gives VL v an R x R map (R from `map`), 0 makes it Lambertian (one
 * RGB sum). glossy may be NULL (all Lambertian). The map must outlive the set. Fixed-point unit
 * VBI_PROFILE_DEFAULT_UNIT. */
vbnl_result vbi_profile_set_create(const vbi_hemioct *map, uint32_t count, const uint8_t *glossy,
                                    vbi_profile_set **out);
/* Same with an explicit fixed-point unit in W (a power of two > 0, else
 * VBNL_ERR_INVALID_ARGUMENT); see "Fixed point" above. */
vbnl_result vbi_profile_set_create_fixed(const vbi_hemioct *map, uint32_t count, const uint8_t *glossy,
                                          double unit, vbi_profile_set **out);
/* The unit for photons of about `typical_power` W: the power of two in
 * (2^-25, 2^-24] x typical_power (VBI_PROFILE_DEFAULT_UNIT when typical_power is not > 0). */
double vbi_profile_unit_for_power(double typical_power);
double vbi_profile_set_unit(const vbi_profile_set *s);
void vbi_profile_set_destroy(vbi_profile_set *s);
uint32_t vbi_profile_set_count(const vbi_profile_set *s);
int vbi_profile_is_glossy(const vbi_profile_set *s, uint32_t vl);
/* Bytes currently allocated by the set (including its incident maps while they exist). */
size_t vbi_profile_set_bytes(const vbi_profile_set *s);

/* Photon splitting (Section 3.3): adds `power` (the photon power times its splitting weight w_i,
 * in W) arriving at VL `vl` from local direction `wi` (pointing away from the surface, towards
 * where the photon came from). Directions below the horizon are projected onto it. Thread-safe. */
void vbi_profile_deposit(vbi_profile_set *s, uint32_t vl, vec3 wi, vec3 power);
/* power (W, RGB) -> steps of the set's unit, rounded to nearest, clamped to
 * [0, VBI_PROFILE_MAX_DEPOSIT] (NaN -> 0). vbi_profile_deposit = quantize + deposit_fixed. */
void vbi_profile_quantize(const vbi_profile_set *s, vec3 power, uint64_t q[3]);
/* Deposit of an already quantised power: Phi_in gets exactly q; a glossy VL's four bilinear
 * texels get an exact integer partition of q. Thread-safe. */
void vbi_profile_deposit_fixed(vbi_profile_set *s, uint32_t vl, vec3 wi, const uint64_t q[3]);
/* The two halves of vbi_profile_deposit_fixed, for callers that keep their own Phi_in sums
 * (photon splitting: per-thread sums by VL, added once at the end). deposit_map_fixed splats q
 * into a glossy VL's incident map (no-op for a Lambertian VL; thread-safe, atomic) and leaves
 * Phi_in alone; add_power_fixed adds q to Phi_in with plain (non-atomic) adds: call it when no
 * other thread deposits into the same VL. Both together equal one deposit_fixed. */
void vbi_profile_deposit_map_fixed(vbi_profile_set *s, uint32_t vl, vec3 wi, const uint64_t q[3]);
void vbi_profile_add_power_fixed(vbi_profile_set *s, uint32_t vl, const uint64_t q[3]);
/* deposit_map_fixed in two steps, so that a caller can prefetch the texels and apply the splat
 * later (photon splitting keeps a few in flight: the maps are large and the texels random):
 * prepare computes the texels and their exact integer shares (the same as deposit_map_fixed)
 * and prefetches them; it returns 0 (nothing to apply) for a Lambertian VL. apply makes the
 * atomic adds; the set must outlive the pending splats. */
typedef struct vbi_profile_splat {
    uint64_t *texel[4];
    uint64_t part[4][3];
} vbi_profile_splat;
int vbi_profile_splat_prepare(vbi_profile_set *s, uint32_t vl, vec3 wi, const uint64_t q[3],
                               vbi_profile_splat *sp);
void vbi_profile_splat_apply(const vbi_profile_splat *sp);
/* Private 32-bit incident maps, so that each thread splats with plain adds (photon splitting:
 * a locked add per texel channel cost ~10% of the glossy box's splitting) into half the memory
 * of a copy of the set's 64-bit maps (fewer cache lines per splat, a smaller working set). A
 * thread's map holds the low 32 bits of its sums, laid out as the set's maps (3 per texel,
 * vbi_profile_incident_bytes / 2 bytes, zeroed); an add that passes 2^32 adds its high part
 * into the set's own texel atomically (sum = set + low half, exactly), and add_incident_lo32
 * adds the low halves when the run ends: the same bits as atomic splats into the set.
 * splat_prepare_slot is splat_prepare by map slot (vbi_profile_slot), prepare_lo32 the same
 * into a 32-bit map, for a caller that keeps the slot
 * beside its own per-VL data (photon splitting: in the VL's line of per-thread sums, so that a
 * splat does not read the set's slot table at random); apply_lo32 adds with plain adds (one
 * writer per map at a time); add_incident_lo32 is not thread-safe: call between phases. */
typedef struct vbi_profile_splat32 {
    uint32_t *texel[4];  /* the low halves in the thread's map */
    uint64_t *carry[4];  /* the same texels in the set's maps */
    uint64_t part[4][3];
} vbi_profile_splat32;
size_t vbi_profile_incident_bytes(const vbi_profile_set *s);
uint64_t *vbi_profile_incident_maps(vbi_profile_set *s);
/* What a caller's own inline splat into 32-bit maps needs (photon splitting's vector splat,
 * which keeps to the rules of prepare_lo32 and apply_lo32 and gives the same bits): the map
 * resolution (octahedral.h, vbi_hemioct_footprint), texels per map and the set's 64-bit maps
 * (slot s's map at incident + 3 s texels; NULL after release). */
typedef struct vbi_profile_maps_view {
    uint32_t res, texels;
    uint64_t *incident;
} vbi_profile_maps_view;
vbi_profile_maps_view vbi_profile_maps_view_of(vbi_profile_set *s);
int vbi_profile_splat_prepare_slot(vbi_profile_set *s, uint32_t slot, vec3 wi, const uint64_t q[3],
                                    vbi_profile_splat *sp);
int vbi_profile_splat_prepare_lo32(vbi_profile_set *s, uint32_t *lo, uint32_t slot, vec3 wi, const uint64_t q[3],
                                    vbi_profile_splat32 *sp);
void vbi_profile_splat_apply_lo32(const vbi_profile_splat32 *sp);
vbnl_result vbi_profile_add_incident_lo32(vbi_profile_set *s, const uint32_t *lo);
/* Exact integer partition of q by weights w[0..n-1] (sum <= 1 up to float rounding):
 * out[k] = floor(q w_k), the residue to the largest weight, so sum out == q. Deterministic. */
void vbi_profile_split_fixed(uint64_t q, uint32_t n, const float *w, uint64_t *out);
/* Phi_in: total incident power received by the VL (W). */
vec3 vbi_profile_incident_power(const vbi_profile_set *s, uint32_t vl);
/* The same as 3 fixed-point integers (steps of the set's unit). */
const uint64_t *vbi_profile_incident_power_fixed(const vbi_profile_set *s, uint32_t vl);
/* The R^2 x 3 fixed-point incident map Phi_i of a glossy VL (NULL for Lambertian VLs or after
 * release); multiply by vbi_profile_set_unit for watts. */
const uint64_t *vbi_profile_incident_map_fixed(const vbi_profile_set *s, uint32_t vl);
/* Phi_i of texel t in W (0 for Lambertian VLs or after release). */
vec3 vbi_profile_incident_texel(const vbi_profile_set *s, uint32_t vl, uint32_t t);
/* Adds src's incident data to dst's (integer adds: exact, so merging the sets of two runs
 * equals one run that made both runs' deposits). Both sets need the same VL count, glossy
 * layout, map resolution and unit (else VBNL_ERR_INVALID_ARGUMENT) and their incident maps
 * (VBNL_ERR_STATE after release). dst's converted texels are reset to unconverted. Not
 * thread-safe: call between phases. */
vbnl_result vbi_profile_set_merge(vbi_profile_set *dst, const vbi_profile_set *src);

/* Import of saved incident data (vl_file.h): sets VL vl's Phi_in to phi (3 fixed-point values
 * in the set's unit) and, for a glossy VL, its incident map to `map` (R^2 x 3 values, the layout
 * of vbi_profile_incident_map_fixed; ignored and may be NULL for a Lambertian VL). Replaces
 * (does not add to) what the VL held and marks its texels unconverted. VBNL_ERR_INVALID_ARGUMENT
 * for NULL arguments, vl out of range or a NULL map for a glossy VL; VBNL_ERR_STATE after
 * release. Not thread-safe: call between phases. */
vbnl_result vbi_profile_set_import_fixed(vbi_profile_set *s, uint32_t vl, const uint64_t phi[3],
                                          const uint64_t *map);

/* Eager conversion of every texel of one VL (no-op for Lambertian VLs and converted texels).
 * Thread-safe, also concurrently with lazy readers. */
void vbi_profile_convert(vbi_profile_set *s, uint32_t vl, const vbi_profile_kernel *k);
/* Frees every incident map. VBNL_ERR_STATE (nothing freed) if some glossy texel has not been
 * converted. Not thread-safe: call between phases. */
vbnl_result vbi_profile_set_release_incident(vbi_profile_set *s);

/* J at the centre of outgoing texel t, converting it first if needed (lazy). */
vec3 vbi_profile_texel(vbi_profile_set *s, uint32_t vl, const vbi_profile_kernel *k, uint32_t t);
/* Bilinearly interpolated J(wo); 0 for wo.z <= 0. Converts the (up to four) texels it reads. */
vec3 vbi_profile_eval(vbi_profile_set *s, uint32_t vl, const vbi_profile_kernel *k, vec3 wo);
/* The same lookup in two steps, by map slot (vbi_profile_slot), so that a caller can start the
 * texel loads of several lights before reading any (the maps are large and the lights random):
 * begin computes the bilinear footprint of wo (wo.z > 0) and prefetches its texels; end reads
 * them (converting if needed) and returns what vbi_profile_eval returns, bit for bit. */
#define VBI_PROFILE_NO_SLOT UINT32_MAX
typedef struct vbi_profile_lookup {
    uint32_t idx[4];
    float wgt[4];
} vbi_profile_lookup;
/* Index of a glossy VL's map, VBI_PROFILE_NO_SLOT for a Lambertian VL. */
uint32_t vbi_profile_slot(const vbi_profile_set *s, uint32_t vl);
void vbi_profile_lookup_begin(const vbi_profile_set *s, uint32_t slot, vec3 wo, vbi_profile_lookup *l);
vec3 vbi_profile_lookup_end(vbi_profile_set *s, uint32_t slot, const vbi_profile_kernel *k,
                             const vbi_profile_lookup *l);
/* I(wo) = J(wo) cos theta_o (0 below the horizon). */
vec3 vbi_profile_intensity(vbi_profile_set *s, uint32_t vl, const vbi_profile_kernel *k, vec3 wo);
/* P_j = integral of I over the hemisphere (see above); needs no conversion. Feed its luminance
 * (or max component) to the power-based selection of Eq. 4. */
vec3 vbi_profile_power(const vbi_profile_set *s, uint32_t vl, const vbi_profile_kernel *k);
/* True when texel t of a glossy VL has been converted (always true for Lambertian VLs). */
int vbi_profile_texel_converted(const vbi_profile_set *s, uint32_t vl, uint32_t t);

#endif
