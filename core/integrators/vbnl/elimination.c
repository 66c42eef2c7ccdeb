/* VBNL stage 2: weighted sample elimination, serial and box-parallel (paper section 3.2,
 * Yuksel 2015). See elimination.h for the method; comments here say why. */
#include "elimination.h"

#include <float.h>
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "kdtree.h"
#include "rng.h"

#define VBI_SQRT3 1.7320508075688772
#define VBI_DEAD UINT32_MAX
/* m-NN and neighbour-list work items: subtrees of at most this many points, a function of M
 * only (results never depend on the thread count, and do not depend on the items at all). */
#define VBI_KNN_CHUNK 8192u
/* Parallel decomposition: 8^levels leaf boxes with at least this many candidates each. */
#define VBI_MIN_BOX_POINTS 512u

/* ---- neighbour-list entries and weight terms ---------------------------------------------- */

/* One entry of a point's neighbour list: a point j whose own d_max,j covers it, and the term it
 * adds to w_j. Every point's list is built once (vbi_nb_build) and serves every box of every
 * level: a box is a contiguous range of tree positions, so "j is in the box" is a range test.
 * This replaces a radius query per point and per removal in a per-box k-d tree: the pairs and
 * their terms are the ones those queries found, computed once instead of once per level, and a
 * removal no longer searches as far as the largest d_max that counted the point ("reach"). */
typedef struct vbi_elim_nb {
    uint32_t j;  /* tree position */
    float term;  /* (1 - d^ / d_max,j)^alpha */
} vbi_elim_nb;

/* A point's list: its entries and their count. */
typedef struct vbi_elim_list {
    const vbi_elim_nb *l;
    uint32_t n;
} vbi_elim_list;

/* (1 - d^ / dmax)^alpha with d^ = max(d, dmin) (Yuksel 2015: weight function and weight
 * limiting; alpha = 8 is three squarings). */
static inline float vbi_elim_term(float d2, float dmax, float dmin_scale, float alpha)
{
    float d = sqrtf(d2), dmin = dmin_scale * dmax;
    float t = 1.0f - (d > dmin ? d : dmin) / dmax;
    if (alpha == 8.0f) {
        t *= t;
        t *= t;
        return t * t;
    }
    return powf(t, alpha);
}

/* vbi_elim_term for alpha = 8, branch-free so that loops over it vectorise; the same value
 * (the same operations in the same order). */
static inline float vbi_elim_term8(float d2, float dmax, float dmin_scale)
{
    float d = sqrtf(d2), dmin = dmin_scale * dmax;
    float t = 1.0f - (d > dmin ? d : dmin) / dmax;
    t *= t;
    t *= t;
    return t * t;
}

/* ---- candidate sets ------------------------------------------------------------------------ */

/* k-th smallest (0-based) of a[0..n), reordering a. Deterministic quickselect. */
static float vbi_select(float *a, int32_t n, int32_t k)
{
    int32_t l = 0, r = n - 1;
    while (r > l) {
        float x = a[l], y = a[l + (r - l) / 2], z = a[r];
        float pv = x < y ? (y < z ? y : (x < z ? z : x)) : (x < z ? x : (y < z ? z : y));
        int32_t i = l, j = r;
        while (i <= j) {
            while (a[i] < pv)
                i++;
            while (a[j] > pv)
                j--;
            if (i <= j) {
                float t = a[i];
                a[i] = a[j];
                a[j] = t;
                i++;
                j--;
            }
        }
        if (k <= j)
            r = j;
        else if (k >= i)
            l = i;
        else
            return a[k]; /* between j and i: equal to the pivot */
    }
    return a[k];
}

/* Candidates of one leaf's queries, structure of arrays (the distance loops vectorise). */
typedef struct vbi_cand {
    uint32_t *i;
    float *x, *y, *z, *d2, *sel, *r2, *dm;
    uint8_t *mask; /* cap + 8 bytes */
    uint32_t cap;
} vbi_cand;

/* Trailing zero bits of x != 0. */
static inline uint32_t vbi_ctz64(uint64_t x)
{
#if defined(__GNUC__) || defined(__clang__)
    return (uint32_t)__builtin_ctzll(x);
#else
    uint32_t n = 0;
    while (!(x & 1u)) {
        x >>= 1;
        n++;
    }
    return n;
#endif
}

/* mask[k] = a[k] < b[k] for k < n, 0 up to the next multiple of 8; returns the count. The
 * compare loop vectorises; the kept indices are then read 8 at a time, one bit per kept byte,
 * instead of a compress loop with a store per candidate. */
static uint32_t vbi_mask_lt(const float *restrict a, const float *restrict b, uint32_t n,
                             uint8_t *restrict mask)
{
    uint32_t cnt = 0;
    for (uint32_t k = 0; k < n; ++k) {
        mask[k] = a[k] < b[k];
        cnt += a[k] < b[k];
    }
    for (uint32_t k = n; k < ((n + 7) & ~7u); ++k)
        mask[k] = 0;
    return cnt;
}

static void vbi_cand_free(vbi_cand *c)
{
    free(c->i);
    free(c->x);
    free(c->y);
    free(c->z);
    free(c->d2);
    free(c->sel);
    free(c->r2);
    free(c->dm);
    free(c->mask);
    memset(c, 0, sizeof(*c));
}

static int vbi_cand_alloc(vbi_cand *c, uint32_t cap)
{
    vbi_cand_free(c);
    c->cap = cap;
    c->i = malloc((size_t)cap * sizeof(uint32_t));
    float **f[7] = {&c->x, &c->y, &c->z, &c->d2, &c->sel, &c->r2, &c->dm};
    for (int k = 0; k < 7; ++k)
        *f[k] = malloc((size_t)cap * sizeof(float));
    c->mask = malloc((size_t)cap + 8);
    if (!c->i || !c->x || !c->y || !c->z || !c->d2 || !c->sel || !c->r2 || !c->dm || !c->mask) {
        vbi_cand_free(c);
        return -1;
    }
    return 0;
}

/* ---- neighbour lists ------------------------------------------------------------------------ */

/* What the neighbour lists are built from. */
typedef struct vbi_nb_ctx {
    const vbi_kd_tree *tree;
    const float *dm;      /* d_max per tree position */
    const float *reach2;  /* d_max^2 per tree position, padded (gathering only) */
    const float *node_r2; /* per node: the largest reach2 of its points */
    float alpha, dmin_scale;
} vbi_nb_ctx;

/* A growing block of lists: the entries, and per point of [pb, pe) where its list starts in
 * the block and its length. */
typedef struct vbi_nb_out {
    vbi_elim_nb *buf;
    size_t used, cap;
    uint32_t pb;
    uint32_t *off, *cnt;
} vbi_nb_out;

static void vbi_nb_out_free(vbi_nb_out *o)
{
    free(o->buf);
    free(o->off);
    free(o->cnt);
    memset(o, 0, sizeof(*o));
}

static int vbi_nb_out_alloc(vbi_nb_out *o, uint32_t pb, uint32_t pe)
{
    memset(o, 0, sizeof(*o));
    o->pb = pb;
    o->cap = (size_t)(pe - pb) * 40 + 1024;
    o->buf = malloc(o->cap * sizeof(vbi_elim_nb));
    o->off = malloc(((size_t)(pe - pb) + 1) * sizeof(uint32_t));
    o->cnt = malloc(((size_t)(pe - pb) + 1) * sizeof(uint32_t));
    if (!o->buf || !o->off || !o->cnt) {
        vbi_nb_out_free(o);
        return -1;
    }
    return 0;
}

/* The neighbour list of every point q of the leaves among nodes [n0, n1): every j != q with
 * d_qj < d_max,j and its term, the pairs and the d^2 test of the weight sum. Leaf by leaf: the
 * j whose d_max,j reaches the leaf's box are gathered once (the tree's nodes carry the largest
 * d_max of their points), then each q is a vectorised pass over them. Appends to `o`; 0, or -1
 * when out of memory. */
static int vbi_nb_build(const vbi_nb_ctx *x, uint32_t n0, uint32_t n1, vbi_nb_out *o,
                         vbi_cand *c)
{
    const vbi_kd_tree *t = x->tree;
    const float alpha = x->alpha, dms = x->dmin_scale;
    for (uint32_t ni = n0; ni < n1; ++ni) {
        const vbi_kd_node *nd = &t->nodes[ni];
        if (nd->axis != VBI_KD_LEAF_AXIS)
            continue;
        const float *box = t->box + 6 * (size_t)ni;
        uint32_t nc;
        while ((nc = vbi_kd_gather_reach(t, box, box + 3, x->node_r2, x->reach2, c->i, c->cap)) > c->cap)
            if (vbi_cand_alloc(c, 2 * c->cap) != 0)
                return -1;
        for (uint32_t k = 0; k < nc; ++k) {
            const float *p = t->pts[c->i[k]].p;
            c->x[k] = p[0];
            c->y[k] = p[1];
            c->z[k] = p[2];
            c->dm[k] = x->dm[c->i[k]];
            c->r2[k] = c->dm[k] * c->dm[k];
        }
        const size_t need = o->used + (size_t)(nd->end - nd->begin) * nc;
        if (need > o->cap) {
            size_t want = o->cap * 2 > need ? o->cap * 2 : need;
            vbi_elim_nb *nbuf = realloc(o->buf, want * sizeof(vbi_elim_nb));
            if (!nbuf)
                return -1;
            o->buf = nbuf;
            o->cap = want;
        }
        uint32_t self[VBI_KD_LEAF];
        for (uint32_t k = 0; k < nc; ++k)
            if (c->i[k] - nd->begin < nd->end - nd->begin)
                self[c->i[k] - nd->begin] = k;
        for (uint32_t q = nd->begin; q < nd->end; ++q) {
            const float qx = t->pts[q].p[0], qy = t->pts[q].p[1], qz = t->pts[q].p[2];
            for (uint32_t k = 0; k < nc; ++k) {
                float dx = qx - c->x[k], dy = qy - c->y[k], dz = qz - c->z[k];
                c->d2[k] = dx * dx + dy * dy + dz * dz;
            }
            /* q itself (always gathered: reach2 > 0) gets INFINITY, tested false below. */
            c->d2[self[q - nd->begin]] = INFINITY;
            /* Terms of all candidates (vectorised; only those covering q are kept). */
            if (alpha == 8.0f)
                for (uint32_t k = 0; k < nc; ++k)
                    c->sel[k] = vbi_elim_term8(c->d2[k], c->dm[k], dms);
            else
                for (uint32_t k = 0; k < nc; ++k)
                    c->sel[k] = c->d2[k] < c->r2[k] ? vbi_elim_term(c->d2[k], c->dm[k], dms, alpha) : 0.0f;
            if (o->used > UINT32_MAX)
                return -1;
            o->off[q - o->pb] = (uint32_t)o->used;
            vbi_elim_nb *restrict e = o->buf + o->used;
            const uint32_t *restrict ci = c->i;
            const float *restrict term = c->sel;
            const uint8_t *restrict mk = c->mask;
            const uint32_t cnt = vbi_mask_lt(c->d2, c->r2, nc, c->mask);
            for (uint32_t base = 0; base < nc; base += 8) {
                uint64_t bits;
                memcpy(&bits, mk + base, 8);
                while (bits) {
                    uint32_t xk = base + (vbi_ctz64(bits) >> 3);
                    e->j = ci[xk];
                    e->term = term[xk];
                    e++;
                    bits &= bits - 1;
                }
            }
            o->cnt[q - o->pb] = cnt;
            o->used += cnt;
        }
    }
    return 0;
}

/* ---- elimination in one box ---------------------------------------------------------------- */

typedef struct vbi_elim_box {
    uint32_t *pos;   /* tree positions: in, the box's alive candidates, increasing; out, survivors */
    uint32_t n;      /* in: count; out: survivors */
    uint32_t remove; /* how many to eliminate */
    uint32_t lo, hi; /* the box is the tree positions [lo, hi) (a subtree) */
    uint32_t node, node_end;   /* and the nodes [node, node_end) */
    const vbi_elim_list *hdr; /* NULL, or the lists of lo..hi-1 (else shared->nb) */
} vbi_elim_box;

typedef struct vbi_elim_shared {
    const vbi_kd_pt *pts;          /* tree order; .id is the global index (ties) */
    vbi_elim_list *nb;             /* per tree position: its neighbour list */
    uint32_t *loc;                  /* per tree position: VBI_DEAD once removed, else scratch */
    vbi_elim_box *boxes;
    const vbi_nb_ctx *ctx;         /* leaf boxes: what they build their lists from ... */
    vbi_elim_nb **kept;            /* ... and per leaf box, the block of its survivors' lists */
    atomic_int failed;
} vbi_elim_shared;

/* A heap slot carries its weight, so that sifting reads one array. */
typedef struct vbi_elim_slot {
    float w;
    uint32_t i; /* the point's index in the box */
} vbi_elim_slot;

/* Heap order: larger weight first, ties broken by the smaller global index (determinism). */
static inline int vbi_elim_before(vbi_elim_slot a, vbi_elim_slot b, const uint32_t *id)
{
    return a.w > b.w || (a.w == b.w && id[a.i] < id[b.i]);
}

/* Weights only decrease (every term is >= 0), so a slot only ever moves down. */
#if defined(__GNUC__) || defined(__clang__)
__attribute__((always_inline)) /* ~2 million calls per 130K candidates, most of them short */
#endif
static inline void vbi_elim_sift_down(vbi_elim_slot *heap, uint32_t *hpos, uint32_t hn,
                                const uint32_t *id, uint32_t pos)
{
    vbi_elim_slot x = heap[pos];
    for (;;) {
        uint32_t c = 2 * pos + 1;
        if (c >= hn)
            break;
        if (c + 1 < hn && vbi_elim_before(heap[c + 1], heap[c], id))
            c++;
        if (!vbi_elim_before(heap[c], x, id))
            break;
        heap[pos] = heap[c];
        hpos[heap[pos].i] = pos;
        pos = c;
    }
    heap[pos] = x;
    hpos[x.i] = pos;
}

#if defined(__GNUC__) || defined(__clang__)
#define VBI_PREFETCH(p) __builtin_prefetch(p)
#else
#define VBI_PREFETCH(p) ((void)(p))
#endif

/* Pops the heap top and subtracts its terms from the alive points of the box that counted it.
 * `list(i)` gives the entries of box point i, `local(j)` an entry's box index (or >= n when it
 * is outside the box). The next top's entries are prefetched while this one's are applied: the
 * removal loop is bound by those loads. */
#define VBI_ELIM_REMOVE_LOOP(LIST, LIST_N, LIST_HEAD, LOCAL)                                      \
    for (uint32_t r = 0; r < remove; ++r) {                                                        \
        uint32_t top = heap[0].i;                                                                  \
        hn--;                                                                                      \
        if (hn > 0) {                                                                              \
            heap[0] = heap[hn];                                                                    \
            hpos[heap[0].i] = 0;                                                                   \
            vbi_elim_sift_down(heap, hpos, hn, id, 0);                                            \
            const vbi_elim_nb *nx = LIST(heap[0].i);                                              \
            for (uint32_t k = 0, c = LIST_N(heap[0].i); k < c; k += 8)                             \
                VBI_PREFETCH(nx + k);                                                             \
            if (hn > 2) { /* the likely tops after that one: their list headers */                 \
                VBI_PREFETCH(LIST_HEAD(heap[1].i));                                               \
                VBI_PREFETCH(LIST_HEAD(heap[2].i));                                               \
            }                                                                                      \
        }                                                                                          \
        hpos[top] = VBI_DEAD;                                                                     \
        const vbi_elim_nb *l = LIST(top);                                                         \
        for (uint32_t k = 0, c = LIST_N(top); k < c; ++k) {                                        \
            uint32_t li = LOCAL(l[k].j);                                                           \
            if (li >= n || hpos[li] == VBI_DEAD)                                                  \
                continue;                                                                          \
            uint32_t sl = hpos[li];                                                                \
            heap[sl].w -= l[k].term;                                                               \
            vbi_elim_sift_down(heap, hpos, hn, id, sl);                                           \
        }                                                                                          \
    }

/* Weighted sample elimination of box->remove points of the box (Yuksel 2015 section 3 with the
 * asymmetric adaptive weights of Li et al. 2022 section 3.2). The box's alive points must not be
 * VBI_DEAD in sh->loc; the removed ones become so. Returns 0 or -1 (out of memory).
 *
 * Everything per point lives in arrays indexed by the point's place in the box (heap slots,
 * global indices, and for a box some of whose points are already gone, its lists cut down to
 * its alive points): the root keeps ~14% of its range, and its lists ~14% of their entries. The
 * weights and the elimination order are the same either way. */
static int vbi_elim_box_run(const vbi_elim_shared *sh, vbi_elim_box *box)
{
    const uint32_t n = box->n;
    if (box->remove == 0 || n == 0)
        return 0;
    const uint32_t lo = box->lo, span = box->hi - box->lo, *pos = box->pos;
    const int compact = n < span; /* else pos[i] = lo + i */
    const vbi_elim_list *nb = sh->nb, *hdr = box->hdr ? box->hdr : sh->nb + lo;
    uint32_t *loc = sh->loc;
    vbi_elim_slot *heap = malloc((size_t)n * sizeof(vbi_elim_slot));
    uint32_t *hpos = malloc((size_t)n * sizeof(uint32_t)), *id = malloc((size_t)n * sizeof(uint32_t));
    float *w = calloc(n, sizeof(float));
    vbi_elim_nb *cl = NULL; /* compacted lists: entries ... */
    uint32_t *cb = NULL;     /* ... and where each point's start (n + 1) */
    if (!heap || !hpos || !id || !w)
        goto fail;
    for (uint32_t i = 0; i < n; ++i)
        id[i] = sh->pts[pos[i]].id;
    /* w_j = sum of the terms of the box's alive points that j's d_max,j covers, summed in
     * increasing tree position of those points (a fixed order: the same weight for any thread
     * count, with or without compaction). */
    if (compact) {
        size_t cap = 0;
        for (uint32_t i = 0; i < n; ++i) {
            loc[pos[i]] = i;
            cap += nb[pos[i]].n;
        }
        if (cap > UINT32_MAX)
            goto fail;
        cb = malloc(((size_t)n + 1) * sizeof(uint32_t));
        cl = malloc((cap ? cap : 1) * sizeof(vbi_elim_nb));
        if (!cb || !cl)
            goto fail;
        uint32_t used = 0;
        for (uint32_t i = 0; i < n; ++i) {
            cb[i] = used;
            const vbi_elim_nb *l = nb[pos[i]].l;
            for (uint32_t k = 0, c = nb[pos[i]].n; k < c; ++k) {
                uint32_t j = l[k].j;
                if (j - lo < span && loc[j] != VBI_DEAD) {
                    w[loc[j]] += l[k].term;
                    cl[used].j = loc[j];
                    cl[used].term = l[k].term;
                    used++;
                }
            }
        }
        cb[n] = used;
    } else {
        for (uint32_t i = 0; i < n; ++i) {
            const vbi_elim_nb *l = hdr[i].l;
            for (uint32_t k = 0, c = hdr[i].n; k < c; ++k)
                if (l[k].j - lo < span)
                    w[l[k].j - lo] += l[k].term;
        }
    }
    for (uint32_t i = 0; i < n; ++i) {
        heap[i].w = w[i];
        heap[i].i = i;
        hpos[i] = i;
    }
    uint32_t hn = n;
    for (uint32_t i = n / 2; i-- > 0;)
        vbi_elim_sift_down(heap, hpos, hn, id, i);
    const uint32_t remove = box->remove < n ? box->remove : n;
    if (compact) {
#define VBI_CL_LIST(i) (cl + cb[i])
#define VBI_CL_N(i) (cb[(i) + 1] - cb[i])
#define VBI_CL_LOCAL(j) (j)
#define VBI_CL_HEAD(i) (cb + (i))
        VBI_ELIM_REMOVE_LOOP(VBI_CL_LIST, VBI_CL_N, VBI_CL_HEAD, VBI_CL_LOCAL)
    } else {
#define VBI_NB_LIST(i) (hdr[i].l)
#define VBI_NB_N(i) (hdr[i].n)
#define VBI_NB_LOCAL(j) ((j) - lo)
#define VBI_NB_HEAD(i) (hdr + (i))
        VBI_ELIM_REMOVE_LOOP(VBI_NB_LIST, VBI_NB_N, VBI_NB_HEAD, VBI_NB_LOCAL)
    }
#undef VBI_CL_LIST
#undef VBI_CL_N
#undef VBI_CL_LOCAL
#undef VBI_CL_HEAD
#undef VBI_NB_LIST
#undef VBI_NB_N
#undef VBI_NB_LOCAL
#undef VBI_NB_HEAD
    uint32_t out = 0;
    for (uint32_t i = 0; i < n; ++i) {
        uint32_t t = pos[i];
        if (hpos[i] != VBI_DEAD)
            box->pos[out++] = t;
        else
            loc[t] = VBI_DEAD;
    }
    box->n = out;
    free(cl);
    free(cb);
    free(w);
    free(id);
    free(hpos);
    free(heap);
    return 0;
fail:
    free(cl);
    free(cb);
    free(w);
    free(id);
    free(hpos);
    free(heap);
    return -1;
}

static void vbi_elim_box_item(void *user, uint64_t item, unsigned thread)
{
    (void)thread;
    vbi_elim_shared *sh = user;
    if (vbi_elim_box_run(sh, &sh->boxes[item]) != 0)
        atomic_store(&sh->failed, 1);
}

/* A leaf box of the parallel variant: builds its points' lists, eliminates, and keeps the
 * survivors' lists (shared->nb) without the entries of its own removed points, which no later
 * level reads. Building the lists box by box keeps them in cache while the box eliminates
 * (~6 MB for 20K points), and only the survivors' shortened lists (~10% of all entries) stay
 * in memory for the joined boxes; the lists, weights and removals are those of building all
 * lists first. */
static void vbi_elim_leaf_item(void *user, uint64_t item, unsigned thread)
{
    (void)thread;
    vbi_elim_shared *sh = user;
    vbi_elim_box *box = &sh->boxes[item];
    const uint32_t lo = box->lo, span = box->hi - box->lo;
    vbi_cand c;
    vbi_nb_out o;
    memset(&c, 0, sizeof(c));
    vbi_elim_list *hdr = NULL;
    vbi_elim_nb *kept = NULL;
    if (vbi_nb_out_alloc(&o, lo, box->hi) != 0 || vbi_cand_alloc(&c, 1024) != 0 ||
        vbi_nb_build(sh->ctx, box->node, box->node_end, &o, &c) != 0)
        goto fail;
    vbi_cand_free(&c);
    hdr = malloc((size_t)span * sizeof(vbi_elim_list));
    if (!hdr)
        goto fail;
    for (uint32_t i = 0; i < span; ++i) {
        hdr[i].l = o.buf + o.off[i];
        hdr[i].n = o.cnt[i];
    }
    box->hdr = hdr;
    if (vbi_elim_box_run(sh, box) != 0)
        goto fail;
    box->hdr = NULL;
    size_t total = 0;
    for (uint32_t s = 0; s < box->n; ++s)
        total += hdr[box->pos[s] - lo].n;
    kept = malloc((total ? total : 1) * sizeof(vbi_elim_nb));
    if (!kept)
        goto fail;
    size_t used = 0;
    for (uint32_t s = 0; s < box->n; ++s) {
        uint32_t t = box->pos[s];
        const vbi_elim_nb *l = hdr[t - lo].l;
        sh->nb[t].l = kept + used;
        for (uint32_t k = 0, cnt = hdr[t - lo].n; k < cnt; ++k)
            if (l[k].j - lo >= span || sh->loc[l[k].j] != VBI_DEAD)
                kept[used++] = l[k];
        sh->nb[t].n = (uint32_t)(kept + used - sh->nb[t].l);
    }
    sh->kept[item] = kept;
    free(hdr);
    vbi_nb_out_free(&o);
    return;
fail:
    box->hdr = NULL;
    free(kept);
    free(hdr);
    vbi_nb_out_free(&o);
    vbi_cand_free(&c);
    atomic_store(&sh->failed, 1);
}

/* ---- running work items ---------------------------------------------------------------------- */

static int vbi_elim_pool_run(void *ctx, uint64_t count, vbi_pool_fn fn, void *user)
{
    uint64_t ran = vbi_pool_run(ctx, count, fn, user, NULL, NULL, 0.0);
    return ran < count ? -1 : 0;
}

vbi_elim_exec vbi_elim_exec_pool(vbi_pool *pool)
{
    vbi_elim_exec e;
    e.run = pool ? vbi_elim_pool_run : NULL;
    e.ctx = pool;
    return e;
}

static int vbi_elim_exec_run(const vbi_elim_exec *exec, uint64_t count, vbi_pool_fn fn, void *user)
{
    if (count == 0)
        return 0;
    if (exec && exec->run)
        return exec->run(exec->ctx, count, fn, user) != 0 ? -1 : 0;
    for (uint64_t i = 0; i < count; ++i)
        fn(user, i, 0);
    return 0;
}

/* vbi_elim_exec_run for a job whose items report allocation failures in *failed: a cancelled
 * run or a failure becomes the error of `what` (the stage, for the message). */
static vbnl_result vbi_elim_exec_checked(const vbi_elim_exec *exec, uint64_t count, vbi_pool_fn fn, void *user,
                                          atomic_int *failed, const char *what, vbnl_error *err)
{
    if (vbi_elim_exec_run(exec, count, fn, user) != 0)
        return vbnl_error_set(err, VBNL_ERR_CANCELLED, "vbi_eliminate: cancelled");
    if (atomic_load(failed))
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "vbi_eliminate: out of memory (%s)", what);
    return VBNL_OK;
}

/* ---- per-point radii (Eq. 1, 2) ------------------------------------------------------------- */

typedef struct vbi_kd_build_job {
    vbi_kd_tree *tree;
    const vbi_kd_subtree *jobs;
    vbi_kd_subtree *out; /* split items: 2 per job */
    uint32_t *nout;       /* split items: per job */
    uint32_t count;
} vbi_kd_build_job;

static void vbi_kd_build_item(void *user, uint64_t item, unsigned thread)
{
    (void)thread;
    vbi_kd_build_job *bj = user;
    vbi_kd_build_subtree(bj->tree, &bj->jobs[item]);
}

static void vbi_kd_split_item(void *user, uint64_t item, unsigned thread)
{
    (void)thread;
    vbi_kd_build_job *bj = user;
    vbi_kd_build_split(bj->tree, &bj->jobs[item], bj->out + 2 * item, bj->nout + item);
}

/* Work items of the m-NN search and of the neighbour lists: the subtrees [node, node_end) at a
 * depth that depends only on M (so results never depend on the thread count). */
typedef struct vbi_tree_items {
    uint32_t *node, *node_end, *begin, *end;
    uint32_t count;
} vbi_tree_items;

typedef struct vbi_knn_job {
    const vbi_kd_tree *tree;
    const vbi_tree_items *items;
    uint32_t m;
    float *area; /* A_i = pi d_i^2 per global index */
    atomic_int failed;
} vbi_knn_job;

/* Padding of distance bounds against rounding (a bound too tight only costs an exact search). */
static inline float vbi_pad2(float r) { return r * r * 1.0001f + FLT_MIN; }

/* Gathering radius of the batched m-NN search, relative to the previous leaf's largest m-th
 * distance: larger gathers more candidates, smaller misses more often (exact search). */
#define VBI_KNN_GATHER 1.15f
/* Selection windows: thresholds relative to the previous leaf's mean m-th squared distance
 * (~6% apart, ~2 of 32 candidates per window), then the gathering radius. */
#define VBI_KNN_LEVELS 8
static const float vbi_knn_level[VBI_KNN_LEVELS - 1] = {0.80f, 0.88f, 0.94f, 1.0f, 1.06f, 1.14f, 1.26f};

/* The m-NN search of Eq. 2, a leaf of the tree at a time. The leaf's queries share one
 * candidate set C, every point within R of the leaf's box; then every point within R of a query
 * q of the leaf is in C, so when at least m candidates other than q lie within R of q, the m-th
 * smallest of their squared distances is the exact one. Each query is then a brute-force pass
 * over ~100 candidates (vectorised) and a selection, instead of a tree descent with a heap. R is
 * an estimate (the previous leaf's m-th distances, VBI_KNN_GATHER larger); a query it misses is
 * searched exactly in the tree (vbi_kd_knn). The result does not depend on R. */
static void vbi_knn_item(void *user, uint64_t item, unsigned thread)
{
    (void)thread;
    vbi_knn_job *job = user;
    const vbi_kd_tree *t = job->tree;
    const uint32_t m = job->m;
    vbi_cand c;
    memset(&c, 0, sizeof(c));
    float *knn_d2 = malloc((size_t)m * sizeof(float)); /* scratch of the exact search */
    uint32_t *knn_i = malloc((size_t)m * sizeof(uint32_t));
    if (!knn_d2 || !knn_i || vbi_cand_alloc(&c, 1024u + 8u * m) != 0) {
        free(knn_d2);
        free(knn_i);
        atomic_store(&job->failed, 1);
        return;
    }
    float est = 0.0f, mean = 0.0f; /* the previous leaf's largest and mean m-th distance */
    for (uint32_t ni = job->items->node[item]; ni < job->items->node_end[item]; ++ni) {
        const vbi_kd_node *nd = &t->nodes[ni];
        if (nd->axis != VBI_KD_LEAF_AXIS)
            continue;
        const uint32_t b = nd->begin, e = nd->end;
        if (!(est > 0.0f))
            mean = est = sqrtf(vbi_kd_mth_dist2(t, b + (e - b) / 2, m, knn_i, knn_d2));
        const float r2g = (VBI_KNN_GATHER * est) * (VBI_KNN_GATHER * est);
        /* Points within R of q have a box distance below r2g even after rounding. */
        const float r2f = r2g * 0.9999f;
        /* Thresholds around the expected m-th squared distance, the last one r2f: counting the
         * candidates under each (one vectorised pass) tells which window (thr[L-1], thr[L]]
         * holds the m-th smallest, and how many are below it. Only that window's few values
         * are then extracted and selected from; the result is exact for any thresholds. */
        float thr[VBI_KNN_LEVELS];
        for (int l = 0; l < VBI_KNN_LEVELS - 1; ++l) {
            float x = vbi_knn_level[l] * mean * mean;
            thr[l] = x < r2f ? x : r2f;
        }
        thr[VBI_KNN_LEVELS - 1] = r2f;
        const float *box = t->box + 6 * (size_t)ni;
        uint32_t nc = r2g > 0.0f ? vbi_kd_gather_box(t, box, box + 3, r2g, c.i, c.cap) : c.cap + 1;
        uint32_t self[VBI_KD_LEAF];
        if (nc <= c.cap)
            for (uint32_t k = 0; k < nc; ++k) {
                const float *p = t->pts[c.i[k]].p;
                c.x[k] = p[0];
                c.y[k] = p[1];
                c.z[k] = p[2];
                if (c.i[k] - b < e - b)
                    self[c.i[k] - b] = k;
            }
        float next = 0.0f, sum = 0.0f;
        for (uint32_t q = b; q < e; ++q) {
            const float *pq = t->pts[q].p;
            uint32_t ns = 0, below = 0; /* window size, and candidates below the window */
            if (nc <= c.cap) {
                const float qx = pq[0], qy = pq[1], qz = pq[2];
                for (uint32_t k = 0; k < nc; ++k) {
                    float dx = qx - c.x[k], dy = qy - c.y[k], dz = qz - c.z[k];
                    c.d2[k] = dx * dx + dy * dy + dz * dz;
                }
                c.d2[self[q - b]] = INFINITY;
                const float *restrict cd2 = c.d2;
                uint32_t cnt[VBI_KNN_LEVELS] = {0};
                for (uint32_t k = 0; k < nc; ++k)
                    for (int l = 0; l < VBI_KNN_LEVELS; ++l)
                        cnt[l] += cd2[k] <= thr[l];
                if (cnt[VBI_KNN_LEVELS - 1] >= m) {
                    int l = 0;
                    while (cnt[l] < m)
                        l++;
                    below = l > 0 ? cnt[l - 1] : 0;
                    const float wlo = l > 0 ? thr[l - 1] : -1.0f, whi = thr[l];
                    uint8_t *restrict mk = c.mask;
                    for (uint32_t k = 0; k < nc; ++k)
                        mk[k] = (uint8_t)((cd2[k] > wlo) & (cd2[k] <= whi)); /* no &&: vectorises */
                    for (uint32_t k = nc; k < ((nc + 7) & ~7u); ++k)
                        mk[k] = 0;
                    ns = cnt[l] - below;
                    float *restrict sel = c.sel, *const sel_end = c.sel + ns;
                    for (uint32_t base = 0; sel < sel_end; base += 8) {
                        uint64_t bits;
                        memcpy(&bits, mk + base, 8);
                        while (bits) {
                            *sel++ = cd2[base + (vbi_ctz64(bits) >> 3)];
                            bits &= bits - 1;
                        }
                    }
                }
            }
            float d2m = ns > 0 ? vbi_select(c.sel, (int32_t)ns, (int32_t)(m - 1 - below))
                               : vbi_kd_mth_dist2(t, q, m, knn_i, knn_d2);
            float d = sqrtf(d2m);
            next = d > next ? d : next;
            sum += d;
            job->area[t->pts[q].id] = VBI_PI * d2m;
        }
        est = next;
        mean = sum / (float)(e - b);
    }
    vbi_cand_free(&c);
    free(knn_d2);
    free(knn_i);
}

/* The lists of all candidates, one work item per subtree (the serial variant). */
typedef struct vbi_nb_job {
    const vbi_nb_ctx *ctx;
    const vbi_tree_items *items;
    vbi_elim_nb **buf;   /* per item: its block */
    vbi_elim_list *nb;   /* per tree position */
    atomic_int failed;
} vbi_nb_job;

static void vbi_nb_item(void *user, uint64_t item, unsigned thread)
{
    (void)thread;
    vbi_nb_job *job = user;
    const uint32_t pb = job->items->begin[item], pe = job->items->end[item];
    vbi_cand c;
    vbi_nb_out o;
    memset(&c, 0, sizeof(c));
    if (vbi_nb_out_alloc(&o, pb, pe) != 0 || vbi_cand_alloc(&c, 1024) != 0 ||
        vbi_nb_build(job->ctx, job->items->node[item], job->items->node_end[item], &o, &c) != 0) {
        vbi_nb_out_free(&o);
        vbi_cand_free(&c);
        job->buf[item] = NULL;
        atomic_store(&job->failed, 1);
        return;
    }
    for (uint32_t q = pb; q < pe; ++q) {
        job->nb[q].l = o.buf + o.off[q - pb];
        job->nb[q].n = o.cnt[q - pb];
    }
    job->buf[item] = o.buf;
    o.buf = NULL;
    vbi_nb_out_free(&o);
    vbi_cand_free(&c);
}

void vbi_elim_params_default(vbi_elim_params *p, uint32_t target)
{
    memset(p, 0, sizeof(*p));
    p->mode = VBI_ELIM_ADAPTIVE;
    p->target = target;
    p->neighbours = VBI_ELIM_DEFAULT_NEIGHBOURS;
    p->alpha = VBI_ELIM_DEFAULT_ALPHA;
    p->early_stop = VBI_ELIM_DEFAULT_EARLY_STOP;
    p->weight_limit = 1;
}

static vbnl_result vbi_elim_check(const vec3 *points, uint32_t count, const vbi_elim_params *p,
                                   const uint32_t *out_kept, vbnl_error *err)
{
    const char *fn = "vbi_eliminate";
    if (!points || !p || !out_kept)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "%s: %s is NULL", fn,
                              !points ? "points" : (!p ? "params" : "out_kept"));
    if (count == 0)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "%s: no candidate points (M = 0)", fn);
    if (p->mode != VBI_ELIM_NONE && p->mode != VBI_ELIM_UNIFORM && p->mode != VBI_ELIM_ADAPTIVE)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "%s: unknown mode %d", fn, (int)p->mode);
    if (p->target == 0)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "%s: target N must be at least 1", fn);
    if (p->target > count)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "%s: target N = %u exceeds the %u candidates (N must be <= M)", fn,
                              p->target, count);
    if (p->neighbours == 0)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "%s: neighbours (m of Eq. 2) must be at least 1", fn);
    if (!isfinite(p->alpha) || p->alpha <= 0.0f)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "%s: alpha must be a finite positive number, got %g", fn, (double)p->alpha);
    if (p->parallel && !(p->early_stop > 0.0f && p->early_stop <= 1.0f))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "%s: early_stop must be in (0, 1], got %g", fn, (double)p->early_stop);
    if (!isfinite(p->max_radius) || p->max_radius < 0.0f)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "%s: max_radius must be finite and >= 0, got %g", fn, (double)p->max_radius);
    if (!isfinite(p->surface_area) || p->surface_area < 0.0)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "%s: surface_area must be finite and >= 0, got %g", fn, p->surface_area);
    /* Finite, and small enough that squared distances stay finite in float. */
    for (uint32_t i = 0; i < count; ++i) /* false for NaN too */
        if (!(fabsf(points[i].x) <= 1e18f && fabsf(points[i].y) <= 1e18f && fabsf(points[i].z) <= 1e18f))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                  "%s: candidate %u is not finite or beyond 1e18 (%g, %g, %g)", fn,
                                  i, (double)points[i].x, (double)points[i].y, (double)points[i].z);
    return VBNL_OK;
}

/* Parallel decomposition (section 3.2): the boxes are the subtrees at depths 3 and 6 of the
 * balanced k-d tree over all candidates, i.e. contiguous ranges of its point order. Collects the
 * ranges of the nodes at `depth`, left to right. */
static void vbi_collect_boxes(const vbi_kd_tree *t, uint32_t ni, uint32_t d, uint32_t depth,
                               uint32_t *begin, uint32_t *end, uint32_t *node, uint32_t *node_end,
                               uint32_t *nb)
{
    const vbi_kd_node *nd = &t->nodes[ni];
    if (d == depth || nd->axis == VBI_KD_LEAF_AXIS) {
        begin[*nb] = nd->begin;
        end[*nb] = nd->end;
        node[*nb] = ni;
        uint32_t last = ni; /* the subtree's nodes end after its right-most leaf (DFS layout) */
        while (t->nodes[last].axis != VBI_KD_LEAF_AXIS)
            last = t->nodes[last].right;
        node_end[*nb] = last + 1;
        (*nb)++;
        return;
    }
    vbi_collect_boxes(t, ni + 1, d + 1, depth, begin, end, node, node_end, nb);
    vbi_collect_boxes(t, nd->right, d + 1, depth, begin, end, node, node_end, nb);
}

/* Integer shares of N proportional to `weight` (largest remainder; ties by box index). */
static void vbi_split_shares(const double *weight, uint32_t nb, uint32_t total, uint32_t *share)
{
    double sum = 0.0;
    for (uint32_t b = 0; b < nb; ++b)
        sum += weight[b];
    uint32_t given = 0;
    double frac[64];
    for (uint32_t b = 0; b < nb; ++b) {
        double x = sum > 0.0 ? (double)total * weight[b] / sum : (double)total / nb;
        share[b] = (uint32_t)floor(x);
        if (share[b] > total)
            share[b] = total;
        frac[b] = x - floor(x);
        given += share[b];
    }
    while (given < total) {
        uint32_t best = 0;
        for (uint32_t b = 1; b < nb; ++b)
            if (frac[b] > frac[best])
                best = b;
        frac[best] = -1.0;
        share[best]++;
        given++;
    }
    while (given > total) { /* only through rounding of huge counts */
        for (uint32_t b = 0; b < nb && given > total; ++b)
            if (share[b] > 0) {
                share[b]--;
                given--;
            }
    }
}

/* Depth of the m-NN and neighbour-list work items: subtrees of at most VBI_KNN_CHUNK points. */
static uint32_t vbi_items_depth(uint32_t M)
{
    uint32_t d = 0;
    while (d < 12 && (((uint64_t)M + (1ull << d) - 1) >> d) > VBI_KNN_CHUNK)
        d++;
    return d;
}

vbnl_result vbi_eliminate(const vec3 *points, uint32_t count, const vbi_elim_params *p,
                           const vbi_elim_exec *exec, uint32_t *out_kept, float *out_rmax,
                           vbi_elim_stats *stats, vbnl_error *err)
{
    vbnl_result res = vbi_elim_check(points, count, p, out_kept, err);
    if (res != VBNL_OK)
        return res;
    vbi_elim_stats st;
    memset(&st, 0, sizeof(st));
    const uint32_t M = count, N = p->target;
    const double t0 = vbi_now();

    uint32_t levels = 0; /* 8^levels leaf boxes */
    if (p->parallel && p->mode != VBI_ELIM_NONE && N < M) {
        if (M >= 64u * VBI_MIN_BOX_POINTS)
            levels = 2;
        else if (M >= 8u * VBI_MIN_BOX_POINTS)
            levels = 1;
    }
    /* The m-NN search is needed by Eq. 2, by the area estimate and by the box shares. */
    int need_knn = p->mode != VBI_ELIM_UNIFORM || p->surface_area == 0.0 || levels > 0;
    if (need_knn && M < 2)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "vbi_eliminate: one candidate has no neighbour to estimate its radius "
                              "from (Eq. 2); give surface_area with the uniform mode");
    /* The tree serves the m-NN search and the neighbour lists of the elimination. */
    const int need_tree = need_knn || (p->mode != VBI_ELIM_NONE && N < M);

    float *rmax = malloc((size_t)M * sizeof(float));
    float *area = need_knn ? malloc((size_t)M * sizeof(float)) : NULL;
    vbi_kd_pt *gpts = need_tree ? malloc((size_t)M * sizeof(vbi_kd_pt)) : NULL;
    uint8_t *keep = NULL;
    uint32_t *ids = NULL;
    vbi_tree_items items;
    memset(&items, 0, sizeof(items));
    vbi_kd_tree gt;
    memset(&gt, 0, sizeof(gt));
    /* Elimination: per tree position d_max, padded d_max^2, lists and the removed mark;
     * per node the largest padded d_max^2; the lists' blocks per work item. */
    float *dm_pos = NULL, *reach2 = NULL, *node_r2 = NULL;
    uint32_t *loc = NULL;
    vbi_elim_list *nb = NULL;
    vbi_elim_nb **nb_buf = NULL; /* blocks of lists: per work item (serial) or leaf box */
    uint32_t nb_blocks = 0;
    if (!rmax || (need_knn && !area) || (need_tree && !gpts)) {
        res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "vbi_eliminate: out of memory (%u candidates)", M);
        goto done;
    }
    uint32_t m = p->neighbours < M - 1 ? p->neighbours : (M > 1 ? M - 1 : 1);
    if (need_tree) {
        for (uint32_t i = 0; i < M; ++i) {
            gpts[i].p[0] = points[i].x;
            gpts[i].p[1] = points[i].y;
            gpts[i].p[2] = points[i].z;
            gpts[i].id = i;
        }
        /* The root's split on this thread; then three levels of splits and the 16 subtrees
         * below them as work items (the tree vbi_kd_build makes). */
        double tb = vbi_now();
        vbi_kd_subtree sub[2][16];
        uint32_t nsub[8];
        vbi_kd_build_job bj;
        bj.tree = &gt;
        bj.nout = nsub;
        if (vbi_kd_build_top(&gt, gpts, M, 1, sub[0], &bj.count) != 0) {
            res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "vbi_eliminate: out of memory (k-d tree)");
            goto done;
        }
        int cancelled = 0;
        for (int lev = 0; lev < 3 && !cancelled; ++lev) {
            bj.jobs = sub[lev & 1];
            bj.out = sub[(lev + 1) & 1];
            cancelled = vbi_elim_exec_run(exec, bj.count, vbi_kd_split_item, &bj) != 0;
            uint32_t k = 0; /* gather the children in order */
            for (uint32_t j = 0; j < bj.count && !cancelled; ++j)
                for (uint32_t c = 0; c < nsub[j]; ++c)
                    bj.out[k++] = bj.out[2 * j + c];
            bj.count = k;
        }
        bj.jobs = sub[1];
        if (cancelled || vbi_elim_exec_run(exec, bj.count, vbi_kd_build_item, &bj) != 0) {
            res = vbnl_error_set(err, VBNL_ERR_CANCELLED, "vbi_eliminate: cancelled");
            goto done;
        }
        st.time_tree = vbi_now() - tb;
        uint32_t depth = vbi_items_depth(M), cap = 1u << depth;
        items.node = malloc((size_t)cap * sizeof(uint32_t));
        items.node_end = malloc((size_t)cap * sizeof(uint32_t));
        items.begin = malloc((size_t)cap * sizeof(uint32_t));
        items.end = malloc((size_t)cap * sizeof(uint32_t));
        if (!items.node || !items.node_end || !items.begin || !items.end) {
            res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "vbi_eliminate: out of memory");
            goto done;
        }
        vbi_collect_boxes(&gt, 0, 0, depth, items.begin, items.end, items.node, items.node_end,
                           &items.count);
    }
    if (need_knn) {
        vbi_knn_job kj;
        kj.tree = &gt;
        kj.items = &items;
        kj.m = m;
        kj.area = area;
        atomic_init(&kj.failed, 0);
        res = vbi_elim_exec_checked(exec, items.count, vbi_knn_item, &kj, &kj.failed, "m-NN search", err);
        if (res != VBNL_OK)
            goto done;
        st.neighbours = m;
    }
    /* Radii. Eq. 2 with n/m = N/M; Eq. 1 with A given or estimated. Each candidate's share of
     * the area around it is A_i / m (A_i holds ~m candidates), so sum_i A_i / m estimates the
     * area of the candidates' surface (slightly high at open borders, where disks overhang). */
    double A = p->surface_area;
    if (need_knn) {
        double sum = 0.0;
        for (uint32_t i = 0; i < M; ++i)
            sum += area[i];
        sum /= m;
        if (A == 0.0)
            A = sum;
        if (!(sum > 0.0) && p->mode != VBI_ELIM_UNIFORM) {
            res = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                 "vbi_eliminate: all candidates coincide (zero area)");
            goto done;
        }
    }
    if (p->mode == VBI_ELIM_UNIFORM && !(A > 0.0)) {
        res = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                             "vbi_eliminate: all candidates coincide (zero area estimate for Eq. 1)");
        goto done;
    }
    st.area = A;
    {
        const double k2 = 2.0 * VBI_SQRT3;
        const float r_uniform = (float)sqrt(A / (k2 * N));
        const double adapt = (double)M / (k2 * (double)N * (double)m);
        for (uint32_t i = 0; i < M; ++i) {
            float r = p->mode == VBI_ELIM_UNIFORM ? r_uniform : (float)sqrt(adapt * area[i]);
            if (p->max_radius > 0.0f && r > p->max_radius)
                r = p->max_radius;
            rmax[i] = r;
        }
    }
    st.time_radius = vbi_now() - t0;
    const double t1 = vbi_now();

    keep = calloc(M, 1);
    if (!keep) {
        res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "vbi_eliminate: out of memory");
        goto done;
    }
    if (p->mode == VBI_ELIM_NONE || N == M) {
        /* Partial Fisher-Yates: a uniformly random N-subset, a function of the seed only. */
        ids = malloc((size_t)M * sizeof(uint32_t));
        if (!ids) {
            res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "vbi_eliminate: out of memory");
            goto done;
        }
        for (uint32_t i = 0; i < M; ++i)
            ids[i] = i;
        vbi_rng rng = vbi_rng_make(p->seed, 0x76626e6c656c696dull);
        for (uint32_t i = 0; i < N && N < M; ++i) {
            uint32_t j = i + vbi_rng_uniform_u32(&rng, M - i);
            uint32_t t = ids[i];
            ids[i] = ids[j];
            ids[j] = t;
        }
        for (uint32_t i = 0; i < N; ++i)
            keep[ids[i]] = 1;
        st.levels = 0;
    } else {
        /* d_max,i = 2 r_i,max (Yuksel 2015); reuse `area` storage when present. */
        float *dmax = area ? area : malloc((size_t)M * sizeof(float));
        if (!dmax) {
            res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "vbi_eliminate: out of memory");
            goto done;
        }
        /* Expected kept points per candidate, for the box shares: A_i / (m 2 sqrt3 r_i,max^2). */
        double share_w[64] = {0};
        uint32_t lb[64], le[64], ln[64], lne[64], nl = 0;
        if (levels > 0) {
            vbi_collect_boxes(&gt, 0, 0, 3 * levels, lb, le, ln, lne, &nl);
            for (uint32_t b = 0; b < nl; ++b)
                for (uint32_t i = lb[b]; i < le[b]; ++i) {
                    uint32_t g = gt.pts[i].id;
                    double r = rmax[g];
                    share_w[b] += r > 0.0 ? (double)area[g] / ((double)m * 2.0 * VBI_SQRT3 * r * r)
                                          : (double)N / M;
                }
        }
        for (uint32_t i = 0; i < M; ++i)
            dmax[i] = 2.0f * rmax[i];
        /* Neighbour lists: serially, of all candidates at once; in parallel, of every leaf box
         * in its work item (vbi_elim_leaf_item). */
        const double tn = vbi_now();
        nb_blocks = levels > 0 ? nl : items.count;
        dm_pos = malloc((size_t)M * sizeof(float));
        reach2 = malloc((size_t)M * sizeof(float));
        node_r2 = malloc((size_t)gt.node_count * sizeof(float));
        nb = malloc((size_t)M * sizeof(vbi_elim_list));
        nb_buf = calloc(nb_blocks, sizeof(vbi_elim_nb *));
        loc = calloc(M, sizeof(uint32_t)); /* 0: alive */
        ids = malloc((size_t)M * sizeof(uint32_t));
        if (dmax != area)
            free(area);
        area = dmax; /* freed as area */
        if (!dm_pos || !reach2 || !node_r2 || !nb || !nb_buf || !loc || !ids) {
            res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "vbi_eliminate: out of memory");
            goto done;
        }
        for (uint32_t i = 0; i < M; ++i) {
            dm_pos[i] = dmax[gt.pts[i].id];
            reach2[i] = vbi_pad2(dm_pos[i]);
        }
        /* Depth-first layout: children follow their parent, so a reverse pass sees them first. */
        for (uint32_t k = gt.node_count; k-- > 0;) {
            const vbi_kd_node *nd = &gt.nodes[k];
            float r2 = 0.0f;
            if (nd->axis == VBI_KD_LEAF_AXIS) {
                for (uint32_t i = nd->begin; i < nd->end; ++i)
                    r2 = reach2[i] > r2 ? reach2[i] : r2;
            } else {
                r2 = node_r2[k + 1] > node_r2[nd->right] ? node_r2[k + 1] : node_r2[nd->right];
            }
            node_r2[k] = r2;
        }
        vbi_nb_ctx ctx;
        ctx.tree = &gt;
        ctx.dm = dm_pos;
        ctx.reach2 = reach2;
        ctx.node_r2 = node_r2;
        ctx.alpha = p->alpha;
        /* Yuksel 2015 weight limiting: d_min = d_max beta (1 - (N/M)^gamma), beta = 0.65,
         * gamma = 1.5, with the overall ratio N/M (also in the boxes of the parallel variant). */
        ctx.dmin_scale = p->weight_limit ? (float)(0.65 * (1.0 - pow((double)N / M, 1.5))) : 0.0f;
        if (levels == 0) {
            vbi_nb_job nj;
            nj.ctx = &ctx;
            nj.items = &items;
            nj.buf = nb_buf;
            nj.nb = nb;
            atomic_init(&nj.failed, 0);
            res = vbi_elim_exec_checked(exec, items.count, vbi_nb_item, &nj, &nj.failed, "neighbour lists", err);
            if (res != VBNL_OK)
                goto done;
            st.time_lists = vbi_now() - tn;
        }

        vbi_elim_shared sh;
        sh.pts = gt.pts;
        sh.nb = nb;
        sh.loc = loc;
        sh.ctx = &ctx;
        sh.kept = nb_buf;
        atomic_init(&sh.failed, 0);
        vbi_elim_box boxes[64];
        uint32_t alive = M;
        for (uint32_t i = 0; i < M; ++i)
            ids[i] = i; /* tree positions */
        if (levels > 0) {
            uint32_t share[64];
            vbi_split_shares(share_w, nl, N, share);
            uint32_t nbx = nl;
            for (uint32_t b = 0; b < nbx; ++b) {
                boxes[b].pos = ids + lb[b];
                boxes[b].n = le[b] - lb[b];
                boxes[b].lo = lb[b];
                boxes[b].hi = le[b];
                boxes[b].node = ln[b];
                boxes[b].node_end = lne[b];
                boxes[b].hdr = NULL;
            }
            /* Leaves, then every 8 joined under their ancestor three levels up (section 3.2). */
            for (uint32_t lev = 0; lev < levels; ++lev) {
                double tl = vbi_now();
                uint64_t removed = 0;
                for (uint32_t b = 0; b < nbx; ++b) {
                    uint32_t excess = boxes[b].n > share[b] ? boxes[b].n - share[b] : 0;
                    boxes[b].remove = (uint32_t)((double)p->early_stop * excess);
                    removed += boxes[b].remove;
                }
                sh.boxes = boxes;
                if (vbi_elim_exec_run(exec, nbx, lev == 0 ? vbi_elim_leaf_item : vbi_elim_box_item,
                                       &sh) != 0) {
                    res = vbnl_error_set(err, VBNL_ERR_CANCELLED, "vbi_eliminate: cancelled");
                    break;
                }
                if (atomic_load(&sh.failed))
                    break;
                if (lev == 0) { /* the leaves' lists are built: what they were built from goes */
                    free(reach2);
                    free(node_r2);
                    free(dm_pos);
                    reach2 = node_r2 = dm_pos = NULL;
                }
                st.boxes[lev] = nbx;
                st.removed[lev] = removed;
                st.time_level[lev] = vbi_now() - tl;
                alive -= (uint32_t)removed;
                /* Join 8 children: move their survivors together, in order. */
                uint32_t np = nbx / 8;
                for (uint32_t q = 0; q < np; ++q) {
                    uint32_t *dst = boxes[8 * q].pos, cnt = 0, sh_sum = 0;
                    for (uint32_t c = 0; c < 8; ++c) {
                        const vbi_elim_box *cb = &boxes[8 * q + c];
                        memmove(dst + cnt, cb->pos, (size_t)cb->n * sizeof(uint32_t));
                        cnt += cb->n;
                        sh_sum += share[8 * q + c];
                    }
                    boxes[q].lo = boxes[8 * q].lo;
                    boxes[q].hi = boxes[8 * q + 7].hi;
                    boxes[q].pos = dst;
                    boxes[q].n = cnt;
                    boxes[q].hdr = NULL;
                    share[q] = sh_sum;
                }
                nbx = np;
            }
        } else {
            boxes[0].pos = ids;
            boxes[0].n = M;
            boxes[0].lo = 0;
            boxes[0].hi = M;
            boxes[0].hdr = NULL;
        }
        if (res == VBNL_OK && !atomic_load(&sh.failed)) {
            /* Root (or the whole serial run): the rest, on the calling thread. */
            boxes[0].remove = alive - N;
            st.boxes[levels] = 1;
            st.removed[levels] = alive - N;
            double tr = vbi_now();
            if (vbi_elim_box_run(&sh, &boxes[0]) != 0)
                atomic_store(&sh.failed, 1);
            st.time_level[levels] = vbi_now() - tr;
        }
        st.levels = levels + 1;
        if (res == VBNL_OK && atomic_load(&sh.failed))
            res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "vbi_eliminate: out of memory (elimination)");
        if (res != VBNL_OK)
            goto done;
        for (uint32_t i = 0; i < N; ++i)
            keep[gt.pts[boxes[0].pos[i]].id] = 1;
    }
    {
        uint32_t k = 0;
        for (uint32_t i = 0; i < M; ++i)
            if (keep[i]) {
                out_kept[k] = i;
                if (out_rmax)
                    out_rmax[k] = rmax[i];
                k++;
            }
    }
    st.time_eliminate = vbi_now() - t1;
    if (stats)
        *stats = st;
done:
    if (nb_buf)
        for (uint32_t k = 0; k < nb_blocks; ++k)
            free(nb_buf[k]);
    free(nb_buf);
    free(nb);
    free(loc);
    free(dm_pos);
    free(reach2);
    free(node_r2);
    free(items.node);
    free(items.node_end);
    free(items.begin);
    free(items.end);
    vbi_kd_free(&gt);
    free(ids);
    free(keep);
    free(gpts);
    free(area);
    free(rmax);
    return res;
}

vbnl_result vbi_elim_measure(const vec3 *points, const uint32_t *kept, const float *rmax,
                              uint32_t n, double *mean_rel, double *min_rel, vbnl_error *err)
{
    if (!points || !kept || !rmax || !mean_rel || !min_rel)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbi_elim_measure: NULL argument");
    if (n < 2)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbi_elim_measure: needs 2 points, got %u", n);
    vbi_kd_pt *pts = malloc((size_t)n * sizeof(vbi_kd_pt));
    vbi_kd_tree t;
    if (!pts)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "vbi_elim_measure: out of memory");
    for (uint32_t i = 0; i < n; ++i) {
        vec3 p = points[kept[i]];
        pts[i].p[0] = p.x;
        pts[i].p[1] = p.y;
        pts[i].p[2] = p.z;
        pts[i].id = i; /* index into kept / rmax */
    }
    if (vbi_kd_build(&t, pts, n) != 0) {
        free(pts);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "vbi_elim_measure: out of memory");
    }
    double sum = 0.0, mn = INFINITY;
    uint32_t cnt = 0;
    uint32_t knn_i[1];
    float knn_d2[1];
    for (uint32_t i = 0; i < n; ++i) {
        float r = rmax[pts[i].id];
        if (!(r > 0.0f))
            continue;
        double rel = sqrt((double)vbi_kd_mth_dist2(&t, i, 1, knn_i, knn_d2)) / (2.0 * r);
        sum += rel;
        mn = rel < mn ? rel : mn;
        cnt++;
    }
    *mean_rel = cnt ? sum / cnt : 0.0;
    *min_rel = cnt ? mn : 0.0;
    vbi_kd_free(&t);
    free(pts);
    return VBNL_OK;
}
