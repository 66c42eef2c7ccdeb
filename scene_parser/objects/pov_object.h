/* vbnl: the object layer's scene model between parsing and building the core scene.
 *
 * An object is a flat list of primitives, each with its own object-to-world transform (POV-Ray
 * coordinates, kept unchanged in the core) and appearance (NULL: inherited from a CSG parent or
 * the #default in effect). Unions concatenate their children's lists; transforms of a parent
 * are composed into every primitive. Meshes are shared (reference counted) between copies. */
#ifndef VBI_POV_OBJECT_H
#define VBI_POV_OBJECT_H

#include <stddef.h>
#include <stdint.h>

#include "pov_internal.h"
#include "pov_matrix.h"

typedef struct pov_mesh {
    int refs;
    float *pos, *nrm, *uv; /* nrm, uv may be NULL */
    uint32_t nv, capv;
    uint32_t *idx;
    int32_t *ftex; /* per triangle: index into texs, -1 = the primitive's appearance; or NULL */
    uint32_t nt, capt;
    pov_appearance **texs;
    uint32_t ntex;
} pov_mesh;

enum { POV_LIGHT_POINT = 0, POV_LIGHT_SPOT, POV_LIGHT_PARALLEL };

typedef struct pov_light {
    int type;
    int cylinder;
    double pos[3], color[3], point_at[3];
    double radius, falloff, tightness;
    int area;
    double axis1[3], axis2[3];
    double fade_distance, fade_power;
    int shadowless;      /* casts no shadows (point, spot and parallel lights) */
    int no_media;        /* media_interaction off: media do not scatter its light */
} pov_light;

/* The inside of a shape that tessellates to a mesh (box, cylinder, cone, torus) or of a CSG, in
 * its primitive's object space (csg_build.c). Shared between copies (reference counted). */
typedef struct pov_solid pov_solid;

/* SKIPPED: an unsupported shape (path holds its keyword); warned about where it is placed.
 * SURFACE: an unbounded shape (a quadric, a polynomial): its solid holds its inside and makes its
 * surface where its extent becomes known (the CSG or clipped_by that bounds it, or the scene's
 * bounds when it is built). */
enum { POV_PRIM_SPHERE = 0, POV_PRIM_PLANE, POV_PRIM_MESH, POV_PRIM_LIGHT, POV_PRIM_IMPORT, POV_PRIM_SKIPPED,
       POV_PRIM_SURFACE };

typedef struct pov_prim {
    int kind;
    double m[16];        /* object space -> world (POV-Ray coordinates) */
    pov_appearance *app; /* owned; NULL = inherit */
    double a[4];         /* sphere: centre, radius; plane: normal, distance */
    pov_mesh *mesh;      /* MESH */
    pov_light light;     /* LIGHT */
    char *path;          /* IMPORT: resolved file name (owned) */
    pov_solid *solid;    /* MESH: its inside for CSG (a reference), NULL when it has none; SURFACE: the shape */
    int inverse;         /* `inverse`: inside and outside swapped (CSG) */
    int no_shadow;       /* `no_shadow`: casts no shadow (the core's VBNL_VISIBLE_NO_SHADOW) */
    vbnl_sdl_loc loc;
} pov_prim;

typedef struct pov_obj {
    pov_prim *v;
    size_t n, cap;
    pov_appearance *app; /* the object's own, handed to primitives without one when finished */
    vbnl_sdl_loc loc;
} pov_obj;

/* ---- meshes (tessellate.c) ------------------------------------------------------------------- */
pov_mesh *pov_mesh_new(void);
void pov_mesh_unref(pov_mesh *m);
/* Appends a vertex (nrm/uv may be NULL; every vertex of a mesh must then agree); returns its
 * index or UINT32_MAX when out of memory. */
uint32_t pov_mesh_vertex(pov_mesh *m, const double p[3], const double n[3], const double uv[2]);
int pov_mesh_tri(pov_mesh *m, uint32_t a, uint32_t b, uint32_t c, int32_t tex); /* 0: OOM */

/* Tessellations (segment counts in tessellate.c); NULL when out of memory. */
#define POV_SEGMENTS 64 /* around an axis */
#define POV_RINGS 32    /* pole to pole */
pov_mesh *pov_tess_sphere(const double c[3], double r);
pov_mesh *pov_tess_box(const double a[3], const double b[3]);
pov_mesh *pov_tess_cone(const double b[3], double rb, const double t[3], double rt, int open);
pov_mesh *pov_tess_disc(const double c[3], const double n[3], double r, double hole);
pov_mesh *pov_tess_torus(double major, double minor);
/* Patch of the plane n.p = d: a square of half-size `half` centred on the point of the plane
 * nearest to `centre`. */
pov_mesh *pov_tess_plane(const double n[3], double d, const double centre[3], double half);
/* Polygon with POV-Ray's sub-polygon rule (a sub-polygon closes when a vertex repeats its first
 * vertex); each sub-polygon is ear-clipped in its plane. *nested is set when a sub-polygon
 * starts inside another (POV-Ray would cut a hole; it is filled here). Ear clipping costs up to
 * O(n^3); sub-polygons of more than POV_EAR_CLIP_MAX points are fanned from their first point
 * instead (exact for convex and star-shaped ones) and *huge is set. */
#define POV_EAR_CLIP_MAX 4096
pov_mesh *pov_tess_polygon(const double *pts, int n, int *nested, int *open_last, int *huge);

/* ---- objects (object.c) --------------------------------------------------------------------- */
/* Appends a primitive (identity transform); NULL when out of memory. */
pov_prim *pov_obj_add(pov_obj *o, int kind, vbnl_sdl_loc loc);
/* Frees the primitives and the appearance and empties the object. */
void pov_obj_clear(pov_obj *o);
/* Appends deep copies of src's primitives (meshes and solids shared). 0 when out of memory. */
int pov_obj_append_copy(pov_obj *dst, const pov_obj *src);
/* Moves src's primitives into dst (src is left without primitives). 0 when out of memory. */
int pov_obj_move(pov_obj *dst, pov_obj *src);
/* Hands the object's own appearance to primitives without one (POV-Ray's CSG inheritance).
 * 0 when out of memory. */
int pov_obj_finish(pov_obj *o);
/* p' = m p for every primitive and the patterns of every appearance attached so far. */
void pov_obj_transform(pov_obj *o, const double m[16]);

/* ---- CSG (csg_build.c) ----------------------------------------------------------------- */
pov_solid *pov_solid_box(const double a[3], const double b[3]);
pov_solid *pov_solid_cone(const double base[3], double rb, const double top[3], double rt);
pov_solid *pov_solid_torus(double major, double minor);
/* The solid of a shape of shapes/: its inside test and the bounds of the region it encloses in its
 * object space (sides may be infinite). `surface` (unbounded shapes only, else NULL) makes its
 * surface within an object-space box (NULL with *why set on failure). The solid takes `data`
 * (destroy frees it, also when the solid cannot be made: NULL is then returned). */
typedef struct pov_solid_fn {
    int (*inside)(const void *data, const double q[3]);
    void (*destroy)(void *data);
    pov_mesh *(*surface)(const void *data, const double lo[3], const double hi[3], const char **why);
} pov_solid_fn;
pov_solid *pov_solid_custom(const pov_solid_fn *fn, void *data, const double lo[3], const double hi[3]);
/* 1 for the solid of an unbounded shape (it makes its own surface). */
int pov_solid_unbounded(const pov_solid *s);
/* 1 when the region a solid encloses has finite bounds. */
int pov_solid_finite(const pov_solid *s);
/* The surface of an unbounded shape placed with m within the box lo..hi of the space m maps to
 * (an empty mesh when the box misses the shape's region). NULL with *why set on failure. */
pov_mesh *pov_solid_surface(const pov_solid *s, const double m[16], const double lo[3], const double hi[3],
                            const char **why);
/* 1 when the world point p is inside the primitive (its exact inside test, `inverse` applied; 0 for
 * primitives without an inside: triangles, discs, meshes, lights). */
int pov_prim_inside(const pov_prim *pr, const double p[3]);
pov_solid *pov_solid_ref(pov_solid *s);
void pov_solid_unref(pov_solid *s);

enum { POV_CSG_INTERSECTION = 0, POV_CSG_DIFFERENCE, POV_CSG_MERGE };
/* Appends to `out` the surface of the CSG of the operands (objects whose primitives are in the
 * CSG's space, appearances handed down): mesh pieces carrying the CSG as their solid, and the
 * operands' lights, skipped shapes and imported meshes unchanged. Returns 0 with *error set on
 * failure (out of memory, or a surface of more than 2M triangles). */
int pov_csg_build(int op, const pov_obj *ops, size_t nops, pov_obj *out, const char **error);
/* The same with the surfaces of the first nsurf operands only: `clipped_by { S }` is the
 * intersection of the object and S without S's surface. */
int pov_csg_build_surfaces(int op, const pov_obj *ops, size_t nops, size_t nsurf, pov_obj *out, const char **error);
/* The CSG's solid alone: one primitive with an empty mesh whose solid is the CSG (a union of
 * shapes as one clipped_by shape). */
int pov_csg_solid(int op, const pov_obj *ops, size_t nops, pov_obj *out, const char **error);

#endif
