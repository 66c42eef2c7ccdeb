/* VBNL stage 1: placement of candidate virtual lights from the camera (§3.1). */
#include "placement.h"
#include "shading.h"

#include <stdlib.h>
#include <string.h>

#define CHUNK 4096u
#define PLACEMENT_STREAM 0x706c6163656d656eull /* keeps placement's random numbers apart */

typedef struct place_job {
    const vbnl_scene *scene;
    const vbi_placement_params *p;
    uint32_t tiles_x, tiles;
    vbi_candidate *cand;        /* one slot per path */
    uint8_t *valid;
    uint8_t *via_specular;
    vbi_thread_stats *tstats;
} place_job;

/* Samples the BSDF at a hit, with the frame conventions of the path tracer. Returns 0 when the
 * path ends here. */
static int scatter(const vbnl_scene *sc, const vbi_hit *hit, vec3 d, vbi_rng *rng, vec3 *wi_world,
                   uint32_t *lobe, vec3 *ng_out, vec3 *ns_out)
{
    vbi_bsdf bsdf_store;
    const vbi_bsdf *bsdf = vbi_surface_bsdf(sc, hit, &bsdf_store);
    vbi_shading_frame sf;
    vbi_shading_frame_make(bsdf, hit, d, &sf);
    vbi_bsdf_sample_rec bs;
    vec2 u = vbi_rng_next2(rng);
    if (!vbi_bsdf_sample(bsdf, sf.wo, u, &bs) || v3_is_black(bs.weight))
        return 0;
    *wi_world = frame_to_world(&sf.fr, bs.wi);
    if (!(bs.lobe & VBI_LOBE_TRANSMISSION) && v3_dot(*wi_world, sf.ng) <= 0.0f)
        return 0;
    *lobe = bs.lobe;
    *ng_out = sf.ng;
    *ns_out = sf.fr.n;
    return 1;
}

static void place_chunk(void *user, uint64_t item, unsigned thread)
{
    place_job *job = user;
    const vbnl_scene *sc = job->scene;
    const vbi_placement_params *p = job->p;
    vbi_thread_stats *ts = &job->tstats[thread];
    uint64_t begin = item * CHUNK, end = begin + CHUNK < p->count ? begin + CHUNK : p->count;
    for (uint64_t k = begin; k < end; ++k) {
        vbi_rng rng = vbi_rng_for(p->seed ^ PLACEMENT_STREAM, k, 0);
        /* round robin over the tiles; fewer candidates than tiles (small sets, the time budget's
         * calibration) are spread evenly over the image instead of filling its first rows */
        uint32_t tile = p->count >= job->tiles ? (uint32_t)(k % job->tiles) : (uint32_t)(k * job->tiles / p->count);
        uint32_t tx = tile % job->tiles_x, ty = tile / job->tiles_x;
        uint32_t x0 = tx * p->tile_size, y0 = ty * p->tile_size;
        uint32_t w = p->width - x0 < p->tile_size ? p->width - x0 : p->tile_size;
        uint32_t h = p->height - y0 < p->tile_size ? p->height - y0 : p->tile_size;
        vec2 u = vbi_rng_next2(&rng);
        vec3 o, d;
        vbi_camera_ray(&sc->camera, p->width, p->height, (float)x0 + u.x * (float)w,
                        (float)y0 + u.y * (float)h, &o, &d);
        job->valid[k] = 0;
        ts->samples++;
        /* Walk the camera path: pass through near-specular vertices; the first diffuse vertex is
         * the shading point, the next diffuse vertex is the candidate. */
        int diffuse_seen = 0;
        uint32_t chain = 0;
        for (;;) {
            vbi_hit hit;
            ts->rays++;
            if (!vbi_scene_intersect(sc, o, d, INFINITY, &hit))
                break;
            vec3 wi, ng, ns;
            uint32_t lobe;
            if (!scatter(sc, &hit, d, &rng, &wi, &lobe, &ng, &ns))
                break;
            vbi_bsdf bsdf_store;
        const vbi_bsdf *bsdf = vbi_surface_bsdf(sc, &hit, &bsdf_store);
            int pass = vbi_lobe_is_near_specular(bsdf, lobe, p->specular_roughness);
            if (pass) {
                if (chain >= p->max_specular_chain)
                    break; /* chain too long: neither a shading point nor a light on a mirror */
                chain++;
            } else if (!diffuse_seen) {
                diffuse_seen = 1;
            } else {
                vbi_candidate *c = &job->cand[k];
                c->p = hit.p;
                c->n = ns;
                c->material = vbi_surface_light_material(sc, &hit, &c->tint);
                c->tile = tile;
                job->valid[k] = 1;
                job->via_specular[k] = chain > 0;
                break;
            }
            o = vbi_offset_ray_origin(hit.p, hit.ng, wi);
            d = wi;
        }
    }
}

vbnl_result vbi_place_candidates(const vbnl_scene *scene, const vbi_placement_params *p,
                                  vbnl_stage_ctx *stage, vbi_pool *pool, vbi_candidate **out,
                                  uint32_t *out_count, vbi_placement_stats *stats, vbnl_error *err)
{
    if (!scene || !p || !out || !out_count)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbi_place_candidates: NULL argument");
    if (p->count == 0 || p->tile_size == 0 || p->width == 0 || p->height == 0)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "placement needs candidates > 0, tile_size > 0 and an image size");
    *out = NULL;
    *out_count = 0;
    place_job job;
    memset(&job, 0, sizeof(job));
    job.scene = scene;
    job.p = p;
    job.tiles_x = (p->width + p->tile_size - 1) / p->tile_size;
    job.tiles = job.tiles_x * ((p->height + p->tile_size - 1) / p->tile_size);
    unsigned threads = vbi_run_thread_count(stage, pool);
    job.cand = malloc(sizeof(vbi_candidate) * p->count);
    job.valid = malloc(p->count);
    job.via_specular = calloc(p->count, 1);
    job.tstats = calloc(threads, sizeof(vbi_thread_stats));
    if (!job.cand || !job.valid || !job.via_specular || !job.tstats) {
        free(job.cand);
        free(job.valid);
        free(job.via_specular);
        free(job.tstats);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory for %u candidates (%.1f MB)",
                              p->count, (double)p->count * sizeof(vbi_candidate) / 1e6);
    }
    uint64_t chunks = (p->count + CHUNK - 1) / CHUNK;
    int rc = vbi_run_items(stage, pool, chunks, place_chunk, &job);
    vbi_placement_stats st;
    memset(&st, 0, sizeof(st));
    for (unsigned t = 0; t < threads; ++t) {
        st.paths += job.tstats[t].samples;
        st.rays += job.tstats[t].rays;
    }
    /* Compact in path order: the result does not depend on the thread count. */
    uint32_t n = 0;
    for (uint32_t k = 0; k < p->count && rc == 0; ++k) {
        if (!job.valid[k])
            continue;
        st.through_specular += job.via_specular[k];
        job.cand[n++] = job.cand[k];
    }
    st.candidates = n;
    free(job.valid);
    free(job.via_specular);
    free(job.tstats);
    if (stats)
        *stats = st;
    if (rc != 0) {
        free(job.cand);
        return vbnl_error_set(err, VBNL_ERR_CANCELLED, "candidate placement was cancelled");
    }
    if (n == 0) {
        free(job.cand);
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "no camera path reached a second diffuse surface: nothing in view "
                              "is lit indirectly (open scene or camera looking at the sky?)");
    }
    vbi_candidate *shrunk = realloc(job.cand, sizeof(vbi_candidate) * n);
    *out = shrunk ? shrunk : job.cand;
    *out_count = n;
    return VBNL_OK;
}
