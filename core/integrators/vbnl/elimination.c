/* VBNL stage 2: weighted sample elimination, serial and box-parallel (paper section 3.2,
 * Yuksel 2015). See elimination.h for the method; comments here say why. */
#include "elimination.h"

#include <float.h>
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "elimination_kdtree.h"
#include "rng.h"

#define VBNL_SQRT3 1.7320508075688772
#define VBNL_DEAD UINT32_MAX
/* m-NN work items: fixed size, so results never depend on the thread count. */
#define VBNL_KNN_CHUNK 8192u
/* Parallel decomposition: 8^levels leaf boxes with at least this many candidates each. */
#define VBNL_MIN_BOX_POINTS 512u

/* ---- elimination in one box ---------------------------------------------------------------- */

typedef struct vbnl_elim_box {
    uint32_t *ids;   /* global indices: in, the box's alive candidates; out, its survivors first */
    uint32_t n;      /* in: count; out: survivors */
    uint32_t remove; /* how many to eliminate */
    /* Optional: the box is the subtree of nodes [node, node_end) of `tree`, whose points are the
     * box's ids in order; the box then reuses it instead of building its own. */
    const vbnl_kd_tree *tree;
    uint32_t node, node_end;
} vbnl_elim_box;

typedef struct vbnl_elim_shared {
    const vec3 *points;
    const float *dmax; /* d_max,i = 2 r_i,max per global index */
    float alpha;
    float dmin_scale;  /* weight limiting: d_min,i = dmin_scale d_max,i (0: off) */
    vbnl_elim_box *boxes;
    atomic_int failed;
} vbnl_elim_shared;

/* (1 - d^ / dmax)^alpha with d^ = max(d, dmin) (Yuksel 2015: weight function and weight
 * limiting; alpha = 8 is three squarings). */
static inline float vbnl_elim_term(float d2, float dmax, float dmin_scale, float alpha)
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

/* Heap order: larger weight first, ties broken by the smaller global index (determinism). */
static inline int vbnl_elim_before(const float *w, const vbnl_kd_pt *pts, uint32_t a, uint32_t b)
{
    return w[a] > w[b] || (w[a] == w[b] && pts[a].id < pts[b].id);
}

static void vbnl_elim_sift_down(uint32_t *heap, uint32_t *hpos, uint32_t hn, const float *w,
                                const vbnl_kd_pt *pts, uint32_t pos)
{
    uint32_t x = heap[pos];
    for (;;) {
        uint32_t c = 2 * pos + 1;
        if (c >= hn)
            break;
        if (c + 1 < hn && vbnl_elim_before(w, pts, heap[c + 1], heap[c]))
            c++;
        if (!vbnl_elim_before(w, pts, heap[c], x))
            break;
        heap[pos] = heap[c];
        hpos[heap[pos]] = pos;
        pos = c;
    }
    heap[pos] = x;
    hpos[x] = pos;
}

/* Drops the removed points from the box's tree once half are gone, so that later queries stop
 * scanning them (and the arrays shrink). Alive points keep their weights and reach bit for bit
 * and the heap order is a strict total order on (weight, index), so the elimination sequence is
 * exactly the one without compaction. Returns the new point count, or 0 when out of memory. */
static uint32_t vbnl_elim_compact(vbnl_kd_tree *t, uint32_t tn, float *dm, float *reach, float *w,
                                  uint32_t *hpos, uint32_t *heap, uint32_t *qi, float *qd)
{
    vbnl_kd_pt *pts = t->pts;
    uint32_t k = 0;
    for (uint32_t i = 0; i < tn; ++i)
        if (hpos[i] != VBNL_DEAD) {
            pts[k] = pts[i];
            dm[k] = dm[i];
            reach[k] = reach[i];
            w[k] = w[i];
            qi[k] = pts[k].id; /* global index, restored below */
            pts[k].id = k;     /* the pre-build position, to carry the attributes along */
            k++;
        }
    vbnl_kd_free(t);
    if (vbnl_kd_build(t, pts, k) != 0)
        return 0;
    float *attr[3] = {dm, reach, w};
    for (int a = 0; a < 3; ++a) {
        memcpy(qd, attr[a], (size_t)k * sizeof(float));
        for (uint32_t q = 0; q < k; ++q)
            attr[a][q] = qd[pts[q].id];
    }
    for (uint32_t q = 0; q < k; ++q)
        pts[q].id = qi[pts[q].id];
    for (uint32_t q = 0; q < k; ++q) {
        heap[q] = q;
        hpos[q] = q;
    }
    for (uint32_t q = k / 2; q-- > 0;)
        vbnl_elim_sift_down(heap, hpos, k, w, pts, q);
    return k;
}

/* Weighted sample elimination of box->remove points of the box (Yuksel 2015 section 3 with the
 * asymmetric adaptive weights of Li et al. 2022 section 3.2). Returns 0 or -1 (out of memory). */
static int vbnl_elim_box_run(const vbnl_elim_shared *sh, vbnl_elim_box *box)
{
    uint32_t n = box->n;
    if (box->remove == 0 || n == 0)
        return 0;
    /* One block: pts | dm reach w qd | hpos heap qi. */
    size_t bytes = (size_t)n * (sizeof(vbnl_kd_pt) + 4 * sizeof(float) + 3 * sizeof(uint32_t));
    char *mem = malloc(bytes);
    if (!mem)
        return -1;
    vbnl_kd_pt *pts = (vbnl_kd_pt *)mem;
    float *dm = (float *)(pts + n), *reach = dm + n, *w = reach + n, *qd = w + n;
    uint32_t *hpos = (uint32_t *)(qd + n), *heap = hpos + n, *qi = heap + n;
    for (uint32_t i = 0; i < n; ++i) {
        vec3 p = sh->points[box->ids[i]];
        pts[i].p[0] = p.x;
        pts[i].p[1] = p.y;
        pts[i].p[2] = p.z;
        pts[i].id = box->ids[i];
    }
    vbnl_kd_tree t;
    if (box->tree) {
        /* Reuse the global tree's subtree (leaf boxes): rebase node and point indices. */
        uint32_t nn = box->node_end - box->node, base = box->tree->nodes[box->node].begin;
        t.pts = pts;
        t.n = n;
        t.node_count = nn;
        t.nodes = malloc((size_t)nn * sizeof(vbnl_kd_node));
        if (!t.nodes) {
            free(mem);
            return -1;
        }
        for (uint32_t k = 0; k < nn; ++k) {
            vbnl_kd_node nd = box->tree->nodes[box->node + k];
            nd.begin -= base;
            nd.end -= base;
            if (nd.axis != VBNL_KD_LEAF_AXIS)
                nd.right -= box->node;
            t.nodes[k] = nd;
        }
    } else if (vbnl_kd_build(&t, pts, n) != 0) {
        free(mem);
        return -1;
    }
    const float alpha = sh->alpha, dms = sh->dmin_scale;
    for (uint32_t i = 0; i < n; ++i) {
        dm[i] = sh->dmax[pts[i].id];
        reach[i] = 0.0f;
        w[i] = 0.0f;
    }
    /* Weights over each point's own d_max,i; reach[j] = largest d_max,i of any i counting j. */
    for (uint32_t i = 0; i < n; ++i) {
        float r = dm[i];
        if (!(r > 0.0f))
            continue;
        float r2 = r * r;
        uint32_t c = vbnl_kd_radius(&t, pts[i].p, r2, qi, qd, n);
        float wi = 0.0f;
        for (uint32_t k = 0; k < c; ++k) {
            uint32_t j = qi[k];
            if (j == i || !(qd[k] < r2))
                continue;
            wi += vbnl_elim_term(qd[k], r, dms, alpha);
            if (r > reach[j])
                reach[j] = r;
        }
        w[i] = wi;
    }
    for (uint32_t i = 0; i < n; ++i) {
        heap[i] = i;
        hpos[i] = i;
    }
    uint32_t hn = n;
    for (uint32_t i = n / 2; i-- > 0;)
        vbnl_elim_sift_down(heap, hpos, hn, w, pts, i);
    uint32_t remove = box->remove < n ? box->remove : n, tn = n;
    for (uint32_t r = 0; r < remove; ++r) {
        if (2 * hn <= tn && hn >= 256 && remove - r >= hn / 16) {
            tn = vbnl_elim_compact(&t, tn, dm, reach, w, hpos, heap, qi, qd);
            if (tn == 0) {
                free(mem);
                return -1;
            }
        }
        uint32_t top = heap[0];
        hn--;
        if (hn > 0) {
            heap[0] = heap[hn];
            hpos[heap[0]] = 0;
            vbnl_elim_sift_down(heap, hpos, hn, w, pts, 0);
        }
        hpos[top] = VBNL_DEAD;
        if (!(reach[top] > 0.0f))
            continue; /* nobody counted it */
        uint32_t c = vbnl_kd_radius(&t, pts[top].p, reach[top] * reach[top], qi, qd, n);
        for (uint32_t k = 0; k < c; ++k) {
            uint32_t j = qi[k];
            if (hpos[j] == VBNL_DEAD)
                continue;
            /* Same d2 (a-b and b-a square equally) and test as when w[j] was summed. */
            float rj = dm[j];
            if (!(qd[k] < rj * rj))
                continue;
            w[j] -= vbnl_elim_term(qd[k], rj, dms, alpha);
            vbnl_elim_sift_down(heap, hpos, hn, w, pts, hpos[j]);
        }
    }
    uint32_t out = 0;
    for (uint32_t i = 0; i < tn; ++i)
        if (hpos[i] != VBNL_DEAD)
            box->ids[out++] = pts[i].id;
    box->n = out;
    vbnl_kd_free(&t);
    free(mem);
    return 0;
}

static void vbnl_elim_box_item(void *user, uint64_t item, unsigned thread)
{
    (void)thread;
    vbnl_elim_shared *sh = user;
    if (vbnl_elim_box_run(sh, &sh->boxes[item]) != 0)
        atomic_store(&sh->failed, 1);
}

/* ---- running work items ---------------------------------------------------------------------- */

static int vbnl_elim_pool_run(void *ctx, uint64_t count, vbnl_pool_fn fn, void *user)
{
    uint64_t ran = vbnl_pool_run(ctx, count, fn, user, NULL, NULL, 0.0);
    return ran < count ? -1 : 0;
}

vbnl_elim_exec vbnl_elim_exec_pool(vbnl_pool *pool)
{
    vbnl_elim_exec e;
    e.run = pool ? vbnl_elim_pool_run : NULL;
    e.ctx = pool;
    return e;
}

static int vbnl_elim_exec_run(const vbnl_elim_exec *exec, uint64_t count, vbnl_pool_fn fn, void *user)
{
    if (count == 0)
        return 0;
    if (exec && exec->run)
        return exec->run(exec->ctx, count, fn, user) != 0 ? -1 : 0;
    for (uint64_t i = 0; i < count; ++i)
        fn(user, i, 0);
    return 0;
}

/* ---- per-point radii (Eq. 1, 2) ------------------------------------------------------------- */

typedef struct vbnl_kd_build_job {
    vbnl_kd_tree *tree;
    const vbnl_kd_subtree *jobs;
    uint32_t count;
} vbnl_kd_build_job;

static void vbnl_kd_build_item(void *user, uint64_t item, unsigned thread)
{
    (void)thread;
    vbnl_kd_build_job *bj = user;
    vbnl_kd_build_subtree(bj->tree, &bj->jobs[item]);
}

typedef struct vbnl_knn_job {
    const vbnl_kd_tree *tree;
    uint32_t m;
    float *area; /* A_i = pi d_i^2 per global index */
    atomic_int failed;
} vbnl_knn_job;

static void vbnl_knn_item(void *user, uint64_t item, unsigned thread)
{
    (void)thread;
    vbnl_knn_job *job = user;
    const vbnl_kd_tree *t = job->tree;
    float *heap = malloc((size_t)job->m * sizeof(float));
    if (!heap) {
        atomic_store(&job->failed, 1);
        return;
    }
    uint32_t b = (uint32_t)item * VBNL_KNN_CHUNK;
    uint32_t e = b + VBNL_KNN_CHUNK < t->n ? b + VBNL_KNN_CHUNK : t->n;
    /* Consecutive points in tree order are close: the previous point's m-NN ball grown by
     * their distance holds m points other than this one (triangle inequality), a tight first
     * bound for the search. Padded against rounding; a miss only costs a second search. */
    float prev = INFINITY;
    for (uint32_t i = b; i < e; ++i) {
        float bound2 = INFINITY;
        if (i > b) {
            float g = prev + sqrtf(vbnl_kd_dist2(t->pts[i].p, t->pts[i - 1].p));
            bound2 = g * g * 1.0001f + FLT_MIN;
        }
        float d2 = vbnl_kd_knn(t, i, job->m, heap, bound2);
        prev = sqrtf(d2);
        job->area[t->pts[i].id] = VBNL_PI * d2;
    }
    free(heap);
}

void vbnl_elim_params_default(vbnl_elim_params *p, uint32_t target)
{
    memset(p, 0, sizeof(*p));
    p->mode = VBNL_ELIM_ADAPTIVE;
    p->target = target;
    p->neighbours = VBNL_ELIM_DEFAULT_NEIGHBOURS;
    p->alpha = VBNL_ELIM_DEFAULT_ALPHA;
    p->early_stop = VBNL_ELIM_DEFAULT_EARLY_STOP;
    p->weight_limit = 1;
}

static vbnl_result vbnl_elim_check(const vec3 *points, uint32_t count, const vbnl_elim_params *p,
                                   const uint32_t *out_kept, vbnl_error *err)
{
    const char *fn = "vbnl_eliminate";
    if (!points || !p || !out_kept)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "%s: %s is NULL", fn,
                              !points ? "points" : (!p ? "params" : "out_kept"));
    if (count == 0)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "%s: no candidate points (M = 0)", fn);
    if (p->mode != VBNL_ELIM_NONE && p->mode != VBNL_ELIM_UNIFORM && p->mode != VBNL_ELIM_ADAPTIVE)
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
    for (uint32_t i = 0; i < count; ++i)
        if (!v3_is_finite(points[i]) || v3_max_comp(v3_max(points[i], v3_neg(points[i]))) > 1e18f)
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                  "%s: candidate %u is not finite or beyond 1e18 (%g, %g, %g)", fn,
                                  i, (double)points[i].x, (double)points[i].y, (double)points[i].z);
    return VBNL_OK;
}

/* Parallel decomposition (section 3.2): the boxes are the subtrees at depths 3 and 6 of the
 * balanced k-d tree over all candidates, i.e. contiguous ranges of its point order. Collects the
 * ranges of the nodes at `depth`, left to right. */
static void vbnl_collect_boxes(const vbnl_kd_tree *t, uint32_t ni, uint32_t d, uint32_t depth,
                               uint32_t *begin, uint32_t *end, uint32_t *node, uint32_t *node_end,
                               uint32_t *nb)
{
    const vbnl_kd_node *nd = &t->nodes[ni];
    if (d == depth || nd->axis == VBNL_KD_LEAF_AXIS) {
        begin[*nb] = nd->begin;
        end[*nb] = nd->end;
        node[*nb] = ni;
        uint32_t last = ni; /* the subtree's nodes end after its right-most leaf (DFS layout) */
        while (t->nodes[last].axis != VBNL_KD_LEAF_AXIS)
            last = t->nodes[last].right;
        node_end[*nb] = last + 1;
        (*nb)++;
        return;
    }
    vbnl_collect_boxes(t, ni + 1, d + 1, depth, begin, end, node, node_end, nb);
    vbnl_collect_boxes(t, nd->right, d + 1, depth, begin, end, node, node_end, nb);
}

/* Integer shares of N proportional to `weight` (largest remainder; ties by box index). */
static void vbnl_split_shares(const double *weight, uint32_t nb, uint32_t total, uint32_t *share)
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

vbnl_result vbnl_eliminate(const vec3 *points, uint32_t count, const vbnl_elim_params *p,
                           const vbnl_elim_exec *exec, uint32_t *out_kept, float *out_rmax,
                           vbnl_elim_stats *stats, vbnl_error *err)
{
    vbnl_result res = vbnl_elim_check(points, count, p, out_kept, err);
    if (res != VBNL_OK)
        return res;
    vbnl_elim_stats st;
    memset(&st, 0, sizeof(st));
    const uint32_t M = count, N = p->target;
    const double t0 = vbnl_now();

    uint32_t levels = 0; /* 8^levels leaf boxes */
    if (p->parallel && p->mode != VBNL_ELIM_NONE && N < M) {
        if (M >= 64u * VBNL_MIN_BOX_POINTS)
            levels = 2;
        else if (M >= 8u * VBNL_MIN_BOX_POINTS)
            levels = 1;
    }
    /* The m-NN search is needed by Eq. 2, by the area estimate and by the box shares. */
    int need_knn = p->mode != VBNL_ELIM_UNIFORM || p->surface_area == 0.0 || levels > 0;
    if (need_knn && M < 2)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "vbnl_eliminate: one candidate has no neighbour to estimate its radius "
                              "from (Eq. 2); give surface_area with the uniform mode");

    float *rmax = malloc((size_t)M * sizeof(float));
    float *area = need_knn ? malloc((size_t)M * sizeof(float)) : NULL;
    vbnl_kd_pt *gpts = need_knn ? malloc((size_t)M * sizeof(vbnl_kd_pt)) : NULL;
    uint8_t *keep = NULL;
    uint32_t *ids = NULL;
    vbnl_kd_tree gt;
    memset(&gt, 0, sizeof(gt));
    if (!rmax || (need_knn && (!area || !gpts))) {
        res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "vbnl_eliminate: out of memory (%u candidates)", M);
        goto done;
    }
    uint32_t m = p->neighbours < M - 1 ? p->neighbours : (M > 1 ? M - 1 : 1);
    if (need_knn) {
        for (uint32_t i = 0; i < M; ++i) {
            gpts[i].p[0] = points[i].x;
            gpts[i].p[1] = points[i].y;
            gpts[i].p[2] = points[i].z;
            gpts[i].id = i;
        }
        /* The top levels on this thread, the 16 subtrees below them as work items. */
        double tb = vbnl_now();
        vbnl_kd_subtree sub[16];
        vbnl_kd_build_job bj;
        bj.tree = &gt;
        bj.jobs = sub;
        if (vbnl_kd_build_top(&gt, gpts, M, 4, sub, &bj.count) != 0) {
            res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "vbnl_eliminate: out of memory (k-d tree)");
            goto done;
        }
        if (vbnl_elim_exec_run(exec, bj.count, vbnl_kd_build_item, &bj) != 0) {
            res = vbnl_error_set(err, VBNL_ERR_CANCELLED, "vbnl_eliminate: cancelled");
            goto done;
        }
        st.time_tree = vbnl_now() - tb;
        vbnl_knn_job kj;
        kj.tree = &gt;
        kj.m = m;
        kj.area = area;
        atomic_init(&kj.failed, 0);
        if (vbnl_elim_exec_run(exec, (M + VBNL_KNN_CHUNK - 1) / VBNL_KNN_CHUNK, vbnl_knn_item, &kj) != 0) {
            res = vbnl_error_set(err, VBNL_ERR_CANCELLED, "vbnl_eliminate: cancelled");
            goto done;
        }
        if (atomic_load(&kj.failed)) {
            res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "vbnl_eliminate: out of memory (m-NN search)");
            goto done;
        }
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
        if (!(sum > 0.0) && p->mode != VBNL_ELIM_UNIFORM) {
            res = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                 "vbnl_eliminate: all candidates coincide (zero area)");
            goto done;
        }
    }
    if (p->mode == VBNL_ELIM_UNIFORM && !(A > 0.0)) {
        res = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                             "vbnl_eliminate: all candidates coincide (zero area estimate for Eq. 1)");
        goto done;
    }
    st.area = A;
    {
        const double k2 = 2.0 * VBNL_SQRT3;
        const float r_uniform = (float)sqrt(A / (k2 * N));
        const double adapt = (double)M / (k2 * (double)N * (double)m);
        for (uint32_t i = 0; i < M; ++i) {
            float r = p->mode == VBNL_ELIM_UNIFORM ? r_uniform : (float)sqrt(adapt * area[i]);
            if (p->max_radius > 0.0f && r > p->max_radius)
                r = p->max_radius;
            rmax[i] = r;
        }
    }
    st.time_radius = vbnl_now() - t0;
    const double t1 = vbnl_now();

    keep = calloc(M, 1);
    if (!keep) {
        res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "vbnl_eliminate: out of memory");
        goto done;
    }
    if (p->mode == VBNL_ELIM_NONE || N == M) {
        /* Partial Fisher-Yates: a uniformly random N-subset, a function of the seed only. */
        ids = malloc((size_t)M * sizeof(uint32_t));
        if (!ids) {
            res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "vbnl_eliminate: out of memory");
            goto done;
        }
        for (uint32_t i = 0; i < M; ++i)
            ids[i] = i;
        vbnl_rng rng = vbnl_rng_make(p->seed, 0x76626e6c656c696dull);
        for (uint32_t i = 0; i < N && N < M; ++i) {
            uint32_t j = i + vbnl_rng_uniform_u32(&rng, M - i);
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
            res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "vbnl_eliminate: out of memory");
            goto done;
        }
        /* Expected kept points per candidate, for the box shares: A_i / (m 2 sqrt3 r_i,max^2). */
        double share_w[64] = {0};
        uint32_t lb[64], le[64], ln[64], lne[64], nl = 0;
        if (levels > 0) {
            vbnl_collect_boxes(&gt, 0, 0, 3 * levels, lb, le, ln, lne, &nl);
            for (uint32_t b = 0; b < nl; ++b)
                for (uint32_t i = lb[b]; i < le[b]; ++i) {
                    uint32_t g = gt.pts[i].id;
                    double r = rmax[g];
                    share_w[b] += r > 0.0 ? (double)area[g] / ((double)m * 2.0 * VBNL_SQRT3 * r * r)
                                          : (double)N / M;
                }
        }
        for (uint32_t i = 0; i < M; ++i)
            dmax[i] = 2.0f * rmax[i];
        ids = malloc((size_t)M * sizeof(uint32_t));
        if (!ids) {
            if (dmax != area)
                free(dmax);
            res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "vbnl_eliminate: out of memory");
            goto done;
        }
        vbnl_elim_shared sh;
        sh.points = points;
        sh.dmax = dmax;
        sh.alpha = p->alpha;
        /* Yuksel 2015 weight limiting: d_min = d_max beta (1 - (N/M)^gamma), beta = 0.65,
         * gamma = 1.5, with the overall ratio N/M (also in the boxes of the parallel variant). */
        sh.dmin_scale = p->weight_limit ? (float)(0.65 * (1.0 - pow((double)N / M, 1.5))) : 0.0f;
        atomic_init(&sh.failed, 0);
        vbnl_elim_box boxes[64];
        uint32_t alive = M;
        if (levels > 0) {
            for (uint32_t i = 0; i < M; ++i)
                ids[i] = gt.pts[i].id;
            uint32_t share[64];
            vbnl_split_shares(share_w, nl, N, share);
            uint32_t nb = nl;
            for (uint32_t b = 0; b < nb; ++b) {
                boxes[b].ids = ids + lb[b];
                boxes[b].n = le[b] - lb[b];
                boxes[b].tree = &gt;
                boxes[b].node = ln[b];
                boxes[b].node_end = lne[b];
            }
            /* Leaves, then every 8 joined under their ancestor three levels up (section 3.2). */
            for (uint32_t lev = 0; lev < levels; ++lev) {
                double tl = vbnl_now();
                uint64_t removed = 0;
                for (uint32_t b = 0; b < nb; ++b) {
                    uint32_t excess = boxes[b].n > share[b] ? boxes[b].n - share[b] : 0;
                    boxes[b].remove = (uint32_t)((double)p->early_stop * excess);
                    removed += boxes[b].remove;
                }
                sh.boxes = boxes;
                if (vbnl_elim_exec_run(exec, nb, vbnl_elim_box_item, &sh) != 0) {
                    res = vbnl_error_set(err, VBNL_ERR_CANCELLED, "vbnl_eliminate: cancelled");
                    break;
                }
                if (atomic_load(&sh.failed))
                    break;
                st.boxes[lev] = nb;
                st.removed[lev] = removed;
                st.time_level[lev] = vbnl_now() - tl;
                alive -= (uint32_t)removed;
                /* Join 8 children: move their survivors together, in order. */
                uint32_t np = nb / 8;
                for (uint32_t q = 0; q < np; ++q) {
                    uint32_t *dst = boxes[8 * q].ids, cnt = 0, sh_sum = 0;
                    for (uint32_t c = 0; c < 8; ++c) {
                        const vbnl_elim_box *cb = &boxes[8 * q + c];
                        memmove(dst + cnt, cb->ids, (size_t)cb->n * sizeof(uint32_t));
                        cnt += cb->n;
                        sh_sum += share[8 * q + c];
                    }
                    boxes[q].ids = dst;
                    boxes[q].n = cnt;
                    boxes[q].tree = NULL;
                    share[q] = sh_sum;
                }
                nb = np;
            }
        } else {
            for (uint32_t i = 0; i < M; ++i)
                ids[i] = i;
            boxes[0].ids = ids;
            boxes[0].n = M;
            boxes[0].tree = NULL;
        }
        if (res == VBNL_OK && !atomic_load(&sh.failed)) {
            /* Root (or the whole serial run): the rest, on the calling thread. */
            boxes[0].remove = alive - N;
            st.boxes[levels] = 1;
            st.removed[levels] = alive - N;
            double tr = vbnl_now();
            if (vbnl_elim_box_run(&sh, &boxes[0]) != 0)
                atomic_store(&sh.failed, 1);
            st.time_level[levels] = vbnl_now() - tr;
        }
        st.levels = levels + 1;
        if (res == VBNL_OK && atomic_load(&sh.failed))
            res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "vbnl_eliminate: out of memory (elimination)");
        if (res == VBNL_OK)
            for (uint32_t i = 0; i < N; ++i)
                keep[boxes[0].ids[i]] = 1;
        if (dmax != area)
            free(dmax);
        if (res != VBNL_OK)
            goto done;
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
    st.time_eliminate = vbnl_now() - t1;
    if (stats)
        *stats = st;
done:
    vbnl_kd_free(&gt);
    free(ids);
    free(keep);
    free(gpts);
    free(area);
    free(rmax);
    return res;
}

vbnl_result vbnl_elim_measure(const vec3 *points, const uint32_t *kept, const float *rmax,
                              uint32_t n, double *mean_rel, double *min_rel, vbnl_error *err)
{
    if (!points || !kept || !rmax || !mean_rel || !min_rel)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_elim_measure: NULL argument");
    if (n < 2)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_elim_measure: needs 2 points, got %u", n);
    vbnl_kd_pt *pts = malloc((size_t)n * sizeof(vbnl_kd_pt));
    vbnl_kd_tree t;
    if (!pts)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "vbnl_elim_measure: out of memory");
    for (uint32_t i = 0; i < n; ++i) {
        vec3 p = points[kept[i]];
        pts[i].p[0] = p.x;
        pts[i].p[1] = p.y;
        pts[i].p[2] = p.z;
        pts[i].id = i; /* index into kept / rmax */
    }
    if (vbnl_kd_build(&t, pts, n) != 0) {
        free(pts);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "vbnl_elim_measure: out of memory");
    }
    double sum = 0.0, mn = INFINITY;
    uint32_t cnt = 0;
    float heap[1];
    for (uint32_t i = 0; i < n; ++i) {
        float r = rmax[pts[i].id];
        if (!(r > 0.0f))
            continue;
        double rel = sqrt((double)vbnl_kd_knn(&t, i, 1, heap, INFINITY)) / (2.0 * r);
        sum += rel;
        mn = rel < mn ? rel : mn;
        cnt++;
    }
    *mean_rel = cnt ? sum / cnt : 0.0;
    *min_rel = cnt ? mn : 0.0;
    vbnl_kd_free(&t);
    free(pts);
    return VBNL_OK;
}
