/* Rich-VPL stage 2: placement by importance (§4.1) and relaxation (§4.2). */
#include <stdlib.h>
#include <string.h>

#include "richvsl.h"
#include "sampling.h"

#define PLACE_STREAM 0x706c6163655f7273ull
#define W_CHUNK 2048u

/* ---- importance at the photons -------------------------------------------------------------- */

typedef struct w_job {
    const rv_maps *m;
    uint32_t K;
    float *W;
} w_job;

static void w_chunk(void *user, uint64_t item, unsigned thread)
{
    (void)thread;
    w_job *job = user;
    const rv_maps *m = job->m;
    uint32_t idx[RV_KNN_MAX];
    float d2[RV_KNN_MAX];
    uint32_t begin = (uint32_t)item * W_CHUNK;
    uint32_t end = begin + W_CHUNK < m->ph_count ? begin + W_CHUNK : m->ph_count;
    for (uint32_t i = begin; i < end; ++i) {
        const float q[3] = {m->ph[i].hit.p.x, m->ph[i].hit.p.y, m->ph[i].hit.p.z};
        uint32_t n = vbi_kd_knn(&m->imp_tree, q, job->K, UINT32_MAX, idx, d2);
        double dK2 = n ? d2[n - 1] : 0.0, sum = 0.0;
        if (n < 2 || !(dK2 > 0.0)) {
            job->W[i] = 0.0f;
            continue;
        }
        /* 2D Epanechnikov kernel normalised over the disk of radius d_K: 2 / (pi d_K^2) */
        for (uint32_t k = 0; k < n; ++k)
            sum += m->imp_w[m->imp_tree.pts[idx[k]].id] * (1.0 - d2[k] / dK2);
        job->W[i] = (float)(sum * 2.0 / (VBI_PI * dK2));
    }
}

vbnl_result rv_importance_at_photons(const rv_maps *m, uint32_t K, vbnl_stage_ctx *stage, vbi_pool *pool,
                                     float *W, double *W_mean, vbnl_error *err)
{
    if (K < 2 || K > RV_KNN_MAX)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "importance neighbours must be in 2 .. %u",
                              RV_KNN_MAX);
    w_job job = {m, K, W};
    if (vbi_run_items(stage, pool, (m->ph_count + W_CHUNK - 1) / W_CHUNK, w_chunk, &job) != 0)
        return vbnl_error_set(err, VBNL_ERR_CANCELLED, "importance estimation was cancelled");
    double sum = 0.0;
    for (uint32_t i = 0; i < m->ph_count; ++i)
        sum += W[i];
    *W_mean = m->ph_count ? sum / m->ph_count : 0.0;
    return VBNL_OK;
}

/* ---- Bernoulli trials ----------------------------------------------------------------------- */

vbnl_result rv_place(const float *W, uint32_t n, double q, double W_mean, uint64_t seed, uint32_t **ids,
                     float **p_rs, uint32_t *count, vbnl_error *err)
{
    *ids = NULL;
    *p_rs = NULL;
    *count = 0;
    uint32_t cap = 1024, c = 0;
    uint32_t *id = malloc(sizeof(uint32_t) * cap);
    float *pr = malloc(sizeof(float) * cap);
    if (!id || !pr) {
        free(id);
        free(pr);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    }
    for (uint32_t i = 0; i < n; ++i) {
        double p = rv_p_rs(W[i], q, W_mean);
        vbi_rng rng = vbi_rng_for(seed ^ PLACE_STREAM, i, 0);
        if (!(p > 0.0) || (double)vbi_rng_next(&rng) >= p)
            continue;
        if (c == cap) {
            cap *= 2;
            uint32_t *ni = realloc(id, sizeof(uint32_t) * cap);
            if (ni)
                id = ni;
            float *np = ni ? realloc(pr, sizeof(float) * cap) : NULL;
            if (!np) {
                free(id);
                free(pr);
                return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
            }
            pr = np;
        }
        id[c] = i;
        pr[c] = (float)p;
        ++c;
    }
    *ids = id;
    *p_rs = pr;
    *count = c;
    return VBNL_OK;
}

/* ---- relaxation ----------------------------------------------------------------------------- */

typedef struct relax_job {
    const vbi_kd_tree *photons;
    const vec3 *pos;              /* photon positions by photon id */
    vbi_kd_tree lights;          /* over the current positions */
    uint32_t *ids;                /* photon of each light (written: the snapped photon) */
    uint32_t *next;
    uint32_t count, K;
} relax_job;

#define RELAX_CHUNK 256u

static void relax_chunk(void *user, uint64_t item, unsigned thread)
{
    (void)thread;
    relax_job *job = user;
    uint32_t idx[RV_KNN_MAX];
    float d2[RV_KNN_MAX];
    uint32_t begin = (uint32_t)item * RELAX_CHUNK;
    uint32_t end = begin + RELAX_CHUNK < job->count ? begin + RELAX_CHUNK : job->count;
    for (uint32_t li = begin; li < end; ++li) {
        /* local index of light li in the light tree: pts are permuted, so look it up by id */
        vec3 xp = job->pos[job->ids[li]];
        const float x[3] = {xp.x, xp.y, xp.z};
        uint32_t n = vbi_kd_knn(&job->lights, x, job->K + 2, UINT32_MAX, idx, d2);
        /* drop the light itself (distance 0 to its own point; a twin on the same photon stays) */
        for (uint32_t k = 0; k < n; ++k)
            if (job->lights.pts[idx[k]].id == li) {
                memmove(idx + k, idx + k + 1, sizeof(uint32_t) * (n - k - 1));
                memmove(d2 + k, d2 + k + 1, sizeof(float) * (n - k - 1));
                --n;
                break;
            }
        if (n < job->K + 1) {
            job->next[li] = job->ids[li];
            continue;
        }
        float d = sqrtf(d2[job->K]); /* the (K+1)-th neighbour */
        float eps = 1e-4f * d;
        float dx[3] = {0.0f, 0.0f, 0.0f};
        for (uint32_t k = 0; k < job->K; ++k) {
            const float *y = job->lights.pts[idx[k]].p;
            float dist = sqrtf(d2[k]);
            if (!(dist > 0.0f)) {
                /* A twin on the same photon (two lights snapped to one): the formula gives no
                 * push, so the twins would move together forever. Each takes a step of length d
                 * along its own direction, hashed from its index (deterministic). */
                vbi_rng rr = vbi_rng_make(li, 0x7477696eu);
                vec3 u = sample_uniform_sphere(vbi_rng_next2(&rr));
                dx[0] += u.x * d;
                dx[1] += u.y * d;
                dx[2] += u.z * d;
                continue;
            }
            float s = d / (dist + eps) - 1.0f;
            for (int c = 0; c < 3; ++c)
                dx[c] += (x[c] - y[c]) * s;
        }
        float q[3];
        for (int c = 0; c < 3; ++c)
            q[c] = x[c] + dx[c] / (float)job->K;
        /* snap to the nearest photon (keeps the light on a surface) */
        uint32_t pi;
        float pd2;
        if (vbi_kd_knn(job->photons, q, 1, UINT32_MAX, &pi, &pd2) == 1)
            job->next[li] = job->photons->pts[pi].id;
        else
            job->next[li] = job->ids[li];
    }
}

vbnl_result rv_relax(const vbi_kd_tree *photon_tree, const vec3 *photon_pos, uint32_t *ids, uint32_t count,
                     uint32_t K, uint32_t iterations, vbnl_stage_ctx *stage, vbi_pool *pool, vbnl_error *err)
{
    if (K == 0 || K + 2 > RV_KNN_MAX)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "relaxation neighbours must be in 1 .. %u",
                              RV_KNN_MAX - 2);
    if (count < K + 2 || iterations == 0)
        return VBNL_OK;
    relax_job job;
    memset(&job, 0, sizeof(job));
    job.photons = photon_tree;
    job.pos = photon_pos;
    job.ids = ids;
    job.count = count;
    job.K = K;
    vbi_kd_pt *pts = malloc(sizeof(vbi_kd_pt) * count);
    job.next = malloc(sizeof(uint32_t) * count);
    vbnl_result r = pts && job.next ? VBNL_OK : vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    for (uint32_t it = 0; it < iterations && r == VBNL_OK; ++it) {
        for (uint32_t i = 0; i < count; ++i) {
            vec3 p = photon_pos[ids[i]];
            pts[i].p[0] = p.x;
            pts[i].p[1] = p.y;
            pts[i].p[2] = p.z;
            pts[i].id = i;
        }
        if (vbi_kd_build(&job.lights, pts, count) != 0) {
            r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
            break;
        }
        if (vbi_run_items(stage, pool, (count + RELAX_CHUNK - 1) / RELAX_CHUNK, relax_chunk, &job) != 0)
            r = vbnl_error_set(err, VBNL_ERR_CANCELLED, "relaxation was cancelled");
        vbi_kd_free(&job.lights);
        if (r == VBNL_OK) /* Jacobi step: every light moved from the same old positions */
            memcpy(ids, job.next, sizeof(uint32_t) * count);
    }
    free(pts);
    free(job.next);
    return r;
}
