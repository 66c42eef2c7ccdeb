/* Photon splitting, the batches: hits recorded with their cell and spatial bin, then deposited
 * in spatial order through a pipeline of prefetches (part of splitting.c, included once by it;
 * see there). */
#ifndef VBI_SPLITTING_BATCH_H
#define VBI_SPLITTING_BATCH_H

/* The quantised pre-test of the n listings from s0 (VBI_VLI_PRETEST, the same candidates in
 * listing order) for a point at q (cell frame): the candidates' ranks go to cand (their count
 * is returned; beyond VBI_VLI_PIPE_CAND only counted), their records and sums are prefetched.
 * The capacity is checked once per eight listings. */
static inline __attribute__((always_inline)) uint32_t fast_pretest(const grid_level *g, const vl_rec *rec,
                                                                   const split_vl *vl, uint32_t s0, uint32_t n,
                                                                   const float q[3], uint32_t *cand)
{
    uint32_t nc = 0;
#if defined(__AVX2__)
    const __m256 vx = _mm256_set1_ps(q[0]), vy = _mm256_set1_ps(q[1]), vz = _mm256_set1_ps(q[2]);
    const __m256 sl = _mm256_set1_ps(VBI_VLI_QSLACK);
    const __m256i byte = _mm256_set1_epi32(0xff);
    const uint32_t end = s0 + n;
    for (uint32_t b = s0 >> 3; b * 8u < end; ++b) { /* whole blocks (level_build pads cells) */
        const uint32_t *blk = g->lst + (size_t)b * 16u;
        __m256i v = _mm256_load_si256((const __m256i *)blk);
        __m256 dx = _mm256_sub_ps(vx, _mm256_cvtepi32_ps(_mm256_and_si256(v, byte)));
        __m256 dy = _mm256_sub_ps(vy, _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(v, 8), byte)));
        __m256 dz = _mm256_sub_ps(vz, _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(v, 16), byte)));
        __m256 rr = _mm256_add_ps(_mm256_cvtepi32_ps(_mm256_srli_epi32(v, 24)), sl);
        __m256 d2 = _mm256_fmadd_ps(dz, dz, _mm256_fmadd_ps(dy, dy, _mm256_mul_ps(dx, dx)));
        unsigned bits = (unsigned)_mm256_movemask_ps(_mm256_cmp_ps(d2, _mm256_mul_ps(rr, rr), _CMP_LT_OQ));
        if (nc + 8 > VBI_VLI_PIPE_CAND) { /* near the capacity: count the rest */
            while (bits) {
                unsigned j = (unsigned)__builtin_ctz(bits);
                bits &= bits - 1;
                if (nc < VBI_VLI_PIPE_CAND)
                    cand[nc] = blk[8u + j];
                ++nc;
            }
            continue;
        }
        /* the ranks of the set lanes (the block's second half), packed */
        __m256i rk = _mm256_load_si256((const __m256i *)(blk + 8));
        _mm256_storeu_si256((__m256i *)(cand + nc), _mm256_permutevar8x32_epi32(rk, compress_idx(bits)));
        nc += (uint32_t)__builtin_popcount(bits);
    }
    /* the candidates' records and sums, for stage D */
    uint32_t np = nc < VBI_VLI_PIPE_CAND ? nc : VBI_VLI_PIPE_CAND;
    if (vl) {
        /* eight at once (a loop of 4 to 10 left its exit to the branch predictor); the entries
         * past nc are ranks too (the packed stores write 8, the slots start zeroed) */
        for (uint32_t j = 0; j < 8; ++j)
            __builtin_prefetch(vl + cand[j]);
        for (uint32_t j = 8; j < np; ++j)
            __builtin_prefetch(vl + cand[j]);
    }
    else
        for (uint32_t j = 0; j < np; ++j)
            __builtin_prefetch(rec + cand[j]);
#else
    VBI_VLI_PRETEST(g, s0, n, q, {
        if (nc < VBI_VLI_PIPE_CAND) {
            if (vl)
                __builtin_prefetch(vl + rank_);
            else
                __builtin_prefetch(rec + rank_);
            cand[nc] = rank_;
        }
        ++nc;
    });
#endif
    return nc;
}

/* The batch pipeline for hits that carry their cell (job->cell_fast), four stages S hits apart:
 * (A) the cell header of hit k (sorted order, scell) is prefetched; (B) the cell's listings and
 * the hit record are prefetched; (C) the quantised pre-test picks the candidates and prefetches
 * their records and sums; (D) the deposit (split_cands). A steady-state loop runs all four
 * without tests. */
typedef struct fast_slot {
    const split_rec *h;
    uint32_t s0, n, ncand;
    uint32_t cand[VBI_VLI_PIPE_CAND];
} fast_slot;

#define FAST_S VBI_VLI_PIPE_STEP
#define FAST_SLOTS VBI_VLI_PIPE_SLOTS
_Static_assert(FAST_SLOTS >= 3 * FAST_S + 1 && (FAST_SLOTS & (FAST_SLOTS - 1)) == 0, "fast pipe slots");

typedef struct fast_pipe {
    const split_ctx *cx;
    const vbi_vl_index *x;
    const grid_level *g;
    const split_rec *recs;
    const uint32_t *order, *scell;
    const split_vl *vl;
    fast_slot ring[FAST_SLOTS];
} fast_pipe;

static inline __attribute__((always_inline)) void fast_a(fast_pipe *fp, uint32_t k)
{
    __builtin_prefetch(fp->g->start + fp->scell[k]);
}

static inline __attribute__((always_inline)) void fast_b(fast_pipe *fp, uint32_t k)
{
    fast_slot *sl = &fp->ring[k & (FAST_SLOTS - 1)];
    const grid_level *g = fp->g;
    uint32_t c = fp->scell[k];
    sl->h = fp->recs + fp->order[k];
    __builtin_prefetch(sl->h);
    uint32_t s0 = g->start[c], n = g->start[c + 1] - s0;
    sl->s0 = s0;
    sl->n = n;
    vbi_vli_prefetch_listings(g, s0, n); /* every line the pre-test reads */
}

static inline __attribute__((always_inline)) void fast_c(fast_pipe *fp, uint32_t k)
{
    fast_slot *sl = &fp->ring[k & (FAST_SLOTS - 1)];
    sl->ncand = fast_pretest(fp->g, fp->x->rec, fp->vl, sl->s0, sl->n, sl->h->q, sl->cand);
}

static inline __attribute__((always_inline)) void fast_d(fast_pipe *fp, uint32_t k)
{
    const fast_slot *sl = &fp->ring[k & (FAST_SLOTS - 1)];
    split_cands(fp->cx, fp->x, sl->h, sl->ncand, sl->cand, 0); /* one level: rank order */
}

/* Step k of the pipeline: stage A of hit k, B of k - S, C of k - 2 S, D of k - 3 S (those that
 * exist). */
static inline __attribute__((always_inline)) void fast_step(fast_pipe *fp, uint32_t k, uint32_t count)
{
    const uint32_t S = FAST_S;
    if (k < count)
        fast_a(fp, k);
    if (k >= S && k - S < count)
        fast_b(fp, k - S);
    if (k >= 2 * S && k - 2 * S < count)
        fast_c(fp, k - 2 * S);
    if (k >= 3 * S && k - 3 * S < count)
        fast_d(fp, k - 3 * S);
}

static void run_fast_pipe(const split_ctx *cx, const uint32_t *scell, uint32_t count)
{
    fast_pipe fp;
    fp.cx = cx;
    fp.x = cx->job->d->index;
    fp.g = &fp.x->levels[0];
    fp.recs = cx->recs;
    fp.order = cx->order;
    fp.scell = scell;
    fp.vl = cx->t->vl;
    memset(fp.ring, 0, sizeof(fp.ring)); /* fast_pretest prefetches cand[0..7] */
    const uint32_t S = FAST_S, end = count + 3 * S;
    uint32_t k = 0;
    for (; k < 3 * S && k < end; ++k)
        fast_step(&fp, k, count);
    for (; k < count; ++k) { /* all four stages */
        fast_a(&fp, k);
        fast_b(&fp, k - S);
        fast_c(&fp, k - 2 * S);
        fast_d(&fp, k - 3 * S);
    }
    for (; k < end; ++k)
        fast_step(&fp, k, count);
}

/* Deposits the thread's batch in spatial order: a counting sort by bin (a cube of the index's
 * Morton key grid), so that consecutive queries read the same cells, sphere records and
 * accumulators, which then stay in cache. The order cannot change the result: deposits are
 * integer adds. */
static __attribute__((noinline)) void flush_batch(const split_job *job, split_thread *t)
{
    uint32_t n = t->n, bins = job->bins;
    if (!n)
        return;
    uint32_t *start = t->start;
    memset(start, 0, ((size_t)bins + 1) * sizeof(uint32_t));
    for (uint32_t i = 0; i < n; ++i)
        start[t->bin[i] + 1]++;
    for (uint32_t b = 0; b < bins; ++b)
        start[b + 1] += start[b];
    if (job->cell_fast) {
        for (uint32_t i = 0; i < n; ++i) {
            uint32_t k = start[t->bin[i]]++;
            t->order[k] = i;
            t->scell[k] = t->cell[i];
        }
    } else {
        for (uint32_t i = 0; i < n; ++i)
            t->order[start[t->bin[i]]++] = i;
    }
    /* Queries in that order, pipelined by the index (vl_index.h), which also prefetches this
     * thread's sums of the candidate VLs. */
    split_ctx cx = {job, t, t->hits, t->order};
    vbi_vl_batch b;
    memset(&b, 0, sizeof(b));
    b.count = n;
    b.order = t->order;
    b.base = t->hits;
    b.stride = sizeof(split_rec);
    b.p_off = offsetof(split_rec, p);
    b.n_off = offsetof(split_rec, n);
    b.wi_off = offsetof(split_rec, wi);
    b.filter = 1;
    b.normal_cos = job->d->normal_cos;
    b.facing = job->d->require_facing;
    b.max_out = VBI_SPLIT_QUERY_MAX;
    b.rank_data = t->vl; /* NULL: nothing to prefetch */
    b.rank_stride = sizeof(split_vl);
    const vbi_vl_index *x = job->d->index;
    if (job->cell_fast) {
        run_fast_pipe(&cx, t->scell, n);
    } else if (x->kind == VBI_VL_INDEX_GRID && x->level_count <= VBI_VLI_PIPE_LEVELS && b.max_out <= VBI_SPLIT_QUERY_MAX) {
        /* the index's pipeline with stage D fused with the deposit (split_pipe_d) */
        vbi_vl_found found[VBI_VL_BATCH_MAX_OUT];
        if (x->level_count == 1)
            VBI_VLI_RUN_PIPE(x, &b, found, split_pipe_d, &cx, 1u);
        else
            VBI_VLI_RUN_PIPE(x, &b, found, split_pipe_d, &cx, x->level_count);
    } else {
        vbi_vl_index_query_batch(x, &b, split_hit, &cx);
    }
#if defined(__AVX2__)
    if (t->sq.n) /* the glossy splats still queued */
        splat_queue_run(job, t);
#endif
    for (uint32_t i = 0; i < t->ring_n; ++i) /* the glossy splats still in flight */
        splat_apply(&t->ring[(t->ring_at + SPLAT_RING - t->ring_n + i) % SPLAT_RING]);
    t->ring_n = 0;
    t->ring_at = 0;
    t->n = 0;
}

/* level_cell of a dense level (same cells): the far-outside test, then floor((p - lo) / cell)
 * clamped to the grid, for the three axes at once. */
static inline __attribute__((always_inline)) uint32_t fast_cell(const grid_level *g, vec3 p, int32_t c3[3])
{
#if defined(__SSE4_1__)
    const __m128 lo = _mm_setr_ps(g->lo.x, g->lo.y, g->lo.z, 0.0f);
    const __m128 nf = _mm_cvtepi32_ps(_mm_setr_epi32(g->n[0], g->n[1], g->n[2], 1));
    __m128 f = _mm_mul_ps(_mm_sub_ps(_mm_setr_ps(p.x, p.y, p.z, 0.0f), lo), _mm_set1_ps(g->inv_cell));
    __m128 in = _mm_and_ps(_mm_cmpgt_ps(f, _mm_set1_ps(-1.0f)), _mm_cmplt_ps(f, _mm_add_ps(nf, _mm_set1_ps(1.0f))));
    if (_mm_movemask_ps(in) != 15) /* also NaN */
        return UINT32_MAX;
    /* f is an integer after the floor: min(max(f, 0), n - 1) is cell_coord's clamp */
    __m128 fl = _mm_min_ps(_mm_max_ps(_mm_floor_ps(f), _mm_setzero_ps()), _mm_sub_ps(nf, _mm_set1_ps(1.0f)));
    __m128i ci = _mm_cvttps_epi32(fl);
    c3[0] = _mm_cvtsi128_si32(ci);
    c3[1] = _mm_extract_epi32(ci, 1);
    c3[2] = _mm_extract_epi32(ci, 2);
    return (uint32_t)c3[0] + (uint32_t)g->n[0] * ((uint32_t)c3[1] + (uint32_t)g->n[1] * (uint32_t)c3[2]);
#else
    return level_cell(g, p, c3);
#endif
}

/* Records a photon hit in the thread's batch (deposited when the batch fills up, by one of the
 * last work items or after the run: run_chunk): p, the geometric normal and wo facing the
 * arriving photon, its flux. */
static inline __attribute__((always_inline)) void record_hit(const split_job *job, split_thread *t, vec3 p, vec3 ng,
                                                             vec3 wo, vec3 beta, uint32_t material)
{
    if (t->n == t->cap)
        flush_batch(job, t);
    split_rec *h = &t->hits[t->n];
    if (job->cell_fast) {
        /* level_cell and cell_frame of the deposit, done here; no sphere can contain a point
         * outside the level (the hit is not recorded) */
        const grid_level *g = &job->d->index->levels[0];
        int32_t c3[3];
        uint32_t c = fast_cell(g, p, c3);
        if (c == UINT32_MAX)
            return;
        *h = (split_rec){p, ng, wo, beta, {0.0f, 0.0f, 0.0f}, material};
        cell_frame(g, p, c3, h->q);
        t->cell[t->n] = c;
        const uint32_t sh = job->cell_shift, b = VBI_SPLIT_BIN_BITS / 3u;
        t->bin[t->n] = vbi_vl_key_spread_bits((uint32_t)c3[0] >> sh, b) |
                       vbi_vl_key_spread_bits((uint32_t)c3[1] >> sh, b) << 1 |
                       vbi_vl_key_spread_bits((uint32_t)c3[2] >> sh, b) << 2;
    } else {
        *h = (split_rec){p, ng, wo, beta, {0.0f, 0.0f, 0.0f}, material};
        /* = vbi_vl_index_spatial_key >> (63 - VBI_SPLIT_BIN_BITS), inline */
        t->bin[t->n] = vbi_vl_key_bin(&job->key_grid, p, VBI_SPLIT_BIN_BITS / 3u);
    }
    t->n++;
}

#endif
