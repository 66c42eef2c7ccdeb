#include "shading.h"

#include <string.h>

void vbi_render_camera_paths(vbnl_tile_job *job, uint32_t stride, vbi_camera_path_fn fn, void *state)
{
    const vbnl_scene *sc = job->scene;
    vbnl_film *film = job->film;
    const uint32_t tw = job->x1 - job->x0;
    const uint32_t npix = tw * (job->y1 - job->y0);
    float values[8][VBNL_FILM_MAX_CHANNELS];
    for (uint32_t smp = job->sample_begin; smp < job->sample_end; ++smp) {
        /* pixel of the packet's first lane, stepped along the tile's rows (no divisions) */
        uint32_t x = job->x0, y = job->y0;
        for (uint32_t base = 0; base < npix; base += 8) {
            int active[8], hit_mask[8], seen[8];
            vec3 o[8], d[8];
            vbi_hit hits[8];
            vbi_sampler sp[8];
            uint32_t px[8], py[8];
            const uint32_t lanes = npix - base < 8 ? npix - base : 8;
            for (uint32_t i = 0; i < 8; ++i) {
                active[i] = i < lanes;
                if (!active[i]) {
                    o[i] = d[i] = v3s(0.0f);
                    continue;
                }
                px[i] = x;
                py[i] = y;
                if (++x == job->x1) {
                    x = job->x0;
                    ++y;
                }
                sp[i] = vbi_pixel_sampler(job, px[i], py[i], smp);
                vec2 u = vbi_sampler_next2(&sp[i]);
                /* a thin lens takes the sample's second pair of numbers (a pinhole camera none), and
                 * so does a mesh camera with several rays per pixel, to pick one */
                const int lens_numbers = sc->camera.lens_radius > 0.0f ||
                                         (sc->camera.projection == VBNL_CAMERA_MESH && sc->camera.mesh_rays_per_pixel > 1);
                vec2 lens = lens_numbers ? vbi_sampler_next2(&sp[i]) : (vec2){0.5f, 0.5f};
                seen[i] = vbi_camera_ray_lens(&sc->camera, job->width, job->height, (float)px[i] + u.x,
                                               (float)py[i] + u.y, lens, &o[i], &d[i]);
                active[i] = seen[i];
            }
            vbi_scene_intersect8_mask(sc, active, o, d, sc->has_masks ? VBI_RAY_CAMERA : VBI_RAY_ANY, hits,
                                       hit_mask);
            job->stats->rays += lanes;
            job->stats->camera_rays += lanes;
            for (uint32_t i = 0; i < lanes; ++i) {
                memset(values[i], 0, sizeof(float) * stride);
                /* where the projection has no ray the sample stays transparent black; elsewhere its
                 * alpha is the camera ray's coverage (POV-Ray's Output_Alpha) */
                if (seen[i]) {
                    fn(state, &sp[i], o[i], d[i], hit_mask[i], &hits[i], values[i], job->stats);
                    values[i][3] = sc->background_alpha >= 1.0f ||
                                           (hit_mask[i] && !sc->has_media && !sc->has_null &&
                                           !vbi_bsdf_is_transmissive(&sc->materials[hits[i].material].bsdf) &&
                                           !sc->materials[hits[i].material].varies)
                                       ? 1.0f
                                       : vbi_camera_alpha(sc, o[i], d[i], hit_mask[i], &hits[i], &sp[i]);
                }
                vbi_film_add(film, px[i], py[i], values[i]);
            }
        }
    }
}
