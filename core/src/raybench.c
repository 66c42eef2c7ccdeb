/* The raw Embree ray rate of a scene: the ceiling integrators are measured against. */
#include <stdlib.h>
#include <string.h>

#include "context.h"
#include "rng.h"
#include "sampling.h"
#include "scene_internal.h"

#define CHUNK 4096u

typedef struct ray_set {
    const vbnl_scene *scene;
    vec3 *o, *d;
    uint32_t count;
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
    for (uint32_t i = begin; i < end; ++i) {
        struct RTCRayHit rh;
        rh.ray.org_x = rs->o[i].x;
        rh.ray.org_y = rs->o[i].y;
        rh.ray.org_z = rs->o[i].z;
        rh.ray.dir_x = rs->d[i].x;
        rh.ray.dir_y = rs->d[i].y;
        rh.ray.dir_z = rs->d[i].z;
        rh.ray.tnear = 0.0f;
        rh.ray.tfar = INFINITY;
        rh.ray.time = 0.0f;
        rh.ray.mask = 0xffffffffu;
        rh.ray.id = 0;
        rh.ray.flags = 0;
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(rs->scene->world, &ictx, &rh);
        hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
    }
    rs->hits[thread & 255u] += hits;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

vbnl_result vbnl_scene_measure_ray_rate(vbnl_context *ctx, const vbnl_scene *scene, uint32_t ray_count,
                                        uint32_t width, uint32_t height, double *rays_per_second,
                                        vbnl_error *err)
{
    if (!ctx || !scene || !rays_per_second || ray_count == 0 || width == 0 || height == 0)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_measure_ray_rate: bad argument");
    if (!scene->committed)
        return vbnl_error_set(err, VBNL_ERR_STATE, "vbnl_scene_measure_ray_rate: scene not committed");
    ray_set rs;
    memset(&rs, 0, sizeof(rs));
    rs.scene = scene;
    rs.o = malloc(sizeof(vec3) * ray_count);
    rs.d = malloc(sizeof(vec3) * ray_count);
    if (!rs.o || !rs.d) {
        free(rs.o);
        free(rs.d);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory for %u rays", ray_count);
    }
    vbnl_rng rng = vbnl_rng_make(0x5eed, 7);
    uint32_t n = 0;
    for (uint64_t attempt = 0; n < ray_count && attempt < (uint64_t)ray_count * 16; ++attempt) {
        vec3 o, d;
        vbnl_camera_ray(&scene->camera, width, height, vbnl_rng_next(&rng) * width,
                        vbnl_rng_next(&rng) * height, &o, &d);
        vbnl_hit h;
        if (!vbnl_scene_intersect(scene, o, d, INFINITY, &h))
            continue;
        vec3 nrm = v3_dot(h.ng, d) < 0.0f ? h.ng : v3_neg(h.ng);
        frame f = frame_from_normal(nrm);
        vec3 w = frame_to_world(&f, sample_cosine_hemisphere(vbnl_rng_next2(&rng)));
        rs.o[n] = vbnl_offset_ray_origin(h.p, nrm, w);
        rs.d[n] = w;
        ++n;
    }
    if (n == 0) {
        free(rs.o);
        free(rs.d);
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "the camera sees no geometry");
    }
    rs.count = n;
    uint64_t chunks = (n + CHUNK - 1) / CHUNK;
    double t[3];
    for (int rep = 0; rep < 3; ++rep) {
        double t0 = vbnl_now();
        vbnl_pool_run(ctx->pool, chunks, trace_chunk, &rs, NULL, NULL, 1.0);
        t[rep] = vbnl_now() - t0;
    }
    qsort(t, 3, sizeof(double), cmp_double);
    *rays_per_second = t[1] > 0.0 ? (double)n / t[1] : 0.0;
    free(rs.o);
    free(rs.d);
    return VBNL_OK;
}
