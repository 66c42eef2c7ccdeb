/* Small scenes built through the public API, shared by the tests (header-only). */
#ifndef VBI_TEST_SCENES_H
#define VBI_TEST_SCENES_H

#include <string.h>

#include "vbnl/vbnl.h"

/* A context of `threads` workers (0: one per core); NULL when it cannot be made. */
static inline vbnl_context *ts_context(unsigned threads)
{
    vbnl_context_desc d;
    vbnl_context_desc_init(&d);
    d.threads = threads;
    vbnl_context *ctx = NULL;
    return vbnl_context_create(&d, &ctx, NULL) == VBNL_OK ? ctx : NULL;
}

static inline uint32_t ts_material(vbnl_scene *s, vbnl_material_type type, float r, float g, float b,
                                   float emit)
{
    vbnl_material_desc d;
    vbnl_material_desc_init(&d);
    d.type = type;
    d.base_color[0] = r;
    d.base_color[1] = g;
    d.base_color[2] = b;
    d.emission[0] = d.emission[1] = d.emission[2] = emit;
    uint32_t id = 0;
    vbnl_scene_add_material(s, &d, &id, NULL);
    return id;
}

/* Quad p0,p1,p2,p3 (counter-clockwise seen from the front). */
static inline void ts_quad(vbnl_scene *s, const float p[12], uint32_t material)
{
    static const uint32_t idx[6] = {0, 1, 2, 0, 2, 3};
    vbnl_mesh_desc m;
    vbnl_mesh_desc_init(&m);
    m.positions = p;
    m.vertex_count = 4;
    m.indices = idx;
    m.triangle_count = 2;
    m.material = material;
    vbnl_scene_add_mesh(s, &m, NULL, NULL);
}

/* The six walls of the box [-1,1]x[0,2]x[-1,1], with materials m: floor, ceiling, back (z = -1),
 * front, left (x = -1), right. */
static inline void ts_room_walls(vbnl_scene *s, const uint32_t m[6])
{
    static const float walls[6][12] = {
        {-1, 0, -1, -1, 0, 1, 1, 0, 1, 1, 0, -1}, {-1, 2, -1, 1, 2, -1, 1, 2, 1, -1, 2, 1},
        {-1, 0, -1, 1, 0, -1, 1, 2, -1, -1, 2, -1}, {-1, 0, 1, -1, 2, 1, 1, 2, 1, 1, 0, 1},
        {-1, 0, -1, -1, 2, -1, -1, 2, 1, -1, 0, 1}, {1, 0, -1, 1, 0, 1, 1, 2, 1, 1, 2, -1},
    };
    for (int i = 0; i < 6; ++i)
        ts_quad(s, walls[i], m[i]);
}

/* A 0.5 x 0.5 light just under the ceiling of that box, of radiance le. */
static inline void ts_room_light(vbnl_scene *s, const float le[3])
{
    vbnl_area_light_desc al;
    vbnl_area_light_desc_init(&al);
    const float corner[3] = {-0.25f, 1.98f, -0.25f}, eu[3] = {0.5f, 0, 0}, ev[3] = {0, 0, 0.5f};
    memcpy(al.corner, corner, sizeof(corner));
    memcpy(al.edge_u, eu, sizeof(eu));
    memcpy(al.edge_v, ev, sizeof(ev));
    memcpy(al.radiance, le, sizeof(al.radiance));
    vbnl_scene_add_area_light(s, &al, NULL, NULL);
}

/* A closed Cornell-like box [-1,1]x[0,2]x[-1,1] (open side closed too) with a ceiling light of
 * radiance `Le`, camera at (0,1,0.9) looking at -z. Not committed. */
static inline vbnl_scene *ts_box_scene(vbnl_context *ctx, float aspect)
{
    vbnl_scene *s = NULL;
    vbnl_scene_create(ctx, &s, NULL);
    uint32_t white = ts_material(s, VBNL_MATERIAL_LAMBERT, 0.73f, 0.71f, 0.68f, 0.0f);
    uint32_t red = ts_material(s, VBNL_MATERIAL_LAMBERT, 0.63f, 0.065f, 0.05f, 0.0f);
    uint32_t green = ts_material(s, VBNL_MATERIAL_LAMBERT, 0.14f, 0.45f, 0.091f, 0.0f);
    uint32_t glossy = 0;
    {
        vbnl_material_desc d;
        vbnl_material_desc_init(&d);
        d.type = VBNL_MATERIAL_PLASTIC;
        d.alpha = 0.2f;
        vbnl_scene_add_material(s, &d, &glossy, NULL);
    }
    const uint32_t walls[6] = {glossy, white, white, white, red, green};
    ts_room_walls(s, walls);
    const float c[3] = {0.3f, 0.4f, -0.3f};
    uint32_t metal;
    {
        vbnl_material_desc d;
        vbnl_material_desc_init(&d);
        d.type = VBNL_MATERIAL_CONDUCTOR;
        d.alpha = 0.3f;
        vbnl_scene_add_material(s, &d, &metal, NULL);
    }
    vbnl_scene_add_sphere(s, c, 0.4f, metal, VBNL_GROUP_WORLD, NULL, NULL);
    const float le[3] = {17.0f, 12.0f, 4.0f};
    ts_room_light(s, le);
    float pos[3] = {0, 1, 0.9f}, target[3] = {0, 1, -1}, up[3] = {0, 1, 0};
    vbnl_camera_desc cam;
    vbnl_camera_look_at(&cam, pos, target, up, 70.0f, aspect, NULL);
    vbnl_scene_set_camera(s, &cam, NULL);
    return s;
}

#endif
