/* Photon splitting, plainly (reference.h): the rules of splitting.h (Li et al. 2022, Section 3.3)
 * one photon hit at a time. */
#include <stdlib.h>
#include <string.h>

#include "reference.h"

typedef struct ref_vl {
    uint32_t id, rank;
    float w;
} ref_vl;

typedef struct ref_split {
    const vbi_split_desc *d;
    uint32_t n;         /* VLs */
    vec3 *center;       /* by rank */
    float *radius;      /* by rank */
    uint32_t *id;       /* by rank */
    ref_vl *vl;         /* scratch: the hit's VLs */
    vbi_split_stats *st;
} ref_split;

/* Keeps the max_vls VLs with the largest weights (ties: smaller id) among m, in their order. */
static uint32_t keep_largest(ref_vl *v, uint32_t m, uint32_t max_vls)
{
    while (m > max_vls) {
        uint32_t worst = 0;
        for (uint32_t i = 1; i < m; ++i)
            if (v[i].w < v[worst].w || (v[i].w == v[worst].w && v[i].id > v[worst].id))
                worst = i;
        memmove(v + worst, v + worst + 1, (m - worst - 1) * sizeof(*v));
        m--;
    }
    return m;
}

/* One photon hit: the rules 1 to 6 of splitting.h, then the exact split and the deposits. */
static void ref_visit(void *user, const vbi_photon_vertex *pv)
{
    ref_split *rs = user;
    const vbi_split_desc *d = rs->d;
    const vec3 p = pv->hit->p, n = pv->ng, wi = pv->wo;
    const vbi_vl_filter f = {n, wi, d->normal_cos, d->require_facing};
    ref_vl *v = rs->vl;
    /* 1, 2: the VLs that contain p and pass the filters, in rank order */
    uint32_t m = 0;
    for (uint32_t r = 0; r < rs->n; ++r) {
        double d2;
        if (!vbi_vl_contains(rs->center[r], rs->radius[r], p, &d2) ||
            !vbi_vl_filter_passes(&f, d->vl_normals[rs->id[r]]))
            continue;
        v[m++] = (ref_vl){rs->id[r], r, 1.0f - (float)d2 / (rs->radius[r] * rs->radius[r])};
    }
    /* 3: the VBI_SPLIT_QUERY_MAX smallest ids */
    if (m > VBI_SPLIT_QUERY_MAX) {
        rs->st->overflow++;
        while (m > VBI_SPLIT_QUERY_MAX) {
            uint32_t largest = 0;
            for (uint32_t i = 1; i < m; ++i)
                largest = v[i].id > v[largest].id ? i : largest;
            memmove(v + largest, v + largest + 1, (m - largest - 1) * sizeof(*v));
            m--;
        }
    }
    /* 4: positive weights */
    uint32_t k = 0;
    for (uint32_t i = 0; i < m; ++i)
        if (v[i].w > 0.0f)
            v[k++] = v[i];
    m = k;
    if (m == 0)
        return;
    /* 5: the support test: the material, then the height and the segment for the VLs whose
     * test has a height */
    if (d->support) {
        const uint32_t before = m;
        float tmax = 0.0f;
        k = 0;
        for (uint32_t i = 0; i < m; ++i) {
            const vbi_vl_support *s = &d->support[v[i].rank];
            if (s->material != pv->hit->material)
                continue;
            tmax = s->tau > tmax ? s->tau : tmax;
            v[k++] = v[i];
        }
        m = k;
        if (tmax > 0.0f) {
            const float hp = vbi_vl_support_height(d->scene, p, n, tmax);
            k = 0;
            for (uint32_t i = 0; i < m; ++i) {
                const float tau = d->support[v[i].rank].tau;
                if (tau > 0.0f && !vbi_vl_support_passes(d->scene, p, n, hp, rs->center[v[i].rank],
                                                          d->vl_normals[v[i].id], tau))
                    continue;
                v[k++] = v[i];
            }
            m = k;
            rs->st->support_tests++;
        }
        rs->st->support_rejects += before - m;
        if (m == 0)
            return;
    }
    /* 6: the max_vls largest weights */
    m = keep_largest(v, m, d->max_vls);
    /* the split: normalised weights (the sum in rank order), the quantised power, an exact
     * partition of each channel, one deposit per VL */
    float sum = 0.0f;
    for (uint32_t i = 0; i < m; ++i)
        sum += v[i].w;
    float w[VBI_SPLIT_MAX_VLS];
    for (uint32_t i = 0; i < m; ++i)
        w[i] = v[i].w / sum;
    uint64_t q[3];
    vbi_profile_quantize(d->profiles, pv->beta, q);
    if (!(q[0] | q[1] | q[2]))
        return;
    uint64_t share[3][VBI_SPLIT_MAX_VLS];
    for (int c = 0; c < 3; ++c)
        vbi_profile_split_fixed(q[c], m, w, share[c]);
    for (uint32_t i = 0; i < m; ++i) {
        const uint64_t s3[3] = {share[0][i], share[1][i], share[2][i]};
        vec3 wl = v3(0.0f, 0.0f, 1.0f); /* Lambertian VLs keep no direction */
        if (vbi_profile_is_glossy(d->profiles, v[i].id)) {
            frame fr = frame_from_normal(d->vl_normals[v[i].id]);
            wl = frame_to_local(&fr, wi);
        }
        vbi_profile_deposit_fixed(d->profiles, v[i].id, wl, s3);
    }
    rs->st->covered_hits++;
    rs->st->deposits += m;
    for (int c = 0; c < 3; ++c)
        rs->st->covered_power[c] += q[c];
}

/* The photon walk of photon_walk.h (vbi_photon_emit, then vbi_photon_scatter at every hit) with
 * each ray traced alone as an eight-wide packet: Embree's packet kernels, which splitting uses,
 * and its single-ray kernel (vbi_photon_walk) may round a hit differently in the last bit; a
 * ray's packet answer does not depend on the other lanes. */
static void ref_walk(const vbi_photon_walk_desc *w, vbi_rng *rng, ref_split *rs, vbi_photon_walk_stats *ws)
{
    vbi_photon_state ps;
    if (!vbi_photon_emit(w, rng, &ps))
        return;
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    _Alignas(32) int valid[8] = {-1, 0, 0, 0, 0, 0, 0, 0};
    for (;;) {
        _Alignas(32) struct RTCRayHit8 r8;
        for (uint32_t i = 0; i < 8; ++i)
            vbi_rayhit8_set(&r8, i, ps.o, ps.dir, INFINITY);
        rtcIntersect8(valid, w->scene->world, &ictx, &r8);
        ws->rays++;
        struct RTCRayHit rh;
        rh.ray.tfar = r8.ray.tfar[0];
        rh.hit.Ng_x = r8.hit.Ng_x[0];
        rh.hit.Ng_y = r8.hit.Ng_y[0];
        rh.hit.Ng_z = r8.hit.Ng_z[0];
        rh.hit.u = r8.hit.u[0];
        rh.hit.v = r8.hit.v[0];
        rh.hit.primID = r8.hit.primID[0];
        rh.hit.geomID = r8.hit.geomID[0];
        rh.hit.instID[0] = r8.hit.instID[0][0];
        vbi_hit hit;
        if (!vbi_photon_hit_from(w->scene, ps.o, ps.dir, &rh, &hit) ||
            !vbi_photon_scatter(w, rng, &ps, &hit, ref_visit, rs, ws))
            return;
    }
}

vbnl_result vbi_split_photons_reference(const vbi_split_desc *d, vbi_split_stats *stats)
{
    vbi_split_stats st;
    memset(&st, 0, sizeof(st));
    if (stats)
        memset(stats, 0, sizeof(*stats));
    if (!d || !d->scene || !d->scene->committed || !d->index || !d->vl_normals || !d->profiles ||
        d->photon_paths == 0 || d->first_path > d->photon_paths ||
        vbi_vl_index_count(d->index) != vbi_profile_set_count(d->profiles) || d->max_vls == 0 ||
        d->max_vls > VBI_SPLIT_MAX_VLS)
        return VBNL_ERR_INVALID_ARGUMENT;
    const uint64_t end = d->path_count ? d->first_path + d->path_count : d->photon_paths;
    if (end < d->first_path)
        return VBNL_ERR_INVALID_ARGUMENT;
    ref_split rs = {d, vbi_vl_index_count(d->index), NULL, NULL, NULL, NULL, &st};
    const size_t n1 = (size_t)rs.n + 1;
    rs.center = malloc(n1 * sizeof(vec3));
    rs.radius = malloc(n1 * sizeof(float));
    rs.id = malloc(n1 * sizeof(uint32_t));
    rs.vl = malloc(n1 * sizeof(ref_vl));
    vbnl_result res = rs.center && rs.radius && rs.id && rs.vl ? VBNL_OK : VBNL_ERR_OUT_OF_MEMORY;
    for (uint32_t r = 0; res == VBNL_OK && r < rs.n; ++r) {
        rs.id[r] = vbi_vl_index_id(d->index, r);
        rs.center[r] = vbi_vl_index_center(d->index, rs.id[r]);
        rs.radius[r] = vbi_vl_index_radius(d->index, rs.id[r]);
    }
    /* the walk of splitting.h: the authors' square-root roulette, the flux over all photon_paths */
    const vbi_photon_walk_desc w = {d->scene, (float)(1.0 / (double)d->photon_paths), d->rr_depth, d->max_depth, 1, 1};
    for (uint64_t k = d->first_path; res == VBNL_OK && k < end; ++k) {
        vbi_rng rng = vbi_rng_for(d->seed, k, 0);
        vbi_photon_walk_stats ws = {0, 0, 0};
        ref_walk(&w, &rng, &rs, &ws);
        st.paths++;
        st.rays += ws.rays;
        st.hits += ws.hits;
        st.delta_hits += ws.delta_hits;
    }
    free(rs.center);
    free(rs.radius);
    free(rs.id);
    free(rs.vl);
    if (stats && res == VBNL_OK)
        *stats = st;
    return res;
}
