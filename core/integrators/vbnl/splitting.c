/* Photon splitting (Li et al. 2022, Section 3.3): photon paths from the lights, every hit's
 * power shared among the virtual lights around it. Design and rules: splitting.h. */
#include "bigalloc.h"
#include "splitting.h"
#include "vl_index_pipe.h"

#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#if defined(__AVX2__)
#include <immintrin.h>
#endif

#define SPLAT_RING 16u

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

/* A photon hit waiting in a thread's batch (64 bytes, one cache line): everything the deposit
 * needs. With a single-level dense grid (job->cell_fast) the hit's cell is located when the
 * hit is recorded, so the deposit starts from the cell's listings. */
typedef struct split_rec {
    vec3 p;     /* hit point */
    vec3 n;     /* unit geometric normal facing the arriving photon */
    vec3 wi;    /* unit, toward where the photon came from */
    vec3 power; /* flux arriving */
    float q[3]; /* cell_fast: p in the cell's quantisation frame (cell_frame) */
    uint32_t material; /* of the surface hit (the support test, vl_support.h) */
} split_rec;
_Static_assert(sizeof(split_rec) == 64, "split_rec: one cache line");

/* One VL as a thread's deposit reads it, by rank (64 bytes, one cache line): a copy of its
 * index record (the exact test and the filters) and this thread's Phi_in sums. A candidate
 * then costs one line fetch instead of two (record and sums apart): the deposit is bound by
 * the number of lines in flight (perf: stalls on the prefetches, not on arithmetic). */
typedef struct split_vl {
    vl_rec rec;
    uint64_t acc[4]; /* RGB and a zero lane (fixed point), one AVX2 vector */
} split_vl;
_Static_assert(sizeof(split_vl) == 64 && offsetof(split_vl, acc) == 32, "split_vl: one cache line");
#define ACC_STRIDE (sizeof(split_vl) / sizeof(uint64_t)) /* uint64_t from one VL's sums to the next */

#if defined(__AVX2__)
/* A glossy splat prepared by the vector path (splat_queue_run): the footprint's two rows
 * (octahedral.h, vbnl_hemioct_footprint: texels x0 and x1 == x0 or x0 + 1 of rows y0 and y1) as
 * eight 32-bit lanes from texel x0's first channel on: x0's three channels, x0 + 1's three, and
 * two lanes that get zero (the next texel's, or the maps' 32 bytes of slack). One unaligned load,
 * add and store per row instead of twelve adds; carry[r] is x0's texel in the set's maps. */
typedef struct splat_rows {
    __m256i add[2];
    uint32_t *row[2];
    uint64_t *carry[2];
} splat_rows;
#endif
/* A glossy splat in flight: rows (AVX2, shares below 2^31) or the general form. */
typedef struct splat_slot {
    int rows;
    union {
        vbnl_profile_splat32 sp;
#if defined(__AVX2__)
        splat_rows sr;
#endif
    } u;
} splat_slot;
#define SPLIT_MAP_SLACK 32u /* bytes after a thread's 32-bit maps (splat_rows) */

#if defined(__AVX2__)
/* Glossy splats waiting to be prepared eight at a time (splat_queue_run): the VL's normal, the
 * photon's direction (world), the share (each channel below 2^51) and the map slot, by lane. */
#define SPLAT_QUEUE 8u
typedef struct splat_queue {
    _Alignas(32) float nx[SPLAT_QUEUE], ny[SPLAT_QUEUE], nz[SPLAT_QUEUE];
    _Alignas(32) float wx[SPLAT_QUEUE], wy[SPLAT_QUEUE], wz[SPLAT_QUEUE];
    _Alignas(32) uint64_t q[3][SPLAT_QUEUE];
    uint32_t slot[SPLAT_QUEUE];
    uint32_t n;
} splat_queue;
#endif

/* Per-thread state; the counters sit on their own cache lines. */
typedef struct split_thread {
    _Alignas(64) vbnl_split_stats s;
    split_vl *vl;        /* by index rank: record copies and this thread's sums (NULL: atomic
                          * deposits into the set) */
    uint64_t *acc;       /* vl[0].acc: rank r's sums at acc + ACC_STRIDE r, 32-byte aligned */
    split_rec *hits;     /* the batch, in trace order */
    uint32_t *order;     /* the batch by bin: indexes into hits */
    uint32_t *bin;       /* bin of hits[i] */
    uint32_t *cell;      /* cell_fast: the cell of hits[i] in level 0 (level_cell, never UINT32_MAX) */
    uint32_t *scell;     /* cell_fast: the cells in sorted order (scell[k] = cell[order[k]]) */
    uint32_t *start;     /* bins + 1 */
    uint32_t n, cap;
    _Alignas(32) uint64_t cov[4]; /* covered power (fixed point, RGB and a zero lane), added to
                                   * s.covered_power when the run ends */
    /* glossy splats in flight (prepared and prefetched, applied SPLAT_RING deposits later) */
    splat_slot ring[SPLAT_RING];
    uint32_t ring_n, ring_at;
#if defined(__AVX2__)
    splat_queue sq; /* glossy splats before they are prepared (lanes past n: earlier entries or zeros) */
#endif
    /* This thread's 32-bit incident maps (profiles.h, vbnl_profile_splat_prepare_lo32), which
     * it splats into with plain adds and which are added into the set when the run ends; NULL:
     * atomic adds into the set's maps (no glossy VL, no per-thread sums, or maps over the
     * budget). */
    uint32_t *maps;
} split_thread;

typedef struct split_job {
    const vbnl_split_desc *d;
    uint64_t begin, end;     /* global path range */
    uint64_t items;          /* work items of `chunk` paths */
    uint32_t chunk, max_vls;
    float inv_paths;
    double inv_unit;         /* 1 / fixed-point unit of the profiles (exact: a power of two) */
    const uint8_t *glossy;   /* by rank: the VL keeps a map; NULL when none does */
    vbnl_vl_key_grid key_grid; /* bin = vbnl_vl_key_bin(key grid, p, VBNL_SPLIT_BIN_BITS / 3) */
    uint32_t bins;
    /* The index is one dense grid level (uniform radii): hits carry their cell (split_rec), and
     * the bin is the Morton code of the cell coordinates >> cell_shift (VBNL_SPLIT_BIN_BITS / 3
     * bits each), so the key grid is not needed. */
    int cell_fast;
    uint32_t cell_shift;
    int empty;               /* the index holds no VL */
    int rec_normals;         /* every index record's normal is bit for bit d->vl_normals[id] */
    vbnl_profile_maps_view maps_view; /* for the threads' vector splats (splat_queue_run) */
    split_thread *threads;
    unsigned thread_count;
} split_job;

uint64_t vbnl_split_map_copy_bytes(uint64_t map_bytes, unsigned threads)
{
    if (threads < 1 || map_bytes == 0)
        return 0;
    const uint64_t copy = map_bytes / 2u * threads; /* 32-bit maps, one per thread */
    const double phys = (double)sysconf(_SC_PHYS_PAGES) * (double)sysconf(_SC_PAGESIZE);
    if ((double)copy > (double)VBNL_SPLIT_MAX_MAP_COPY_BYTES || (phys > 0.0 && (double)copy > phys / 8.0))
        return 0;
    return copy;
}

uint64_t vbnl_split_batch_bytes(uint32_t hits)
{
    return (uint64_t)hits * (sizeof(split_rec) + 4u * sizeof(uint32_t)); /* hits, order, bin, cell, scell */
}

uint32_t vbnl_split_batch_hits(unsigned threads)
{
    uint64_t fit = (uint64_t)VBNL_SPLIT_MAX_BATCH_BYTES / vbnl_split_batch_bytes(1) / (threads ? threads : 1u);
    fit &= ~(uint64_t)1023u;
    return fit >= VBNL_SPLIT_BATCH_HITS ? VBNL_SPLIT_BATCH_HITS
                                        : (fit <= VBNL_SPLIT_BATCH_HITS_MIN ? VBNL_SPLIT_BATCH_HITS_MIN : (uint32_t)fit);
}

void vbnl_split_desc_init(vbnl_split_desc *d)
{
    memset(d, 0, sizeof(*d));
    d->normal_cos = 0.7f;
    d->require_facing = 1;
    d->max_vls = 8;
    d->rr_depth = 5;
    d->max_depth = 0;
    d->chunk = VBNL_SPLIT_DEFAULT_CHUNK;
}

double vbnl_split_photon_unit(const vbnl_scene *scene, uint64_t photon_paths)
{
    double total = 0.0;
    for (uint32_t i = 0; i < scene->light_count; ++i)
        total += v3_max_comp(vbnl_light_power(&scene->lights[i]));
    return vbnl_profile_unit_for_power(photon_paths ? total / (double)photon_paths : 0.0);
}

/* ---- one hit: share the photon among the VLs around it ------------------------------------- */

/* vbnl_profile_quantize (same bits), inlined: power -> steps of the unit, rounded to nearest,
 * clamped to [0, VBNL_PROFILE_MAX_DEPOSIT]. Values stay below 2^53, so the conversions through
 * int64 give the same results as the unsigned ones, without their slow paths. */
static inline uint64_t quantize1(float v, double inv_unit)
{
    double x = (double)v * inv_unit;
    if (!(x > 0.0))
        return 0;
    return x < VBNL_PROFILE_MAX_DEPOSIT ? (uint64_t)(int64_t)(x + 0.5) : (uint64_t)VBNL_PROFILE_MAX_DEPOSIT;
}

/* vbnl_profile_split_fixed (same bits) for the three channels at once. There
 * v = x < left ? trunc(x) : left, which is min(trunc(x), left) for 0 <= x < 2^53 (left is an
 * integer below 2^53, exact in double). */
static inline void split3(const uint64_t q[3], uint32_t n, const float *w, uint64_t out[][VBNL_SPLIT_MAX_VLS])
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

typedef struct split_ctx {
    const split_job *job;
    split_thread *t;
    const split_rec *recs;
    const uint32_t *order;
} split_ctx;

/* Keeps the max_vls of the m VLs with the largest weights (ties: smaller id) in their order:
 * drops the smallest (ties: larger id) m - max_vls times, or, when more than half go, moves the
 * largest to the front max_vls times (then in weight order). Either keeps the same set. Returns
 * the sum of the kept weights in their new order. */
static inline float select_max_vls(const vbnl_vl_index *x, float *w, uint32_t *rk, uint32_t m, uint32_t max_vls)
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
    }
    float sum = 0.0f;
    for (uint32_t i = 0; i < m; ++i)
        sum += w[i];
    return sum;
}

/* A glossy splat into the thread's maps (split_thread.maps): the rows of splat_rows, each one
 * 32-bit add of eight lanes, unless a lane wraps past 2^32 (then that row lane by lane in 64 bits,
 * the high part into the set atomically, as vbnl_profile_splat_apply_lo32), or the general form. */
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
    vbnl_profile_splat_apply_lo32(&ss->u.sp);
}

#if defined(__AVX2__)
/* One share of the exact integer split (vbnl_profile_split_fixed, same bits) in 64-bit lanes:
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

/* The queued splats (lanes [0, n) of t->sq) prepared eight at a time and put in the ring. Each
 * lane gets the values of the one-at-a-time form (frame_from_normal and frame_to_local of the
 * VL's normal, then vbnl_profile_splat_prepare_lo32: the footprint of vbnl_hemioct_footprint,
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
    const vbnl_profile_maps_view *mv = &job->maps_view;
    const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps(), half = _mm256_set1_ps(0.5f);
    /* frame_from_normal(nv), then wl = frame_to_local(wi) */
    const __m256 nx = _mm256_load_ps(sq->nx), ny = _mm256_load_ps(sq->ny), nz = _mm256_load_ps(sq->nz);
    const __m256 wx = _mm256_load_ps(sq->wx), wy = _mm256_load_ps(sq->wy), wz = _mm256_load_ps(sq->wz);
    __m256 fr[6];
    frame8(nx, ny, nz, fr);
    const __m256 lx = dot8(wx, wy, wz, fr[0], fr[1], fr[2]), ly = dot8(wx, wy, wz, fr[3], fr[4], fr[5]),
                 lz = dot8(wx, wy, wz, nx, ny, nz);
    /* vbnl_hemioct_encode_inline: fmaxf(z, 0) (max_ps gives 0 for a NaN, as fmaxf does; the sign
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
    /* vbnl_hemioct_footprint */
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
            if (!vbnl_profile_splat_prepare_lo32(job->d->profiles, t->maps, sq->slot[i],
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
    const vbnl_split_desc *d = job->d;
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
        vbnl_profile_splat sp;
        if (vbnl_profile_splat_prepare_slot(d->profiles, slot, wl, s3, &sp))
            vbnl_profile_splat_apply(&sp);
        return;
    }
    splat_slot *ss = ring_take(t);
    if (!vbnl_profile_splat_prepare_lo32(d->profiles, t->maps, slot, wl, s3, &ss->u.sp))
        t->ring_n--;
    else
        t->ring_at = (t->ring_at + 1) % SPLAT_RING;
}

/* The deposit of one hit h: the m VLs of rank rk[i] and weight w[i] = 1 - (d/r)^2 > 0
 * (Section 3.3; those that passed the authors' filters, in rank order) share it; sum is the
 * sum of the w[i] in order. The arrays are scratch (reordered by the max_vls selection). */
static inline __attribute__((always_inline)) void split_deposit(const split_ctx *cx, const split_rec *h, float *w,
                                                                uint32_t *rk, uint32_t m, float sum)
{
    const split_job *job = cx->job;
    split_thread *t = cx->t;
    vbnl_split_stats *st = &t->s;
    const vbnl_vl_index *x = job->d->index;
    /* The support test (vl_support.h): the material, then the rays for the VLs that are not
     * clear. When a VL goes, the sum is that of the kept weights in order, as the candidate
     * tests form it. */
    const vbnl_vl_support *sup = job->d->support;
    if (sup) {
        uint32_t k = 0;
        float s2 = 0.0f, tmax = 0.0f;
        for (uint32_t i = 0; i < m; ++i) {
            const vbnl_vl_support *v = &sup[rk[i]];
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
            const float hp = vbnl_vl_support_height(sc, h->p, h->n, tmax);
            uint32_t kk = 0;
            s2 = 0.0f;
            for (uint32_t i = 0; i < k; ++i) {
                const vl_rec *e = x->rec + rk[i];
                const float tau = sup[rk[i]].tau;
                if (tau > 0.0f && !vbnl_vl_support_passes(sc, h->p, h->n, hp, v3(e->cx, e->cy, e->cz),
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
            /* vbnl_profile_split_fixed (same bits) with the normalisation w[i] / sum fused and the
             * shares added straight into this thread's sums (by rank): v = min(trunc(q w), left)
             * per channel, trunc by floor (x >= 0) and the 2^52 trick, min and subtraction in
             * 64-bit lanes; the residue goes to the largest normalised weight (first on ties). */
            __m256i *a_big = NULL;
            float w_big = -1.0f;
            uint32_t i_big = 0;
            _Alignas(32) uint64_t share[VBNL_SPLIT_MAX_VLS][4]; /* glossy: the shares to splat */
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
     * as in vbnl_profile_split_fixed (split3 finds the same one). */
    for (uint32_t i = 0; i < m; ++i)
        w[i] /= sum;
    /* Quantise once, then partition exactly (profiles.h, "Fixed point"). */
    uint64_t q[3] = {quantize1(h->power.x, job->inv_unit), quantize1(h->power.y, job->inv_unit),
                     quantize1(h->power.z, job->inv_unit)};
    if (!(q[0] | q[1] | q[2]))
        return;
    uint64_t share[3][VBNL_SPLIT_MAX_VLS];
    split3(q, m, w, share);
    const vbnl_split_desc *d = job->d;
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
            vbnl_profile_deposit_fixed(d->profiles, id, wl, s3);
        }
    }
    st->covered_hits++;
    st->deposits += m;
    t->cov[0] += q[0];
    t->cov[1] += q[1];
    t->cov[2] += q[2];
}

/* The deposit of hit `hit` of the sorted batch from the index's answer `f` (containing spheres
 * that passed the filters, in rank order): the plain-query path (vbnl_vl_batch_fn). */
static void split_found(const split_ctx *cx, const split_rec *h, uint32_t total, const vbnl_vl_found *f,
                        uint32_t nf)
{
    if (!nf)
        return;
    cx->t->s.overflow += total > VBNL_SPLIT_QUERY_MAX;
    float w[VBNL_SPLIT_QUERY_MAX];
    uint32_t rk[VBNL_SPLIT_QUERY_MAX];
    uint32_t m = 0;
    float sum = 0.0f; /* of the kept weights in order (adding 0 for the dropped changes no bit) */
    for (uint32_t i = 0; i < nf; ++i) {
        float r = f[i].r;
        float wi = 1.0f - f[i].d2 / (r * r);
        w[m] = wi;
        rk[m] = f[i].rank;
        int keep = wi > 0.0f; /* d within rounding of r: dropped */
        sum += keep ? wi : 0.0f;
        m += (uint32_t)keep;
    }
    if (m)
        split_deposit(cx, h, w, rk, m, sum);
}

static void split_hit(void *user, uint32_t hit, uint32_t total, const vbnl_vl_found *f, uint32_t nf)
{
    const split_ctx *cx = user;
    split_found(cx, &cx->recs[cx->order[hit]], total, f, nf);
}

/* The plain query of hit h (vbnl_vli_batch_plain) and its deposit. */
static void split_plain(const split_ctx *cx, const split_rec *h)
{
    const vbnl_split_desc *d = cx->job->d;
    vbnl_vl_filter fl = {h->n, h->wi, d->normal_cos, d->require_facing};
    vbnl_vl_found found[VBNL_SPLIT_QUERY_MAX];
    uint32_t total = vbnl_vl_index_query_found(d->index, h->p, &fl, VBNL_SPLIT_QUERY_MAX, found);
    split_found(cx, h, total, found, total < VBNL_SPLIT_QUERY_MAX ? total : VBNL_SPLIT_QUERY_MAX);
}

/* Stage D of the index's batch pipeline (vl_index_pipe.h) fused with split_hit: the exact
 * test and the filters of the index's pipe_d on the ncand candidates (ranks) of hit h, the
 * weights straight from them (the same decisions, values and order as split_hit on pipe_d's
 * answer, without the answer records). */
static inline __attribute__((always_inline)) void split_cands(const split_ctx *cx, const vbnl_vl_index *x,
                                                              const split_rec *h, uint32_t ncand,
                                                              const uint32_t *cand)
{
    if (ncand > VBNL_VLI_PIPE_CAND) {
        split_plain(cx, h);
        return;
    }
    const vec3 p = h->p, n = h->n, wi = h->wi;
    const float ncos = cx->job->d->normal_cos;
    const int use_cos = ncos > -1.0f, use_facing = cx->job->d->require_facing;
    float w[VBNL_SPLIT_QUERY_MAX + 8]; /* + 8: the packed stores of the AVX2 path */
    uint32_t rk[VBNL_SPLIT_QUERY_MAX + 8];
    uint32_t nf = 0, m = 0;
    float sum = 0.0f;
#if defined(__AVX2__)
    /* Eight candidates at a time: the records transposed into lanes, then the decisions of
     * vbnl_vli_accept (r > 0, d^2 < r^2 in double with exact products, the normal-cone and facing
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
        if (nf > VBNL_SPLIT_QUERY_MAX) { /* capped: the plain query keeps the smallest ids */
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
    if (0)
#endif
    for (uint32_t i = 0; i < ncand; ++i) {
        uint32_t rank = cand[i];
        const vl_rec *e = x->rec + rank;
        double d2;
        if (!vbnl_vli_accept(e, p, use_cos, n, ncos, use_facing, wi, &d2))
            continue;
        const float r = e->r;
        if (nf == VBNL_SPLIT_QUERY_MAX) { /* capped: the plain query keeps the smallest ids */
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
    if (m)
        split_deposit(cx, h, w, rk, m, sum);
}

static inline __attribute__((always_inline)) void split_pipe_d(const vbnl_vl_index *x, const vbnl_vl_batch *b,
                                                               uint32_t k, const vbnl_vli_pipe_slot *s,
                                                               vbnl_vl_found *found, void *user)
{
    (void)b;
    (void)found;
    const split_ctx *cx = user;
    split_cands(cx, x, &cx->recs[cx->order[k]], s->ncand, s->cand);
}

/* The quantised pre-test of the n listings from s0 (VBNL_VLI_PRETEST, the same candidates in
 * listing order) for a point at q (cell frame): the candidates' ranks go to cand (their count
 * is returned; beyond VBNL_VLI_PIPE_CAND only counted), their records and sums are prefetched.
 * The capacity is checked once per eight listings. */
static inline __attribute__((always_inline)) uint32_t fast_pretest(const grid_level *g, const vl_rec *rec,
                                                                   const split_vl *vl, uint32_t s0, uint32_t n,
                                                                   const float q[3], uint32_t *cand)
{
    uint32_t nc = 0;
#if defined(__AVX2__)
    const __m256 vx = _mm256_set1_ps(q[0]), vy = _mm256_set1_ps(q[1]), vz = _mm256_set1_ps(q[2]);
    const __m256 sl = _mm256_set1_ps(VBNL_VLI_QSLACK);
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
        if (nc + 8 > VBNL_VLI_PIPE_CAND) { /* near the capacity: count the rest */
            while (bits) {
                unsigned j = (unsigned)__builtin_ctz(bits);
                bits &= bits - 1;
                if (nc < VBNL_VLI_PIPE_CAND)
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
    uint32_t np = nc < VBNL_VLI_PIPE_CAND ? nc : VBNL_VLI_PIPE_CAND;
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
    VBNL_VLI_PRETEST(g, s0, n, q, {
        if (nc < VBNL_VLI_PIPE_CAND) {
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
    uint32_t cand[VBNL_VLI_PIPE_CAND];
} fast_slot;

#define FAST_S VBNL_VLI_PIPE_STEP
#define FAST_SLOTS VBNL_VLI_PIPE_SLOTS
_Static_assert(FAST_SLOTS >= 3 * FAST_S + 1 && (FAST_SLOTS & (FAST_SLOTS - 1)) == 0, "fast pipe slots");

typedef struct fast_pipe {
    const split_ctx *cx;
    const vbnl_vl_index *x;
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
    vbnl_vli_prefetch_listings(g, s0, n); /* every line the pre-test reads */
}

static inline __attribute__((always_inline)) void fast_c(fast_pipe *fp, uint32_t k)
{
    fast_slot *sl = &fp->ring[k & (FAST_SLOTS - 1)];
    sl->ncand = fast_pretest(fp->g, fp->x->rec, fp->vl, sl->s0, sl->n, sl->h->q, sl->cand);
}

static inline __attribute__((always_inline)) void fast_d(fast_pipe *fp, uint32_t k)
{
    const fast_slot *sl = &fp->ring[k & (FAST_SLOTS - 1)];
    split_cands(fp->cx, fp->x, sl->h, sl->ncand, sl->cand);
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
    vbnl_vl_batch b;
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
    b.max_out = VBNL_SPLIT_QUERY_MAX;
    b.rank_data = t->vl; /* NULL: nothing to prefetch */
    b.rank_stride = sizeof(split_vl);
    const vbnl_vl_index *x = job->d->index;
    if (job->cell_fast) {
        run_fast_pipe(&cx, t->scell, n);
    } else if (x->kind == VBNL_VL_INDEX_GRID && x->level_count <= VBNL_VLI_PIPE_LEVELS && b.max_out <= VBNL_SPLIT_QUERY_MAX) {
        /* the index's pipeline with stage D fused with the deposit (split_pipe_d) */
        vbnl_vl_found found[VBNL_VL_BATCH_MAX_OUT];
        if (x->level_count == 1)
            VBNL_VLI_RUN_PIPE(x, &b, found, split_pipe_d, &cx, 1u);
        else
            VBNL_VLI_RUN_PIPE(x, &b, found, split_pipe_d, &cx, x->level_count);
    } else {
        vbnl_vl_index_query_batch(x, &b, split_hit, &cx);
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

/* ---- one photon path ------------------------------------------------------------------------ */

void vbnl_photon_walk(const vbnl_photon_walk_desc *w, vbnl_rng *rng, vbnl_photon_visit_fn visit, void *user,
                      vbnl_photon_walk_stats *st)
{
    vbnl_photon_walk_inline(w, rng, visit, user, st);
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
        const uint32_t sh = job->cell_shift, b = VBNL_SPLIT_BIN_BITS / 3u;
        t->bin[t->n] = vbnl_vl_key_spread_bits((uint32_t)c3[0] >> sh, b) |
                       vbnl_vl_key_spread_bits((uint32_t)c3[1] >> sh, b) << 1 |
                       vbnl_vl_key_spread_bits((uint32_t)c3[2] >> sh, b) << 2;
    } else {
        *h = (split_rec){p, ng, wo, beta, {0.0f, 0.0f, 0.0f}, material};
        /* = vbnl_vl_index_spatial_key >> (63 - VBNL_SPLIT_BIN_BITS), inline */
        t->bin[t->n] = vbnl_vl_key_bin(&job->key_grid, p, VBNL_SPLIT_BIN_BITS / 3u);
    }
    t->n++;
}

typedef struct split_visit {
    const split_job *job;
    split_thread *t;
} split_visit;

static void split_visit_fn(void *user, const vbnl_photon_vertex *v)
{
    split_visit *sv = user;
    record_hit(sv->job, sv->t, v->hit->p, v->ng, v->wo, v->beta, v->hit->material);
}

/* No VL at all: no hit can deposit. */
static void skip_visit_fn(void *user, const vbnl_photon_vertex *v)
{
    (void)user;
    (void)v;
}

/* Paths in flight per thread. One walk alone is a chain of dependent steps (trace, set up the
 * hit, visit, bounce, trace again). With several paths in flight their rays go to Embree
 * together as one 8-wide packet (rtcIntersect8; independent directions, so Embree's hybrid
 * traversal), and the hits that are the common case (below) are set up, recorded and bounced
 * eight at a time in SIMD; the others one after another by the general walk. The packet is what
 * gains (eight paths in flight traced with rtcIntersect1 one ray after another are no faster
 * than one path at a time), and 16 or 24 paths in flight are no faster than 8; in the SIMD step the walk's own
 * work is ~170 instructions per hit (callgrind, Cornell box). Paths keep their
 * own streams, a ray's answer does not depend on its packet mates, the SIMD step computes the
 * general walk's values bit for bit (same operations in the same order; this file is compiled
 * without contracted multiply-adds), and the deposits are integer sums, so neither the order
 * of hits nor the grouping changes a bit of the result (test_splitting: chunks of 7 paths,
 * ranges merged, 1 to 3 threads; SIMD step against the general walk). */
#define SPLIT_LANES 8u

/* The paths in flight, a structure of arrays (the SIMD step reads each field as a vector);
 * lane i's vbnl_photon_state is (o, d, b, depth, max_depth)[i]. */
typedef struct photon_lanes {
    _Alignas(32) float ox[SPLIT_LANES], oy[SPLIT_LANES], oz[SPLIT_LANES];
    _Alignas(32) float dx[SPLIT_LANES], dy[SPLIT_LANES], dz[SPLIT_LANES];
    _Alignas(32) float bx[SPLIT_LANES], by[SPLIT_LANES], bz[SPLIT_LANES];
    _Alignas(32) int32_t depth[SPLIT_LANES], max_depth[SPLIT_LANES];
    vbnl_rng rng[SPLIT_LANES];
} photon_lanes;

static inline __attribute__((always_inline)) void lane_get(const photon_lanes *L, uint32_t i, vbnl_photon_state *ps)
{
    ps->o = v3(L->ox[i], L->oy[i], L->oz[i]);
    ps->dir = v3(L->dx[i], L->dy[i], L->dz[i]);
    ps->beta = v3(L->bx[i], L->by[i], L->bz[i]);
    ps->depth = L->depth[i];
    ps->max_depth = L->max_depth[i];
}

static inline __attribute__((always_inline)) void lane_put(photon_lanes *L, uint32_t i, const vbnl_photon_state *ps)
{
    L->ox[i] = ps->o.x, L->oy[i] = ps->o.y, L->oz[i] = ps->o.z;
    L->dx[i] = ps->dir.x, L->dy[i] = ps->dir.y, L->dz[i] = ps->dir.z;
    L->bx[i] = ps->beta.x, L->by[i] = ps->beta.y, L->bz[i] = ps->beta.z;
    L->depth[i] = ps->depth;
    L->max_depth[i] = ps->max_depth;
}

static inline __attribute__((always_inline)) void lane_move(photon_lanes *L, uint32_t to, uint32_t from)
{
    L->ox[to] = L->ox[from], L->oy[to] = L->oy[from], L->oz[to] = L->oz[from];
    L->dx[to] = L->dx[from], L->dy[to] = L->dy[from], L->dz[to] = L->dz[from];
    L->bx[to] = L->bx[from], L->by[to] = L->by[from], L->bz[to] = L->bz[from];
    L->depth[to] = L->depth[from];
    L->max_depth[to] = L->max_depth[from];
    L->rng[to] = L->rng[from];
}

/* Starts path k, or the next ones whose emission succeeds, in lane i; 0 when [*k, e) has none. */
static inline __attribute__((always_inline)) int lane_start(const split_job *job, split_thread *t,
                                                            const vbnl_photon_walk_desc *w, photon_lanes *L,
                                                            uint32_t i, uint64_t *k, uint64_t e)
{
    while (*k < e) {
        vbnl_rng rng = vbnl_rng_for(job->d->seed, *k, 0);
        ++*k;
        t->s.paths++;
        vbnl_photon_state ps;
        if (vbnl_photon_emit(w, &rng, &ps)) {
            L->rng[i] = rng;
            lane_put(L, i, &ps);
            return 1;
        }
    }
    return 0;
}

/* The current rays of lanes [0, n) as one packet, answered in r8. */
static inline __attribute__((always_inline)) void trace_packet(const vbnl_scene *sc, struct RTCIntersectContext *ictx,
                                                              const photon_lanes *L, uint32_t n,
                                                              struct RTCRayHit8 *r8)
{
    _Static_assert(SPLIT_LANES == 8, "one rtcIntersect8 packet per step");
    _Alignas(32) int valid[8];
    for (uint32_t i = 0; i < 8; ++i) {
        valid[i] = i < n ? -1 : 0;
        vbnl_rayhit8_set(r8, i, v3(L->ox[i], L->oy[i], L->oz[i]), v3(L->dx[i], L->dy[i], L->dz[i]), INFINITY);
    }
    rtcIntersect8(valid, sc->world, ictx, r8);
}

/* Lane i's answer as vbnl_photon_hit_from reads it. */
static inline __attribute__((always_inline)) void packet_lane(const struct RTCRayHit8 *r8, uint32_t i,
                                                             struct RTCRayHit *rh)
{
    rh->ray.tfar = r8->ray.tfar[i];
    rh->hit.Ng_x = r8->hit.Ng_x[i];
    rh->hit.Ng_y = r8->hit.Ng_y[i];
    rh->hit.Ng_z = r8->hit.Ng_z[i];
    rh->hit.u = r8->hit.u[i];
    rh->hit.v = r8->hit.v[i];
    rh->hit.primID = r8->hit.primID[i];
    rh->hit.geomID = r8->hit.geomID[i];
    rh->hit.instID[0] = r8->hit.instID[0][i];
}

#if defined(__AVX2__)
/* What step_fast needs of the lanes' surfaces beyond Embree's answer: the Lambertian colour
 * and, for lanes in `shaded`, the vertex normals of the triangle hit (vertex k's in n[k]); for
 * lanes in `other` (an opaque, non-delta, non-Lambertian BSDF: plastic, conductor), the BSDF
 * the bounce samples instead. */
typedef struct fast_surf {
    _Alignas(32) float cr[8], cg[8], cb[8];
    _Alignas(32) float n[3][3][8]; /* [vertex][axis][lane] */
    const vbnl_bsdf *bsdf[8];
    uint32_t material[8];
    unsigned shaded, other;
} fast_surf;

/* The lanes of `fast` (hits on a non-instanced triangle mesh whose material is untextured and
 * either a Lambertian with a non-black colour or, in sf->other, an opaque non-delta BSDF),
 * eight at once: vbnl_photon_hit_from, vbnl_photon_scatter with its visit (record_hit when
 * `rec`) and bounce, operation for operation (hence the same bits): the hit point o + d t; the
 * unit normals (vbnl_fill_mesh_hit: the interpolated shading normal where the mesh has normals,
 * the geometric one turned to its side) turned to face the photon; the frame of the shading
 * normal (frame_from_normal); the direction: cosine-weighted for the Lambertian lanes
 * (sample_cosine_hemisphere), vbnl_bsdf_sample of wo in the frame (frame_to_local) for the
 * others, one lane at a time; frame_to_world; the adjoint shading-normal correction; Russian
 * roulette; the offset origin of the next ray. Each lane draws from its own stream in the
 * general walk's order (the bounce's two numbers, then the roulette's). Returns the lanes of
 * `fast` that go on. */
static inline __attribute__((always_inline)) unsigned step_fast(const split_job *job, split_thread *t,
                                                               const vbnl_photon_walk_desc *w, photon_lanes *L,
                                                               const struct RTCRayHit8 *r8, unsigned fast,
                                                               const fast_surf *sf, int rec,
                                                               vbnl_photon_walk_stats *ws)
{
    const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps();
    const __m256 ox = _mm256_load_ps(L->ox), oy = _mm256_load_ps(L->oy), oz = _mm256_load_ps(L->oz);
    const __m256 dx = _mm256_load_ps(L->dx), dy = _mm256_load_ps(L->dy), dz = _mm256_load_ps(L->dz);
    const __m256 tf = _mm256_loadu_ps(r8->ray.tfar);
    /* p = o + d t (v3_fma) */
    const __m256 px = _mm256_add_ps(ox, _mm256_mul_ps(dx, tf)), py = _mm256_add_ps(oy, _mm256_mul_ps(dy, tf)),
                 pz = _mm256_add_ps(oz, _mm256_mul_ps(dz, tf));
    /* ng = v3_norm(Embree's Ng) */
    __m256 nx = _mm256_loadu_ps(r8->hit.Ng_x), ny = _mm256_loadu_ps(r8->hit.Ng_y), nz = _mm256_loadu_ps(r8->hit.Ng_z);
    {
        __m256 l = _mm256_sqrt_ps(dot8(nx, ny, nz, nx, ny, nz));
        __m256 pos = _mm256_cmp_ps(l, zero, _CMP_GT_OQ), inv = _mm256_div_ps(one, l);
        nx = sel8(pos, _mm256_mul_ps(nx, inv), nx);
        ny = sel8(pos, _mm256_mul_ps(ny, inv), ny);
        nz = sel8(pos, _mm256_mul_ps(nz, inv), nz);
    }
    /* the shading normal: b0 n0 + u n1 + v n2, normalised; ng = ns where that is degenerate;
     * then ng on the side of ns */
    __m256 sx = nx, sy = ny, sz = nz;
    if (sf->shaded) {
        const __m256 bu = _mm256_loadu_ps(r8->hit.u), bv = _mm256_loadu_ps(r8->hit.v);
        const __m256 b0 = _mm256_sub_ps(_mm256_sub_ps(one, bu), bv);
        __m256 ix_[3];
        for (int a = 0; a < 3; ++a)
            ix_[a] = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(_mm256_load_ps(sf->n[0][a]), b0),
                                                 _mm256_mul_ps(_mm256_load_ps(sf->n[1][a]), bu)),
                                   _mm256_mul_ps(_mm256_load_ps(sf->n[2][a]), bv));
        __m256 l = _mm256_sqrt_ps(dot8(ix_[0], ix_[1], ix_[2], ix_[0], ix_[1], ix_[2]));
        __m256 pos = _mm256_cmp_ps(l, zero, _CMP_GT_OQ), inv = _mm256_div_ps(one, l);
        for (int a = 0; a < 3; ++a)
            ix_[a] = sel8(pos, _mm256_mul_ps(ix_[a], inv), ix_[a]);
        __m256 use = _mm256_and_ps(mask8(sf->shaded),
                                   _mm256_cmp_ps(dot8(ix_[0], ix_[1], ix_[2], ix_[0], ix_[1], ix_[2]),
                                                 _mm256_set1_ps(0.5f), _CMP_GT_OQ));
        sx = sel8(use, ix_[0], nx);
        sy = sel8(use, ix_[1], ny);
        sz = sel8(use, ix_[2], nz);
        __m256 flip = _mm256_and_ps(mask8(sf->shaded), _mm256_cmp_ps(dot8(nx, ny, nz, sx, sy, sz), zero, _CMP_LT_OQ));
        nx = sel8(flip, neg8(nx), nx);
        ny = sel8(flip, neg8(ny), ny);
        nz = sel8(flip, neg8(nz), nz);
    }
    /* wo = -d; both normals face the photon, ns = ng where ns does not */
    const __m256 wox = neg8(dx), woy = neg8(dy), woz = neg8(dz);
    {
        __m256 flip = _mm256_cmp_ps(dot8(nx, ny, nz, wox, woy, woz), zero, _CMP_LT_OQ);
        nx = sel8(flip, neg8(nx), nx);
        ny = sel8(flip, neg8(ny), ny);
        nz = sel8(flip, neg8(nz), nz);
        sx = sel8(flip, neg8(sx), sx);
        sy = sel8(flip, neg8(sy), sy);
        sz = sel8(flip, neg8(sz), sz);
        __m256 back = _mm256_cmp_ps(dot8(sx, sy, sz, wox, woy, woz), zero, _CMP_LE_OQ);
        sx = sel8(back, nx, sx);
        sy = sel8(back, ny, sy);
        sz = sel8(back, nz, sz);
    }
    const __m256 bx = _mm256_load_ps(L->bx), by = _mm256_load_ps(L->by), bz = _mm256_load_ps(L->bz);
    ws->hits += (uint64_t)__builtin_popcount(fast);

    /* the visits, and the bounce's two numbers of each lane */
    _Alignas(32) float ux[8], uy[8];
    if (rec && job->cell_fast) {
        /* record_hit with the cell of each hit (fast_cell) and its point in the cell's frame
         * (cell_frame) computed for the eight lanes at once */
        const grid_level *g = &job->d->index->levels[0];
        _Alignas(32) float a[15][8];
        _Alignas(32) int32_t ci[3][8];
        _Alignas(32) uint32_t cl[8];
        const __m256 P[3] = {px, py, pz}, lo[3] = {_mm256_set1_ps(g->lo.x), _mm256_set1_ps(g->lo.y),
                                                   _mm256_set1_ps(g->lo.z)};
        const __m256 inv = _mm256_set1_ps(g->inv_cell), cellv = _mm256_set1_ps(g->cell);
        __m256 in = mask8(fast);
        __m256i c3[3];
        for (int ax = 0; ax < 3; ++ax) {
            const __m256 nf = _mm256_set1_ps((float)g->n[ax]);
            __m256 f = _mm256_mul_ps(_mm256_sub_ps(P[ax], lo[ax]), inv);
            in = _mm256_and_ps(in, _mm256_and_ps(_mm256_cmp_ps(f, _mm256_set1_ps(-1.0f), _CMP_GT_OQ),
                                                 _mm256_cmp_ps(f, _mm256_add_ps(nf, one), _CMP_LT_OQ)));
            __m256 fl = _mm256_min_ps(_mm256_max_ps(_mm256_floor_ps(f), zero), _mm256_sub_ps(nf, one));
            c3[ax] = _mm256_cvttps_epi32(fl);
            _mm256_store_si256((__m256i *)ci[ax], c3[ax]);
            /* cell_frame: (p - (lo + c cell) + q_off) q_scale */
            __m256 org = _mm256_add_ps(lo[ax], _mm256_mul_ps(_mm256_cvtepi32_ps(c3[ax]), cellv));
            _mm256_store_ps(a[12 + ax], _mm256_mul_ps(_mm256_add_ps(_mm256_sub_ps(P[ax], org), _mm256_set1_ps(g->q_off)),
                                                      _mm256_set1_ps(g->q_scale)));
        }
        _mm256_store_si256((__m256i *)cl,
                           _mm256_add_epi32(c3[0], _mm256_mullo_epi32(_mm256_set1_epi32(g->n[0]),
                                                                      _mm256_add_epi32(c3[1], _mm256_mullo_epi32(
                                                                          _mm256_set1_epi32(g->n[1]), c3[2])))));
        _mm256_store_ps(a[0], px), _mm256_store_ps(a[1], py), _mm256_store_ps(a[2], pz);
        _mm256_store_ps(a[3], nx), _mm256_store_ps(a[4], ny), _mm256_store_ps(a[5], nz);
        _mm256_store_ps(a[6], wox), _mm256_store_ps(a[7], woy), _mm256_store_ps(a[8], woz);
        _mm256_store_ps(a[9], bx), _mm256_store_ps(a[10], by), _mm256_store_ps(a[11], bz);
        const unsigned inside = (unsigned)_mm256_movemask_ps(in);
        const uint32_t sh = job->cell_shift, bb = VBNL_SPLIT_BIN_BITS / 3u;
        for (unsigned m = fast; m; m &= m - 1) {
            unsigned i = (unsigned)__builtin_ctz(m);
            if (inside >> i & 1u) {
                if (t->n == t->cap)
                    flush_batch(job, t);
                split_rec *h = &t->hits[t->n];
                *h = (split_rec){v3(a[0][i], a[1][i], a[2][i]), v3(a[3][i], a[4][i], a[5][i]),
                                 v3(a[6][i], a[7][i], a[8][i]), v3(a[9][i], a[10][i], a[11][i]),
                                 {a[12][i], a[13][i], a[14][i]}, sf->material[i]};
                t->cell[t->n] = cl[i];
                t->bin[t->n] = vbnl_vl_key_spread_bits((uint32_t)ci[0][i] >> sh, bb) |
                               vbnl_vl_key_spread_bits((uint32_t)ci[1][i] >> sh, bb) << 1 |
                               vbnl_vl_key_spread_bits((uint32_t)ci[2][i] >> sh, bb) << 2;
                t->n++;
            }
            ux[i] = vbnl_rng_next(&L->rng[i]);
            uy[i] = vbnl_rng_next(&L->rng[i]);
        }
    } else {
        _Alignas(32) float a[12][8];
        if (rec) {
            _mm256_store_ps(a[0], px), _mm256_store_ps(a[1], py), _mm256_store_ps(a[2], pz);
            _mm256_store_ps(a[3], nx), _mm256_store_ps(a[4], ny), _mm256_store_ps(a[5], nz);
            _mm256_store_ps(a[6], wox), _mm256_store_ps(a[7], woy), _mm256_store_ps(a[8], woz);
            _mm256_store_ps(a[9], bx), _mm256_store_ps(a[10], by), _mm256_store_ps(a[11], bz);
        }
        for (unsigned m = fast; m; m &= m - 1) {
            unsigned i = (unsigned)__builtin_ctz(m);
            if (rec)
                record_hit(job, t, v3(a[0][i], a[1][i], a[2][i]), v3(a[3][i], a[4][i], a[5][i]),
                           v3(a[6][i], a[7][i], a[8][i]), v3(a[9][i], a[10][i], a[11][i]), sf->material[i]);
            ux[i] = vbnl_rng_next(&L->rng[i]);
            uy[i] = vbnl_rng_next(&L->rng[i]);
        }
    }
    __m256 alive = _mm256_and_ps(mask8(fast), _mm256_cmp_ps(dot8(wox, woy, woz, sx, sy, sz), zero, _CMP_GT_OQ));
    /* frame_from_normal(ns) */
    __m256 fr[6];
    frame8(sx, sy, sz, fr);
    const __m256 fsx = fr[0], fsy = fr[1], fsz = fr[2], ftx = fr[3], fty = fr[4], ftz = fr[5];

    /* sample_cosine_hemisphere(u): the concentric disk with sincos_quarter, then z */
    __m256 wx, wy, wz;
    {
        const __m256 two = _mm256_set1_ps(2.0f), am = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
        __m256 ex = _mm256_sub_ps(_mm256_mul_ps(two, _mm256_load_ps(ux)), one);
        __m256 ey = _mm256_sub_ps(_mm256_mul_ps(two, _mm256_load_ps(uy)), one);
        __m256 centre = _mm256_and_ps(_mm256_cmp_ps(ex, zero, _CMP_EQ_OQ), _mm256_cmp_ps(ey, zero, _CMP_EQ_OQ));
        __m256 first = _mm256_cmp_ps(_mm256_and_ps(ex, am), _mm256_and_ps(ey, am), _CMP_GT_OQ);
        __m256 r = sel8(first, ex, ey), other = sel8(first, ey, ex);
        __m256 phi = _mm256_mul_ps(_mm256_set1_ps(VBNL_PI / 4.0f), _mm256_div_ps(other, r));
        __m256 x2 = _mm256_mul_ps(phi, phi);
        /* sincos_quarter(phi): the same Horner steps, innermost first */
#define SPLIT_H(acc, cst) _mm256_add_ps(_mm256_set1_ps(cst), _mm256_mul_ps(x2, (acc)))
        __m256 s = _mm256_set1_ps(1.0f / 362880.0f);
        s = SPLIT_H(s, -1.0f / 5040.0f);
        s = SPLIT_H(s, 1.0f / 120.0f);
        s = SPLIT_H(s, -1.0f / 6.0f);
        s = _mm256_mul_ps(phi, _mm256_add_ps(one, _mm256_mul_ps(x2, s)));
        __m256 c = _mm256_set1_ps(-1.0f / 3628800.0f);
        c = SPLIT_H(c, 1.0f / 40320.0f);
        c = SPLIT_H(c, -1.0f / 720.0f);
        c = SPLIT_H(c, 1.0f / 24.0f);
        c = SPLIT_H(c, -0.5f);
        c = _mm256_add_ps(one, _mm256_mul_ps(x2, c));
#undef SPLIT_H
        __m256 rs = _mm256_mul_ps(r, s), rc = _mm256_mul_ps(r, c);
        __m256 ddx = _mm256_andnot_ps(centre, sel8(first, rc, rs));
        __m256 ddy = _mm256_andnot_ps(centre, sel8(first, rs, rc));
        wx = ddx;
        wy = ddy;
        wz = _mm256_sqrt_ps(_mm256_max_ps(_mm256_sub_ps(_mm256_sub_ps(one, _mm256_mul_ps(ddx, ddx)),
                                                        _mm256_mul_ps(ddy, ddy)),
                                          zero));
    }
    alive = _mm256_and_ps(alive, _mm256_cmp_ps(wz, zero, _CMP_GT_OQ));
    /* the other lanes: vbnl_bsdf_sample of wo in the frame, then their direction and weight */
    _Alignas(32) float owx[8], owy[8], owz[8], ogr[8], ogg[8], ogb[8];
    if (sf->other) {
        _Alignas(32) float lx[8], ly[8], lz[8];
        _mm256_store_ps(lx, dot8(wox, woy, woz, fsx, fsy, fsz));
        _mm256_store_ps(ly, dot8(wox, woy, woz, ftx, fty, ftz));
        _mm256_store_ps(lz, dot8(wox, woy, woz, sx, sy, sz));
        unsigned ok = 0;
        for (unsigned m = sf->other; m; m &= m - 1) {
            unsigned i = (unsigned)__builtin_ctz(m);
            vbnl_bsdf_sample_rec bs;
            owx[i] = owy[i] = owz[i] = ogr[i] = ogg[i] = ogb[i] = 0.0f;
            if (!vbnl_bsdf_sample(sf->bsdf[i], v3(lx[i], ly[i], lz[i]), (vec2){ux[i], uy[i]}, &bs) ||
                v3_is_black(bs.weight))
                continue;
            ok |= 1u << i;
            owx[i] = bs.wi.x, owy[i] = bs.wi.y, owz[i] = bs.wi.z;
            ogr[i] = bs.weight.x, ogg[i] = bs.weight.y, ogb[i] = bs.weight.z;
        }
        const __m256 om = mask8(sf->other);
        wx = sel8(om, _mm256_load_ps(owx), wx);
        wy = sel8(om, _mm256_load_ps(owy), wy);
        wz = sel8(om, _mm256_load_ps(owz), wz);
        alive = sel8(om, mask8(ok), alive);
    }
    /* frame_to_world */
    __m256 ix, iy, iz;
    {
        ix = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(fsx, wx), _mm256_mul_ps(ftx, wy)), _mm256_mul_ps(sx, wz));
        iy = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(fsy, wx), _mm256_mul_ps(fty, wy)), _mm256_mul_ps(sy, wz));
        iz = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(fsz, wx), _mm256_mul_ps(ftz, wy)), _mm256_mul_ps(sz, wz));
    }
    /* a reflection must leave on the photon's side of the real surface */
    alive = _mm256_and_ps(alive, _mm256_cmp_ps(dot8(ix, iy, iz, nx, ny, nz), zero, _CMP_GT_OQ));
    /* wt = colour, with the adjoint shading-normal correction (Veach 1997, Eq. 5.17) where ns
     * differs from ng; nb = beta wt; Russian roulette */
    __m256 wtx = _mm256_load_ps(sf->cr), wty = _mm256_load_ps(sf->cg), wtz = _mm256_load_ps(sf->cb);
    if (sf->other) { /* the sampled weight f cos / pdf */
        const __m256 om = mask8(sf->other);
        wtx = sel8(om, _mm256_load_ps(ogr), wtx);
        wty = sel8(om, _mm256_load_ps(ogg), wty);
        wtz = sel8(om, _mm256_load_ps(ogb), wtz);
    }
    if (sf->shaded) {
        __m256 differ = _mm256_or_ps(_mm256_or_ps(_mm256_cmp_ps(sx, nx, _CMP_NEQ_UQ), _mm256_cmp_ps(sy, ny, _CMP_NEQ_UQ)),
                                     _mm256_cmp_ps(sz, nz, _CMP_NEQ_UQ));
        const __m256 am = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
        __m256 den = _mm256_mul_ps(_mm256_and_ps(dot8(wox, woy, woz, nx, ny, nz), am),
                                   _mm256_and_ps(dot8(ix, iy, iz, sx, sy, sz), am));
        __m256 fac = _mm256_div_ps(_mm256_mul_ps(_mm256_and_ps(dot8(wox, woy, woz, sx, sy, sz), am),
                                                 _mm256_and_ps(dot8(ix, iy, iz, nx, ny, nz), am)),
                                   den);
        __m256 corr = _mm256_and_ps(differ, _mm256_cmp_ps(den, zero, _CMP_GT_OQ));
        wtx = sel8(corr, _mm256_mul_ps(wtx, fac), wtx);
        wty = sel8(corr, _mm256_mul_ps(wty, fac), wty);
        wtz = sel8(corr, _mm256_mul_ps(wtz, fac), wtz);
    }
    __m256 nbx = _mm256_mul_ps(bx, wtx), nby = _mm256_mul_ps(by, wty), nbz = _mm256_mul_ps(bz, wtz);
    const __m256i depth = _mm256_load_si256((const __m256i *)L->depth);
    const __m256i depth1 = _mm256_add_epi32(depth, _mm256_set1_epi32(1));
    __m256 rr = _mm256_castsi256_ps(_mm256_cmpgt_epi32(depth1, _mm256_set1_epi32(w->rr_depth - 1)));
    unsigned rr_bits = (unsigned)_mm256_movemask_ps(_mm256_and_ps(rr, alive));
    if (rr_bits) {
        __m256 ratio = _mm256_div_ps(maxf8(nbx, maxf8(nby, nbz)), maxf8(bx, maxf8(by, bz)));
        __m256 q = minf8(one, w->rr_sqrt ? _mm256_sqrt_ps(ratio) : ratio);
        unsigned draw = rr_bits & (unsigned)_mm256_movemask_ps(_mm256_cmp_ps(q, zero, _CMP_GT_OQ));
        _Alignas(32) float qa[8], ua[8] = {0};
        _mm256_store_ps(qa, q);
        for (unsigned m = draw; m; m &= m - 1) {
            unsigned i = (unsigned)__builtin_ctz(m);
            ua[i] = vbnl_rng_next(&L->rng[i]);
        }
        /* survivors: drawn and below q; lanes without roulette stay */
        __m256 survive = _mm256_and_ps(mask8(draw), _mm256_cmp_ps(_mm256_load_ps(ua), q, _CMP_LT_OQ));
        alive = _mm256_and_ps(alive, _mm256_or_ps(_mm256_andnot_ps(rr, alive), survive));
        __m256 inv = _mm256_div_ps(one, q);
        nbx = sel8(rr, _mm256_mul_ps(nbx, inv), nbx);
        nby = sel8(rr, _mm256_mul_ps(nby, inv), nby);
        nbz = sel8(rr, _mm256_mul_ps(nbz, inv), nbz);
    }
    const __m256 absm = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
    {
        const __m256 inf = _mm256_set1_ps(INFINITY);
        __m256 finite = _mm256_and_ps(_mm256_and_ps(_mm256_cmp_ps(_mm256_and_ps(nbx, absm), inf, _CMP_LT_OQ),
                                                    _mm256_cmp_ps(_mm256_and_ps(nby, absm), inf, _CMP_LT_OQ)),
                                      _mm256_cmp_ps(_mm256_and_ps(nbz, absm), inf, _CMP_LT_OQ));
        __m256 black = _mm256_and_ps(_mm256_and_ps(_mm256_cmp_ps(nbx, zero, _CMP_EQ_OQ),
                                                   _mm256_cmp_ps(nby, zero, _CMP_EQ_OQ)),
                                     _mm256_cmp_ps(nbz, zero, _CMP_EQ_OQ));
        alive = _mm256_and_ps(alive, _mm256_andnot_ps(black, finite));
    }
    /* ++depth < max_depth */
    const __m256i maxd = _mm256_load_si256((const __m256i *)L->max_depth);
    alive = _mm256_and_ps(alive, _mm256_castsi256_ps(_mm256_cmpgt_epi32(maxd, depth1)));
    /* the next ray: vbnl_offset_ray_origin(p, ng, wi), whose normal faces wi already (ng . wi > 0
     * above, and the hit's unflipped normal is turned to the same side), then wi */
    __m256 nox, noy, noz;
    {
        const __m256 int_scale = _mm256_set1_ps(256.0f), float_scale = _mm256_set1_ps(1.0f / 65536.0f);
        const __m256 origin = _mm256_set1_ps(1.0f / 32.0f);
#define SPLIT_OFFSET(P, N, OUT)                                                                            \
    do {                                                                                                   \
        __m256i of_ = _mm256_cvttps_epi32(_mm256_mul_ps(int_scale, (N)));                                  \
        __m256i neg_ = _mm256_castps_si256(_mm256_cmp_ps((P), zero, _CMP_LT_OQ));                          \
        of_ = _mm256_sub_epi32(_mm256_xor_si256(of_, neg_), neg_);                                         \
        __m256 pi_ = _mm256_castsi256_ps(_mm256_add_epi32(_mm256_castps_si256(P), of_));                   \
        __m256 pf_ = _mm256_add_ps((P), _mm256_mul_ps(float_scale, (N)));                                  \
        (OUT) = sel8(_mm256_cmp_ps(_mm256_and_ps((P), absm), origin, _CMP_LT_OQ), pf_, pi_);               \
    } while (0)
        SPLIT_OFFSET(px, nx, nox);
        SPLIT_OFFSET(py, ny, noy);
        SPLIT_OFFSET(pz, nz, noz);
#undef SPLIT_OFFSET
    }
    /* the lanes of `fast` take their new state (dead ones are replaced by the caller) */
    const __m256 fm = mask8(fast);
    _mm256_store_ps(L->ox, sel8(fm, nox, ox)), _mm256_store_ps(L->oy, sel8(fm, noy, oy));
    _mm256_store_ps(L->oz, sel8(fm, noz, oz));
    _mm256_store_ps(L->dx, sel8(fm, ix, dx)), _mm256_store_ps(L->dy, sel8(fm, iy, dy));
    _mm256_store_ps(L->dz, sel8(fm, iz, dz));
    _mm256_store_ps(L->bx, sel8(fm, nbx, bx)), _mm256_store_ps(L->by, sel8(fm, nby, by));
    _mm256_store_ps(L->bz, sel8(fm, nbz, bz));
    _mm256_store_si256((__m256i *)L->depth,
                       _mm256_castps_si256(sel8(fm, _mm256_castsi256_ps(depth1), _mm256_castsi256_ps(depth))));
    return (unsigned)_mm256_movemask_ps(alive) & fast;
}
#endif

/* Paths [b, e) of the walk (vbnl_photon_walk_inline's steps), SPLIT_LANES at a time; `rec`:
 * hits are recorded (else there is no VL to deposit into). */
static inline __attribute__((always_inline)) void trace_lanes(const split_job *job, split_thread *t, uint64_t b,
                                                             uint64_t e, int rec)
{
    const vbnl_split_desc *d = job->d;
    const vbnl_scene *sc = d->scene;
    vbnl_photon_walk_desc w = {sc, job->inv_paths, d->rr_depth, d->max_depth, 1, 1};
    vbnl_photon_walk_stats ws = {0, 0, 0};
    split_visit sv = {job, t};
    const vbnl_photon_visit_fn visit = rec ? split_visit_fn : skip_visit_fn;
    photon_lanes L;
    memset(&L, 0, sizeof(L));
    _Alignas(32) struct RTCRayHit8 r8;
    uint32_t n = 0;
    uint64_t k = b;
    while (n < SPLIT_LANES && lane_start(job, t, &w, &L, n, &k, e))
        n++;
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    while (n > 0) {
        trace_packet(sc, &ictx, &L, n, &r8);
        ws.rays += n;
        unsigned alive = 0, general = 0;
#if defined(__AVX2__)
        /* the lanes the SIMD step takes (step_fast); misses end */
        fast_surf sf; /* lanes outside `fast` (and normals outside `shaded`) are computed on and
                       * discarded: zero, not indeterminate, values there */
        memset(&sf, 0, sizeof(sf));
        unsigned fast = 0;
        if (d->general_walk)
            general = (1u << n) - 1u;
        else
            for (uint32_t i = 0; i < n; ++i) {
            const uint32_t gid = r8.hit.geomID[i];
            if (gid == RTC_INVALID_GEOMETRY_ID)
                continue;
            const scene_geom *g = &sc->geoms[gid];
            if (r8.hit.instID[0][i] != RTC_INVALID_GEOMETRY_ID || g->kind != SCENE_GEOM_MESH) {
                general |= 1u << i;
                continue;
            }
            const scene_mesh *me = &g->u.mesh;
            const uint32_t mi = me->face_materials ? me->face_materials[r8.hit.primID[i]] : me->material;
            const scene_material *sm = &sc->materials[mi];
            if (sm->varies) {
                general |= 1u << i;
                continue;
            }
            if (sm->bsdf.type != VBNL_MATERIAL_LAMBERT) {
                if (vbnl_bsdf_is_delta(&sm->bsdf) || vbnl_bsdf_is_transmissive(&sm->bsdf)) {
                    general |= 1u << i;
                    continue;
                }
                sf.other |= 1u << i;
                sf.bsdf[i] = &sm->bsdf;
            } else if (v3_is_black(sm->bsdf.color)) {
                general |= 1u << i;
                continue;
            }
            fast |= 1u << i;
            sf.material[i] = mi;
            sf.cr[i] = sm->bsdf.color.x;
            sf.cg[i] = sm->bsdf.color.y;
            sf.cb[i] = sm->bsdf.color.z;
            if (me->normals) {
                const uint32_t *tri = me->indices + 3 * (size_t)r8.hit.primID[i];
                for (int vtx = 0; vtx < 3; ++vtx)
                    for (int a = 0; a < 3; ++a)
                        sf.n[vtx][a][i] = me->normals[3 * (size_t)tri[vtx] + (size_t)a];
                sf.shaded |= 1u << i;
            }
        }
        if (fast) {
            alive = step_fast(job, t, &w, &L, &r8, fast, &sf, rec, &ws);
            t->s.simd_hits += (uint64_t)__builtin_popcount(fast);
        }
#else
        general = (1u << n) - 1u;
#endif
        /* the others through the general walk */
        for (unsigned m = general; m; m &= m - 1) {
            unsigned i = (unsigned)__builtin_ctz(m);
            struct RTCRayHit rh;
            packet_lane(&r8, i, &rh);
            vbnl_photon_state ps;
            lane_get(&L, i, &ps);
            vbnl_hit hit;
            if (vbnl_photon_hit_from(sc, ps.o, ps.dir, &rh, &hit) &&
                vbnl_photon_scatter(&w, &L.rng[i], &ps, &hit, visit, &sv, &ws)) {
                lane_put(&L, i, &ps);
                alive |= 1u << i;
            }
        }
        uint32_t m = 0; /* lanes kept, compacted in place */
        for (uint32_t i = 0; i < n; ++i) {
            if ((alive >> i & 1u) || lane_start(job, t, &w, &L, i, &k, e)) {
                if (m != i)
                    lane_move(&L, m, i);
                m++;
            }
        }
        n = m;
    }
    t->s.rays += ws.rays;
    t->s.hits += ws.hits;
    t->s.delta_hits += ws.delta_hits;
}

static __attribute__((flatten)) void trace_paths(const split_job *job, split_thread *t, uint64_t b, uint64_t e)
{
    if (job->empty)
        trace_lanes(job, t, b, e, 0);
    else
        trace_lanes(job, t, b, e, 1);
}

/* vbnl_pool_run with poll == NULL never moves its wake-up time forward once it has passed and
 * then spins on pthread_cond_timedwait (pool.c); a no-op poll keeps the caller asleep. */
static int no_poll(void *user, uint64_t finished, uint64_t count)
{
    (void)user;
    (void)finished;
    (void)count;
    return 0;
}

/* A work item traces its paths into the thread's batch, deposited whenever it fills up; the
 * last thread_count items deposit what their thread holds before they return (the caller
 * deposits what is left after the run, splitting.h), so once the run is over every finished
 * item has made all its deposits. */
static void run_chunk(void *user, uint64_t item, unsigned thread)
{
    const split_job *job = user;
    /* Workers are numbered 0 .. thread_count - 1 (pool.h; the caller never runs items), so
     * each split_thread, whose sums are plain adds, has one writer. */
    split_thread *t = &job->threads[thread];
    uint64_t b = job->begin + item * job->chunk;
    uint64_t e = b + job->chunk < job->end ? b + job->chunk : job->end;
    trace_paths(job, t, b, e);
    if (item + job->thread_count >= job->items)
        flush_batch(job, t);
}

static void threads_free(split_job *job)
{
    if (!job->threads)
        return;
    for (unsigned i = 0; i < job->thread_count; ++i) {
        split_thread *t = &job->threads[i];
        free(t->vl);
        free(t->maps);
        free(t->hits);
        free(t->order);
        free(t->bin);
        free(t->cell);
        free(t->scell);
        free(t->start);
    }
    free(job->threads);
    job->threads = NULL;
}

vbnl_result vbnl_split_photons(const vbnl_split_desc *d, vbnl_pool *pool, vbnl_stage_ctx *stage,
                               vbnl_split_stats *stats)
{
    if (stats)
        memset(stats, 0, sizeof(*stats));
    if (!d || !d->scene || !d->scene->committed || !d->index || !d->vl_normals || !d->profiles ||
        (!vbnl_vl_index_has_normals(d->index) && (d->normal_cos > -1.0f || d->require_facing)) ||
        (!pool && !stage) || d->photon_paths == 0 || d->first_path > d->photon_paths ||
        vbnl_vl_index_count(d->index) != vbnl_profile_set_count(d->profiles) || d->max_vls == 0 ||
        d->max_vls > VBNL_SPLIT_MAX_VLS)
        return VBNL_ERR_INVALID_ARGUMENT;
    double t0 = vbnl_now();
    split_job job;
    memset(&job, 0, sizeof(job));
    job.d = d;
    job.begin = d->first_path;
    job.end = d->path_count ? d->first_path + d->path_count : d->photon_paths;
    if (job.end < job.begin)
        return VBNL_ERR_INVALID_ARGUMENT;
    job.chunk = d->chunk ? d->chunk : VBNL_SPLIT_DEFAULT_CHUNK;
    job.max_vls = d->max_vls;
    job.inv_paths = (float)(1.0 / (double)d->photon_paths);
    job.inv_unit = 1.0 / vbnl_profile_set_unit(d->profiles);
    _Static_assert(VBNL_SPLIT_BIN_BITS % 3u == 0 && VBNL_SPLIT_BIN_BITS <= 24u, "bins: whole Morton triples");
    job.key_grid = vbnl_vl_index_key_grid(d->index);
    job.bins = 1u << VBNL_SPLIT_BIN_BITS;
    {
        const vbnl_vl_index *x = d->index;
        job.cell_fast = x->kind == VBNL_VL_INDEX_GRID && x->level_count == 1 && x->levels[0].dense;
        if (job.cell_fast) {
            const grid_level *g = &x->levels[0];
            int32_t nmax = g->n[0] > g->n[1] ? g->n[0] : g->n[1];
            nmax = nmax > g->n[2] ? nmax : g->n[2];
            while (((uint32_t)(nmax - 1) >> job.cell_shift) >= (1u << (VBNL_SPLIT_BIN_BITS / 3u)))
                job.cell_shift++;
        }
    }
    job.thread_count = stage ? vbnl_stage_thread_count(stage) : vbnl_pool_thread_count(pool);
    if (job.thread_count == 0)
        job.thread_count = 1;
    const uint32_t batch_hits = vbnl_split_batch_hits(job.thread_count);
    uint32_t nvl = vbnl_vl_index_count(d->index);
    job.empty = nvl == 0;
    uint8_t *glossy = NULL;
    vbnl_result res = VBNL_OK;
    for (uint32_t r = 0; r < nvl; ++r) {
        uint32_t id = vbnl_vl_index_id(d->index, r);
        if (!vbnl_profile_is_glossy(d->profiles, id))
            continue;
        if (!glossy && !(glossy = calloc(nvl, 1))) {
            res = VBNL_ERR_OUT_OF_MEMORY;
            goto done;
        }
        glossy[r] = 1;
    }
    job.glossy = glossy;
    if (glossy)
        job.maps_view = vbnl_profile_maps_view_of(d->profiles);
    job.rec_normals = vbnl_vl_index_has_normals(d->index);
    for (uint32_t r = 0; r < nvl && job.rec_normals; ++r) {
        const vl_rec *e = &d->index->rec[r];
        const vec3 nv = d->vl_normals[e->id];
        job.rec_normals = e->nx == nv.x && e->ny == nv.y && e->nz == nv.z;
    }
    job.threads = aligned_alloc(64, sizeof(split_thread) * job.thread_count);
    if (!job.threads) {
        res = VBNL_ERR_OUT_OF_MEMORY;
        goto done;
    }
    memset(job.threads, 0, sizeof(split_thread) * job.thread_count);
    /* Per-thread sums unless they would take more than VBNL_SPLIT_MAX_SUM_BYTES (many threads
     * and millions of VLs): then atomic adds into the set, the same bits. */
    int own_sums = !d->atomic_deposits &&
                   (double)nvl * (double)sizeof(split_vl) * job.thread_count <= (double)VBNL_SPLIT_MAX_SUM_BYTES;
    /* 32-bit private maps for every worker when they fit in VBNL_SPLIT_MAX_MAP_COPY_BYTES and
     * an eighth of the machine's memory; else atomic splats into the set, the same bits. */
    const size_t map_bytes = vbnl_profile_incident_bytes(d->profiles);
    const uint64_t copy_bytes = vbnl_split_map_copy_bytes(map_bytes, job.thread_count);
    const int map_copies = own_sums && copy_bytes > 0;
    for (unsigned i = 0; i < job.thread_count && !job.empty; ++i) {
        split_thread *t = &job.threads[i];
        t->cap = batch_hits;
        if (own_sums && (t->vl = vbnl_big_alloc(sizeof(split_vl) * ((size_t)nvl + 1)))) {
            memset(t->vl, 0, sizeof(split_vl) * ((size_t)nvl + 1));
            for (uint32_t r = 0; r < nvl; ++r) {
                t->vl[r].rec = d->index->rec[r];
                if (glossy && glossy[r]) /* slot + 1 in the zero lane (split_deposit) */
                    t->vl[r].acc[3] = (uint64_t)vbnl_profile_slot(d->profiles, d->index->rec[r].id) + 1u;
            }
            t->acc = t->vl[0].acc;
        }
        if (t->acc && glossy && map_copies) {
            t->maps = vbnl_big_calloc(map_bytes / 2u + SPLIT_MAP_SLACK, 1);
            if (!t->maps) {
                res = VBNL_ERR_OUT_OF_MEMORY;
                goto done;
            }
        }
        t->hits = vbnl_big_alloc(t->cap * sizeof(split_rec));
        t->order = malloc(t->cap * sizeof(uint32_t));
        t->bin = malloc(t->cap * sizeof(uint32_t));
        if (job.cell_fast && (!(t->cell = malloc(t->cap * sizeof(uint32_t))) ||
                              !(t->scell = malloc(t->cap * sizeof(uint32_t))))) {
            res = VBNL_ERR_OUT_OF_MEMORY;
            goto done;
        }
        t->start = malloc(((size_t)job.bins + 1) * sizeof(uint32_t));
        if ((own_sums && !t->vl) || !t->hits || !t->order || !t->bin || !t->start) {
            res = VBNL_ERR_OUT_OF_MEMORY;
            goto done;
        }
    }
    uint64_t items = (job.end - job.begin + job.chunk - 1) / job.chunk;
    job.items = items;
    if (items) {
        if (stage) {
            if (vbnl_stage_run(stage, items, run_chunk, &job) != 0)
                res = VBNL_ERR_CANCELLED;
        } else {
            vbnl_pool_run(pool, items, run_chunk, &job, no_poll, NULL, 1.0);
        }
        /* the batches of threads whose last item was not among the last thread_count (also
         * after a cancel: the items that ran have finished) */
        for (unsigned i = 0; i < job.thread_count && !job.empty; ++i)
            flush_batch(&job, &job.threads[i]);
    }
    /* The private maps' low halves into the set's maps (integer adds: the same bits as atomic
     * splats; deposits of finished work items stay after a cancel). */
    for (unsigned i = 0; i < job.thread_count && !job.empty; ++i)
        if (job.threads[i].maps)
            vbnl_profile_add_incident_lo32(d->profiles, job.threads[i].maps);
    /* Phi_in: the threads' sums, added in rank order (integer adds: the same bits for any
     * thread count and order). */
    for (uint32_t r = 0; r < nvl && own_sums; ++r) {
        uint64_t q[3] = {0, 0, 0};
        for (unsigned i = 0; i < job.thread_count; ++i)
            for (int c = 0; c < 3; ++c)
                q[c] += job.threads[i].acc[ACC_STRIDE * (size_t)r + c];
        if (q[0] | q[1] | q[2])
            vbnl_profile_add_power_fixed(d->profiles, vbnl_vl_index_id(d->index, r), q);
    }
    if (stats) {
        for (unsigned i = 0; i < job.thread_count; ++i) {
            const vbnl_split_stats *s = &job.threads[i].s;
            stats->paths += s->paths;
            stats->rays += s->rays;
            stats->hits += s->hits;
            stats->delta_hits += s->delta_hits;
            stats->simd_hits += s->simd_hits;
            stats->covered_hits += s->covered_hits;
            stats->deposits += s->deposits;
            stats->overflow += s->overflow;
            stats->support_tests += s->support_tests;
            stats->support_rejects += s->support_rejects;
            for (int c = 0; c < 3; ++c)
                stats->covered_power[c] += job.threads[i].cov[c];
        }
        stats->seconds = vbnl_now() - t0;
        stats->scratch_bytes = job.empty ? 0u : (uint64_t)job.thread_count *
                               ((own_sums ? (uint64_t)sizeof(split_vl) * (nvl + 1) : 0ull) +
                                (uint64_t)batch_hits *
                                    (sizeof(split_rec) + (job.cell_fast ? 4 : 2) * sizeof(uint32_t)) +
                                4ull * (job.bins + 1)) +
                               (glossy ? nvl : 0u) +
                               (map_copies ? copy_bytes : 0ull);
    }
done:
    threads_free(&job);
    free(glossy);
    return res;
}
