/* The raw Embree ray rates of a scene: the ceiling integrators are measured against.
 *
 * A path tracer traces three kinds of rays whose Embree costs differ a lot (on the McGuire
 * Cornell box, in instructions per ray: coherent camera packets ~220, occlusion rays ~430,
 * incoherent closest-hit rays ~660), so each kind is measured on its own: camera rays as 8-wide
 * packets in pixel order (as vbi_render_camera_paths traces them), diffuse bounce rays from
 * the points the camera sees (rtcIntersect1), and shadow rays from the same points to points
 * sampled on the lights the way next-event estimation samples them (rtcOccluded1, ending just
 * short of the light). A renderer's ray counts per kind then give the time Embree alone would
 * need for its rays (vbnl_ray_rates_mix). */
#include <stdlib.h>
#include <string.h>

#include "context.h"
#include "rng.h"
#include "sampling.h"
#include "scene_internal.h"

#define CHUNK 4096u /* rays per work item; a multiple of 8 */

enum { KIND_CAMERA, KIND_CLOSEST, KIND_CLOSEST8, KIND_SHADOW };

typedef struct ray_set {
    const vbnl_scene *scene;
    vec3 *o, *d;
    float *tfar;      /* shadow rays only */
    uint32_t count;
    int kind;
    uint64_t hits[256]; /* per thread, only to keep the traversal from being optimised away */
} ray_set;

static void trace_chunk(void *user, uint64_t item, unsigned thread)
{
    ray_set *rs = user;
    uint32_t begin = (uint32_t)item * CHUNK;
    uint32_t end = begin + CHUNK < rs->count ? begin + CHUNK : rs->count;
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    uint64_t hits = 0;
    if (rs->kind == KIND_CAMERA || rs->kind == KIND_CLOSEST8) {
        if (rs->kind == KIND_CAMERA)
            ictx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
        for (uint32_t i0 = begin; i0 < end; i0 += 8) {
            _Alignas(32) struct RTCRayHit8 rh;
            _Alignas(32) int valid[8];
            vbi_rayhit8_fill(&rh, valid, rs->o, rs->d, i0, end);
            rtcIntersect8(valid, rs->scene->world, &ictx, &rh);
            for (uint32_t k = 0; k < 8; ++k)
                hits += valid[k] && rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID;
        }
    } else if (rs->kind == KIND_CLOSEST) {
        for (uint32_t i = begin; i < end; ++i) {
            struct RTCRayHit rh;
            vbi_rayhit_init(&rh, rs->o[i], rs->d[i], INFINITY);
            rtcIntersect1(rs->scene->world, &ictx, &rh);
            hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
        }
    } else {
        for (uint32_t i = begin; i < end; ++i) {
            struct RTCRay ray;
            ray.org_x = rs->o[i].x;
            ray.org_y = rs->o[i].y;
            ray.org_z = rs->o[i].z;
            ray.dir_x = rs->d[i].x;
            ray.dir_y = rs->d[i].y;
            ray.dir_z = rs->d[i].z;
            ray.tnear = 0.0f;
            ray.tfar = rs->tfar[i];
            ray.time = 0.0f;
            ray.mask = 0xffffffffu;
            ray.id = 0;
            ray.flags = 0;
            rtcOccluded1(rs->scene->world, &ictx, &ray);
            hits += ray.tfar == -INFINITY;
        }
    }
    rs->hits[thread & 255u] += hits;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Seconds of one run over the set (0 for an empty set). */
static double time_set(vbnl_context *ctx, ray_set *rs)
{
    if (rs->count == 0)
        return 0.0;
    uint64_t chunks = (rs->count + CHUNK - 1) / CHUNK;
    double t0 = vbi_now();
    vbi_pool_run(ctx->pool, chunks, trace_chunk, rs, NULL, NULL, 1.0);
    return vbi_now() - t0;
}

/* Rays per second from the median of three run times (0 for an empty set). */
static double rate_of(const ray_set *rs, double t[3])
{
    qsort(t, 3, sizeof(double), cmp_double);
    return rs->count && t[1] > 0.0 ? (double)rs->count / t[1] : 0.0;
}

static void free_set(ray_set *rs)
{
    free(rs->o);
    free(rs->d);
    free(rs->tfar);
}

static int alloc_set(ray_set *rs, const vbnl_scene *scene, uint32_t n, int kind)
{
    memset(rs, 0, sizeof(*rs));
    rs->scene = scene;
    rs->kind = kind;
    rs->o = malloc(sizeof(vec3) * n);
    rs->d = malloc(sizeof(vec3) * n);
    rs->tfar = kind == KIND_SHADOW ? malloc(sizeof(float) * n) : NULL;
    return rs->o && rs->d && (kind != KIND_SHADOW || rs->tfar);
}

vbnl_result vbnl_scene_measure_ray_rates(vbnl_context *ctx, const vbnl_scene *scene, uint32_t ray_count,
                                         uint32_t width, uint32_t height, vbnl_ray_rates *out, vbnl_error *err)
{
    if (!ctx || !scene || !out || ray_count == 0 || width == 0 || height == 0)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_measure_ray_rates: bad argument");
    if (!scene->committed)
        return vbnl_error_set(err, VBNL_ERR_STATE, "vbnl_scene_measure_ray_rates: scene not committed");
    memset(out, 0, sizeof(*out));
    ray_set cam, bounce, shadow;
    if (!alloc_set(&cam, scene, ray_count, KIND_CAMERA) | !alloc_set(&bounce, scene, ray_count, KIND_CLOSEST) |
        !alloc_set(&shadow, scene, ray_count, KIND_SHADOW)) {
        free_set(&cam);
        free_set(&bounce);
        free_set(&shadow);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory for %u rays", ray_count);
    }
    /* Bounce and shadow rays leave from the points random camera rays see. The bounce rays are
     * made exactly as before the shadow rays were added (the same stream), so the closest-hit
     * figure is comparable with older measurements. */
    vbi_rng rng = vbi_rng_make(0x5eed, 7), rng_light = vbi_rng_make(0x5eed, 8);
    const int lights = scene->light_table.n > 0;
    uint32_t n = 0, ns = 0;
    for (uint64_t attempt = 0; n < ray_count && attempt < (uint64_t)ray_count * 16; ++attempt) {
        vec3 o, d;
        vbi_camera_ray(&scene->camera, width, height, vbi_rng_next(&rng) * width,
                        vbi_rng_next(&rng) * height, &o, &d);
        vbi_hit h;
        if (!vbi_scene_intersect(scene, o, d, INFINITY, &h))
            continue;
        vec3 nrm = v3_dot(h.ng, d) < 0.0f ? h.ng : v3_neg(h.ng);
        frame f = frame_from_normal(nrm);
        vec3 w = frame_to_world(&f, sample_cosine_hemisphere(vbi_rng_next2(&rng)));
        bounce.o[n] = vbi_offset_ray_origin(h.p, nrm, w);
        bounce.d[n] = w;
        ++n;
        /* the shadow ray next-event estimation would trace from here (vbi_estimate_direct) */
        if (!lights)
            continue;
        float pmf;
        uint32_t li = vbi_scene_pick_light(scene, vbi_rng_next(&rng_light), &pmf);
        vbi_light_li_sample ls;
        if (!vbi_light_sample_li(&scene->lights[li], h.p, vbi_rng_next2(&rng_light), &ls) || !(ls.pdf > 0.0f) ||
            v3_dot(ls.wi, nrm) <= 0.0f)
            continue;
        shadow.o[ns] = vbi_offset_ray_origin(h.p, nrm, ls.wi);
        shadow.d[ns] = ls.wi;
        shadow.tfar[ns] = isinf(ls.dist) ? INFINITY : ls.dist * (1.0f - 1e-4f);
        ++ns;
    }
    if (n == 0) {
        free_set(&cam);
        free_set(&bounce);
        free_set(&shadow);
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "the camera sees no geometry");
    }
    bounce.count = n;
    shadow.count = ns;
    /* Camera rays: jittered, pixel after pixel in rows, sample after sample, 8 to a packet. */
    const uint64_t npix = (uint64_t)width * height;
    for (uint32_t i = 0; i < ray_count; ++i) {
        uint64_t k = i % npix;
        vbi_camera_ray(&scene->camera, width, height, (float)(k % width) + vbi_rng_next(&rng),
                        (float)(k / width) + vbi_rng_next(&rng), &cam.o[i], &cam.d[i]);
    }
    cam.count = ray_count;
    /* the kinds take turns, so that a load that comes and goes on a shared machine falls on
     * all of them alike */
    double t_cl[3], t_cl8[3], t_sh[3], t_cam[3];
    for (int rep = 0; rep < 3; ++rep) {
        bounce.kind = KIND_CLOSEST;
        t_cl[rep] = time_set(ctx, &bounce);
        bounce.kind = KIND_CLOSEST8;
        t_cl8[rep] = time_set(ctx, &bounce);
        t_sh[rep] = time_set(ctx, &shadow);
        t_cam[rep] = time_set(ctx, &cam);
    }
    out->closest = rate_of(&bounce, t_cl);
    out->closest_packet = rate_of(&bounce, t_cl8);
    out->shadow = rate_of(&shadow, t_sh);
    out->camera = rate_of(&cam, t_cam);
    free_set(&cam);
    free_set(&bounce);
    free_set(&shadow);
    return VBNL_OK;
}

vbnl_result vbnl_scene_measure_ray_rate(vbnl_context *ctx, const vbnl_scene *scene, uint32_t ray_count,
                                        uint32_t width, uint32_t height, double *rays_per_second,
                                        vbnl_error *err)
{
    if (!rays_per_second)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_measure_ray_rate: bad argument");
    vbnl_ray_rates r;
    vbnl_result res = vbnl_scene_measure_ray_rates(ctx, scene, ray_count, width, height, &r, err);
    if (res != VBNL_OK)
        return res;
    *rays_per_second = r.closest;
    return VBNL_OK;
}

double vbnl_ray_rates_mix(const vbnl_ray_rates *r, uint64_t camera_rays, uint64_t closest_rays,
                          uint64_t shadow_rays)
{
    if (!r)
        return 0.0;
    double t = 0.0;
    const uint64_t n[3] = {camera_rays, closest_rays, shadow_rays};
    const double rate[3] = {r->camera, r->closest, r->shadow};
    for (int k = 0; k < 3; ++k) {
        if (n[k] == 0)
            continue;
        if (!(rate[k] > 0.0))
            return 0.0;
        t += (double)n[k] / rate[k];
    }
    return t > 0.0 ? (double)(n[0] + n[1] + n[2]) / t : 0.0;
}
