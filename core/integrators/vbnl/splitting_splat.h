/* Photon splitting, glossy VLs: the splats of a VL's share into its incident direction map
 * (part of splitting.c, included once by it; see there). */
#ifndef VBI_SPLITTING_SPLAT_H
#define VBI_SPLITTING_SPLAT_H

/* A glossy splat into the thread's maps (split_thread.maps): the rows of splat_rows, each one
 * 32-bit add of eight lanes, unless a lane wraps past 2^32 (then that row lane by lane in 64 bits,
 * the high part into the set atomically, as vbi_profile_splat_apply_lo32), or the general form. */
static inline __attribute__((always_inline)) void splat_apply(const splat_slot *ss)
{
#if defined(__AVX2__)
    if (ss->rows) {
        const splat_rows *sr = &ss->u.sr;
        for (int r = 0; r < 2; ++r) {
            const __m256i old = _mm256_loadu_si256((const __m256i *)sr->row[r]);
            const __m256i sum = _mm256_add_epi32(old, sr->add[r]);
            /* no lane wrapped: sum >= old (unsigned) everywhere */
            if (_mm256_movemask_epi8(_mm256_cmpeq_epi32(_mm256_max_epu32(sum, old), sum)) == -1) {
                _mm256_storeu_si256((__m256i *)sr->row[r], sum);
                continue;
            }
            _Alignas(32) uint32_t add[8];
            _mm256_store_si256((__m256i *)add, sr->add[r]);
            for (int l = 0; l < 6; ++l) { /* lanes 6 and 7 add zero */
                const uint64_t s64 = (uint64_t)sr->row[r][l] + add[l];
                sr->row[r][l] = (uint32_t)s64;
                if (s64 >> 32)
                    __atomic_fetch_add(sr->carry[r] + l, s64 & ~(uint64_t)UINT32_MAX, __ATOMIC_RELAXED);
            }
        }
        return;
    }
#endif
    vbi_profile_splat_apply_lo32(&ss->u.sp);
}

/* The next slot of the thread's ring of splats in flight; the oldest is applied first when the
 * ring is full. The caller fills it (or gives it back with ring_n--, ring_at unchanged). */
static inline __attribute__((always_inline)) splat_slot *ring_take(split_thread *t)
{
    splat_slot *ss = &t->ring[t->ring_at];
    if (t->ring_n == SPLAT_RING)
        splat_apply(ss); /* the oldest, prefetched long ago */
    else
        t->ring_n++;
    ss->rows = 0;
    return ss;
}

#if defined(__AVX2__)
/* The queued splats (lanes [0, n) of t->sq) prepared eight at a time and put in the ring. Each
 * lane gets the values of the one-at-a-time form (frame_from_normal and frame_to_local of the
 * VL's normal, then vbi_profile_splat_prepare_lo32: the footprint of vbi_hemioct_footprint,
 * the exact parts min(floor(q w_k), left) of each channel with the residue to the largest weight,
 * first on ties), operation for operation in the same order (this file is compiled without
 * contraction) but across the lanes: the frame and the footprint in float lanes, the split of
 * each channel in two vectors of four 64-bit lanes, and the parts' low halves turned into each
 * lane's two rows (splat_rows) by 8 x 8 transposes. A lane whose parts reach 2^31 (two parts of
 * a row lane could then pass 2^32 together) takes the general form. About 170 instructions per
 * splat with its apply (callgrind, glossy box). */
static __attribute__((noinline)) void splat_queue_run(const split_job *job, split_thread *t)
{
    splat_queue *sq = &t->sq;
    const uint32_t n = sq->n;
    sq->n = 0;
    const vbi_profile_maps_view *mv = &job->maps_view;
    const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps(), half = _mm256_set1_ps(0.5f);
    /* frame_from_normal(nv), then wl = frame_to_local(wi) */
    const __m256 nx = _mm256_load_ps(sq->nx), ny = _mm256_load_ps(sq->ny), nz = _mm256_load_ps(sq->nz);
    const __m256 wx = _mm256_load_ps(sq->wx), wy = _mm256_load_ps(sq->wy), wz = _mm256_load_ps(sq->wz);
    __m256 fr[6];
    frame8(nx, ny, nz, fr);
    const __m256 lx = dot8(wx, wy, wz, fr[0], fr[1], fr[2]), ly = dot8(wx, wy, wz, fr[3], fr[4], fr[5]),
                 lz = dot8(wx, wy, wz, nx, ny, nz);
    /* vbi_hemioct_encode_inline: fmaxf(z, 0) (max_ps gives 0 for a NaN, as fmaxf does; the sign
     * of a zero result cannot change l1), then the rotated diamond, clampf to [0, 1], (1, 1)
     * where l1 is not positive */
    const __m256 absm = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
    const __m256 l1 = _mm256_add_ps(_mm256_add_ps(_mm256_and_ps(lx, absm), _mm256_and_ps(ly, absm)),
                                    _mm256_max_ps(lz, zero));
    const __m256 ok = _mm256_cmp_ps(l1, zero, _CMP_GT_OQ);
    const __m256 px = _mm256_div_ps(lx, l1), py = _mm256_div_ps(ly, l1);
    __m256 ux = _mm256_add_ps(_mm256_mul_ps(half, _mm256_add_ps(px, py)), half);
    __m256 uy = _mm256_add_ps(_mm256_mul_ps(half, _mm256_sub_ps(px, py)), half);
    ux = sel8(_mm256_cmp_ps(ux, zero, _CMP_LT_OQ), zero, sel8(_mm256_cmp_ps(ux, one, _CMP_GT_OQ), one, ux));
    uy = sel8(_mm256_cmp_ps(uy, zero, _CMP_LT_OQ), zero, sel8(_mm256_cmp_ps(uy, one, _CMP_GT_OQ), one, uy));
    ux = sel8(ok, ux, one);
    uy = sel8(ok, uy, one);
    /* vbi_hemioct_footprint */
    const __m256 resf = _mm256_set1_ps((float)mv->res);
    const __m256 x = _mm256_sub_ps(_mm256_mul_ps(ux, resf), half), y = _mm256_sub_ps(_mm256_mul_ps(uy, resf), half);
    const __m256 fx0 = _mm256_floor_ps(x), fy0 = _mm256_floor_ps(y);
    const __m256 fx = _mm256_sub_ps(x, fx0), fy = _mm256_sub_ps(y, fy0);
    const __m256i last = _mm256_set1_epi32((int)mv->res - 1), izero = _mm256_setzero_si256();
    const __m256i ix0 = _mm256_cvttps_epi32(fx0), iy0 = _mm256_cvttps_epi32(fy0), ione = _mm256_set1_epi32(1);
    const __m256i x0 = _mm256_max_epi32(_mm256_min_epi32(ix0, last), izero);
    const __m256i x1 = _mm256_max_epi32(_mm256_min_epi32(_mm256_add_epi32(ix0, ione), last), izero);
    const __m256i y0 = _mm256_max_epi32(_mm256_min_epi32(iy0, last), izero);
    const __m256i y1 = _mm256_max_epi32(_mm256_min_epi32(_mm256_add_epi32(iy0, ione), last), izero);
    const __m256 gx = _mm256_sub_ps(one, fx), gy = _mm256_sub_ps(one, fy);
    const __m256 wgt[4] = {_mm256_mul_ps(gx, gy), _mm256_mul_ps(fx, gy), _mm256_mul_ps(gx, fy), _mm256_mul_ps(fx, fy)};
    /* the largest weight, first on ties */
    __m256 wbig = wgt[0];
    __m256i kbig = izero;
    for (int k = 1; k < 4; ++k) {
        const __m256 gt = _mm256_cmp_ps(wgt[k], wbig, _CMP_GT_OQ);
        wbig = sel8(gt, wgt[k], wbig);
        kbig = _mm256_blendv_epi8(kbig, _mm256_set1_epi32(k), _mm256_castps_si256(gt));
    }
    /* the exact parts, channel c of lanes 4h..4h+3 in part[k][c][h] */
    const __m256d two52 = _mm256_set1_pd(0x1p52);
    __m256i part[4][3][2], left[3][2];
    __m256d dq[3][2];
    for (int c = 0; c < 3; ++c)
        for (int h = 0; h < 2; ++h) {
            left[c][h] = _mm256_load_si256((const __m256i *)(sq->q[c] + 4 * h));
            dq[c][h] = _mm256_sub_pd(_mm256_castsi256_pd(_mm256_or_si256(left[c][h], _mm256_castpd_si256(two52))), two52);
        }
    for (int k = 0; k < 4; ++k) {
        const __m256 wk = _mm256_and_ps(_mm256_cmp_ps(wgt[k], zero, _CMP_GT_OQ), wgt[k]); /* > 0 ? w : 0 */
        const __m256d wd[2] = {_mm256_cvtps_pd(_mm256_castps256_ps128(wk)), _mm256_cvtps_pd(_mm256_extractf128_ps(wk, 1))};
        for (int c = 0; c < 3; ++c)
            for (int h = 0; h < 2; ++h)
                part[k][c][h] = split_step_v(dq[c][h], wd[h], &left[c][h]);
    }
    const __m256i lim = _mm256_set1_epi64x(((int64_t)1 << 31) - 1);
    __m256i over[2] = {izero, izero};
    for (int h = 0; h < 2; ++h) {
        const __m256i kb = _mm256_cvtepi32_epi64(h ? _mm256_extracti128_si256(kbig, 1) : _mm256_castsi256_si128(kbig));
        for (int k = 0; k < 4; ++k) {
            const __m256i is = _mm256_cmpeq_epi64(kb, _mm256_set1_epi64x(k));
            for (int c = 0; c < 3; ++c) {
                part[k][c][h] = _mm256_add_epi64(part[k][c][h], _mm256_and_si256(is, left[c][h]));
                over[h] = _mm256_or_si256(over[h], _mm256_cmpgt_epi64(part[k][c][h], lim));
            }
        }
    }
    const unsigned general = (unsigned)_mm256_movemask_pd(_mm256_castsi256_pd(over[0])) |
                             (unsigned)_mm256_movemask_pd(_mm256_castsi256_pd(over[1])) << 4;
    /* low halves as eight 32-bit lanes per (texel, channel), then by lane: T[0][i] = texels 0, 1
     * and texel 2's first two channels of lane i, T[1][i] = texel 2's third and texel 3's */
    const __m256i lo4 = _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6);
    __m256i T[2][8];
    for (int j = 0; j < 12; ++j) {
        const int k = j / 3, c = j % 3;
        const __m256i v = _mm256_blend_epi32(_mm256_permutevar8x32_epi32(part[k][c][0], lo4),
                                             _mm256_permutevar8x32_epi32(part[k][c][1], lo4), 0xF0);
        T[j / 8][j % 8] = v;
    }
    for (int j = 4; j < 8; ++j)
        T[1][j] = izero;
    transpose8(T[0]);
    transpose8(T[1]);
    _Alignas(32) int32_t ax0[8], ax1[8], ay0[8], ay1[8];
    _Alignas(32) float awl[3][8];
    _mm256_store_si256((__m256i *)ax0, x0);
    _mm256_store_si256((__m256i *)ax1, x1);
    _mm256_store_si256((__m256i *)ay0, y0);
    _mm256_store_si256((__m256i *)ay1, y1);
    if (general) {
        _mm256_store_ps(awl[0], lx);
        _mm256_store_ps(awl[1], ly);
        _mm256_store_ps(awl[2], lz);
    }
    const __m256i keep3 = _mm256_setr_epi32(-1, -1, -1, 0, 0, 0, 0, 0);
    const __m256i fold = _mm256_setr_epi32(3, 4, 5, 6, 6, 6, 6, 6); /* lanes 6, 7 are zero */
    const __m256i r1a = _mm256_setr_epi32(6, 7, 0, 0, 0, 0, 0, 0), r1b = _mm256_setr_epi32(4, 4, 0, 1, 2, 3, 4, 4);
    const int res = (int)mv->res;
    for (uint32_t i = 0; i < n; ++i) {
        splat_slot *ss = ring_take(t);
        const size_t base = 3 * (size_t)sq->slot[i] * mv->texels;
        if (general >> i & 1u) {
            const uint64_t s3[3] = {sq->q[0][i], sq->q[1][i], sq->q[2][i]};
            if (!vbi_profile_splat_prepare_lo32(job->d->profiles, t->maps, sq->slot[i],
                                                 v3(awl[0][i], awl[1][i], awl[2][i]), s3, &ss->u.sp)) {
                t->ring_n--;
                continue;
            }
        } else {
            __m256i row0 = _mm256_blend_epi32(T[0][i], izero, 0xC0);
            __m256i row1 = _mm256_blend_epi32(_mm256_permutevar8x32_epi32(T[1][i], r1b),
                                              _mm256_permutevar8x32_epi32(T[0][i], r1a), 0x03);
            if (ax1[i] == ax0[i]) { /* x1 clamped onto x0: both parts into x0's lanes */
                row0 = _mm256_add_epi32(_mm256_and_si256(row0, keep3), _mm256_permutevar8x32_epi32(row0, fold));
                row1 = _mm256_add_epi32(_mm256_and_si256(row1, keep3), _mm256_permutevar8x32_epi32(row1, fold));
            }
            splat_rows *sr = &ss->u.sr;
            const int yr[2] = {ay0[i], ay1[i]};
            sr->add[0] = row0;
            sr->add[1] = row1;
            for (int r = 0; r < 2; ++r) {
                const size_t at = base + 3 * (size_t)(yr[r] * res + ax0[i]);
                sr->row[r] = t->maps + at;
                sr->carry[r] = mv->incident + at;
                __builtin_prefetch(sr->row[r], 1);
                __builtin_prefetch((const char *)sr->row[r] + 31, 1);
            }
            ss->rows = 1;
        }
        t->ring_at = (t->ring_at + 1) % SPLAT_RING;
    }
}
#endif

/* The splat of share s3 of a photon arriving from wi into glossy VL sv's map (slot): into the
 * thread's 32-bit maps, queued and prepared with seven others (splat_queue_run; shares below
 * 2^51) or prepared now (larger shares; without AVX2), then prefetched and applied SPLAT_RING
 * splats later; or, without private maps, atomically into the set's. */
static inline __attribute__((always_inline)) void glossy_splat(const split_job *job, split_thread *t,
                                                               const split_vl *sv, uint32_t slot, vec3 wi,
                                                               const uint64_t s3[3])
{
    const vbi_split_desc *d = job->d;
    /* the record's normal when it is the VL's (split_job.rec_normals) */
    vec3 nv = job->rec_normals ? v3(sv->rec.nx, sv->rec.ny, sv->rec.nz) : d->vl_normals[sv->rec.id];
#if defined(__AVX2__)
    if (t->maps && (s3[0] | s3[1] | s3[2]) < ((uint64_t)1 << 51)) { /* queued, prepared eight at a time */
        splat_queue *sq = &t->sq;
        const uint32_t i = sq->n;
        sq->nx[i] = nv.x, sq->ny[i] = nv.y, sq->nz[i] = nv.z;
        sq->wx[i] = wi.x, sq->wy[i] = wi.y, sq->wz[i] = wi.z;
        sq->q[0][i] = s3[0], sq->q[1][i] = s3[1], sq->q[2][i] = s3[2];
        sq->slot[i] = slot;
        if (++sq->n == SPLAT_QUEUE)
            splat_queue_run(job, t);
        return;
    }
#endif
    frame fr = frame_from_normal(nv);
    vec3 wl = frame_to_local(&fr, wi);
    if (!t->maps) { /* atomic adds into the set's maps */
        vbi_profile_splat sp;
        if (vbi_profile_splat_prepare_slot(d->profiles, slot, wl, s3, &sp))
            vbi_profile_splat_apply(&sp);
        return;
    }
    splat_slot *ss = ring_take(t);
    if (!vbi_profile_splat_prepare_lo32(d->profiles, t->maps, slot, wl, s3, &ss->u.sp))
        t->ring_n--;
    else
        t->ring_at = (t->ring_at + 1) % SPLAT_RING;
}

#endif
