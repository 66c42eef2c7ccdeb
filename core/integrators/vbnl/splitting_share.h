/* Photon splitting, one hit: the VLs around it and their shares of its power (Li et al. 2022,
 * Section 3.3; part of splitting.c, included once by it; see there). */
#ifndef VBI_SPLITTING_SHARE_H
#define VBI_SPLITTING_SHARE_H

/* vbi_profile_quantize (same bits), inlined: power -> steps of the unit, rounded to nearest,
 * clamped to [0, VBI_PROFILE_MAX_DEPOSIT]. Values stay below 2^53, so the conversions through
 * int64 give the same results as the unsigned ones, without their slow paths. */
static inline uint64_t quantize1(float v, double inv_unit)
{
    double x = (double)v * inv_unit;
    if (!(x > 0.0))
        return 0;
    return x < VBI_PROFILE_MAX_DEPOSIT ? (uint64_t)(int64_t)(x + 0.5) : (uint64_t)VBI_PROFILE_MAX_DEPOSIT;
}

/* vbi_profile_split_fixed (same bits) for the three channels at once. There
 * v = x < left ? trunc(x) : left, which is min(trunc(x), left) for 0 <= x < 2^53 (left is an
 * integer below 2^53, exact in double). */
static inline void split3(const uint64_t q[3], uint32_t n, const float *w, uint64_t out[][VBI_SPLIT_MAX_VLS])
{
    uint64_t left0 = q[0], left1 = q[1], left2 = q[2];
    double dq0 = (double)(int64_t)q[0], dq1 = (double)(int64_t)q[1], dq2 = (double)(int64_t)q[2];
    uint32_t big = 0;
    for (uint32_t k = 0; k < n; ++k) {
        double wk = (double)(w[k] > 0.0f ? w[k] : 0.0f);
        uint64_t v0 = (uint64_t)(int64_t)(dq0 * wk), v1 = (uint64_t)(int64_t)(dq1 * wk),
                 v2 = (uint64_t)(int64_t)(dq2 * wk);
        v0 = v0 < left0 ? v0 : left0;
        v1 = v1 < left1 ? v1 : left1;
        v2 = v2 < left2 ? v2 : left2;
        out[0][k] = v0;
        out[1][k] = v1;
        out[2][k] = v2;
        left0 -= v0;
        left1 -= v1;
        left2 -= v2;
        if (w[k] > w[big])
            big = k;
    }
    out[0][big] += left0;
    out[1][big] += left1;
    out[2][big] += left2;
}

/* Sorts the m weights w and ranks rk (distinct) by ascending rank (insertion: m is small and the
 * arrays usually nearly sorted). */
static inline void vl_sort_by_rank(float *w, uint32_t *rk, uint32_t m)
{
    for (uint32_t i = 1; i < m; ++i) {
        const float wi = w[i];
        const uint32_t ri = rk[i];
        uint32_t j = i;
        for (; j > 0 && rk[j - 1] > ri; --j) {
            w[j] = w[j - 1];
            rk[j] = rk[j - 1];
        }
        w[j] = wi;
        rk[j] = ri;
    }
}

/* Keeps the max_vls of the m VLs with the largest weights (ties: smaller id) in rank order:
 * drops the smallest (ties: larger id) m - max_vls times, or, when more than half go, moves the
 * largest to the front max_vls times and sorts them back by rank. Either keeps the same set in
 * the same order. Returns the sum of the kept weights in that order. */
static inline float select_max_vls(const vbi_vl_index *x, float *w, uint32_t *rk, uint32_t m, uint32_t max_vls)
{
    if (m - max_vls <= max_vls) {
        for (; m > max_vls; --m) {
            uint32_t worst = 0;
            for (uint32_t b = 1; b < m; ++b)
                if (w[b] < w[worst] || (w[b] == w[worst] && x->rec[rk[b]].id > x->rec[rk[worst]].id))
                    worst = b;
            for (uint32_t b = worst + 1; b < m; ++b) {
                w[b - 1] = w[b];
                rk[b - 1] = rk[b];
            }
        }
    } else {
        for (uint32_t a = 0; a < max_vls; ++a) {
            uint32_t best = a;
            for (uint32_t b = a + 1; b < m; ++b)
                if (w[b] > w[best] || (w[b] == w[best] && x->rec[rk[b]].id < x->rec[rk[best]].id))
                    best = b;
            float tw = w[a];
            uint32_t tr = rk[a];
            w[a] = w[best];
            rk[a] = rk[best];
            w[best] = tw;
            rk[best] = tr;
        }
        m = max_vls;
        vl_sort_by_rank(w, rk, m); /* back in rank order */
    }
    float sum = 0.0f;
    for (uint32_t i = 0; i < m; ++i)
        sum += w[i];
    return sum;
}

/* The deposit of one hit h: the m VLs of rank rk[i] and weight w[i] = 1 - (d/r)^2 > 0
 * (Section 3.3; those that passed the authors' filters, in rank order) share it; sum is the
 * sum of the w[i] in order. The arrays are scratch (reordered by the max_vls selection). */
static inline __attribute__((always_inline)) void split_deposit(const split_ctx *cx, const split_rec *h, float *w,
                                                                uint32_t *rk, uint32_t m, float sum)
{
    const split_job *job = cx->job;
    split_thread *t = cx->t;
    vbi_split_stats *st = &t->s;
    const vbi_vl_index *x = job->d->index;
    /* The support test (vl_support.h): the material, then the rays for the VLs that are not
     * clear. When a VL goes, the sum is that of the kept weights in order, as the candidate
     * tests form it. */
    const vbi_vl_support *sup = job->d->support;
    if (sup) {
        uint32_t k = 0;
        float s2 = 0.0f, tmax = 0.0f;
        for (uint32_t i = 0; i < m; ++i) {
            const vbi_vl_support *v = &sup[rk[i]];
            if (v->material != h->material)
                continue;
            tmax = v->tau > tmax ? v->tau : tmax;
            w[k] = w[i];
            rk[k] = rk[i];
            s2 += w[i];
            k++;
        }
        if (tmax > 0.0f) {
            const vbnl_scene *sc = job->d->scene;
            const float hp = vbi_vl_support_height(sc, h->p, h->n, tmax);
            uint32_t kk = 0;
            s2 = 0.0f;
            for (uint32_t i = 0; i < k; ++i) {
                const vl_rec *e = x->rec + rk[i];
                const float tau = sup[rk[i]].tau;
                if (tau > 0.0f && !vbi_vl_support_passes(sc, h->p, h->n, hp, v3(e->cx, e->cy, e->cz),
                                                          v3(e->nx, e->ny, e->nz), tau))
                    continue;
                w[kk] = w[i];
                rk[kk] = rk[i];
                s2 += w[i];
                kk++;
            }
            st->support_tests++;
            k = kk;
        }
        st->support_rejects += m - k;
        if (k == 0)
            return;
        if (k < m) {
            m = k;
            sum = s2;
        }
    }
    /* The max_vls largest weights (ties: smaller id); otherwise rank order. */
    if (m > job->max_vls) {
        sum = select_max_vls(x, w, rk, m, job->max_vls);
        m = job->max_vls;
    }
    /* With per-thread sums, a glossy VL's map slot + 1 is kept in the zero lane of its sums
     * (split_vl.acc[3]; every add leaves that lane alone), on the line the candidate test has
     * just read. */
#if defined(__AVX2__)
    if (t->acc) {
        /* quantize1 for the three channels in one vector (same bits): x = power / unit, 0 unless
         * x > 0 (also NaN), trunc(x + 0.5) turned into an integer by the 2^52 trick, exact below
         * 2^51; larger photons take the scalar path below. */
        const __m256d two52 = _mm256_set1_pd(0x1p52);
        const __m256i two52i = _mm256_castpd_si256(two52);
        __m256d xq = _mm256_mul_pd(_mm256_cvtps_pd(_mm_setr_ps(h->power.x, h->power.y, h->power.z, 0.0f)),
                                   _mm256_set1_pd(job->inv_unit));
        __m256d pos = _mm256_cmp_pd(xq, _mm256_setzero_pd(), _CMP_GT_OQ);
        if (!_mm256_movemask_pd(_mm256_cmp_pd(xq, _mm256_set1_pd(0x1p51), _CMP_GE_OQ))) {
            __m256d dq = _mm256_and_pd(pos, _mm256_round_pd(_mm256_add_pd(xq, _mm256_set1_pd(0.5)),
                                                            _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC));
            __m256i left = _mm256_xor_si256(_mm256_castpd_si256(_mm256_add_pd(dq, two52)), two52i);
            if (_mm256_testz_si256(left, left))
                return;
            /* The covered power before the split consumes `left`. */
            _mm256_store_si256((__m256i *)t->cov, _mm256_add_epi64(_mm256_load_si256((const __m256i *)t->cov), left));
            /* vbi_profile_split_fixed (same bits) with the normalisation w[i] / sum fused and the
             * shares added straight into this thread's sums (by rank): v = min(trunc(q w), left)
             * per channel, trunc by floor (x >= 0) and the 2^52 trick, min and subtraction in
             * 64-bit lanes; the residue goes to the largest normalised weight (first on ties). */
            __m256i *a_big = NULL;
            float w_big = -1.0f;
            uint32_t i_big = 0;
            _Alignas(32) uint64_t share[VBI_SPLIT_MAX_VLS][4]; /* glossy: the shares to splat */
            uint64_t glossy = 0; /* bit i: VL i keeps a map (its slot + 1 in acc[3]) */
            const int any_glossy = job->glossy != NULL;
            for (uint32_t i = 0; i < m; ++i) {
                float wk = w[i] / sum;
                const __m256i v = split_step(dq, (double)wk, &left);
                __m256i *a = (__m256i *)(t->acc + ACC_STRIDE * (size_t)rk[i]);
                const __m256i sums = _mm256_load_si256(a);
                _mm256_store_si256(a, _mm256_add_epi64(sums, v));
                if (any_glossy) { /* loop-invariant */
                    _mm256_store_si256((__m256i *)share[i], v);
                    glossy |= (uint64_t)(_mm256_extract_epi64(sums, 3) != 0) << i;
                }
                if (wk > w_big) {
                    w_big = wk;
                    a_big = a;
                    i_big = i;
                }
            }
            _mm256_store_si256(a_big, _mm256_add_epi64(_mm256_load_si256(a_big), left));
            if (glossy) { /* the splats of the glossy VLs, the residue in the largest share */
                _mm256_store_si256((__m256i *)share[i_big],
                                   _mm256_add_epi64(_mm256_load_si256((const __m256i *)share[i_big]), left));
                for (uint64_t gm = glossy; gm; gm &= gm - 1) {
                    const uint32_t i = (uint32_t)__builtin_ctzll(gm);
                    const uint64_t slot1 = t->acc[ACC_STRIDE * (size_t)rk[i] + 3];
                    glossy_splat(job, t, &t->vl[rk[i]], (uint32_t)(slot1 - 1), h->wi, share[i]);
                }
            }
            st->covered_hits++;
            st->deposits += m;
            return;
        }
    }
#endif
    /* Normalised weights; the residue of the exact split goes to the largest (first on ties),
     * as in vbi_profile_split_fixed (split3 finds the same one). */
    for (uint32_t i = 0; i < m; ++i)
        w[i] /= sum;
    /* Quantise once, then partition exactly (profiles.h, "Fixed point"). */
    uint64_t q[3] = {quantize1(h->power.x, job->inv_unit), quantize1(h->power.y, job->inv_unit),
                     quantize1(h->power.z, job->inv_unit)};
    if (!(q[0] | q[1] | q[2]))
        return;
    uint64_t share[3][VBI_SPLIT_MAX_VLS];
    split3(q, m, w, share);
    const vbi_split_desc *d = job->d;
    for (uint32_t i = 0; i < m; ++i) {
        /* Phi_in into this thread's sums (plain adds, merged at the end), the direction into
         * the VL's map (split_thread.maps); without per-thread sums, both atomically into the
         * set. */
        uint64_t s3[3] = {share[0][i], share[1][i], share[2][i]};
        if (t->acc) {
            /* the VL's line: its record copy and sums (split_vl) */
            const split_vl *sv = &t->vl[rk[i]];
            uint64_t *a = t->acc + ACC_STRIDE * (size_t)rk[i];
            a[0] += s3[0];
            a[1] += s3[1];
            a[2] += s3[2];
            if (a[3]) /* glossy: slot + 1 */
                glossy_splat(job, t, sv, (uint32_t)(a[3] - 1), h->wi, s3);
        } else {
            uint32_t id = x->rec[rk[i]].id;
            int gl = job->glossy && job->glossy[rk[i]];
            vec3 wl = v3(0.0f, 0.0f, 1.0f); /* Lambertian VLs keep no direction */
            if (gl) {
                frame fr = frame_from_normal(d->vl_normals[id]);
                wl = frame_to_local(&fr, h->wi);
            }
            vbi_profile_deposit_fixed(d->profiles, id, wl, s3);
        }
    }
    st->covered_hits++;
    st->deposits += m;
    t->cov[0] += q[0];
    t->cov[1] += q[1];
    t->cov[2] += q[2];
}

/* The deposit of hit `hit` of the sorted batch from the index's answer `f` (containing spheres
 * that passed the filters, in rank order): the plain-query path (vbi_vl_batch_fn). */
static void split_found(const split_ctx *cx, const split_rec *h, uint32_t total, const vbi_vl_found *f,
                        uint32_t nf)
{
    if (!nf)
        return;
    cx->t->s.overflow += total > VBI_SPLIT_QUERY_MAX;
    float w[VBI_SPLIT_QUERY_MAX];
    uint32_t rk[VBI_SPLIT_QUERY_MAX];
    uint32_t m = 0;
    for (uint32_t i = 0; i < nf; ++i) {
        float r = f[i].r;
        float wi = 1.0f - f[i].d2 / (r * r);
        w[m] = wi;
        rk[m] = f[i].rank;
        m += wi > 0.0f; /* d within rounding of r: dropped */
    }
    vl_sort_by_rank(w, rk, m); /* the index answers in id order */
    float sum = 0.0f;
    for (uint32_t i = 0; i < m; ++i)
        sum += w[i];
    if (m)
        split_deposit(cx, h, w, rk, m, sum);
}

static void split_hit(void *user, uint32_t hit, uint32_t total, const vbi_vl_found *f, uint32_t nf)
{
    const split_ctx *cx = user;
    split_found(cx, &cx->recs[cx->order[hit]], total, f, nf);
}

/* The plain query of hit h (vbi_vli_batch_plain) and its deposit. */
static void split_plain(const split_ctx *cx, const split_rec *h)
{
    const vbi_split_desc *d = cx->job->d;
    vbi_vl_filter fl = {h->n, h->wi, d->normal_cos, d->require_facing};
    vbi_vl_found found[VBI_SPLIT_QUERY_MAX];
    uint32_t total = vbi_vl_index_query_found(d->index, h->p, &fl, VBI_SPLIT_QUERY_MAX, found);
    split_found(cx, h, total, found, total < VBI_SPLIT_QUERY_MAX ? total : VBI_SPLIT_QUERY_MAX);
}

/* Stage D of the index's batch pipeline (vl_index_pipe.h) fused with split_hit: the exact
 * test and the filters of the index's pipe_d on the ncand candidates (ranks) of hit h, the
 * weights straight from them (the same decisions, values and order as split_hit on pipe_d's
 * answer, without the answer records). */
static inline __attribute__((always_inline)) void split_cands(const split_ctx *cx, const vbi_vl_index *x,
                                                              const split_rec *h, uint32_t ncand,
                                                              const uint32_t *cand, int levels)
{
    if (ncand > VBI_VLI_PIPE_CAND) {
        split_plain(cx, h);
        return;
    }
    const vec3 p = h->p, n = h->n, wi = h->wi;
    const float ncos = cx->job->d->normal_cos;
    const int use_cos = ncos > -1.0f, use_facing = cx->job->d->require_facing;
    float w[VBI_SPLIT_QUERY_MAX + 8]; /* + 8: the packed stores of the AVX2 path */
    uint32_t rk[VBI_SPLIT_QUERY_MAX + 8];
    uint32_t nf = 0, m = 0;
    float sum = 0.0f;
#if defined(__AVX2__)
    /* Eight candidates at a time: the records transposed into lanes, then the decisions of
     * vbi_vli_accept (r > 0, d^2 < r^2 in double with exact products, the normal-cone and facing
     * filters) and the weights 1 - (float)d^2 / (r r) as in the scalar loop below; the kept
     * ones are appended and summed in candidate order. Missing lanes repeat candidate 0 and
     * are masked off. */
    const __m256 px = _mm256_set1_ps(p.x), py = _mm256_set1_ps(p.y), pz = _mm256_set1_ps(p.z);
    const __m256 nx_ = _mm256_set1_ps(n.x), ny_ = _mm256_set1_ps(n.y), nz_ = _mm256_set1_ps(n.z);
    const __m256 wx = _mm256_set1_ps(wi.x), wy = _mm256_set1_ps(wi.y), wz = _mm256_set1_ps(wi.z);
    const __m256 vcos = _mm256_set1_ps(ncos);
    const __m256i lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    /* the records: this thread's copies beside its sums (split_vl), else the index's */
    const float *base = cx->t->vl ? &cx->t->vl[0].rec.cx : &x->rec[0].cx;
    const __m128i rshift = _mm_cvtsi32_si128(cx->t->vl ? 4 : 3); /* floats per record: 16 or 8 */
    for (uint32_t i0 = 0; i0 < ncand; i0 += 8) {
        uint32_t left = ncand - i0, cnt = left < 8 ? left : 8;
        /* float offsets of the records (8 floats each, 16 apart in split_vl); cand[] has room for 8 past i0 */
        __m256i ci = _mm256_loadu_si256((const __m256i *)(cand + i0));
        ci = _mm256_blendv_epi8(_mm256_set1_epi32((int)cand[i0]), ci,
                                _mm256_cmpgt_epi32(_mm256_set1_epi32((int)cnt), lanes));
        uint32_t off[8];
        _mm256_storeu_si256((__m256i *)off, _mm256_sll_epi32(ci, rshift));
        __m256 r0 = _mm256_loadu_ps(base + off[0]), r1 = _mm256_loadu_ps(base + off[1]),
               r2 = _mm256_loadu_ps(base + off[2]), r3 = _mm256_loadu_ps(base + off[3]),
               r4 = _mm256_loadu_ps(base + off[4]), r5 = _mm256_loadu_ps(base + off[5]),
               r6 = _mm256_loadu_ps(base + off[6]), r7 = _mm256_loadu_ps(base + off[7]);
        __m256 t0 = _mm256_unpacklo_ps(r0, r1), t1 = _mm256_unpackhi_ps(r0, r1);
        __m256 t2 = _mm256_unpacklo_ps(r2, r3), t3 = _mm256_unpackhi_ps(r2, r3);
        __m256 t4 = _mm256_unpacklo_ps(r4, r5), t5 = _mm256_unpackhi_ps(r4, r5);
        __m256 t6 = _mm256_unpacklo_ps(r6, r7), t7 = _mm256_unpackhi_ps(r6, r7);
        __m256 u0 = _mm256_shuffle_ps(t0, t2, 0x44), u1 = _mm256_shuffle_ps(t0, t2, 0xEE);
        __m256 u2 = _mm256_shuffle_ps(t1, t3, 0x44), u3 = _mm256_shuffle_ps(t1, t3, 0xEE);
        __m256 u4 = _mm256_shuffle_ps(t4, t6, 0x44), u5 = _mm256_shuffle_ps(t4, t6, 0xEE);
        __m256 u6 = _mm256_shuffle_ps(t5, t7, 0x44), u7 = _mm256_shuffle_ps(t5, t7, 0xEE);
        /* lanes = candidates: centre, radius, normal */
        __m256 cxv = _mm256_permute2f128_ps(u0, u4, 0x20), nxv = _mm256_permute2f128_ps(u0, u4, 0x31);
        __m256 cyv = _mm256_permute2f128_ps(u1, u5, 0x20), nyv = _mm256_permute2f128_ps(u1, u5, 0x31);
        __m256 czv = _mm256_permute2f128_ps(u2, u6, 0x20), nzv = _mm256_permute2f128_ps(u2, u6, 0x31);
        __m256 rv = _mm256_permute2f128_ps(u3, u7, 0x20);
        __m256 dx = _mm256_sub_ps(px, cxv), dy = _mm256_sub_ps(py, cyv), dz = _mm256_sub_ps(pz, czv);
        /* d^2 in double: the products of floats are exact, summed in the scalar order */
        __m256d dxl = _mm256_cvtps_pd(_mm256_castps256_ps128(dx)), dxh = _mm256_cvtps_pd(_mm256_extractf128_ps(dx, 1));
        __m256d dyl = _mm256_cvtps_pd(_mm256_castps256_ps128(dy)), dyh = _mm256_cvtps_pd(_mm256_extractf128_ps(dy, 1));
        __m256d dzl = _mm256_cvtps_pd(_mm256_castps256_ps128(dz)), dzh = _mm256_cvtps_pd(_mm256_extractf128_ps(dz, 1));
        __m256d d2l = _mm256_fmadd_pd(dzl, dzl, _mm256_fmadd_pd(dyl, dyl, _mm256_mul_pd(dxl, dxl)));
        __m256d d2h = _mm256_fmadd_pd(dzh, dzh, _mm256_fmadd_pd(dyh, dyh, _mm256_mul_pd(dxh, dxh)));
        __m256d rl = _mm256_cvtps_pd(_mm256_castps256_ps128(rv)), rh = _mm256_cvtps_pd(_mm256_extractf128_ps(rv, 1));
        unsigned in = (unsigned)_mm256_movemask_pd(_mm256_cmp_pd(d2l, _mm256_mul_pd(rl, rl), _CMP_LT_OQ)) |
                      (unsigned)_mm256_movemask_pd(_mm256_cmp_pd(d2h, _mm256_mul_pd(rh, rh), _CMP_LT_OQ)) << 4;
        __m256 ok = _mm256_cmp_ps(rv, _mm256_setzero_ps(), _CMP_GT_OQ);
        if (use_cos) {
            __m256 c = _mm256_fmadd_ps(nzv, nz_, _mm256_fmadd_ps(nyv, ny_, _mm256_mul_ps(nxv, nx_)));
            ok = _mm256_and_ps(ok, _mm256_cmp_ps(c, vcos, _CMP_GT_OQ));
        }
        if (use_facing) {
            __m256 f = _mm256_fmadd_ps(nzv, wz, _mm256_fmadd_ps(nyv, wy, _mm256_mul_ps(nxv, wx)));
            ok = _mm256_and_ps(ok, _mm256_cmp_ps(f, _mm256_setzero_ps(), _CMP_GT_OQ));
        }
        unsigned acc_bits = in & (unsigned)_mm256_movemask_ps(ok) & ((1u << cnt) - 1u);
        if (!acc_bits)
            continue;
        nf += (uint32_t)__builtin_popcount(acc_bits);
        if (nf > VBI_SPLIT_QUERY_MAX) { /* capped: the plain query keeps the smallest ids */
            split_plain(cx, h);
            return;
        }
        __m256 d2f = _mm256_set_m128(_mm256_cvtpd_ps(d2h), _mm256_cvtpd_ps(d2l));
        __m256 wv = _mm256_sub_ps(_mm256_set1_ps(1.0f), _mm256_div_ps(d2f, _mm256_mul_ps(rv, rv)));
        unsigned keep = acc_bits & (unsigned)_mm256_movemask_ps(_mm256_cmp_ps(wv, _mm256_setzero_ps(), _CMP_GT_OQ));
        /* The kept weights and ranks packed onto the ends of w and rk (d within rounding of r:
         * dropped); the lanes past them are zero weights, whose adds to the sum change no bit
         * (sum >= 0), so the sum takes the kept weights in order without a loop over them. */
        __m256i pi = compress_idx(keep);
        __m256 wc = _mm256_and_ps(_mm256_permutevar8x32_ps(wv, pi),
                                  _mm256_castsi256_ps(_mm256_cmpgt_epi32(
                                      _mm256_set1_epi32(__builtin_popcount(keep)), lanes)));
        _mm256_storeu_ps(w + m, wc);
        _mm256_storeu_si256((__m256i *)(rk + m), _mm256_permutevar8x32_epi32(ci, pi));
        { /* from the register (loads of the lanes just stored waited for the store) */
            const __m128 lo = _mm256_castps256_ps128(wc), hi = _mm256_extractf128_ps(wc, 1);
            sum = (((((((sum + _mm_cvtss_f32(lo)) + _mm_cvtss_f32(_mm_movehdup_ps(lo))) +
                       _mm_cvtss_f32(_mm_movehl_ps(lo, lo))) +
                      _mm_cvtss_f32(_mm_shuffle_ps(lo, lo, 3))) +
                     _mm_cvtss_f32(hi)) +
                    _mm_cvtss_f32(_mm_movehdup_ps(hi))) +
                   _mm_cvtss_f32(_mm_movehl_ps(hi, hi))) +
                  _mm_cvtss_f32(_mm_shuffle_ps(hi, hi, 3));
        }
        m += (uint32_t)__builtin_popcount(keep);
    }
#else
    for (uint32_t i = 0; i < ncand; ++i) {
        uint32_t rank = cand[i];
        const vl_rec *e = x->rec + rank;
        double d2;
        if (!vbi_vli_accept(e, p, use_cos, n, ncos, use_facing, wi, &d2))
            continue;
        const float r = e->r;
        if (nf == VBI_SPLIT_QUERY_MAX) { /* capped: the plain query keeps the smallest ids */
            split_plain(cx, h);
            return;
        }
        nf++;
        float wk = 1.0f - (float)d2 / (r * r);
        w[m] = wk;
        rk[m] = rank;
        int keep = wk > 0.0f; /* d within rounding of r: dropped */
        sum += keep ? wk : 0.0f;
        m += (uint32_t)keep;
    }
#endif
    if (levels) { /* candidates come level by level: back in rank order */
        vl_sort_by_rank(w, rk, m);
        sum = 0.0f;
        for (uint32_t i = 0; i < m; ++i)
            sum += w[i];
    }
    if (m)
        split_deposit(cx, h, w, rk, m, sum);
}

static inline __attribute__((always_inline)) void split_pipe_d(const vbi_vl_index *x, const vbi_vl_batch *b,
                                                               uint32_t k, const vbi_vli_pipe_slot *s,
                                                               vbi_vl_found *found, void *user)
{
    (void)b;
    (void)found;
    const split_ctx *cx = user;
    split_cands(cx, x, &cx->recs[cx->order[k]], s->ncand, s->cand, x->level_count > 1);
}

#endif
