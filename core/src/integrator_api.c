/* The public integrator ABI's tile jobs and scene queries (vbnl/integrator.h): thin wrappers of the
 * functions the core's own integrators call inline. */
#include <string.h>

#include "render_internal.h"

_Static_assert(sizeof(vbi_sampler) <= sizeof(vbnl_sample_stream), "vbnl_sample_stream holds a vbi_sampler");
_Static_assert(_Alignof(vbi_sampler) <= _Alignof(vbnl_sample_stream), "vbnl_sample_stream aligns a vbi_sampler");

void vbnl_tile_job_rect(const vbnl_tile_job *job, uint32_t *x0, uint32_t *y0, uint32_t *x1, uint32_t *y1)
{
    *x0 = job->x0;
    *y0 = job->y0;
    *x1 = job->x1;
    *y1 = job->y1;
}

void vbnl_tile_job_samples(const vbnl_tile_job *job, uint32_t *begin, uint32_t *end)
{
    *begin = job->sample_begin;
    *end = job->sample_end;
}

unsigned vbnl_tile_job_thread(const vbnl_tile_job *job) { return job->thread; }

void vbnl_tile_job_stream(const vbnl_tile_job *job, uint32_t x, uint32_t y, uint32_t sample,
                          vbnl_sample_stream *out)
{
    const vbi_sampler sp = vbi_pixel_sampler(job, x, y, sample);
    memset(out, 0, sizeof(*out));
    memcpy(out, &sp, sizeof(sp));
}

float vbnl_sample_stream_next(vbnl_sample_stream *s)
{
    vbi_sampler sp;
    memcpy(&sp, s, sizeof(sp));
    const float u = vbi_sampler_next(&sp);
    memcpy(s, &sp, sizeof(sp));
    return u;
}

void vbnl_tile_job_camera_ray(const vbnl_tile_job *job, float px, float py, float origin[3], float direction[3])
{
    vec3 o, d;
    vbi_camera_ray(&job->scene->camera, job->width, job->height, px, py, &o, &d);
    v3_store(origin, o);
    v3_store(direction, d);
}

void vbnl_tile_job_add_sample(vbnl_tile_job *job, uint32_t x, uint32_t y, const float *record)
{
    vbi_film_add(job->film, x, y, record);
}

void vbnl_tile_job_count_rays(vbnl_tile_job *job, uint64_t rays) { job->stats->rays += rays; }

int vbnl_scene_trace_ray(const vbnl_scene *scene, const float origin[3], const float direction[3], float tmax,
                         vbnl_surface_hit *hit)
{
    vbi_hit h;
    if (!vbi_scene_intersect(scene, v3_load(origin), v3_load(direction), tmax, &h))
        return 0;
    hit->t = h.t;
    v3_store(hit->position, h.p);
    v3_store(hit->geometric_normal, h.ng);
    v3_store(hit->shading_normal, h.ns);
    hit->uv[0] = h.uv.x;
    hit->uv[1] = h.uv.y;
    hit->material = h.material;
    return 1;
}

int vbnl_scene_ray_occluded(const vbnl_scene *scene, const float origin[3], const float direction[3], float tmax)
{
    return vbi_scene_occluded(scene, v3_load(origin), v3_load(direction), tmax);
}

void vbnl_scene_offset_origin(const float position[3], const float normal[3], const float direction[3],
                              float origin[3])
{
    v3_store(origin, vbi_offset_ray_origin(v3_load(position), v3_load(normal), v3_load(direction)));
}

vbnl_result vbnl_scene_get_material(const vbnl_scene *scene, uint32_t id, vbnl_material_desc *out, vbnl_error *err)
{
    if (!scene || !out)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_get_material: NULL argument");
    if (id >= scene->material_count)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_get_material: no material %u (%u added)",
                              id, scene->material_count);
    *out = scene->materials[id].desc;
    return VBNL_OK;
}
