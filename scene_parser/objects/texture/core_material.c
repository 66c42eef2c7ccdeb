/* vbnl object layer, texture part: an appearance onto core materials (the table in
 * scene_parser/README.md, "Textures"). A texture tree becomes core nodes (vbnl/scene.h's texture
 * section): patterns, pigments, normals, and material nodes for textures whose BSDF varies over
 * the surface; a plain texture with an opaque solid colour and no normal stays a plain material.
 * Core materials are shared: one per distinct content, found by a byte key of the tree, its
 * interior and its transforms (pov_key_texture). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pov_texture.h"

/* A core material added by the texture part, and what made it. */
struct pov_material_entry {
    unsigned char *key;
    size_t key_len;
    uint32_t material;
    vbnl_material_desc desc; /* the plain material, or the top layer's BSDF of a node (tests) */
};

/* Warnings found while mapping an appearance: reported only when it makes a new core material,
 * so objects sharing an appearance warn once. */
typedef struct map_notes {
    const char *clamped_what;
    double clamped_value;
    double refl_sum;    /* diffuse colour + the reflection's maximum, when above 1 (0: none) */
} map_notes;

typedef struct build {
    pov_ctx *c;
    vbnl_pattern_set *set;   /* patterns and pigments go here instead of the scene (functions) */
    map_notes notes;
    vbnl_error *err;
    int radiance;            /* colours are radiances (sky_sphere): not clamped to [0, 1] */
    int uv;                  /* the appearance's textures are uv-mapped */
    const double *pre;       /* the point map of its top-level patterns (NULL: identity) */
    vbnl_material_desc top;  /* the top layer's plain material (tests) */
    int have_top;
} build;

/* ---- function patterns --------------------------------------------------------------------------- */

struct pov_fn {
    int refs;
    vbnl_sdl_function *f; /* detached */
};

pov_fn *pov_fn_retain(pov_fn *f)
{
    if (f)
        f->refs++;
    return f;
}

void pov_fn_release(pov_fn *f)
{
    if (f && --f->refs <= 0) {
        vbnl_sdl_function_free_detached(f->f);
        free(f);
    }
}

static double fn_call(void *user, const double p[3]) { return vbnl_sdl_function_eval_detached(((pov_fn *)user)->f, p, 3); }
static void fn_destroy(void *user) { pov_fn_release(user); }

/* function { body }, positioned on the keyword `function`. */
vbnl_result pov_function_pattern(pov_ctx *c, pov_pattern *pat, const vbnl_sdl_loc *loc)
{
    vbnl_sdl_parser *p = c->parser;
    vbnl_sdl_value v;
    if (vbnl_sdl_parse_rvalue(p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (v.kind != VBNL_SDL_FUNCTION) {
        vbnl_sdl_value_clear(p, &v);
        return vbnl_sdl_error(p, loc, "a function pattern needs function { ... }");
    }
    pov_fn *f = malloc(sizeof(*f));
    if (f) {
        f->refs = 1;
        f->f = vbnl_sdl_function_detach(v.u.fn);
    }
    vbnl_sdl_value_clear(p, &v);
    if (!f || !f->f) {
        free(f);
        return vbnl_sdl_error(p, loc, "out of memory");
    }
    pov_fn_release(pat->fn);
    pat->fn = f;
    return VBNL_OK;
}

/* ---- colours ------------------------------------------------------------------------------------- */

static float clamp_albedo(map_notes *n, double v, const char *what)
{
    if (v > 1.0 || v < 0.0 || !isfinite(v)) {
        if (!n->clamped_what) {
            n->clamped_what = what;
            n->clamped_value = v;
        }
        v = v > 1.0 ? 1.0 : 0.0;
    }
    return (float)v;
}

/* POV-Ray's pigment colour for the core: r g b in [0, 1] (warned) for a surface, any finite value
 * for a radiance; filter and transmit in [0, 1]. */
static void color5(const build *b, map_notes *n, const double in[5], float out[5])
{
    for (int k = 0; k < 3; ++k)
        out[k] = b->radiance ? (float)(isfinite(in[k]) ? in[k] : 0.0) : clamp_albedo(n, in[k], "pigment colour");
    for (int k = 3; k < 5; ++k)
        out[k] = (float)(in[k] < 0.0 || !isfinite(in[k]) ? 0.0 : (in[k] > 1.0 ? 1.0 : in[k]));
}

static void report_notes(pov_ctx *c, const pov_appearance *a, const map_notes *n)
{
    const vbnl_sdl_loc *loc = a && a->loc.file ? &a->loc : NULL;
    if (n->clamped_what)
        vbnl_sdl_warning(c->parser, loc, "%s %.3g exceeds the energy-conserving range [0, 1]: clamped",
                         n->clamped_what, n->clamped_value);
    if (n->refl_sum > 0.0)
        vbnl_sdl_warning(c->parser, loc,
                         "diffuse plus reflection reflect up to %.3g of the light they receive: the diffuse is "
                         "reduced at the angles where the sum would exceed 1",
                         n->refl_sum);
}

/* ---- patterns, pigments, normals ----------------------------------------------------------------- */

static void image_desc(const pov_image *im, vbnl_image_desc *d)
{
    vbnl_image_desc_init(d);
    d->width = im->width;
    d->height = im->height;
    d->channels = im->channels;
    d->texels = im->texels;
    d->indices = im->indices;
}

vbnl_result pov_image_core_id(pov_ctx *c, int i, uint32_t *out, vbnl_error *err)
{
    pov_image *im = &c->tex->images[i];
    if (!im->core_id) {
        vbnl_image_desc d;
        image_desc(im, &d);
        uint32_t id;
        vbnl_result r = vbnl_scene_add_image(c->scene, &d, &id, err);
        if (r != VBNL_OK)
            return r;
        im->core_id = id + 1;
    }
    *out = im->core_id - 1;
    return VBNL_OK;
}

static vbnl_result build_pigment(build *b, const pov_pigment *g, int top, uint32_t *out);

static vbnl_result add_pattern(build *b, const vbnl_pattern_desc *d, uint32_t *out)
{
    return b->set ? vbnl_pattern_set_add_pattern(b->set, d, out, b->err) : vbnl_scene_add_pattern(b->c->scene, d, out, b->err);
}

static vbnl_result add_pigment(build *b, const vbnl_pigment_desc *d, uint32_t *out)
{
    return b->set ? vbnl_pattern_set_add_pigment(b->set, d, out, b->err) : vbnl_scene_add_pigment(b->c->scene, d, out, b->err);
}

/* A pattern for the core: `pre` (a point map applied first, NULL for none) and the scene's noise
 * generator and number of waves where the pattern has none of its own. */
static vbnl_result build_pattern(build *b, const pov_pattern *pat, const double *pre, uint32_t *out)
{
    pov_ctx *c = b->c;
    vbnl_pattern_desc d = pat->d;
    if (pre)
        memcpy(d.transform, pre, sizeof(d.transform));
    d.warps = pat->warps;
    d.warp_count = pat->nwarps;
    if (d.noise_generator == 0)
        d.noise_generator = c->tex->noise_generator ? c->tex->noise_generator : 2;
    d.waves = c->tex->waves ? c->tex->waves : 10;
    vbnl_result r;
    if (d.kind == VBNL_PATTERN_IMAGE) {
        uint32_t id;
        vbnl_image_desc id_desc;
        image_desc(&c->tex->images[pat->image], &id_desc);
        if ((r = b->set ? vbnl_pattern_set_add_image(b->set, &id_desc, &id, b->err)
                        : pov_image_core_id(c, pat->image, &id, b->err)) != VBNL_OK)
            return r;
        d.image.image = id + 1;
    }
    if (d.kind == VBNL_PATTERN_PIGMENT) {
        uint32_t id;
        if ((r = build_pigment(b, pat->pigment, 0, &id)) != VBNL_OK)
            return r;
        d.pigment = id + 1;
    }
    if (d.kind == VBNL_PATTERN_DENSITY) {
        d.density.values = pat->density->v;
        d.density.nx = pat->density->n[0];
        d.density.ny = pat->density->n[1];
        d.density.nz = pat->density->n[2];
    }
    if (d.kind == VBNL_PATTERN_FUNCTION) {
        d.function.fn = fn_call;
        d.function.user = pov_fn_retain(pat->fn);
        d.function.destroy = fn_destroy;
    }
    if (d.kind == VBNL_PATTERN_PAVEMENT) { /* not implemented: the tiling of its cells */
        d.tiling = d.pavement.sides == 4 ? 1 : d.pavement.sides == 6 ? 2 : 3;
        d.kind = VBNL_PATTERN_TILING;
    }
    if (d.kind == VBNL_PATTERN_OBJECT) { /* not read: every point is outside */
        d.kind = VBNL_PATTERN_PLANAR;
        d.transform[0] = d.transform[5] = d.transform[10] = 1.0;
        d.transform[12] = d.transform[13] = d.transform[14] = 0.0;
        d.transform[7] = 1e9; /* y far away: planar's value 0 */
        d.warp_count = 0;
    }
    r = add_pattern(b, &d, out);
    if (r != VBNL_OK && d.kind == VBNL_PATTERN_FUNCTION)
        pov_fn_release(pat->fn);
    return r;
}

static vbnl_result build_pigment(build *b, const pov_pigment *g, int top, uint32_t *out)
{
    vbnl_pigment_desc d;
    vbnl_pigment_desc_init(&d);
    d.uv = g->uv_mapping || (top && b->uv);
    vbnl_result r;
    if (g->kind == POV_PIG_SOLID) {
        color5(b, &b->notes, g->color, d.color);
        return add_pigment(b, &d, out);
    }
    uint32_t pattern;
    if ((r = build_pattern(b, &g->pat, top ? b->pre : NULL, &pattern)) != VBNL_OK)
        return r;
    d.pattern = pattern + 1;
    if (g->kind == POV_PIG_IMAGE) {
        d.kind = VBNL_PIGMENT_IMAGE;
        return add_pigment(b, &d, out);
    }
    d.kind = g->kind == POV_PIG_AVERAGE ? VBNL_PIGMENT_AVERAGE : VBNL_PIGMENT_MAP;
    pov_map def = {POV_MAP_COLOR, 0, NULL};
    const pov_map *m = &g->map;
    if (m->count == 0) {
        pov_default_color_map(&g->pat, &def);
        m = &def;
    }
    vbnl_pigment_map_entry *e = calloc(m->count ? m->count : 1, sizeof(*e));
    if (!e) {
        pov_map_free(&def);
        return vbnl_error_set(b->err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    }
    r = VBNL_OK;
    for (uint32_t i = 0; i < m->count && r == VBNL_OK; ++i) {
        e[i].value = (float)m->e[i].value;
        if (m->kind == POV_MAP_PIGMENT && m->e[i].sub) {
            uint32_t id;
            if ((r = build_pigment(b, m->e[i].sub, 0, &id)) == VBNL_OK)
                e[i].pigment = id + 1;
        } else {
            color5(b, &b->notes, m->e[i].color, e[i].color);
        }
    }
    if (r == VBNL_OK) {
        d.map = e;
        d.map_count = m->count;
        r = add_pigment(b, &d, out);
    }
    free(e);
    pov_map_free(&def);
    return r;
}

static vbnl_result build_normal(build *b, const pov_normal *n, int top, uint32_t *out)
{
    pov_ctx *c = b->c;
    vbnl_normal_desc d;
    vbnl_normal_desc_init(&d);
    d.amount = (float)n->amount;
    d.accuracy = (float)n->accuracy;
    d.no_bump_scale = n->no_bump_scale;
    d.uv = n->uv_mapping || (top && b->uv);
    vbnl_result r;
    if (n->kind != POV_NRM_AVERAGE || n->pat.nwarps || (top && b->pre)) {
        uint32_t pattern;
        if ((r = build_pattern(b, &n->pat, top ? b->pre : NULL, &pattern)) != VBNL_OK)
            return r;
        d.pattern = pattern + 1;
    }
    d.kind = n->kind == POV_NRM_MAP ? VBNL_NORMAL_MAP
             : n->kind == POV_NRM_AVERAGE ? VBNL_NORMAL_AVERAGE
             : n->kind == POV_NRM_IMAGE   ? VBNL_NORMAL_IMAGE
                                          : VBNL_NORMAL_PATTERN;
    vbnl_slope_map_entry *sl = NULL;
    vbnl_normal_map_entry *nm = NULL;
    if (n->slopes.count) {
        if (!(sl = calloc(n->slopes.count, sizeof(*sl))))
            return vbnl_error_set(b->err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        for (uint32_t i = 0; i < n->slopes.count; ++i)
            sl[i] = (vbnl_slope_map_entry){(float)n->slopes.e[i].value, (float)n->slopes.e[i].slope[0],
                                           (float)n->slopes.e[i].slope[1]};
        d.slope_map = sl;
        d.slope_map_count = n->slopes.count;
    }
    r = VBNL_OK;
    if (d.kind == VBNL_NORMAL_MAP || d.kind == VBNL_NORMAL_AVERAGE) {
        if (!(nm = calloc(n->map.count ? n->map.count : 1, sizeof(*nm)))) {
            free(sl);
            return vbnl_error_set(b->err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        }
        for (uint32_t i = 0; i < n->map.count && r == VBNL_OK; ++i) {
            nm[i].value = (float)n->map.e[i].value;
            if (n->map.e[i].sub) {
                r = build_normal(b, n->map.e[i].sub, 0, &nm[i].normal);
            } else {
                /* an entry without a normal: a flat one (bumps of amount 0) */
                pov_normal *flat = pov_normal_new();
                if (!flat) {
                    r = vbnl_error_set(b->err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
                    break;
                }
                flat->pat.d.kind = VBNL_PATTERN_BUMPS;
                flat->pat.name = "bumps";
                flat->amount = 0.0;
                r = build_normal(b, flat, 0, &nm[i].normal);
                pov_normal_free(flat);
            }
        }
        d.map = nm;
        d.map_count = n->map.count;
    }
    if (r == VBNL_OK)
        r = vbnl_scene_add_normal(c->scene, &d, out, b->err);
    free(sl);
    free(nm);
    return r;
}

/* ---- finishes ------------------------------------------------------------------------------------ */

/* Blinn-Phong exponent n to GGX alpha (Walter et al. 2007): alpha = sqrt(2 / (n + 2)). */
static float alpha_from_exponent(double n)
{
    double a = sqrt(2.0 / (n + 2.0));
    return (float)(a < 0.001 ? 0.001 : (a > 1.0 ? 1.0 : a));
}

/* A finish's variable reflection as a core coat curve: min + (max - min) (1 - cos)^falloff, or with
 * `fresnel` the interior's Fresnel reflectance between min and max (one colour: between 0 and it,
 * as POV-Ray reads it). */
static void reflection_curve(build *b, const pov_finish *f, vbnl_material_desc *md)
{
    const double zero[3] = {0, 0, 0};
    const int one_colour = !memcmp(f->reflection, f->reflection_min, sizeof(f->reflection));
    const double *lo = f->fresnel && one_colour ? zero : f->reflection_min;
    md->coat_curve = f->fresnel ? VBNL_COAT_FRESNEL : VBNL_COAT_SCHLICK;
    for (int k = 0; k < 3; ++k) {
        md->coat_min[k] = clamp_albedo(&b->notes, lo[k], "reflection");
        md->coat_max[k] = clamp_albedo(&b->notes, f->reflection[k], "reflection");
    }
    md->coat_falloff = (float)f->falloff;
}

/* The plain core material of a plain layer's finish (the finish table), with its base colour
 * scaled by `pc` (the pigment's colour, or 1 where the pigment colours it per point). *tinted is
 * 0 when the pigment does not colour this material (a mirror takes its reflection colour). */
static void finish_material(build *b, const pov_texture *t, const pov_interior *in, const double pc[3],
                            vbnl_material_desc *md, int *tinted)
{
    const pov_finish *f = &t->fin;
    vbnl_material_desc_init(md);
    *tinted = 1;
    double scale[3] = {1, 1, 1};
    if (t->ext.set) {
        *md = t->ext.desc;
        if (t->ext.has_color) {
            *tinted = 0; /* an explicit colour replaces the pigment */
            return;
        }
        for (int k = 0; k < 3; ++k)
            md->base_color[k] = clamp_albedo(&b->notes, pc[k], "albedo");
        return;
    }
    md->interior = in->medium; /* what a ray that enters travels in (its media) */
    double refl = 0.0;
    for (int k = 0; k < 3; ++k)
        refl = fmax(refl, fmax(f->reflection[k], f->reflection_min[k]));
    const int highlight = f->specular > 0.0 || f->phong > 0.0;
    const float rough = f->specular > 0.0 ? alpha_from_exponent(1.0 / f->roughness)
                        : f->phong > 0.0  ? alpha_from_exponent(4.0 * f->phong_size)
                                          : 0.001f;
    const int variable = memcmp(f->reflection, f->reflection_min, sizeof(f->reflection)) != 0 || f->fresnel ||
                         f->reflect_metallic > 0.0;
    if (f->metallic && (refl > 0.0 || highlight)) {
        md->type = VBNL_MATERIAL_CONDUCTOR;
        md->alpha = rough;
    } else if (refl > 0.0 && f->diffuse <= 0.0 && !highlight && !variable) {
        md->type = VBNL_MATERIAL_MIRROR;
        memcpy(scale, f->reflection, sizeof(scale));
        *tinted = 0;
    } else if (refl > 0.0) {
        /* POV-Ray's variable reflection (reference "Reflection"): a coat whose reflectance follows
         * min + (max - min) (1 - cos)^falloff, or the interior's Fresnel reflectance between min and
         * max, over the diffuse base it adds to (smooth, or GGX with the highlight's roughness) */
        md->type = VBNL_MATERIAL_PLASTIC;
        md->alpha = rough;
        md->ior = (float)(in->ior > 1.0 ? in->ior : 1.5);
        reflection_curve(b, f, md);
        md->coat_metallic = (float)f->reflect_metallic;
        md->base_scale = clamp_albedo(&b->notes, f->diffuse, "diffuse");
        /* POV-Ray adds diffuse and reflection; the core's base gives way at the angles where
         * the sum would exceed 1 (vbnl/scene.h), noted here for the pigment's average colour */
        double avg[5], sum = 0.0;
        pov_pigment_average(t->pig, b->c->tex, avg);
        for (int k = 0; k < 3; ++k)
            sum = fmax(sum, md->base_scale * fmin(fmax(avg[k], 0.0), 1.0) + fmax(md->coat_min[k], md->coat_max[k]));
        if (sum > 1.0 + 1e-6 && b->notes.refl_sum == 0.0)
            b->notes.refl_sum = sum;
    } else if (highlight) {
        md->type = VBNL_MATERIAL_PLASTIC;
        md->alpha = rough;
        md->ior = (float)(in->ior > 1.0 ? in->ior : 1.5);
        scale[0] = scale[1] = scale[2] = f->diffuse;
    } else {
        /* brilliance b > 1: POV-Ray's cos^b falloff as a reciprocal BSDF (VBNL_MATERIAL_BRILLIANCE) */
        md->type = f->brilliance > 1.0 ? VBNL_MATERIAL_BRILLIANCE : VBNL_MATERIAL_LAMBERT;
        md->brilliance = (float)f->brilliance;
        scale[0] = scale[1] = scale[2] = f->diffuse;
    }
    for (int k = 0; k < 3; ++k)
        md->base_color[k] = clamp_albedo(&b->notes, scale[k] * (*tinted ? pc[k] : 1.0), "albedo");
}

/* True when a finish has a reflection (other than a finish-level metallic's conductor). */
static int finish_reflects(const pov_finish *f)
{
    if (f->metallic)
        return 0;
    for (int k = 0; k < 3; ++k)
        if (f->reflection[k] > 0.0 || f->reflection_min[k] > 0.0)
            return 1;
    return 0;
}

/* The reflection of a finish on the light a transparent pigment lets through: POV-Ray reflects
 * F(theta) there too and, with conserve_energy, lets 1 - F through (reference "Conserve Energy
 * for Reflection"); the core's dielectric with a coat curve does that always, so that nothing
 * leaves the surface brighter than it came (without conserve_energy POV-Ray passes all the light
 * and adds the reflection). Its `metallic` tint is not applied here: the glass has no pigment
 * colour of its own. */
static void glass_reflection(build *b, const pov_finish *f, vbnl_material_desc *glass)
{
    if (finish_reflects(f))
        reflection_curve(b, f, glass);
}

/* The emitted radiance of a plain layer: POV-Ray's emission times the pigment's colour and
 * opacity (a patterned pigment's average: the core's emission is constant per material). */
static void layer_emission(build *b, const pov_texture *t, float out[3])
{
    double col[5];
    if (t->ext.set) {
        memcpy(out, t->ext.desc.emission, 3 * sizeof(float));
        return;
    }
    pov_pigment_average(t->pig, b->c->tex, col);
    double opacity = 1.0 - col[3] - col[4];
    opacity = opacity < 0.0 ? 0.0 : (opacity > 1.0 ? 1.0 : opacity);
    for (int k = 0; k < 3; ++k) {
        double e = t->fin.emission[k] * (col[k] > 0.0 ? col[k] : 0.0) * opacity;
        out[k] = isfinite(e) && e > 0.0 ? (float)e : 0.0f;
    }
}

/* ---- textures ------------------------------------------------------------------------------------ */

static vbnl_result build_stack(build *b, const pov_texture *t, const pov_interior *in, int top, uint32_t *out,
                               float emission[3]);

/* A plain layer: a plain material when its pigment is an opaque colour and it has no normal, else
 * a TEXTURED node. */
static vbnl_result build_plain(build *b, const pov_texture *t, const pov_interior *in, int top, uint32_t *out,
                               float emission[3])
{
    pov_ctx *c = b->c;
    const pov_pigment *g = t->pig;
    const int solid = g->kind == POV_PIG_SOLID;
    const double white[3] = {1, 1, 1};
    int tinted;
    vbnl_material_desc md;
    finish_material(b, t, in, solid ? g->color : white, &md, &tinted);
    layer_emission(b, t, emission);
    const int transparent = solid ? g->color[3] + g->color[4] > 0.0 : 1;
    memcpy(md.emission, emission, sizeof(md.emission));
    md.two_sided = t->ext.set ? md.two_sided : 1; /* POV-Ray's emission glows on both sides */
    if (!b->have_top) {
        b->top = md;
        b->have_top = 1;
    }
    vbnl_result r;
    if (solid && !t->nrm && !transparent)
        return vbnl_scene_add_material(c->scene, &md, out, b->err);
    /* the leaf: the finish alone, the pigment colouring it per point */
    vbnl_material_desc leaf_desc;
    finish_material(b, t, in, white, &leaf_desc, &tinted);
    uint32_t leaf;
    if ((r = vbnl_scene_add_material(c->scene, &leaf_desc, &leaf, b->err)) != VBNL_OK)
        return r;
    vbnl_material_node_desc nd;
    vbnl_material_node_desc_init(&nd);
    nd.kind = VBNL_NODE_TEXTURED;
    nd.material = leaf;
    memcpy(nd.emission, emission, sizeof(nd.emission));
    nd.two_sided = 1;
    uint32_t pg;
    if (tinted) {
        if ((r = build_pigment(b, g, top, &pg)) != VBNL_OK)
            return r;
    } else {
        /* a mirror or an explicit colour: the pigment only says how much passes (white, its f t) */
        pov_pigment clear = *g;
        if (solid) {
            clear.color[0] = clear.color[1] = clear.color[2] = 1.0;
        }
        if ((r = build_pigment(b, solid ? &clear : g, top, &pg)) != VBNL_OK)
            return r;
    }
    nd.pigment = pg + 1;
    if (t->nrm) {
        uint32_t n;
        if ((r = build_normal(b, t->nrm, top, &n)) != VBNL_OK)
            return r;
        nd.normal = n + 1;
    }
    if (in->ior > 1.0 || in->medium || finish_reflects(&t->fin)) {
        /* the light the pigment lets through refracts into the interior (or enters its media
         * unrefracted: ior 1) */
        vbnl_material_desc glass;
        vbnl_material_desc_init(&glass);
        glass.type = VBNL_MATERIAL_DIELECTRIC;
        glass.ior = (float)(in->ior > 1.0 ? in->ior : 1.0);
        glass_reflection(b, &t->fin, &glass);
        glass.interior = in->medium;
        glass.base_color[0] = glass.base_color[1] = glass.base_color[2] = 1.0f;
        uint32_t gid;
        if ((r = vbnl_scene_add_material(c->scene, &glass, &gid, b->err)) != VBNL_OK)
            return r;
        nd.transmission = gid + 1;
    }
    return vbnl_scene_add_material_node(c->scene, &nd, out, b->err);
}

/* A patterned texture (texture_map, a list, tiles, material_map, average). */
static vbnl_result build_patterned(build *b, const pov_texture *t, const pov_interior *in, int top, uint32_t *out,
                                   float emission[3])
{
    pov_ctx *c = b->c;
    vbnl_material_node_desc nd;
    vbnl_material_node_desc_init(&nd);
    nd.kind = t->kind == POV_TEX_AVERAGE ? VBNL_NODE_AVERAGE : VBNL_NODE_MAP;
    nd.uv = t->uv_mapping || (top && b->uv);
    vbnl_result r;
    if (t->kind != POV_TEX_AVERAGE || t->pat.nwarps || (top && b->pre)) {
        uint32_t pattern;
        if ((r = build_pattern(b, &t->pat, top ? b->pre : NULL, &pattern)) != VBNL_OK)
            return r;
        nd.pattern = pattern + 1;
    }
    const uint32_t n = t->map.count;
    vbnl_material_map_entry *e = calloc(n ? n : 1, sizeof(*e));
    if (!e)
        return vbnl_error_set(b->err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    double acc[3] = {0, 0, 0};
    r = VBNL_OK;
    for (uint32_t i = 0; i < n && r == VBNL_OK; ++i) {
        e[i].value = (float)t->map.e[i].value;
        float em[3] = {0, 0, 0};
        const pov_texture *sub = t->map.e[i].sub ? t->map.e[i].sub : c->tex->deflt.tex;
        r = build_stack(b, sub, in, 0, &e[i].material, em);
        for (int k = 0; k < 3; ++k)
            acc[k] += em[k] / n;
    }
    for (int k = 0; k < 3; ++k)
        emission[k] = (float)acc[k];
    if (r == VBNL_OK) {
        nd.map = e;
        nd.map_count = n;
        memcpy(nd.emission, emission, sizeof(nd.emission));
        nd.two_sided = 1;
        r = vbnl_scene_add_material_node(c->scene, &nd, out, b->err);
    }
    free(e);
    return r;
}

/* A stack of layers (top first): one material, or a LAYERS node. */
static vbnl_result build_stack(build *b, const pov_texture *t, const pov_interior *in, int top, uint32_t *out,
                               float emission[3])
{
    if (!t->below)
        return t->kind == POV_TEX_PLAIN ? build_plain(b, t, in, top, out, emission)
                                        : build_patterned(b, t, in, top, out, emission);
    uint32_t count = 0, *ids;
    for (const pov_texture *l = t; l; l = l->below)
        count++;
    if (count > VBNL_TEXTURE_MAP_MAX)
        return vbnl_error_set(b->err, VBNL_ERR_INVALID_ARGUMENT, "more than %u texture layers", VBNL_TEXTURE_MAP_MAX);
    if (!(ids = malloc(sizeof(*ids) * count)))
        return vbnl_error_set(b->err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    vbnl_result r = VBNL_OK;
    uint32_t i = 0;
    float top_emission[3] = {0, 0, 0};
    for (const pov_texture *l = t; l && r == VBNL_OK; l = l->below, ++i) {
        float em[3];
        /* a layer is its own texture: build it without the layers below it */
        pov_texture one = *l;
        one.below = NULL;
        r = one.kind == POV_TEX_PLAIN ? build_plain(b, &one, in, top, &ids[i], em)
                                      : build_patterned(b, &one, in, top, &ids[i], em);
        if (i == 0)
            memcpy(top_emission, em, sizeof(em));
    }
    if (r == VBNL_OK) {
        vbnl_material_node_desc nd;
        vbnl_material_node_desc_init(&nd);
        nd.kind = VBNL_NODE_LAYERS;
        nd.layers = ids;
        nd.layer_count = count;
        memcpy(nd.emission, top_emission, sizeof(nd.emission));
        nd.two_sided = 1;
        memcpy(emission, top_emission, 3 * sizeof(float));
        r = vbnl_scene_add_material_node(b->c->scene, &nd, out, b->err);
    }
    free(ids);
    return r;
}

/* 1 when any texture of the stack (at its top level) asks for uv_mapping. */
static int uv_mapped(const pov_texture *t)
{
    for (; t; t = t->below)
        if (t->uv_mapping)
            return 1;
    return 0;
}

/* The core medium of an interior (id + 1 in *out; 0 when it has neither media nor fade): its
 * media, their densities as core pigments seen through the object's transforms given after the
 * interior (POV-Ray evaluates densities in the object's space), and its fade as one more
 * absorbing part. */
static vbnl_result interior_medium(pov_ctx *c, const pov_interior *in, const double world_from_pov[16],
                                   uint32_t *out, vbnl_error *err)
{
    *out = 0;
    float fade[3];
    const int fades = pov_interior_fade(in, fade);
    if (!in->nmedia && !fades)
        return VBNL_OK;
    vbnl_medium_part_desc parts[VBNL_MEDIUM_PARTS_MAX + 1];
    uint32_t ids[VBNL_MEDIUM_PARTS_MAX][VBNL_MEDIUM_DENSITY_MAX];
    memcpy(parts, in->media, sizeof(parts[0]) * in->nmedia);
    uint32_t n = in->nmedia;
    build b;
    memset(&b, 0, sizeof(b));
    b.c = c;
    b.err = err;
    b.radiance = 1; /* densities are not albedos: not clamped to [0, 1] */
    vbnl_result r;
    for (uint32_t i = 0; i < n; ++i) {
        double world_from_media[16], pre[16];
        pov_m4_mul(world_from_pov, in->xf[i], world_from_media);
        if (!pov_m4_invert(world_from_media, pre))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "an interior transform is singular");
        b.pre = pre;
        parts[i].density = ids[i];
        parts[i].density_count = 0;
        for (uint32_t k = 0; k < VBNL_MEDIUM_DENSITY_MAX && in->density[i][k]; ++k) {
            if ((r = build_pigment(&b, pov_density_at(c, in->density[i][k] - 1), 1, &ids[i][k])) != VBNL_OK)
                return r;
            parts[i].density_count++;
        }
    }
    if (fades) {
        if (n == VBNL_MEDIUM_PARTS_MAX)
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "an interior with fade holds at most %u media",
                                  VBNL_MEDIUM_PARTS_MAX - 1);
        memset(&parts[n], 0, sizeof(parts[n]));
        memcpy(parts[n].absorption, fade, sizeof(fade));
        parts[n].phase = VBNL_PHASE_ISOTROPIC;
        n++;
    }
    vbnl_medium_desc md;
    vbnl_medium_desc_init(&md);
    md.parts = parts;
    md.part_count = n;
    uint32_t id;
    if ((r = vbnl_scene_add_medium(c->scene, &md, &id, err)) != VBNL_OK)
        return r;
    *out = id + 1;
    return VBNL_OK;
}

vbnl_result pov_appearance_material(pov_ctx *c, const pov_appearance *a, const double world_from_pov[16],
                                    uint32_t *material, vbnl_error *err)
{
    pov_texture_state *s = c->tex;
    const pov_texture *tex = a && a->tex ? a->tex : s->deflt.tex;
    const pov_interior *in = a ? &a->interior : &s->deflt.interior;
    const double *xf = a ? a->xf : s->deflt.xf;
    /* the point map of the top-level patterns: core world -> POV world -> the object's pattern space */
    double world_from_pattern[16], pre[16];
    pov_m4_mul(world_from_pov, xf, world_from_pattern);
    if (!pov_m4_invert(world_from_pattern, pre))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "an appearance transform is singular");
    int identity = 1;
    for (int i = 0; i < 16; ++i)
        identity &= pre[i] == ((i % 5) == 0 ? 1.0 : 0.0);

    pov_key key = {NULL, 0, 0, 0};
    pov_key_texture(&key, tex);
    pov_key_bytes(&key, in, sizeof(*in));
    pov_key_bytes(&key, pre, sizeof(pre));
    if (in->nmedia) /* with in->xf: where its media are */
        pov_key_bytes(&key, world_from_pov, 16 * sizeof(double));
    pov_key_bytes(&key, &s->noise_generator, sizeof(s->noise_generator));
    pov_key_bytes(&key, &s->waves, sizeof(s->waves));
    if (key.failed) {
        free(key.b);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    }
    for (uint32_t i = 0; i < s->cache_count; ++i) {
        if (s->cache[i]->key_len == key.n && !memcmp(s->cache[i]->key, key.b, key.n)) {
            *material = s->cache[i]->material;
            free(key.b);
            return VBNL_OK;
        }
    }
    build b;
    memset(&b, 0, sizeof(b));
    b.c = c;
    b.err = err;
    b.uv = uv_mapped(tex);
    b.pre = identity ? NULL : pre;
    float emission[3];
    pov_interior inside = *in; /* with its core medium */
    vbnl_result r = interior_medium(c, in, world_from_pov, &inside.medium, err);
    if (r == VBNL_OK)
        r = build_stack(&b, tex, &inside, 1, material, emission);
    if (r != VBNL_OK) {
        free(key.b);
        return r;
    }
    report_notes(c, a, &b.notes);
    if (s->cache_count == s->cache_cap) {
        uint32_t cap = s->cache_cap ? 2 * s->cache_cap : 16;
        pov_material_entry **grown = realloc(s->cache, sizeof(*grown) * cap);
        if (!grown) {
            free(key.b);
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        }
        s->cache = grown;
        s->cache_cap = cap;
    }
    pov_material_entry *ce = calloc(1, sizeof(*ce));
    if (!ce) {
        free(key.b);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    }
    ce->key = key.b;
    ce->key_len = key.n;
    ce->material = *material;
    ce->desc = b.top;
    s->cache[s->cache_count++] = ce;
    return VBNL_OK;
}

void pov_material_cache_free(pov_ctx *c)
{
    for (uint32_t i = 0; i < c->tex->cache_count; ++i) {
        free(c->tex->cache[i]->key);
        free(c->tex->cache[i]);
    }
    free(c->tex->cache);
    c->tex->cache = NULL;
    c->tex->cache_count = c->tex->cache_cap = 0;
}

/* ---- pattern and pigment functions --------------------------------------------------------------- */

/* The evaluator of a function { pattern { } } or function { pigment { } }: its own pattern set. */
typedef struct fn_block {
    int refs;
    vbnl_pattern_set *set;
    uint32_t id;
    int pigment;
} fn_block;

static void fn_block_eval(void *user, const double p[3], double out[5])
{
    const fn_block *f = user;
    if (f->pigment) {
        float c[5];
        vbnl_pattern_set_color(f->set, f->id, p, c);
        for (int k = 0; k < 5; ++k)
            out[k] = c[k];
        return;
    }
    out[0] = vbnl_pattern_set_value(f->set, f->id, p);
}

static void fn_block_retain(void *user) { ((fn_block *)user)->refs++; }

static void fn_block_release(void *user)
{
    fn_block *f = user;
    if (--f->refs > 0)
        return;
    vbnl_pattern_set_destroy(f->set);
    free(f);
}

vbnl_result pov_function_block_build(pov_ctx *c, const pov_pigment *g, int pigment, vbnl_sdl_fn_block *out,
                                     vbnl_error *err)
{
    fn_block *f = calloc(1, sizeof(*f));
    if (!f)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    f->refs = 1;
    f->pigment = pigment;
    vbnl_result r = vbnl_pattern_set_create(&f->set, err);
    if (r != VBNL_OK) {
        free(f);
        return r;
    }
    build b;
    memset(&b, 0, sizeof(b));
    b.c = c;
    b.set = f->set;
    b.err = err;
    r = pigment ? build_pigment(&b, g, 0, &f->id) : build_pattern(&b, &g->pat, NULL, &f->id);
    if (r != VBNL_OK) {
        fn_block_release(f);
        return r;
    }
    out->user = f;
    out->dims = pigment ? 5 : 1;
    out->eval = fn_block_eval;
    out->retain = fn_block_retain;
    out->release = fn_block_release;
    return VBNL_OK;
}

/* ---- sky_sphere pigments ------------------------------------------------------------------------ */

vbnl_result pov_pigment_core(pov_ctx *c, const pov_pigment *g, uint32_t *out, vbnl_error *err)
{
    build b;
    memset(&b, 0, sizeof(b));
    b.c = c;
    b.err = err;
    b.radiance = 1;
    return build_pigment(&b, g, 0, out);
}

/* ---- test accessors (pov_texture.h) ---------------------------------------------------------- */

const vbnl_material_desc *pov_texture_material_desc(const pov_ctx *c, uint32_t material)
{
    for (uint32_t i = 0; i < c->tex->cache_count; ++i)
        if (c->tex->cache[i]->material == material)
            return &c->tex->cache[i]->desc;
    return NULL;
}

uint32_t pov_texture_material_count(const pov_ctx *c) { return c->tex->cache_count; }
