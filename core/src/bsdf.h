/* Scattering functions (private header).
 *
 * All directions are in the local shading frame (z = shading normal), both pointing away from
 * the surface. Convention (Mitsuba's): eval returns f(wo, wi) * |cos theta_i|; sample returns the
 * weight f * |cos theta_i| / pdf. Delta lobes (mirror, smooth glass) are never returned by
 * eval/pdf; sample reports them with VBI_LOBE_SPECULAR and pdf = probability of picking that lobe.
 *
 * Sidedness: opaque materials are one-sided: eval/pdf/sample give 0 unless wo.z > 0 (and, for
 * eval/pdf, wi.z > 0). The integrator flips the shading frame to face wo for opaque surfaces.
 * The dielectric uses the true orientation: z is the outward normal and wo.z < 0 means the ray
 * arrived from inside. Radiance transport: refraction scales by 1/eta^2 (pbrt's convention). */
#ifndef VBI_BSDF_H
#define VBI_BSDF_H

#include <stdint.h>

#include "sampling.h"
#include "vbnl/scene.h"
#include "vmath.h"

enum {
    VBI_LOBE_REFLECTION = 1u << 0,
    VBI_LOBE_TRANSMISSION = 1u << 1,
    VBI_LOBE_DIFFUSE = 1u << 2,
    VBI_LOBE_GLOSSY = 1u << 3,
    VBI_LOBE_SPECULAR = 1u << 4, /* a delta distribution */
};

/* A material resolved at a hit point: its pigment's colour applied, and, where a normal
 * perturbs it, the shading normal there (vbi_surface_bsdf). */
typedef struct vbi_bsdf {
    vbnl_material_type type;
    vec3 color;       /* Lambert / plastic base albedo; conductor F0; mirror / glass tint */
    float alpha;      /* GGX roughness, clamped to [1e-3, 1] */
    float ior;        /* dielectric / plastic coat */
    int use_ior;      /* conductor: eta/k instead of F0 */
    vec3 eta, k;
    float brilliance; /* VBNL_MATERIAL_BRILLIANCE: the exponent b */
    int coat_curve;   /* VBNL_MATERIAL_PLASTIC: vbnl_coat_curve, and the fields below for the others */
    vec3 coat_min, coat_max;
    float coat_falloff, coat_metallic, base_scale;
    int coat_conserve;
    int bumped;       /* 1: ns replaces the hit's shading normal */
    vec3 ns;          /* the perturbed unit shading normal, on the hit's geometric side */
} vbi_bsdf;

/* The shading normal to build the frame on: the perturbed one where a normal perturbs the
 * surface, else the hit's. */
static inline vec3 vbi_bsdf_shading_normal(const vbi_bsdf *b, vec3 hit_ns) { return b->bumped ? b->ns : hit_ns; }

typedef struct vbi_bsdf_sample_rec {
    vec3 wi;
    vec3 weight;      /* f * |cos theta_i| / pdf */
    float pdf;        /* solid-angle pdf; for delta lobes the discrete lobe probability */
    uint32_t lobe;    /* VBI_LOBE_* of the sampled lobe */
    float eta;        /* relative IOR crossed by a transmission (1 for reflections) */
} vbi_bsdf_sample_rec;

void vbi_bsdf_from_material(vbi_bsdf *b, const vbnl_material_desc *m);

/* The non-Lambertian cases of eval / pdf / sample (bsdf.c); call the inline functions below. */
vec3 vbi_bsdf_eval_other(const vbi_bsdf *b, vec3 wo, vec3 wi);
float vbi_bsdf_pdf_other(const vbi_bsdf *b, vec3 wo, vec3 wi);
int vbi_bsdf_sample_other(const vbi_bsdf *b, vec3 wo, vec2 u, vbi_bsdf_sample_rec *out);

/* Lambert is inline: it is every surface of most test scenes, and inlined into next-event
 * estimation the compiler keeps only the z of wi it needs (and shares it between eval and pdf). */
static inline vec3 vbi_bsdf_eval(const vbi_bsdf *b, vec3 wo, vec3 wi)
{
    if (b->type != VBNL_MATERIAL_LAMBERT)
        return vbi_bsdf_eval_other(b, wo, wi);
    if (wo.z <= 0.0f || wi.z <= 0.0f)
        return v3s(0.0f);
    return v3_scale(b->color, VBI_INV_PI * wi.z);
}

static inline float vbi_bsdf_pdf(const vbi_bsdf *b, vec3 wo, vec3 wi)
{
    if (b->type != VBNL_MATERIAL_LAMBERT)
        return vbi_bsdf_pdf_other(b, wo, wi);
    return wo.z > 0.0f ? pdf_cosine_hemisphere(wi) : 0.0f;
}

/* One uniform 2D number u in [0,1)^2 picks the lobe and the direction: the lobe from u.x, which
 * is then rescaled within the lobe's share and reused for the direction (so a stratified u stays
 * stratified within each lobe); a smooth dielectric chooses reflection or refraction with u.x.
 * Returns 1 with *out filled, or 0 (absorbed). */
static inline int vbi_bsdf_sample(const vbi_bsdf *b, vec3 wo, vec2 u, vbi_bsdf_sample_rec *out)
{
    if (b->type != VBNL_MATERIAL_LAMBERT) {
        /* through a copy, so that the caller's record need not live in memory (see
         * vbi_light_sample_li) */
        vbi_bsdf_sample_rec other;
        int ok = vbi_bsdf_sample_other(b, wo, u, &other);
        if (ok)
            *out = other;
        return ok;
    }
    if (wo.z <= 0.0f)
        return 0;
    vec3 wi = sample_cosine_hemisphere(u);
    if (wi.z <= 0.0f)
        return 0;
    out->wi = wi;
    out->pdf = pdf_cosine_hemisphere(wi);
    out->weight = b->color; /* (color / pi) cos / (cos / pi) */
    out->lobe = VBI_LOBE_REFLECTION | VBI_LOBE_DIFFUSE;
    out->eta = 1.0f;
    return 1;
}

/* The microfacet (single-scattering GGX) lobe of a conductor or plastic alone, in eval's
 * convention (f |cos theta_i|), and its sampler (the visible normals of wo, Heitz 2018) with the
 * sampled direction's solid-angle pdf (returns 0 when the direction is unusable); zero / 0 for
 * the other types. The rest of those BSDFs (a conductor's multiple scattering, a plastic's base)
 * is smooth. Profile kernels integrate this lobe by sampling where it is narrower than their
 * texels (profiles.c). */
vec3 vbi_bsdf_eval_microfacet(const vbi_bsdf *b, vec3 wo, vec3 wi);
int vbi_bsdf_sample_microfacet(const vbi_bsdf *b, vec3 wo, vec2 u, vec3 *wi, float *pdf);

/* The share of vbi_bsdf_pdf(b, wo, wi) that comes from samples reported as VBI_LOBE_DIFFUSE
 * (a Lambertian's whole pdf, a plastic's base lobe times its probability; 0 for the others). */
float vbi_bsdf_pdf_diffuse(const vbi_bsdf *b, vec3 wo, vec3 wi);

/* Union of the lobes this BSDF has. */
uint32_t vbi_bsdf_lobes(const vbi_bsdf *b);
/* True when every lobe is a delta (no point in next-event estimation). */
static inline int vbi_bsdf_is_delta(const vbi_bsdf *b)
{
    return b->type == VBNL_MATERIAL_MIRROR || b->type == VBNL_MATERIAL_DIELECTRIC;
}
/* Colour for the albedo AOV (the diffuse or specular tint). */
vec3 vbi_bsdf_albedo(const vbi_bsdf *b);
/* True for the dielectric: the integrator must keep the geometric orientation. */
static inline int vbi_bsdf_is_transmissive(const vbi_bsdf *b) { return b->type == VBNL_MATERIAL_DIELECTRIC; }

/* Fresnel reflectance of a dielectric interface for cos_i on the side given by its sign
 * (eta = n_inside / n_outside). */
float vbi_fresnel_dielectric(float cos_i, float eta);

/* What a smooth dielectric of ior 1 lets through straight at |cos| to its normal: its tint times
 * 1 - F, F its reflectance curve (vbnl_material_desc.coat_curve; 0 without one). */
vec3 vbi_bsdf_pass_weight(const vbi_bsdf *b, float cos);

#endif
