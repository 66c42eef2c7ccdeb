/* Rich-VPL stage 3: emission profiles ("enrich", Simon et al. 2015, §5). */
#include <stdlib.h>
#include <string.h>

#include "richvsl.h"

void rv_lights_free(rv_lights *l)
{
    if (!l)
        return;
    free(l->photon);
    free(l->p);
    free(l->n);
    free(l->ng);
    free(l->p_rs);
    free(l->radius);
    free(l->gather_r);
    free(l->gathered);
    free(l->intensity);
    free(l->table);
    free(l->lambert);
    free(l->sampled);
    memset(l, 0, sizeof(*l));
}

vec3 rv_lambert_intensity(const vbi_bsdf *bsdf, vec3 n, const rv_gathered *g, uint32_t count)
{
    frame f = frame_from_normal(n);
    const vec3 up = v3(0.0f, 0.0f, 1.0f);
    vec3 sum = v3s(0.0f);
    for (uint32_t j = 0; j < count; ++j) {
        vec3 wi = frame_to_local(&f, g[j].wi);
        if (wi.z <= 1e-4f)
            continue; /* arrives from below the light's horizon */
        /* f_r = eval / cos(theta_i); Lambertian: rho / pi whatever the directions */
        vec3 fr = v3_scale(vbi_bsdf_eval(bsdf, up, wi), 1.0f / wi.z);
        sum = v3_add(sum, v3_mul(fr, g[j].flux));
    }
    return sum;
}

void rv_emission_table(const vbi_hemioct *map, const vbi_hemioct *incident_map, const vbi_bsdf *bsdf, vec3 n,
                       const rv_gathered *g, uint32_t count, float *rgb)
{
    const uint32_t T = vbi_hemioct_texel_count(map);
    const uint32_t B = vbi_hemioct_texel_count(incident_map);
    memset(rgb, 0, sizeof(float) * 3 * T);
    float inc[3 * RV_INCIDENT_RES * RV_INCIDENT_RES];
    if (B > RV_INCIDENT_RES * RV_INCIDENT_RES)
        return;
    memset(inc, 0, sizeof(float) * 3 * B);
    frame f = frame_from_normal(n);
    /* 1. the incident flux, binned by direction (bilinear splat: the bins receive it all) */
    for (uint32_t j = 0; j < count; ++j) {
        vec3 wi = frame_to_local(&f, g[j].wi);
        if (wi.z <= 1e-4f)
            continue;
        vbi_hemioct_splat(incident_map, inc, wi, g[j].flux);
    }
    /* 2. reflected by the BSDF at the light toward every texel centre:
     *    I(w_t) = sum_b f_r(w_b -> w_t) E_b, f_r = eval(w_t, w_b) / cos(theta_b) */
    const vec3 *in_dirs = vbi_hemioct_texel_dirs(incident_map);
    const vec3 *out_dirs = vbi_hemioct_texel_dirs(map);
    for (uint32_t b = 0; b < B; ++b) {
        vec3 E = v3(inc[3 * b], inc[3 * b + 1], inc[3 * b + 2]);
        vec3 wb = in_dirs[b];
        if (v3_is_black(E) || wb.z <= 0.0f)
            continue;
        float inv_cos = 1.0f / wb.z;
        for (uint32_t t = 0; t < T; ++t) {
            vec3 fr = vbi_bsdf_eval(bsdf, out_dirs[t], wb);
            rgb[3 * t] += fr.x * inv_cos * E.x;
            rgb[3 * t + 1] += fr.y * inv_cos * E.y;
            rgb[3 * t + 2] += fr.z * inv_cos * E.z;
        }
    }
}

void rv_emission_table_sampled(const vbi_hemioct *map, const vbi_bsdf *bsdf, vec3 n, const rv_gathered *g,
                               uint32_t count, uint32_t samples, vbi_rng *rng, float *rgb)
{
    const uint32_t T = vbi_hemioct_texel_count(map);
    memset(rgb, 0, sizeof(float) * 3 * T);
    frame f = frame_from_normal(n);
    const float inv_s = 1.0f / (float)samples;
    for (uint32_t j = 0; j < count; ++j) {
        vec3 wi = frame_to_local(&f, g[j].wi);
        int below = wi.z <= 1e-4f;
        for (uint32_t k = 0; k < samples; ++k) {
            /* fixed use of the stream per sample */
            vec2 u = vbi_rng_next2(rng);
            vbi_bsdf_sample_rec bs;
            if (below || !vbi_bsdf_sample(bsdf, wi, u, &bs) || bs.wi.z <= 0.0f || v3_is_black(bs.weight))
                continue;
            vbi_hemioct_splat(map, rgb, bs.wi, v3_scale(v3_mul(g[j].flux, bs.weight), inv_s));
        }
    }
    const float *C = vbi_hemioct_bilinear_projected(map);
    for (uint32_t t = 0; t < T; ++t)
        for (int c = 0; c < 3; ++c)
            rgb[3 * t + c] = C[t] > 0.0f ? rgb[3 * t + c] / C[t] : 0.0f;
}

/* ---- every light ---------------------------------------------------------------------------- */

typedef struct em_job {
    const vbnl_scene *sc;
    const rv_maps *m;
    const vbi_hemioct *map, *incident;
    const rv_emission_params *ep;
    rv_lights *l;
    vbi_kd_tree lights;
    uint32_t *idx;   /* per thread, RV_GATHER_MAX + 1 each */
    float *d2;
    rv_gathered *g;
} em_job;

#define EM_CHUNK 64u
#define EMISSION_STREAM 0x656d697373696f6eull

static void em_light(em_job *job, uint32_t li, uint32_t *idx, float *d2, rv_gathered *g)
{
    const rv_maps *m = job->m;
    rv_lights *l = job->l;
    const float q[3] = {l->p[li].x, l->p[li].y, l->p[li].z};
    /* gather radius: distance to the second-closest other light */
    uint32_t li_idx[4];
    float li_d2[4];
    uint32_t n = vbi_kd_knn(&job->lights, q, 3, UINT32_MAX, li_idx, li_d2);
    uint32_t others = 0;
    float r2 = INFINITY;
    for (uint32_t k = 0; k < n; ++k) {
        if (job->lights.pts[li_idx[k]].id == li)
            continue;
        if (++others == 2) {
            r2 = li_d2[k];
            break;
        }
    }
    uint32_t found = r2 < INFINITY ? vbi_kd_radius(&m->ph_tree, q, r2, idx, d2, RV_GATHER_MAX) : RV_GATHER_MAX + 1;
    if (found > RV_GATHER_MAX) {
        /* too many (or no second light): the RV_GATHER_MAX nearest, kernel radius = the farthest */
        found = vbi_kd_knn(&m->ph_tree, q, RV_GATHER_MAX, UINT32_MAX, idx, d2);
        r2 = found ? d2[found - 1] * (1.0f + 1e-6f) : 0.0f;
    }
    /* the photon the light sits on is always inside (d = 0) */
    const rv_photon *self = &m->ph[l->photon[li]];
    double wsum = 0.0;
    uint32_t c = 0;
    for (uint32_t k = 0; k < found; ++k) {
        const rv_photon *ph = &m->ph[m->ph_tree.pts[idx[k]].id];
        if (v3_dot(ph->ng, self->ng) <= RV_NORMAL_COS)
            continue;
        float w = r2 > 0.0f ? 1.0f - d2[k] / r2 : 1.0f;
        if (!(w > 0.0f))
            continue;
        g[c].wi = ph->wi;
        g[c].flux = v3_scale(ph->flux, w);
        wsum += w;
        ++c;
    }
    float scale = wsum > 0.0 ? (float)(1.0 / (wsum * l->p_rs[li])) : 0.0f;
    for (uint32_t k = 0; k < c; ++k)
        g[k].flux = v3_scale(g[k].flux, scale);
    l->gather_r[li] = sqrtf(r2);
    l->gathered[li] = c;
    vbi_bsdf store;
    const vbi_bsdf *bsdf = vbi_surface_bsdf(job->sc, &self->hit, &store);
    if (l->lambert[li])
        l->intensity[li] = rv_lambert_intensity(bsdf, l->n[li], g, c);
    else if (l->sampled[li]) {
        vbi_rng rng = vbi_rng_for(job->ep->seed ^ EMISSION_STREAM, li, 0);
        rv_emission_table_sampled(job->map, bsdf, l->n[li], g, c, job->ep->samples, &rng,
                                  l->table + (size_t)li * 3 * vbi_hemioct_texel_count(job->map));
    } else
        rv_emission_table(job->map, job->incident, bsdf, l->n[li], g, c,
                          l->table + (size_t)li * 3 * vbi_hemioct_texel_count(job->map));
}

static void em_chunk(void *user, uint64_t item, unsigned thread)
{
    em_job *job = user;
    size_t o = (size_t)thread * (RV_GATHER_MAX + 1);
    uint32_t begin = (uint32_t)item * EM_CHUNK;
    uint32_t end = begin + EM_CHUNK < job->l->count ? begin + EM_CHUNK : job->l->count;
    for (uint32_t li = begin; li < end; ++li)
        em_light(job, li, job->idx + o, job->d2 + o, job->g + o);
}

vbnl_result rv_build_emission(const vbnl_scene *sc, const rv_maps *m, const vbi_hemioct *map,
                              const rv_emission_params *ep, rv_lights *l, vbnl_stage_ctx *stage, vbi_pool *pool,
                              vbnl_error *err)
{
    em_job job;
    memset(&job, 0, sizeof(job));
    job.sc = sc;
    job.m = m;
    job.map = map;
    job.ep = ep;
    job.l = l;
    const uint32_t n = l->count;
    l->sampled = calloc(n ? n : 1, 1);
    if (!l->sampled)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    for (uint32_t i = 0; i < n; ++i) {
        if (l->lambert[i])
            continue;
        vbi_bsdf store;
        const vbi_bsdf *b = vbi_surface_bsdf(sc, &m->ph[l->photon[i]].hit, &store);
        l->sampled[i] = b->type == VBNL_MATERIAL_CONDUCTOR && b->alpha < ep->sampled_alpha && ep->samples > 0;
    }
    vbi_hemioct *incident = NULL;
    vbi_kd_pt *pts = malloc(sizeof(vbi_kd_pt) * (n ? n : 1));
    uint32_t glossy = 0;
    for (uint32_t i = 0; i < n; ++i)
        glossy += !l->lambert[i];
    const size_t T = vbi_hemioct_texel_count(map);
    l->res = vbi_hemioct_res(map);
    l->gather_r = malloc(sizeof(float) * (n ? n : 1));
    l->gathered = malloc(sizeof(uint32_t) * (n ? n : 1));
    l->intensity = calloc(n ? n : 1, sizeof(vec3));
    /* tables for every light index, so a light's row is found without an extra index; the rows of
     * Lambertian lights are never touched (untouched calloc pages cost no memory) */
    l->table = glossy ? calloc((size_t)n * 3 * T, sizeof(float)) : NULL;
    size_t per = (size_t)vbi_run_thread_count(stage, pool) * (RV_GATHER_MAX + 1);
    job.idx = malloc(sizeof(uint32_t) * per);
    job.d2 = malloc(sizeof(float) * per);
    job.g = malloc(sizeof(rv_gathered) * per);
    if (!job.idx || !job.d2 || !job.g || !pts || !l->gather_r || !l->gathered || !l->intensity || (glossy && !l->table)) {
        free(pts);
        free(job.idx);
        free(job.d2);
        free(job.g);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory for the emission of %u lights (%.1f MB)",
                              n, (double)glossy * 12.0 * T / 1e6);
    }
    if (vbi_hemioct_create(RV_INCIDENT_RES, &incident) != VBNL_OK) {
        free(pts);
        free(job.idx);
        free(job.d2);
        free(job.g);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    }
    job.incident = incident;
    for (uint32_t i = 0; i < n; ++i) {
        pts[i].p[0] = l->p[i].x;
        pts[i].p[1] = l->p[i].y;
        pts[i].p[2] = l->p[i].z;
        pts[i].id = i;
    }
    vbnl_result r = VBNL_OK;
    if (vbi_kd_build(&job.lights, pts, n) != 0)
        r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    else if (vbi_run_items(stage, pool, (n + EM_CHUNK - 1) / EM_CHUNK, em_chunk, &job) != 0)
        r = vbnl_error_set(err, VBNL_ERR_CANCELLED, "emission was cancelled");
    vbi_kd_free(&job.lights);
    vbi_hemioct_destroy(incident);
    free(pts);
    free(job.idx);
    free(job.d2);
    free(job.g);
    return r;
}
