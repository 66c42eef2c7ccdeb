/* Pipelined batch queries of the VL sphere index (vl_index.h, vbnl_vl_index_query_batch), for
 * photon splitting's sorted batches of hits (Li et al. 2022, Section 3.3). */
#include "vl_index_internal.h"

/* ---- batched queries: a software pipeline over the points ------------------------------------
 * Point k goes through four stages, PIPE_STEP points apart: (A) its cells are located and their
 * headers fetched; (B) the cells' entries are fetched; (C) the quantised pre-test picks the
 * candidates and fetches their records (and the caller's per-rank data); (D) the exact test,
 * then the callback. Each stage finds in cache what the previous one fetched, so the four
 * dependent memory accesses of a query overlap with the work on other points. The answers are
 * the sets of vbnl_vl_index_query_found: the candidates of (C) are a superset of the containing
 * spheres; (D) keeps them in candidate order (an id sort costs a third of the stage in branch
 * misses) unless the answer is capped. */
#define PIPE_STEP 4u
#define PIPE_SLOTS 16u     /* >= 3 PIPE_STEP + 1, a power of two */
#define PIPE_LEVELS 4u     /* indexes with more levels use plain queries */
#define PIPE_CAND 128u     /* more candidates: the point gets a plain query */

typedef struct pipe_slot {
    uint32_t cell[PIPE_LEVELS];
    int32_t c3[PIPE_LEVELS][3];
    uint32_t s0[PIPE_LEVELS], n[PIPE_LEVELS];
    uint32_t ncand;
    uint32_t cand[PIPE_CAND];
} pipe_slot;

static inline const char *batch_rec(const vbnl_vl_batch *b, uint32_t k)
{
    return (const char *)b->base + (size_t)(b->order ? b->order[k] : k) * b->stride;
}

static inline vec3 batch_vec(const vbnl_vl_batch *b, uint32_t k, size_t off)
{
    vec3 v;
    memcpy(&v, batch_rec(b, k) + off, sizeof(v));
    return v;
}

/* The stages take the level count `nl` as an argument so that the single-level case (uniform
 * radii, the common one) is compiled without the loops over levels. */
static inline __attribute__((always_inline)) void pipe_a(const vbnl_vl_index *x, vec3 p, pipe_slot *s, uint32_t nl)
{
    for (uint32_t L = 0; L < nl; ++L) {
        const grid_level *g = &x->levels[L];
        s->cell[L] = level_cell(g, p, s->c3[L]);
        if (s->cell[L] != UINT32_MAX)
            __builtin_prefetch(g->start + s->cell[L]);
    }
}

static inline __attribute__((always_inline)) void pipe_b(const vbnl_vl_index *x, pipe_slot *s, uint32_t nl)
{
    for (uint32_t L = 0; L < nl; ++L) {
        const grid_level *g = &x->levels[L];
        uint32_t c = s->cell[L];
        s->n[L] = 0;
        if (c == UINT32_MAX)
            continue;
        s->s0[L] = g->start[c];
        s->n[L] = g->start[c + 1] - s->s0[L];
        for (uint32_t i = 0; i < s->n[L]; i += 16) {
            __builtin_prefetch(g->qent + s->s0[L] + i);
            __builtin_prefetch(g->items + s->s0[L] + i);
        }
    }
}

static inline __attribute__((always_inline)) void pipe_c(const vbnl_vl_index *x, const vbnl_vl_batch *b, vec3 p,
                                                         pipe_slot *s, uint32_t nl)
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
            if (nc < PIPE_CAND) {
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
static void batch_plain(const vbnl_vl_index *x, const vbnl_vl_batch *b, uint32_t k, vbnl_vl_found *found,
                        vbnl_vl_batch_fn fn, void *user)
{
    vbnl_vl_filter fl = {batch_vec(b, k, b->n_off), batch_vec(b, k, b->wi_off), b->normal_cos, b->facing};
    uint32_t total = vbnl_vl_index_query_found(x, batch_vec(b, k, b->p_off), b->filter ? &fl : NULL, b->max_out, found);
    fn(user, k, total, found, total < b->max_out ? total : b->max_out);
}

/* Stage D: the exact test and the filter on the candidates, the same decisions as test_rec_exact
 * and passes, with the filter in registers. Falls back to the plain query when the answer would
 * be capped (more than max_out spheres, rare) or the candidates overflowed. */
static void pipe_d(const vbnl_vl_index *x, const vbnl_vl_batch *b, uint32_t k, const pipe_slot *s,
                   vbnl_vl_found *found, vbnl_vl_batch_fn fn, void *user)
{
    if (s->ncand > PIPE_CAND) {
        batch_plain(x, b, k, found, fn, user);
        return;
    }
    const char *rec_k = batch_rec(b, k);
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
        float dx = p.x - e->cx, dy = p.y - e->cy, dz = p.z - e->cz, r = e->r;
        double d2 = (double)dx * dx + (double)dy * dy + (double)dz * dz; /* = vbnl_vl_dist2(p, centre) */
        if (!(r > 0.0f && d2 < (double)r * r))
            continue;
        vec3 nj = v3(e->nx, e->ny, e->nz);
        if (use_cos && !(v3_dot(nj, n) > ncos))
            continue;
        if (use_facing && !(v3_dot(nj, wi) > 0.0f))
            continue;
        if (m == max_out) { /* capped: the plain query keeps the max_out smallest ids */
            batch_plain(x, b, k, found, fn, user);
            return;
        }
        found[m++] = (vbnl_vl_found){e->id, rank, (float)d2, r};
    }
    fn(user, k, m, found, m); /* in candidate (rank) order: see vl_index.h */
}

static inline __attribute__((always_inline)) void run_pipe(const vbnl_vl_index *x, const vbnl_vl_batch *b,
                                                           vbnl_vl_found *found, vbnl_vl_batch_fn fn, void *user,
                                                           uint32_t nl)
{
    pipe_slot ring[PIPE_SLOTS];
    const uint32_t m = PIPE_SLOTS - 1, count = b->count;
    for (uint32_t k = 0; k < count + 3 * PIPE_STEP; ++k) {
        if (k + PIPE_STEP < count) {
            const char *r = batch_rec(b, k + PIPE_STEP);
            __builtin_prefetch(r);
            __builtin_prefetch(r + b->stride - 1);
        }
        if (k < count)
            pipe_a(x, batch_vec(b, k, b->p_off), &ring[k & m], nl);
        if (k >= PIPE_STEP && k - PIPE_STEP < count)
            pipe_b(x, &ring[(k - PIPE_STEP) & m], nl);
        if (k >= 2 * PIPE_STEP && k - 2 * PIPE_STEP < count)
            pipe_c(x, b, batch_vec(b, k - 2 * PIPE_STEP, b->p_off), &ring[(k - 2 * PIPE_STEP) & m], nl);
        if (k >= 3 * PIPE_STEP)
            pipe_d(x, b, k - 3 * PIPE_STEP, &ring[(k - 3 * PIPE_STEP) & m], found, fn, user);
    }
}

void vbnl_vl_index_query_batch(const vbnl_vl_index *x, const vbnl_vl_batch *b, vbnl_vl_batch_fn fn, void *user)
{
    vbnl_vl_found found[VBNL_VL_BATCH_MAX_OUT];
    uint32_t count = b->count;
    if (x->kind != VBNL_VL_INDEX_GRID) {
        for (uint32_t k = 0; k < count; ++k)
            batch_plain(x, b, k, found, fn, user);
        return;
    }
    if (x->level_count > PIPE_LEVELS) {
        for (uint32_t k = 0; k < count; ++k)
            batch_plain(x, b, k, found, fn, user);
        return;
    }
    if (x->level_count == 1)
        run_pipe(x, b, found, fn, user, 1);
    else
        run_pipe(x, b, found, fn, user, x->level_count);
}
