/* Materials chosen per point (reference manual, "Texture Maps", "Layered Textures", "Average",
 * "Tiles", "Material Maps"; POV-Ray 3.7's trace.cpp: ComputeOneTextureColour and the layer loop of
 * ComputeLightedTexture), and the BSDF at a hit.
 *
 * POV-Ray blends the lit colours of the textures a point holds: a texture map's two neighbouring
 * entries by the pattern's fraction, an average's entries by their weights, layers by
 * (1 - f_i - t_i) prod_{j<i} (f_j c_j + t_j), and the light that passes every layer goes on
 * through the surface. Lit colour is linear in the BSDF, so the blend is a BSDF mixture. Here one
 * member of the mixture is chosen at each hit with probability proportional to its weight (the
 * largest channel of colour weights), and the chosen BSDF carries weight / probability as a
 * colour factor: its expected value is the mixture, and each integrator's estimators (next-event
 * estimation, BSDF sampling, their MIS weights, photon and virtual-light transport) work on one
 * ordinary BSDF with its own pdfs. The choice draws from a stream seeded by a hash of the hit
 * (position bits, primitive, geometry), so every integrator, and every ray that finds the same
 * point, sees the same material there. */
#include <string.h>

#include "rng.h"
#include "scene_internal.h"

/* The decision stream of a hit (SplitMix64 steps). */
typedef struct pick_rng {
    uint64_t s;
} pick_rng;

static double pick_next(pick_rng *r)
{
    r->s += 0x9e3779b97f4a7c15ull;
    return (double)(vbi_hash64(r->s) >> 11) * 0x1.0p-53;
}

/* What the walk down the nodes found. */
typedef struct choice {
    uint32_t leaf;         /* the plain material chosen */
    double tint[3];        /* its colour factor */
    uint32_t normal;       /* normal id + 1 perturbing its shading normal, 0 none */
    dvec3 q;               /* the point the normal receives */
    uint32_t stack[VBNL_TEXTURE_DEPTH_MAX]; /* patterns (id + 1) between the hit and the leaf, outermost first */
    uint32_t depth;
} choice;

static double max3d(const double c[3]) { return fmax(c[0], fmax(c[1], c[2])); }

/* A layer's pigment at q; without one the material's own colour, opaque. */
static void pigment_color(const vbi_texture_set *ts, uint32_t pigment, dvec3 q, const vbi_shade_point *sp,
                          float c[5])
{
    if (pigment) {
        /* outside a `once` image: clear; a uv-mapped pigment reads the hit's (u, v, 0) */
        vbi_pigment_eval(ts, pigment - 1, ts->pigments[pigment - 1].uv ? d3(sp->u, sp->v, 0.0) : q, sp, c);
        return;
    }
    c[0] = c[1] = c[2] = 1.0f;
    c[3] = c[4] = 0.0f;
}

static int finite_nonneg(vec3 c) { return c.x >= 0.0f && c.y >= 0.0f && c.z >= 0.0f && v3_is_finite(c); }

static void choose(const vbnl_scene *s, uint32_t m, dvec3 q, const vbi_shade_point *sp, pick_rng *rng, choice *c);

/* A stack of layers (a TEXTURED node is a stack of one). Each candidate - a layer, or what passes
 * all layers - is weighed by the largest channel of its colour weight and kept with probability
 * weight / running total (weighted reservoir sampling over one pass), so the pigments of layers
 * below an opaque one are never evaluated. */
static void choose_layers(const vbnl_scene *s, const vbnl_material_map_entry *layers, uint32_t count, uint32_t single,
                          dvec3 q, const vbi_shade_point *sp, pick_rng *rng, choice *c)
{
    const vbi_texture_set *ts = &s->tex;
    double fil[3] = {1.0, 1.0, 1.0}, total = 0.0, kept_w = 0.0, kept_col[3] = {0.0, 0.0, 0.0};
    uint32_t kept = UINT32_MAX, top_normal = 0, transmission = 0;
    int kept_pass = 0;
    for (uint32_t i = 0; i < count; ++i) {
        const uint32_t lm = layers ? layers[i].material : single;
        const scene_material *sm = &s->materials[lm];
        float col[5] = {1.0f, 1.0f, 1.0f, 0.0f, 0.0f};
        if (sm->is_node && sm->node.kind == VBNL_NODE_TEXTURED) {
            pigment_color(ts, sm->node.pigment, q, sp, col);
            if (i == 0)
                top_normal = sm->node.normal;
            transmission = sm->node.transmission;
        } else {
            transmission = 0; /* plain materials and other nodes are opaque layers */
        }
        double f = col[3], t = col[4], att = 1.0 - f - t;
        if (att < 0.0)
            att = 0.0;
        double w[3];
        for (int k = 0; k < 3; ++k)
            w[k] = fil[k] * att * fmax(col[k], 0.0);
        const double wm = max3d(w);
        if (wm > 0.0) {
            total += wm;
            if (pick_next(rng) * total < wm) {
                kept = i;
                kept_w = wm;
                kept_pass = 0;
                memcpy(kept_col, w, sizeof(w));
            }
        }
        for (int k = 0; k < 3; ++k)
            fil[k] *= fmax(col[k] * f + t, 0.0);
        if (!(max3d(fil) > 0.0))
            break;
    }
    double wt = max3d(fil);
    if (transmission && wt > 0.0) { /* what passes every layer goes through the bottom one */
        total += wt;
        if (pick_next(rng) * total < wt) {
            kept = count;
            kept_w = wt;
            kept_pass = 1;
            memcpy(kept_col, fil, sizeof(fil));
        }
    }
    if (kept == UINT32_MAX) { /* nothing reflects or passes: black */
        const uint32_t lm = layers ? layers[0].material : single;
        const scene_material *sm = &s->materials[lm];
        c->leaf = sm->is_node && sm->node.kind == VBNL_NODE_TEXTURED ? sm->node.material : lm;
        c->tint[0] = c->tint[1] = c->tint[2] = 0.0;
        return;
    }
    const double scale = total / kept_w; /* 1 / probability */
    if (kept_pass) {
        c->leaf = transmission - 1;
        c->normal = top_normal; /* POV-Ray refracts on the top layer's normal */
        c->q = q;
        for (int k = 0; k < 3; ++k)
            c->tint[k] *= kept_col[k] * scale;
        return;
    }
    const uint32_t lm = layers ? layers[kept].material : single;
    const scene_material *sm = &s->materials[lm];
    if (sm->is_node && sm->node.kind == VBNL_NODE_TEXTURED) {
        c->leaf = sm->node.material;
        c->normal = sm->node.normal;
        c->q = q;
        for (int k = 0; k < 3; ++k)
            c->tint[k] *= kept_col[k] * scale;
        /* without a pigment of its own, the material's base_texture colours it */
        const uint32_t bt = s->materials[c->leaf].desc.base_texture;
        if (!sm->node.pigment && bt) {
            float col[5];
            vbi_pigment_eval(ts, bt - 1, q, sp, col);
            for (int k = 0; k < 3; ++k)
                c->tint[k] *= fmax(col[k], 0.0);
        }
        return;
    }
    for (int k = 0; k < 3; ++k)
        c->tint[k] *= kept_col[k] * scale;
    choose(s, lm, q, sp, rng, c);
}

static void choose(const vbnl_scene *s, uint32_t m, dvec3 q, const vbi_shade_point *sp, pick_rng *rng, choice *c)
{
    const vbi_texture_set *ts = &s->tex;
    const scene_material *sm = &s->materials[m];
    if (!sm->is_node) {
        c->leaf = m;
        if (sm->desc.base_texture) {
            float col[5];
            vbi_pigment_eval(ts, sm->desc.base_texture - 1, q, sp, col);
            for (int k = 0; k < 3; ++k)
                c->tint[k] *= fmax(col[k], 0.0);
        }
        return;
    }
    const vbi_mnode *nd = &sm->node;
    const vbnl_material_map_entry *map = ts->material_entries + nd->entry_begin;
    switch (nd->kind) {
    case VBNL_NODE_TEXTURED:
        choose_layers(s, NULL, 1, m, q, sp, rng, c);
        return;
    case VBNL_NODE_LAYERS:
        choose_layers(s, map, nd->entry_count, 0, q, sp, rng, c);
        return;
    case VBNL_NODE_MAP: {
        const vbi_pattern *pt = &ts->patterns[nd->pattern - 1];
        dvec3 w;
        double v = vbi_pattern_value(ts, pt, q, sp, &w);
        uint32_t a, b;
        double f;
        vbi_map_search(&map[0].value, sizeof(*map), nd->entry_count, v, &a, &b, &f);
        uint32_t e = a == b || pick_next(rng) < f ? b : a;
        if (c->depth < VBNL_TEXTURE_DEPTH_MAX)
            c->stack[c->depth++] = nd->pattern;
        choose(s, map[e].material, w, sp, rng, c);
        return;
    }
    case VBNL_NODE_AVERAGE: {
        dvec3 w = q;
        if (nd->pattern) {
            w = vbi_pattern_point(ts, &ts->patterns[nd->pattern - 1], q);
            if (c->depth < VBNL_TEXTURE_DEPTH_MAX)
                c->stack[c->depth++] = nd->pattern;
        }
        double total = 0.0;
        for (uint32_t i = 0; i < nd->entry_count; ++i)
            total += fmax(map[i].value, 0.0);
        double u = pick_next(rng) * total, acc = 0.0;
        uint32_t e = nd->entry_count - 1;
        for (uint32_t i = 0; i < nd->entry_count; ++i) {
            acc += fmax(map[i].value, 0.0);
            if (u < acc) {
                e = i;
                break;
            }
        }
        choose(s, map[e].material, w, sp, rng, c);
        return;
    }
    }
}

static void shade_point(const vbnl_scene *s, const vbi_hit *hit, vbi_shade_point *sp)
{
    sp->p = d3(hit->p.x, hit->p.y, hit->p.z);
    sp->n = d3(hit->ns.x, hit->ns.y, hit->ns.z);
    sp->u = hit->uv.x;
    sp->v = hit->uv.y;
    sp->eye = d3(s->camera.position[0], s->camera.position[1], s->camera.position[2]);
}

static uint64_t hit_seed(const vbi_hit *hit)
{
    uint32_t b[3];
    memcpy(&b[0], &hit->p.x, 4);
    memcpy(&b[1], &hit->p.y, 4);
    memcpy(&b[2], &hit->p.z, 4);
    return vbi_hash3(((uint64_t)b[0] << 32) | b[1], ((uint64_t)b[2] << 32) | hit->prim, hit->geom);
}

/* The material chosen at a hit, and the perturbed shading normal when `bumped` is not NULL. */
static void resolve(const vbnl_scene *s, const vbi_hit *hit, choice *c, int *bumped, vec3 *ns)
{
    vbi_shade_point sp;
    shade_point(s, hit, &sp);
    pick_rng rng = {hit_seed(hit)};
    const scene_material *top = &s->materials[hit->material];
    const int uv = top->is_node ? top->node.uv : 0;
    c->tint[0] = c->tint[1] = c->tint[2] = 1.0;
    c->normal = 0;
    c->depth = 0;
    dvec3 q = uv ? d3(sp.u, sp.v, 0.0) : sp.p;
    if (!top->is_node && top->desc.base_texture && s->tex.pigments[top->desc.base_texture - 1].uv)
        q = d3(sp.u, sp.v, 0.0);
    choose(s, hit->material, q, &sp, &rng, c);
    if (!bumped)
        return;
    *bumped = 0;
    if (!c->normal)
        return;
    /* the normal in the space the leaf's point lives in: through the maps' transforms and back */
    const vbi_texture_set *ts = &s->tex;
    dvec3 n = sp.n;
    for (uint32_t i = 0; i < c->depth; ++i)
        n = d3_norm(vbi_pattern_normal_in(ts, &ts->patterns[c->stack[i] - 1], n));
    vbi_shade_point lsp = sp;
    lsp.n = n;
    if (ts->normals[c->normal - 1].uv)
        c->q = d3(sp.u, sp.v, 0.0);
    n = vbi_normal_perturb_at(ts, c->normal - 1, c->q, &lsp);
    for (uint32_t i = c->depth; i-- > 0;)
        n = d3_norm(vbi_pattern_normal_out(ts, &ts->patterns[c->stack[i] - 1], n));
    if (!(d3_dot(n, n) > 0.5) || !isfinite(n.x + n.y + n.z))
        return;
    *bumped = 1;
    *ns = v3((float)n.x, (float)n.y, (float)n.z);
}

void vbi_surface_bsdf_resolve(const vbnl_scene *s, const vbi_hit *hit, vbi_bsdf *storage)
{
    choice c;
    int bumped;
    vec3 ns;
    resolve(s, hit, &c, &bumped, &ns);
    *storage = s->materials[c.leaf].bsdf;
    storage->color = v3_mul(storage->color, v3((float)c.tint[0], (float)c.tint[1], (float)c.tint[2]));
    if (!finite_nonneg(storage->color))
        storage->color = v3s(0.0f);
    storage->bumped = bumped;
    if (bumped)
        storage->ns = ns;
}

uint32_t vbi_surface_light_material(const vbnl_scene *s, const vbi_hit *hit, vec3 *tint)
{
    const scene_material *m = &s->materials[hit->material];
    if (!m->varies) {
        *tint = v3s(1.0f);
        return hit->material;
    }
    choice c;
    resolve(s, hit, &c, NULL, NULL);
    *tint = v3((float)c.tint[0], (float)c.tint[1], (float)c.tint[2]);
    if (!finite_nonneg(*tint))
        *tint = v3s(0.0f);
    return m->is_node ? vbi_material_hidden(s, hit->material, c.leaf) : hit->material;
}
