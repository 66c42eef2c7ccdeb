/* vbnl object layer: mesh { triangle { ... [texture { T }] } smooth_triangle { ... }
 * [inside_vector V] modifiers }. */
#include <stdlib.h>
#include <string.h>

#include "pov_shape.h"

typedef struct mesh_tri {
    double v[3][3], n[3][3], uv[3][2]; /* uv: zero unless given */
    int smooth;
    int32_t tex; /* index in the mesh's textures, -1: the object's appearance */
} mesh_tri;

typedef struct mesh_build {
    pov_loader *L;
    pov_mesh *m;
    mesh_tri *tris;
    size_t nt, cap;
    int any_smooth, any_uv;
} mesh_build;

static const pov_row inside_vector_rows[] = {{"inside_vector", pov_item_any_vec3, 0}, {NULL, NULL, 0}};
static const pov_row *const inside_vector_tables[] = {inside_vector_rows, NULL};
const pov_block pov_inside_vector_block = {.tables = inside_vector_tables};

/* ---- a triangle's items ------------------------------------------------------------------------ */

/* Per-triangle uv_vectors (uv_mapping, the mesh camera); the mesh's other triangles get (0, 0). */
static vbnl_result tri_uv_vectors(const pov_item *it)
{
    mesh_build *mb = it->target;
    mesh_tri *tr = &mb->tris[mb->nt - 1];
    vbnl_sdl_next(it->p);
    for (int k = 0; k < 3; ++k) {
        if (k)
            pov_comma(mb->L);
        if (vbnl_sdl_parse_vector(it->p, 2, tr->uv[k]) != VBNL_OK)
            return VBNL_ERR_PARSE;
    }
    mb->any_uv = 1;
    return VBNL_OK;
}

static vbnl_result tri_texture(const pov_item *it)
{
    mesh_build *mb = it->target;
    pov_mesh *m = mb->m;
    pov_appearance *a = NULL;
    if (pov_appearance_parse_modifier(&mb->L->c, &a) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_appearance **nx = realloc(m->texs, (m->ntex + 1) * sizeof *nx);
    if (!nx) {
        pov_appearance_free(a);
        return pov_oom(mb->L);
    }
    m->texs = nx;
    m->texs[m->ntex] = a;
    mb->tris[mb->nt - 1].tex = (int32_t)m->ntex++;
    return VBNL_OK;
}

static const pov_row tri_rows[] = {
    {"uv_vectors", tri_uv_vectors, 0},
    {"texture", tri_texture, 0},
    {"texture_list", tri_texture, 0},
    {NULL, NULL, 0},
};
static const pov_row *const tri_tables[] = {tri_rows, NULL};
static const pov_block tri_block = {.tables = tri_tables};

static vbnl_result mesh_triangle(const pov_item *it)
{
    mesh_build *mb = it->target;
    int smooth = it->kw[0] == 's';
    vbnl_sdl_next(it->p);
    if (mb->nt == mb->cap) {
        size_t cap = mb->cap ? 2 * mb->cap : 64;
        mesh_tri *n = realloc(mb->tris, cap * sizeof *n);
        if (!n)
            return pov_oom(mb->L);
        mb->tris = n;
        mb->cap = cap;
    }
    mesh_tri *tr = &mb->tris[mb->nt++];
    memset(tr, 0, sizeof *tr);
    tr->smooth = smooth;
    tr->tex = -1;
    mb->any_smooth |= smooth;
    if (vbnl_sdl_expect(it->p, '{', smooth ? "after 'smooth_triangle'" : "after 'triangle'") != VBNL_OK ||
        pov_triangle_values(mb->L, smooth, tr->v, tr->n) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_triangle_normals(tr->v, tr->n, smooth);
    return pov_block_parse(&tri_block, it->p, mb->L, mb, it->kw);
}

static const pov_row mesh_rows[] = {
    {"triangle", mesh_triangle, 0},
    {"smooth_triangle", mesh_triangle, 0},
    {NULL, NULL, 0},
};
static const pov_row *const mesh_tables[] = {mesh_rows, NULL};
static const pov_block mesh_block = {.tables = mesh_tables};

/* ---- the mesh ---------------------------------------------------------------------------------- */

static vbnl_result mesh_make(const pov_shape *s, mesh_build *mb)
{
    for (size_t i = 0; i < mb->nt; ++i) {
        uint32_t id[3];
        for (int k = 0; k < 3; ++k)
            id[k] = pov_mesh_vertex(mb->m, mb->tris[i].v[k], mb->any_smooth ? mb->tris[i].n[k] : NULL,
                                    mb->any_uv ? mb->tris[i].uv[k] : NULL);
        if (!pov_mesh_tri(mb->m, id[0], id[1], id[2], mb->tris[i].tex))
            return pov_oom(s->L);
    }
    if (mb->nt == 0)
        vbnl_sdl_warning(s->L->c.parser, &s->loc, "mesh without triangles");
    vbnl_result r = pov_shape_add_mesh(s, mb->m);
    mb->m = NULL;
    return r;
}

vbnl_result pov_shape_mesh(const pov_shape *s)
{
    vbnl_sdl_parser *p = s->L->c.parser;
    /* mesh { ID modifiers }: a copy of a declared object, as object { ID } (POV-Ray takes one here;
     * the mesh_camera scenes write mesh { camera_mesh texture { ... } }) */
    if (pov_declared(s->L, vbnl_sdl_peek(p), &pov_object_type))
        return pov_shape_object(s);
    mesh_build mb = {s->L, pov_mesh_new(), NULL, 0, 0, 0, 0};
    if (!mb.m)
        return pov_oom(s->L);
    vbnl_result r = pov_block_prefix(&mesh_block, p, s->L, &mb);
    if (r == VBNL_OK)
        r = mesh_make(s, &mb);
    free(mb.tris);
    pov_mesh_unref(mb.m);
    if (r != VBNL_OK || pov_block_prefix(&pov_inside_vector_block, p, s->L, NULL) != VBNL_OK)
        return VBNL_ERR_PARSE;
    return pov_shape_modifiers(s);
}
