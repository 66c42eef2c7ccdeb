/* Scene internals shared by the integrators (private header).
 *
 * Embree ids: every geometry is attached to its group's RTCScene under its index in
 * scene->geoms, so a hit's geomID (and instID[0] for instanced hits) indexes scene->geoms
 * directly, whatever group the geometry lives in. */
#ifndef VBI_SCENE_INTERNAL_H
#define VBI_SCENE_INTERNAL_H

#include <embree3/rtcore.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif
#include <stdint.h>
#include <string.h>

#include "bsdf.h"
#include "lights.h"
#include "medium.h"
#include "sampling.h"
#include "texture/texture.h"
#include "vbnl/scene.h"
#include "vmath.h"

#define VBI_NO_LIGHT UINT32_MAX

typedef enum scene_geom_kind {
    SCENE_GEOM_MESH = 0,
    SCENE_GEOM_SPHERE = 1,
    SCENE_GEOM_INSTANCE = 2,
    SCENE_GEOM_AREA_LIGHT = 3, /* the visible quad of a rectangular area light */
} scene_geom_kind;

typedef struct scene_mesh {
    float *positions, *normals, *uvs; /* in the space of the mesh's group */
    uint32_t *indices;
    uint32_t *face_materials;         /* NULL: every face uses `material` */
    uint32_t *face_lights;            /* per-face light index or VBI_NO_LIGHT (NULL: none emissive) */
    uint32_t vertex_count, triangle_count, material;
} scene_mesh;

typedef struct scene_geom {
    scene_geom_kind kind;
    uint32_t group;
    uint32_t visibility;      /* VBNL_VISIBLE_* (vbnl_scene_set_visibility) */
    union {
        scene_mesh mesh;
        struct {
            vec3 center;
            float radius;
            uint32_t material, light;
        } sphere;
        struct {
            uint32_t group;
            mat4 xf, inv;
        } inst;
        struct {
            vec3 corner, edge_u, edge_v, normal;
            uint32_t material, light;
        } area;
    } u;
} scene_geom;

typedef struct scene_material {
    vbnl_material_desc desc;
    vbi_bsdf bsdf;
    int emissive;
    int varies;       /* the BSDF depends on the hit (a node, or a pigment): vbi_surface_bsdf
                       * resolves it there */
    int is_node;      /* a material node (vbnl_scene_add_material_node) */
    vbi_mnode node;
    uint32_t surface; /* the material whose hits this BSDF stands for: itself, or for the hidden
                       * copy of a node's leaf (made at commit) the node. VBNL lights store the
                       * material resolved at their point, and take photons from the hits of its
                       * surface (vl_support.h) */
    uint32_t origin;  /* hidden copies: the leaf material copied; others: itself */
    uint32_t hidden_begin, hidden_count; /* nodes: their hidden leaf copies in `materials` */
    int may_pass;     /* some hit may resolve to a BSDF that lets light through unchanged in
                       * direction (vbi_bsdf_is_null; set at commit) */
} scene_material;

struct vbnl_scene {
    vbnl_context *ctx;
    RTCDevice device;
    RTCScene world;
    RTCScene *group_rtc;       /* per group (index 0 = world) */
    uint32_t group_count;
    scene_geom *geoms;
    uint32_t geom_count, geom_capacity;
    scene_material *materials;
    uint32_t material_count, material_capacity;
    uint32_t user_material_count; /* at commit: the materials added, before the hidden copies */
    vbi_texture_set tex;      /* images, patterns, pigments, normals (texture/texture.h) */
    uint32_t pass_material;    /* id + 1 of the material that lets light through unchanged (made
                                * for the nodes that need it) */
    vbi_light *lights;        /* user lights first, then emitters found at commit */
    uint32_t light_count, light_capacity, user_light_count;
    vbi_alias_table light_table; /* power-based selection: photons and light paths */
    vbi_alias_table nee_table;   /* next-event estimation: by the irradiance each light gives at the
                                  * scene's centre (scene_commit.c) */
    uint32_t env_light;        /* index in lights or VBI_NO_LIGHT */
    vec3 env_radiance;
    struct vbi_env *env_sky;  /* a directional environment (environment.h) or NULL */
    int has_camera;
    vbnl_camera_desc camera;
    int committed;
    vec3 bounds_min, bounds_max;
    uint64_t triangle_count;
    /* media and fog (medium.h) */
    scene_medium *media;
    uint32_t medium_count, medium_cap;
    uint32_t atmosphere;       /* medium id + 1 filling the outside, 0 none */
    vbi_fog *fogs;
    uint32_t fog_count, fog_cap;
    float far_bound;           /* where escaped segments in sampled media end (from the camera) */
    int has_media;             /* some medium or fog: paths track their regions */
    int has_null;              /* some surface may let light through unchanged in direction (a
                                * dielectric of ior 1): shadow rays pass such surfaces */
    int has_masks;             /* some geometry has visibility flags: rays carry their kind's mask */
    float background_alpha;    /* the alpha of escaped camera rays */
};

/* Embree ray masks of the kinds of rays (geometries clear the bits of the rays that do not see
 * them: vbnl_scene_set_visibility); rays that need no distinction use VBI_RAY_ANY. */
#define VBI_RAY_CAMERA 1u
#define VBI_RAY_SHADOW 2u
#define VBI_RAY_REFLECTED 4u
#define VBI_RAY_OTHER 8u
#define VBI_RAY_NO_SHADOW_PROBE 16u /* only no_shadow geometry has this bit */
#define VBI_RAY_ANY (~VBI_RAY_NO_SHADOW_PROBE)

/* add_* calls that need an open scene: VBNL_OK, or the error naming `fn`. */
vbnl_result vbi_scene_check_open(const vbnl_scene *s, const char *fn, vbnl_error *err);
/* Commit's texture step (texture/nodes.c): which plain materials vary per hit, and each node's
 * hidden copies of the plain materials it may resolve to (appended to `materials`). */
vbnl_result vbi_texture_commit(vbnl_scene *s, vbnl_error *err);
/* The hidden copy of `leaf` that node `node` resolves to (the node itself when none). */
uint32_t vbi_material_hidden(const vbnl_scene *s, uint32_t node, uint32_t leaf);
/* The texture nodes' share of vbi_scene_fingerprint (FNV-1a continued from h). */
uint64_t vbi_texture_fingerprint(const vbnl_scene *s, uint64_t h);

/* A surface point found by a ray. */
typedef struct vbi_hit {
    float t;
    vec3 p;
    vec3 ng;          /* unit geometric normal (winding / outward side) */
    vec3 ns;          /* unit shading normal, on the same side as ng */
    vec2 uv;
    uint32_t material;
    uint32_t light;   /* emitter index or VBI_NO_LIGHT */
    uint32_t geom, prim;
} vbi_hit;

/* A single ray from o along d over (0, tfar), no hit yet: every query and the raw-rate
 * measurement start from this. */
static inline void vbi_rayhit_init(struct RTCRayHit *rh, vec3 o, vec3 d, float tfar)
{
    rh->ray.org_x = o.x;
    rh->ray.org_y = o.y;
    rh->ray.org_z = o.z;
    rh->ray.dir_x = d.x;
    rh->ray.dir_y = d.y;
    rh->ray.dir_z = d.z;
    rh->ray.tnear = 0.0f;
    rh->ray.tfar = tfar;
    rh->ray.time = 0.0f;
    rh->ray.mask = 0xffffffffu;
    rh->ray.id = 0;
    rh->ray.flags = 0;
    rh->hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
}

/* Lane k of an 8-wide packet: vbi_rayhit_init for that lane (id = k). */
static inline void vbi_rayhit8_set(struct RTCRayHit8 *rh, unsigned k, vec3 o, vec3 d, float tfar)
{
    rh->ray.org_x[k] = o.x;
    rh->ray.org_y[k] = o.y;
    rh->ray.org_z[k] = o.z;
    rh->ray.dir_x[k] = d.x;
    rh->ray.dir_y[k] = d.y;
    rh->ray.dir_z[k] = d.z;
    rh->ray.tnear[k] = 0.0f;
    rh->ray.tfar[k] = tfar;
    rh->ray.time[k] = 0.0f;
    rh->ray.mask[k] = 0xffffffffu;
    rh->ray.id[k] = k;
    rh->ray.flags[k] = 0;
    rh->hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
    rh->hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
}

/* Rays i0 .. min(i0 + 8, end) - 1 of the arrays (o, d) as one packet (vbi_rayhit8_set, tfar
 * infinite); lanes past `end` repeat ray i0 and are off in `valid`. */
static inline void vbi_rayhit8_fill(struct RTCRayHit8 *rh, int valid[8], const vec3 *o, const vec3 *d, uint32_t i0,
                                     uint32_t end)
{
    for (uint32_t k = 0; k < 8; ++k) {
        uint32_t i = i0 + k < end ? i0 + k : i0;
        valid[k] = i0 + k < end ? -1 : 0;
        vbi_rayhit8_set(rh, k, o[i], d[i], INFINITY);
    }
}

/* The mesh part of a hit's set-up (vbi_fill_hit below; inline also in the photon walk,
 * photon_fast.h): normals, uv, material and light of triangle `prim` at barycentrics (bu, bv),
 * from Embree's unnormalised geometric normal e_ng ((p1 - p0) x (p2 - p0), the scene's winding),
 * in the mesh's own space. t, p, geom and prim are the caller's. */
static inline __attribute__((always_inline)) void vbi_fill_mesh_hit(const scene_mesh *m, uint32_t prim, float bu,
                                                                     float bv, vec3 e_ng, vbi_hit *h)
{
    const uint32_t *tri = m->indices + 3 * (size_t)prim;
    vec3 ng = v3_norm(e_ng), ns = ng;
    float b0 = 1.0f - bu - bv;
    if (m->normals) {
        ns = v3_add(v3_add(v3_scale(v3_load(m->normals + 3 * tri[0]), b0), v3_scale(v3_load(m->normals + 3 * tri[1]), bu)),
                    v3_scale(v3_load(m->normals + 3 * tri[2]), bv));
        ns = v3_norm(ns);
        if (!(v3_len2(ns) > 0.5f))
            ns = ng;
        /* pbrt: with shading normals, the geometric normal follows their side */
        if (v3_dot(ng, ns) < 0.0f)
            ng = v3_neg(ng);
    }
    h->uv = (vec2){bu, bv};
    if (m->uvs) {
        const float *uv = m->uvs;
        h->uv = (vec2){b0 * uv[2 * tri[0]] + bu * uv[2 * tri[1]] + bv * uv[2 * tri[2]],
                       b0 * uv[2 * tri[0] + 1] + bu * uv[2 * tri[1] + 1] + bv * uv[2 * tri[2] + 1]};
    }
    h->material = m->face_materials ? m->face_materials[prim] : m->material;
    h->light = m->face_lights ? m->face_lights[prim] : VBI_NO_LIGHT;
    h->ng = ng;
    h->ns = ns;
}

/* The whole set-up of a hit from Embree's answer (geometry, primitive, instance, barycentrics,
 * distance, the ray, and Embree's geometric normal e_ng, unnormalised, object space: for
 * triangles (p1 - p0) x (p2 - p0), the orientation the scene's winding gives, without reloading
 * the vertices). Inlined into each query: a call with eleven arguments cost a fifth of its body. */
static inline __attribute__((always_inline)) void vbi_fill_hit(const vbnl_scene *s, unsigned geom_id,
                                                                unsigned prim_id, unsigned inst_id, float bu,
                                                                float bv, float t, vec3 o, vec3 d, vec3 e_ng,
                                                                vbi_hit *h)
{
    h->t = t;
    h->p = v3_fma(o, d, t);
    h->geom = geom_id;
    h->prim = prim_id;
    h->light = VBI_NO_LIGHT;
    h->uv = (vec2){bu, bv};
    const scene_geom *g = &s->geoms[geom_id];
    const mat4 *xf = NULL;
    vec3 po = h->p;
    if (inst_id != RTC_INVALID_GEOMETRY_ID) {
        const scene_geom *ig = &s->geoms[inst_id];
        xf = &ig->u.inst.xf;
        po = mat4_point(&ig->u.inst.inv, h->p);
    }
    vec3 ng, ns;
    switch (g->kind) {
    case SCENE_GEOM_MESH:
        vbi_fill_mesh_hit(&g->u.mesh, prim_id, bu, bv, e_ng, h);
        ng = h->ng;
        ns = h->ns;
        break;
    case SCENE_GEOM_SPHERE: {
        vec3 n = v3_scale(v3_sub(po, g->u.sphere.center), 1.0f / g->u.sphere.radius);
        ng = ns = v3_norm(n);
        h->uv = (vec2){(atan2f(ng.y, ng.x) + VBI_PI) * VBI_INV_2PI, acosf(clampf(ng.z, -1.0f, 1.0f)) * VBI_INV_PI};
        h->material = g->u.sphere.material;
        h->light = g->u.sphere.light;
        /* re-project onto the surface: removes the error of o + t d far from the origin */
        if (!xf)
            h->p = v3_fma(g->u.sphere.center, ng, g->u.sphere.radius);
        break;
    }
    case SCENE_GEOM_AREA_LIGHT:
    default:
        ng = ns = g->u.area.normal;
        h->material = g->u.area.material;
        h->light = g->u.area.light;
        break;
    }
    if (xf) {
        ng = v3_norm(mat4_normal(xf, ng));
        ns = v3_norm(mat4_normal(xf, ns));
    }
    h->ng = ng;
    h->ns = ns;
}

/* vbi_scene_intersect and vbi_scene_occluded inline, for loops that trace a ray per bounce
 * (the path tracer): without the call, the hit is filled in the caller's frame and the caller's
 * live floats need not be saved around a second call level. */
static inline __attribute__((always_inline)) int vbi_scene_intersect_mask(const vbnl_scene *s, vec3 o, vec3 d,
                                                                           float tfar, uint32_t mask, vbi_hit *hit)
{
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    struct RTCRayHit rh;
    vbi_rayhit_init(&rh, o, d, tfar);
    rh.ray.mask = mask;
    rtcIntersect1(s->world, &ictx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID)
        return 0;
    vbi_fill_hit(s, rh.hit.geomID, rh.hit.primID, rh.hit.instID[0], rh.hit.u, rh.hit.v, rh.ray.tfar, o, d,
                  v3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z), hit);
    return 1;
}

static inline __attribute__((always_inline)) int vbi_scene_intersect_inline(const vbnl_scene *s, vec3 o, vec3 d,
                                                                             float tfar, vbi_hit *hit)
{
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    struct RTCRayHit rh;
    vbi_rayhit_init(&rh, o, d, tfar);
    rtcIntersect1(s->world, &ictx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID)
        return 0;
    vbi_fill_hit(s, rh.hit.geomID, rh.hit.primID, rh.hit.instID[0], rh.hit.u, rh.hit.v, rh.ray.tfar, o, d,
                  v3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z), hit);
    return 1;
}

static inline __attribute__((always_inline)) int vbi_scene_occluded_mask(const vbnl_scene *s, vec3 o, vec3 d,
                                                                          float tfar, uint32_t mask)
{
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    struct RTCRay ray;
    ray.org_x = o.x;
    ray.org_y = o.y;
    ray.org_z = o.z;
    ray.dir_x = d.x;
    ray.dir_y = d.y;
    ray.dir_z = d.z;
    ray.tnear = 0.0f;
    ray.tfar = tfar;
    ray.time = 0.0f;
    ray.mask = mask;
    ray.id = 0;
    ray.flags = 0;
    rtcOccluded1(s->world, &ictx, &ray);
    return ray.tfar == -INFINITY;
}

static inline __attribute__((always_inline)) int vbi_scene_occluded_inline(const vbnl_scene *s, vec3 o, vec3 d,
                                                                            float tfar)
{
    return vbi_scene_occluded_mask(s, o, d, tfar, 0xffffffffu);
}

/* Distance to the closest hit along o + t d for t in (0, tfar), or tfar for a miss (the hit
 * itself is not filled in). */
static inline float vbi_scene_hit_distance(const vbnl_scene *s, vec3 o, vec3 d, float tfar)
{
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    struct RTCRayHit rh;
    vbi_rayhit_init(&rh, o, d, tfar);
    rtcIntersect1(s->world, &ictx, &rh);
    return rh.hit.geomID == RTC_INVALID_GEOMETRY_ID ? tfar : rh.ray.tfar;
}

/* Closest hit along o + t d for t in (0, tfar). Returns 1 and fills *hit, or 0 for a miss. */
int vbi_scene_intersect(const vbnl_scene *s, vec3 o, vec3 d, float tfar, vbi_hit *hit);
/* 1 when something blocks o + t d for t in (0, tfar). */
int vbi_scene_occluded(const vbnl_scene *s, vec3 o, vec3 d, float tfar);
/* Closest hits of up to 8 coherent rays (primary rays) as one Embree packet. Lanes with
 * active[i] == 0 are ignored; hit_mask[i] is set to 1 for lanes that hit. */
void vbi_scene_intersect8(const vbnl_scene *s, const int active[8], const vec3 o[8],
                           const vec3 d[8], vbi_hit hits[8], int hit_mask[8]);
/* The same with a ray mask (VBI_RAY_*). */
void vbi_scene_intersect8_mask(const vbnl_scene *s, const int active[8], const vec3 o[8], const vec3 d[8],
                                uint32_t mask, vbi_hit hits[8], int hit_mask[8]);

/* A surface whose BSDF lets light through unchanged in direction (a dielectric of ior 1: POV-Ray's
 * transmit and filter without refraction): light passes it with the BSDF's tint. */
static inline int vbi_bsdf_is_null(const vbi_bsdf *b)
{
    /* (a dielectric with a reflectance curve reflects even at ior 1: vbnl_material_desc.coat_curve) */
    return b->type == VBNL_MATERIAL_DIELECTRIC && b->ior == 1.0f && b->coat_curve == VBNL_COAT_DIELECTRIC;
}
/* A smooth dielectric of ior 1, with or without a reflectance curve: a shadow ray to a delta light
 * passes it straight, weighted by vbi_bsdf_pass_weight (no path can reach such a light, so next-
 * event estimation alone counts what crosses a reflecting one). */
static inline int vbi_bsdf_passes_straight(const vbi_bsdf *b)
{
    return b->type == VBNL_MATERIAL_DIELECTRIC && b->ior == 1.0f;
}

/* The BSDF at a surface hit. Every integrator asks for the BSDF at a hit through this one
 * function: a plain material's BSDF; for a material that varies over the surface (a pigment, a
 * material node) the BSDF resolved at the hit (texture/material.c: the material chosen there,
 * its colour, its perturbed shading normal), written into *storage. */
void vbi_surface_bsdf_resolve(const vbnl_scene *s, const vbi_hit *hit, vbi_bsdf *storage);
static inline const vbi_bsdf *vbi_surface_bsdf(const vbnl_scene *s, const vbi_hit *hit,
                                                 vbi_bsdf *storage)
{
    const scene_material *m = &s->materials[hit->material];
    if (!m->varies)
        return &m->bsdf;
    vbi_surface_bsdf_resolve(s, hit, storage);
    return storage;
}

/* What a virtual light on the surface at a hit must remember: the material whose BSDF it uses
 * (for a node, the hidden copy of the leaf chosen there, whose `surface` is the node) and the
 * colour factor its BSDF carries there (1 for plain materials). */
uint32_t vbi_surface_light_material(const vbnl_scene *s, const vbi_hit *hit, vec3 *tint);
/* The material whose hits a BSDF of material m stands for (scene_material.surface). */
static inline uint32_t vbi_material_surface(const vbnl_scene *s, uint32_t m) { return s->materials[m].surface; }

static inline float vbi_int_as_float(int32_t i)
{
    float f;
    memcpy(&f, &i, sizeof(f));
    return f;
}
static inline int32_t vbi_float_as_int(float f)
{
    int32_t i;
    memcpy(&i, &f, sizeof(i));
    return i;
}

/* Offsets a ray origin off the surface along the geometric normal n, which must already point
 * to the side the ray leaves on (Waechter & Binder, Ray Tracing Gems ch. 6): robust without a
 * scene-scale epsilon. Inline: every bounce and shadow ray calls it; with SSE2 the three
 * components go at once (the same operations lane by lane: truncating conversion, integer
 * step, select). */
static inline vec3 vbi_offset_ray_origin_along(vec3 p, vec3 n)
{
    const float origin = 1.0f / 32.0f, float_scale = 1.0f / 65536.0f, int_scale = 256.0f;
#ifdef __SSE2__
    const __m128 P = _mm_setr_ps(p.x, p.y, p.z, 0.0f), N = _mm_setr_ps(n.x, n.y, n.z, 0.0f);
    __m128i of = _mm_cvttps_epi32(_mm_mul_ps(_mm_set1_ps(int_scale), N));
    __m128i neg = _mm_castps_si128(_mm_cmplt_ps(P, _mm_setzero_ps())); /* p < 0: step by -of */
    of = _mm_sub_epi32(_mm_xor_si128(of, neg), neg);
    __m128 pi = _mm_castsi128_ps(_mm_add_epi32(_mm_castps_si128(P), of));
    __m128 pf = _mm_add_ps(P, _mm_mul_ps(_mm_set1_ps(float_scale), N));
    __m128 absP = _mm_andnot_ps(_mm_set1_ps(-0.0f), P);
    __m128 small = _mm_cmplt_ps(absP, _mm_set1_ps(origin));
    __m128 r = _mm_or_ps(_mm_and_ps(small, pf), _mm_andnot_ps(small, pi));
    float out[4];
    _mm_storeu_ps(out, r);
    return v3(out[0], out[1], out[2]);
#else
    float pc[3] = {p.x, p.y, p.z}, nc[3] = {n.x, n.y, n.z}, out[3];
    for (int i = 0; i < 3; ++i) {
        int32_t of = (int32_t)(int_scale * nc[i]);
        float pi = vbi_int_as_float(vbi_float_as_int(pc[i]) + (pc[i] < 0.0f ? -of : of));
        out[i] = fabsf(pc[i]) < origin ? pc[i] + float_scale * nc[i] : pi;
    }
    return v3(out[0], out[1], out[2]);
#endif
}

/* The same for a ray leaving along w, whichever side n points to. */
static inline vec3 vbi_offset_ray_origin(vec3 p, vec3 n, vec3 w)
{
    if (v3_dot(n, w) < 0.0f)
        n = v3_neg(n);
    return vbi_offset_ray_origin_along(p, n);
}

/* Camera ray through image point (px, py) in pixels (continuous; row 0 at the top), through the
 * point `lens` of the unit square mapped onto the lens disc (vbnl_camera_desc). Returns 0 where the
 * projection has no ray (the fisheye's corners): the sample then sees nothing and is transparent
 * black; o and d still hold a valid ray for callers that only need one. */
int vbi_camera_ray_lens(const vbnl_camera_desc *c, uint32_t width, uint32_t height, float px, float py, vec2 lens,
                         vec3 *o, vec3 *d);
/* The same through the centre of the lens (the pinhole ray). */
int vbi_camera_ray(const vbnl_camera_desc *c, uint32_t width, uint32_t height, float px, float py, vec3 *o, vec3 *d);

/* Picks a light by power; *pmf receives its selection probability. */
/* 64-bit FNV-1a fingerprint of a committed scene: geometry (positions, normals, uvs, indices,
 * per-face materials, spheres, area-light quads, instance transforms and groups), material
 * descriptions, textures, lights (the user's and the emitters found at commit) and the environment.
 * Floats are hashed by their bits, so any change of the input changes it (with probability
 * 1 - 2^-64) and equal inputs give equal values on every run and thread count.
 * The camera is left out on purpose: a prepared virtual-light set (vl_file.h) is a valid
 * description of the scene's indirect light from any viewpoint (the camera only decided where
 * the lights are densest), so a set prepared for one view may be reused from another.
 * 0 for NULL or an uncommitted scene. */
uint64_t vbi_scene_fingerprint(const vbnl_scene *s);

/* Picks a light by power (photons and light paths: each then carries the same share of the
 * scene's power). */
static inline uint32_t vbi_scene_pick_light(const vbnl_scene *s, float u, float *pmf)
{
    return vbi_alias_table_sample(&s->light_table, u, pmf);
}
/* Picks a light for next-event estimation (nee_table), returning in *rest u rescaled within the
 * picked light's share of [0,1) (vbi_alias_table_sample_reuse). */
static inline uint32_t vbi_scene_pick_light_reuse(const vbnl_scene *s, float u, float *pmf, float *rest)
{
    return vbi_alias_table_sample_reuse(&s->nee_table, u, pmf, rest);
}
/* The probability that next-event estimation picks `light` (for MIS with BSDF sampling). */
static inline float vbi_scene_light_pmf(const vbnl_scene *s, uint32_t light)
{
    return s->nee_table.pmf[light];
}

#endif
