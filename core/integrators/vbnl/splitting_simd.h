/* Photon splitting's AVX2 helpers (part of splitting.c, included once by it; see there). */
#ifndef VBI_SPLITTING_SIMD_H
#define VBI_SPLITTING_SIMD_H

#if defined(__AVX2__)
/* Left-packing of 8 lanes by a mask (AVX2 has no compress): entry m holds, 4 bits per lane, the
 * indexes of the set bits of m in ascending order (then zeros). compress_idx turns it into the
 * vpermd index vector, so 8 lanes are packed with one permute and one store instead of a loop
 * over the set bits (whose exits mispredict: the counts vary from hit to hit). */
static const uint32_t compress_lut[256] = {
    0x00000000, 0x00000000, 0x00000001, 0x00000010, 0x00000002, 0x00000020, 0x00000021, 0x00000210,
    0x00000003, 0x00000030, 0x00000031, 0x00000310, 0x00000032, 0x00000320, 0x00000321, 0x00003210,
    0x00000004, 0x00000040, 0x00000041, 0x00000410, 0x00000042, 0x00000420, 0x00000421, 0x00004210,
    0x00000043, 0x00000430, 0x00000431, 0x00004310, 0x00000432, 0x00004320, 0x00004321, 0x00043210,
    0x00000005, 0x00000050, 0x00000051, 0x00000510, 0x00000052, 0x00000520, 0x00000521, 0x00005210,
    0x00000053, 0x00000530, 0x00000531, 0x00005310, 0x00000532, 0x00005320, 0x00005321, 0x00053210,
    0x00000054, 0x00000540, 0x00000541, 0x00005410, 0x00000542, 0x00005420, 0x00005421, 0x00054210,
    0x00000543, 0x00005430, 0x00005431, 0x00054310, 0x00005432, 0x00054320, 0x00054321, 0x00543210,
    0x00000006, 0x00000060, 0x00000061, 0x00000610, 0x00000062, 0x00000620, 0x00000621, 0x00006210,
    0x00000063, 0x00000630, 0x00000631, 0x00006310, 0x00000632, 0x00006320, 0x00006321, 0x00063210,
    0x00000064, 0x00000640, 0x00000641, 0x00006410, 0x00000642, 0x00006420, 0x00006421, 0x00064210,
    0x00000643, 0x00006430, 0x00006431, 0x00064310, 0x00006432, 0x00064320, 0x00064321, 0x00643210,
    0x00000065, 0x00000650, 0x00000651, 0x00006510, 0x00000652, 0x00006520, 0x00006521, 0x00065210,
    0x00000653, 0x00006530, 0x00006531, 0x00065310, 0x00006532, 0x00065320, 0x00065321, 0x00653210,
    0x00000654, 0x00006540, 0x00006541, 0x00065410, 0x00006542, 0x00065420, 0x00065421, 0x00654210,
    0x00006543, 0x00065430, 0x00065431, 0x00654310, 0x00065432, 0x00654320, 0x00654321, 0x06543210,
    0x00000007, 0x00000070, 0x00000071, 0x00000710, 0x00000072, 0x00000720, 0x00000721, 0x00007210,
    0x00000073, 0x00000730, 0x00000731, 0x00007310, 0x00000732, 0x00007320, 0x00007321, 0x00073210,
    0x00000074, 0x00000740, 0x00000741, 0x00007410, 0x00000742, 0x00007420, 0x00007421, 0x00074210,
    0x00000743, 0x00007430, 0x00007431, 0x00074310, 0x00007432, 0x00074320, 0x00074321, 0x00743210,
    0x00000075, 0x00000750, 0x00000751, 0x00007510, 0x00000752, 0x00007520, 0x00007521, 0x00075210,
    0x00000753, 0x00007530, 0x00007531, 0x00075310, 0x00007532, 0x00075320, 0x00075321, 0x00753210,
    0x00000754, 0x00007540, 0x00007541, 0x00075410, 0x00007542, 0x00075420, 0x00075421, 0x00754210,
    0x00007543, 0x00075430, 0x00075431, 0x00754310, 0x00075432, 0x00754320, 0x00754321, 0x07543210,
    0x00000076, 0x00000760, 0x00000761, 0x00007610, 0x00000762, 0x00007620, 0x00007621, 0x00076210,
    0x00000763, 0x00007630, 0x00007631, 0x00076310, 0x00007632, 0x00076320, 0x00076321, 0x00763210,
    0x00000764, 0x00007640, 0x00007641, 0x00076410, 0x00007642, 0x00076420, 0x00076421, 0x00764210,
    0x00007643, 0x00076430, 0x00076431, 0x00764310, 0x00076432, 0x00764320, 0x00764321, 0x07643210,
    0x00000765, 0x00007650, 0x00007651, 0x00076510, 0x00007652, 0x00076520, 0x00076521, 0x00765210,
    0x00007653, 0x00076530, 0x00076531, 0x00765310, 0x00076532, 0x00765320, 0x00765321, 0x07653210,
    0x00007654, 0x00076540, 0x00076541, 0x00765410, 0x00076542, 0x00765420, 0x00765421, 0x07654210,
    0x00076543, 0x00765430, 0x00765431, 0x07654310, 0x00765432, 0x07654320, 0x07654321, 0x76543210,
};

static inline __m256i compress_idx(unsigned mask)
{
    const __m256i shifts = _mm256_setr_epi32(0, 4, 8, 12, 16, 20, 24, 28);
    return _mm256_and_si256(_mm256_srlv_epi32(_mm256_set1_epi32((int)compress_lut[mask]), shifts),
                            _mm256_set1_epi32(7));
}

/* maxf / minf of vmath.h on lanes (the non-NaN operand wins; same results). */
static inline __m256 maxf8(__m256 a, __m256 b)
{
    return _mm256_blendv_ps(b, a, _mm256_or_ps(_mm256_cmp_ps(a, b, _CMP_GT_OQ), _mm256_cmp_ps(b, b, _CMP_UNORD_Q)));
}
static inline __m256 minf8(__m256 a, __m256 b)
{
    return _mm256_blendv_ps(b, a, _mm256_or_ps(_mm256_cmp_ps(a, b, _CMP_LT_OQ), _mm256_cmp_ps(b, b, _CMP_UNORD_Q)));
}
static inline __m256 neg8(__m256 a) { return _mm256_xor_ps(a, _mm256_set1_ps(-0.0f)); }
static inline __m256 sel8(__m256 m, __m256 a, __m256 b) { return _mm256_blendv_ps(b, a, m); } /* m ? a : b */
static inline __m256 dot8(__m256 ax, __m256 ay, __m256 az, __m256 bx, __m256 by, __m256 bz)
{
    return _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ax, bx), _mm256_mul_ps(ay, by)), _mm256_mul_ps(az, bz));
}
static inline __m256 mask8(unsigned bits)
{
    const __m256i lane = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    return _mm256_castsi256_ps(
        _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32((int)bits), lane), lane));
}
/* frame_from_normal (vmath.h) of the unit normals (nx, ny, nz) on lanes, operation for
 * operation: the tangents s = f[0..2] and t = f[3..5] (the frame's n is the normal). */
static inline __attribute__((always_inline)) void frame8(__m256 nx, __m256 ny, __m256 nz, __m256 f[6])
{
    const __m256 one = _mm256_set1_ps(1.0f);
    const __m256 sign = _mm256_or_ps(_mm256_and_ps(nz, _mm256_set1_ps(-0.0f)), one); /* copysignf(1, n.z) */
    const __m256 a = _mm256_div_ps(_mm256_set1_ps(-1.0f), _mm256_add_ps(sign, nz));
    const __m256 b = _mm256_mul_ps(_mm256_mul_ps(nx, ny), a);
    f[0] = _mm256_add_ps(one, _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(sign, nx), nx), a));
    f[1] = _mm256_mul_ps(sign, b);
    f[2] = _mm256_mul_ps(neg8(sign), nx);
    f[3] = b;
    f[4] = _mm256_add_ps(sign, _mm256_mul_ps(_mm256_mul_ps(ny, ny), a));
    f[5] = neg8(ny);
}
#endif

#if defined(__AVX2__)
/* One share of the exact integer split (vbi_profile_split_fixed, same bits) in 64-bit lanes:
 * v = min(floor(dq w), left), left -= v, with dq w >= 0 below 2^51, floor by rounding and the
 * 2^52 trick. split_deposit uses it for a photon among its VLs (the three channels in lanes 0-2,
 * one weight), splat_queue_run for a share among four texels (four splats' channel in the
 * lanes, a weight per lane). */
static inline __attribute__((always_inline)) __m256i split_step_v(__m256d dq, __m256d w, __m256i *left)
{
    const __m256d two52 = _mm256_set1_pd(0x1p52);
    const __m256d xv = _mm256_round_pd(_mm256_mul_pd(dq, w), _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
    __m256i v = _mm256_xor_si256(_mm256_castpd_si256(_mm256_add_pd(xv, two52)), _mm256_castpd_si256(two52));
    v = _mm256_blendv_epi8(v, *left, _mm256_cmpgt_epi64(v, *left));
    *left = _mm256_sub_epi64(*left, v);
    return v;
}
static inline __attribute__((always_inline)) __m256i split_step(__m256d dq, double w, __m256i *left)
{
    return split_step_v(dq, _mm256_set1_pd(w), left);
}
#endif

#if defined(__AVX2__)
/* 8 x 8 transpose of 32-bit lanes: r[j] lane i -> r[i] lane j. */
static inline __attribute__((always_inline)) void transpose8(__m256i r[8])
{
    __m256 t[8], u[8];
    for (int j = 0; j < 8; j += 2) {
        t[j] = _mm256_unpacklo_ps(_mm256_castsi256_ps(r[j]), _mm256_castsi256_ps(r[j + 1]));
        t[j + 1] = _mm256_unpackhi_ps(_mm256_castsi256_ps(r[j]), _mm256_castsi256_ps(r[j + 1]));
    }
    for (int j = 0; j < 8; j += 4) {
        u[j] = _mm256_shuffle_ps(t[j], t[j + 2], 0x44);
        u[j + 1] = _mm256_shuffle_ps(t[j], t[j + 2], 0xEE);
        u[j + 2] = _mm256_shuffle_ps(t[j + 1], t[j + 3], 0x44);
        u[j + 3] = _mm256_shuffle_ps(t[j + 1], t[j + 3], 0xEE);
    }
    for (int j = 0; j < 4; ++j) {
        r[j] = _mm256_castps_si256(_mm256_permute2f128_ps(u[j], u[j + 4], 0x20));
        r[j + 4] = _mm256_castps_si256(_mm256_permute2f128_ps(u[j], u[j + 4], 0x31));
    }
}
#endif

#endif
