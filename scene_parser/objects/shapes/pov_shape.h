/* vbnl object layer: the shapes. Each family of shapes is one file of this folder; the table in
 * shapes.c maps every keyword to its parser. Adding a shape is a file with its parser and one
 * row in that table (and, for a shape listed as unsupported, removing it from that list). */
#ifndef VBI_POV_SHAPE_H
#define VBI_POV_SHAPE_H

#include "pov_loader.h"

/* The shape being read: its keyword and the '{' after it are consumed. */
typedef struct pov_shape {
    pov_loader *L;
    pov_obj *o;          /* the object the shape adds its primitives to */
    const char *keyword; /* interned */
    vbnl_sdl_loc loc;    /* of the keyword */
} pov_shape;

/* Reads the rest of the shape, up to and including its closing '}'; most shapes read their own
 * values and end with pov_shape_modifiers. */
typedef vbnl_result (*pov_shape_fn)(const pov_shape *s);

typedef struct pov_shape_row {
    const char *keyword;
    pov_shape_fn parse;
} pov_shape_row;

/* The row of a supported shape keyword, or NULL. */
const pov_shape_row *pov_shape_find(const char *keyword);
/* 1 for the POV-Ray shapes that are parsed (their block skipped) and left out with a warning. */
int pov_shape_unsupported(const char *keyword);

/* A simple shape's modifiers to the closing '}', clipped_by applied at the end. */
vbnl_result pov_shape_modifiers(const pov_shape *s);
/* Appends a mesh primitive (takes m; NULL m reports out of memory). */
vbnl_result pov_shape_add_mesh(const pov_shape *s, pov_mesh *m);
/* `<v>, f` (sphere: centre, radius; plane: normal, distance). */
vbnl_result pov_shape_vector_float(const pov_shape *s, double v[3], double *f);
/* Appends an analytic primitive with a = (v, f), then reads the modifiers. */
vbnl_result pov_shape_add_analytic(const pov_shape *s, int kind, const double v[3], double f);

/* Simple shapes made once per load (shape_cache.c), so that equal CSGs of them are shared too:
 * the mesh and solid of kind with these parameters (references taken) when made before. */
int pov_shape_cache_find(pov_loader *L, const char *kind, const double *params, int n, pov_mesh **mesh,
                         pov_solid **solid);
void pov_shape_cache_keep(pov_loader *L, const char *kind, const double *params, int n, pov_mesh *mesh, pov_solid *solid);

/* The parsers (one file each unless noted). */
vbnl_result pov_shape_sphere(const pov_shape *s);
vbnl_result pov_shape_box(const pov_shape *s);
vbnl_result pov_shape_plane(const pov_shape *s);
vbnl_result pov_shape_cone(const pov_shape *s);     /* cone and cylinder (cone.c) */
vbnl_result pov_shape_disc(const pov_shape *s);
vbnl_result pov_shape_torus(const pov_shape *s);
vbnl_result pov_shape_triangle(const pov_shape *s); /* triangle and smooth_triangle (triangle.c) */
vbnl_result pov_shape_polygon(const pov_shape *s);
vbnl_result pov_shape_mesh(const pov_shape *s);
vbnl_result pov_shape_mesh2(const pov_shape *s);
vbnl_result pov_shape_vbnl_mesh(const pov_shape *s);
vbnl_result pov_shape_object(const pov_shape *s);
vbnl_result pov_shape_csg(const pov_shape *s);      /* intersection, difference, merge (csg.c) */
vbnl_result pov_shape_union(const pov_shape *s);    /* union and light_group (union.c) */
vbnl_result pov_shape_light(const pov_shape *s);    /* light_source (../light.c) */
vbnl_result pov_shape_text(const pov_shape *s);
vbnl_result pov_shape_poly(const pov_shape *s);     /* poly polynomial cubic quartic quadric (poly.c) */
vbnl_result pov_shape_isosurface(const pov_shape *s);
vbnl_result pov_shape_parametric(const pov_shape *s);
vbnl_result pov_shape_lathe(const pov_shape *s);    /* lathe and sor (lathe.c) */
vbnl_result pov_shape_prism(const pov_shape *s);
vbnl_result pov_shape_height_field(const pov_shape *s);
vbnl_result pov_shape_blob(const pov_shape *s);
vbnl_result pov_shape_superellipsoid(const pov_shape *s);
vbnl_result pov_shape_julia(const pov_shape *s);    /* julia_fractal (julia.c) */
vbnl_result pov_shape_bicubic(const pov_shape *s);  /* bicubic_patch (bicubic.c) */
vbnl_result pov_shape_ovus(const pov_shape *s);     /* ovus and lemon (ovus.c) */
vbnl_result pov_shape_sphere_sweep(const pov_shape *s);

/* triangle.c, for mesh { }: a triangle's values after its '{' and its normals made unit (a
 * flat triangle gets its face normal; a degenerate one +y). */
vbnl_result pov_triangle_values(pov_loader *L, int smooth, double v[3][3], double n[3][3]);
void pov_triangle_normals(double v[3][3], double n[3][3], int smooth);

/* mesh.c, for mesh2 { }: `inside_vector V` items (read and dropped: CSG uses no inside of a mesh). */
extern const pov_block pov_inside_vector_block;

#endif
