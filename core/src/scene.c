/* Scene building and Embree queries.
 *
 * add_* calls only validate and copy; commit creates the Embree scenes (one per group, the world
 * last), turns emissive surfaces into lights and builds the power-based light table. */
#include <float.h>
#include <stdlib.h>
#include <string.h>

#include "context.h"
#include "desc.h"
#include "scene_internal.h"

#define GROW(arr, count, cap, type)                                                                \
    do {                                                                                           \
        if ((count) == (cap)) {                                                                    \
            uint32_t ncap_ = (cap) ? (cap) * 2 : 16;                                               \
            type *n_ = realloc((arr), sizeof(type) * ncap_);                                       \
            if (!n_)                                                                               \
                return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");              \
            (arr) = n_;                                                                            \
            (cap) = ncap_;                                                                         \
        }                                                                                          \
    } while (0)

void vbnl_material_desc_init(vbnl_material_desc *d)
{
    if (!d)
        return;
    memset(d, 0, sizeof(*d));
    d->size = sizeof(*d);
    d->type = VBNL_MATERIAL_LAMBERT;
    d->base_color[0] = d->base_color[1] = d->base_color[2] = 0.8f;
    d->alpha = 0.1f;
    d->ior = 1.5f;
    d->eta[0] = d->eta[1] = d->eta[2] = 1.0f;
}

static void *dup_array_early(const void *src, size_t bytes)
{
    void *p = malloc(bytes ? bytes : 1);
    if (p && bytes)
        memcpy(p, src, bytes);
    return p;
}

void vbnl_texture_desc_init(vbnl_texture_desc *d)
{
    if (!d)
        return;
    memset(d, 0, sizeof(*d));
    d->size = sizeof(*d);
    d->kind = VBNL_TEXTURE_CHECKER;
    d->pattern_from_world[0] = d->pattern_from_world[5] = d->pattern_from_world[10] =
        d->pattern_from_world[15] = 1.0f;
    d->projection = VBNL_PROJECTION_UV;
    d->wrap = VBNL_WRAP_REPEAT;
    d->interpolate = 1;
    d->gradient[0] = 1.0f;
    d->brick_size[0] = 8.0f;
    d->brick_size[1] = 3.0f;
    d->brick_size[2] = 4.5f;
    d->mortar = 0.5f;
    d->frequency = 1.0f;
    d->wave = VBNL_WAVE_RAMP;
}

void vbnl_mesh_desc_init(vbnl_mesh_desc *d)
{
    if (!d)
        return;
    memset(d, 0, sizeof(*d));
    d->size = sizeof(*d);
    d->group = VBNL_GROUP_WORLD;
}

void vbnl_spot_light_desc_init(vbnl_spot_light_desc *d)
{
    if (!d)
        return;
    memset(d, 0, sizeof(*d));
    d->size = sizeof(*d);
}

void vbnl_area_light_desc_init(vbnl_area_light_desc *d)
{
    if (!d)
        return;
    memset(d, 0, sizeof(*d));
    d->size = sizeof(*d);
}

void vbnl_camera_desc_init(vbnl_camera_desc *d)
{
    if (!d)
        return;
    memset(d, 0, sizeof(*d));
    d->size = sizeof(*d);
}

static int finite3(const float *v) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

static vbnl_result check_open(const vbnl_scene *s, const char *fn, vbnl_error *err)
{
    if (!s)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "%s: scene is NULL", fn);
    if (s->committed)
        return vbnl_error_set(err, VBNL_ERR_STATE, "%s: the scene is already committed", fn);
    return VBNL_OK;
}

vbnl_result vbnl_scene_create(vbnl_context *ctx, vbnl_scene **out, vbnl_error *err)
{
    if (!ctx || !out)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_create: NULL argument");
    vbnl_scene *s = calloc(1, sizeof(*s));
    if (!s)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    s->ctx = ctx;
    s->device = ctx->device;
    s->group_count = 1; /* the world */
    s->env_light = VBNL_NO_LIGHT;
    *out = s;
    return VBNL_OK;
}

static void geom_free(scene_geom *g)
{
    if (g->kind == SCENE_GEOM_MESH) {
        free(g->u.mesh.positions);
        free(g->u.mesh.normals);
        free(g->u.mesh.uvs);
        free(g->u.mesh.indices);
        free(g->u.mesh.face_materials);
        free(g->u.mesh.face_lights);
    }
}

void vbnl_scene_destroy(vbnl_scene *s)
{
    if (!s)
        return;
    for (uint32_t i = 0; i < s->geom_count; ++i)
        geom_free(&s->geoms[i]);
    if (s->group_rtc) {
        for (uint32_t i = 0; i < s->group_count; ++i)
            if (s->group_rtc[i])
                rtcReleaseScene(s->group_rtc[i]);
        free(s->group_rtc);
    }
    vbnl_alias_table_free(&s->light_table);
    free(s->geoms);
    free(s->materials);
    for (uint32_t i = 0; i < s->texture_count; ++i) {
        free(s->textures[i].texels);
        free(s->textures[i].map);
    }
    free(s->textures);
    free(s->lights);
    free(s);
}

vbnl_result vbnl_scene_add_material(vbnl_scene *s, const vbnl_material_desc *d, uint32_t *out_id,
                                    vbnl_error *err)
{
    vbnl_result r = check_open(s, "vbnl_scene_add_material", err);
    if (r != VBNL_OK)
        return r;
    if (d && (r = VBNL_DESC_CHECK(d, vbnl_material_desc, err)) != VBNL_OK)
        return r;
    if (!d)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_add_material: desc is NULL");
    if ((unsigned)d->type > VBNL_MATERIAL_DIELECTRIC)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "unknown material type %d", (int)d->type);
    for (int i = 0; i < 3; ++i) {
        if (!(d->base_color[i] >= 0.0f && d->base_color[i] <= 1.0f))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                  "material base_color components must lie in [0, 1] (got %g)",
                                  d->base_color[i]);
        if (!(d->emission[i] >= 0.0f) || !isfinite(d->emission[i]))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                  "material emission must be finite and >= 0 (got %g)", d->emission[i]);
        if (d->type == VBNL_MATERIAL_CONDUCTOR && d->conductor_use_ior &&
            (!(d->eta[i] > 0.0f) || !(d->k[i] >= 0.0f)))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                  "conductor eta must be > 0 and k >= 0");
    }
    if (d->base_texture > s->texture_count)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "material base_texture %u names no texture (%u added; it is id + 1)",
                              d->base_texture, s->texture_count);
    if ((d->type == VBNL_MATERIAL_CONDUCTOR || d->type == VBNL_MATERIAL_PLASTIC) &&
        !(d->alpha >= 0.0f && d->alpha <= 1.0f))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "material alpha (GGX roughness) must lie in [0, 1] (got %g)", d->alpha);
    if ((d->type == VBNL_MATERIAL_DIELECTRIC || d->type == VBNL_MATERIAL_PLASTIC) &&
        !(d->ior > 1.0f && d->ior < 10.0f))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "material ior must lie in (1, 10) (got %g)", d->ior);
    GROW(s->materials, s->material_count, s->material_capacity, scene_material);
    scene_material *m = &s->materials[s->material_count];
    m->desc = *d;
    vbnl_bsdf_from_material(&m->bsdf, d);
    m->emissive = d->emission[0] > 0.0f || d->emission[1] > 0.0f || d->emission[2] > 0.0f;
    m->texture = NULL;
    if (out_id)
        *out_id = s->material_count;
    s->material_count++;
    return VBNL_OK;
}

vbnl_result vbnl_scene_add_texture(vbnl_scene *s, const vbnl_texture_desc *d, uint32_t *out_id,
                                   vbnl_error *err)
{
    vbnl_result r = check_open(s, "vbnl_scene_add_texture", err);
    if (r != VBNL_OK)
        return r;
    if (d && (r = VBNL_DESC_CHECK(d, vbnl_texture_desc, err)) != VBNL_OK)
        return r;
    if (!d)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_add_texture: desc is NULL");
    if ((unsigned)d->kind > VBNL_TEXTURE_BRICK)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "unknown texture kind %d", (int)d->kind);
    vbnl_texture t;
    memset(&t, 0, sizeof(t));
    t.kind = d->kind;
    for (int i = 0; i < 16; ++i) {
        if (!isfinite(d->pattern_from_world[i]))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "texture matrix is not finite");
        t.xf.m[i / 4][i % 4] = d->pattern_from_world[i];
    }
    if (!(fabsf(mat4_det3(&t.xf)) > 1e-20f))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "texture matrix is singular");
    if (d->kind == VBNL_TEXTURE_IMAGE) {
        if (!d->texels || d->width == 0 || d->height == 0 || d->width > (1u << 16) ||
            d->height > (1u << 16))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                  "image texture needs texels and a size in [1, 65536]^2 (got %u x %u)",
                                  d->width, d->height);
        if ((unsigned)d->projection > VBNL_PROJECTION_CYLINDRICAL || (unsigned)d->wrap > VBNL_WRAP_CLAMP)
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "unknown image projection or wrap mode");
        size_t n = 3 * (size_t)d->width * d->height;
        for (size_t i = 0; i < n; ++i)
            if (!(d->texels[i] >= 0.0f) || !isfinite(d->texels[i]))
                return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                      "image texel values must be finite and >= 0 (got %g)", d->texels[i]);
        t.width = d->width;
        t.height = d->height;
        t.projection = d->projection;
        t.wrap = d->wrap;
        t.interpolate = d->interpolate != 0;
        t.texels = dup_array_early(d->texels, n * sizeof(float));
        if (!t.texels)
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    } else {
        if (!d->color_map || d->color_map_count == 0 || d->color_map_count > VBNL_COLOR_MAP_MAX)
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                  "pattern texture needs a colour map of 1..%u entries", VBNL_COLOR_MAP_MAX);
        for (uint32_t i = 0; i < d->color_map_count; ++i) {
            const vbnl_color_map_entry *e = &d->color_map[i];
            if (!isfinite(e->value) || (i > 0 && e->value < d->color_map[i - 1].value))
                return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                      "colour map values must be finite and sorted (entry %u)", i);
            for (int c = 0; c < 3; ++c)
                if (!(e->color[c] >= 0.0f) || !isfinite(e->color[c]))
                    return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                          "colour map colours must be finite and >= 0 (entry %u)", i);
        }
        vec3 g = v3_load(d->gradient);
        if (d->kind == VBNL_TEXTURE_GRADIENT) {
            if (!v3_is_finite(g) || !(v3_len2(g) > 0.0f))
                return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "gradient axis must be non-zero");
            if (!isfinite(d->frequency) || !isfinite(d->phase) || (unsigned)d->wave > VBNL_WAVE_SCALLOP)
                return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                      "gradient frequency / phase must be finite and the wave known");
            t.gradient = v3_norm(g);
        }
        if (d->kind == VBNL_TEXTURE_BRICK) {
            for (int c = 0; c < 3; ++c)
                if (!(d->brick_size[c] > 0.0f) || !isfinite(d->brick_size[c]))
                    return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "brick_size components must be > 0");
            if (!(d->mortar >= 0.0f) || !isfinite(d->mortar))
                return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "mortar must be >= 0");
            t.brick_size = v3_load(d->brick_size);
            t.mortar = d->mortar;
        }
        t.frequency = d->frequency;
        t.phase = d->phase;
        t.wave = d->wave;
        t.map_count = d->color_map_count;
        t.map = dup_array_early(d->color_map, sizeof(vbnl_color_map_entry) * d->color_map_count);
        if (!t.map)
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    }
    if (s->texture_count == s->texture_capacity) {
        uint32_t ncap = s->texture_capacity ? s->texture_capacity * 2 : 16;
        vbnl_texture *n = realloc(s->textures, sizeof(*n) * ncap);
        if (!n) {
            free(t.texels);
            free(t.map);
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        }
        s->textures = n;
        s->texture_capacity = ncap;
    }
    s->textures[s->texture_count] = t;
    if (out_id)
        *out_id = s->texture_count;
    s->texture_count++;
    return VBNL_OK;
}

static void *dup_array(const void *src, size_t bytes)
{
    if (!src)
        return NULL;
    void *p = malloc(bytes ? bytes : 1);
    if (p)
        memcpy(p, src, bytes);
    return p;
}

static vbnl_result check_group(const vbnl_scene *s, uint32_t group, vbnl_error *err)
{
    if (group >= s->group_count)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "unknown group %u", group);
    return VBNL_OK;
}

static vbnl_result check_transform(const float *m, mat4 *out, mat4 *inv, vbnl_error *err)
{
    for (int i = 0; i < 16; ++i)
        if (!isfinite(m[i]))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "transform has a non-finite entry");
    memcpy(out->m, m, sizeof(float) * 16);
    if (out->m[3][0] != 0.0f || out->m[3][1] != 0.0f || out->m[3][2] != 0.0f || out->m[3][3] != 1.0f)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "transform must be affine (last row 0 0 0 1)");
    float det = mat4_det3(out);
    if (!(fabsf(det) > 1e-12f))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "transform is not invertible");
    if (inv) {
        /* inverse of the 3x3 part is cofactor^T / det; translation follows */
        const float(*a)[4] = out->m;
        mat4 r = mat4_identity();
        r.m[0][0] = (a[1][1] * a[2][2] - a[1][2] * a[2][1]) / det;
        r.m[0][1] = (a[0][2] * a[2][1] - a[0][1] * a[2][2]) / det;
        r.m[0][2] = (a[0][1] * a[1][2] - a[0][2] * a[1][1]) / det;
        r.m[1][0] = (a[1][2] * a[2][0] - a[1][0] * a[2][2]) / det;
        r.m[1][1] = (a[0][0] * a[2][2] - a[0][2] * a[2][0]) / det;
        r.m[1][2] = (a[0][2] * a[1][0] - a[0][0] * a[1][2]) / det;
        r.m[2][0] = (a[1][0] * a[2][1] - a[1][1] * a[2][0]) / det;
        r.m[2][1] = (a[0][1] * a[2][0] - a[0][0] * a[2][1]) / det;
        r.m[2][2] = (a[0][0] * a[1][1] - a[0][1] * a[1][0]) / det;
        vec3 t = mat4_vector(&r, v3(a[0][3], a[1][3], a[2][3]));
        r.m[0][3] = -t.x;
        r.m[1][3] = -t.y;
        r.m[2][3] = -t.z;
        *inv = r;
    }
    return VBNL_OK;
}

vbnl_result vbnl_scene_add_mesh(vbnl_scene *s, const vbnl_mesh_desc *d, uint32_t *out_id,
                                vbnl_error *err)
{
    vbnl_result r = check_open(s, "vbnl_scene_add_mesh", err);
    if (r != VBNL_OK)
        return r;
    if (d && (r = VBNL_DESC_CHECK(d, vbnl_mesh_desc, err)) != VBNL_OK)
        return r;
    if (!d || !d->positions || !d->indices)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "vbnl_scene_add_mesh: desc, positions and indices are required");
    if (d->vertex_count == 0 || d->triangle_count == 0)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_add_mesh: empty mesh");
    if ((r = check_group(s, d->group, err)) != VBNL_OK)
        return r;
    for (uint64_t i = 0; i < (uint64_t)d->triangle_count * 3; ++i)
        if (d->indices[i] >= d->vertex_count)
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                  "mesh index %u at position %llu is out of range (%u vertices)",
                                  d->indices[i], (unsigned long long)i, d->vertex_count);
    for (uint32_t i = 0; i < d->vertex_count; ++i)
        if (!finite3(d->positions + 3 * (size_t)i))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "mesh vertex %u is not finite", i);
    int emissive = 0;
    for (uint32_t i = 0; i < (d->face_materials ? d->triangle_count : 1); ++i) {
        uint32_t m = d->face_materials ? d->face_materials[i] : d->material;
        if (m >= s->material_count)
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "unknown material %u", m);
        emissive |= s->materials[m].emissive;
    }
    if (emissive && d->group != VBNL_GROUP_WORLD)
        return vbnl_error_set(err, VBNL_ERR_UNSUPPORTED,
                              "emissive meshes must be added to the world group, not instanced");
    mat4 xf, inv;
    if (d->transform && (r = check_transform(d->transform, &xf, &inv, err)) != VBNL_OK)
        return r;
    GROW(s->geoms, s->geom_count, s->geom_capacity, scene_geom);
    scene_geom *g = &s->geoms[s->geom_count];
    memset(g, 0, sizeof(*g));
    g->kind = SCENE_GEOM_MESH;
    g->group = d->group;
    scene_mesh *m = &g->u.mesh;
    size_t nv = d->vertex_count, nt = d->triangle_count;
    /* Embree reads vertex buffers 16 bytes at a time: pad by one float. */
    m->positions = malloc(sizeof(float) * (3 * nv + 1));
    m->indices = dup_array(d->indices, sizeof(uint32_t) * 3 * nt);
    m->normals = d->normals ? dup_array(d->normals, sizeof(float) * 3 * nv) : NULL;
    m->uvs = d->uvs ? dup_array(d->uvs, sizeof(float) * 2 * nv) : NULL;
    m->face_materials = d->face_materials ? dup_array(d->face_materials, sizeof(uint32_t) * nt) : NULL;
    if (!m->positions || !m->indices || (d->normals && !m->normals) || (d->uvs && !m->uvs) ||
        (d->face_materials && !m->face_materials)) {
        geom_free(g);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    }
    memcpy(m->positions, d->positions, sizeof(float) * 3 * nv);
    m->positions[3 * nv] = 0.0f;
    if (d->transform) {
        for (size_t i = 0; i < nv; ++i) {
            vec3 p = mat4_point(&xf, v3_load(m->positions + 3 * i));
            v3_store(m->positions + 3 * i, p);
            if (m->normals) {
                vec3 n = v3_norm(mat4_normal(&xf, v3_load(m->normals + 3 * i)));
                v3_store(m->normals + 3 * i, n);
            }
        }
    }
    if (m->normals) {
        for (size_t i = 0; i < nv; ++i) {
            vec3 n = v3_load(m->normals + 3 * i);
            if (!v3_is_finite(n) || v3_len2(n) == 0.0f) {
                /* a degenerate normal would poison shading: fall back to flat shading */
                free(m->normals);
                m->normals = NULL;
                break;
            }
            v3_store(m->normals + 3 * i, v3_norm(n));
        }
    }
    m->vertex_count = d->vertex_count;
    m->triangle_count = d->triangle_count;
    m->material = d->material;
    if (out_id)
        *out_id = s->geom_count;
    s->geom_count++;
    return VBNL_OK;
}

vbnl_result vbnl_scene_add_sphere(vbnl_scene *s, const float center[3], float radius,
                                  uint32_t material, uint32_t group, uint32_t *out_id,
                                  vbnl_error *err)
{
    vbnl_result r = check_open(s, "vbnl_scene_add_sphere", err);
    if (r != VBNL_OK)
        return r;
    if (!center || !finite3(center) || !(radius > 0.0f) || !isfinite(radius))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "vbnl_scene_add_sphere: needs a finite centre and a radius > 0");
    if ((r = check_group(s, group, err)) != VBNL_OK)
        return r;
    if (material >= s->material_count)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "unknown material %u", material);
    if (s->materials[material].emissive && group != VBNL_GROUP_WORLD)
        return vbnl_error_set(err, VBNL_ERR_UNSUPPORTED,
                              "emissive spheres must be added to the world group, not instanced");
    GROW(s->geoms, s->geom_count, s->geom_capacity, scene_geom);
    scene_geom *g = &s->geoms[s->geom_count];
    memset(g, 0, sizeof(*g));
    g->kind = SCENE_GEOM_SPHERE;
    g->group = group;
    g->u.sphere.center = v3_load(center);
    g->u.sphere.radius = radius;
    g->u.sphere.material = material;
    g->u.sphere.light = VBNL_NO_LIGHT;
    if (out_id)
        *out_id = s->geom_count;
    s->geom_count++;
    return VBNL_OK;
}

vbnl_result vbnl_scene_add_group(vbnl_scene *s, uint32_t *out_group, vbnl_error *err)
{
    vbnl_result r = check_open(s, "vbnl_scene_add_group", err);
    if (r != VBNL_OK)
        return r;
    if (!out_group)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_add_group: out is NULL");
    *out_group = s->group_count++;
    return VBNL_OK;
}

vbnl_result vbnl_scene_add_instance(vbnl_scene *s, uint32_t group, const float transform[16],
                                    uint32_t *out_id, vbnl_error *err)
{
    vbnl_result r = check_open(s, "vbnl_scene_add_instance", err);
    if (r != VBNL_OK)
        return r;
    if (!transform)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_add_instance: transform is NULL");
    if (group == VBNL_GROUP_WORLD || group >= s->group_count)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "vbnl_scene_add_instance: %u is not a group made by vbnl_scene_add_group",
                              group);
    mat4 xf, inv;
    if ((r = check_transform(transform, &xf, &inv, err)) != VBNL_OK)
        return r;
    GROW(s->geoms, s->geom_count, s->geom_capacity, scene_geom);
    scene_geom *g = &s->geoms[s->geom_count];
    memset(g, 0, sizeof(*g));
    g->kind = SCENE_GEOM_INSTANCE;
    g->group = VBNL_GROUP_WORLD;
    g->u.inst.group = group;
    g->u.inst.xf = xf;
    g->u.inst.inv = inv;
    if (out_id)
        *out_id = s->geom_count;
    s->geom_count++;
    return VBNL_OK;
}

static vbnl_result push_light(vbnl_scene *s, const vbnl_light *l, uint32_t *out_id, vbnl_error *err)
{
    GROW(s->lights, s->light_count, s->light_capacity, vbnl_light);
    s->lights[s->light_count] = *l;
    if (out_id)
        *out_id = s->light_count;
    s->light_count++;
    return VBNL_OK;
}

static vbnl_result check_color(const float *c, const char *what, vbnl_error *err)
{
    if (!c || !finite3(c) || c[0] < 0.0f || c[1] < 0.0f || c[2] < 0.0f)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "%s must be finite and >= 0", what);
    return VBNL_OK;
}

vbnl_result vbnl_scene_add_point_light(vbnl_scene *s, const float position[3],
                                       const float intensity[3], uint32_t *out_id, vbnl_error *err)
{
    vbnl_result r = check_open(s, "vbnl_scene_add_point_light", err);
    if (r != VBNL_OK)
        return r;
    if (!position || !finite3(position))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "point light position must be finite");
    if ((r = check_color(intensity, "point light intensity", err)) != VBNL_OK)
        return r;
    vbnl_light l;
    memset(&l, 0, sizeof(l));
    l.type = VBNL_LIGHT_POINT;
    l.p = v3_load(position);
    l.L = v3_load(intensity);
    r = push_light(s, &l, out_id, err);
    s->user_light_count = s->light_count;
    return r;
}

vbnl_result vbnl_scene_add_spot_light(vbnl_scene *s, const vbnl_spot_light_desc *d, uint32_t *out_id,
                                      vbnl_error *err)
{
    vbnl_result r = check_open(s, "vbnl_scene_add_spot_light", err);
    if (r != VBNL_OK)
        return r;
    if (d && (r = VBNL_DESC_CHECK(d, vbnl_spot_light_desc, err)) != VBNL_OK)
        return r;
    if (!d || !finite3(d->position) || !finite3(d->direction) || v3_len(v3_load(d->direction)) == 0.0f)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "spot light needs a finite position and a non-zero direction");
    if ((r = check_color(d->intensity, "spot light intensity", err)) != VBNL_OK)
        return r;
    if (!(d->cos_outer >= -1.0f && d->cos_outer < 1.0f && d->cos_inner >= d->cos_outer &&
          d->cos_inner <= 1.0f) || !(d->exponent >= 0.0f))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "spot light needs -1 <= cos_outer <= cos_inner <= 1, cos_outer < 1 and exponent >= 0");
    vbnl_light l;
    memset(&l, 0, sizeof(l));
    l.type = VBNL_LIGHT_SPOT;
    l.p = v3_load(d->position);
    l.n = v3_norm(v3_load(d->direction));
    l.L = v3_load(d->intensity);
    l.cos_inner = d->cos_inner;
    l.cos_outer = d->cos_outer;
    l.exponent = d->exponent;
    r = push_light(s, &l, out_id, err);
    s->user_light_count = s->light_count;
    return r;
}

vbnl_result vbnl_scene_add_area_light(vbnl_scene *s, const vbnl_area_light_desc *d, uint32_t *out_id,
                                      vbnl_error *err)
{
    vbnl_result r = check_open(s, "vbnl_scene_add_area_light", err);
    if (r != VBNL_OK)
        return r;
    if (d && (r = VBNL_DESC_CHECK(d, vbnl_area_light_desc, err)) != VBNL_OK)
        return r;
    if (!d || !finite3(d->corner) || !finite3(d->edge_u) || !finite3(d->edge_v))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "area light needs finite corner and edges");
    if ((r = check_color(d->radiance, "area light radiance", err)) != VBNL_OK)
        return r;
    vec3 eu = v3_load(d->edge_u), ev = v3_load(d->edge_v);
    vec3 c = v3_cross(eu, ev);
    float area = v3_len(c);
    if (!(area > 0.0f))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "area light edges are parallel or zero");
    /* A black material with emission makes the quad visible to camera and BSDF rays. */
    vbnl_material_desc md;
    vbnl_material_desc_init(&md);
    md.base_color[0] = md.base_color[1] = md.base_color[2] = 0.0f;
    memcpy(md.emission, d->radiance, sizeof(md.emission));
    md.two_sided = d->two_sided;
    uint32_t mat;
    if ((r = vbnl_scene_add_material(s, &md, &mat, err)) != VBNL_OK)
        return r;
    vbnl_light l;
    memset(&l, 0, sizeof(l));
    l.type = VBNL_LIGHT_RECT;
    l.p = v3_load(d->corner);
    l.e0 = eu;
    l.e1 = ev;
    l.n = v3_scale(c, 1.0f / area);
    l.area = area;
    l.L = v3_load(d->radiance);
    l.two_sided = d->two_sided;
    uint32_t light;
    if ((r = push_light(s, &l, &light, err)) != VBNL_OK)
        return r;
    s->user_light_count = s->light_count;
    GROW(s->geoms, s->geom_count, s->geom_capacity, scene_geom);
    scene_geom *g = &s->geoms[s->geom_count];
    memset(g, 0, sizeof(*g));
    g->kind = SCENE_GEOM_AREA_LIGHT;
    g->group = VBNL_GROUP_WORLD;
    g->u.area.corner = l.p;
    g->u.area.edge_u = eu;
    g->u.area.edge_v = ev;
    g->u.area.normal = l.n;
    g->u.area.material = mat;
    g->u.area.light = light;
    s->geom_count++;
    if (out_id)
        *out_id = light;
    return VBNL_OK;
}

vbnl_result vbnl_scene_add_directional_light(vbnl_scene *s, const float direction[3],
                                             const float irradiance[3], uint32_t *out_id,
                                             vbnl_error *err)
{
    vbnl_result r = check_open(s, "vbnl_scene_add_directional_light", err);
    if (r != VBNL_OK)
        return r;
    if (!direction || !finite3(direction) || v3_len(v3_load(direction)) == 0.0f)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "directional light needs a finite non-zero direction");
    if ((r = check_color(irradiance, "directional light irradiance", err)) != VBNL_OK)
        return r;
    vbnl_light l;
    memset(&l, 0, sizeof(l));
    l.type = VBNL_LIGHT_DIRECTIONAL;
    l.n = v3_norm(v3_load(direction));
    l.L = v3_load(irradiance);
    r = push_light(s, &l, out_id, err);
    s->user_light_count = s->light_count;
    return r;
}

vbnl_result vbnl_scene_set_environment(vbnl_scene *s, const float radiance[3], vbnl_error *err)
{
    vbnl_result r = check_open(s, "vbnl_scene_set_environment", err);
    if (r != VBNL_OK)
        return r;
    if ((r = check_color(radiance, "environment radiance", err)) != VBNL_OK)
        return r;
    s->env_radiance = v3_load(radiance);
    return VBNL_OK;
}

vbnl_result vbnl_camera_look_at(vbnl_camera_desc *out, const float position[3], const float target[3],
                                const float up[3], float fov_y_degrees, float aspect, vbnl_error *err)
{
    if (!out || !position || !target || !up)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_camera_look_at: NULL argument");
    if (!(fov_y_degrees > 0.0f && fov_y_degrees < 180.0f) || !(aspect > 0.0f) || !isfinite(aspect))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "camera field of view must lie in (0, 180) degrees and aspect be > 0");
    vec3 p = v3_load(position), t = v3_load(target), u = v3_load(up);
    vec3 f = v3_sub(t, p);
    if (!(v3_len(f) > 0.0f))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "camera position equals its target");
    f = v3_norm(f);
    vec3 r = v3_cross(f, u);
    if (!(v3_len(r) > 1e-6f))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "camera up vector is parallel to the view direction");
    r = v3_norm(r);
    vec3 uu = v3_cross(r, f);
    float h = 2.0f * tanf(fov_y_degrees * (float)M_PI / 360.0f);
    vbnl_camera_desc_init(out);
    v3_store(out->position, p);
    v3_store(out->forward, f);
    v3_store(out->right, v3_scale(r, h * aspect));
    v3_store(out->up, v3_scale(uu, h));
    return VBNL_OK;
}

vbnl_result vbnl_scene_set_camera(vbnl_scene *s, const vbnl_camera_desc *c, vbnl_error *err)
{
    vbnl_result r = check_open(s, "vbnl_scene_set_camera", err);
    if (r != VBNL_OK)
        return r;
    if (c && (r = VBNL_DESC_CHECK(c, vbnl_camera_desc, err)) != VBNL_OK)
        return r;
    if (!c || !finite3(c->position) || !finite3(c->forward) || !finite3(c->right) || !finite3(c->up))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "camera vectors must be finite");
    vec3 f = v3_load(c->forward), rt = v3_load(c->right), up = v3_load(c->up);
    if (!(fabsf(v3_dot(f, v3_cross(rt, up))) > 1e-12f))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "camera forward, right and up vectors must be linearly independent");
    s->camera = *c;
    s->has_camera = 1;
    return VBNL_OK;
}

void vbnl_camera_ray(const vbnl_camera_desc *c, uint32_t width, uint32_t height, float px, float py,
                     vec3 *o, vec3 *d)
{
    float sx = px / (float)width - 0.5f;
    float sy = 0.5f - py / (float)height;
    vec3 dir = v3_add(v3_load(c->forward),
                      v3_add(v3_scale(v3_load(c->right), sx), v3_scale(v3_load(c->up), sy)));
    *o = v3_load(c->position);
    *d = v3_norm(dir);
}
