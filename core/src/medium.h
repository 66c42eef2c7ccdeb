/* Participating media and fog (private header): the committed form of scene.h's media section,
 * phase functions, and the two ways every integrator meets a medium along a ray segment:
 * delta tracking (where does the path interact next, vbi_medium_track) and the transmittance of
 * a connection (vbi_medium_transmittance).
 *
 * Regions. What a ray travels in is a region: VBI_REGION_OUTSIDE (the atmosphere and the fogs,
 * where the camera and the lights are), VBI_REGION_CLEAR (nothing), or a medium id + 1. A path
 * keeps a small stack of the regions it has entered (vbi_medium_stack): crossing a surface inward
 * (through a transmitting BSDF, against the geometric normal) pushes what the material's interior
 * says, crossing outward pops, so a glass inside a fog-filled box returns the ray to the box's
 * medium. A stack that overflows keeps its bottom entries; a pop of an empty stack stays outside.
 *
 * Coefficients. A medium is a sum of parts (POV-Ray's media blocks); part k at point p has
 * sigma_a,k d_k(p), sigma_s,k d_k(p) and emission e_k d_k(p), with d_k the product of its density
 * pigments' colours there (1 without any). The majorant is a scalar bound of the largest channel
 * of sigma_t = sum_k (sigma_a,k + sigma_s,k) d_k over all space, from the pigments' colour bounds;
 * a medium that only emits gets the majorant 1 / (the scene's radius), so that its emission is
 * still sampled along a segment.
 *
 * Tracking (Woodcock tracking with null collisions; the spectral form of Kutz et al. 2017 /
 * pbrt-v4 with probabilities from the channel means): tentative collisions at the majorant's
 * exponential steps; at each one the path adds beta e(p) / majorant (the collision estimator of
 * the emission integral) and then scatters, is absorbed (ends) or goes on (null collision) with
 * probabilities mean(sigma_s) / majorant, mean(sigma_a) / majorant and the rest, its throughput
 * multiplied by sigma_s / (majorant P_s) or sigma_n / (majorant P_n), channel by channel (1 for
 * grey media). A medium without density pattern and with grey extinction is tracked exactly
 * (one exponential step, no null collisions; absorption becomes the weight sigma_s / sigma_t).
 * Transmittance: exp(-sigma_t d) in closed form for constant media, ratio tracking otherwise
 * (Novak et al. 2014), both unbiased. Segments that leave the scene (escaped rays) are clipped at
 * the scene's far bound for the sampled media; fog keeps POV-Ray's infinite depth.
 *
 * Random numbers come from the path's sampler or the photon walk's stream (vbi_rand); the number
 * drawn varies with the collisions, so images stay deterministic for a seed. */
#ifndef VBI_MEDIUM_H
#define VBI_MEDIUM_H

#include <stdint.h>

#include "rng.h"
#include "sampler.h"
#include "texture/texture.h"
#include "vbnl/scene.h"
#include "vmath.h"

#define VBI_REGION_OUTSIDE 0u
#define VBI_REGION_CLEAR UINT32_MAX
#define VBI_MEDIUM_STACK_MAX 6u

typedef struct vbi_medium_part {
    vec3 sigma_a, sigma_s, emission;
    vbnl_phase_kind phase;
    float g;
    uint32_t density[VBNL_MEDIUM_DENSITY_MAX]; /* pigment ids */
    uint32_t density_count;
    float ext;             /* the share of sigma_s in the extinction (1 - extinction_deficit) */
} vbi_medium_part;

typedef struct scene_medium {
    vbi_medium_part part[VBNL_MEDIUM_PARTS_MAX];
    uint32_t part_count;
    int constant;          /* no density pigment: the coefficients below hold everywhere */
    vec3 sigma_a, sigma_s, emission; /* constant: the sums over the parts */
    vec3 sigma_x;          /* constant: the scattering's share of the extinction, sum of ext sigma_s */
    int partial;           /* some part's ext is not 1 (sigma_t = sigma_a + sigma_x, not + sigma_s) */
    float majorant;        /* bound of max-channel sigma_t (> 0 once committed) */
    int scatters, emits, extinguishes;
} scene_medium;

typedef struct vbi_fog {
    vbnl_fog_kind kind;
    double distance;
    vec3 color;
    float filter, transmit;
    double offset, alt;
    dvec3 up;
    int turbulent;
    vbi_turb turb;
    double turb_depth;
    int generator;
} vbi_fog;

/* The regions a ray has entered, innermost last. */
typedef struct vbi_medium_stack {
    uint32_t r[VBI_MEDIUM_STACK_MAX];
    uint32_t n;
} vbi_medium_stack;

static inline void vbi_medium_stack_init(vbi_medium_stack *s) { s->n = 0; }
static inline uint32_t vbi_medium_region(const vbi_medium_stack *s)
{
    return s->n ? s->r[s->n - 1] : VBI_REGION_OUTSIDE;
}

/* A source of uniform numbers in [0, 1): the path's sampler, else the stream. */
typedef struct vbi_rand {
    vbi_sampler *sp;
    vbi_rng *rng;
} vbi_rand;
static inline float vbi_rand_next(vbi_rand *r) { return r->sp ? vbi_sampler_next(r->sp) : vbi_rng_next(r->rng); }
static inline vec2 vbi_rand_next2(vbi_rand *r) { return r->sp ? vbi_sampler_next2(r->sp) : vbi_rng_next2(r->rng); }

/* ---- phase functions (medium.c) ---- */

/* The phase function's value for the cosine mu between the directions of travel before and after
 * scattering (normalised: its integral over the sphere is 1). */
float vbi_phase_eval(vbnl_phase_kind kind, float g, float mu);
/* Samples the direction of travel after scattering, given the one before (`in`, unit); returns
 * it with *pdf = vbi_phase_eval of it (every sampler here is exact: the weight is 1). */
vec3 vbi_phase_sample(vbnl_phase_kind kind, float g, vec3 in, vec2 u, float *pdf);

/* ---- what the tracking finds ---- */

typedef struct vbi_medium_event {
    vec3 p;                 /* where the path scatters */
    float t;                /* its distance along the segment */
    vbnl_phase_kind phase;  /* the part chosen there (by its share of sigma_s) */
    float g;
} vbi_medium_event;

enum {
    VBI_TRACK_PASSED = 0,  /* the path reached the segment's end */
    VBI_TRACK_SCATTERED,   /* it scatters at the event's point */
    VBI_TRACK_ABSORBED,    /* it ends in the medium */
};

/* Follows the path over (0, tmax) of o + t d (tmax may be INFINITY) in `region`: beta is multiplied
 * by the segment's weights, *L receives beta times the light emitted along the way (emission
 * media, fog); a VBI_TRACK_* answer, with *ev filled when it scatters. */
int vbi_medium_track(const vbnl_scene *sc, uint32_t region, vec3 o, vec3 d, float tmax, vbi_rand *r, vec3 *beta,
                      vec3 *L, vbi_medium_event *ev);
/* The transmittance of the segment in `region` (closed form, or ratio tracking with numbers from r;
 * fog: POV-Ray's attenuation with the filter colour). */
vec3 vbi_medium_transmittance(const vbnl_scene *sc, uint32_t region, vec3 o, vec3 d, float tmax, vbi_rand *r);
/* The region stack after the path crossed the surface of `material` along d, ng being the
 * surface's geometric normal (winding side). */
void vbi_medium_cross(const vbnl_scene *sc, vbi_medium_stack *s, uint32_t material, vec3 ng, vec3 d);
/* 1 when a segment in `region` meets nothing (no medium, no fog). */
int vbi_region_is_empty(const vbnl_scene *sc, uint32_t region);

/* 1 when the medium of `region` scatters light (fog does not: it only blends). */
int vbi_region_scatters(const vbnl_scene *sc, uint32_t region);
/* sum_k sigma_s,k(p) phase_k(mu) of the region's medium at p: the light scattered per unit
 * length and solid angle at the cosine mu between the directions of travel (0 outside media). */
vec3 vbi_medium_inscatter(const vbnl_scene *sc, uint32_t region, vec3 p, float mu);

/* ---- commit (medium.c) ---- */

/* Majorants and flags once the textures and bounds are final. */
void vbi_media_commit(vbnl_scene *sc);
/* Sets every material's may_pass; returns 1 when some material may. */
int vbi_media_commit_pass(vbnl_scene *sc);

#endif
