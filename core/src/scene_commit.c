/* Scene commit (Embree scenes, emitters, light table) and ray queries. */
#include <float.h>
#include <stdlib.h>
#include <string.h>

#include "context.h"
#include "environment.h"
#include "scene_internal.h"

static vbnl_result embree_fail(const vbnl_scene *s, const char *what, vbnl_error *err)
{
    const char *msg = s->ctx->embree_error[0] ? s->ctx->embree_error : "no details";
    return vbnl_error_set(err, VBNL_ERR_BACKEND, "%s failed: %s", what, msg);
}

static RTCGeometry make_geometry(vbnl_scene *s, scene_geom *g)
{
    RTCGeometry geom = NULL;
    switch (g->kind) {
    case SCENE_GEOM_MESH: {
        scene_mesh *m = &g->u.mesh;
        geom = rtcNewGeometry(s->device, RTC_GEOMETRY_TYPE_TRIANGLE);
        if (!geom)
            return NULL;
        rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, m->positions, 0,
                                   sizeof(float) * 3, m->vertex_count);
        rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, m->indices, 0,
                                   sizeof(uint32_t) * 3, m->triangle_count);
        break;
    }
    case SCENE_GEOM_SPHERE: {
        geom = rtcNewGeometry(s->device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
        if (!geom)
            return NULL;
        float *v = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4,
                                           sizeof(float) * 4, 1);
        if (!v) {
            rtcReleaseGeometry(geom);
            return NULL;
        }
        v[0] = g->u.sphere.center.x;
        v[1] = g->u.sphere.center.y;
        v[2] = g->u.sphere.center.z;
        v[3] = g->u.sphere.radius;
        break;
    }
    case SCENE_GEOM_AREA_LIGHT: {
        geom = rtcNewGeometry(s->device, RTC_GEOMETRY_TYPE_QUAD);
        if (!geom)
            return NULL;
        float *v = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                           sizeof(float) * 3, 4);
        uint32_t *idx = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT4,
                                                sizeof(uint32_t) * 4, 1);
        if (!v || !idx) {
            rtcReleaseGeometry(geom);
            return NULL;
        }
        vec3 c = g->u.area.corner, eu = g->u.area.edge_u, ev = g->u.area.edge_v;
        v3_store(v + 0, c);
        v3_store(v + 3, v3_add(c, eu));
        v3_store(v + 6, v3_add(v3_add(c, eu), ev));
        v3_store(v + 9, v3_add(c, ev));
        idx[0] = 0;
        idx[1] = 1;
        idx[2] = 2;
        idx[3] = 3;
        break;
    }
    case SCENE_GEOM_INSTANCE: {
        geom = rtcNewGeometry(s->device, RTC_GEOMETRY_TYPE_INSTANCE);
        if (!geom)
            return NULL;
        rtcSetGeometryInstancedScene(geom, s->group_rtc[g->u.inst.group]);
        float xfm[12];
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c)
                xfm[r * 4 + c] = g->u.inst.xf.m[r][c];
        rtcSetGeometryTransform(geom, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, xfm);
        break;
    }
    }
    /* visibility flags clear the bits of the rays that must not see the geometry */
    uint32_t mask = VBI_RAY_ANY;
    if (g->visibility & VBNL_VISIBLE_NO_SHADOW)
        mask = (mask & ~VBI_RAY_SHADOW) | VBI_RAY_NO_SHADOW_PROBE;
    if (g->visibility & VBNL_VISIBLE_NO_IMAGE)
        mask &= ~VBI_RAY_CAMERA;
    if (g->visibility & VBNL_VISIBLE_NO_REFLECTION)
        mask &= ~VBI_RAY_REFLECTED;
    rtcSetGeometryMask(geom, mask);
    rtcCommitGeometry(geom);
    return geom;
}

static void grow_bounds(vbnl_scene *s, vec3 p)
{
    s->bounds_min = v3_min(s->bounds_min, p);
    s->bounds_max = v3_max(s->bounds_max, p);
}

/* A slot for one more light (NULL when out of memory). */
static vbi_light *append_light(vbnl_scene *s)
{
    if (s->light_count == s->light_capacity) {
        uint32_t cap = s->light_capacity ? s->light_capacity * 2 : 16;
        vbi_light *nl = realloc(s->lights, sizeof(vbi_light) * cap);
        if (!nl)
            return NULL;
        s->lights = nl;
        s->light_capacity = cap;
    }
    vbi_light *l = &s->lights[s->light_count++];
    memset(l, 0, sizeof(*l));
    return l;
}

static vbnl_result add_emitters(vbnl_scene *s, vbnl_error *err)
{
    for (uint32_t gi = 0; gi < s->geom_count; ++gi) {
        scene_geom *g = &s->geoms[gi];
        if (g->group != VBNL_GROUP_WORLD)
            continue;
        if (g->kind == SCENE_GEOM_MESH) {
            scene_mesh *m = &g->u.mesh;
            int any = 0;
            for (uint32_t t = 0; t < m->triangle_count && !any; ++t)
                any = s->materials[m->face_materials ? m->face_materials[t] : m->material].emissive;
            if (!any)
                continue;
            m->face_lights = malloc(sizeof(uint32_t) * m->triangle_count);
            if (!m->face_lights)
                return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
            for (uint32_t t = 0; t < m->triangle_count; ++t) {
                m->face_lights[t] = VBI_NO_LIGHT;
                const scene_material *mat = &s->materials[m->face_materials ? m->face_materials[t] : m->material];
                if (!mat->emissive)
                    continue;
                vec3 p0 = v3_load(m->positions + 3 * m->indices[3 * t]);
                vec3 p1 = v3_load(m->positions + 3 * m->indices[3 * t + 1]);
                vec3 p2 = v3_load(m->positions + 3 * m->indices[3 * t + 2]);
                vec3 c = v3_cross(v3_sub(p1, p0), v3_sub(p2, p0));
                float len = v3_len(c);
                if (!(len > 0.0f))
                    continue; /* degenerate triangles emit nothing */
                vec3 n = v3_scale(c, 1.0f / len);
                if (m->normals) {
                    /* the emitting side follows the shading normals, as hits do */
                    vec3 ns = v3_add(v3_add(v3_load(m->normals + 3 * m->indices[3 * t]),
                                            v3_load(m->normals + 3 * m->indices[3 * t + 1])),
                                     v3_load(m->normals + 3 * m->indices[3 * t + 2]));
                    if (v3_dot(ns, n) < 0.0f)
                        n = v3_neg(n);
                }
                vbi_light *l = append_light(s);
                if (!l)
                    return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
                l->type = VBI_LIGHT_TRIANGLE;
                l->p = p0;
                l->e0 = v3_sub(p1, p0);
                l->e1 = v3_sub(p2, p0);
                l->n = n;
                l->area = 0.5f * len;
                l->L = v3_load(mat->desc.emission);
                l->two_sided = mat->desc.two_sided;
                m->face_lights[t] = s->light_count - 1;
            }
        } else if (g->kind == SCENE_GEOM_SPHERE && s->materials[g->u.sphere.material].emissive) {
            const scene_material *mat = &s->materials[g->u.sphere.material];
            vbi_light *l = append_light(s);
            if (!l)
                return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
            l->type = VBI_LIGHT_SPHERE;
            l->p = g->u.sphere.center;
            l->radius = g->u.sphere.radius;
            l->area = 4.0f * VBI_PI * l->radius * l->radius;
            l->L = v3_load(mat->desc.emission);
            l->two_sided = mat->desc.two_sided;
            g->u.sphere.light = s->light_count - 1;
        }
    }
    /* A directional sky: its table is baked here (environment.h); a sky that turns out constant
     * (solid layers) becomes the constant environment, and a black one no light at all. */
    vec3 env_L = s->env_radiance;
    const vbi_env *env_sky = NULL;
    if (s->env_sky) {
        if (vbi_env_bake(s->env_sky) != 0)
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory baking the environment");
        env_L = s->env_sky->mean;
        env_sky = s->env_sky->constant ? NULL : s->env_sky;
    }
    if (!v3_is_black(env_L)) {
        vbi_light *l = append_light(s);
        if (!l)
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        l->type = VBI_LIGHT_ENV;
        l->L = env_L;
        l->env = env_sky;
        s->env_light = s->light_count - 1;
    }
    return VBNL_OK;
}

/* What a failed commit built, taken back: the scene is again as before the call (the user's
 * lights, no Embree scenes, no emitters), so that it can be completed and committed again. */
static void commit_undo(vbnl_scene *s)
{
    if (s->group_rtc) {
        for (uint32_t i = 0; i < s->group_count; ++i)
            if (s->group_rtc[i])
                rtcReleaseScene(s->group_rtc[i]);
        free(s->group_rtc);
        s->group_rtc = NULL;
    }
    s->world = NULL;
    for (uint32_t gi = 0; gi < s->geom_count; ++gi) {
        scene_geom *g = &s->geoms[gi];
        if (g->kind == SCENE_GEOM_MESH) {
            free(g->u.mesh.face_lights);
            g->u.mesh.face_lights = NULL;
        } else if (g->kind == SCENE_GEOM_SPHERE) {
            g->u.sphere.light = VBI_NO_LIGHT;
        }
    }
    s->light_count = s->user_light_count;
    s->env_light = VBI_NO_LIGHT;
    vbi_env_unbake(s->env_sky);
    vbi_alias_table_free(&s->light_table);
    vbi_alias_table_free(&s->nee_table);
}

static vbnl_result commit_build(vbnl_scene *s, vbnl_error *err);

vbnl_result vbnl_scene_commit(vbnl_scene *s, vbnl_error *err)
{
    if (!s)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_commit: scene is NULL");
    if (s->committed)
        return vbnl_error_set(err, VBNL_ERR_STATE, "vbnl_scene_commit: already committed");
    if (!s->has_camera)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "the scene has no camera");
    vbnl_result r = commit_build(s, err);
    if (r != VBNL_OK)
        commit_undo(s);
    return r;
}

/* The commit proper: Embree scenes (groups, then the world with its instances), bounds, emitters,
 * the light table. On failure the caller undoes what it built. */
static vbnl_result commit_build(vbnl_scene *s, vbnl_error *err)
{
    s->ctx->embree_error[0] = '\0';
    /* textures are final now: which materials vary per hit, and the hidden leaf copies of nodes */
    s->user_material_count = s->material_count;
    vbnl_result tr = vbi_texture_commit(s, err);
    if (tr != VBNL_OK)
        return tr;
    s->group_rtc = calloc(s->group_count, sizeof(RTCScene));
    if (!s->group_rtc)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    for (uint32_t i = 0; i < s->group_count; ++i) {
        s->group_rtc[i] = rtcNewScene(s->device);
        if (!s->group_rtc[i])
            return embree_fail(s, "rtcNewScene", err);
        rtcSetSceneBuildQuality(s->group_rtc[i], RTC_BUILD_QUALITY_HIGH);
    }
    s->world = s->group_rtc[0];
    /* Groups first (instances need committed scenes), then the world with its instances. */
    for (int pass = 0; pass < 2; ++pass) {
        for (uint32_t gi = 0; gi < s->geom_count; ++gi) {
            scene_geom *g = &s->geoms[gi];
            if ((g->kind == SCENE_GEOM_INSTANCE) != (pass == 1))
                continue;
            RTCGeometry geom = make_geometry(s, g);
            if (!geom)
                return embree_fail(s, "creating an Embree geometry", err);
            rtcAttachGeometryByID(s->group_rtc[g->group], geom, gi);
            rtcReleaseGeometry(geom);
        }
        if (pass == 0) {
            for (uint32_t i = 1; i < s->group_count; ++i)
                rtcCommitScene(s->group_rtc[i]);
        }
    }
    rtcCommitScene(s->world);
    if (s->ctx->embree_error[0])
        return embree_fail(s, "building the BVH", err);

    /* bounds and triangle count */
    s->bounds_min = v3s(FLT_MAX);
    s->bounds_max = v3s(-FLT_MAX);
    struct RTCBounds b;
    rtcGetSceneBounds(s->world, &b);
    if (b.lower_x <= b.upper_x) {
        grow_bounds(s, v3(b.lower_x, b.lower_y, b.lower_z));
        grow_bounds(s, v3(b.upper_x, b.upper_y, b.upper_z));
    }
    for (uint32_t i = 0; i < s->light_count; ++i)
        if (s->lights[i].type == VBI_LIGHT_POINT || s->lights[i].type == VBI_LIGHT_SPOT)
            grow_bounds(s, s->lights[i].p);
    if (s->bounds_min.x > s->bounds_max.x) {
        s->bounds_min = v3s(-1.0f);
        s->bounds_max = v3s(1.0f);
    }
    s->triangle_count = 0;
    for (uint32_t gi = 0; gi < s->geom_count; ++gi) {
        const scene_geom *g = &s->geoms[gi];
        if (g->kind == SCENE_GEOM_MESH && g->group == VBNL_GROUP_WORLD)
            s->triangle_count += g->u.mesh.triangle_count;
        else if (g->kind == SCENE_GEOM_INSTANCE)
            for (uint32_t k = 0; k < s->geom_count; ++k)
                if (s->geoms[k].kind == SCENE_GEOM_MESH && s->geoms[k].group == g->u.inst.group)
                    s->triangle_count += s->geoms[k].u.mesh.triangle_count;
    }

    vbnl_result r = add_emitters(s, err);
    if (r != VBNL_OK)
        return r;
    if (s->light_count == 0)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "the scene has no light (add a light source, an emissive surface or an environment)");
    vec3 center = v3_scale(v3_add(s->bounds_min, s->bounds_max), 0.5f);
    float radius = 0.5f * v3_len(v3_sub(s->bounds_max, s->bounds_min));
    float *power = malloc(sizeof(float) * s->light_count), *weight = malloc(sizeof(float) * s->light_count);
    if (!power || !weight) {
        free(power);
        free(weight);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    }
    for (uint32_t i = 0; i < s->light_count; ++i) {
        s->lights[i].world_center = center;
        s->lights[i].world_radius = radius > 0.0f ? radius : 1.0f;
        power[i] = v3_avg(vbi_light_power(&s->lights[i]));
    }
    int rc = vbi_alias_table_build(&s->light_table, power, s->light_count);
    if (rc == 0) {
        /* Next-event estimation picks a light by the irradiance it gives at the scene's centre:
         * a finite light's power over 4 pi d^2 (d its distance from the centre, at least 1% of
         * the scene's radius), a spot light's as if its axis intensity shone every way (what it
         * gives inside its cone, wherever the cone points), pi times an environment's mean
         * radiance, a directional light's irradiance. By power alone an environment or directional light would count its
         * radiance over the scene's whole cross-section, which an unbounded plane makes huge,
         * and a sun beside a sky would be picked so rarely that its light came as speckles; by
         * its power a narrow spot would be picked rarely and its pool of light come as speckles. */
        float floor2 = sqr(0.01f * (radius > 0.0f ? radius : 1.0f)), total = 0.0f;
        for (uint32_t i = 0; i < s->light_count; ++i) {
            const vbi_light *l = &s->lights[i];
            vec3 c = l->p;
            if (l->type == VBI_LIGHT_RECT)
                c = v3_add(l->p, v3_scale(v3_add(l->e0, l->e1), 0.5f));
            else if (l->type == VBI_LIGHT_TRIANGLE)
                c = v3_add(l->p, v3_scale(v3_add(l->e0, l->e1), 1.0f / 3.0f));
            const float d2 = fmaxf(v3_len2(v3_sub(c, center)), floor2);
            float w = l->type == VBI_LIGHT_ENV           ? VBI_PI * v3_avg(l->L)
                      : l->type == VBI_LIGHT_DIRECTIONAL ? v3_avg(l->L)
                      : l->type == VBI_LIGHT_SPOT        ? v3_avg(l->L) / d2
                                                         : power[i] / (4.0f * VBI_PI * d2);
            weight[i] = isfinite(w) && w > 0.0f ? w : 0.0f;
            total += weight[i];
        }
        /* (every weight underflowing, lights astronomically far from the scene: by power) */
        rc = vbi_alias_table_build(&s->nee_table, total > 0.0f ? weight : power, s->light_count);
        if (rc != 0)
            vbi_alias_table_free(&s->light_table);
    }
    free(weight);
    free(power);
    if (rc != 0)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "every light of the scene has zero power");
    vbi_media_commit(s);
    s->has_masks = 0;
    for (uint32_t gi = 0; gi < s->geom_count; ++gi)
        s->has_masks |= s->geoms[gi].visibility != 0;
    s->has_null = vbi_media_commit_pass(s);
    s->committed = 1;
    return VBNL_OK;
}

vbnl_result vbnl_scene_get_info(const vbnl_scene *s, vbnl_scene_info *out, vbnl_error *err)
{
    if (!s || !out)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_get_info: NULL argument");
    memset(out, 0, sizeof(*out));
    for (uint32_t i = 0; i < s->geom_count; ++i) {
        if (s->geoms[i].kind == SCENE_GEOM_SPHERE)
            out->sphere_count++;
        else if (s->geoms[i].kind == SCENE_GEOM_INSTANCE)
            out->instance_count++;
    }
    out->material_count = s->committed ? s->user_material_count : s->material_count;
    out->light_count = s->light_count;
    if (s->committed) {
        out->triangle_count = s->triangle_count;
        v3_store(out->bounds_min, s->bounds_min);
        v3_store(out->bounds_max, s->bounds_max);
        return VBNL_OK;
    }
    /* Before commit: bounds of the world geometry from the stored data (hosts use them to frame
     * a camera). Instances contribute the transformed corners of their group's box. */
    vec3 lo = v3s(FLT_MAX), hi = v3s(-FLT_MAX);
    for (uint32_t pass = 0; pass < 2; ++pass) {
        for (uint32_t i = 0; i < s->geom_count; ++i) {
            const scene_geom *g = &s->geoms[i];
            vec3 bmin = v3s(FLT_MAX), bmax = v3s(-FLT_MAX);
            if (g->kind == SCENE_GEOM_MESH) {
                for (uint32_t v = 0; v < g->u.mesh.vertex_count; ++v) {
                    vec3 p = v3_load(g->u.mesh.positions + 3 * (size_t)v);
                    bmin = v3_min(bmin, p);
                    bmax = v3_max(bmax, p);
                }
                if (pass == 0 && g->group == VBNL_GROUP_WORLD)
                    out->triangle_count += g->u.mesh.triangle_count;
            } else if (g->kind == SCENE_GEOM_SPHERE) {
                bmin = v3_sub(g->u.sphere.center, v3s(g->u.sphere.radius));
                bmax = v3_add(g->u.sphere.center, v3s(g->u.sphere.radius));
            } else if (g->kind == SCENE_GEOM_AREA_LIGHT) {
                vec3 c = g->u.area.corner, a = v3_add(c, g->u.area.edge_u), b = v3_add(c, g->u.area.edge_v);
                bmin = v3_min(v3_min(c, a), v3_min(b, v3_add(a, g->u.area.edge_v)));
                bmax = v3_max(v3_max(c, a), v3_max(b, v3_add(a, g->u.area.edge_v)));
            } else if (g->kind == SCENE_GEOM_INSTANCE && pass == 1) {
                vec3 glo = v3s(FLT_MAX), ghi = v3s(-FLT_MAX);
                for (uint32_t k = 0; k < s->geom_count; ++k) {
                    const scene_geom *c = &s->geoms[k];
                    if (c->group != g->u.inst.group)
                        continue;
                    if (c->kind == SCENE_GEOM_MESH) {
                        for (uint32_t v = 0; v < c->u.mesh.vertex_count; ++v) {
                            vec3 p = v3_load(c->u.mesh.positions + 3 * (size_t)v);
                            glo = v3_min(glo, p);
                            ghi = v3_max(ghi, p);
                        }
                    } else if (c->kind == SCENE_GEOM_SPHERE) {
                        glo = v3_min(glo, v3_sub(c->u.sphere.center, v3s(c->u.sphere.radius)));
                        ghi = v3_max(ghi, v3_add(c->u.sphere.center, v3s(c->u.sphere.radius)));
                    }
                }
                if (glo.x <= ghi.x) {
                    for (int corner = 0; corner < 8; ++corner) {
                        vec3 p = v3(corner & 1 ? ghi.x : glo.x, corner & 2 ? ghi.y : glo.y,
                                    corner & 4 ? ghi.z : glo.z);
                        p = mat4_point(&g->u.inst.xf, p);
                        bmin = v3_min(bmin, p);
                        bmax = v3_max(bmax, p);
                    }
                }
            }
            if (g->group != VBNL_GROUP_WORLD || (pass == 0) == (g->kind == SCENE_GEOM_INSTANCE))
                continue;
            lo = v3_min(lo, bmin);
            hi = v3_max(hi, bmax);
        }
    }
    v3_store(out->bounds_min, lo);
    v3_store(out->bounds_max, hi);
    return VBNL_OK;
}

/* ---- queries ------------------------------------------------------------------------------ */

/* The queries are vbi_scene_intersect_inline and vbi_scene_occluded_inline (scene_internal.h),
 * which the path tracer inlines into its bounce loop. */
int vbi_scene_intersect(const vbnl_scene *s, vec3 o, vec3 d, float tfar, vbi_hit *hit)
{
    return vbi_scene_intersect_inline(s, o, d, tfar, hit);
}

int vbi_scene_occluded(const vbnl_scene *s, vec3 o, vec3 d, float tfar)
{
    return vbi_scene_occluded_inline(s, o, d, tfar);
}

void vbi_scene_intersect8(const vbnl_scene *s, const int active[8], const vec3 o[8], const vec3 d[8],
                           vbi_hit hits[8], int hit_mask[8])
{
    vbi_scene_intersect8_mask(s, active, o, d, VBI_RAY_ANY, hits, hit_mask);
}

void vbi_scene_intersect8_mask(const vbnl_scene *s, const int active[8], const vec3 o[8], const vec3 d[8],
                                uint32_t mask, vbi_hit hits[8], int hit_mask[8])
{
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    ictx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    _Alignas(32) struct RTCRayHit8 rh;
    _Alignas(32) int valid[8];
    for (int i = 0; i < 8; ++i) {
        valid[i] = active[i] ? -1 : 0;
        rh.ray.org_x[i] = o[i].x;
        rh.ray.org_y[i] = o[i].y;
        rh.ray.org_z[i] = o[i].z;
        rh.ray.dir_x[i] = d[i].x;
        rh.ray.dir_y[i] = d[i].y;
        rh.ray.dir_z[i] = d[i].z;
        rh.ray.tnear[i] = 0.0f;
        rh.ray.tfar[i] = INFINITY;
        rh.ray.time[i] = 0.0f;
        rh.ray.mask[i] = mask;
        rh.ray.id[i] = (unsigned)i;
        rh.ray.flags[i] = 0;
        rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
    }
    rtcIntersect8(valid, s->world, &ictx, &rh);
    for (int i = 0; i < 8; ++i) {
        hit_mask[i] = active[i] && rh.hit.geomID[i] != RTC_INVALID_GEOMETRY_ID;
        if (hit_mask[i])
            vbi_fill_hit(s, rh.hit.geomID[i], rh.hit.primID[i], rh.hit.instID[0][i], rh.hit.u[i], rh.hit.v[i],
                          rh.ray.tfar[i], o[i], d[i], v3(rh.hit.Ng_x[i], rh.hit.Ng_y[i], rh.hit.Ng_z[i]), &hits[i]);
    }
}

/* ---- fingerprint (scene_internal.h) ------------------------------------------------------- */

#define FP_OFFSET 0xcbf29ce484222325ull
#define FP_PRIME 0x100000001b3ull

static uint64_t fp_bytes(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; ++i)
        h = (h ^ p[i]) * FP_PRIME;
    return h;
}
static uint64_t fp_u32(uint64_t h, uint32_t v) { return fp_bytes(h, &v, sizeof(v)); }
static uint64_t fp_f32(uint64_t h, float v) { return fp_bytes(h, &v, sizeof(v)); }
static uint64_t fp_v3(uint64_t h, vec3 v) { return fp_f32(fp_f32(fp_f32(h, v.x), v.y), v.z); }
/* An optional array: its presence, then its contents. */
static uint64_t fp_array(uint64_t h, const void *data, size_t n)
{
    h = fp_u32(h, data != NULL);
    return data ? fp_bytes(h, data, n) : h;
}

uint64_t vbi_scene_fingerprint(const vbnl_scene *s)
{
    if (!s || !s->committed)
        return 0;
    uint64_t h = FP_OFFSET;
    h = fp_u32(h, s->group_count);
    h = fp_u32(h, s->geom_count);
    for (uint32_t gi = 0; gi < s->geom_count; ++gi) {
        const scene_geom *g = &s->geoms[gi];
        h = fp_u32(fp_u32(h, (uint32_t)g->kind), g->group);
        switch (g->kind) {
        case SCENE_GEOM_MESH: {
            const scene_mesh *m = &g->u.mesh;
            size_t nv = m->vertex_count, nt = m->triangle_count;
            h = fp_u32(fp_u32(fp_u32(h, m->vertex_count), m->triangle_count), m->material);
            h = fp_array(h, m->positions, sizeof(float) * 3 * nv);
            h = fp_array(h, m->normals, sizeof(float) * 3 * nv);
            h = fp_array(h, m->uvs, sizeof(float) * 2 * nv);
            h = fp_array(h, m->indices, sizeof(uint32_t) * 3 * nt);
            h = fp_array(h, m->face_materials, sizeof(uint32_t) * nt);
            break;
        }
        case SCENE_GEOM_SPHERE:
            h = fp_f32(fp_v3(h, g->u.sphere.center), g->u.sphere.radius);
            h = fp_u32(h, g->u.sphere.material);
            break;
        case SCENE_GEOM_INSTANCE:
            h = fp_u32(h, g->u.inst.group);
            for (int r = 0; r < 4; ++r)
                for (int c = 0; c < 4; ++c)
                    h = fp_f32(h, g->u.inst.xf.m[r][c]);
            break;
        case SCENE_GEOM_AREA_LIGHT:
            h = fp_v3(fp_v3(fp_v3(fp_v3(h, g->u.area.corner), g->u.area.edge_u), g->u.area.edge_v), g->u.area.normal);
            h = fp_u32(h, g->u.area.material);
            break;
        }
    }
    h = fp_u32(h, s->material_count);
    for (uint32_t i = 0; i < s->material_count; ++i) {
        /* field by field: the description is all 4-byte members, but say so rather than rely on it */
        const vbnl_material_desc *d = &s->materials[i].desc;
        h = fp_u32(h, (uint32_t)d->type);
        h = fp_bytes(h, d->base_color, sizeof(d->base_color));
        h = fp_f32(fp_f32(h, d->alpha), d->ior);
        h = fp_u32(h, (uint32_t)d->conductor_use_ior);
        h = fp_bytes(h, d->eta, sizeof(d->eta));
        h = fp_bytes(h, d->k, sizeof(d->k));
        h = fp_bytes(h, d->emission, sizeof(d->emission));
        h = fp_u32(h, (uint32_t)d->two_sided);
        h = fp_u32(h, d->base_texture);
        h = fp_u32(fp_f32(h, d->brilliance), d->interior);
        h = fp_u32(h, (uint32_t)d->coat_curve);
        h = fp_bytes(h, d->coat_min, sizeof(d->coat_min));
        h = fp_bytes(h, d->coat_max, sizeof(d->coat_max));
        h = fp_f32(fp_f32(h, d->coat_falloff), d->coat_metallic);
        h = fp_f32(fp_u32(h, (uint32_t)d->coat_conserve), d->base_scale);
    }
    h = vbi_texture_fingerprint(s, h);
    h = fp_u32(h, s->light_count);
    for (uint32_t i = 0; i < s->light_count; ++i) {
        /* not the whole struct: its padding is not defined */
        const vbi_light *l = &s->lights[i];
        h = fp_u32(h, (uint32_t)l->type);
        h = fp_v3(fp_v3(fp_v3(fp_v3(h, l->p), l->e0), l->e1), l->n);
        h = fp_f32(fp_f32(h, l->area), l->radius);
        h = fp_v3(h, l->L);
        h = fp_f32(fp_f32(fp_f32(h, l->cos_inner), l->cos_outer), l->exponent);
        h = fp_u32(h, (uint32_t)l->two_sided);
    }
    h = fp_v3(h, s->env_radiance);
    if (s->env_sky) {
        const vbi_env *e = s->env_sky;
        h = fp_u32(h, e->count);
        for (uint32_t i = 0; i < e->count; ++i)
            h = fp_u32(h, e->pigments[i]);
        h = fp_bytes(h, e->xf.m, sizeof(e->xf.m));
        h = fp_u32(fp_v3(fp_v3(h, e->emission), e->background), (uint32_t)e->legacy);
    }
    return h;
}
