/* vbnl object layer: triangle lists on a surface, refined edge by edge (pov_surface.h).
 *
 * Each edge is decided once (a hash of its two vertex ids remembers the midpoint it got, or
 * that it stays), so the two triangles on an edge always split it alike: the refined mesh has no
 * T-junctions. A triangle with one, two or three split edges becomes two, three or four, and
 * the new triangles are refined in turn. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pov_surface.h"

uint32_t pov_smesh_vert(pov_smesh *m, const pov_svert *v)
{
    if (m->oom)
        return UINT32_MAX;
    if (m->nv == m->capv) {
        uint32_t cap = m->capv ? 2 * m->capv : 256;
        pov_svert *n = cap > m->capv ? realloc(m->v, (size_t)cap * sizeof *n) : NULL;
        if (!n) {
            m->oom = 1;
            return UINT32_MAX;
        }
        m->v = n;
        m->capv = cap;
    }
    m->v[m->nv] = *v;
    return m->nv++;
}

void pov_smesh_tri(pov_smesh *m, uint32_t a, uint32_t b, uint32_t c)
{
    if (m->oom || a == UINT32_MAX || b == UINT32_MAX || c == UINT32_MAX) {
        m->oom = 1;
        return;
    }
    if (a == b || b == c || a == c)
        return;
    if (m->nt == m->capt) {
        uint32_t cap = m->capt ? 2 * m->capt : 256;
        uint32_t *n = cap > m->capt ? realloc(m->t, (size_t)cap * 3 * sizeof *n) : NULL;
        if (!n) {
            m->oom = 1;
            return;
        }
        m->t = n;
        m->capt = cap;
    }
    m->t[3 * m->nt] = a;
    m->t[3 * m->nt + 1] = b;
    m->t[3 * m->nt + 2] = c;
    m->nt++;
}

void pov_smesh_tri_facing(pov_smesh *m, uint32_t a, uint32_t b, uint32_t c)
{
    if (m->oom || a >= m->nv || b >= m->nv || c >= m->nv) {
        m->oom = 1;
        return;
    }
    const double *pa = m->v[a].p, *pb = m->v[b].p, *pc = m->v[c].p;
    double e1[3] = {pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]}, e2[3] = {pc[0] - pa[0], pc[1] - pa[1], pc[2] - pa[2]};
    double f[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    double d = 0;
    for (int k = 0; k < 3; ++k)
        d += f[k] * (m->v[a].n[k] + m->v[b].n[k] + m->v[c].n[k]);
    if (d < 0)
        pov_smesh_tri(m, a, c, b);
    else
        pov_smesh_tri(m, a, b, c);
}

void pov_smesh_free(pov_smesh *m)
{
    free(m->v);
    free(m->t);
    memset(m, 0, sizeof *m);
}

pov_mesh *pov_smesh_to_mesh(const pov_smesh *m, int with_uv)
{
    pov_mesh *o = pov_mesh_new();
    if (!o || m->oom)
        goto fail;
    /* only the vertices the triangles use, in their order of first use */
    uint32_t *map = malloc(sizeof *map * (m->nv ? m->nv : 1));
    if (!map)
        goto fail;
    for (uint32_t i = 0; i < m->nv; ++i)
        map[i] = UINT32_MAX;
    for (uint32_t t = 0; t < m->nt; ++t) {
        uint32_t id[3];
        for (int k = 0; k < 3; ++k) {
            uint32_t v = m->t[3 * t + k];
            if (map[v] == UINT32_MAX)
                map[v] = pov_mesh_vertex(o, m->v[v].p, m->v[v].n, with_uv ? m->v[v].uv : NULL);
            id[k] = map[v];
        }
        if (!pov_mesh_tri(o, id[0], id[1], id[2], -1)) {
            free(map);
            goto fail;
        }
    }
    free(map);
    return o;
fail:
    pov_mesh_unref(o);
    return NULL;
}

/* ---- parametric patches ------------------------------------------------------------------------- */

static double dist2(const double a[3], const double b[3])
{
    double d0 = a[0] - b[0], d1 = a[1] - b[1], d2 = a[2] - b[2];
    return d0 * d0 + d1 * d1 + d2 * d2;
}

void pov_smesh_grid(pov_smesh *m, pov_param_fn eval, void *user, const double lo[2], const double hi[2], int n0, int n1)
{
    const uint32_t w = (uint32_t)n0 + 1;
    uint32_t *ids = malloc(sizeof *ids * w * (size_t)(n1 + 1));
    if (!ids) {
        m->oom = 1;
        return;
    }
    for (int j = 0; j <= n1; ++j) {
        pov_svert row[w];
        int pole = 1;
        for (int i = 0; i <= n0; ++i) {
            pov_svert *v = &row[i];
            memset(v, 0, sizeof *v);
            v->s[0] = i == n0 ? hi[0] : lo[0] + (hi[0] - lo[0]) * i / n0;
            v->s[1] = j == n1 ? hi[1] : lo[1] + (hi[1] - lo[1]) * j / n1;
            eval(user, v);
            pole &= dist2(v->p, row[0].p) == 0;
        }
        /* a row that is one point (a pole) is one vertex, without a first parameter: the edges
         * to it are then shared by their two triangles, and their midpoints take the other end's */
        if (pole && n0 > 0) {
            row[0].s[0] = NAN;
            uint32_t id = pov_smesh_vert(m, &row[0]);
            for (int i = 0; i <= n0; ++i)
                ids[(size_t)j * w + (size_t)i] = id;
        } else {
            for (int i = 0; i <= n0; ++i)
                ids[(size_t)j * w + (size_t)i] = pov_smesh_vert(m, &row[i]);
        }
    }
    if (m->oom) {
        free(ids);
        return;
    }
    for (int j = 0; j < n1; ++j)
        for (int i = 0; i < n0; ++i) {
            const uint32_t *r0 = ids + (size_t)j * w + (size_t)i, *r1 = r0 + w;
            uint32_t a = r0[0], b = r0[1], c = r1[1], d = r1[0];
            /* the shorter diagonal; a pole (two corners at one point) loses its empty triangle */
            const double *pa = m->v[a].p, *pb = m->v[b].p, *pc = m->v[c].p, *pd = m->v[d].p;
            int ab = dist2(pa, pb) == 0, cd = dist2(pc, pd) == 0;
            if (ab || cd || dist2(pa, pc) <= dist2(pb, pd)) {
                if (!ab)
                    pov_smesh_tri(m, a, b, c);
                if (!cd)
                    pov_smesh_tri(m, a, c, d);
            } else {
                pov_smesh_tri(m, a, b, d);
                pov_smesh_tri(m, b, c, d);
            }
        }
    free(ids);
}

int pov_param_mid(void *user, const pov_svert *a, const pov_svert *b, pov_svert *out)
{
    const pov_param *pp = user;
    memset(out, 0, sizeof *out);
    if (isnan(a->s[0]) && isnan(b->s[0]))
        return 0; /* both at one pole */
    out->s[0] = isnan(a->s[0]) ? b->s[0] : isnan(b->s[0]) ? a->s[0] : 0.5 * (a->s[0] + b->s[0]);
    out->s[1] = 0.5 * (a->s[1] + b->s[1]);
    pp->eval(pp->user, out);
    return 1;
}

/* ---- refinement --------------------------------------------------------------------------------- */

#define NO_SPLIT (UINT32_MAX - 1)

/* ---- a hash table of 64-bit keys (edges here, grid points in implicit.c) ---------------------- */

static uint64_t mix(uint64_t k)
{
    k ^= k >> 33;
    k *= 0xff51afd7ed558ccdull;
    k ^= k >> 33;
    k *= 0xc4ceb9fe1a85ec53ull;
    return k ^ (k >> 33);
}

static int hmap_grow(pov_hmap *m)
{
    size_t cap = m->cap ? 2 * m->cap : 1024;
    uint64_t *k = calloc(cap, sizeof *k);
    uint32_t *v = malloc(cap * sizeof *v);
    if (!k || !v) {
        free(k);
        free(v);
        return 0;
    }
    for (size_t i = 0; i < m->cap; ++i)
        if (m->keys[i]) {
            size_t h = mix(m->keys[i]) & (cap - 1);
            while (k[h])
                h = (h + 1) & (cap - 1);
            k[h] = m->keys[i];
            v[h] = m->vals[i];
        }
    free(m->keys);
    free(m->vals);
    m->keys = k;
    m->vals = v;
    m->cap = cap;
    return 1;
}

uint32_t *pov_hmap_at(pov_hmap *m, uint64_t key, int *isnew)
{
    if ((m->n + 1) * 2 > m->cap && !hmap_grow(m))
        return NULL;
    key += 1;
    size_t h = mix(key) & (m->cap - 1);
    while (m->keys[h] && m->keys[h] != key)
        h = (h + 1) & (m->cap - 1);
    *isnew = !m->keys[h];
    if (*isnew) {
        m->keys[h] = key;
        m->vals[h] = UINT32_MAX;
        m->n++;
    }
    return &m->vals[h];
}

void pov_hmap_free(pov_hmap *m)
{
    free(m->keys);
    free(m->vals);
    memset(m, 0, sizeof *m);
}

typedef struct refiner {
    pov_smesh *m;
    pov_mid_fn mid;
    void *user;
    double tol2, cos_limit;
    int max_depth;
    pov_hmap edges; /* edge (min << 32 | max) -> its midpoint's vertex, or NO_SPLIT */
} refiner;

/* The midpoint vertex of edge a-b, or NO_SPLIT; UINT32_MAX when out of memory. */
static uint32_t edge_mid(refiner *r, uint32_t a, uint32_t b, int depth)
{
    int isnew;
    uint32_t *slot = pov_hmap_at(&r->edges, (uint64_t)(a < b ? a : b) << 32 | (a < b ? b : a), &isnew);
    if (!slot)
        return UINT32_MAX;
    if (!isnew)
        return *slot;
    uint32_t res = NO_SPLIT;
    pov_smesh *m = r->m;
    if (depth < r->max_depth && !m->capped) {
        const pov_svert *va = &m->v[a], *vb = &m->v[b];
        double len2 = dist2(va->p, vb->p);
        pov_svert mv;
        if (len2 > r->tol2 && r->mid(r->user, va, vb, &mv)) {
            double c[3] = {0.5 * (va->p[0] + vb->p[0]), 0.5 * (va->p[1] + vb->p[1]), 0.5 * (va->p[2] + vb->p[2])};
            double cosn = va->n[0] * vb->n[0] + va->n[1] * vb->n[1] + va->n[2] * vb->n[2];
            if (dist2(mv.p, c) > r->tol2 || (cosn < r->cos_limit && len2 > 256 * r->tol2)) {
                if (m->nt >= POV_TESS_MAX_TRIANGLES)
                    m->capped = 1;
                else
                    res = pov_smesh_vert(m, &mv);
            }
        }
    }
    *slot = res; /* the table did not change since: the slot stands */
    return res;
}

static void refine_tri(refiner *r, uint32_t a, uint32_t b, uint32_t c, int depth)
{
    pov_smesh *m = r->m;
    if (m->oom)
        return;
    uint32_t ab = edge_mid(r, a, b, depth), bc = edge_mid(r, b, c, depth), ca = edge_mid(r, c, a, depth);
    if (ab == UINT32_MAX || bc == UINT32_MAX || ca == UINT32_MAX) {
        m->oom = 1;
        return;
    }
    int sab = ab != NO_SPLIT, sbc = bc != NO_SPLIT, sca = ca != NO_SPLIT;
    switch (sab + sbc + sca) {
    case 0:
        pov_smesh_tri(m, a, b, c);
        return;
    case 3:
        refine_tri(r, a, ab, ca, depth + 1);
        refine_tri(r, ab, b, bc, depth + 1);
        refine_tri(r, ca, bc, c, depth + 1);
        refine_tri(r, ab, bc, ca, depth + 1);
        return;
    case 1: /* rotate so that the split edge is a-b */
        if (sbc)
            refine_tri(r, bc, c, a, depth + 1), refine_tri(r, bc, a, b, depth + 1);
        else if (sca)
            refine_tri(r, ca, a, b, depth + 1), refine_tri(r, ca, b, c, depth + 1);
        else
            refine_tri(r, ab, b, c, depth + 1), refine_tri(r, ab, c, a, depth + 1);
        return;
    default: { /* two: rotate so that the unsplit edge is c-a */
        uint32_t v0 = a, v1 = b, v2 = c, m01 = ab, m12 = bc;
        if (!sab) /* bc and ca split: edge a-b stays */
            v0 = b, v1 = c, v2 = a, m01 = bc, m12 = ca;
        else if (!sbc) /* ca and ab split: edge b-c stays */
            v0 = c, v1 = a, v2 = b, m01 = ca, m12 = ab;
        refine_tri(r, m01, v1, m12, depth + 1);
        /* the quad v0 m01 m12 v2 along its shorter diagonal */
        if (dist2(m->v[v0].p, m->v[m12].p) <= dist2(m->v[m01].p, m->v[v2].p)) {
            refine_tri(r, v0, m01, m12, depth + 1);
            refine_tri(r, v0, m12, v2, depth + 1);
        } else {
            refine_tri(r, v0, m01, v2, depth + 1);
            refine_tri(r, m01, m12, v2, depth + 1);
        }
        return;
    }
    }
}

void pov_smesh_refine(pov_smesh *m, uint32_t first, pov_mid_fn mid, void *user, double tol, int max_depth)
{
    if (m->oom || m->nt <= first)
        return;
    refiner r;
    memset(&r, 0, sizeof r);
    r.m = m;
    r.mid = mid;
    r.user = user;
    r.tol2 = tol * tol;
    r.cos_limit = 0.5; /* 60 degrees between the end normals */
    r.max_depth = max_depth;
    size_t count = (size_t)(m->nt - first) * 3;
    uint32_t *old = malloc(count * sizeof *old), nt = m->nt - first;
    if (!old) {
        m->oom = 1;
        return;
    }
    memcpy(old, m->t + 3 * (size_t)first, count * sizeof *old);
    m->nt = first;
    for (uint32_t t = 0; t < nt && !m->oom; ++t)
        refine_tri(&r, old[3 * t], old[3 * t + 1], old[3 * t + 2], 0);
    free(old);
    pov_hmap_free(&r.edges);
}
