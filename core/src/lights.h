/* Light sources (private header).
 *
 * Each vbi_light is self-contained (it keeps its own world-space geometry), so lights can be
 * sampled without the scene. Emissive meshes become one VBI_LIGHT_TRIANGLE per triangle; the
 * scene builds an alias table over light powers for selection (sampling.h).
 *
 * Conventions: `wi` points from the reference point toward the light. pdfs of area-like lights
 * are solid-angle pdfs at the reference point; delta lights (point, spot, directional) report
 * pdf = 1 and is_delta = 1 and their Li already includes the 1/r^2 falloff. */
#ifndef VBI_LIGHTS_H
#define VBI_LIGHTS_H

#include <stdint.h>

#include "sampling.h"
#include "vmath.h"

typedef enum vbi_light_type {
    VBI_LIGHT_POINT = 0,
    VBI_LIGHT_SPOT = 1,
    VBI_LIGHT_RECT = 2,        /* parallelogram p + s e0 + t e1 */
    VBI_LIGHT_TRIANGLE = 3,    /* p, p + e0, p + e1 */
    VBI_LIGHT_SPHERE = 4,      /* centre p, radius */
    VBI_LIGHT_DIRECTIONAL = 5, /* light travels along n */
    VBI_LIGHT_ENV = 6,         /* radiance from every direction: constant, or `env` */
} vbi_light_type;

typedef struct vbi_light {
    vbi_light_type type;
    vec3 p;              /* position / corner / first vertex / centre */
    vec3 e0, e1;         /* edges of rect and triangle lights */
    vec3 n;              /* unit normal of rect/triangle (emitting side); unit direction of travel for spot/directional */
    float area;          /* rect, triangle, sphere */
    float radius;        /* sphere */
    vec3 L;              /* radiance (rect, triangle, sphere, env), intensity (point, spot), irradiance (directional) */
    float cos_inner, cos_outer, exponent; /* spot */
    int two_sided;       /* rect, triangle, sphere (sphere: emits inward too) */
    vec3 world_center;   /* scene bounding sphere, for directional and env lights */
    float world_radius;
    const struct vbi_env *env; /* env: the directional sky (environment.h; L is then its mean
                                 * radiance), NULL for a constant one */
    int shadowless;      /* casts no shadow (vbnl_scene_set_light_shadowless) */
    int no_media;        /* media do not scatter its light (vbnl_scene_set_light_media_interaction) */
} vbi_light;

typedef struct vbi_light_li_sample {
    vec3 wi;             /* unit, toward the light */
    float dist;          /* distance to the sampled point (INFINITY for directional/env) */
    vec3 p, n;           /* sampled point and its normal (area lights) */
    vec3 Li;             /* incident radiance (or, for delta lights, the irradiance-like term I/r^2) */
    float pdf;           /* solid angle pdf (1 for delta lights) */
    int is_delta;
} vbi_light_li_sample;

/* Every light type but rect and triangle (lights.c); call the inline functions below, which do
 * the planar lights (the emissive meshes' triangles, the commonest lights) without a call. */
int vbi_light_sample_li_other(const vbi_light *l, vec3 ref, vec2 u, vbi_light_li_sample *out);
float vbi_light_pdf_li_other(const vbi_light *l, vec3 ref, vec3 p_light, vec3 n_light, vec3 wi);
vec3 vbi_light_Le_other(const vbi_light *l, vec3 n_light, vec3 w);

/* Area sampling of a planar light at q converted to solid angle: pdf = r^2 / (|cos| A). */
static inline int vbi_light_sample_li_planar(const vbi_light *l, vec3 ref, vec3 q, vbi_light_li_sample *out)
{
    vec3 d = v3_sub(q, ref);
    float dist2 = v3_len2(d);
    if (!(dist2 > 0.0f) || !(l->area > 0.0f))
        goto none;
    float dist = sqrtf(dist2);
    vec3 wi = v3_scale(d, 1.0f / dist);
    float cos_l = -v3_dot(l->n, wi);
    if (!l->two_sided && cos_l <= 0.0f)
        goto none;
    cos_l = fabsf(cos_l);
    if (cos_l == 0.0f)
        goto none;
    out->wi = wi;
    out->dist = dist;
    out->p = q;
    out->n = l->n;
    out->Li = l->L;
    out->pdf = dist2 / (cos_l * l->area);
    out->is_delta = 0;
    return isfinite(out->pdf);
none:
    *out = (vbi_light_li_sample){0};
    return 0;
}

/* Samples incident light at ref. Returns 0 when there is none (for example the back of a
 * one-sided light, or a spot outside its cone). */
static inline int vbi_light_sample_li(const vbi_light *l, vec3 ref, vec2 u, vbi_light_li_sample *out)
{
    if (l->type == VBI_LIGHT_TRIANGLE) {
        vec2 b = sample_uniform_triangle(u);
        return vbi_light_sample_li_planar(l, ref, v3_add(l->p, v3_add(v3_scale(l->e0, b.x), v3_scale(l->e1, b.y))),
                                           out);
    }
    if (l->type == VBI_LIGHT_RECT)
        return vbi_light_sample_li_planar(l, ref, v3_add(l->p, v3_add(v3_scale(l->e0, u.x), v3_scale(l->e1, u.y))),
                                           out);
    /* Through a copy: were the caller's record handed to the call, it would have to live in
     * memory, and the planar cases above would store every field (p and n too, which next-event
     * estimation never reads). */
    vbi_light_li_sample other;
    int ok = vbi_light_sample_li_other(l, ref, u, &other);
    *out = other;
    return ok;
}

/* Solid-angle pdf that sample_li picks the point p_light (with normal n_light) seen from ref
 * along wi. 0 for delta lights. For env lights p_light/n_light are ignored. */
static inline float vbi_light_pdf_li(const vbi_light *l, vec3 ref, vec3 p_light, vec3 n_light, vec3 wi)
{
    if (l->type != VBI_LIGHT_TRIANGLE && l->type != VBI_LIGHT_RECT)
        return vbi_light_pdf_li_other(l, ref, p_light, n_light, wi);
    /* The light's own normal: the plane is flat, and the caller's may be flipped. */
    float cos_l = v3_absdot(l->n, wi);
    float dist2 = v3_len2(v3_sub(p_light, ref));
    if (cos_l == 0.0f || !(l->area > 0.0f))
        return 0.0f;
    return dist2 / (cos_l * l->area);
}

/* Radiance leaving an area light at a point with normal n_light toward direction w (unit, pointing
 * away from the light); 0 from the back of a one-sided light. Env: radiance along any w.
 * Rect/triangle decide the side with the light's own n (n_light is ignored, so a hit normal of
 * either orientation works); spheres need the outward normal in n_light. */
static inline vec3 vbi_light_Le(const vbi_light *l, vec3 n_light, vec3 w)
{
    if (l->type != VBI_LIGHT_TRIANGLE && l->type != VBI_LIGHT_RECT)
        return vbi_light_Le_other(l, n_light, w);
    return (l->two_sided || v3_dot(l->n, w) > 0.0f) ? l->L : v3s(0.0f);
}

/* Total emitted power (W per channel) used for power-based selection. */
vec3 vbi_light_power(const vbi_light *l);

/* Emission sampling for light tracing (photons, VPLs): a point and a direction leaving the light.
 * Le is the radiance (area lights), intensity (point, spot) or radiance (directional, env); the
 * estimate of the emitted flux carried by the ray is Le * |cos| / (pdf_pos * pdf_dir). */
typedef struct vbi_light_le_sample {
    vec3 p, n, dir;
    vec3 Le;
    float pdf_pos;       /* area pdf (1 for point/spot) */
    float pdf_dir;       /* solid angle pdf */
    float cos_at_light;  /* |cos| between dir and n for area lights, 1 otherwise */
} vbi_light_le_sample;
int vbi_light_sample_le(const vbi_light *l, vec2 u_pos, vec2 u_dir, vbi_light_le_sample *out);

#endif
