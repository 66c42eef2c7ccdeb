/* Materials: Lambert, GGX conductor with Kulla-Conty multiple-scattering compensation, rough
 * plastic (Lambert under a GGX coat with a dielectric Fresnel term or a reflectance curve),
 * perfect mirror, smooth dielectric.
 *
 * Conventions are those of bsdf.h: local shading frame, eval returns f * |cos theta_i|, sample
 * returns the weight f * |cos theta_i| / pdf. Every non-delta BSDF here is a sum of lobes
 * sampled by a one-sample mixture, so its pdf is the mixture pdf and eval / pdf is the weight
 * of whichever lobe produced the direction (Veach 1997, Section 9.2.4).
 *
 * Microfacet model: GGX with Smith height-correlated masking-shadowing (microfacet.h). Energy
 * lost by single scattering is restored with Kulla & Conty 2017 ("Revisiting Physically Based
 * Shading at Imageworks"): f_ms = (1 - E(mu_o)) (1 - E(mu_i)) / (pi (1 - E_avg)), a reciprocal
 * lobe whose albedo is exactly 1 - E(mu_o) for a white conductor, scaled for coloured Fresnel by
 * F_avg^2 E_avg / (1 - F_avg (1 - E_avg)). E and E_avg come from constant tables generated
 * offline (ggx_tables.c). */
#include "bsdf.h"

#include "microfacet.h"
#include "sampling.h"

/* ---- tables ----------------------------------------------------------------------------- */

static void table_cell(float x, int n, int *i, float *f)
{
    int k = (int)x;
    if (k > n - 2)
        k = n - 2;
    if (k < 0)
        k = 0;
    *i = k;
    *f = clampf(x - (float)k, 0.0f, 1.0f);
}

static float lerp2(const float *row0, const float *row1, int im, float fm, float fa)
{
    float a = row0[im] + (row0[im + 1] - row0[im]) * fm;
    float b = row1[im] + (row1[im + 1] - row1[im]) * fm;
    return a + (b - a) * fa;
}

/* The cells of a material's roughness (and coat IOR) in the tables: a BSDF's context computes
 * them once for its E(mu_o), E_avg and E(mu_i) (the same values as three separate lookups). */
typedef struct table_ai {
    int ia, ik;
    float fa, fk;
} table_ai;

static table_ai table_alpha(float alpha)
{
    table_ai t = {0, 0, 0.0f, 0.0f};
    table_cell(ggx_table_x_alpha(alpha), VBI_GGX_N_ALPHA, &t.ia, &t.fa);
    return t;
}

static table_ai table_alpha_ior(float alpha, float ior)
{
    table_ai t;
    table_cell(ggx_table_x_ior(ior), VBI_GGX_N_IOR, &t.ik, &t.fk);
    table_cell(ggx_table_x_alpha(alpha), VBI_GGX_N_ALPHA, &t.ia, &t.fa);
    return t;
}

/* Single-scattering albedo of a white GGX conductor and its cosine-weighted average. */
static float conductor_E(const table_ai *t, float mu)
{
    int im;
    float fm;
    table_cell(ggx_table_x_mu(mu), VBI_GGX_N_MU, &im, &fm);
    return lerp2(vbi_ggx_conductor_E[t->ia], vbi_ggx_conductor_E[t->ia + 1], im, fm, t->fa);
}

static float conductor_Eavg(const table_ai *t)
{
    const int ia = t->ia;
    return vbi_ggx_conductor_Eavg[ia] + (vbi_ggx_conductor_Eavg[ia + 1] - vbi_ggx_conductor_Eavg[ia]) * t->fa;
}

/* Albedo of the dielectric coat's specular reflection (trilinear in ior, alpha, mu). */
static float coat_E(const table_ai *t, float mu)
{
    int im;
    float fm;
    const int ik = t->ik, ia = t->ia;
    table_cell(ggx_table_x_mu(mu), VBI_GGX_N_MU, &im, &fm);
    float e0 = lerp2(vbi_ggx_coat_E[ik][ia], vbi_ggx_coat_E[ik][ia + 1], im, fm, t->fa);
    float e1 = lerp2(vbi_ggx_coat_E[ik + 1][ia], vbi_ggx_coat_E[ik + 1][ia + 1], im, fm, t->fa);
    return e0 + (e1 - e0) * t->fk;
}

static float coat_Eavg(const table_ai *t)
{
    const int ik = t->ik, ia = t->ia;
    const float fa = t->fa;
    const float *r0 = vbi_ggx_coat_Eavg[ik], *r1 = vbi_ggx_coat_Eavg[ik + 1];
    float e0 = r0[ia] + (r0[ia + 1] - r0[ia]) * fa;
    float e1 = r1[ia] + (r1[ia + 1] - r1[ia]) * fa;
    return e0 + (e1 - e0) * t->fk;
}

/* ---- Fresnel ------------------------------------------------------------------------------ */

float vbi_fresnel_dielectric(float cos_i, float eta) { return fresnel_dielectric_inline(cos_i, eta); }

/* Exact unpolarised reflectance of a conductor with complex IOR eta + i k against vacuum/air
 * (pbrt-v3 FrConductor, after Born & Wolf; derivation in S. Lagarde's 2013 "Memo on Fresnel
 * equations"). */
static float fresnel_conductor(float cos_i, float eta, float k)
{
    float c2 = sqr(clampf(cos_i, 0.0f, 1.0f));
    float s2 = 1.0f - c2;
    float eta2 = eta * eta, k2 = k * k;
    float t0 = eta2 - k2 - s2;
    float a2b2 = sqrtf(maxf(t0 * t0 + 4.0f * eta2 * k2, 0.0f));
    float t1 = a2b2 + c2;
    float a = safe_sqrtf(0.5f * (a2b2 + t0));
    float t2 = 2.0f * sqrtf(c2) * a;
    float rs = (t1 - t2) / maxf(t1 + t2, 1e-20f);
    float t3 = c2 * a2b2 + s2 * s2;
    float t4 = t2 * s2;
    float rp = rs * (t3 - t4) / maxf(t3 + t4, 1e-20f);
    return clampf(0.5f * (rp + rs), 0.0f, 1.0f);
}

static vec3 conductor_fresnel(const vbi_bsdf *b, float cos_i)
{
    if (b->use_ior)
        return v3(fresnel_conductor(cos_i, b->eta.x, b->k.x), fresnel_conductor(cos_i, b->eta.y, b->k.y),
                  fresnel_conductor(cos_i, b->eta.z, b->k.z));
    /* Schlick 1994: F0 + (1 - F0)(1 - cos)^5. */
    float m = 1.0f - clampf(cos_i, 0.0f, 1.0f);
    float m5 = (m * m) * (m * m) * m;
    return v3_add(b->color, v3_scale(v3_sub(v3s(1.0f), b->color), m5));
}

/* 8-point Gauss-Legendre nodes and weights on [0, 1]. */
static const float gl8_x[8] = {0.0198550718f, 0.1016667613f, 0.2372337950f, 0.4082826788f,
                               0.5917173212f, 0.7627662050f, 0.8983332387f, 0.9801449282f};
static const float gl8_w[8] = {0.0506142681f, 0.1111905172f, 0.1568533229f, 0.1813418917f,
                               0.1813418917f, 0.1568533229f, 0.1111905172f, 0.0506142681f};

/* Hemispherical average F_avg = 2 int_0^1 F(mu) mu dmu (Kulla & Conty 2017, Eq. for F_avg). For
 * Schlick it is F0 + (1 - F0) / 21 in closed form; for the exact conductor Fresnel it is
 * integrated with 8-point Gauss-Legendre on [0, 1] (the integrand is smooth: measured error below
 * 1e-6 against a 200k-point midpoint rule for gold and for eta, k ~ 3). */
static vec3 conductor_favg(const vbi_bsdf *b)
{
    if (!b->use_ior)
        return v3_add(b->color, v3_scale(v3_sub(v3s(1.0f), b->color), 1.0f / 21.0f));
    vec3 sum = v3s(0.0f);
    for (int i = 0; i < 8; ++i)
        sum = v3_fma(sum, conductor_fresnel(b, gl8_x[i]), 2.0f * gl8_x[i] * gl8_w[i]);
    return sum;
}

/* ---- material setup ----------------------------------------------------------------------- */

void vbi_bsdf_from_material(vbi_bsdf *b, const vbnl_material_desc *m)
{
    b->type = m->type;
    b->color = v3_min(v3_max(v3_load(m->base_color), v3s(0.0f)), v3s(1.0f));
    b->alpha = clampf(isfinite(m->alpha) ? m->alpha : 1.0f, VBI_GGX_ALPHA_MIN, 1.0f);
    b->ior = isfinite(m->ior) && m->ior >= 1.0f ? m->ior : 1.5f;
    b->use_ior = m->conductor_use_ior;
    b->eta = v3_max(v3_load(m->eta), v3s(1e-3f));
    b->k = v3_max(v3_load(m->k), v3s(0.0f));
    b->brilliance = m->type == VBNL_MATERIAL_BRILLIANCE ? clampf(m->brilliance, 1.0f, 1000.0f) : 1.0f;
    b->coat_curve = m->type == VBNL_MATERIAL_PLASTIC || m->type == VBNL_MATERIAL_DIELECTRIC ? m->coat_curve
                                                                                           : VBNL_COAT_DIELECTRIC;
    b->coat_min = v3_min(v3_max(v3_load(m->coat_min), v3s(0.0f)), v3s(1.0f));
    b->coat_max = v3_min(v3_max(v3_load(m->coat_max), v3s(0.0f)), v3s(1.0f));
    b->coat_falloff = clampf(isfinite(m->coat_falloff) ? m->coat_falloff : 1.0f, 1e-3f, 1000.0f);
    b->coat_metallic = clampf(isfinite(m->coat_metallic) ? m->coat_metallic : 0.0f, 0.0f, 1.0f);
    b->base_scale = clampf(isfinite(m->base_scale) ? m->base_scale : 1.0f, 0.0f, 1.0f);
    b->coat_conserve = m->coat_conserve != 0;
    b->bumped = 0;
    b->ns = v3(0.0f, 0.0f, 1.0f);
}

/* ---- Lambert ------------------------------------------------------------------------------ */

/* Inline in bsdf.h. */

/* ---- brilliance ---------------------------------------------------------------------------- */

/* POV-Ray's brilliance b makes diffuse light fall off as cos^b of the light's incidence (its
 * trace.cpp, ComputeDiffuseColour). A reciprocal, energy-conserving BRDF with that falloff for a
 * surface seen head-on: f = rho (b + 1) / (2 pi) (cos_i cos_o)^(b - 1). Its albedo seen from wo
 * is rho cos_o^(b - 1) <= rho (the integral of cos_i^b over the hemisphere is 2 pi / (b + 1)), so
 * it reflects rho head-on and less at grazing views; b = 1 is Lambert. Sampling: cos_i with
 * density (b + 1) / (2 pi) cos_i^b, cos_i = u^(1 / (b + 1)), weight rho cos_o^(b - 1). */
static float brilliance_norm(float b) { return (b + 1.0f) * VBI_INV_2PI; }

static vec3 brilliance_eval(const vbi_bsdf *b, vec3 wo, vec3 wi)
{
    if (wo.z <= 0.0f || wi.z <= 0.0f)
        return v3s(0.0f);
    const float e = b->brilliance - 1.0f;
    return v3_scale(b->color, brilliance_norm(b->brilliance) * powf(wi.z * wo.z, e) * wi.z);
}

static float brilliance_pdf(const vbi_bsdf *b, vec3 wo, vec3 wi)
{
    if (wo.z <= 0.0f || wi.z <= 0.0f)
        return 0.0f;
    return brilliance_norm(b->brilliance) * powf(wi.z, b->brilliance);
}

static int brilliance_sample(const vbi_bsdf *b, vec3 wo, vec2 u, vbi_bsdf_sample_rec *out)
{
    if (wo.z <= 0.0f)
        return 0;
    const float c = powf(1.0f - u.x, 1.0f / (b->brilliance + 1.0f)), s = safe_sqrtf(1.0f - c * c);
    const float phi = 2.0f * VBI_PI * u.y;
    vec3 wi = v3(s * cosf(phi), s * sinf(phi), c);
    float pdf = brilliance_pdf(b, wo, wi);
    if (!(wi.z > 0.0f) || !(pdf > 0.0f))
        return 0;
    out->wi = wi;
    out->pdf = pdf;
    out->weight = v3_scale(b->color, powf(wo.z, b->brilliance - 1.0f));
    out->lobe = VBI_LOBE_REFLECTION | VBI_LOBE_DIFFUSE;
    out->eta = 1.0f;
    return 1;
}

/* ---- GGX conductor ------------------------------------------------------------------------ */

/* Everything the conductor's eval, pdf and sample need about wo. */
typedef struct conductor_ctx {
    table_ai t;     /* the roughness's table cell */
    float e_o;      /* E(mu_o) */
    float e_avg;
    vec3 fms;       /* colour of the multiple-scattering lobe: F_avg^2 E_avg / (1 - F_avg (1 - E_avg)) */
    float p_cos;    /* probability of sampling the cosine (multiple-scattering) lobe */
} conductor_ctx;

static conductor_ctx conductor_setup(const vbi_bsdf *b, vec3 wo)
{
    conductor_ctx c;
    c.t = table_alpha(b->alpha);
    c.e_o = conductor_E(&c.t, wo.z);
    c.e_avg = conductor_Eavg(&c.t);
    vec3 favg = conductor_favg(b);
    /* Kulla & Conty 2017: the energy that leaves after k >= 1 extra bounces forms the geometric
     * series F_avg E_avg sum (F_avg (1 - E_avg))^k; with F = 1 the factor is exactly 1. */
    vec3 denom = v3_sub(v3s(1.0f), v3_scale(favg, 1.0f - c.e_avg));
    c.fms = v3_div(v3_scale(v3_mul(favg, favg), c.e_avg), v3_max(denom, v3s(1e-6f)));
    /* Choose the lobe in proportion to its (luminance) albedo at wo: single scattering ~ E(mu_o)
     * F_avg, multiple scattering exactly (1 - E(mu_o)) fms. */
    float ss = c.e_o * v3_luminance(favg);
    float ms = (1.0f - c.e_o) * v3_luminance(c.fms);
    c.p_cos = ss + ms > 0.0f ? clampf(ms / (ss + ms), 0.0f, 1.0f) : 0.0f;
    return c;
}

static inline __attribute__((always_inline)) vec3 conductor_eval_ctx(const vbi_bsdf *b, const conductor_ctx *c, vec3 wo, vec3 wi)
{
    vec3 h = v3_add(wo, wi);
    if (v3_len2(h) == 0.0f)
        return v3s(0.0f);
    h = v3_norm(h);
    /* Single scattering (Walter et al. 2007, Eq. 20) times cos theta_i:
     * F D G2 / (4 cos_o cos_i) * cos_i. */
    float dg = ggx_d(h, b->alpha) * ggx_g2(wo, wi, b->alpha) / (4.0f * wo.z);
    vec3 f = v3_scale(conductor_fresnel(b, v3_dot(wo, h)), dg);
    /* Multiple scattering (Kulla & Conty 2017), times cos theta_i. */
    float e_i = conductor_E(&c->t, wi.z);
    float ms = (1.0f - c->e_o) * (1.0f - e_i) / (VBI_PI * maxf(1.0f - c->e_avg, 1e-6f)) * wi.z;
    return v3_fma(f, c->fms, ms);
}

static inline __attribute__((always_inline)) float conductor_pdf_ctx(const vbi_bsdf *b, const conductor_ctx *c, vec3 wo, vec3 wi)
{
    vec3 h = v3_add(wo, wi);
    if (v3_len2(h) == 0.0f)
        return 0.0f;
    h = v3_norm(h);
    return (1.0f - c->p_cos) * ggx_pdf_vndf_reflect(wo, h, b->alpha) + c->p_cos * pdf_cosine_hemisphere(wi);
}

static vec3 conductor_eval(const vbi_bsdf *b, vec3 wo, vec3 wi)
{
    if (wo.z <= 0.0f || wi.z <= 0.0f)
        return v3s(0.0f);
    conductor_ctx c = conductor_setup(b, wo);
    return conductor_eval_ctx(b, &c, wo, wi);
}

static float conductor_pdf(const vbi_bsdf *b, vec3 wo, vec3 wi)
{
    if (wo.z <= 0.0f || wi.z <= 0.0f)
        return 0.0f;
    conductor_ctx c = conductor_setup(b, wo);
    return conductor_pdf_ctx(b, &c, wo, wi);
}

/* Two-lobe BSDFs choose the lobe with the first coordinate of the direction's 2D number and
 * reuse it for the direction (vbi_choose_reuse), so a stratified number stays stratified within
 * each lobe. */
static int conductor_sample(const vbi_bsdf *b, vec3 wo, vec2 u, vbi_bsdf_sample_rec *out)
{
    if (wo.z <= 0.0f)
        return 0;
    conductor_ctx c = conductor_setup(b, wo);
    vec3 wi;
    if (vbi_choose_reuse(&u.x, c.p_cos))
        wi = sample_cosine_hemisphere(u);
    else
        wi = reflect_about(wo, ggx_sample_vndf(wo, b->alpha, u));
    if (wi.z <= 0.0f)
        return 0;
    float pdf = conductor_pdf_ctx(b, &c, wo, wi);
    if (!(pdf > 0.0f))
        return 0;
    out->wi = wi;
    out->pdf = pdf;
    out->weight = v3_scale(conductor_eval_ctx(b, &c, wo, wi), 1.0f / pdf);
    out->lobe = VBI_LOBE_REFLECTION | VBI_LOBE_GLOSSY;
    out->eta = 1.0f;
    return 1;
}

/* ---- rough plastic ------------------------------------------------------------------------ */

/* Specular coat: GGX reflection with dielectric Fresnel (no multiple-scattering compensation:
 * the coat's own inter-reflection is a second-order effect at F ~ 4%). Base: Lambert scaled by
 * the energy the coat lets through in both directions,
 *   f_d = color / pi * (1 - E_s(mu_o)) (1 - E_s(mu_i)) / (1 - E_s,avg),
 * the same reciprocal construction as Kulla-Conty's f_ms (and as Kelemen & Szirmay-Kalos 2001's
 * coupled model): its albedo is color (1 - E_s(mu_o)), so the total is E_s + color (1 - E_s) <= 1
 * and exactly 1 for a white base. E_s is tabulated for ior in [1.05, 3] (ggx_tables.c): beyond
 * that range the table is clamped while the Fresnel term uses the true ior, which keeps
 * reciprocity but no longer guarantees the albedo bound exactly.
 *
 * A coat with a reflectance curve (VBNL_COAT_SCHLICK, VBNL_COAT_FRESNEL: POV-Ray's variable
 * reflection, vbnl/scene.h) uses the same GGX lobe with the curve F(c) in place of the Fresnel
 * term, evaluated per channel at c = wo.h (POV-Ray evaluates it at the angle of incidence of its
 * mirror ray, which is wo.h for the smooth coat). Its base, k = base_scale color, is either
 * added (POV-Ray's diffuse + reflection): f_d = k / pi g(mu_o) g(mu_i), g(mu) = min(1, (1 -
 * F(mu)) / k) per channel, which is k / pi wherever k + F <= 1 and less only at the angles where
 * the sum would exceed 1 (there the albedo is at most k g(mu_o) <= 1 - F(mu_o)); or coupled to
 * the curve as above with F(mu) in place of E_s(mu): f_d = k / pi (1 - F(mu_o)) (1 - F(mu_i)) /
 * (1 - F_avg), F_avg = 2 int F(mu) mu dmu, whose albedo is k (1 - F(mu_o)). Both are reciprocal;
 * the bound uses F(mu_o) for the coat's albedo, exact for the smooth coat (a rough coat of a curve
 * rising towards grazing reflects less than F(mu_o), its facets facing wo more squarely). */

/* POV-Ray's empirical curve of its `metallic` tint (its trace.cpp, ComputeMetallic): 0 seen
 * head-on, 1 at grazing, of x = theta / (pi / 2): 0.014567225 / (x - 1.12)^2 - 0.011612903. */
static float metallic_curve(float c)
{
    float x = acosf(clampf(c, 0.0f, 1.0f)) * (2.0f * VBI_INV_PI);
    return clampf(0.014567225f / sqr(x - 1.12f) - 0.011612903f, 0.0f, 1.0f);
}

/* The reflectance of a coat with a curve at cosine c, per channel. */
static vec3 coat_curve_F(const vbi_bsdf *b, float c)
{
    c = clampf(c, 0.0f, 1.0f);
    float w = b->coat_curve == VBNL_COAT_SCHLICK ? powf(1.0f - c, b->coat_falloff) : vbi_fresnel_dielectric(c, b->ior);
    vec3 F = v3_add(b->coat_min, v3_scale(v3_sub(b->coat_max, b->coat_min), w));
    if (b->coat_metallic > 0.0f) {
        float t = b->coat_metallic * (1.0f - metallic_curve(c));
        F = v3_mul(F, v3_add(v3s(1.0f), v3_scale(v3_sub(b->color, v3s(1.0f)), t)));
    }
    return v3_min(v3_max(F, v3s(0.0f)), v3s(1.0f));
}

vec3 vbi_bsdf_pass_weight(const vbi_bsdf *b, float cos)
{
    if (b->coat_curve == VBNL_COAT_DIELECTRIC)
        return b->color;
    return v3_mul(b->color, v3_sub(v3s(1.0f), coat_curve_F(b, fabsf(cos))));
}

/* F_avg = 2 int_0^1 F(mu) mu dmu by 16-point Gauss-Legendre on [0, 1] (two 8-point panels at
 * 0.5: the Fresnel curve bends sharply near grazing). */
static vec3 coat_curve_favg(const vbi_bsdf *b)
{
    vec3 sum = v3s(0.0f);
    for (int panel = 0; panel < 2; ++panel)
        for (int i = 0; i < 8; ++i) {
            float mu = 0.5f * ((float)panel + gl8_x[i]);
            sum = v3_fma(sum, coat_curve_F(b, mu), mu * gl8_w[i]); /* 2 mu w / 2 (the panel's width) */
        }
    return sum;
}

typedef struct plastic_ctx {
    table_ai t;     /* the roughness's (and the coat IOR's) table cells */
    float es_o;     /* dielectric coat: E_s(mu_o); curve: a white GGX coat's E(mu_o) */
    float es_avg;
    float p_spec;   /* probability of sampling the specular lobe */
    /* curve coats */
    vec3 f_o;       /* F(mu_o) */
    vec3 base;      /* additive: k g(mu_o); conserving: k (1 - F(mu_o)) / (1 - F_avg) */
} plastic_ctx;

/* The additive base's g(mu) = min(1, (1 - F(mu)) / k) per channel, for F = F(mu). */
static vec3 additive_g(vec3 k, vec3 F)
{
    vec3 room = v3_sub(v3s(1.0f), F);
    return v3(k.x > room.x ? room.x / k.x : 1.0f, k.y > room.y ? room.y / k.y : 1.0f,
              k.z > room.z ? room.z / k.z : 1.0f);
}

static plastic_ctx plastic_setup(const vbi_bsdf *b, vec3 wo)
{
    plastic_ctx c;
    float spec, diff;
    if (b->coat_curve == VBNL_COAT_DIELECTRIC) {
        c.t = table_alpha_ior(b->alpha, b->ior);
        c.es_o = coat_E(&c.t, wo.z);
        c.es_avg = coat_Eavg(&c.t);
        c.f_o = c.base = v3s(0.0f);
        /* Lobe albedos at wo: specular E_s(mu_o), diffuse lum(color) (1 - E_s(mu_o)). */
        spec = c.es_o;
        diff = v3_luminance(b->color) * (1.0f - c.es_o);
    } else {
        c.t = table_alpha(b->alpha);
        c.es_o = conductor_E(&c.t, wo.z);
        c.es_avg = 0.0f;
        c.f_o = coat_curve_F(b, wo.z);
        vec3 kd = v3_scale(b->color, b->base_scale);
        if (b->coat_conserve) {
            vec3 favg = coat_curve_favg(b);
            c.base = v3_div(v3_mul(kd, v3_sub(v3s(1.0f), c.f_o)), v3_max(v3_sub(v3s(1.0f), favg), v3s(1e-6f)));
            diff = v3_luminance(v3_mul(kd, v3_sub(v3s(1.0f), c.f_o)));
        } else {
            c.base = v3_mul(kd, additive_g(kd, c.f_o));
            diff = v3_luminance(c.base);
        }
        spec = c.es_o * v3_luminance(c.f_o);
    }
    c.p_spec = spec + diff > 0.0f ? clampf(spec / (spec + diff), 0.0f, 1.0f) : 1.0f;
    return c;
}

static inline __attribute__((always_inline)) vec3 plastic_eval_ctx(const vbi_bsdf *b, const plastic_ctx *c, vec3 wo, vec3 wi)
{
    vec3 h = v3_norm(v3_add(wo, wi));
    float dg = ggx_d(h, b->alpha) * ggx_g2(wo, wi, b->alpha) / (4.0f * wo.z);
    if (b->coat_curve != VBNL_COAT_DIELECTRIC) {
        vec3 spec = v3_scale(coat_curve_F(b, v3_dot(wo, h)), dg);
        vec3 f_i = coat_curve_F(b, wi.z);
        vec3 diff = b->coat_conserve ? v3_mul(c->base, v3_sub(v3s(1.0f), f_i))
                                     : v3_mul(c->base, additive_g(v3_scale(b->color, b->base_scale), f_i));
        return v3_fma(spec, diff, VBI_INV_PI * wi.z);
    }
    float spec = vbi_fresnel_dielectric(v3_dot(wo, h), b->ior) * dg;
    float es_i = coat_E(&c->t, wi.z);
    float diff = (1.0f - c->es_o) * (1.0f - es_i) / maxf(1.0f - c->es_avg, 1e-6f) * VBI_INV_PI * wi.z;
    return v3_add(v3s(spec), v3_scale(b->color, diff));
}

static inline __attribute__((always_inline)) float plastic_pdf_ctx(const vbi_bsdf *b, const plastic_ctx *c, vec3 wo, vec3 wi)
{
    vec3 h = v3_norm(v3_add(wo, wi));
    return c->p_spec * ggx_pdf_vndf_reflect(wo, h, b->alpha) + (1.0f - c->p_spec) * pdf_cosine_hemisphere(wi);
}

static vec3 plastic_eval(const vbi_bsdf *b, vec3 wo, vec3 wi)
{
    if (wo.z <= 0.0f || wi.z <= 0.0f)
        return v3s(0.0f);
    plastic_ctx c = plastic_setup(b, wo);
    return plastic_eval_ctx(b, &c, wo, wi);
}

static float plastic_pdf(const vbi_bsdf *b, vec3 wo, vec3 wi)
{
    if (wo.z <= 0.0f || wi.z <= 0.0f)
        return 0.0f;
    plastic_ctx c = plastic_setup(b, wo);
    return plastic_pdf_ctx(b, &c, wo, wi);
}

static int plastic_sample(const vbi_bsdf *b, vec3 wo, vec2 u, vbi_bsdf_sample_rec *out)
{
    if (wo.z <= 0.0f)
        return 0;
    plastic_ctx c = plastic_setup(b, wo);
    vec3 wi;
    uint32_t lobe;
    if (vbi_choose_reuse(&u.x, c.p_spec)) {
        wi = reflect_about(wo, ggx_sample_vndf(wo, b->alpha, u));
        lobe = VBI_LOBE_REFLECTION | VBI_LOBE_GLOSSY;
    } else {
        wi = sample_cosine_hemisphere(u);
        lobe = VBI_LOBE_REFLECTION | VBI_LOBE_DIFFUSE;
    }
    if (wi.z <= 0.0f)
        return 0;
    float pdf = plastic_pdf_ctx(b, &c, wo, wi);
    if (!(pdf > 0.0f))
        return 0;
    out->wi = wi;
    out->pdf = pdf;
    out->weight = v3_scale(plastic_eval_ctx(b, &c, wo, wi), 1.0f / pdf);
    out->lobe = lobe;
    out->eta = 1.0f;
    return 1;
}

/* ---- delta BSDFs -------------------------------------------------------------------------- */

static int mirror_sample(const vbi_bsdf *b, vec3 wo, vbi_bsdf_sample_rec *out)
{
    if (wo.z <= 0.0f)
        return 0;
    out->wi = reflect_z(wo);
    out->weight = b->color;
    out->pdf = 1.0f;
    out->lobe = VBI_LOBE_REFLECTION | VBI_LOBE_SPECULAR;
    out->eta = 1.0f;
    return 1;
}

/* The refracted direction of wo (either side) for eta = n_t / n_i; 0 at total internal reflection. */
static int refract_z(vec3 wo, float eta, vec3 *wt)
{
    float sin2_t = (1.0f - wo.z * wo.z) / (eta * eta);
    if (sin2_t >= 1.0f)
        return 0;
    float cos_t = sqrtf(1.0f - sin2_t);
    *wt = v3(-wo.x / eta, -wo.y / eta, wo.z > 0.0f ? -cos_t : cos_t);
    return 1;
}

/* A smooth dielectric whose reflectance is a coat curve (vbnl/scene.h) instead of Fresnel's: POV-
 * Ray's variable reflection on a transparent surface, which reflects F(cos) of the light and lets
 * (1 - F) through (its conserve_energy; reference "Conserve Energy for Reflection"), from either
 * side, and reflects everything at total internal reflection. F is RGB: the lobe is chosen with
 * the probability avg(F) and each weight divides by its own probability. */
static int dielectric_curve_sample(const vbi_bsdf *b, vec3 wo, float u_lobe, vbi_bsdf_sample_rec *out)
{
    const float eta = wo.z > 0.0f ? b->ior : 1.0f / b->ior;
    vec3 wt;
    const int tir = !refract_z(wo, eta, &wt);
    vec3 F = tir ? v3s(1.0f) : coat_curve_F(b, fabsf(wo.z));
    float p = tir ? 1.0f : clampf(v3_avg(F), 0.0f, 1.0f);
    if (p > 0.0f && p < 1.0f)
        p = clampf(p, 1e-3f, 1.0f - 1e-3f); /* a coloured F may have a zero average in one lobe */
    if (u_lobe < p) {
        out->wi = reflect_z(wo);
        out->weight = v3_scale(F, 1.0f / p);
        out->pdf = p;
        out->lobe = VBI_LOBE_REFLECTION | VBI_LOBE_SPECULAR;
        out->eta = 1.0f;
        return 1;
    }
    out->wi = wt;
    out->weight = v3_scale(v3_mul(b->color, v3_sub(v3s(1.0f), F)), 1.0f / ((1.0f - p) * eta * eta));
    out->pdf = 1.0f - p;
    out->lobe = VBI_LOBE_TRANSMISSION | VBI_LOBE_SPECULAR;
    out->eta = eta;
    return 1;
}

/* Smooth dielectric (pbrt-v4 DielectricBxDF, specular case): reflect with probability F,
 * refract otherwise, so both weights are independent of F. The tint multiplies transmission
 * only: it stands for absorption inside the material, which light reflected at the surface
 * never enters. Refracted radiance is scaled by 1 / eta^2 (Veach 1997, Section 5.2), eta =
 * n_t / n_i of the crossing. */
static int dielectric_sample(const vbi_bsdf *b, vec3 wo, float u_lobe, vbi_bsdf_sample_rec *out)
{
    float cos_o = wo.z;
    if (cos_o == 0.0f)
        return 0;
    if (b->coat_curve != VBNL_COAT_DIELECTRIC)
        return dielectric_curve_sample(b, wo, u_lobe, out);
    float F = vbi_fresnel_dielectric(cos_o, b->ior);
    if (u_lobe < F) {
        out->wi = reflect_z(wo);
        out->weight = v3s(1.0f);
        out->pdf = F;
        out->lobe = VBI_LOBE_REFLECTION | VBI_LOBE_SPECULAR;
        out->eta = 1.0f;
        return 1;
    }
    float eta = cos_o > 0.0f ? b->ior : 1.0f / b->ior; /* n_t / n_i */
    float sin2_t = (1.0f - cos_o * cos_o) / (eta * eta);
    if (sin2_t >= 1.0f) /* cannot happen when F = 1 at TIR, kept for rounding */
        return 0;
    float cos_t = sqrtf(1.0f - sin2_t);
    out->wi = v3(-wo.x / eta, -wo.y / eta, cos_o > 0.0f ? -cos_t : cos_t);
    out->weight = v3_scale(b->color, 1.0f / (eta * eta));
    out->pdf = 1.0f - F;
    out->lobe = VBI_LOBE_TRANSMISSION | VBI_LOBE_SPECULAR;
    out->eta = eta;
    return 1;
}

/* ---- dispatch ----------------------------------------------------------------------------- */

vec3 vbi_bsdf_eval_other(const vbi_bsdf *b, vec3 wo, vec3 wi)
{
    switch (b->type) {
    case VBNL_MATERIAL_LAMBERT:
        return vbi_bsdf_eval(b, wo, wi);
    case VBNL_MATERIAL_CONDUCTOR:
        return conductor_eval(b, wo, wi);
    case VBNL_MATERIAL_PLASTIC:
        return plastic_eval(b, wo, wi);
    case VBNL_MATERIAL_BRILLIANCE:
        return brilliance_eval(b, wo, wi);
    default: /* delta lobes only */
        return v3s(0.0f);
    }
}

float vbi_bsdf_pdf_other(const vbi_bsdf *b, vec3 wo, vec3 wi)
{
    switch (b->type) {
    case VBNL_MATERIAL_LAMBERT:
        return vbi_bsdf_pdf(b, wo, wi);
    case VBNL_MATERIAL_CONDUCTOR:
        return conductor_pdf(b, wo, wi);
    case VBNL_MATERIAL_PLASTIC:
        return plastic_pdf(b, wo, wi);
    case VBNL_MATERIAL_BRILLIANCE:
        return brilliance_pdf(b, wo, wi);
    default:
        return 0.0f;
    }
}

int vbi_bsdf_sample_other(const vbi_bsdf *b, vec3 wo, vec2 u, vbi_bsdf_sample_rec *out)
{
    switch (b->type) {
    case VBNL_MATERIAL_LAMBERT:
        return vbi_bsdf_sample(b, wo, u, out);
    case VBNL_MATERIAL_CONDUCTOR:
        return conductor_sample(b, wo, u, out);
    case VBNL_MATERIAL_PLASTIC:
        return plastic_sample(b, wo, u, out);
    case VBNL_MATERIAL_MIRROR:
        return mirror_sample(b, wo, out);
    case VBNL_MATERIAL_DIELECTRIC:
        return dielectric_sample(b, wo, u.x, out);
    case VBNL_MATERIAL_BRILLIANCE:
        return brilliance_sample(b, wo, u, out);
    }
    return 0;
}

/* ---- the microfacet lobe alone (bsdf.h) ---------------------------------------------------- */

vec3 vbi_bsdf_eval_microfacet(const vbi_bsdf *b, vec3 wo, vec3 wi)
{
    if ((b->type != VBNL_MATERIAL_CONDUCTOR && b->type != VBNL_MATERIAL_PLASTIC) || wo.z <= 0.0f || wi.z <= 0.0f)
        return v3s(0.0f);
    vec3 h = v3_add(wo, wi);
    if (v3_len2(h) == 0.0f)
        return v3s(0.0f);
    h = v3_norm(h);
    float dg = ggx_d(h, b->alpha) * ggx_g2(wo, wi, b->alpha) / (4.0f * wo.z);
    if (b->type == VBNL_MATERIAL_CONDUCTOR)
        return v3_scale(conductor_fresnel(b, v3_dot(wo, h)), dg);
    if (b->coat_curve != VBNL_COAT_DIELECTRIC)
        return v3_scale(coat_curve_F(b, v3_dot(wo, h)), dg);
    return v3s(vbi_fresnel_dielectric(v3_dot(wo, h), b->ior) * dg);
}

int vbi_bsdf_sample_microfacet(const vbi_bsdf *b, vec3 wo, vec2 u, vec3 *wi, float *pdf)
{
    if ((b->type != VBNL_MATERIAL_CONDUCTOR && b->type != VBNL_MATERIAL_PLASTIC) || wo.z <= 0.0f)
        return 0;
    vec3 h = ggx_sample_vndf(wo, b->alpha, u);
    *wi = reflect_about(wo, h);
    *pdf = ggx_pdf_vndf_reflect(wo, h, b->alpha);
    return wi->z > 0.0f && *pdf > 0.0f;
}

float vbi_bsdf_pdf_diffuse(const vbi_bsdf *b, vec3 wo, vec3 wi)
{
    if (wo.z <= 0.0f || wi.z <= 0.0f)
        return 0.0f;
    if (b->type == VBNL_MATERIAL_LAMBERT)
        return pdf_cosine_hemisphere(wi);
    if (b->type == VBNL_MATERIAL_BRILLIANCE)
        return brilliance_pdf(b, wo, wi);
    if (b->type != VBNL_MATERIAL_PLASTIC)
        return 0.0f;
    plastic_ctx c = plastic_setup(b, wo);
    return (1.0f - c.p_spec) * pdf_cosine_hemisphere(wi);
}

uint32_t vbi_bsdf_lobes(const vbi_bsdf *b)
{
    switch (b->type) {
    case VBNL_MATERIAL_LAMBERT:
    case VBNL_MATERIAL_BRILLIANCE:
        return VBI_LOBE_REFLECTION | VBI_LOBE_DIFFUSE;
    case VBNL_MATERIAL_CONDUCTOR:
        return VBI_LOBE_REFLECTION | VBI_LOBE_GLOSSY;
    case VBNL_MATERIAL_PLASTIC:
        return VBI_LOBE_REFLECTION | VBI_LOBE_GLOSSY | VBI_LOBE_DIFFUSE;
    case VBNL_MATERIAL_MIRROR:
        return VBI_LOBE_REFLECTION | VBI_LOBE_SPECULAR;
    case VBNL_MATERIAL_DIELECTRIC:
        return VBI_LOBE_REFLECTION | VBI_LOBE_TRANSMISSION | VBI_LOBE_SPECULAR;
    }
    return 0;
}

vec3 vbi_bsdf_albedo(const vbi_bsdf *b)
{
    if (b->type == VBNL_MATERIAL_CONDUCTOR)
        return conductor_fresnel(b, 1.0f); /* F0 */
    return b->color;
}
