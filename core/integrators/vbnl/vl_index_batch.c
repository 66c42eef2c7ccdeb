/* Pipelined batch queries of the VL sphere index (vl_index.h, vbi_vl_index_query_batch), for
 * photon splitting's sorted batches of hits (Li et al. 2022, Section 3.3). */
#include "vl_index_pipe.h"

typedef struct pipe_user {
    vbi_vl_batch_fn fn;
    void *user;
} pipe_user;

/* Stage D: the exact test and the filter on the candidates, the same decisions as test_rec_exact
 * and passes, with the filter in registers. Falls back to the plain query when the answer would
 * be capped (more than max_out spheres, rare) or the candidates overflowed. */
static void pipe_d(const vbi_vl_index *x, const vbi_vl_batch *b, uint32_t k, const vbi_vli_pipe_slot *s,
                   vbi_vl_found *found, const pipe_user *pu)
{
    vbi_vl_batch_fn fn = pu->fn;
    void *user = pu->user;
    if (s->ncand > VBI_VLI_PIPE_CAND) {
        vbi_vli_batch_plain(x, b, k, found, fn, user);
        return;
    }
    const char *rec_k = vbi_vli_batch_rec(b, k);
    vec3 p, n = v3s(0.0f), wi = v3s(0.0f);
    memcpy(&p, rec_k + b->p_off, sizeof(p));
    const int filter = b->filter && x->has_normals;
    const int use_cos = filter && b->normal_cos > -1.0f, use_facing = filter && b->facing;
    const float ncos = b->normal_cos;
    if (filter) {
        memcpy(&n, rec_k + b->n_off, sizeof(n));
        memcpy(&wi, rec_k + b->wi_off, sizeof(wi));
    }
    uint32_t m = 0, max_out = b->max_out;
    for (uint32_t i = 0; i < s->ncand; ++i) {
        uint32_t rank = s->cand[i];
        const vl_rec *e = x->rec + rank;
        double d2;
        if (!vbi_vli_accept(e, p, use_cos, n, ncos, use_facing, wi, &d2))
            continue;
        const float r = e->r;
        if (m == max_out) { /* capped: the plain query keeps the max_out smallest ids */
            vbi_vli_batch_plain(x, b, k, found, fn, user);
            return;
        }
        found[m++] = (vbi_vl_found){e->id, rank, (float)d2, r};
    }
    fn(user, k, m, found, m); /* in candidate (rank) order: see vl_index.h */
}

void vbi_vl_index_query_batch(const vbi_vl_index *x, const vbi_vl_batch *b, vbi_vl_batch_fn fn, void *user)
{
    vbi_vl_found found[VBI_VL_BATCH_MAX_OUT];
    uint32_t count = b->count;
    if (x->kind != VBI_VL_INDEX_GRID) {
        for (uint32_t k = 0; k < count; ++k)
            vbi_vli_batch_plain(x, b, k, found, fn, user);
        return;
    }
    if (x->level_count > VBI_VLI_PIPE_LEVELS) {
        for (uint32_t k = 0; k < count; ++k)
            vbi_vli_batch_plain(x, b, k, found, fn, user);
        return;
    }
    /* the single-level case (uniform radii, the common one) without the loops over levels */
    const pipe_user pu = {fn, user};
    if (x->level_count == 1)
        VBI_VLI_RUN_PIPE(x, b, found, pipe_d, &pu, 1u);
    else
        VBI_VLI_RUN_PIPE(x, b, found, pipe_d, &pu, x->level_count);
}
