/* Rich-VPL stage 1: the importon and photon maps (Simon et al. 2015, §4.1). */
#include <stdlib.h>
#include <string.h>

#include "richvsl.h"
#include "shading.h"
#include "photon_walk.h"

#define IMPORTON_STREAM 0x696d706f72746f6eull
#define PHOTON_STREAM 0x70686f746f6e6d61ull
#define IMP_CHUNK 4096u
#define PH_CHUNK 1024u
#define PH_BATCH 64u /* chunks per batch: the stopping point does not depend on threads */

void rv_maps_free(rv_maps *m)
{
    if (!m)
        return;
    vbi_kd_free(&m->imp_tree);
    vbi_kd_free(&m->ph_tree);
    free(m->imp_pts);
    free(m->imp_w);
    free(m->ph);
    free(m->ph_pts);
    memset(m, 0, sizeof(*m));
}

/* ---- importons ------------------------------------------------------------------------------ */

typedef struct imp_job {
    const vbnl_scene *sc;
    uint32_t width, height, ppp;
    uint64_t paths, seed;
    float inv_paths;
    vec3 *pos;
    float *w;
    uint8_t *valid;
} imp_job;

static void imp_chunk(void *user, uint64_t item, unsigned thread)
{
    (void)thread;
    imp_job *job = user;
    const vbnl_scene *sc = job->sc;
    uint64_t begin = item * IMP_CHUNK, end = begin + IMP_CHUNK < job->paths ? begin + IMP_CHUNK : job->paths;
    for (uint64_t k = begin; k < end; ++k) {
        job->valid[k] = 0;
        vbi_rng rng = vbi_rng_for(job->seed ^ IMPORTON_STREAM, k, 0);
        uint64_t pix = k / job->ppp;
        uint32_t px = (uint32_t)(pix % job->width), py = (uint32_t)(pix / job->width);
        vec2 u = vbi_rng_next2(&rng);
        vec3 o, d;
        vbi_camera_ray(&sc->camera, job->width, job->height, (float)px + u.x, (float)py + u.y, &o, &d);
        vec3 beta = v3s(1.0f);
        int shading_seen = 0, chain = 0;
        for (;;) {
            vbi_hit hit;
            if (!vbi_scene_intersect(sc, o, d, INFINITY, &hit))
                break;
            if (shading_seen) { /* x3: the importon (stored whatever the surface) */
                job->pos[k] = hit.p;
                job->w[k] = v3_avg(beta) * job->inv_paths;
                job->valid[k] = job->w[k] > 0.0f;
                break;
            }
            vbi_bsdf store;
            const vbi_bsdf *bsdf = vbi_surface_bsdf(sc, &hit, &store);
            int delta = vbi_bsdf_is_delta(bsdf);
            if (delta && ++chain > RV_MAX_SPECULAR_CHAIN)
                break;
            if (!delta)
                shading_seen = 1; /* x2: the shading point VPLs will light */
            vbi_shading_frame sf;
            vbi_shading_frame_make(bsdf, &hit, d, &sf);
            vbi_bsdf_sample_rec bs;
            vec2 ub = vbi_rng_next2(&rng);
            if (!vbi_bsdf_sample(bsdf, sf.wo, ub, &bs) || v3_is_black(bs.weight))
                break;
            vec3 w = frame_to_world(&sf.fr, bs.wi);
            if (!(bs.lobe & VBI_LOBE_TRANSMISSION) && v3_dot(w, sf.ng) <= 0.0f)
                break;
            beta = v3_mul(beta, bs.weight);
            if (!v3_is_finite(beta))
                break;
            o = vbi_offset_ray_origin(hit.p, hit.ng, w);
            d = w;
        }
    }
}

vbnl_result rv_trace_importons(const vbnl_scene *sc, uint32_t width, uint32_t height, uint32_t paths_per_pixel,
                               uint64_t seed, vbnl_stage_ctx *stage, vbi_pool *pool, rv_maps *m,
                               vbnl_error *err)
{
    imp_job job;
    memset(&job, 0, sizeof(job));
    job.sc = sc;
    job.width = width;
    job.height = height;
    job.ppp = paths_per_pixel;
    job.paths = (uint64_t)width * height * paths_per_pixel;
    job.seed = seed;
    job.inv_paths = 1.0f / (float)job.paths;
    if (job.paths == 0 || job.paths >= UINT32_MAX)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "integrator 'richvsl': %llu importon paths (%ux%u pixels x %u) must be between 1 "
                              "and 2^32 - 1",
                              (unsigned long long)job.paths, width, height, paths_per_pixel);
    job.pos = malloc(sizeof(vec3) * job.paths);
    job.w = malloc(sizeof(float) * job.paths);
    job.valid = malloc(job.paths);
    if (!job.pos || !job.w || !job.valid) {
        free(job.pos);
        free(job.w);
        free(job.valid);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory for %llu importon paths",
                              (unsigned long long)job.paths);
    }
    int rc = vbi_run_items(stage, pool, (job.paths + IMP_CHUNK - 1) / IMP_CHUNK, imp_chunk, &job);
    vbnl_result r = VBNL_OK;
    uint32_t n = 0;
    if (rc != 0) {
        r = vbnl_error_set(err, VBNL_ERR_CANCELLED, "importon tracing was cancelled");
    } else {
        for (uint64_t k = 0; k < job.paths; ++k)
            n += job.valid[k];
        if (n == 0)
            r = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                               "integrator 'richvsl': no camera path reached a surface after its first "
                               "non-specular bounce (nothing in view is lit indirectly)");
    }
    if (r == VBNL_OK) {
        m->imp_pts = malloc(sizeof(vbi_kd_pt) * n);
        m->imp_w = malloc(sizeof(float) * n);
        if (!m->imp_pts || !m->imp_w)
            r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory for %u importons", n);
    }
    if (r == VBNL_OK) {
        uint32_t j = 0;
        for (uint64_t k = 0; k < job.paths; ++k) {
            if (!job.valid[k])
                continue;
            m->imp_pts[j].p[0] = job.pos[k].x;
            m->imp_pts[j].p[1] = job.pos[k].y;
            m->imp_pts[j].p[2] = job.pos[k].z;
            m->imp_pts[j].id = j;
            m->imp_w[j] = job.w[k];
            ++j;
        }
        m->imp_count = n;
        m->imp_paths = job.paths;
        if (vbi_kd_build(&m->imp_tree, m->imp_pts, n) != 0)
            r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory for the importon tree");
    }
    free(job.pos);
    free(job.w);
    free(job.valid);
    return r;
}

/* ---- photons -------------------------------------------------------------------------------- */

typedef struct ph_buf {
    rv_photon *ph;
    uint32_t n, cap;
    int oom;
} ph_buf;

typedef struct ph_job {
    const vbnl_scene *sc;
    uint64_t seed, first_path;
    ph_buf *bufs; /* PH_BATCH of them */
} ph_job;

typedef struct ph_visit {
    ph_buf *b;
} ph_visit;

static void ph_store(void *user, const vbi_photon_vertex *v)
{
    ph_buf *b = ((ph_visit *)user)->b;
    if (b->n == b->cap) {
        uint32_t cap = b->cap ? 2 * b->cap : 256;
        rv_photon *p = realloc(b->ph, sizeof(rv_photon) * cap);
        if (!p) {
            b->oom = 1;
            return;
        }
        b->ph = p;
        b->cap = cap;
    }
    rv_photon *p = &b->ph[b->n++];
    p->hit = *v->hit;
    p->ng = v->ng;
    p->ns = v->ns;
    p->wi = v->wo;
    p->flux = v->beta; /* unnormalised (inv_paths = 1); divided by the path count at the end */
}

static void ph_chunk(void *user, uint64_t item, unsigned thread)
{
    (void)thread;
    ph_job *job = user;
    ph_buf *b = &job->bufs[item];
    b->n = 0;
    ph_visit pv = {b};
    /* plain Russian roulette (survival = sampled albedo) from the first bounce on */
    vbi_photon_walk_desc wd = {job->sc, 1.0f, 1, 0, 0, 0};
    for (uint64_t k = 0; k < PH_CHUNK; ++k) {
        uint64_t path = job->first_path + item * PH_CHUNK + k;
        vbi_rng rng = vbi_rng_for(job->seed ^ PHOTON_STREAM, path, 0);
        vbi_photon_walk_stats ws = {0, 0, 0};
        vbi_photon_walk(&wd, &rng, ph_store, &pv, &ws);
    }
}

vbnl_result rv_trace_photons(const vbnl_scene *sc, uint64_t target, uint64_t seed, vbnl_stage_ctx *stage,
                             vbi_pool *pool, rv_maps *m, vbnl_error *err)
{
    if (target == 0 || target >= UINT32_MAX / 2)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "integrator 'richvsl': %llu photons requested (1 .. 2^31)", (unsigned long long)target);
    if (sc->light_count == 0)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "integrator 'richvsl': the scene has no light");
    ph_job job;
    memset(&job, 0, sizeof(job));
    job.sc = sc;
    job.seed = seed;
    job.bufs = calloc(PH_BATCH, sizeof(ph_buf));
    rv_photon *all = NULL;
    uint64_t n = 0, cap = 0, paths = 0;
    /* a scene whose lights reach (almost) nothing: give up after this many paths */
    const uint64_t max_paths = target * 64 + (1u << 22);
    /* chunks per batch: PH_BATCH, fewer for small maps (a path leaves about one photon or more in
     * a closed scene), so that a map of a few thousand photons does not trace 65K paths; the
     * batch depends on the target only, so the stopping point does not depend on threads */
    const uint64_t batch = target / PH_CHUNK + 1 < PH_BATCH ? target / PH_CHUNK + 1 : PH_BATCH;
    vbnl_result r = job.bufs ? VBNL_OK : vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    while (r == VBNL_OK && n < target && paths < max_paths) {
        job.first_path = paths;
        if (vbi_run_items(stage, pool, batch, ph_chunk, &job) != 0) {
            r = vbnl_error_set(err, VBNL_ERR_CANCELLED, "photon tracing was cancelled");
            break;
        }
        paths += batch * PH_CHUNK;
        for (uint32_t b = 0; b < batch && r == VBNL_OK; ++b) {
            ph_buf *bf = &job.bufs[b];
            if (bf->oom) {
                r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory for the photon map");
                break;
            }
            if (n + bf->n > cap) {
                uint64_t nc = cap ? cap : 1u << 16;
                while (nc < n + bf->n)
                    nc *= 2;
                rv_photon *p = realloc(all, sizeof(rv_photon) * nc);
                if (!p) {
                    r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory for %llu photons",
                                       (unsigned long long)(n + bf->n));
                    break;
                }
                all = p;
                cap = nc;
            }
            memcpy(all + n, bf->ph, sizeof(rv_photon) * bf->n);
            n += bf->n;
        }
    }
    for (uint32_t b = 0; job.bufs && b < PH_BATCH; ++b)
        free(job.bufs[b].ph);
    free(job.bufs);
    if (r == VBNL_OK && n == 0)
        r = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                           "integrator 'richvsl': no photon reached a non-specular surface in %llu light paths",
                           (unsigned long long)paths);
    if (r == VBNL_OK && n >= UINT32_MAX)
        r = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "integrator 'richvsl': too many photons");
    if (r == VBNL_OK) {
        float inv = (float)(1.0 / (double)paths);
        m->ph_pts = malloc(sizeof(vbi_kd_pt) * n);
        if (!m->ph_pts)
            r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory for %llu photons", (unsigned long long)n);
        for (uint64_t i = 0; r == VBNL_OK && i < n; ++i) {
            all[i].flux = v3_scale(all[i].flux, inv);
            m->ph_pts[i].p[0] = all[i].hit.p.x;
            m->ph_pts[i].p[1] = all[i].hit.p.y;
            m->ph_pts[i].p[2] = all[i].hit.p.z;
            m->ph_pts[i].id = (uint32_t)i;
        }
    }
    if (r == VBNL_OK) {
        m->ph = all;
        m->ph_count = (uint32_t)n;
        m->ph_paths = paths;
        if (vbi_kd_build(&m->ph_tree, m->ph_pts, (uint32_t)n) != 0)
            r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory for the photon tree");
    } else {
        free(all);
    }
    return r;
}
