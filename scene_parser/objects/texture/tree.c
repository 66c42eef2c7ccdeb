/* vbnl object layer, texture part: the texture trees (pov_texture.h): creation, deep copies,
 * freeing, POV-Ray's transform rules, average colours and the byte keys that identify equal
 * trees. */
#include <stdlib.h>
#include <string.h>

#include "pov_texture.h"

/* ---- patterns ----------------------------------------------------------------------------------- */

void pov_pattern_init(pov_pattern *p)
{
    memset(p, 0, sizeof(*p));
    vbnl_pattern_desc_init(&p->d);
    p->d.noise_generator = 0; /* the scene's (global_settings), resolved when the scene is built */
    p->image = -1;
}

static void density_release(pov_density *d)
{
    if (d && --d->refs <= 0) {
        free(d->v);
        free(d);
    }
}

void pov_fn_release(pov_fn *f); /* core_material.c */
pov_fn *pov_fn_retain(pov_fn *f);

void pov_pattern_free(pov_pattern *p)
{
    free(p->warps);
    pov_pigment_free(p->pigment);
    pov_fn_release(p->fn);
    density_release(p->density);
    pov_pattern_init(p);
}

int pov_pattern_copy(pov_pattern *dst, const pov_pattern *src)
{
    *dst = *src;
    dst->warps = NULL;
    dst->pigment = NULL;
    if (src->nwarps) {
        dst->warps = malloc(sizeof(*dst->warps) * src->nwarps);
        if (!dst->warps)
            return 0;
        memcpy(dst->warps, src->warps, sizeof(*dst->warps) * src->nwarps);
    }
    if (src->pigment && !(dst->pigment = pov_pigment_dup(src->pigment))) {
        free(dst->warps);
        return 0;
    }
    dst->fn = pov_fn_retain(src->fn);
    if (dst->density)
        dst->density->refs++;
    return 1;
}

int pov_pattern_prepend_warp(pov_pattern *p, const vbnl_warp_desc *w)
{
    if (w->kind == VBNL_WARP_TRANSFORM && p->nwarps && p->warps[0].kind == VBNL_WARP_TRANSFORM) {
        /* the new map acts first: head = head . new */
        double out[16];
        pov_m4_mul(p->warps[0].matrix, w->matrix, out);
        memcpy(p->warps[0].matrix, out, sizeof(out));
        return 1;
    }
    if (p->nwarps >= POV_WARP_MAX)
        return 0;
    vbnl_warp_desc *n = realloc(p->warps, sizeof(*n) * (p->nwarps + 1));
    if (!n)
        return 0;
    memmove(n + 1, n, sizeof(*n) * p->nwarps);
    n[0] = *w;
    p->warps = n;
    p->nwarps++;
    return 1;
}

int pov_pattern_transform(pov_pattern *p, const double m[16])
{
    vbnl_warp_desc w;
    vbnl_warp_desc_init(&w);
    w.kind = VBNL_WARP_TRANSFORM;
    if (!pov_m4_invert(m, w.matrix))
        return 1; /* singular transforms were refused where they were read */
    return pov_pattern_prepend_warp(p, &w);
}

/* ---- maps --------------------------------------------------------------------------------------- */

static void sub_free(pov_map_kind k, void *sub)
{
    if (!sub)
        return;
    if (k == POV_MAP_PIGMENT)
        pov_pigment_free(sub);
    else if (k == POV_MAP_NORMAL)
        pov_normal_free(sub);
    else if (k == POV_MAP_TEXTURE)
        pov_texture_free(sub);
}

static void *sub_dup(pov_map_kind k, const void *sub)
{
    if (k == POV_MAP_PIGMENT)
        return pov_pigment_dup(sub);
    if (k == POV_MAP_NORMAL)
        return pov_normal_dup(sub);
    if (k == POV_MAP_TEXTURE)
        return pov_texture_dup(sub);
    return NULL;
}

void pov_map_free(pov_map *m)
{
    for (uint32_t i = 0; i < m->count; ++i)
        sub_free(m->kind, m->e[i].sub);
    free(m->e);
    m->e = NULL;
    m->count = 0;
}

int pov_map_copy(pov_map *dst, const pov_map *src)
{
    dst->kind = src->kind;
    dst->count = 0;
    dst->e = NULL;
    if (!src->count)
        return 1;
    dst->e = calloc(src->count, sizeof(*dst->e));
    if (!dst->e)
        return 0;
    for (uint32_t i = 0; i < src->count; ++i) {
        dst->e[i] = src->e[i];
        dst->e[i].sub = NULL;
        if (src->e[i].sub && !(dst->e[i].sub = sub_dup(src->kind, src->e[i].sub))) {
            dst->count = i;
            pov_map_free(dst);
            return 0;
        }
    }
    dst->count = src->count;
    return 1;
}

pov_map_entry *pov_map_add(pov_map *m)
{
    if (m->count >= POV_MAP_MAX)
        return NULL;
    pov_map_entry *n = realloc(m->e, sizeof(*n) * (m->count + 1));
    if (!n)
        return NULL;
    m->e = n;
    memset(&n[m->count], 0, sizeof(*n));
    return &n[m->count++];
}

/* ---- pigments ----------------------------------------------------------------------------------- */

pov_pigment *pov_pigment_new(void)
{
    pov_pigment *g = malloc(sizeof(*g));
    if (g) {
        memset(g, 0, sizeof(*g));
        pov_pattern_init(&g->pat);
        g->map.kind = POV_MAP_COLOR;
    }
    return g;
}

pov_pigment *pov_pigment_dup(const pov_pigment *g)
{
    if (!g)
        return NULL;
    pov_pigment *d = malloc(sizeof(*d));
    if (!d)
        return NULL;
    *d = *g;
    if (!pov_pattern_copy(&d->pat, &g->pat)) {
        free(d);
        return NULL;
    }
    if (!pov_map_copy(&d->map, &g->map)) {
        pov_pattern_free(&d->pat);
        free(d);
        return NULL;
    }
    return d;
}

void pov_pigment_free(pov_pigment *g)
{
    if (!g)
        return;
    pov_pattern_free(&g->pat);
    pov_map_free(&g->map);
    free(g);
}

void pov_pigment_clear(pov_pigment *g)
{
    pov_pattern_free(&g->pat);
    pov_map_free(&g->map);
    memset(g, 0, sizeof(*g));
    pov_pattern_init(&g->pat);
}

/* ---- normals ------------------------------------------------------------------------------------ */

pov_normal *pov_normal_new(void)
{
    pov_normal *n = malloc(sizeof(*n));
    if (n) {
        memset(n, 0, sizeof(*n));
        pov_pattern_init(&n->pat);
        n->amount = 0.5;
        n->accuracy = 0.02;
        n->slopes.kind = POV_MAP_SLOPE;
        n->map.kind = POV_MAP_NORMAL;
    }
    return n;
}

pov_normal *pov_normal_dup(const pov_normal *n)
{
    if (!n)
        return NULL;
    pov_normal *d = malloc(sizeof(*d));
    if (!d)
        return NULL;
    *d = *n;
    d->slopes.e = d->map.e = NULL;
    d->slopes.count = d->map.count = 0;
    if (!pov_pattern_copy(&d->pat, &n->pat)) {
        free(d);
        return NULL;
    }
    if (!pov_map_copy(&d->slopes, &n->slopes) || !pov_map_copy(&d->map, &n->map)) {
        pov_normal_free(d);
        return NULL;
    }
    return d;
}

void pov_normal_free(pov_normal *n)
{
    if (!n)
        return;
    pov_pattern_free(&n->pat);
    pov_map_free(&n->slopes);
    pov_map_free(&n->map);
    free(n);
}

/* ---- textures ----------------------------------------------------------------------------------- */

pov_texture *pov_texture_new(void)
{
    pov_texture *t = malloc(sizeof(*t));
    if (!t)
        return NULL;
    memset(t, 0, sizeof(*t));
    pov_pattern_init(&t->pat);
    t->map.kind = POV_MAP_TEXTURE;
    pov_finish_init(&t->fin);
    t->pig = pov_pigment_new();
    if (!t->pig) {
        free(t);
        return NULL;
    }
    return t;
}

static pov_texture *dup_one(const pov_texture *t)
{
    pov_texture *d = malloc(sizeof(*d));
    if (!d)
        return NULL;
    *d = *t;
    d->pig = NULL;
    d->nrm = NULL;
    d->below = NULL;
    d->map.e = NULL;
    d->map.count = 0;
    pov_pattern_init(&d->pat);
    int ok = (!t->pig || (d->pig = pov_pigment_dup(t->pig))) && (!t->nrm || (d->nrm = pov_normal_dup(t->nrm))) &&
             pov_pattern_copy(&d->pat, &t->pat);
    if (ok && !pov_map_copy(&d->map, &t->map)) {
        pov_pattern_free(&d->pat);
        ok = 0;
    }
    if (!ok) {
        pov_pigment_free(d->pig);
        pov_normal_free(d->nrm);
        free(d);
        return NULL;
    }
    return d;
}

pov_texture *pov_texture_dup(const pov_texture *t)
{
    pov_texture *head = NULL, **tail = &head;
    for (; t; t = t->below) {
        if (!(*tail = dup_one(t))) {
            pov_texture_free(head);
            return NULL;
        }
        tail = &(*tail)->below;
    }
    return head;
}

void pov_texture_free(pov_texture *t)
{
    while (t) {
        pov_texture *below = t->below;
        pov_pigment_free(t->pig);
        pov_normal_free(t->nrm);
        pov_pattern_free(&t->pat);
        pov_map_free(&t->map);
        free(t);
        t = below;
    }
}

void pov_texture_put_layer(pov_texture **stack, pov_texture *above)
{
    if (!above)
        return;
    pov_texture *last = above;
    while (last->below)
        last = last->below;
    last->below = *stack;
    *stack = above;
}

int pov_texture_transform(pov_texture *t, const double m[16])
{
    for (; t; t = t->below) {
        if (t->kind == POV_TEX_PLAIN) {
            if (t->pig && !pov_pattern_transform(&t->pig->pat, m))
                return 0;
            if (t->nrm && !pov_pattern_transform(&t->nrm->pat, m))
                return 0;
        } else if (!pov_pattern_transform(&t->pat, m)) {
            return 0;
        }
    }
    return 1;
}

/* ---- averages ----------------------------------------------------------------------------------- */

static void entry_color(const pov_map *m, uint32_t i, const pov_texture_state *s, double out[5])
{
    if (m->kind == POV_MAP_PIGMENT && m->e[i].sub)
        pov_pigment_average(m->e[i].sub, s, out);
    else
        memcpy(out, m->e[i].color, 5 * sizeof(double));
}

void pov_pigment_average(const pov_pigment *g, const pov_texture_state *s, double out[5])
{
    memset(out, 0, 5 * sizeof(double));
    if (g->kind == POV_PIG_SOLID) {
        memcpy(out, g->color, 5 * sizeof(double));
        return;
    }
    if (g->kind == POV_PIG_IMAGE) {
        const pov_image *im = g->pat.image >= 0 && (uint32_t)g->pat.image < s->image_count ? &s->images[g->pat.image] : NULL;
        size_t n = im ? (size_t)im->width * im->height : 0;
        for (size_t i = 0; i < n; ++i) {
            const float *t = im->texels + i * im->channels;
            for (int k = 0; k < 3; ++k)
                out[k] += (im->channels < 3 ? t[0] : t[k]) / (double)n;
        }
        return;
    }
    pov_map def = {POV_MAP_COLOR, 0, NULL};
    const pov_map *m = &g->map;
    if (m->count == 0) {
        pov_default_color_map(&g->pat, &def);
        m = &def;
    }
    double c0[5], c1[5];
    if (g->kind == POV_PIG_AVERAGE || pov_pattern_is_block(&g->pat)) {
        /* every entry weighs its value (average) or covers the same share of space (blocks) */
        double total = 0.0;
        for (uint32_t i = 0; i < m->count; ++i) {
            double w = g->kind == POV_PIG_AVERAGE ? m->e[i].value : 1.0;
            entry_color(m, i, s, c0);
            for (int k = 0; k < 5; ++k)
                out[k] += w * c0[k];
            total += w;
        }
        for (int k = 0; total != 0.0 && k < 5; ++k)
            out[k] /= total;
    } else if (m->count) {
        /* a value uniform on [0, 1] through the map */
        double prev_v = 0.0;
        entry_color(m, 0, s, c0);
        for (uint32_t i = 0; i <= m->count; ++i) {
            double v = i < m->count ? m->e[i].value : 1.0;
            if (i < m->count)
                entry_color(m, i, s, c1);
            v = v < 0.0 ? 0.0 : (v > 1.0 ? 1.0 : v);
            double w = v - prev_v;
            for (int k = 0; w > 0.0 && k < 5; ++k)
                out[k] += w * 0.5 * (c0[k] + c1[k]);
            prev_v = v > prev_v ? v : prev_v;
            memcpy(c0, c1, sizeof(c0));
        }
    }
    pov_map_free(&def);
}

/* ---- keys --------------------------------------------------------------------------------------- */

void pov_key_bytes(pov_key *k, const void *p, size_t n)
{
    if (k->failed)
        return;
    if (k->n + n > k->cap) {
        size_t cap = k->cap ? k->cap : 256;
        while (cap < k->n + n)
            cap *= 2;
        unsigned char *b = realloc(k->b, cap);
        if (!b) {
            k->failed = 1;
            return;
        }
        k->b = b;
        k->cap = cap;
    }
    memcpy(k->b + k->n, p, n);
    k->n += n;
}

#define KEY(k, v) pov_key_bytes((k), &(v), sizeof(v))

static void key_pigment(pov_key *k, const pov_pigment *g);
static void key_normal(pov_key *k, const pov_normal *n);

static void key_pattern(pov_key *k, const pov_pattern *p)
{
    vbnl_pattern_desc d = p->d;
    d.warps = NULL;
    d.density.values = NULL;
    d.function.user = NULL;
    pov_key_bytes(k, &d, sizeof(d));
    KEY(k, p->nwarps);
    if (p->nwarps)
        pov_key_bytes(k, p->warps, sizeof(*p->warps) * p->nwarps);
    KEY(k, p->image);
    KEY(k, p->fn);
    KEY(k, p->density);
    uint8_t has = p->pigment != NULL;
    KEY(k, has);
    if (p->pigment)
        key_pigment(k, p->pigment);
}

static void key_map(pov_key *k, const pov_map *m)
{
    KEY(k, m->kind);
    KEY(k, m->count);
    for (uint32_t i = 0; i < m->count; ++i) {
        const pov_map_entry *e = &m->e[i];
        KEY(k, e->value);
        pov_key_bytes(k, e->color, sizeof(e->color));
        pov_key_bytes(k, e->slope, sizeof(e->slope));
        uint8_t has = e->sub != NULL;
        KEY(k, has);
        if (!e->sub)
            continue;
        if (m->kind == POV_MAP_PIGMENT)
            key_pigment(k, e->sub);
        else if (m->kind == POV_MAP_NORMAL)
            key_normal(k, e->sub);
        else if (m->kind == POV_MAP_TEXTURE)
            pov_key_texture(k, e->sub);
    }
}

static void key_pigment(pov_key *k, const pov_pigment *g)
{
    KEY(k, g->kind);
    KEY(k, g->uv_mapping);
    if (g->kind == POV_PIG_SOLID) {
        pov_key_bytes(k, g->color, sizeof(g->color));
        return;
    }
    key_pattern(k, &g->pat);
    key_map(k, &g->map);
}

static void key_normal(pov_key *k, const pov_normal *n)
{
    KEY(k, n->kind);
    KEY(k, n->amount);
    KEY(k, n->accuracy);
    KEY(k, n->no_bump_scale);
    KEY(k, n->uv_mapping);
    key_pattern(k, &n->pat);
    key_map(k, &n->slopes);
    key_map(k, &n->map);
}

void pov_key_texture(pov_key *k, const pov_texture *t)
{
    for (; t; t = t->below) {
        KEY(k, t->kind);
        KEY(k, t->uv_mapping);
        if (t->kind == POV_TEX_PLAIN) {
            key_pigment(k, t->pig);
            uint8_t has = t->nrm != NULL;
            KEY(k, has);
            if (t->nrm)
                key_normal(k, t->nrm);
            pov_key_bytes(k, &t->fin, sizeof(t->fin));
            pov_key_bytes(k, &t->ext, sizeof(t->ext));
        } else {
            key_pattern(k, &t->pat);
            key_map(k, &t->map);
        }
        uint8_t more = t->below != NULL;
        KEY(k, more);
    }
}
