/* Scene building and Embree queries.
 *
 * add_* calls only validate and copy; commit creates the Embree scenes (one per group, the world
 * last), turns emissive surfaces into lights and builds the power-based light table. */
#include <float.h>
#include <stdlib.h>
#include <string.h>

#include "context.h"
#include "desc.h"
#include "camera_mesh.h"
#include "environment.h"
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
    d->brilliance = 1.0f;
    d->coat_curve = VBNL_COAT_DIELECTRIC;
    d->coat_max[0] = d->coat_max[1] = d->coat_max[2] = 1.0f;
    d->coat_falloff = 1.0f;
    d->base_scale = 1.0f;
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

vbnl_result vbi_scene_check_open(const vbnl_scene *s, const char *fn, vbnl_error *err)
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
    s->background_alpha = 1.0f; /* opaque, unless the front end asks for POV-Ray's +UA */
    s->env_light = VBI_NO_LIGHT;
    vbi_texture_set_init(&s->tex);
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
    vbi_alias_table_free(&s->light_table);
    vbi_alias_table_free(&s->nee_table);
    free(s->geoms);
    free(s->materials);
    vbi_env_destroy(s->env_sky);
    vbi_texture_set_free(&s->tex);
    free(s->lights);
    vbi_camera_mesh_free((void *)s->camera.mesh_index);
    free(s->media);
    free(s->fogs);
    free(s);
}

/* The coat fields of a plastic (vbnl_material_desc). */
static vbnl_result check_coat(const vbnl_material_desc *d, vbnl_error *err)
{
    if (d->coat_curve != VBNL_COAT_DIELECTRIC && d->coat_curve != VBNL_COAT_SCHLICK &&
        d->coat_curve != VBNL_COAT_FRESNEL)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "unknown material coat_curve %d", d->coat_curve);
    if (d->coat_curve == VBNL_COAT_DIELECTRIC)
        return VBNL_OK;
    for (int i = 0; i < 3; ++i)
        if (!(d->coat_min[i] >= 0.0f && d->coat_min[i] <= 1.0f) || !(d->coat_max[i] >= 0.0f && d->coat_max[i] <= 1.0f))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                  "material coat_min and coat_max components must lie in [0, 1] (got %g, %g)",
                                  d->coat_min[i], d->coat_max[i]);
    if (d->coat_curve == VBNL_COAT_SCHLICK && !(d->coat_falloff > 0.0f && d->coat_falloff <= 1000.0f))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "material coat_falloff must lie in (0, 1000] (got %g)",
                              d->coat_falloff);
    if (!(d->coat_metallic >= 0.0f && d->coat_metallic <= 1.0f))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "material coat_metallic must lie in [0, 1] (got %g)",
                              d->coat_metallic);
    if (!(d->base_scale >= 0.0f && d->base_scale <= 1.0f))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "material base_scale must lie in [0, 1] (got %g)",
                              d->base_scale);
    if (d->coat_conserve != 0 && d->coat_conserve != 1)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "material coat_conserve must be 0 or 1 (got %d)",
                              d->coat_conserve);
    return VBNL_OK;
}

vbnl_result vbnl_scene_add_material(vbnl_scene *s, const vbnl_material_desc *d, uint32_t *out_id,
                                    vbnl_error *err)
{
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_add_material", err);
    if (r != VBNL_OK)
        return r;
    if (d && (r = VBI_DESC_CHECK(d, vbnl_material_desc, err)) != VBNL_OK)
        return r;
    if (!d)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_add_material: desc is NULL");
    if ((unsigned)d->type > VBNL_MATERIAL_BRILLIANCE)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "unknown material type %d", (int)d->type);
    if (d->type == VBNL_MATERIAL_BRILLIANCE && !(d->brilliance >= 1.0f && d->brilliance <= 1000.0f))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "material brilliance must lie in [1, 1000] (got %g)",
                              d->brilliance);
    if (d->interior != VBNL_INTERIOR_SAME && d->interior != VBNL_INTERIOR_CLEAR && d->interior > s->medium_count)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "material interior %u names no medium (%u added; it is id + 1)", d->interior,
                              s->medium_count);
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
    if (d->base_texture > s->tex.pigment_count)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "material base_texture %u names no pigment (%u added; it is id + 1)",
                              d->base_texture, s->tex.pigment_count);
    if ((d->type == VBNL_MATERIAL_CONDUCTOR || d->type == VBNL_MATERIAL_PLASTIC) &&
        !(d->alpha >= 0.0f && d->alpha <= 1.0f))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "material alpha (GGX roughness) must lie in [0, 1] (got %g)", d->alpha);
    if ((d->type == VBNL_MATERIAL_PLASTIC && !(d->ior > 1.0f && d->ior < 10.0f)) ||
        (d->type == VBNL_MATERIAL_DIELECTRIC && !(d->ior >= 1.0f && d->ior < 10.0f)))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "material ior must lie in %s, 10) (got %g)",
                              d->type == VBNL_MATERIAL_PLASTIC ? "(1" : "[1", d->ior);
    if ((d->type == VBNL_MATERIAL_PLASTIC || d->type == VBNL_MATERIAL_DIELECTRIC) &&
        (r = check_coat(d, err)) != VBNL_OK)
        return r;
    GROW(s->materials, s->material_count, s->material_capacity, scene_material);
    scene_material *m = &s->materials[s->material_count];
    m->desc = *d;
    vbi_bsdf_from_material(&m->bsdf, d);
    m->emissive = d->emission[0] > 0.0f || d->emission[1] > 0.0f || d->emission[2] > 0.0f;
    m->varies = d->base_texture != 0;
    m->is_node = 0;
    memset(&m->node, 0, sizeof(m->node));
    m->surface = m->origin = s->material_count;
    m->hidden_begin = m->hidden_count = 0;
    if (out_id)
        *out_id = s->material_count;
    s->material_count++;
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
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_add_mesh", err);
    if (r != VBNL_OK)
        return r;
    if (d && (r = VBI_DESC_CHECK(d, vbnl_mesh_desc, err)) != VBNL_OK)
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
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_add_sphere", err);
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
    g->u.sphere.light = VBI_NO_LIGHT;
    if (out_id)
        *out_id = s->geom_count;
    s->geom_count++;
    return VBNL_OK;
}

vbnl_result vbnl_scene_add_group(vbnl_scene *s, uint32_t *out_group, vbnl_error *err)
{
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_add_group", err);
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
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_add_instance", err);
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

static vbnl_result push_light(vbnl_scene *s, const vbi_light *l, uint32_t *out_id, vbnl_error *err)
{
    GROW(s->lights, s->light_count, s->light_capacity, vbi_light);
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
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_add_point_light", err);
    if (r != VBNL_OK)
        return r;
    if (!position || !finite3(position))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "point light position must be finite");
    if ((r = check_color(intensity, "point light intensity", err)) != VBNL_OK)
        return r;
    vbi_light l;
    memset(&l, 0, sizeof(l));
    l.type = VBI_LIGHT_POINT;
    l.p = v3_load(position);
    l.L = v3_load(intensity);
    r = push_light(s, &l, out_id, err);
    s->user_light_count = s->light_count;
    return r;
}

vbnl_result vbnl_scene_add_spot_light(vbnl_scene *s, const vbnl_spot_light_desc *d, uint32_t *out_id,
                                      vbnl_error *err)
{
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_add_spot_light", err);
    if (r != VBNL_OK)
        return r;
    if (d && (r = VBI_DESC_CHECK(d, vbnl_spot_light_desc, err)) != VBNL_OK)
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
    vbi_light l;
    memset(&l, 0, sizeof(l));
    l.type = VBI_LIGHT_SPOT;
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
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_add_area_light", err);
    if (r != VBNL_OK)
        return r;
    if (d && (r = VBI_DESC_CHECK(d, vbnl_area_light_desc, err)) != VBNL_OK)
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
    vbi_light l;
    memset(&l, 0, sizeof(l));
    l.type = VBI_LIGHT_RECT;
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
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_add_directional_light", err);
    if (r != VBNL_OK)
        return r;
    if (!direction || !finite3(direction) || v3_len(v3_load(direction)) == 0.0f)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "directional light needs a finite non-zero direction");
    if ((r = check_color(irradiance, "directional light irradiance", err)) != VBNL_OK)
        return r;
    vbi_light l;
    memset(&l, 0, sizeof(l));
    l.type = VBI_LIGHT_DIRECTIONAL;
    l.n = v3_norm(v3_load(direction));
    l.L = v3_load(irradiance);
    r = push_light(s, &l, out_id, err);
    s->user_light_count = s->light_count;
    return r;
}

vbnl_result vbnl_scene_set_environment(vbnl_scene *s, const float radiance[3], vbnl_error *err)
{
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_set_environment", err);
    if (r != VBNL_OK)
        return r;
    if ((r = check_color(radiance, "environment radiance", err)) != VBNL_OK)
        return r;
    s->env_radiance = v3_load(radiance);
    vbi_env_destroy(s->env_sky);
    s->env_sky = NULL;
    return VBNL_OK;
}

void vbnl_environment_desc_init(vbnl_environment_desc *d)
{
    if (!d)
        return;
    memset(d, 0, sizeof(*d));
    d->size = sizeof(*d);
    d->pattern_from_world[0] = d->pattern_from_world[5] = d->pattern_from_world[10] = d->pattern_from_world[15] = 1.0;
    d->emission[0] = d->emission[1] = d->emission[2] = 1.0f;
}

vbnl_result vbnl_scene_set_environment_pigments(vbnl_scene *s, const vbnl_environment_desc *d, vbnl_error *err)
{
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_set_environment_pigments", err);
    if (r != VBNL_OK)
        return r;
    if (!d)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_set_environment_pigments: desc is NULL");
    if ((r = VBI_DESC_CHECK(d, vbnl_environment_desc, err)) != VBNL_OK)
        return r;
    if (d->pigment_count == 0 || d->pigment_count > VBNL_ENVIRONMENT_LAYERS_MAX || !d->pigments)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "environment needs 1 to %u pigments, got %u",
                              VBNL_ENVIRONMENT_LAYERS_MAX, d->pigment_count);
    for (uint32_t i = 0; i < d->pigment_count; ++i)
        if (d->pigments[i] >= s->tex.pigment_count)
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "environment layer %u: unknown pigment id %u", i,
                                  d->pigments[i]);
    for (int i = 0; i < 16; ++i)
        if (!isfinite(d->pattern_from_world[i]))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "environment transform has a non-finite entry");
    if (d->pattern_from_world[12] != 0.0 || d->pattern_from_world[13] != 0.0 || d->pattern_from_world[14] != 0.0 ||
        d->pattern_from_world[15] != 1.0)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "environment transform must be affine (last row 0 0 0 1)");
    if ((r = check_color(d->emission, "environment emission", err)) != VBNL_OK ||
        (r = check_color(d->background, "environment background", err)) != VBNL_OK)
        return r;
    vbi_env *e = vbi_env_create(d, &s->tex);
    if (!e)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    vbi_env_destroy(s->env_sky);
    s->env_sky = e;
    s->env_radiance = v3s(0.0f);
    return VBNL_OK;
}

vbnl_result vbnl_scene_set_background_alpha(vbnl_scene *s, float alpha, vbnl_error *err)
{
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_set_background_alpha", err);
    if (r != VBNL_OK)
        return r;
    if (!(alpha >= 0.0f && alpha <= 1.0f))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "background alpha must lie in [0, 1] (got %g)", alpha);
    s->background_alpha = alpha;
    return VBNL_OK;
}

vbnl_result vbnl_scene_set_visibility(vbnl_scene *s, uint32_t geom, uint32_t flags, vbnl_error *err)
{
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_set_visibility", err);
    if (r != VBNL_OK)
        return r;
    if (geom >= s->geom_count || s->geoms[geom].kind == SCENE_GEOM_AREA_LIGHT)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_set_visibility: geometry %u does not exist",
                              geom);
    const uint32_t all = VBNL_VISIBLE_NO_SHADOW | VBNL_VISIBLE_NO_IMAGE | VBNL_VISIBLE_NO_REFLECTION;
    if (flags & ~all)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_set_visibility: unknown flags 0x%x",
                              flags & ~all);
    s->geoms[geom].visibility = flags;
    return VBNL_OK;
}

vbnl_result vbnl_scene_set_light_shadowless(vbnl_scene *s, uint32_t light, int shadowless, vbnl_error *err)
{
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_set_light_shadowless", err);
    if (r != VBNL_OK)
        return r;
    if (light >= s->light_count)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_set_light_shadowless: light %u does not exist",
                              light);
    s->lights[light].shadowless = shadowless != 0;
    return VBNL_OK;
}

vbnl_result vbnl_scene_set_light_media_interaction(vbnl_scene *s, uint32_t light, int interacts, vbnl_error *err)
{
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_set_light_media_interaction", err);
    if (r != VBNL_OK)
        return r;
    if (light >= s->light_count)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "vbnl_scene_set_light_media_interaction: light %u does not exist", light);
    s->lights[light].no_media = interacts == 0;
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
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_set_camera", err);
    if (r != VBNL_OK)
        return r;
    if (c && (r = VBI_DESC_CHECK(c, vbnl_camera_desc, err)) != VBNL_OK)
        return r;
    if (!c || !finite3(c->position) || !finite3(c->forward) || !finite3(c->right) || !finite3(c->up))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "camera vectors must be finite");
    vec3 f = v3_load(c->forward), rt = v3_load(c->right), up = v3_load(c->up);
    if (!(fabsf(v3_dot(f, v3_cross(rt, up))) > 1e-12f))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "camera forward, right and up vectors must be linearly independent");
    if ((unsigned)c->projection > (unsigned)VBNL_CAMERA_MESH)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "camera projection %d is unknown", (int)c->projection);
    if (!(c->angle[0] >= 0.0f && c->angle[0] <= 360.0f) || !(c->angle[1] >= 0.0f && c->angle[1] <= 360.0f))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "camera angles must lie in [0, 360] degrees");
    if (!(c->lens_radius >= 0.0f) || !isfinite(c->lens_radius) ||
        (c->lens_radius > 0.0f && !(c->focal_distance > 0.0f && isfinite(c->focal_distance))))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "camera lens radius must be >= 0 and, with a lens, the focal distance > 0");
    vbnl_camera_desc copy = *c;
    copy.meshes = NULL;
    copy.mesh_index = NULL;
    if (c->projection == VBNL_CAMERA_MESH) {
        copy.meshes = c->meshes;
        if ((r = vbi_camera_mesh_copy(&copy, err)) != VBNL_OK)
            return r;
    }
    vbi_camera_mesh_free((void *)s->camera.mesh_index);
    s->camera = copy;
    s->has_camera = 1;
    return VBNL_OK;
}

/* v rotated by `angle` radians about the unit axis k (Rodrigues' formula), the rotation POV-Ray's
 * spherical camera applies. */
static vec3 rotate_about(vec3 v, vec3 k, float angle)
{
    float c = cosf(angle), s = sinf(angle);
    return v3_add(v3_add(v3_scale(v, c), v3_scale(v3_cross(k, v), s)), v3_scale(k, v3_dot(k, v) * (1.0f - c)));
}

/* The pinhole ray of the camera's projection through the normalised image point (sx, sy): its
 * origin and unnormalised direction, as POV-Ray 3.7 builds its primary rays (the formulas of the
 * reference's "Camera Types"). 0 where the projection has no ray (outside the fisheye's circle). */
static int camera_pinhole(const vbnl_camera_desc *c, float sx, float sy, vec3 *o, vec3 *d)
{
    const vec3 f = v3_load(c->forward), r = v3_load(c->right), u = v3_load(c->up);
    *o = v3_load(c->position);
    if (c->projection == VBNL_CAMERA_PERSPECTIVE) {
        *d = v3_add(f, v3_add(v3_scale(r, sx), v3_scale(u, sy)));
        return 1;
    }
    const float lr = v3_len(r), lu = v3_len(u), rad = (float)M_PI / 180.0f;
    const vec3 fn = v3_norm(f), rn = v3_norm(r), un = v3_norm(u);
    switch (c->projection) {
    case VBNL_CAMERA_ORTHOGRAPHIC:
        *o = v3_add(*o, v3_add(v3_scale(r, sx), v3_scale(u, sy)));
        *d = f;
        return 1;
    case VBNL_CAMERA_FISHEYE: {
        /* the circle of radius 1 in (2 sx |right|, 2 sy |up|) spans angle[0]; its centre is forward */
        float x = 2.0f * sx * lr, y = 2.0f * sy * lu, rho = sqrtf(x * x + y * y);
        float phi = rho > 0.0f ? atan2f(y, x) : 0.0f, theta = rho * 0.5f * c->angle[0] * rad;
        *d = v3_add(v3_add(v3_scale(rn, cosf(phi) * sinf(theta)), v3_scale(un, sinf(phi) * sinf(theta))),
                    v3_scale(fn, cosf(theta)));
        return rho <= 1.0f;
    }
    case VBNL_CAMERA_ULTRA_WIDE_ANGLE: {
        float x = sx * c->angle[0] * rad, y = sy * c->angle[0] * rad * (lu / lr);
        *d = v3_add(v3_add(v3_scale(rn, sinf(x)), v3_scale(un, sinf(y))), v3_scale(fn, cosf(x) * cosf(y)));
        return 1;
    }
    case VBNL_CAMERA_PANORAMIC: {
        /* 180 degrees across the width, from -right at the left edge to +right at the right one */
        float x = (0.5f - sx) * (float)M_PI, y = sy * (float)M_PI;
        float t = fabsf(fabsf(y) - 0.5f * (float)M_PI) < 1e-6f ? copysignf(1e30f, y) : tanf(y);
        *d = v3_add(v3_add(v3_scale(r, cosf(x)), v3_scale(u, t)), v3_scale(f, sinf(x)));
        return 1;
    }
    case VBNL_CAMERA_SPHERICAL: {
        /* latitude about right, then longitude about up */
        vec3 v = rotate_about(f, rn, -sy * c->angle[1] * rad);
        *d = rotate_about(v, un, sx * c->angle[0] * rad);
        return 1;
    }
    case VBNL_CAMERA_CYLINDER_1:
    case VBNL_CAMERA_CYLINDER_3: {
        float a = sx * c->angle[0] * rad, h = sy * lu;
        *d = v3_add(v3_scale(rn, sinf(a)), v3_scale(fn, cosf(a)));
        if (c->projection == VBNL_CAMERA_CYLINDER_1)
            *d = v3_add(*d, v3_scale(un, h));
        else
            *o = v3_add(*o, v3_scale(un, h));
        return 1;
    }
    case VBNL_CAMERA_CYLINDER_2:
    case VBNL_CAMERA_CYLINDER_4: {
        float a = sy * c->angle[0] * rad, w = sx * lr;
        *d = v3_add(v3_scale(un, sinf(a)), v3_scale(fn, cosf(a)));
        if (c->projection == VBNL_CAMERA_CYLINDER_2)
            *d = v3_add(*d, v3_scale(rn, w));
        else
            *o = v3_add(*o, v3_scale(rn, w));
        return 1;
    }
    default:
        *d = v3_add(f, v3_add(v3_scale(r, sx), v3_scale(u, sy)));
        return 1;
    }
}

int vbi_camera_ray_lens(const vbnl_camera_desc *c, uint32_t width, uint32_t height, float px, float py, vec2 lens,
                         vec3 *o, vec3 *d)
{
    if (c->projection == VBNL_CAMERA_MESH) {
        int ok = vbi_camera_mesh_ray(c, width, height, px, py, lens.x, o, d);
        if (!ok) {
            *o = v3_load(c->position); /* a ray all the same, for callers that ignore the answer */
            *d = v3_norm(v3_load(c->forward));
        }
        return ok;
    }
    const float sx = px / (float)width - 0.5f, sy = 0.5f - py / (float)height;
    vec3 dir;
    int ok = camera_pinhole(c, sx, sy, o, &dir);
    if (!ok)
        dir = v3_load(c->forward); /* a direction all the same, for callers that ignore the answer */
    if (c->lens_radius > 0.0f) {
        /* thin lens: the origin moves within the lens disc, the ray still meets the pinhole ray's
         * point at the focal distance */
        const vec3 f = v3_load(c->forward);
        const vec3 focus = v3_add(*o, v3_scale(dir, c->focal_distance / v3_len(f)));
        const vec3 ex = v3_norm(v3_cross(v3_load(c->up), f)), ey = v3_norm(v3_cross(f, ex));
        const vec2 p = sample_concentric_disk(lens);
        *o = v3_add(*o, v3_scale(v3_add(v3_scale(ex, p.x), v3_scale(ey, p.y)), c->lens_radius));
        dir = v3_sub(focus, *o);
    }
    *d = v3_norm(dir);
    return ok;
}

int vbi_camera_ray(const vbnl_camera_desc *c, uint32_t width, uint32_t height, float px, float py, vec3 *o, vec3 *d)
{
    return vbi_camera_ray_lens(c, width, height, px, py, (vec2){0.5f, 0.5f}, o, d);
}
