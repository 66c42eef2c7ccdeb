/* Pieces every integrator shares (private header): the camera-ray tile loop with 8-wide primary
 * packets, the shading frame, and next-event estimation of the real lights. */
#ifndef VBNL_SHADING_H
#define VBNL_SHADING_H

#include "render_internal.h"

/* Traces the camera path whose first hit (when hit_ok) is given and writes one sample's film
 * record into `out` (zeroed, film stride floats). */
typedef void (*vbnl_camera_path_fn)(void *state, vbnl_rng *rng, vec3 o, vec3 d, int hit_ok,
                                    const vbnl_hit *hit, float *out, vbnl_thread_stats *stats);

/* Renders every sample of a tile job: a camera ray per sample through a uniformly jittered
 * position in the pixel (box filter), primary hits as 8-wide Embree packets, then fn. The
 * first two random numbers of each sample's stream place it in the pixel. */
void vbnl_render_camera_paths(vbnl_tile_job *job, uint32_t stride, vbnl_camera_path_fn fn, void *state);

/* Shading frame at a hit seen along d. Opaque surfaces are two-sided: ng and the shading normal
 * are flipped to face the viewer, and a shading normal that faces away falls back to ng; the
 * dielectric keeps its orientation. */
typedef struct vbnl_shading_frame {
    frame fr;  /* z = shading normal */
    vec3 ng;   /* geometric normal used for sidedness and ray offsets */
    vec3 wo;   /* -d in the local frame */
} vbnl_shading_frame;
void vbnl_shading_frame_make(const vbnl_bsdf *bsdf, const vbnl_hit *hit, vec3 d, vbnl_shading_frame *sf);

/* Next-event estimation at x (non-delta BSDF): one light picked by power, a point on it, a
 * shadow ray, MIS against BSDF sampling (power heuristic). Returns f * Li * w / pdf (not yet
 * multiplied by the path throughput). */
vec3 vbnl_estimate_direct(const vbnl_scene *sc, const vbnl_bsdf *bsdf, vec3 x, const vbnl_shading_frame *sf,
                          vbnl_rng *rng, vbnl_thread_stats *stats);

/* MIS weight of light found by a BSDF sample from x along w (environment when !hit_ok, else the
 * emitter at y), against next-event estimation; 1 after a specular bounce. Also returns Le. */
float vbnl_arriving_light(const vbnl_scene *sc, int hit_ok, const vbnl_hit *y, vec3 x, vec3 w, float pdf_bsdf,
                          int specular, vec3 *Le);

#endif
