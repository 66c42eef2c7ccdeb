/* The software pipeline of the VL index's batch queries (vl_index.h, vbi_vl_index_query_batch),
 * shared by vl_index_batch.c and photon splitting (splitting.c), which runs it with its own stage
 * D fused with the deposit. Private to those files. */
#ifndef VBI_VL_INDEX_PIPE_H
#define VBI_VL_INDEX_PIPE_H

#include "vl_index_internal.h"

/* ---- batched queries: a software pipeline over the points ------------------------------------
 * Point k goes through four stages, VBI_VLI_PIPE_STEP points apart: (A) its cells are located and their
 * headers fetched; (B) the cells' entries are fetched; (C) the quantised pre-test picks the
 * candidates and fetches their records (and the caller's per-rank data); (D) the exact test,
 * then the callback. Each stage finds in cache what the previous one fetched, so the four
 * dependent memory accesses of a query overlap with the work on other points. The answers are
 * the sets of vbi_vl_index_query_found: the candidates of (C) are a superset of the containing
 * spheres; (D) keeps them in candidate order (an id sort costs a third of the stage in branch
 * misses) unless the answer is capped. */
#define VBI_VLI_PIPE_STEP 4u
#define VBI_VLI_PIPE_SLOTS 16u     /* >= 3 VBI_VLI_PIPE_STEP + 1, a power of two */
#define VBI_VLI_PIPE_LEVELS 4u     /* indexes with more levels use plain queries */
#define VBI_VLI_PIPE_CAND 128u     /* more candidates: the point gets a plain query */

typedef struct vbi_vli_pipe_slot {
    uint32_t cell[VBI_VLI_PIPE_LEVELS];
    int32_t c3[VBI_VLI_PIPE_LEVELS][3];
    uint32_t s0[VBI_VLI_PIPE_LEVELS], n[VBI_VLI_PIPE_LEVELS];
    uint32_t ncand;
    uint32_t cand[VBI_VLI_PIPE_CAND];
} vbi_vli_pipe_slot;

static inline const char *vbi_vli_batch_rec(const vbi_vl_batch *b, uint32_t k)
{
    return (const char *)b->base + (size_t)(b->order ? b->order[k] : k) * b->stride;
}

static inline vec3 vbi_vli_batch_vec(const vbi_vl_batch *b, uint32_t k, size_t off)
{
    vec3 v;
    memcpy(&v, vbi_vli_batch_rec(b, k) + off, sizeof(v));
    return v;
}

/* The stages take the level count `nl` as an argument so that the single-level case (uniform
 * radii, the common one) is compiled without the loops over levels. */
static inline __attribute__((always_inline)) void vbi_vli_pipe_a(const vbi_vl_index *x, vec3 p, vbi_vli_pipe_slot *s, uint32_t nl)
{
    for (uint32_t L = 0; L < nl; ++L)
        s->cell[L] = vbi_vli_locate(&x->levels[L], p, s->c3[L]);
}

static inline __attribute__((always_inline)) void vbi_vli_pipe_b(const vbi_vl_index *x, vbi_vli_pipe_slot *s, uint32_t nl)
{
    for (uint32_t L = 0; L < nl; ++L)
        vbi_vli_fetch(&x->levels[L], s->cell[L], &s->s0[L], &s->n[L]);
}

static inline __attribute__((always_inline)) void vbi_vli_pipe_c(const vbi_vl_index *x, const vbi_vl_batch *b, vec3 p,
                                                         vbi_vli_pipe_slot *s, uint32_t nl)
{
    uint32_t nc = 0;
    const char *rd = b->rank_data;
    for (uint32_t L = 0; L < nl; ++L) {
        const grid_level *g = &x->levels[L];
        if (!s->n[L])
            continue;
        float q[3];
        cell_frame(g, p, s->c3[L], q);
        VBI_VLI_PRETEST(g, s->s0[L], s->n[L], q, {
            if (nc < VBI_VLI_PIPE_CAND) {
                __builtin_prefetch(x->rec + rank_);
                if (rd)
                    __builtin_prefetch(rd + (size_t)rank_ * b->rank_stride);
                s->cand[nc] = rank_;
            }
            ++nc;
        });
    }
    s->ncand = nc;
}

/* Plain query of point k (no pipeline) for the batch. */
static inline void vbi_vli_batch_plain(const vbi_vl_index *x, const vbi_vl_batch *b, uint32_t k, vbi_vl_found *found,
                        vbi_vl_batch_fn fn, void *user)
{
    vbi_vl_filter fl = {vbi_vli_batch_vec(b, k, b->n_off), vbi_vli_batch_vec(b, k, b->wi_off), b->normal_cos, b->facing};
    uint32_t total = vbi_vl_index_query_found(x, vbi_vli_batch_vec(b, k, b->p_off), b->filter ? &fl : NULL, b->max_out, found);
    fn(user, k, total, found, total < b->max_out ? total : b->max_out);
}

/* The pipeline over the batch's points with stage D = D(x, b, k, slot, found, user) (a function
 * or an inline one, which is then compiled into the loop: photon splitting's fused stage D). */
#define VBI_VLI_RUN_PIPE(x, b, found, D, user, nl)                                                             \
    do {                                                                                                       \
        vbi_vli_pipe_slot ring_[VBI_VLI_PIPE_SLOTS];                                                         \
        const uint32_t m_ = VBI_VLI_PIPE_SLOTS - 1, count_ = (b)->count, S_ = VBI_VLI_PIPE_STEP;              \
        for (uint32_t k_ = 0; k_ < count_ + 3 * S_; ++k_) {                                                    \
            if (k_ + S_ < count_) {                                                                            \
                const char *r_ = vbi_vli_batch_rec((b), k_ + S_);                                             \
                __builtin_prefetch(r_);                                                                        \
                __builtin_prefetch(r_ + (b)->stride - 1);                                                      \
            }                                                                                                  \
            if (k_ < count_)                                                                                   \
                vbi_vli_pipe_a((x), vbi_vli_batch_vec((b), k_, (b)->p_off), &ring_[k_ & m_], (nl));          \
            if (k_ >= S_ && k_ - S_ < count_)                                                                  \
                vbi_vli_pipe_b((x), &ring_[(k_ - S_) & m_], (nl));                                            \
            if (k_ >= 2 * S_ && k_ - 2 * S_ < count_)                                                          \
                vbi_vli_pipe_c((x), (b), vbi_vli_batch_vec((b), k_ - 2 * S_, (b)->p_off),                    \
                                &ring_[(k_ - 2 * S_) & m_], (nl));                                             \
            if (k_ >= 3 * S_)                                                                                  \
                D((x), (b), k_ - 3 * S_, &ring_[(k_ - 3 * S_) & m_], (found), (user));                         \
        }                                                                                                      \
    } while (0)

#endif
