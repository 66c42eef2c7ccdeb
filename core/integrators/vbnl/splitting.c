/* Photon splitting (Li et al. 2022, Section 3.3): photon paths from the lights, every hit's
 * power shared among the virtual lights around it. Design and rules: splitting.h. */
#include "splitting.h"

#include <stdlib.h>
#include <string.h>

/* Per-thread counters on their own cache lines. */
typedef struct split_thread {
    _Alignas(64) vbnl_split_stats s; /* sizeof is a multiple of 64 (aligned_alloc needs it) */
} split_thread;

typedef struct split_job {
    const vbnl_split_desc *d;
    uint64_t begin, end;     /* global path range */
    uint32_t chunk, max_vls;
    float inv_paths;
    split_thread *threads;
    unsigned thread_count;
} split_job;

void vbnl_split_desc_init(vbnl_split_desc *d)
{
    memset(d, 0, sizeof(*d));
    d->normal_cos = 0.7f;
    d->require_facing = 1;
    d->max_vls = 8;
    d->rr_depth = 5;
    d->max_depth = 0;
    d->chunk = VBNL_SPLIT_DEFAULT_CHUNK;
}

double vbnl_split_photon_unit(const vbnl_scene *scene, uint64_t photon_paths)
{
    double total = 0.0;
    for (uint32_t i = 0; i < scene->light_count; ++i)
        total += v3_max_comp(vbnl_light_power(&scene->lights[i]));
    return vbnl_profile_unit_for_power(photon_paths ? total / (double)photon_paths : 0.0);
}

/* ---- one hit: share the photon among the VLs around it ------------------------------------- */

/* p: hit point; n: unit geometric normal facing the arriving photon; wi: unit direction toward
 * where the photon came from; power: the photon's flux. */
static void split_hit(const split_job *job, vbnl_split_stats *st, vec3 p, vec3 n, vec3 wi, vec3 power)
{
    const vbnl_split_desc *d = job->d;
    uint32_t ids[VBNL_SPLIT_QUERY_MAX];
    float d2[VBNL_SPLIT_QUERY_MAX];
    vbnl_vl_filter flt = {n, wi, d->normal_cos, d->require_facing};
    uint32_t total = vbnl_vl_index_query_filtered(d->index, p, &flt, VBNL_SPLIT_QUERY_MAX, ids, d2);
    if (!total)
        return;
    uint32_t found = total < VBNL_SPLIT_QUERY_MAX ? total : VBNL_SPLIT_QUERY_MAX;
    st->overflow += total > VBNL_SPLIT_QUERY_MAX;
    /* The weights 1 - (d/r)^2 (Section 3.3) of the VLs that passed the authors' filters. */
    uint32_t keep_id[VBNL_SPLIT_QUERY_MAX];
    float keep_w[VBNL_SPLIT_QUERY_MAX];
    uint32_t m = 0;
    for (uint32_t k = 0; k < found; ++k) {
        float r = vbnl_vl_index_radius(d->index, ids[k]);
        float w = 1.0f - d2[k] / (r * r);
        if (!(w > 0.0f)) /* d within rounding of r */
            continue;
        keep_id[m] = ids[k];
        keep_w[m] = w;
        ++m;
    }
    if (!m)
        return;
    /* The max_vls largest weights (ids ascend, so a stable selection breaks ties by id). */
    if (m > job->max_vls) {
        for (uint32_t a = 0; a < job->max_vls; ++a) {
            uint32_t best = a;
            for (uint32_t b = a + 1; b < m; ++b)
                if (keep_w[b] > keep_w[best] || (keep_w[b] == keep_w[best] && keep_id[b] < keep_id[best]))
                    best = b;
            uint32_t ti = keep_id[a];
            float tw = keep_w[a];
            keep_id[a] = keep_id[best];
            keep_w[a] = keep_w[best];
            keep_id[best] = ti;
            keep_w[best] = tw;
        }
        m = job->max_vls;
    }
    float sum = 0.0f;
    for (uint32_t k = 0; k < m; ++k)
        sum += keep_w[k];
    for (uint32_t k = 0; k < m; ++k)
        keep_w[k] /= sum;
    /* Quantise once, then partition exactly (profiles.h, "Fixed point"). */
    uint64_t q[3], share[3][VBNL_SPLIT_MAX_VLS];
    vbnl_profile_quantize(d->profiles, power, q);
    if (!(q[0] | q[1] | q[2]))
        return;
    for (int c = 0; c < 3; ++c)
        vbnl_profile_split_fixed(q[c], m, keep_w, share[c]);
    for (uint32_t k = 0; k < m; ++k) {
        uint64_t s3[3] = {share[0][k], share[1][k], share[2][k]};
        vec3 wl = v3(0.0f, 0.0f, 1.0f); /* Lambertian VLs keep no direction */
        if (vbnl_profile_is_glossy(d->profiles, keep_id[k])) {
            frame f = frame_from_normal(d->vl_normals[keep_id[k]]);
            wl = frame_to_local(&f, wi);
        }
        vbnl_profile_deposit_fixed(d->profiles, keep_id[k], wl, s3);
    }
    st->covered_hits++;
    st->deposits += m;
    for (int c = 0; c < 3; ++c)
        st->covered_power[c] += q[c];
}

/* ---- one photon path ------------------------------------------------------------------------ */

void vbnl_photon_walk(const vbnl_photon_walk_desc *w, vbnl_rng *rng, vbnl_photon_visit_fn visit, void *user,
                      vbnl_photon_walk_stats *st)
{
    const vbnl_scene *sc = w->scene;
    float pmf;
    uint32_t li = vbnl_scene_pick_light(sc, vbnl_rng_next(rng), &pmf);
    vec2 u_pos = vbnl_rng_next2(rng), u_dir = vbnl_rng_next2(rng);
    vbnl_light_le_sample les;
    if (!(pmf > 0.0f) || !vbnl_light_sample_le(&sc->lights[li], u_pos, u_dir, &les))
        return;
    float den = pmf * les.pdf_pos * les.pdf_dir;
    if (!(den > 0.0f))
        return;
    /* Flux of the photon: Le |cos| / (p_j pdf_pos pdf_dir) / N (lights.h). */
    vec3 beta = v3_scale(les.Le, les.cos_at_light / den * w->inv_paths);
    if (!v3_is_finite(beta) || v3_is_black(beta))
        return;
    vec3 o = vbnl_offset_ray_origin(les.p, les.n, les.dir), dir = les.dir;
    int max_depth = w->max_depth > 0 && w->max_depth < VBNL_SPLIT_SAFETY_DEPTH ? w->max_depth
                                                                              : VBNL_SPLIT_SAFETY_DEPTH;
    for (int depth = 0; depth < max_depth; ++depth) {
        vbnl_hit hit;
        st->rays++;
        if (!vbnl_scene_intersect(sc, o, dir, INFINITY, &hit))
            return;
        st->hits++;
        vbnl_bsdf bsdf_store;
        const vbnl_bsdf *bsdf = vbnl_surface_bsdf(sc, &hit, &bsdf_store);
        vec3 wo_w = v3_neg(dir); /* toward where the photon came from */
        vec3 ng = hit.ng, ns = hit.ns;
        int transmissive = vbnl_bsdf_is_transmissive(bsdf);
        if (!transmissive) { /* two-sided opaque surface: frame facing the photon (path.c) */
            if (v3_dot(ng, wo_w) < 0.0f) {
                ng = v3_neg(ng);
                ns = v3_neg(ns);
            }
            if (v3_dot(ns, wo_w) <= 0.0f)
                ns = ng;
        }
        if (vbnl_bsdf_is_delta(bsdf)) {
            st->delta_hits++;
        } else {
            vbnl_photon_vertex v = {&hit, bsdf, ng, ns, wo_w, beta, depth};
            visit(user, &v);
        }

        /* Bounce (importance transport, splitting.h). */
        frame fr = frame_from_normal(ns);
        vec3 wo = frame_to_local(&fr, wo_w);
        vbnl_bsdf_sample_rec bs;
        float ulobe = vbnl_rng_next(rng);
        vec2 ub = vbnl_rng_next2(rng);
        if (!vbnl_bsdf_sample(bsdf, wo, ulobe, ub, &bs) || v3_is_black(bs.weight))
            return;
        vec3 wi_w = frame_to_world(&fr, bs.wi);
        if (!(bs.lobe & VBNL_LOBE_TRANSMISSION) && v3_dot(wi_w, ng) <= 0.0f)
            return; /* a reflection must leave on the photon's side of the real surface */
        vec3 wt = bs.weight;
        if (bs.lobe & VBNL_LOBE_TRANSMISSION)
            wt = v3_scale(wt, bs.eta * bs.eta); /* flux is not compressed by refraction */
        /* Adjoint shading-normal correction (Veach 1997, Eq. 5.17); 1 when ns == ng. */
        float den_c = v3_absdot(wo_w, ng) * v3_absdot(wi_w, ns);
        if (den_c > 0.0f)
            wt = v3_scale(wt, v3_absdot(wo_w, ns) * v3_absdot(wi_w, ng) / den_c);
        vec3 nb = v3_mul(beta, wt);
        if (depth + 1 >= w->rr_depth) {
            /* VBNL authors' rule: continue with q = sqrt(max(new) / max(old)); the plain rule
             * (q = max(new) / max(old), the sampled albedo) otherwise; at most 1. */
            float ratio = v3_max_comp(nb) / v3_max_comp(beta);
            float q = fminf(1.0f, w->rr_sqrt ? sqrtf(ratio) : ratio);
            if (!(q > 0.0f) || vbnl_rng_next(rng) >= q)
                return;
            nb = v3_scale(nb, 1.0f / q);
        }
        if (!v3_is_finite(nb) || v3_is_black(nb))
            return;
        beta = nb;
        o = vbnl_offset_ray_origin(hit.p, hit.ng, wi_w);
        dir = wi_w;
    }
}

typedef struct split_visit {
    const split_job *job;
    vbnl_split_stats *st;
} split_visit;

static void split_visit_fn(void *user, const vbnl_photon_vertex *v)
{
    split_visit *sv = user;
    split_hit(sv->job, sv->st, v->hit->p, v->ng, v->wo, v->beta);
}

static void trace_photon(const split_job *job, vbnl_split_stats *st, uint64_t k)
{
    const vbnl_split_desc *d = job->d;
    vbnl_rng rng = vbnl_rng_for(d->seed, k, 0);
    st->paths++;
    vbnl_photon_walk_desc w = {d->scene, job->inv_paths, d->rr_depth, d->max_depth, 1};
    vbnl_photon_walk_stats ws = {0, 0, 0};
    split_visit sv = {job, st};
    vbnl_photon_walk(&w, &rng, split_visit_fn, &sv, &ws);
    st->rays += ws.rays;
    st->hits += ws.hits;
    st->delta_hits += ws.delta_hits;
}

/* vbnl_pool_run with poll == NULL never moves its wake-up time forward once it has passed and
 * then spins on pthread_cond_timedwait (pool.c); a no-op poll keeps the caller asleep. */
static int no_poll(void *user, uint64_t finished, uint64_t count)
{
    (void)user;
    (void)finished;
    (void)count;
    return 0;
}

static void run_chunk(void *user, uint64_t item, unsigned thread)
{
    const split_job *job = user;
    vbnl_split_stats *st = &job->threads[thread < job->thread_count ? thread : 0].s;
    uint64_t b = job->begin + item * job->chunk;
    uint64_t e = b + job->chunk < job->end ? b + job->chunk : job->end;
    for (uint64_t k = b; k < e; ++k)
        trace_photon(job, st, k);
}

vbnl_result vbnl_split_photons(const vbnl_split_desc *d, vbnl_pool *pool, vbnl_stage_ctx *stage,
                               vbnl_split_stats *stats)
{
    if (stats)
        memset(stats, 0, sizeof(*stats));
    if (!d || !d->scene || !d->scene->committed || !d->index || !d->vl_normals || !d->profiles ||
        (!vbnl_vl_index_has_normals(d->index) && (d->normal_cos > -1.0f || d->require_facing)) ||
        (!pool && !stage) || d->photon_paths == 0 || d->first_path > d->photon_paths ||
        vbnl_vl_index_count(d->index) != vbnl_profile_set_count(d->profiles) || d->max_vls == 0 ||
        d->max_vls > VBNL_SPLIT_MAX_VLS)
        return VBNL_ERR_INVALID_ARGUMENT;
    double t0 = vbnl_now();
    split_job job;
    memset(&job, 0, sizeof(job));
    job.d = d;
    job.begin = d->first_path;
    job.end = d->path_count ? d->first_path + d->path_count : d->photon_paths;
    if (job.end < job.begin)
        return VBNL_ERR_INVALID_ARGUMENT;
    job.chunk = d->chunk ? d->chunk : VBNL_SPLIT_DEFAULT_CHUNK;
    job.max_vls = d->max_vls;
    job.inv_paths = (float)(1.0 / (double)d->photon_paths);
    job.thread_count = stage ? vbnl_stage_thread_count(stage) : vbnl_pool_thread_count(pool);
    if (job.thread_count == 0)
        job.thread_count = 1;
    job.threads = aligned_alloc(64, sizeof(split_thread) * job.thread_count);
    if (!job.threads)
        return VBNL_ERR_OUT_OF_MEMORY;
    memset(job.threads, 0, sizeof(split_thread) * job.thread_count);
    uint64_t items = (job.end - job.begin + job.chunk - 1) / job.chunk;
    vbnl_result res = VBNL_OK;
    if (items) {
        if (stage) {
            if (vbnl_stage_run(stage, items, run_chunk, &job) != 0)
                res = VBNL_ERR_CANCELLED;
        } else {
            vbnl_pool_run(pool, items, run_chunk, &job, no_poll, NULL, 1.0);
        }
    }
    if (stats) {
        for (unsigned t = 0; t < job.thread_count; ++t) {
            const vbnl_split_stats *s = &job.threads[t].s;
            stats->paths += s->paths;
            stats->rays += s->rays;
            stats->hits += s->hits;
            stats->delta_hits += s->delta_hits;
            stats->covered_hits += s->covered_hits;
            stats->deposits += s->deposits;
            stats->overflow += s->overflow;
            for (int c = 0; c < 3; ++c)
                stats->covered_power[c] += s->covered_power[c];
        }
        stats->seconds = vbnl_now() - t0;
    }
    free(job.threads);
    return res;
}
