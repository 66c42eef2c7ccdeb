/* k-d tree over points (kdtree.h). */
#include "kdtree.h"

#include <float.h>
#include <stdlib.h>

/* Traversal stacks grow by at most one entry per level: depth + 1 <= 33 for 2^32 points. */
#define VBI_KD_STACK 96

/* Quickselect (Hoare partition, median-of-three pivot): afterwards a[k] has its sorted place,
 * a[0..k) <= a[k] <= a(k..n) on axis `ax`. Deterministic. */
static void vbi_kd_select(vbi_kd_pt *a, uint32_t n, uint32_t k, int ax)
{
#define VBI_KEY(i) (a[i].p[ax])
#define VBI_SWAP(i, j) do { vbi_kd_pt t_ = a[i]; a[i] = a[j]; a[j] = t_; } while (0)
    uint32_t l = 0, ir = n - 1;
    for (;;) {
        if (ir <= l + 1) {
            if (ir == l + 1 && VBI_KEY(ir) < VBI_KEY(l))
                VBI_SWAP(l, ir);
            return;
        }
        uint32_t mid = (l + ir) >> 1;
        VBI_SWAP(mid, l + 1);
        if (VBI_KEY(l) > VBI_KEY(ir)) VBI_SWAP(l, ir);
        if (VBI_KEY(l + 1) > VBI_KEY(ir)) VBI_SWAP(l + 1, ir);
        if (VBI_KEY(l) > VBI_KEY(l + 1)) VBI_SWAP(l, l + 1);
        uint32_t i = l + 1, j = ir;
        vbi_kd_pt pivot = a[l + 1];
        float pk = pivot.p[ax];
        for (;;) {
            do i++; while (VBI_KEY(i) < pk);
            do j--; while (VBI_KEY(j) > pk);
            if (j < i)
                break;
            VBI_SWAP(i, j);
        }
        a[l + 1] = a[j];
        a[j] = pivot;
        if (j >= k) ir = j - 1;
        if (j <= k) l = i;
    }
#undef VBI_KEY
#undef VBI_SWAP
}

/* Nodes of the tree over n points (the build's exact depth-first layout). */
static uint32_t vbi_kd_node_count(uint32_t n)
{
    return n <= VBI_KD_LEAF ? 1u : 1u + vbi_kd_node_count(n / 2) + vbi_kd_node_count(n - n / 2);
}

/* Builds the subtree over pts[b, e) at node *next. Nodes at depth `defer` with more than a leaf
 * of points are only reserved and recorded in jobs[] (their subtree size is known in advance). */
static uint32_t vbi_kd_build_rec(vbi_kd_tree *t, uint32_t *next, uint32_t b, uint32_t e,
                                  uint32_t depth, uint32_t defer, vbi_kd_subtree *jobs,
                                  uint32_t *njobs)
{
    uint32_t ni = (*next)++;
    vbi_kd_node *nd = &t->nodes[ni];
    nd->begin = b;
    nd->end = e;
    nd->right = 0;
    nd->split = 0.0f;
    if (e - b > VBI_KD_LEAF && depth == defer) {
        jobs[*njobs].node = ni;
        jobs[*njobs].begin = b;
        jobs[*njobs].end = e;
        (*njobs)++;
        *next = ni + vbi_kd_node_count(e - b);
        return ni; /* its box too is written by the job */
    }
    /* The bounding box: kept for box queries (vbi_kd_gather_*), and it picks the split axis. */
    float lo[3] = {FLT_MAX, FLT_MAX, FLT_MAX}, hi[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
    for (uint32_t i = b; i < e; ++i)
        for (int a = 0; a < 3; ++a) {
            float v = t->pts[i].p[a];
            lo[a] = v < lo[a] ? v : lo[a];
            hi[a] = v > hi[a] ? v : hi[a];
        }
    float *bx = t->box + 6 * (size_t)ni;
    for (int a = 0; a < 3; ++a) {
        bx[a] = lo[a];
        bx[3 + a] = hi[a];
    }
    if (e - b <= VBI_KD_LEAF) {
        nd->axis = VBI_KD_LEAF_AXIS;
        return ni;
    }
    /* Split at the median along the axis of largest extent (a balanced tree: section 3.2 uses
     * the same rule for the parallel boxes, which are this tree's top levels). */
    int ax = 0;
    for (int a = 1; a < 3; ++a)
        if (hi[a] - lo[a] > hi[ax] - lo[ax])
            ax = a;
    uint32_t mid = b + (e - b) / 2;
    vbi_kd_select(t->pts + b, e - b, mid - b, ax);
    t->nodes[ni].split = t->pts[mid].p[ax];
    t->nodes[ni].axis = (uint32_t)ax;
    vbi_kd_build_rec(t, next, b, mid, depth + 1, defer, jobs, njobs);
    uint32_t r = vbi_kd_build_rec(t, next, mid, e, depth + 1, defer, jobs, njobs);
    t->nodes[ni].right = r;
    return ni;
}

int vbi_kd_build_top(vbi_kd_tree *t, vbi_kd_pt *pts, uint32_t n, uint32_t levels,
                      vbi_kd_subtree *jobs, uint32_t *njobs)
{
    t->pts = pts;
    t->n = n;
    t->node_count = n > 0 ? vbi_kd_node_count(n) : 0;
    t->nodes = malloc(((size_t)t->node_count + 1) * sizeof(vbi_kd_node));
    t->box = malloc(((size_t)t->node_count + 1) * 6 * sizeof(float));
    if (njobs)
        *njobs = 0;
    if (!t->nodes || !t->box) {
        vbi_kd_free(t);
        return -1;
    }
    uint32_t next = 0;
    if (n > 0)
        vbi_kd_build_rec(t, &next, 0, n, 0, levels, jobs, njobs);
    return 0;
}

void vbi_kd_build_split(vbi_kd_tree *t, const vbi_kd_subtree *job, vbi_kd_subtree *out,
                         uint32_t *nout)
{
    uint32_t next = job->node;
    *nout = 0;
    vbi_kd_build_rec(t, &next, job->begin, job->end, 0, 1, out, nout);
}

void vbi_kd_build_subtree(vbi_kd_tree *t, const vbi_kd_subtree *job)
{
    uint32_t next = job->node;
    vbi_kd_build_rec(t, &next, job->begin, job->end, 0, UINT32_MAX, NULL, NULL);
}

int vbi_kd_build(vbi_kd_tree *t, vbi_kd_pt *pts, uint32_t n)
{
    return vbi_kd_build_top(t, pts, n, UINT32_MAX, NULL, NULL);
}

void vbi_kd_free(vbi_kd_tree *t)
{
    free(t->nodes);
    free(t->box);
    t->nodes = NULL;
    t->box = NULL;
}

/* All points with squared distance <= r2 of q: local indices and squared distances, at most
 * `cap` of them (the output arrays' size); returns the count, or cap + 1 when more were found. */
uint32_t vbi_kd_radius(const vbi_kd_tree *t, const float *q, float r2, uint32_t *out_i,
                        float *out_d2, uint32_t cap)
{
    uint32_t stack[VBI_KD_STACK];
    int sp = 0;
    uint32_t cnt = 0;
    stack[sp++] = 0;
    while (sp > 0) {
        uint32_t ni = stack[--sp];
        const vbi_kd_node *nd = &t->nodes[ni];
        if (nd->axis == VBI_KD_LEAF_AXIS) {
            for (uint32_t i = nd->begin; i < nd->end; ++i) {
                float d2 = vbi_kd_dist2(q, t->pts[i].p);
                if (d2 <= r2) {
                    if (cnt == cap)
                        return cap + 1;
                    out_i[cnt] = i;
                    out_d2[cnt] = d2;
                    cnt++;
                }
            }
            continue;
        }
        /* Left points have coordinate <= split <= right points: the far side is at least
         * |diff| away (float subtraction is monotonic, so the test is conservative). */
        float diff = q[nd->axis] - nd->split;
        int far_ok = diff * diff <= r2;
        if (diff <= 0.0f) {
            if (far_ok) stack[sp++] = nd->right;
            stack[sp++] = ni + 1;
        } else {
            if (far_ok) stack[sp++] = ni + 1;
            stack[sp++] = nd->right;
        }
    }
    return cnt;
}

/* The k best so far are a max-heap in (out_i, out_d2) ordered by (distance, id), the order of
 * vbi_kd_knn's answer: the root is the k-th best, the bound of the search. Entry j's id is
 * t->pts[out_i[j]].id, read only on equal distances. */
static inline int vbi_kd_heap_before(const vbi_kd_tree *t, const uint32_t *hi, const float *hd, uint32_t a,
                                      uint32_t b)
{
    if (hd[a] != hd[b])
        return hd[a] < hd[b];
    return t->pts[hi[a]].id < t->pts[hi[b]].id;
}

/* Puts (vi, vd) at the root of the heap of n entries and sifts it down (moving entries up into
 * the hole instead of swapping). */
static inline void vbi_kd_heap_replace_top(const vbi_kd_tree *t, uint32_t *hi, float *hd, uint32_t n, uint32_t vi,
                                            float vd)
{
    const uint32_t vid = t->pts[vi].id;
    uint32_t j = 0;
    for (;;) {
        uint32_t c = 2 * j + 1;
        if (c >= n)
            break;
        if (c + 1 < n && vbi_kd_heap_before(t, hi, hd, c, c + 1))
            c++;
        if (!(vd < hd[c] || (vd == hd[c] && vid < t->pts[hi[c]].id)))
            break;
        hi[j] = hi[c];
        hd[j] = hd[c];
        j = c;
    }
    hi[j] = vi;
    hd[j] = vd;
}

/* The k-nearest search: a depth-first descent, near side first, that skips a subtree whose box
 * distance exceeds the k-th distance found so far (ties are still visited, so ties by id are
 * exact), keeping the k best in a max-heap in (out_i, out_d2). Returns their count. */
static uint32_t vbi_kd_knn_heap(const vbi_kd_tree *t, const float q[3], uint32_t k, uint32_t skip,
                                 uint32_t *out_i, float *out_d2)
{
    if (!t->nodes || t->n == 0 || k == 0)
        return 0;
    struct {
        uint32_t node;
        float d2;
    } stack[VBI_KD_STACK];
    int sp = 0;
    uint32_t cnt = 0;
    stack[sp].node = 0;
    stack[sp].d2 = 0.0f;
    sp++;
    while (sp > 0) {
        --sp;
        uint32_t ni = stack[sp].node;
        if (cnt == k && stack[sp].d2 > out_d2[0])
            continue;
        const vbi_kd_node *nd = &t->nodes[ni];
        if (nd->axis == VBI_KD_LEAF_AXIS) {
            for (uint32_t i = nd->begin; i < nd->end; ++i) {
                if (i == skip)
                    continue;
                const float d2 = vbi_kd_dist2(q, t->pts[i].p);
                if (cnt < k) { /* push: sift up through the hole */
                    const uint32_t id = t->pts[i].id;
                    uint32_t j = cnt++;
                    while (j > 0) {
                        const uint32_t p = (j - 1) / 2;
                        if (!(out_d2[p] < d2 || (out_d2[p] == d2 && t->pts[out_i[p]].id < id)))
                            break;
                        out_i[j] = out_i[p];
                        out_d2[j] = out_d2[p];
                        j = p;
                    }
                    out_i[j] = i;
                    out_d2[j] = d2;
                } else if (d2 < out_d2[0] || (d2 == out_d2[0] && t->pts[i].id < t->pts[out_i[0]].id)) {
                    vbi_kd_heap_replace_top(t, out_i, out_d2, k, i, d2); /* replaces the k-th best */
                }
            }
            continue;
        }
        /* the far side is at least |diff| away (left points <= split <= right points) */
        float diff = q[nd->axis] - nd->split;
        float pd = stack[sp].d2;
        float fd = diff * diff > pd ? diff * diff : pd;
        uint32_t near = diff <= 0.0f ? ni + 1 : nd->right, far = diff <= 0.0f ? nd->right : ni + 1;
        stack[sp].node = far; /* the stack grows by one entry per level at most */
        stack[sp].d2 = fd;
        sp++;
        stack[sp].node = near;
        stack[sp].d2 = pd;
        sp++;
    }
    return cnt;
}

uint32_t vbi_kd_knn(const vbi_kd_tree *t, const float q[3], uint32_t k, uint32_t skip, uint32_t *out_i,
                     float *out_d2)
{
    const uint32_t cnt = vbi_kd_knn_heap(t, q, k, skip, out_i, out_d2);
    /* heap sort: the largest to the end, one at a time */
    for (uint32_t n = cnt; n > 1; --n) {
        const uint32_t top_i = out_i[0];
        const float top_d = out_d2[0];
        vbi_kd_heap_replace_top(t, out_i, out_d2, n - 1, out_i[n - 1], out_d2[n - 1]);
        out_i[n - 1] = top_i;
        out_d2[n - 1] = top_d;
    }
    return cnt;
}

float vbi_kd_mth_dist2(const vbi_kd_tree *t, uint32_t self, uint32_t m, uint32_t *idx, float *d2)
{
    const uint32_t cnt = vbi_kd_knn_heap(t, t->pts[self].p, m, self, idx, d2);
    float worst = 0.0f; /* the heap's root once full; the largest of fewer otherwise */
    for (uint32_t j = 0; j < (cnt == m ? 1u : cnt); ++j)
        worst = d2[j] > worst ? d2[j] : worst;
    return cnt ? worst : INFINITY;
}

/* Squared distance between two boxes (0 when they overlap). */
static inline float vbi_kd_box_box_dist2(const float *alo, const float *ahi, const float *b)
{
    float s = 0.0f;
    for (int a = 0; a < 3; ++a) {
        float g = b[a] - ahi[a] > alo[a] - b[3 + a] ? b[a] - ahi[a] : alo[a] - b[3 + a];
        s += g > 0.0f ? g * g : 0.0f;
    }
    return s;
}

uint32_t vbi_kd_gather_box(const vbi_kd_tree *t, const float *lo, const float *hi, float r2,
                            uint32_t *out_i, uint32_t cap)
{
    uint32_t stack[VBI_KD_STACK];
    int sp = 0;
    uint32_t cnt = 0;
    stack[sp++] = 0;
    while (sp > 0) {
        uint32_t ni = stack[--sp];
        if (vbi_kd_box_box_dist2(lo, hi, t->box + 6 * (size_t)ni) > r2)
            continue;
        const vbi_kd_node *nd = &t->nodes[ni];
        if (nd->axis == VBI_KD_LEAF_AXIS) {
            if (cnt + (nd->end - nd->begin) > cap) { /* close to the cap: test and stop exactly */
                for (uint32_t i = nd->begin; i < nd->end; ++i)
                    if (vbi_kd_box_dist2(lo, hi, t->pts[i].p) <= r2) {
                        if (cnt == cap)
                            return cap + 1;
                        out_i[cnt++] = i;
                    }
                continue;
            }
            for (uint32_t i = nd->begin; i < nd->end; ++i) { /* branchless: the test is unpredictable */
                out_i[cnt] = i;
                cnt += vbi_kd_box_dist2(lo, hi, t->pts[i].p) <= r2;
            }
            continue;
        }
        stack[sp++] = nd->right; /* left first: depth-first order */
        stack[sp++] = ni + 1;
    }
    return cnt;
}

uint32_t vbi_kd_gather_reach(const vbi_kd_tree *t, const float *lo, const float *hi,
                              const float *node_r2, const float *pt_r2, uint32_t *out_i,
                              uint32_t cap)
{
    uint32_t stack[VBI_KD_STACK];
    int sp = 0;
    uint32_t cnt = 0;
    stack[sp++] = 0;
    while (sp > 0) {
        uint32_t ni = stack[--sp];
        if (!(vbi_kd_box_box_dist2(lo, hi, t->box + 6 * (size_t)ni) < node_r2[ni]))
            continue;
        const vbi_kd_node *nd = &t->nodes[ni];
        if (nd->axis == VBI_KD_LEAF_AXIS) {
            if (cnt + (nd->end - nd->begin) > cap) {
                for (uint32_t i = nd->begin; i < nd->end; ++i)
                    if (vbi_kd_box_dist2(lo, hi, t->pts[i].p) < pt_r2[i]) {
                        if (cnt == cap)
                            return cap + 1;
                        out_i[cnt++] = i;
                    }
                continue;
            }
            for (uint32_t i = nd->begin; i < nd->end; ++i) {
                out_i[cnt] = i;
                cnt += vbi_kd_box_dist2(lo, hi, t->pts[i].p) < pt_r2[i];
            }
            continue;
        }
        stack[sp++] = nd->right;
        stack[sp++] = ni + 1;
    }
    return cnt;
}
