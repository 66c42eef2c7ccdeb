/* GGX microfacet helpers (private header).
 *
 * Isotropic Trowbridge-Reitz/GGX distribution in the local shading frame (z = macro normal),
 * Smith masking in its height-correlated form, visible-normal sampling, and the layout of the
 * precomputed directional-albedo tables used for the Kulla-Conty energy compensation.
 *
 * tools/gen_ggx_tables.c includes this header too, so the tables are computed with exactly the
 * model that bsdf.c evaluates. Everything here is static inline and stateless. */
#ifndef VBI_MICROFACET_H
#define VBI_MICROFACET_H

#include "vmath.h"

/* D(h) = 1 / (pi a^2 cos^4 (1 + tan^2 / a^2)^2) (Walter et al. 2007, Eq. 33), written with the
 * unit vector's components so that no trigonometry is needed: the bracket is x^2/a^2 + y^2/a^2 +
 * z^2. */
static inline float ggx_d(vec3 h, float alpha)
{
    if (h.z <= 0.0f)
        return 0.0f;
    float a2 = alpha * alpha;
    float t = (h.x * h.x + h.y * h.y) / a2 + h.z * h.z;
    return 1.0f / (VBI_PI * a2 * t * t);
}

/* Smith Lambda for GGX: (-1 + sqrt(1 + a^2 tan^2 theta)) / 2 (Heitz 2014, Eq. 86), written as
 * t / (2 (1 + sqrt(1 + t))) to avoid cancellation when a^2 tan^2 theta is small. */
static inline float ggx_lambda(vec3 w, float alpha)
{
    float z2 = w.z * w.z;
    if (z2 == 0.0f)
        return INFINITY;
    float t = alpha * alpha * (w.x * w.x + w.y * w.y) / z2;
    return 0.5f * t / (1.0f + sqrtf(1.0f + t));
}

/* Smith masking G1 = 1 / (1 + Lambda) (Heitz 2014, Eq. 43). */
static inline float ggx_g1(vec3 w, float alpha) { return 1.0f / (1.0f + ggx_lambda(w, alpha)); }

/* Height-correlated masking-shadowing G2 = 1 / (1 + Lambda(wo) + Lambda(wi)) (Heitz 2014,
 * Eq. 99) for wo and wi on the same side. It is symmetric, so the BRDF stays reciprocal, and it
 * is less dark than the separable product G1 G1 at grazing angles. */
static inline float ggx_g2(vec3 wo, vec3 wi, float alpha)
{
    return 1.0f / (1.0f + ggx_lambda(wo, alpha) + ggx_lambda(wi, alpha));
}

/* Samples a visible normal for wo (wo.z > 0) with pdf D_wo(h) = G1(wo) max(0, wo.h) D(h) / wo.z
 * (Heitz 2018, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4), Listing 1). */
static inline vec3 ggx_sample_vndf(vec3 wo, float alpha, vec2 u)
{
    /* Section 3.2: stretch the view vector to the hemisphere configuration (alpha = 1). */
    vec3 vh = v3_norm(v3(alpha * wo.x, alpha * wo.y, wo.z));
    /* Section 4.1: orthonormal basis around vh (T1 horizontal, so undefined only at normal
     * incidence where any horizontal vector will do). */
    float lensq = vh.x * vh.x + vh.y * vh.y;
    vec3 t1 = lensq > 0.0f ? v3_scale(v3(-vh.y, vh.x, 0.0f), 1.0f / sqrtf(lensq)) : v3(1.0f, 0.0f, 0.0f);
    vec3 t2 = v3_cross(vh, t1);
    /* Section 4.2: uniform point on the projected area (a disk whose lower half is squashed). */
    float r = sqrtf(u.x);
    float phi = 2.0f * VBI_PI * u.y;
    float p1 = r * cosf(phi);
    float p2 = r * sinf(phi);
    float s = 0.5f * (1.0f + vh.z);
    p2 = (1.0f - s) * safe_sqrtf(1.0f - p1 * p1) + s * p2;
    /* Section 4.3: reproject onto the hemisphere. */
    vec3 nh = v3_add(v3_add(v3_scale(t1, p1), v3_scale(t2, p2)),
                     v3_scale(vh, safe_sqrtf(1.0f - p1 * p1 - p2 * p2)));
    /* Section 3.4: unstretch back to the ellipsoid configuration. */
    return v3_norm(v3(alpha * nh.x, alpha * nh.y, maxf(1e-6f, nh.z)));
}

/* Solid-angle pdf of wi = reflect(wo, h) when h is drawn from the VNDF: D_wo(h) / (4 wo.h)
 * (Heitz 2018, Eq. 17 with the reflection Jacobian 1 / (4 wo.h)), where the wo.h cancel. */
static inline float ggx_pdf_vndf_reflect(vec3 wo, vec3 h, float alpha)
{
    if (wo.z <= 0.0f)
        return 0.0f;
    return ggx_g1(wo, alpha) * ggx_d(h, alpha) / (4.0f * wo.z);
}

static inline vec3 reflect_about(vec3 w, vec3 h) { return v3_sub(v3_scale(h, 2.0f * v3_dot(w, h)), w); }

/* Unpolarised Fresnel reflectance of a dielectric interface (pbrt-v4 FrDielectric). eta =
 * n_inside / n_outside; cos_i < 0 means the incident direction is inside. Returns 1 under total
 * internal reflection. */
static inline float fresnel_dielectric_inline(float cos_i, float eta)
{
    cos_i = clampf(cos_i, -1.0f, 1.0f);
    if (cos_i < 0.0f) {
        eta = 1.0f / eta;
        cos_i = -cos_i;
    }
    float sin2_t = (1.0f - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.0f)
        return 1.0f;
    float cos_t = safe_sqrtf(1.0f - sin2_t);
    float r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    float r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    return 0.5f * (r_parl * r_parl + r_perp * r_perp);
}

/* ---- directional-albedo tables (core/src/ggx_tables.c, made by tools/gen_ggx_tables.c) ----
 *
 * E(mu, alpha) is the albedo of the single-scattering GGX lobe for cos theta_o = mu:
 *   conductor: F = 1 (the Kulla-Conty "E"), indexed [alpha][mu];
 *   coat:      dielectric Fresnel reflection only, seen from outside, indexed [ior][alpha][mu].
 * E_avg = 2 int_0^1 E(mu) mu dmu, integrated exactly over the interpolant of the table row (linear
 * in t = sqrt(mu), see below), so that the compensation lobe built from the interpolated table conserves energy
 * exactly with respect to that same table.
 *
 * Axes (grid points, linear interpolation between them):
 *   mu    = t^2 with t = i / (N_MU - 1) uniform   (mu = 0 is evaluated at VBI_GGX_MU_MIN):
 *           E dips sharply just above grazing for small alpha (G2/G1 -> 1 as mu -> 0 but the
 *           shadowing of wi bites at mu ~ alpha), so the grid is dense near mu = 0;
 *   r     = sqrt(alpha), uniform on [sqrt(VBI_GGX_ALPHA_MIN), 1]: resolution where E changes
 *           fastest (small alpha);
 *   s     = (ior - 1) / (ior + 1) = sqrt(F0), uniform on [s(VBI_GGX_IOR_MIN), s(VBI_GGX_IOR_MAX)]:
 *           E at normal incidence is F0 = s^2, quadratic in s, so linear interpolation in s has
 *           a small bounded error, while interpolation in ior or F0 would not (E jumps near ior 1
 *           at grazing angles). */
#define VBI_GGX_N_MU 32
#define VBI_GGX_N_ALPHA 32
#define VBI_GGX_N_IOR 16
#define VBI_GGX_ALPHA_MIN 1e-3f
#define VBI_GGX_MU_MIN 1e-4f
#define VBI_GGX_IOR_MIN 1.05f
#define VBI_GGX_IOR_MAX 3.0f

extern const float vbi_ggx_conductor_E[VBI_GGX_N_ALPHA][VBI_GGX_N_MU];
extern const float vbi_ggx_conductor_Eavg[VBI_GGX_N_ALPHA];
extern const float vbi_ggx_coat_E[VBI_GGX_N_IOR][VBI_GGX_N_ALPHA][VBI_GGX_N_MU];
extern const float vbi_ggx_coat_Eavg[VBI_GGX_N_IOR][VBI_GGX_N_ALPHA];

/* Continuous table coordinates in [0, N - 1] for each axis (shared by the generator and the
 * lookups so they cannot disagree). */
static inline float ggx_table_x_mu(float mu) { return sqrtf(clampf(mu, 0.0f, 1.0f)) * (float)(VBI_GGX_N_MU - 1); }
static inline float ggx_table_x_alpha(float alpha)
{
    float r0 = sqrtf(VBI_GGX_ALPHA_MIN);
    float r = sqrtf(clampf(alpha, VBI_GGX_ALPHA_MIN, 1.0f));
    return clampf((r - r0) / (1.0f - r0), 0.0f, 1.0f) * (float)(VBI_GGX_N_ALPHA - 1);
}
static inline float ggx_ior_to_s(float ior) { return (ior - 1.0f) / (ior + 1.0f); }
static inline float ggx_table_x_ior(float ior)
{
    float s0 = ggx_ior_to_s(VBI_GGX_IOR_MIN), s1 = ggx_ior_to_s(VBI_GGX_IOR_MAX);
    float s = ggx_ior_to_s(clampf(ior, VBI_GGX_IOR_MIN, VBI_GGX_IOR_MAX));
    return clampf((s - s0) / (s1 - s0), 0.0f, 1.0f) * (float)(VBI_GGX_N_IOR - 1);
}
/* Inverse maps: the parameter value at grid coordinate x (integer or not). */
static inline float ggx_table_mu_at(float x) { return maxf(sqr(x / (float)(VBI_GGX_N_MU - 1)), VBI_GGX_MU_MIN); }
static inline float ggx_table_alpha_at(float x)
{
    float r0 = sqrtf(VBI_GGX_ALPHA_MIN);
    float r = r0 + (1.0f - r0) * x / (float)(VBI_GGX_N_ALPHA - 1);
    return r * r;
}
static inline float ggx_table_ior_at(float x)
{
    float s0 = ggx_ior_to_s(VBI_GGX_IOR_MIN), s1 = ggx_ior_to_s(VBI_GGX_IOR_MAX);
    float s = s0 + (s1 - s0) * x / (float)(VBI_GGX_N_IOR - 1);
    return (1.0f + s) / (1.0f - s);
}

#endif
