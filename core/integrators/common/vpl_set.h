/* Virtual point lights shared by the many-light baselines `vpl` and `vsl` (private header).
 *
 * Generation (instant radiosity, Keller 1997; the survey of Dachsbacher et al. 2014, §2.1): light
 * random walks (vbi_photon_walk of photon_walk.h: light picked by power through the scene's alias
 * table, emission sampling, BSDF-sampled bounces, Russian roulette with survival = the sampled
 * albedo ratio), a VPL at every non-delta hit (none on the light itself: direct light is computed
 * separately), flux divided by the number of light *paths* N (survey Eq. 6), never by the VPL
 * count. A VPL keeps the BSDF resolved at its hit and the direction the light came from.
 *
 * Count: with `light_paths` > 0 exactly that many paths are traced (N fixed, the estimator is
 * unbiased). Otherwise paths are traced in order until `target` VPLs are stored; the set is cut
 * at the target inside the last path and N is the number of paths begun (equal-count
 * comparisons; the stopping rule is the usual one of progressive IR).
 *
 * Georgiev & Slusallek 2010 acceptance (`epsilon` > 0 and frames >= 1): every candidate VPL is
 * kept with probability p_i = min(Phi_i / Phi_v + epsilon, 1) and its flux divided by p_i; a
 * rejected candidate does not end its walk (descendants use the unmodified throughput). Phi_i is
 * the candidate's mean luminance contribution over `camera_points` fresh camera points of the
 * frame (shadow rays and the clamped geometry term, as the renderer shades), with the flux
 * normalised by the previous frame's path count; Phi_v = Phi_total / (P N) with Phi_total the
 * previous frame's image total, estimated by P times the mean over that frame's camera points of
 * its accepted VPLs' contributions (0 on the first frame, so p = 1). Pilot frames use their own
 * walk seeds; the final frame uses the walks of plain IR and a separate random stream for the
 * acceptance test, so epsilon >= 1 gives exactly the plain IR set. Only the last frame's set is
 * kept. Accepted VPLs count toward `target`.
 *
 * Determinism: path k of a frame draws from vbi_rng_for(frame seed, k, 0) (walk) and
 * vbi_rng_for(frame seed, k, 1) (acceptance); chunks of paths run in parallel and are
 * concatenated in path order, so the set does not depend on the thread count. */
#ifndef VBI_VPL_SET_H
#define VBI_VPL_SET_H

#include <stddef.h>
#include <stdint.h>

#include "render_internal.h"
#include "shading.h"

typedef struct vbi_vpl {
    vec3 p;
    vec3 ng;        /* geometric normal on the lit side */
    frame fr;       /* shading frame on the lit side (z = shading normal) */
    vec3 wi;        /* local, toward where the light came from */
    vec3 flux;      /* Phi_i (W), after the 1/N normalisation and any 1/p_i */
    vbi_bsdf bsdf; /* resolved at the hit */
} vbi_vpl;

typedef struct vbi_vpl_params {
    uint32_t target;        /* VPLs wanted (when light_paths == 0) */
    uint64_t light_paths;   /* fixed path count N, 0 = trace until `target` */
    float clamp;            /* bound b on the geometry term, 0 = none */
    int rr_depth;           /* bounces of the light walk before Russian roulette */
    uint64_t seed;
    /* Georgiev-Slusallek acceptance */
    int acceptance;
    float epsilon;
    uint32_t camera_points; /* N_C */
    uint32_t frames;        /* >= 1; frame 1 is plain IR */
    uint32_t width, height; /* image the camera sees (P = width x height) */
} vbi_vpl_params;

typedef struct vbi_vpl_set {
    vbi_vpl *vpls;
    uint32_t count;
    uint64_t paths;         /* N of the final set */
    uint64_t candidates;    /* VPL candidates of the final frame (= count without acceptance) */
    double mean_acceptance; /* mean p_i over the final frame's candidates (1 without acceptance) */
    double phi_total;       /* the Phi_total used for the final frame */
} vbi_vpl_set;

/* Refuses requests whose VPLs (and candidates, with acceptance) would not fit in the machine's
 * memory, naming the bytes needed; `owner` names the integrator in the message. */
vbnl_result vbi_vpl_params_check(const vbi_vpl_params *p, const char *owner, vbnl_error *err);

/* Generates the set. Work runs through `stage` (progress "light paths", cancellation) or
 * serially when it is NULL. Errors: VBNL_ERR_OUT_OF_MEMORY, VBNL_ERR_CANCELLED. */
vbnl_result vbi_vpl_set_build(const vbnl_scene *scene, const vbi_vpl_params *p, vbnl_stage_ctx *stage,
                               vbi_vpl_set *out, vbnl_error *err);
void vbi_vpl_set_free(vbi_vpl_set *s);

/* Unoccluded contribution of VPL v to the radiance leaving x toward sf->wo (non-delta bsdf):
 * f_x cos_x f_y cos_y Phi / d^2, with the geometry term G = cos_x cos_y / d^2 clamped to `clamp`
 * (> 0; BSDFs are never clamped). Returns 0 when it is black. *w and *dist receive the direction
 * and distance to the VPL for the shadow ray. */
vec3 vbi_vpl_contribution(const vbi_vpl *v, const vbi_bsdf *bsdf, vec3 x, const vbi_shading_frame *sf,
                           float clamp, vec3 *w, float *dist);
/* 1 when nothing blocks the segment from x (geometric normal ng) to VPL v. */
int vbi_vpl_visible(const vbnl_scene *sc, vec3 x, vec3 ng, const vbi_vpl *v, vec3 w, float dist);

/* The first non-delta surface a camera ray reaches, through at most VBI_VPL_MAX_SPECULAR delta
 * bounces (mirror, glass), chosen by BSDF sampling, from the camera hit *hit (when hit_ok) seen
 * along *d; *hit and *d become the vertex and the direction arriving there. `direct` receives the emitted light met on
 * the way (an emitter hit directly or through delta bounces: part of the direct image), `beta`
 * the throughput to the returned vertex. Returns 0 when the path ends first. */
#define VBI_VPL_MAX_SPECULAR 16
int vbi_vpl_camera_vertex(const vbnl_scene *sc, vbi_sampler *sp, int hit_ok, vbi_hit *hit, vec3 *d, vec3 *beta,
                           vec3 *direct, vbi_thread_stats *stats);

/* The camera side of `vpl` and `vsl`: emission seen directly, the delta chain to the first
 * non-delta vertex x (vbi_vpl_camera_vertex), direct light at x with the shared estimator
 * (next-event estimation + the MIS-weighted BSDF sample, as `path`), then `gather` for the light
 * of the virtual lights at x. The direct parts are left out when indirect_only. Writes one film
 * sample like vbi_camera_path_fn. */
typedef vec3 (*vbi_vpl_gather_fn)(const void *state, const vbi_bsdf *bsdf, vec3 x, const vbi_shading_frame *sf,
                                   vbi_sampler *sp, vbi_thread_stats *stats);
void vbi_vpl_trace(const vbnl_scene *sc, int indirect_only, vec3 cam_forward, vbi_vpl_gather_fn gather,
                    const void *gstate, vbi_sampler *sp, vec3 o, vec3 d, int hit_ok, const vbi_hit *first,
                    float *out, vbi_thread_stats *stats);

static inline float vbi_luminance(vec3 c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

#endif
