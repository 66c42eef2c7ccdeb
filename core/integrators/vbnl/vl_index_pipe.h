/* The software pipeline of the VL index's batch queries (vl_index.h, vbnl_vl_index_query_batch),
 * shared by vl_index_batch.c and photon splitting (splitting.c), which runs it with its own stage
 * D fused with the deposit. Private to those files. */
#ifndef VBNL_VL_INDEX_PIPE_H
#define VBNL_VL_INDEX_PIPE_H

#include "vl_index_internal.h"

/* ---- batched queries: a software pipeline over the points ------------------------------------
 * Point k goes through four stages, VBNL_VLI_PIPE_STEP points apart: (A) its cells are located and their
 * headers fetched; (B) the cells' entries are fetched; (C) the quantised pre-test picks the
 * candidates and fetches their records (and the caller's per-rank data); (D) the exact test,
 * then the callback. Each stage finds in cache what the previous one fetched, so the four
 * dependent memory accesses of a query overlap with the work on other points. The answers are
 * the sets of vbnl_vl_index_query_found: the candidates of (C) are a superset of the containing
 * spheres; (D) keeps them in candidate order (an id sort costs a third of the stage in branch
 * misses) unless the answer is capped. */
#define VBNL_VLI_PIPE_STEP 4u
#define VBNL_VLI_PIPE_SLOTS 16u     /* >= 3 VBNL_VLI_PIPE_STEP + 1, a power of two */
#define VBNL_VLI_PIPE_LEVELS 4u     /* indexes with more levels use plain queries */
#define VBNL_VLI_PIPE_CAND 128u     /* more candidates: the point gets a plain query */

typedef struct vbnl_vli_pipe_slot {
    uint32_t cell[VBNL_VLI_PIPE_LEVELS];
    int32_t c3[VBNL_VLI_PIPE_LEVELS][3];
    uint32_t s0[VBNL_VLI_PIPE_LEVELS], n[VBNL_VLI_PIPE_LEVELS];
    uint32_t ncand;
    uint32_t cand[VBNL_VLI_PIPE_CAND];
} vbnl_vli_pipe_slot;

static inline const char *vbnl_vli_batch_rec(const vbnl_vl_batch *b, uint32_t k)
{
    return (const char *)b->base + (size_t)(b->order ? b->order[k] : k) * b->stride;
}

static inline vec3 vbnl_vli_batch_vec(const vbnl_vl_batch *b, uint32_t k, size_t off)
{
    vec3 v;
    memcpy(&v, vbnl_vli_batch_rec(b, k) + off, sizeof(v));
    return v;
}

/* The stages take the level count `nl` as an argument so that the single-level case (uniform
 * radii, the common one) is compiled without the loops over levels. */
static inline __attribute__((always_inline)) void vbnl_vli_pipe_a(const vbnl_vl_index *x, vec3 p, vbnl_vli_pipe_slot *s, uint32_t nl)
{
    for (uint32_t L = 0; L < nl; ++L)
        s->cell[L] = vbnl_vli_locate(&x->levels[L], p, s->c3[L]);
}

static inline __attribute__((always_inline)) void vbnl_vli_pipe_b(const vbnl_vl_index *x, vbnl_vli_pipe_slot *s, uint32_t nl)
{
    for (uint32_t L = 0; L < nl; ++L)
        vbnl_vli_fetch(&x->levels[L], s->cell[L], &s->s0[L], &s->n[L]);
}

static inline __attribute__((always_inline)) void vbnl_vli_pipe_c(const vbnl_vl_index *x, const vbnl_vl_batch *b, vec3 p,
                                                         vbnl_vli_pipe_slot *s, uint32_t nl)
{
    uint32_t nc = 0;
    const char *rd = b->rank_data;
    for (uint32_t L = 0; L < nl; ++L) {
        const grid_level *g = &x->levels[L];
        if (!s->n[L])
            continue;
        float q[3];
        cell_frame(g, p, s->c3[L], q);
        VBNL_VLI_PRETEST(g, s->s0[L], s->n[L], q, {
            if (nc < VBNL_VLI_PIPE_CAND) {
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
static inline void vbnl_vli_batch_plain(const vbnl_vl_index *x, const vbnl_vl_batch *b, uint32_t k, vbnl_vl_found *found,
                        vbnl_vl_batch_fn fn, void *user)
{
    vbnl_vl_filter fl = {vbnl_vli_batch_vec(b, k, b->n_off), vbnl_vli_batch_vec(b, k, b->wi_off), b->normal_cos, b->facing};
    uint32_t total = vbnl_vl_index_query_found(x, vbnl_vli_batch_vec(b, k, b->p_off), b->filter ? &fl : NULL, b->max_out, found);
    fn(user, k, total, found, total < b->max_out ? total : b->max_out);
}

/* The pipeline over the batch's points with stage D = D(x, b, k, slot, found, user) (a function
 * or an inline one, which is then compiled into the loop: photon splitting's fused stage D). */
#define VBNL_VLI_RUN_PIPE(x, b, found, D, user, nl)                                                             \
    do {                                                                                                       \
        vbnl_vli_pipe_slot ring_[VBNL_VLI_PIPE_SLOTS];                                                         \
        const uint32_t m_ = VBNL_VLI_PIPE_SLOTS - 1, count_ = (b)->count, S_ = VBNL_VLI_PIPE_STEP;              \
        for (uint32_t k_ = 0; k_ < count_ + 3 * S_; ++k_) {                                                    \
            if (k_ + S_ < count_) {                                                                            \
                const char *r_ = vbnl_vli_batch_rec((b), k_ + S_);                                             \
                __builtin_prefetch(r_);                                                                        \
                __builtin_prefetch(r_ + (b)->stride - 1);                                                      \
            }                                                                                                  \
            if (k_ < count_)                                                                                   \
                vbnl_vli_pipe_a((x), vbnl_vli_batch_vec((b), k_, (b)->p_off), &ring_[k_ & m_], (nl));          \
            if (k_ >= S_ && k_ - S_ < count_)                                                                  \
                vbnl_vli_pipe_b((x), &ring_[(k_ - S_) & m_], (nl));                                            \
            if (k_ >= 2 * S_ && k_ - 2 * S_ < count_)                                                          \
                vbnl_vli_pipe_c((x), (b), vbnl_vli_batch_vec((b), k_ - 2 * S_, (b)->p_off),                    \
                                &ring_[(k_ - 2 * S_) & m_], (nl));                                             \
            if (k_ >= 3 * S_)                                                                                  \
                D((x), (b), k_ - 3 * S_, &ring_[(k_ - 3 * S_) & m_], (found), (user));                         \
        }                                                                                                      \
    } while (0)

#endif
