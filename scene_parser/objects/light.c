/* vbnl object layer: light_source, and its mapping onto the core's lights (README: "Scene
 * files", the light mapping). */
#include <stdio.h>
#include <string.h>

#include "pov_loader.h"
#include "pov_shape.h"
#include "sdl_internal.h"

/* ---- light_source { } -------------------------------------------------------------------------- */

#define LIGHT_FIELD(f) offsetof(pov_prim, light.f)

static void light_transform(const pov_item *it, const double m[16])
{
    pov_prim *pr = it->target;
    pov_m4_mul(m, pr->m, pr->m);
}

static vbnl_result set_type(const pov_item *it)
{
    pov_light *l = &((pov_prim *)it->target)->light;
    vbnl_sdl_next(it->p);
    l->type = (int)it->arg;
    if (strcmp(it->kw, "cylinder") == 0) {
        l->cylinder = 1;
        vbnl_sdl_warning(it->p, &it->loc, "cylinder light_source is rendered as a spotlight with the same angles");
    }
    return VBNL_OK;
}

static vbnl_result area_light(const pov_item *it)
{
    pov_loader *L = it->ctx;
    pov_light *l = &((pov_prim *)it->target)->light;
    double n1, n2;
    vbnl_sdl_next(it->p);
    if (pov_vec3(L, l->axis1) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_comma(L);
    if (pov_vec3(L, l->axis2) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_comma(L);
    if (pov_float(L, &n1) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_comma(L);
    l->area = 1;
    return pov_float(L, &n2);
}

/* media_interaction [bool]: off, participating media do not scatter the light (the core's
 * vbnl_scene_set_light_media_interaction). media_attenuation is accepted and changes nothing:
 * media always attenuate light on its way (docs/scene-language.md, "Lights"). */
static vbnl_result media_interaction(const pov_item *it)
{
    pov_light *l = &((pov_prim *)it->target)->light;
    double v;
    vbnl_sdl_next(it->p);
    if (pov_opt_bool(it->p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    l->no_media = v == 0.0;
    return VBNL_OK;
}

/* POV-Ray's shadowless: the light's direct light reaches every point it faces (no shadow rays);
 * an area light keeps its shadows (it is an emitting surface in the core). */
static vbnl_result shadowless(const pov_item *it)
{
    pov_light *l = &((pov_prim *)it->target)->light;
    vbnl_sdl_next(it->p);
    l->shadowless = 1;
    return VBNL_OK;
}

static vbnl_result looks_like(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    if (strcmp(it->kw, "looks_like") == 0)
        vbnl_sdl_warning(it->p, &it->loc, "looks_like: the object is not rendered (it would enclose the point light and block it)");
    else
        vbnl_sdl_warning(it->p, &it->loc, "projected_through is ignored");
    return vbnl_sdl_skip_block(it->p);
}

static vbnl_result light_color(const pov_item *it) /* the keyword is part of the colour */
{
    double col[5];
    vbnl_result r = vbnl_sdl_parse_color(it->p, col);
    pov_set3(((pov_prim *)it->target)->light.color, col[0], col[1], col[2]);
    return r;
}

static const pov_row light_rows[] = {
    {"spotlight", set_type, POV_LIGHT_SPOT},
    {"cylinder", set_type, POV_LIGHT_SPOT},
    {"parallel", set_type, POV_LIGHT_PARALLEL},
    {"point_at", pov_item_vec3, LIGHT_FIELD(point_at)},
    {"radius", pov_item_float, LIGHT_FIELD(radius)},
    {"falloff", pov_item_float, LIGHT_FIELD(falloff)},
    {"tightness", pov_item_float, LIGHT_FIELD(tightness)},
    {"fade_distance", pov_item_float, LIGHT_FIELD(fade_distance)},
    {"fade_power", pov_item_float, LIGHT_FIELD(fade_power)},
    {"area_light", area_light, 0},
    {"adaptive", pov_item_any_float, 0},
    {"area_illumination", pov_item_any_bool, 0},
    {"media_interaction", media_interaction, 0},
    {"media_attenuation", pov_item_any_bool, 0},
    {"jitter", pov_item_any_bool, 0},
    {"circular", pov_item_any_bool, 0},
    {"orient", pov_item_any_bool, 0},
    {"shadowless", shadowless, 0},
    {"looks_like", looks_like, 0},
    {"projected_through", looks_like, 0},
    {"photons", pov_item_skip, 0},
    {"color", light_color, 0},
    {"colour", light_color, 0},
    {"rgb", light_color, 0},
    {NULL, NULL, 0},
};

static const pov_row *const light_tables[] = {pov_transform_rows, light_rows, NULL};
static const pov_block light_block = {.name = "light_source",
                                      .tables = light_tables,
                                      .transform = light_transform};

/* light_source { ID | <location>, colour  items } (after the '{'): a light primitive. */
vbnl_result pov_shape_light(const pov_shape *s)
{
    pov_loader *L = s->L;
    vbnl_sdl_parser *p = L->c.parser;
    pov_prim *pr = pov_obj_add(s->o, POV_PRIM_LIGHT, s->loc);
    if (!pr)
        return pov_oom(L);
    pov_light *l = &pr->light;
    const pov_obj *d = pov_declared(L, vbnl_sdl_peek(p), &pov_object_type);
    if (d && d->n == 1 && d->v[0].kind == POV_PRIM_LIGHT) {
        vbnl_sdl_next(p);
        *pr = d->v[0];
    } else {
        double col[5];
        if (pov_vec3(L, l->pos) != VBNL_OK)
            return VBNL_ERR_PARSE;
        pov_comma(L);
        if (vbnl_sdl_parse_color(p, col) != VBNL_OK)
            return VBNL_ERR_PARSE;
        pov_set3(l->color, col[0], col[1], col[2]);
        pov_set3(l->point_at, 0, 0, 1);
        l->radius = 30;
        l->falloff = 45;
        l->tightness = 0;
        l->fade_power = 0;
        l->fade_distance = 0;
    }
    if (pov_block_parse(&light_block, p, L, pr, NULL) != VBNL_OK)
        return VBNL_ERR_PARSE;
    double ax[3] = {l->point_at[0] - l->pos[0], l->point_at[1] - l->pos[1], l->point_at[2] - l->pos[2]};
    if (l->type != POV_LIGHT_POINT && !(pov_len3(ax) > 0))
        return vbnl_sdl_error(p, &s->loc, "light_source: %s point_at equals the location",
                              l->type == POV_LIGHT_SPOT ? "spotlight" : "parallel");
    return VBNL_OK;
}

/* ---- onto the core --------------------------------------------------------------------------- */

/* The flags of a point, spot or parallel light the core added as `id`. */
static vbnl_result light_flags(pov_loader *L, const pov_light *l, uint32_t id, vbnl_error *err)
{
    vbnl_result r = l->shadowless ? vbnl_scene_set_light_shadowless(L->c.scene, id, 1, err) : VBNL_OK;
    if (r == VBNL_OK && l->no_media)
        r = vbnl_scene_set_light_media_interaction(L->c.scene, id, 0, err);
    return r;
}

vbnl_result pov_light_emit(pov_loader *L, const pov_prim *pr, vbnl_error *err)
{
    const pov_light *l = &pr->light;
    double pos[3], at[3], a1[3], a2[3];
    pov_m4_point(pr->m, l->pos, pos);
    pov_m4_point(pr->m, l->point_at, at);
    pov_m4_dir(pr->m, l->axis1, a1);
    pov_m4_dir(pr->m, l->axis2, a2);
    /* POV-Ray's light of colour c lights a surface of `diffuse d` and pigment p facing it at
     * distance d' with the colour d p c a(d') cos(theta), a = 1 unfaded and a = 2 / (1 + (d' /
     * fade_distance)^fade_power) faded (reference "Light Fading", "Diffuse Reflection Items"): no
     * 1/pi, so in the core, whose Lambertian of albedo d p reflects the radiance d p E / pi, the
     * light's irradiance is pi c a(d') cos(theta). The core's lights fall off physically, as 1/d^2:
     * the radiant intensity I = pi c a(D) D^2 (W/sr) gives POV-Ray's brightness at D, the distance
     * from the light to the centre of the scene's geometry (at least 1; the fade distance when the
     * scene has no finite geometry); a parallel light's irradiance is pi c. */
    const int faded = l->fade_distance > 0 && l->fade_power > 0;
    double D = faded ? l->fade_distance : 1;
    if (L->have_geo) {
        double d[3] = {pos[0] - L->geo_centre[0], pos[1] - L->geo_centre[1], pos[2] - L->geo_centre[2]};
        D = fmax(1.0, pov_len3(d));
    }
    double s = POV_PI * D * D * (faded ? 2.0 / (1.0 + pow(D / l->fade_distance, l->fade_power)) : 1.0);
    float I[3];
    for (int i = 0; i < 3; ++i)
        I[i] = (float)(fmax(l->color[i], 0) * s);
    double dir[3] = {at[0] - pos[0], at[1] - pos[1], at[2] - pos[2]};
    if (l->type == POV_LIGHT_PARALLEL) {
        if (!(pov_len3(dir) > 0))
            return vbnl_error_set(err, VBNL_ERR_PARSE, "%s:%d:%d: parallel light: point_at equals the location",
                                  pr->loc.file, pr->loc.line, pr->loc.col);
        float d[3] = {(float)dir[0], (float)dir[1], (float)dir[2]};
        float E[3] = {(float)(POV_PI * fmax(l->color[0], 0)), (float)(POV_PI * fmax(l->color[1], 0)),
                      (float)(POV_PI * fmax(l->color[2], 0))};
        uint32_t id;
        vbnl_result r = vbnl_scene_add_directional_light(L->c.scene, d, E, &id, err);
        return r == VBNL_OK ? light_flags(L, l, id, err) : r;
    }
    float P[3] = {(float)pos[0], (float)pos[1], (float)pos[2]};
    if (l->type == POV_LIGHT_SPOT) {
        if (!(pov_len3(dir) > 0))
            return vbnl_error_set(err, VBNL_ERR_PARSE, "%s:%d:%d: spotlight: point_at equals the location",
                                  pr->loc.file, pr->loc.line, pr->loc.col);
        vbnl_spot_light_desc sd;
        vbnl_spot_light_desc_init(&sd);
        memcpy(sd.position, P, sizeof P);
        for (int i = 0; i < 3; ++i)
            sd.direction[i] = (float)dir[i];
        memcpy(sd.intensity, I, sizeof I);
        double rad = fmin(fmax(l->radius, 0), 180), fall = fmin(fmax(l->falloff, rad), 180);
        sd.cos_inner = (float)cos(rad * POV_PI / 180);
        sd.cos_outer = (float)cos(fall * POV_PI / 180);
        sd.exponent = (float)fmax(l->tightness, 0);
        uint32_t id;
        vbnl_result r = vbnl_scene_add_spot_light(L->c.scene, &sd, &id, err);
        return r == VBNL_OK ? light_flags(L, l, id, err) : r;
    }
    double n[3];
    pov_cross3(a1, a2, n);
    double area = pov_len3(n);
    if (l->area && area > 0) {
        /* Two-sided Lambertian rectangle with the point light's power 4 pi I = 2 pi A L. */
        vbnl_area_light_desc ad;
        vbnl_area_light_desc_init(&ad);
        for (int i = 0; i < 3; ++i) {
            ad.corner[i] = (float)(pos[i] - 0.5 * a1[i] - 0.5 * a2[i]);
            ad.edge_u[i] = (float)a1[i];
            ad.edge_v[i] = (float)a2[i];
            ad.radiance[i] = (float)(2.0 * I[i] / area);
        }
        ad.two_sided = 1;
        if (l->shadowless && !L->warned_shadowless++)
            vbnl_sdl_warning(L->c.parser, &pr->loc, "shadowless area_light is not supported: it casts shadows");
        uint32_t aid;
        vbnl_result ar = vbnl_scene_add_area_light(L->c.scene, &ad, &aid, err);
        return ar == VBNL_OK && l->no_media ? vbnl_scene_set_light_media_interaction(L->c.scene, aid, 0, err) : ar;
    }
    uint32_t id;
    vbnl_result r = vbnl_scene_add_point_light(L->c.scene, P, I, &id, err);
    return r == VBNL_OK ? light_flags(L, l, id, err) : r;
}
