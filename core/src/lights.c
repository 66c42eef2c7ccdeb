/* Light sources: incident-light sampling (next-event estimation), emission sampling (light
 * tracing) and power (light selection). Maths follows pbrt-v4 chapter 12 unless noted.
 *
 * Fields the scene builder must fill consistently (nothing here recomputes them per call):
 *   rect/triangle: `n` = unit normal of the emitting side, `area` = |e0 x e1| (rect) or half of it
 *   (triangle); sphere: `area` = 4 pi r^2; spot/directional: `n` unit; directional/env:
 *   world_center/world_radius = the scene's bounding sphere.
 *
 * Sidedness. Rect and triangle lights emit from the side `n` points to (both when two_sided);
 * vbi_light_Le uses the light's own `n` for them rather than the caller's hit normal, so a
 * mesh whose winding disagrees with its emitting side cannot flip the emission. A sphere emits
 * outward; two_sided adds inward emission, which is what a closed "furnace" sphere around the
 * camera needs. For spheres vbi_light_Le takes the caller's outward normal at the hit.
 *
 * pdf_li returns the density with which sample_li would produce the direction even when the
 * light is seen from its non-emitting side (as pbrt does): Le is zero there, so MIS weights for
 * such paths never matter, and sample_li and pdf_li stay one consistent pair. */
#include "lights.h"

#include <math.h>
#include <string.h>

#include "environment.h"
#include "sampling.h"

/* ---- spot falloff ---------------------------------------------------------------------------- */

static float spot_smoothstep(float x, float a, float b)
{
    if (a == b)
        return x < a ? 0.0f : 1.0f;
    float t = clampf((x - a) / (b - a), 0.0f, 1.0f);
    return t * t * (3.0f - 2.0f * t);
}

/* Intensity scale along a direction whose cosine to the axis is cos_t: pbrt-v4's smoothstep
 * between cos_outer and cos_inner, times cos^exponent (POV-Ray "tightness") when exponent > 0.
 * A cos_inner below cos_outer is treated as a hard edge at cos_outer. */
static float spot_falloff(const vbi_light *l, float cos_t)
{
    float co = l->cos_outer, ci = maxf(l->cos_inner, l->cos_outer);
    if (cos_t < co)
        return 0.0f;
    float f = spot_smoothstep(cos_t, co, ci);
    if (l->exponent > 0.0f)
        f *= powf(maxf(cos_t, 0.0f), l->exponent);
    return f;
}

/* Integral of the falloff over the sphere divided by 2 pi, i.e. int_{-1}^{1} falloff(c) dc.
 * The inner cone is done in closed form; the transition band, a cubic times c^exponent, with a
 * fixed composite 8-point Gauss-Legendre rule (exact for exponent 0 and integer exponents up to
 * 12, where the integrand is a polynomial of degree <= 15; far below 1e-6 relative otherwise), so vbi_light_power stays a cheap pure
 * function with no per-light precomputation. */
static double spot_falloff_integral(const vbi_light *l)
{
    static const double gl_x[4] = {0.1834346424956498, 0.5255324099163290, 0.7966664774136267,
                                   0.9602898564975363};
    static const double gl_w[4] = {0.3626837833783620, 0.3137066959918857, 0.2223810344533745,
                                   0.1012285362903763};
    double co = clampf(l->cos_outer, -1.0f, 1.0f);
    double ci = fmax(clampf(l->cos_inner, -1.0f, 1.0f), co);
    double e = l->exponent > 0.0f ? (double)l->exponent : 0.0;

    double inner = e > 0.0 ? (1.0 - pow(fmax(ci, 0.0), e + 1.0)) / (e + 1.0) : 1.0 - ci;

    /* cos^e is clamped to 0 below the horizon, so the band starts at 0 at the earliest then. */
    double lo = e > 0.0 ? fmax(co, 0.0) : co;
    double band = 0.0;
    if (ci > lo) {
        enum { PANELS = 4 };
        double h = (ci - lo) / PANELS;
        for (int k = 0; k < PANELS; ++k) {
            double mid = lo + (k + 0.5) * h;
            for (int i = 0; i < 8; ++i) {
                double c = mid + (i < 4 ? -gl_x[i] : gl_x[i - 4]) * 0.5 * h;
                double t = (c - co) / (ci - co);
                double f = t * t * (3.0 - 2.0 * t);
                if (e > 0.0)
                    f *= pow(fmax(c, 0.0), e);
                band += gl_w[i & 3] * 0.5 * h * f;
            }
        }
    }
    return inner + band;
}

/* ---- sphere cone geometry -------------------------------------------------------------------- */

/* 1 - cos(theta_max) of the cone subtended by a sphere with sin^2(theta_max) = sin2_max. Below
 * 1.5 degrees the direct form loses every digit in float, so use the Taylor expansion (pbrt-v4
 * Sphere::Sample). sample_li and pdf_li share this function so their pdfs agree bit for bit. */
static float sphere_one_minus_cos_max(float sin2_max)
{
    if (sin2_max < 0.00068523f)
        return 0.5f * sin2_max;
    return 1.0f - safe_sqrtf(1.0f - sin2_max);
}

/* ---- incident light ---------------------------------------------------------------------------- */

/* Fills the parts of a delta-light sample common to point and spot lights. */
static int sample_li_positional(const vbi_light *l, vec3 ref, float scale, vbi_light_li_sample *out)
{
    vec3 d = v3_sub(l->p, ref);
    float dist2 = v3_len2(d);
    if (!(dist2 > 0.0f) || !(scale > 0.0f))
        return 0;
    float dist = sqrtf(dist2);
    out->wi = v3_scale(d, 1.0f / dist);
    out->dist = dist;
    out->p = l->p;
    out->n = v3_neg(out->wi);
    out->Li = v3_scale(l->L, scale / dist2);
    out->pdf = 1.0f;
    out->is_delta = 1;
    return 1;
}

/* Reference points on the surface (shading points of the sphere itself, whose positions carry
 * rounding) count as inside: from outside they see none of the sphere, from inside they see all
 * of it, and the cone construction degenerates there. sample_li and pdf_li must agree. */
static int sphere_ref_inside(float dc2, float r) { return dc2 <= r * r * (1.0f + 1e-3f); }

static int sample_li_sphere(const vbi_light *l, vec3 ref, vec2 u, vbi_light_li_sample *out)
{
    vec3 c = l->p;
    float r = l->radius;
    vec3 dc_vec = v3_sub(c, ref);
    float dc2 = v3_len2(dc_vec);
    if (!(r > 0.0f))
        return 0;
    vec3 q, nq;
    if (sphere_ref_inside(dc2, r)) {
        /* Inside: uniform area sampling; only inward emission is visible from here. */
        if (!l->two_sided)
            return 0;
        nq = sample_uniform_sphere(u);
        q = v3_fma(c, nq, r);
        vec3 d = v3_sub(q, ref);
        float dist2 = v3_len2(d);
        if (!(dist2 > 0.0f))
            return 0;
        float dist = sqrtf(dist2);
        vec3 wi = v3_scale(d, 1.0f / dist);
        float cos_l = v3_absdot(nq, wi);
        if (cos_l == 0.0f)
            return 0;
        out->wi = wi;
        out->dist = dist;
        out->p = q;
        out->n = nq;
        out->Li = l->L;
        out->pdf = dist2 / (cos_l * l->area);
        out->is_delta = 0;
        return isfinite(out->pdf);
    }

    /* Outside: uniform sampling of the cone of directions that see the sphere (pbrt-v3
     * Sphere::Sample(ref, u), with pbrt-v4's float-robust form). The sampled direction is
     * mapped to the point on the sphere it hits first, found through the angle alpha at the
     * centre instead of a ray-sphere intersection. Only outward-facing points are visible, so
     * one- and two-sided spheres look the same from outside. */
    float dc = sqrtf(dc2);
    vec3 wc = v3_scale(dc_vec, 1.0f / dc);
    float sin2_max = r * r / dc2;
    float sin_max = sqrtf(sin2_max);
    float one_minus_cos_max = sphere_one_minus_cos_max(sin2_max);
    float cos_t, sin2_t;
    if (sin2_max < 0.00068523f) {
        sin2_t = sin2_max * u.x;
        cos_t = sqrtf(1.0f - sin2_t);
    } else {
        cos_t = 1.0f - u.x * one_minus_cos_max;
        sin2_t = 1.0f - cos_t * cos_t;
    }
    float cos_alpha = sin2_t / sin_max + cos_t * safe_sqrtf(1.0f - sin2_t / sin2_max);
    float sin_alpha = safe_sqrtf(1.0f - cos_alpha * cos_alpha);
    float phi = 2.0f * VBI_PI * u.y;
    frame f = frame_from_normal(wc);
    nq = frame_to_world(&f, v3(-sin_alpha * cosf(phi), -sin_alpha * sinf(phi), -cos_alpha));
    q = v3_fma(c, nq, r);
    vec3 d = v3_sub(q, ref);
    float dist = v3_len(d);
    if (!(dist > 0.0f))
        return 0;
    out->wi = v3_scale(d, 1.0f / dist);
    out->dist = dist;
    out->p = q;
    out->n = nq;
    out->Li = l->L;
    out->pdf = 1.0f / (2.0f * VBI_PI * one_minus_cos_max);
    out->is_delta = 0;
    return isfinite(out->pdf);
}

/* Distant lights: a shadow ray must reach past the scene, so report a point two world radii
 * away (outside the bounding sphere from any point inside it). */
static void fill_distant(const vbi_light *l, vec3 ref, vec3 wi, vbi_light_li_sample *out)
{
    out->wi = wi;
    out->dist = INFINITY;
    out->p = v3_fma(ref, wi, 2.0f * maxf(l->world_radius, 1.0f));
    out->n = v3_neg(wi);
    out->Li = l->L;
}

int vbi_light_sample_li_other(const vbi_light *l, vec3 ref, vec2 u, vbi_light_li_sample *out)
{
    memset(out, 0, sizeof(*out));
    switch (l->type) {
    case VBI_LIGHT_RECT:
    case VBI_LIGHT_TRIANGLE:
        return vbi_light_sample_li(l, ref, u, out);
    case VBI_LIGHT_POINT:
        return sample_li_positional(l, ref, 1.0f, out);
    case VBI_LIGHT_SPOT: {
        vec3 w_out = v3_norm(v3_sub(ref, l->p)); /* direction the light leaves toward ref */
        return sample_li_positional(l, ref, spot_falloff(l, v3_dot(l->n, w_out)), out);
    }
    case VBI_LIGHT_SPHERE:
        return sample_li_sphere(l, ref, u, out);
    case VBI_LIGHT_DIRECTIONAL:
        fill_distant(l, ref, v3_neg(l->n), out);
        out->pdf = 1.0f;
        out->is_delta = 1;
        return !v3_is_black(l->L);
    case VBI_LIGHT_ENV:
        if (l->env) {
            /* the table's direction and density, the exact pattern's radiance */
            vec3 d;
            float pdf;
            if (!vbi_env_sample(l->env, u, &d, &pdf))
                return 0;
            fill_distant(l, ref, d, out);
            out->Li = vbi_env_radiance(l->env, d);
            out->pdf = pdf;
            return !v3_is_black(out->Li);
        }
        fill_distant(l, ref, sample_uniform_sphere(u), out);
        out->pdf = pdf_uniform_sphere();
        out->is_delta = 0;
        return !v3_is_black(l->L);
    }
    return 0;
}

float vbi_light_pdf_li_other(const vbi_light *l, vec3 ref, vec3 p_light, vec3 n_light, vec3 wi)
{
    switch (l->type) {
    case VBI_LIGHT_POINT:
    case VBI_LIGHT_SPOT:
    case VBI_LIGHT_DIRECTIONAL:
        return 0.0f;
    case VBI_LIGHT_RECT:
    case VBI_LIGHT_TRIANGLE:
        return vbi_light_pdf_li(l, ref, p_light, n_light, wi);
    case VBI_LIGHT_SPHERE: {
        vec3 dc_vec = v3_sub(l->p, ref);
        float dc2 = v3_len2(dc_vec);
        float r = l->radius;
        if (!(r > 0.0f))
            return 0.0f;
        if (sphere_ref_inside(dc2, r)) {
            /* Exact normal from the geometry; n_light only matters for its orientation. */
            vec3 nq = v3_scale(v3_sub(p_light, l->p), 1.0f / r);
            float cos_l = v3_absdot(nq, wi);
            float dist2 = v3_len2(v3_sub(p_light, ref));
            if (cos_l == 0.0f || !(l->area > 0.0f))
                return 0.0f;
            return dist2 / (cos_l * l->area);
        }
        /* Zero outside the cone so the pdf is a true density over all directions. The test uses
         * sin^2 (from a cross product) because cosines near 1 are too coarse in float; the 1e-3
         * slack keeps grazing hits, whose wi carries rounding, inside the cone. */
        float sin2_max = r * r / dc2;
        vec3 x = v3_cross(wi, dc_vec);
        if (v3_dot(wi, dc_vec) <= 0.0f || v3_len2(x) > sin2_max * dc2 * 1.001f)
            return 0.0f;
        return 1.0f / (2.0f * VBI_PI * sphere_one_minus_cos_max(sin2_max));
    }
    case VBI_LIGHT_ENV:
        return l->env ? vbi_env_pdf(l->env, wi) : pdf_uniform_sphere();
    }
    (void)n_light;
    return 0.0f;
}

vec3 vbi_light_Le_other(const vbi_light *l, vec3 n_light, vec3 w)
{
    switch (l->type) {
    case VBI_LIGHT_RECT:
    case VBI_LIGHT_TRIANGLE:
        return vbi_light_Le(l, n_light, w);
    case VBI_LIGHT_SPHERE:
        return (l->two_sided || v3_dot(n_light, w) > 0.0f) ? l->L : v3s(0.0f);
    case VBI_LIGHT_ENV:
        /* w leaves the light toward the receiver: the sky lies along -w */
        return l->env ? vbi_env_radiance(l->env, v3_neg(w)) : l->L;
    default:
        return v3s(0.0f); /* delta lights cannot be hit */
    }
}

vec3 vbi_light_power(const vbi_light *l)
{
    float sides = l->two_sided ? 2.0f : 1.0f;
    switch (l->type) {
    case VBI_LIGHT_POINT:
        return v3_scale(l->L, 4.0f * VBI_PI);
    case VBI_LIGHT_SPOT:
        return v3_scale(l->L, (float)(2.0 * M_PI * spot_falloff_integral(l)));
    case VBI_LIGHT_RECT:
    case VBI_LIGHT_TRIANGLE:
    case VBI_LIGHT_SPHERE:
        /* Lambertian emitter: pi L per unit area and side. */
        return v3_scale(l->L, sides * VBI_PI * l->area);
    case VBI_LIGHT_DIRECTIONAL:
        /* Irradiance through the scene's cross-section (pbrt-v4 DistantLight::Phi). */
        return v3_scale(l->L, VBI_PI * sqr(l->world_radius));
    case VBI_LIGHT_ENV:
        /* Radiance from every direction through the cross-section (pbrt-v4 UniformInfiniteLight). */
        return v3_scale(l->L, 4.0f * VBI_PI * VBI_PI * sqr(l->world_radius));
    }
    return v3s(0.0f);
}

/* ---- emission ------------------------------------------------------------------------------- */

/* Cosine-weighted direction about the emitting side of a surface with unit normal n. A
 * two-sided emitter picks each side with probability 1/2 (reusing u.x), which halves pdf_dir. */
static void sample_le_lambert(const vbi_light *l, vec3 q, vec3 n, vec2 u, vbi_light_le_sample *out)
{
    float side_pdf = 1.0f;
    if (l->two_sided) {
        side_pdf = 0.5f;
        if (u.x < 0.5f) {
            u.x = minf(u.x * 2.0f, VBI_ONE_MINUS_EPS);
        } else {
            u.x = minf(u.x * 2.0f - 1.0f, VBI_ONE_MINUS_EPS);
            n = v3_neg(n);
        }
    }
    vec3 wl = sample_cosine_hemisphere(u);
    frame f = frame_from_normal(n);
    out->p = q;
    out->n = n; /* normal of the side that emits this ray */
    out->dir = frame_to_world(&f, wl);
    out->Le = l->L;
    out->pdf_pos = 1.0f / l->area;
    out->pdf_dir = side_pdf * pdf_cosine_hemisphere(wl);
    out->cos_at_light = wl.z;
}

/* A ray of a distant light travelling along d: its origin is uniform on the disk of radius R
 * perpendicular to d, one radius behind the scene's bounding sphere, so the rays cover the
 * sphere's cross-section exactly once (pbrt-v4 DistantLight::SampleLe). */
static int sample_le_distant(const vbi_light *l, vec3 d, vec2 u_pos, vbi_light_le_sample *out)
{
    float R = l->world_radius;
    if (!(R > 0.0f))
        return 0;
    frame f = frame_from_normal(d);
    vec2 dk = sample_concentric_disk(u_pos);
    vec3 o = v3_fma(l->world_center, d, -R);
    o = v3_fma(o, f.s, dk.x * R);
    out->p = v3_fma(o, f.t, dk.y * R);
    out->n = d;
    out->dir = d;
    out->Le = l->L;
    out->pdf_pos = 1.0f / (VBI_PI * R * R);
    out->cos_at_light = 1.0f;
    return 1;
}

int vbi_light_sample_le(const vbi_light *l, vec2 u_pos, vec2 u_dir, vbi_light_le_sample *out)
{
    memset(out, 0, sizeof(*out));
    switch (l->type) {
    case VBI_LIGHT_POINT:
        out->p = l->p;
        out->dir = sample_uniform_sphere(u_dir);
        out->n = out->dir;
        out->Le = l->L;
        out->pdf_pos = 1.0f;
        out->pdf_dir = pdf_uniform_sphere();
        out->cos_at_light = 1.0f;
        return 1;
    case VBI_LIGHT_SPOT: {
        /* Uniform over the outer cone: the falloff is smooth and bounded, so matching it is
         * not worth a non-invertible warp. */
        float co = clampf(l->cos_outer, -1.0f, 1.0f);
        if (co >= 1.0f)
            return 0;
        frame f = frame_from_normal(l->n);
        vec3 wl = sample_uniform_cone(u_dir, co);
        out->p = l->p;
        out->dir = frame_to_world(&f, wl);
        out->n = out->dir;
        out->Le = v3_scale(l->L, spot_falloff(l, wl.z));
        out->pdf_pos = 1.0f;
        out->pdf_dir = pdf_uniform_cone(co);
        out->cos_at_light = 1.0f;
        return !v3_is_black(out->Le);
    }
    case VBI_LIGHT_RECT:
    case VBI_LIGHT_TRIANGLE: {
        if (!(l->area > 0.0f))
            return 0;
        vec2 b = l->type == VBI_LIGHT_RECT ? u_pos : sample_uniform_triangle(u_pos);
        vec3 q = v3_add(l->p, v3_add(v3_scale(l->e0, b.x), v3_scale(l->e1, b.y)));
        sample_le_lambert(l, q, l->n, u_dir, out);
        return out->pdf_dir > 0.0f;
    }
    case VBI_LIGHT_SPHERE: {
        if (!(l->area > 0.0f))
            return 0;
        vec3 nq = sample_uniform_sphere(u_pos);
        sample_le_lambert(l, v3_fma(l->p, nq, l->radius), nq, u_dir, out);
        return out->pdf_dir > 0.0f;
    }
    case VBI_LIGHT_DIRECTIONAL:
        out->pdf_dir = 1.0f;
        return sample_le_distant(l, l->n, u_pos, out);
    case VBI_LIGHT_ENV: {
        /* The ray travels along d, against the direction -d the radiance arrives from. */
        if (l->env) {
            vec3 sky;
            float pdf;
            if (!vbi_env_sample(l->env, u_dir, &sky, &pdf) || !sample_le_distant(l, v3_neg(sky), u_pos, out))
                return 0;
            out->Le = vbi_env_radiance(l->env, sky);
            out->pdf_dir = pdf;
            return !v3_is_black(out->Le);
        }
        vec3 d = sample_uniform_sphere(u_dir);
        out->pdf_dir = pdf_uniform_sphere();
        return sample_le_distant(l, d, u_pos, out);
    }
    }
    return 0;
}
