/* vbnl object layer, texture part: an appearance onto a core material and texture (the finish
 * table in scene_parser/README.md). Core materials are shared: one per distinct content, found by
 * a byte key of the material description and the texture inputs (the image by its file). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pov_texture.h"

/* A core material added by the texture part, and what made it. */
struct pov_material_entry {
    unsigned char key[sizeof(vbnl_material_desc) + sizeof(pov_pigment) + 8];
    uint32_t material;
    vbnl_material_desc desc;
    int has_texture;
    vbnl_texture_desc tdesc;
    vbnl_color_map_entry map[POV_MAP_MAX];
};

/* Warnings found while mapping an appearance: reported only when it makes a new core material,
 * so objects sharing an appearance warn once. */
typedef struct map_notes {
    const char *clamped_what;
    double clamped_value;
    int no_ior;
} map_notes;

static float clamp_albedo(map_notes *n, double v, const char *what)
{
    if (v > 1.0 || v < 0.0) {
        if (!n->clamped_what) {
            n->clamped_what = what;
            n->clamped_value = v;
        }
        v = v > 1.0 ? 1.0 : 0.0;
    }
    return (float)v;
}

static void report_notes(pov_ctx *c, const pov_appearance *a, const map_notes *n)
{
    const vbnl_sdl_loc *loc = a->loc.file ? &a->loc : NULL;
    if (n->clamped_what)
        vbnl_sdl_warning(c->parser, loc, "%s %.3g exceeds the energy-conserving range [0, 1]: clamped",
                         n->clamped_what, n->clamped_value);
    if (n->no_ior)
        vbnl_sdl_warning(c->parser, loc,
                         "transparent pigment without interior { ior > 1 }: rendered as glass of ior 1.5");
}

/* Blinn-Phong exponent n to GGX alpha (Walter et al. 2007): alpha = sqrt(2 / (n + 2)). */
static float alpha_from_exponent(double n)
{
    double a = sqrt(2.0 / (n + 2.0));
    return (float)(a < 0.001 ? 0.001 : (a > 1.0 ? 1.0 : a));
}

vbnl_result pov_appearance_material(pov_ctx *c, const pov_appearance *a, const double world_from_pov[16],
                                    uint32_t *material, vbnl_error *err)
{
    pov_texture_state *s = c->tex;
    pov_appearance tmp;
    if (!a) {
        tmp = s->deflt;
        a = &tmp;
    }
    const pov_texture *tx = &a->tex;
    const pov_pigment *g = &tx->pig;
    const pov_finish *f = &tx->fin;
    map_notes notes = {NULL, 0.0, 0};

    /* the pigment's representative colour (solid colour, or 1 where a texture supplies it) */
    double pc[5] = {1, 1, 1, 0, 0};
    int textured = g->kind != POV_PIG_SOLID;
    if (!textured)
        memcpy(pc, g->color, sizeof(pc));
    double filter = textured ? 0.0 : pc[3], transmit = textured ? 0.0 : pc[4];

    vbnl_material_desc md;
    vbnl_material_desc_init(&md);
    double scale[3] = {1, 1, 1}; /* multiplies the pigment colour into base_color */
    if (tx->ext.set) {
        md = tx->ext.desc;
        if (!tx->ext.has_color) {
            scale[0] = scale[1] = scale[2] = 1.0;
        } else {
            textured = 0; /* an explicit colour replaces the pigment */
            for (int k = 0; k < 3; ++k)
                pc[k] = md.base_color[k];
        }
    } else {
        double refl = (f->reflection[0] + f->reflection[1] + f->reflection[2]) / 3.0;
        if (filter + transmit > 0.0) {
            md.type = VBNL_MATERIAL_DIELECTRIC;
            md.ior = (float)(a->interior.ior > 1.0 ? a->interior.ior : 1.5);
            notes.no_ior = !(a->interior.ior > 1.0);
            /* filter tints by the colour, transmit passes light unchanged */
            double w = filter / (filter + transmit);
            for (int k = 0; k < 3; ++k)
                pc[k] = w * pc[k] + (1.0 - w);
        } else if (f->metallic && (refl > 0.0 || f->specular > 0.0 || f->phong > 0.0)) {
            md.type = VBNL_MATERIAL_CONDUCTOR;
            md.alpha = f->specular > 0.0   ? alpha_from_exponent(1.0 / f->roughness)
                       : f->phong > 0.0    ? alpha_from_exponent(4.0 * f->phong_size)
                                           : 0.001f;
        } else if (refl > 0.0 && f->diffuse <= 0.0 && f->specular <= 0.0 && f->phong <= 0.0) {
            md.type = VBNL_MATERIAL_MIRROR;
            for (int k = 0; k < 3; ++k)
                scale[k] = f->reflection[k];
            textured = 0;
            pc[0] = pc[1] = pc[2] = 1.0;
        } else if (refl > 0.0 || f->specular > 0.0 || f->phong > 0.0) {
            md.type = VBNL_MATERIAL_PLASTIC;
            md.alpha = f->specular > 0.0 ? alpha_from_exponent(1.0 / f->roughness)
                       : f->phong > 0.0  ? alpha_from_exponent(4.0 * f->phong_size)
                                         : 0.001f;
            md.ior = (float)(a->interior.ior > 1.0 ? a->interior.ior : 1.5);
            for (int k = 0; k < 3; ++k)
                scale[k] = f->diffuse;
        } else {
            md.type = VBNL_MATERIAL_LAMBERT;
            for (int k = 0; k < 3; ++k)
                scale[k] = f->diffuse;
        }
        for (int k = 0; k < 3; ++k)
            md.emission[k] = (float)(f->emission[k] * (textured ? 1.0 : pc[k]));
        md.two_sided = 1; /* POV-Ray's emission glows on both sides of a surface */
        if (textured && (f->emission[0] > 0 || f->emission[1] > 0 || f->emission[2] > 0)) {
            double avg[5];
            pov_color_map_average(&g->map, avg);
            for (int k = 0; k < 3; ++k)
                md.emission[k] = (float)(f->emission[k] * (g->kind == POV_PIG_IMAGE ? 1.0 : avg[k]));
        }
    }
    for (int k = 0; k < 3; ++k) {
        if (!(md.emission[k] >= 0.0f) || !isfinite(md.emission[k]))
            md.emission[k] = 0.0f;
        md.base_color[k] = clamp_albedo(&notes, scale[k] * (textured ? 1.0 : pc[k]), "albedo");
    }

    /* the texture */
    vbnl_texture_desc td;
    vbnl_texture_desc_init(&td);
    vbnl_color_map_entry map[POV_MAP_MAX];
    int image = -1;
    if (textured) {
        double pov_from_world[16], world_from_pattern[16], pattern_from_world[16];
        if (!pov_m4_invert(world_from_pov, pov_from_world))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "world_from_pov is singular");
        pov_m4_mul(world_from_pov, g->xf, world_from_pattern);
        if (!pov_m4_invert(world_from_pattern, pattern_from_world))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "a pigment transform is singular");
        for (int i = 0; i < 16; ++i)
            td.pattern_from_world[i] = (float)pattern_from_world[i];
        switch (g->kind) {
        case POV_PIG_CHECKER: td.kind = VBNL_TEXTURE_CHECKER; break;
        case POV_PIG_GRADIENT: td.kind = VBNL_TEXTURE_GRADIENT; break;
        case POV_PIG_BRICK: td.kind = VBNL_TEXTURE_BRICK; break;
        default: td.kind = VBNL_TEXTURE_IMAGE; break;
        }
        for (int k = 0; k < 3; ++k) {
            td.gradient[k] = (float)g->gradient[k];
            td.brick_size[k] = (float)g->brick_size[k];
        }
        td.mortar = (float)g->mortar;
        td.frequency = (float)g->frequency;
        td.phase = (float)g->phase;
        td.wave = (vbnl_texture_wave)g->wave;
        if (g->kind == POV_PIG_IMAGE) {
            const pov_image *im = &s->images[g->image];
            image = g->image;
            td.texels = im->texels;
            td.width = im->width;
            td.height = im->height;
            td.projection = g->uv_mapping ? VBNL_PROJECTION_UV
                            : g->map_type == 1 ? VBNL_PROJECTION_SPHERICAL
                            : g->map_type == 2 ? VBNL_PROJECTION_CYLINDRICAL
                                               : VBNL_PROJECTION_PLANAR;
            td.wrap = g->once ? VBNL_WRAP_CLAMP : VBNL_WRAP_REPEAT;
            td.interpolate = g->interpolate;
        } else {
            td.color_map = map;
            td.color_map_count = g->map.count;
            for (uint32_t i = 0; i < g->map.count; ++i) {
                map[i].value = (float)g->map.e[i].value;
                for (int k = 0; k < 3; ++k)
                    map[i].color[k] = clamp_albedo(&notes, g->map.e[i].color[k], "pigment colour");
            }
        }
    }

    /* the cache: one core material per distinct content */
    pov_material_entry *ce = calloc(1, sizeof(*ce));
    if (!ce)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    ce->desc = md;
    ce->has_texture = textured;
    ce->tdesc = td;
    if (textured) {
        memcpy(ce->map, map, sizeof(vbnl_color_map_entry) * td.color_map_count);
        ce->tdesc.color_map = NULL;
        ce->tdesc.texels = NULL;
    }
    /* key: the material description, the texture inputs (with the image index in place of texels) */
    unsigned char *k = ce->key;
    memcpy(k, &md, sizeof(md));
    k += sizeof(md);
    if (textured) {
        pov_pigment key_pig;
        memset(&key_pig, 0, sizeof(key_pig));
        key_pig.kind = g->kind;
        memcpy(key_pig.xf, td.pattern_from_world, sizeof(td.pattern_from_world)); /* floats suffice */
        key_pig.map.count = g->map.count;
        for (uint32_t i = 0; i < g->map.count; ++i) {
            key_pig.map.e[i].value = map[i].value;
            for (int q = 0; q < 3; ++q)
                key_pig.map.e[i].color[q] = map[i].color[q];
        }
        memcpy(key_pig.gradient, g->gradient, sizeof(g->gradient));
        memcpy(key_pig.brick_size, g->brick_size, sizeof(g->brick_size));
        key_pig.mortar = g->mortar;
        key_pig.frequency = g->frequency;
        key_pig.phase = g->phase;
        key_pig.wave = g->wave;
        key_pig.image = image;
        key_pig.map_type = (int)td.projection;
        key_pig.once = g->once;
        key_pig.interpolate = g->interpolate;
        memcpy(k, &key_pig, sizeof(key_pig));
    }
    for (uint32_t i = 0; i < s->cache_count; ++i) {
        if (!memcmp(s->cache[i]->key, ce->key, sizeof(ce->key))) {
            *material = s->cache[i]->material;
            free(ce);
            return VBNL_OK;
        }
    }
    report_notes(c, a, &notes);
    if (textured) {
        uint32_t tid;
        vbnl_result r = vbnl_scene_add_texture(c->scene, &td, &tid, err);
        if (r != VBNL_OK) {
            free(ce);
            return r;
        }
        md.base_texture = tid + 1;
        ce->desc.base_texture = tid + 1;
    }
    vbnl_result r = vbnl_scene_add_material(c->scene, &md, &ce->material, err);
    if (r != VBNL_OK) {
        free(ce);
        return r;
    }
    if (s->cache_count == s->cache_cap) {
        uint32_t ncap = s->cache_cap ? 2 * s->cache_cap : 16;
        pov_material_entry **n = realloc(s->cache, sizeof(*n) * ncap);
        if (!n) {
            free(ce);
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        }
        s->cache = n;
        s->cache_cap = ncap;
    }
    s->cache[s->cache_count++] = ce;
    *material = ce->material;
    return VBNL_OK;
}

/* ---- test accessors (pov_texture.h) ---------------------------------------------------------- */

static const pov_material_entry *find_entry(const pov_ctx *c, uint32_t material)
{
    for (uint32_t i = 0; i < c->tex->cache_count; ++i)
        if (c->tex->cache[i]->material == material)
            return c->tex->cache[i];
    return NULL;
}

const vbnl_material_desc *pov_texture_material_desc(const pov_ctx *c, uint32_t material)
{
    const pov_material_entry *e = find_entry(c, material);
    return e ? &e->desc : NULL;
}

const vbnl_texture_desc *pov_texture_texture_desc(const pov_ctx *c, uint32_t material)
{
    pov_material_entry *e = (pov_material_entry *)find_entry(c, material);
    if (!e || !e->has_texture)
        return NULL;
    e->tdesc.color_map = e->tdesc.kind == VBNL_TEXTURE_IMAGE ? NULL : e->map;
    return &e->tdesc;
}

uint32_t pov_texture_material_count(const pov_ctx *c) { return c->tex->cache_count; }
