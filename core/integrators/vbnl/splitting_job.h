/* Photon splitting's working state (part of splitting.c, included once by it; see there): the
 * batch records, the per-thread sums and splat queues, the job. */
#ifndef VBI_SPLITTING_JOB_H
#define VBI_SPLITTING_JOB_H

#define SPLAT_RING 16u

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
 * (octahedral.h, vbi_hemioct_footprint: texels x0 and x1 == x0 or x0 + 1 of rows y0 and y1) as
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
        vbi_profile_splat32 sp;
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
    _Alignas(64) vbi_split_stats s;
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
    /* This thread's 32-bit incident maps (profiles.h, vbi_profile_splat_prepare_lo32), which
     * it splats into with plain adds and which are added into the set when the run ends; NULL:
     * atomic adds into the set's maps (no glossy VL, no per-thread sums, or maps over the
     * budget). */
    uint32_t *maps;
} split_thread;

typedef struct split_job {
    const vbi_split_desc *d;
    uint64_t begin, end;     /* global path range */
    uint64_t items;          /* work items of `chunk` paths */
    uint32_t chunk, max_vls;
    float inv_paths;
    double inv_unit;         /* 1 / fixed-point unit of the profiles (exact: a power of two) */
    const uint8_t *glossy;   /* by rank: the VL keeps a map; NULL when none does */
    vbi_vl_key_grid key_grid; /* bin = vbi_vl_key_bin(key grid, p, VBI_SPLIT_BIN_BITS / 3) */
    uint32_t bins;
    /* The index is one dense grid level (uniform radii): hits carry their cell (split_rec), and
     * the bin is the Morton code of the cell coordinates >> cell_shift (VBI_SPLIT_BIN_BITS / 3
     * bits each), so the key grid is not needed. */
    int cell_fast;
    uint32_t cell_shift;
    int empty;               /* the index holds no VL */
    int rec_normals;         /* every index record's normal is bit for bit d->vl_normals[id] */
    vbi_profile_maps_view maps_view; /* for the threads' vector splats (splat_queue_run) */
    split_thread *threads;
    unsigned thread_count;
} split_job;

typedef struct split_ctx {
    const split_job *job;
    split_thread *t;
    const split_rec *recs;
    const uint32_t *order;
} split_ctx;

#endif
