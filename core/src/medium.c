/* Participating media and fog: phase functions, delta and ratio tracking, POV-Ray's fog in closed
 * form, region crossings, and the scene API of scene.h's media section (medium.h). */
#include "medium.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "desc.h"
#include "sampling.h"
#include "scene_internal.h"

/* ---- phase functions --------------------------------------------------------------------------- */

/* POV-Ray's Mie approximations are 1 + a x^n in x = (1 + mu) / 2; over the sphere x is uniform
 * in [0, 1], so their mean is 1 + a / (n + 1) and the normalised function is their value over
 * 4 pi times that mean. */
static void mie_shape(vbnl_phase_kind kind, float *a, int *n)
{
    if (kind == VBNL_PHASE_MIE_HAZY) {
        *a = 9.0f;
        *n = 8;
    } else {
        *a = 50.0f;
        *n = 32;
    }
}

float vbi_phase_eval(vbnl_phase_kind kind, float g, float mu)
{
    mu = clampf(mu, -1.0f, 1.0f);
    switch (kind) {
    case VBNL_PHASE_MIE_HAZY:
    case VBNL_PHASE_MIE_MURKY: {
        float a;
        int n;
        mie_shape(kind, &a, &n);
        float x = 0.5f * (1.0f + mu);
        return (1.0f + a * powf(x, (float)n)) * VBI_INV_4PI / (1.0f + a / (float)(n + 1));
    }
    case VBNL_PHASE_RAYLEIGH:
        return 3.0f / (16.0f * VBI_PI) * (1.0f + mu * mu);
    case VBNL_PHASE_HENYEY_GREENSTEIN: {
        float g2 = g * g, den = 1.0f + g2 - 2.0f * g * mu;
        return VBI_INV_4PI * (1.0f - g2) / (den * sqrtf(den));
    }
    case VBNL_PHASE_ISOTROPIC:
    default:
        return VBI_INV_4PI;
    }
}

/* The cosine mu of a sample (its azimuth is uniform for every phase function here). */
static float phase_sample_mu(vbnl_phase_kind kind, float g, float u)
{
    switch (kind) {
    case VBNL_PHASE_MIE_HAZY:
    case VBNL_PHASE_MIE_MURKY: {
        /* the mixture of its two terms: uniform mu with probability 1 / (1 + a / (n + 1)), else
         * x^n, whose x = (1 + mu) / 2 is sampled as v^(1 / (n + 1)) */
        float a;
        int n;
        mie_shape(kind, &a, &n);
        float p_uniform = 1.0f / (1.0f + a / (float)(n + 1));
        if (u < p_uniform)
            return clampf(2.0f * (u / p_uniform) - 1.0f, -1.0f, 1.0f);
        float v = (u - p_uniform) / (1.0f - p_uniform);
        return clampf(2.0f * powf(v, 1.0f / (float)(n + 1)) - 1.0f, -1.0f, 1.0f);
    }
    case VBNL_PHASE_RAYLEIGH: {
        /* CDF (mu^3 + 3 mu + 4) / 8 = u: Cardano's root of mu^3 + 3 mu - (8u - 4) = 0 */
        double z = 4.0 * u - 2.0, s = sqrt(z * z + 1.0);
        return clampf((float)(cbrt(z + s) + cbrt(z - s)), -1.0f, 1.0f);
    }
    case VBNL_PHASE_HENYEY_GREENSTEIN:
        if (fabsf(g) > 1e-3f) {
            float sq = (1.0f - g * g) / (1.0f - g + 2.0f * g * u);
            return clampf((1.0f + g * g - sq * sq) / (2.0f * g), -1.0f, 1.0f);
        }
        return 1.0f - 2.0f * u; /* isotropic in the limit */
    case VBNL_PHASE_ISOTROPIC:
    default:
        return 1.0f - 2.0f * u;
    }
}

vec3 vbi_phase_sample(vbnl_phase_kind kind, float g, vec3 in, vec2 u, float *pdf)
{
    float mu = phase_sample_mu(kind, g, u.x);
    float s = safe_sqrtf(1.0f - mu * mu), phi = 2.0f * VBI_PI * u.y;
    frame f = frame_from_normal(in);
    vec3 out = v3_norm(frame_to_world(&f, v3(s * cosf(phi), s * sinf(phi), mu)));
    *pdf = vbi_phase_eval(kind, g, v3_dot(in, out));
    return out;
}

/* ---- coefficients at a point ------------------------------------------------------------------- */

static vec3 part_density(const vbnl_scene *sc, const vbi_medium_part *pt, vec3 p)
{
    vec3 d = v3s(1.0f);
    if (!pt->density_count)
        return d;
    vbi_shade_point sp;
    memset(&sp, 0, sizeof(sp));
    sp.p = d3(p.x, p.y, p.z);
    sp.eye = d3(sc->camera.position[0], sc->camera.position[1], sc->camera.position[2]);
    for (uint32_t k = 0; k < pt->density_count; ++k) {
        float c[5];
        vbi_pigment_eval(&sc->tex, pt->density[k], sp.p, &sp, c);
        d = v3_mul(d, v3_max(v3(c[0], c[1], c[2]), v3s(0.0f)));
    }
    return d;
}

/* The coefficients of medium m at p; with `parts`, each part's scattering weight too. */
typedef struct coeffs {
    vec3 sa, ss, em;
    vec3 sx; /* the scattering's share of the extinction: sigma_t = sa + sx */
    vec3 part_ss[VBNL_MEDIUM_PARTS_MAX];
    float part_w[VBNL_MEDIUM_PARTS_MAX];
} coeffs;

static void medium_at(const vbnl_scene *sc, const scene_medium *m, vec3 p, coeffs *c)
{
    if (m->constant) {
        c->sa = m->sigma_a;
        c->ss = m->sigma_s;
        c->sx = m->sigma_x;
        c->em = m->emission;
        for (uint32_t k = 0; k < m->part_count; ++k) {
            c->part_ss[k] = m->part[k].sigma_s;
            c->part_w[k] = v3_avg(m->part[k].sigma_s);
        }
        return;
    }
    c->sa = c->ss = c->sx = c->em = v3s(0.0f);
    for (uint32_t k = 0; k < m->part_count; ++k) {
        const vbi_medium_part *pt = &m->part[k];
        vec3 d = part_density(sc, pt, p);
        c->sa = v3_add(c->sa, v3_mul(pt->sigma_a, d));
        vec3 ss = v3_mul(pt->sigma_s, d);
        c->ss = v3_add(c->ss, ss);
        c->sx = v3_add(c->sx, v3_scale(ss, pt->ext));
        c->em = v3_add(c->em, v3_mul(pt->emission, d));
        c->part_ss[k] = ss;
        c->part_w[k] = v3_avg(ss);
    }
}

/* The part whose phase function a scattering at these coefficients uses. In channel c the
 * medium's phase function is the mixture of its parts' weighted by sigma_s,k,c / sigma_s,c; the
 * part is picked with probability P_k from the channel means, and beta is multiplied by
 * (sigma_s,k,c / sigma_s,c) / P_k (1 for grey media or a single part). */
static void pick_part(const scene_medium *m, const coeffs *c, float u, vbi_medium_event *ev, vec3 *beta)
{
    float total = 0.0f;
    for (uint32_t k = 0; k < m->part_count; ++k)
        total += c->part_w[k];
    uint32_t pick = 0;
    float acc = 0.0f, target = u * total;
    for (uint32_t k = 0; k < m->part_count; ++k) {
        acc += c->part_w[k];
        if (c->part_w[k] > 0.0f) {
            pick = k;
            if (target < acc)
                break;
        }
    }
    ev->phase = m->part[pick].phase;
    ev->g = m->part[pick].g;
    if (m->part_count > 1 && total > 0.0f && c->part_w[pick] > 0.0f) {
        const float P = c->part_w[pick] / total;
        const vec3 share = v3(c->ss.x > 0.0f ? c->part_ss[pick].x / c->ss.x : 0.0f,
                              c->ss.y > 0.0f ? c->part_ss[pick].y / c->ss.y : 0.0f,
                              c->ss.z > 0.0f ? c->part_ss[pick].z / c->ss.z : 0.0f);
        *beta = v3_mul(*beta, v3_scale(share, 1.0f / P));
    }
}

static const scene_medium *region_medium(const vbnl_scene *sc, uint32_t region)
{
    if (region == VBI_REGION_CLEAR)
        return NULL;
    if (region == VBI_REGION_OUTSIDE)
        return sc->atmosphere ? &sc->media[sc->atmosphere - 1] : NULL;
    return region <= sc->medium_count ? &sc->media[region - 1] : NULL;
}

int vbi_region_is_empty(const vbnl_scene *sc, uint32_t region)
{
    if (region == VBI_REGION_CLEAR)
        return 1;
    if (region == VBI_REGION_OUTSIDE && sc->fog_count)
        return 0;
    return region_medium(sc, region) == NULL;
}

int vbi_region_scatters(const vbnl_scene *sc, uint32_t region)
{
    const scene_medium *m = region_medium(sc, region);
    return m && m->scatters;
}

vec3 vbi_medium_inscatter(const vbnl_scene *sc, uint32_t region, vec3 p, float mu)
{
    const scene_medium *m = region_medium(sc, region);
    vec3 f = v3s(0.0f);
    if (!m || !m->scatters)
        return f;
    coeffs c;
    medium_at(sc, m, p, &c);
    for (uint32_t k = 0; k < m->part_count; ++k)
        if (c.part_w[k] > 0.0f)
            f = v3_add(f, v3_scale(c.part_ss[k], vbi_phase_eval(m->part[k].phase, m->part[k].g, mu)));
    return f;
}

/* ---- fog --------------------------------------------------------------------------------------- */

/* POV-Ray's ground fog density 1 / (1 + h^2) above the offset (1 below) averaged along the
 * segment from height h1 to h2: its integral is atan. */
static double ground_mean_density(double h1, double h2)
{
    if (h1 <= 0.0 && h2 <= 0.0)
        return 1.0;
    if (h1 <= 0.0)
        return (atan(h2) - h1) / (h2 - h1);
    if (h2 <= 0.0)
        return (atan(h1) - h2) / (h1 - h2);
    double dh = h1 - h2;
    if (fabs(dh) > 1e-10)
        return (atan(h1) - atan(h2)) / dh;
    return 1.0 / (h1 * h1 + 1.0);
}

/* The attenuation of one fog over the segment [o, o + tmax d] (tmax may be INFINITY), before the
 * transmit floor. */
static double fog_attenuation(const vbnl_scene *sc, const vbi_fog *f, vec3 o, vec3 d, float tmax)
{
    double width = isinf(tmax) ? 1e10 : (double)tmax; /* POV-Ray's depth of a ray that hits nothing */
    dvec3 p1 = d3(o.x, o.y, o.z), dir = d3(d.x, d.y, d.z);
    double density = 1.0;
    if (f->kind == VBNL_FOG_GROUND) {
        dvec3 p2 = d3_fma(p1, dir, width);
        double h1 = (d3_dot(p1, f->up) - f->offset) / f->alt, h2 = (d3_dot(p2, f->up) - f->offset) / f->alt;
        density = ground_mean_density(h1, h2);
    }
    if (f->turbulent) {
        dvec3 mid = d3_fma(p1, dir, 0.5 * width);
        dvec3 q = d3_mul(mid, f->turb.amount);
        double k = exp(-width / f->distance);
        double t = vbi_turbulence(sc->tex.noise, q, &f->turb, f->generator);
        width *= 1.0 - k * fmin(1.0, t * f->turb_depth);
    }
    return exp(-width * density / f->distance);
}

/* Every fog over the segment: *T the attenuation of what arrives from the far end, *add the colour
 * the segment adds (POV-Ray's ComputeFog: attenuations multiply, colours add). */
static void fog_segment(const vbnl_scene *sc, vec3 o, vec3 d, float tmax, vec3 *T, vec3 *add)
{
    *T = v3s(1.0f);
    *add = v3s(0.0f);
    for (uint32_t i = 0; i < sc->fog_count; ++i) {
        const vbi_fog *f = &sc->fogs[i];
        float att = (float)fog_attenuation(sc, f, o, d, tmax);
        att = maxf(att, f->transmit);
        vec3 filt = v3_add(v3s(1.0f - f->filter), v3_scale(f->color, f->filter));
        *T = v3_mul(*T, v3_scale(filt, att));
        *add = v3_add(*add, v3_scale(f->color, 1.0f - att));
    }
}

/* ---- tracking ---------------------------------------------------------------------------------- */

static int grey(vec3 c) { return c.x == c.y && c.y == c.z; }

/* Beer-Lambert exp(-sigma d), d possibly infinite (then 0, or 1 where sigma is 0). */
static float beer(float sigma, float d) { return sigma > 0.0f ? expf(-sigma * d) : 1.0f; }

/* Exponential step of rate `rate`. */
static float exp_step(vbi_rand *r, float rate) { return -logf(1.0f - vbi_rand_next(r)) / rate; }

/* Russian roulette on a weight that null collisions (tracking) or ratios (transmittance) of
 * chromatic and patterned media wear down: below 0.1 in every channel it survives with ten times
 * its largest channel, scaled up to match. Returns 0 when it ends. */
static int roulette(vec3 *w, vbi_rand *r)
{
    const float m = v3_max_comp(*w);
    if (m >= 0.1f)
        return 1;
    if (!(m > 0.0f) || vbi_rand_next(r) >= m * 10.0f)
        return 0;
    *w = v3_scale(*w, 1.0f / (m * 10.0f));
    return 1;
}

int vbi_medium_track(const vbnl_scene *sc, uint32_t region, vec3 o, vec3 d, float tmax, vbi_rand *r, vec3 *beta,
                      vec3 *L, vbi_medium_event *ev)
{
    if (region == VBI_REGION_CLEAR)
        return VBI_TRACK_PASSED;
    const scene_medium *m = region_medium(sc, region);
    if (m) {
        const vec3 sigma_t = v3_add(m->sigma_a, m->sigma_x);
        if (m->constant && grey(sigma_t) && sigma_t.x > 0.0f) {
            /* exact: one exponential step at sigma_t, absorption as the weight sigma_s / sigma_t
             * (an escaped ray in a constant medium always meets it: its transmittance to infinity
             * is 0) */
            const float st = sigma_t.x;
            const float t = exp_step(r, st);
            if (t < tmax) {
                *L = v3_add(*L, v3_mul(*beta, v3_scale(m->emission, 1.0f / st)));
                *beta = v3_mul(*beta, v3_scale(m->sigma_s, 1.0f / st));
                if (v3_is_black(*beta))
                    return VBI_TRACK_ABSORBED;
                ev->t = t;
                ev->p = v3_fma(o, d, t);
                coeffs c;
                medium_at(sc, m, ev->p, &c);
                pick_part(m, &c, vbi_rand_next(r), ev, beta);
                return VBI_TRACK_SCATTERED;
            }
        } else {
            /* an escaped segment ends at the far bound: sampled media are taken to end there */
            const float tend = isinf(tmax) ? sc->far_bound : tmax;
            const float maj = m->majorant;
            for (float t = 0.0f;;) {
                t += exp_step(r, maj);
                if (!(t < tend))
                    break;
                vec3 p = v3_fma(o, d, t);
                coeffs c;
                medium_at(sc, m, p, &c);
                *L = v3_add(*L, v3_mul(*beta, v3_scale(c.em, 1.0f / maj)));
                const vec3 sn = v3_max(v3_sub(v3s(maj), v3_add(c.sa, c.sx)), v3s(0.0f));
                const float pa = v3_avg(c.sa) / maj, ps = v3_avg(c.ss) / maj, pn = v3_avg(sn) / maj;
                /* the events' probabilities are pa, ps, pn over their sum, which is 1 unless the
                 * scattering extincts only partly (sigma_a + sigma_s + sigma_n exceeds the majorant) */
                const float sum = pa + ps + pn, norm = m->partial ? sum : 1.0f;
                const float u = vbi_rand_next(r) * sum;
                if (u < pa)
                    return VBI_TRACK_ABSORBED;
                if (u < pa + ps) {
                    *beta = v3_mul(*beta, v3_scale(c.ss, norm / (maj * ps)));
                    ev->t = t;
                    ev->p = p;
                    pick_part(m, &c, vbi_rand_next(r), ev, beta);
                    return VBI_TRACK_SCATTERED;
                }
                *beta = v3_mul(*beta, v3_scale(sn, norm / (maj * pn)));
                if (!roulette(beta, r))
                    return VBI_TRACK_ABSORBED;
            }
        }
    }
    if (region == VBI_REGION_OUTSIDE && sc->fog_count) {
        vec3 T, add;
        fog_segment(sc, o, d, tmax, &T, &add);
        *L = v3_add(*L, v3_mul(*beta, add));
        *beta = v3_mul(*beta, T);
    }
    return VBI_TRACK_PASSED;
}

vec3 vbi_medium_transmittance(const vbnl_scene *sc, uint32_t region, vec3 o, vec3 d, float tmax, vbi_rand *r)
{
    vec3 T = v3s(1.0f);
    if (region == VBI_REGION_CLEAR)
        return T;
    const scene_medium *m = region_medium(sc, region);
    if (m && m->extinguishes) {
        if (m->constant) {
            vec3 st = v3_add(m->sigma_a, m->sigma_x);
            T = v3(beer(st.x, tmax), beer(st.y, tmax), beer(st.z, tmax));
        } else {
            const float tend = isinf(tmax) ? sc->far_bound : tmax;
            const float maj = m->majorant;
            for (float t = 0.0f;;) {
                t += exp_step(r, maj);
                if (!(t < tend))
                    break;
                coeffs c;
                medium_at(sc, m, v3_fma(o, d, t), &c);
                T = v3_mul(T, v3_max(v3_sub(v3s(1.0f), v3_scale(v3_add(c.sa, c.sx), 1.0f / maj)), v3s(0.0f)));
                if (!roulette(&T, r))
                    return v3s(0.0f);
            }
        }
    }
    if (region == VBI_REGION_OUTSIDE && sc->fog_count) {
        vec3 Tf, add;
        fog_segment(sc, o, d, tmax, &Tf, &add);
        T = v3_mul(T, Tf);
    }
    return T;
}

void vbi_medium_cross(const vbnl_scene *sc, vbi_medium_stack *s, uint32_t material, vec3 ng, vec3 d)
{
    if (v3_dot(d, ng) >= 0.0f) { /* leaving */
        if (s->n)
            s->n--;
        return;
    }
    uint32_t in = sc->materials[material].desc.interior;
    uint32_t region = in == VBNL_INTERIOR_SAME ? vbi_medium_region(s) : in;
    if (s->n < VBI_MEDIUM_STACK_MAX)
        s->r[s->n++] = region;
}

/* ---- commit ------------------------------------------------------------------------------------ */

/* An upper bound of each channel of pigment id's colour (its map's entries, its image's texels);
 * INFINITY where there is none. */
static vec3 pigment_bound(const vbi_texture_set *ts, uint32_t id, uint32_t depth)
{
    if (depth > VBNL_TEXTURE_DEPTH_MAX)
        return v3s(INFINITY);
    const vbi_pigment *pg = &ts->pigments[id];
    if (pg->kind == VBNL_PIGMENT_SOLID)
        return v3(pg->color[0], pg->color[1], pg->color[2]);
    if (pg->kind == VBNL_PIGMENT_IMAGE) {
        const vbi_pattern *pt = &ts->patterns[pg->pattern - 1];
        const vbi_image *im = &ts->images[pt->u.image.image];
        vec3 b = v3s(0.0f);
        const uint32_t ch = im->channels;
        for (size_t i = 0; i < (size_t)im->width * im->height; ++i) {
            const float *t = im->texels + i * ch;
            vec3 c = ch >= 3 ? v3(t[0], t[1], t[2]) : v3s(t[0]);
            b = v3_max(b, c);
        }
        return b;
    }
    vec3 b = v3s(0.0f);
    const vbnl_pigment_map_entry *map = ts->pigment_entries + pg->entry_begin;
    for (uint32_t i = 0; i < pg->entry_count; ++i)
        b = v3_max(b, map[i].pigment ? pigment_bound(ts, map[i].pigment - 1, depth + 1)
                                     : v3(map[i].color[0], map[i].color[1], map[i].color[2]));
    return b;
}

void vbi_media_commit(vbnl_scene *sc)
{
    /* a textured node's surface lets light into the interior of its transmission material */
    for (uint32_t i = 0; i < sc->material_count; ++i) {
        scene_material *m = &sc->materials[i];
        if (m->is_node && m->node.kind == VBNL_NODE_TEXTURED && m->node.transmission &&
            m->desc.interior == VBNL_INTERIOR_SAME)
            m->desc.interior = sc->materials[m->node.transmission - 1].desc.interior;
    }
    vec3 c = v3_scale(v3_add(sc->bounds_min, sc->bounds_max), 0.5f);
    float radius = 0.5f * v3_len(v3_sub(sc->bounds_max, sc->bounds_min));
    if (!(radius > 0.0f) || !isfinite(radius))
        radius = 1.0f;
    /* escaped segments in sampled media end here: beyond twice the scene's bounding sphere from
     * the camera's side of it */
    const vec3 cam = v3_load(sc->camera.position);
    sc->far_bound = v3_len(v3_sub(cam, c)) + 2.0f * radius;
    for (uint32_t i = 0; i < sc->medium_count; ++i) {
        scene_medium *m = &sc->media[i];
        float maj = 0.0f, emit = 0.0f;
        m->constant = 1;
        m->sigma_a = m->sigma_s = m->sigma_x = m->emission = v3s(0.0f);
        m->scatters = m->emits = m->extinguishes = m->partial = 0;
        for (uint32_t k = 0; k < m->part_count; ++k) {
            const vbi_medium_part *pt = &m->part[k];
            vec3 b = v3s(1.0f);
            for (uint32_t j = 0; j < pt->density_count; ++j)
                b = v3_mul(b, v3_max(pigment_bound(&sc->tex, pt->density[j], 0), v3s(0.0f)));
            if (pt->density_count)
                m->constant = 0;
            /* scattering events are sampled at sigma_s even where they extinct less (ext < 1) */
            maj += v3_max_comp(v3_mul(v3_add(pt->sigma_a, v3_scale(pt->sigma_s, fmaxf(pt->ext, 1.0f))), b));
            emit += v3_max_comp(v3_mul(pt->emission, b));
            m->sigma_a = v3_add(m->sigma_a, pt->sigma_a);
            m->sigma_s = v3_add(m->sigma_s, pt->sigma_s);
            m->sigma_x = v3_add(m->sigma_x, v3_scale(pt->sigma_s, pt->ext));
            m->partial |= pt->ext != 1.0f && !v3_is_black(pt->sigma_s);
            m->emission = v3_add(m->emission, pt->emission);
            m->scatters |= !v3_is_black(pt->sigma_s);
            m->emits |= !v3_is_black(pt->emission);
        }
        m->extinguishes = maj > 0.0f;
        /* a medium that only emits (or whose extinction is tiny) still needs collisions to sample
         * its emission: at least one per scene radius, and enough that one collision adds at most
         * a tenth of the emission's bound (each adds emission / majorant), up to 4096 collisions
         * over the far bound (an escaped segment's length) */
        const float emit_rate = fminf(10.0f * emit, 4096.0f / sc->far_bound);
        m->majorant = fmaxf(fmaxf(maj * 1.0001f, 1.0f / radius), emit_rate);
    }
    sc->has_media = sc->medium_count > 0 || sc->fog_count > 0;
}

/* 1 when pigment id may be partly clear somewhere (filter or transmit above 0). */
static int pigment_may_pass(const vbi_texture_set *ts, uint32_t id, uint32_t depth)
{
    if (depth > VBNL_TEXTURE_DEPTH_MAX)
        return 1;
    const vbi_pigment *pg = &ts->pigments[id];
    if (pg->kind == VBNL_PIGMENT_SOLID)
        return pg->color[3] + pg->color[4] > 0.0f;
    if (pg->kind == VBNL_PIGMENT_IMAGE) {
        const vbi_pattern *pt = &ts->patterns[pg->pattern - 1];
        return !ts->images[pt->u.image.image].opaque || pt->u.image.filter_all > 0.0 ||
               pt->u.image.transmit_all > 0.0 || pt->u.image.wrap == VBI_IMAGE_ONCE;
    }
    const vbnl_pigment_map_entry *map = ts->pigment_entries + pg->entry_begin;
    for (uint32_t i = 0; i < pg->entry_count; ++i)
        if (map[i].pigment ? pigment_may_pass(ts, map[i].pigment - 1, depth + 1)
                           : map[i].color[3] + map[i].color[4] > 0.0f)
            return 1;
    return 0;
}

static int material_may_pass(const vbnl_scene *sc, uint32_t m, uint32_t depth)
{
    const scene_material *sm = &sc->materials[m];
    if (!sm->is_node)
        return vbi_bsdf_passes_straight(&sm->bsdf);
    if (depth > VBNL_TEXTURE_DEPTH_MAX)
        return 1;
    const vbi_mnode *nd = &sm->node;
    if (nd->kind == VBNL_NODE_TEXTURED)
        return nd->transmission && vbi_bsdf_passes_straight(&sc->materials[nd->transmission - 1].bsdf) &&
               (!nd->pigment || pigment_may_pass(&sc->tex, nd->pigment - 1, 0));
    const vbnl_material_map_entry *map = sc->tex.material_entries + nd->entry_begin;
    for (uint32_t i = 0; i < nd->entry_count; ++i)
        if (material_may_pass(sc, map[i].material, depth + 1))
            return 1;
    return 0;
}

int vbi_media_commit_pass(vbnl_scene *sc)
{
    int any = 0;
    for (uint32_t i = 0; i < sc->material_count; ++i)
        any |= sc->materials[i].may_pass = material_may_pass(sc, i, 0);
    return any;
}

/* ---- scene API --------------------------------------------------------------------------------- */

void vbnl_medium_desc_init(vbnl_medium_desc *d)
{
    if (!d)
        return;
    memset(d, 0, sizeof(*d));
    d->size = sizeof(*d);
}

void vbnl_fog_desc_init(vbnl_fog_desc *d)
{
    if (!d)
        return;
    memset(d, 0, sizeof(*d));
    d->size = sizeof(*d);
    d->kind = VBNL_FOG_CONSTANT;
    d->distance = 1.0f;
    d->alt = 1.0f;
    d->up[1] = 1.0f;
    d->turbulence.octaves = 6;
    d->turbulence.omega = 0.5f;
    d->turbulence.lambda = 2.0f;
    d->turb_depth = 0.5f;
    d->noise_generator = 2;
}

static int nonneg3(const float *v)
{
    for (int i = 0; i < 3; ++i)
        if (!(v[i] >= 0.0f) || !isfinite(v[i]))
            return 0;
    return 1;
}

vbnl_result vbnl_scene_add_medium(vbnl_scene *s, const vbnl_medium_desc *d, uint32_t *out_id, vbnl_error *err)
{
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_add_medium", err);
    if (r != VBNL_OK)
        return r;
    if (!d)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_add_medium: desc is NULL");
    if ((r = VBI_DESC_CHECK(d, vbnl_medium_desc, err)) != VBNL_OK)
        return r;
    if (!d->parts || d->part_count < 1 || d->part_count > VBNL_MEDIUM_PARTS_MAX)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "a medium needs 1 to %u parts (got %u)",
                              VBNL_MEDIUM_PARTS_MAX, d->part_count);
    scene_medium m;
    memset(&m, 0, sizeof(m));
    for (uint32_t k = 0; k < d->part_count; ++k) {
        const vbnl_medium_part_desc *pd = &d->parts[k];
        if (!nonneg3(pd->absorption) || !nonneg3(pd->scattering) || !nonneg3(pd->emission))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                  "medium part %u: absorption, scattering and emission must be finite and >= 0", k);
        if (pd->phase < VBNL_PHASE_ISOTROPIC || pd->phase > VBNL_PHASE_HENYEY_GREENSTEIN)
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "medium part %u: unknown phase function %d", k,
                                  (int)pd->phase);
        if (pd->phase == VBNL_PHASE_HENYEY_GREENSTEIN && !(fabsf(pd->g) < 1.0f))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                  "medium part %u: the Henyey-Greenstein eccentricity must lie in (-1, 1) (got %g)", k,
                                  pd->g);
        if (pd->density_count > VBNL_MEDIUM_DENSITY_MAX || (pd->density_count && !pd->density))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "medium part %u: 0 to %u density pigments", k,
                                  VBNL_MEDIUM_DENSITY_MAX);
        if (!(pd->extinction_deficit <= 1.0f) || !isfinite(pd->extinction_deficit))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                  "medium part %u: the extinction deficit must be finite and at most 1 (got %g)", k,
                                  pd->extinction_deficit);
        vbi_medium_part *pt = &m.part[k];
        pt->ext = 1.0f - pd->extinction_deficit;
        pt->sigma_a = v3_load(pd->absorption);
        pt->sigma_s = v3_load(pd->scattering);
        pt->emission = v3_load(pd->emission);
        pt->phase = pd->phase;
        pt->g = pd->phase == VBNL_PHASE_HENYEY_GREENSTEIN ? pd->g : 0.0f;
        for (uint32_t j = 0; j < pd->density_count; ++j) {
            if (pd->density[j] >= s->tex.pigment_count)
                return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                      "medium part %u: density pigment %u does not exist (%u added)", k, pd->density[j],
                                      s->tex.pigment_count);
            vec3 b = pigment_bound(&s->tex, pd->density[j], 0);
            if (!v3_is_finite(b))
                return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                      "medium part %u: density pigment %u has no finite upper bound", k, pd->density[j]);
            pt->density[j] = pd->density[j];
        }
        pt->density_count = pd->density_count;
    }
    m.part_count = d->part_count;
    if (s->medium_count == s->medium_cap) {
        uint32_t cap = s->medium_cap ? 2 * s->medium_cap : 4;
        scene_medium *n = realloc(s->media, sizeof(*n) * cap);
        if (!n)
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        s->media = n;
        s->medium_cap = cap;
    }
    s->media[s->medium_count] = m;
    if (out_id)
        *out_id = s->medium_count;
    s->medium_count++;
    return VBNL_OK;
}

vbnl_result vbnl_scene_set_atmosphere(vbnl_scene *s, uint32_t medium, vbnl_error *err)
{
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_set_atmosphere", err);
    if (r != VBNL_OK)
        return r;
    if (medium > s->medium_count)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "vbnl_scene_set_atmosphere: medium %u does not exist (%u added; it is id + 1)", medium,
                              s->medium_count);
    s->atmosphere = medium;
    return VBNL_OK;
}

vbnl_result vbnl_scene_add_fog(vbnl_scene *s, const vbnl_fog_desc *d, vbnl_error *err)
{
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_add_fog", err);
    if (r != VBNL_OK)
        return r;
    if (!d)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_add_fog: desc is NULL");
    if ((r = VBI_DESC_CHECK(d, vbnl_fog_desc, err)) != VBNL_OK)
        return r;
    if (d->kind != VBNL_FOG_CONSTANT && d->kind != VBNL_FOG_GROUND)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "unknown fog kind %d", (int)d->kind);
    if (!(d->distance > 0.0f) || !isfinite(d->distance) || !(d->alt > 0.0f) || !isfinite(d->alt))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "fog distance and alt must be positive and finite (got %g and %g)", d->distance, d->alt);
    for (int i = 0; i < 5; ++i)
        if (!isfinite(d->color[i]))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "fog colour must be finite");
    dvec3 up = d3(d->up[0], d->up[1], d->up[2]);
    if (!(d3_len(up) > 0.0) || !isfinite(d3_len(up)) || !isfinite(d->offset) || !isfinite(d->turb_depth))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "fog up vector must be non-zero and finite");
    vbi_fog f;
    memset(&f, 0, sizeof(f));
    f.kind = d->kind;
    f.distance = d->distance;
    f.color = v3_load(d->color);
    f.filter = clampf(d->color[3], 0.0f, 1.0f);
    f.transmit = clampf(d->color[4], 0.0f, 1.0f);
    f.offset = d->offset;
    f.alt = d->alt;
    f.up = d3_norm(up);
    const vbnl_turbulence_desc *t = &d->turbulence;
    f.turbulent = t->amount[0] != 0.0 || t->amount[1] != 0.0 || t->amount[2] != 0.0;
    f.turb.amount = d3(t->amount[0], t->amount[1], t->amount[2]);
    f.turb.octaves = t->octaves < 1 ? 1 : t->octaves > 10 ? 10 : t->octaves;
    f.turb.omega = t->omega;
    f.turb.lambda = t->lambda;
    f.turb_depth = d->turb_depth;
    f.generator = d->noise_generator >= 1 && d->noise_generator <= 3 ? d->noise_generator : 2;
    if (s->fog_count == s->fog_cap) {
        uint32_t cap = s->fog_cap ? 2 * s->fog_cap : 4;
        vbi_fog *n = realloc(s->fogs, sizeof(*n) * cap);
        if (!n)
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        s->fogs = n;
        s->fog_cap = cap;
    }
    s->fogs[s->fog_count++] = f;
    return VBNL_OK;
}
