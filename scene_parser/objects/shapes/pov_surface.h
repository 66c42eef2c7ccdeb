/* vbnl object layer: what the curved shapes share. Every POV-Ray shape is turned into triangles
 * (the core traces triangle meshes and spheres; CSG, the VBNL placement and the photon stages
 * work on them unchanged), with vertices on the exact surface, the exact surface normal at every
 * vertex, and an error bound: no point of an edge's midpoint lies further than the tolerance from
 * the surface (docs/scene-language.md, "How shapes are traced").
 *
 *   refine.c     triangle lists on a surface, refined edge by edge to the tolerance
 *   implicit.c   surfaces f(p) = 0 (polynomials, blobs, isosurfaces, superellipsoids, fractals)
 *   outline.c    closed 2D outlines: flattening, caps, extrusion (prism, text)
 *   revolve.c    surfaces of revolution of a profile (lathe, sor, ovus, lemon)
 *   shape_solid.c  the shapes' inside tests as CSG solids, and the deferred shapes' blocks */
#ifndef VBI_POV_SURFACE_H
#define VBI_POV_SURFACE_H

#include "pov_shape.h"

/* The chord error allowed, as a fraction of a shape's bounding radius: 1e-3 keeps silhouettes
 * within half a pixel at 1080p for a shape that fills the frame's height. */
#define POV_TESS_TOL 1e-3
/* At most this many triangles per shape: refinement stops there (a warning says so). */
#define POV_TESS_MAX_TRIANGLES 4000000u

/* ---- a hash table of 64-bit keys to 32-bit values (refine.c) ------------------------------------ */

typedef struct pov_hmap {
    uint64_t *keys; /* key + 1; 0 = empty */
    uint32_t *vals;
    size_t cap, n;
} pov_hmap;
/* The value of key, inserted as UINT32_MAX (*isnew set) when absent; NULL when out of memory.
 * The pointer stays valid until the next insertion. */
uint32_t *pov_hmap_at(pov_hmap *m, uint64_t key, int *isnew);
void pov_hmap_free(pov_hmap *m);

/* ---- triangle lists on a surface (refine.c) -------------------------------------------------- */

typedef struct pov_svert {
    double p[3], n[3]; /* position, unit outward normal */
    double uv[2];      /* texture coordinates (uv_mapping) */
    double s[2];       /* the surface's own parameters (refinement of parametric surfaces) */
} pov_svert;

typedef struct pov_smesh {
    pov_svert *v;
    uint32_t nv, capv;
    uint32_t *t; /* 3 per triangle, counter-clockwise seen from outside */
    uint32_t nt, capt;
    int oom;     /* an allocation failed: the list is incomplete */
    int capped;  /* refinement stopped at POV_TESS_MAX_TRIANGLES */
} pov_smesh;

uint32_t pov_smesh_vert(pov_smesh *m, const pov_svert *v); /* UINT32_MAX (and oom) when out of memory */
void pov_smesh_tri(pov_smesh *m, uint32_t a, uint32_t b, uint32_t c);
/* The triangle wound so that its face normal agrees with its vertices' normals. */
void pov_smesh_tri_facing(pov_smesh *m, uint32_t a, uint32_t b, uint32_t c);
void pov_smesh_free(pov_smesh *m);

/* The point of the surface that the edge a-b should pass through (a parametric surface's point
 * at the mean parameters, an implicit surface's point nearest the chord's midpoint). 1: *out set;
 * 0: there is none (the edge stays). */
typedef int (*pov_mid_fn)(void *user, const pov_svert *a, const pov_svert *b, pov_svert *out);

/* Splits every edge (of the triangles from `first` on) whose midpoint lies further than tol from the surface (or whose end normals
 * differ by more than 60 degrees while it is longer than 16 tol: a sharp crease stops there), at the surface point `mid` gives,
 * until no edge does, at most max_depth halvings deep. Edges are decided once, so neighbouring
 * triangles split alike and the mesh stays watertight. */
void pov_smesh_refine(pov_smesh *m, uint32_t first, pov_mid_fn mid, void *user, double tol, int max_depth);

/* The list as a shape's mesh (normals always; uvs when with_uv). NULL when out of memory. */
pov_mesh *pov_smesh_to_mesh(const pov_smesh *m, int with_uv);

/* A parametric patch (s0, s1 over [s0lo, s0hi] x [s1lo, s1hi]) as an n0 x n1 grid of quads, each
 * split along its shorter diagonal; eval fills p, n, uv from s. Degenerate quads (a pole) give
 * one triangle or none. */
typedef void (*pov_param_fn)(void *user, pov_svert *v);
void pov_smesh_grid(pov_smesh *m, pov_param_fn eval, void *user, const double lo[2], const double hi[2], int n0, int n1);
/* The pov_mid_fn of a parametric surface: eval at the mean of a's and b's parameters. The user
 * pointer is a pov_param (below). */
typedef struct pov_param {
    pov_param_fn eval;
    void *user;
} pov_param;
int pov_param_mid(void *user, const pov_svert *a, const pov_svert *b, pov_svert *out);

/* ---- implicit surfaces (implicit.c) -------------------------------------------------------- */

/* f < 0 inside, f > 0 outside, f = 0 on the surface. */
typedef double (*pov_field_fn)(void *user, const double p[3]);

typedef struct pov_implicit {
    pov_field_fn f;
    void *user;
    double lo[3], hi[3]; /* the region to polygonise (the surface is cut at its faces) */
    int depth;           /* finest grid: 2^depth cells along the longest side (2..9) */
    double lipschitz;    /* a bound of |grad f| (cells further than f / bound from the surface are
                          * skipped); 0: every cell is visited at the finest level */
    /* optional, instead of the bound: 1 when f surely has no zero in the box lo..hi (interval
     * arithmetic) */
    int (*excludes)(void *user, const double lo[3], const double hi[3]);
    double tol;          /* chord error of the refinement (absolute) */
    double grad_step;    /* central differences of the gradient (absolute) */
    uint64_t max_evals;  /* evaluation budget (0: none); exceeding it fails with *why set */
    int refine_depth;    /* edge halvings allowed in refinement (0: 8) */
} pov_implicit;

/* The surface f = 0 inside the region: dual contouring on a sparse grid (one vertex per cell
 * crossed, placed by the least-squares fit of the crossings' tangent planes, so sharp edges stay
 * sharp), then pov_smesh_refine with points found on the surface along the mean normal. Normals
 * are the gradient's. NULL with *why set ("out of memory", or the budget) on failure. */
pov_mesh *pov_implicit_mesh(const pov_implicit *im, const char **why);
/* The bounds of the part of the region where f may vanish, by `excludes` on an octree down to
 * 2^depth cells along the longest side (each kept cell whole). 0 when f vanishes nowhere. */
int pov_implicit_bounds(const pov_implicit *im, int depth, double lo[3], double hi[3]);
/* The eigen decomposition of the symmetric 3x3 a (Jacobi rotations; a is overwritten):
 * a = v diag(w) v^T, the eigenvectors in v's columns. */
void pov_sym_eigen3(double a[3][3], double w[3], double v[3][3]);
/* The unit gradient of f at p by central differences of step h (0 0 0 where it vanishes). */
void pov_field_normal(pov_field_fn f, void *user, const double p[3], double h, double n[3]);

/* ---- 2D outlines (outline.c) ------------------------------------------------------------------ */

/* Closed contours of points in a plane (x, z for prisms, x, y for text), each point with the
 * outward direction of the outline there for the walls' normals: a point where the outline turns
 * (a corner) appears twice, once with the direction of each side. */
typedef struct pov_outline {
    double *xy;   /* 2 per point */
    double *nrm;  /* 2 per point: the outline's unit normal (pointing out of the filled region) */
    uint32_t *start; /* first point of each contour; contour i runs to start[i + 1] (or n) */
    uint32_t n, cap, ncont, capcont;
    int oom;
} pov_outline;

void pov_outline_free(pov_outline *o);
/* Starts a contour. */
void pov_outline_begin(pov_outline *o);
/* Appends a point with its tangent (the direction the contour runs; the normal is set when the
 * outline is finished). */
void pov_outline_point(pov_outline *o, double x, double y, double tx, double ty);
/* Sets the normals from the tangents so that they point out of the region the contours enclose
 * by the even-odd rule (a point just to each side is tested). Returns 0 when out of memory. */
int pov_outline_finish(pov_outline *o);
/* Quadratic and cubic Bezier segments, flattened so that no chord is further than tol from the
 * curve (a Bezier's chord error is bounded by its control polygon's). The segment's first point
 * is the previous one (not appended again); `corner`: start a new point there. */
void pov_outline_line(pov_outline *o, const double p0[2], const double p1[2]);
void pov_outline_quad(pov_outline *o, const double p0[2], const double p1[2], const double p2[2], double tol);
void pov_outline_cubic(pov_outline *o, const double p0[2], const double p1[2], const double p2[2], const double p3[2],
                       double tol);
/* Even-odd inside test (POV-Ray's rule for prisms and glyphs). */
int pov_outline_inside(const pov_outline *o, double x, double y);

/* The filled region as triangles in the plane: vertical slabs between the points' x values,
 * split into trapezoids between the outline's crossings by the even-odd rule. Appends to m with
 * pos(x, y) giving each 3D point and n the normal (the triangles face it). */
typedef void (*pov_plane_fn)(void *user, double x, double y, double p[3]);
void pov_outline_fill(const pov_outline *o, pov_smesh *m, pov_plane_fn pos, void *user, const double n[3]);

/* The walls swept by the outline: sweep(user, xy, nrm, h, p, n) places the outline point xy with
 * outline normal nrm at the sweep's start (h = 0) or end (h = 1), with the wall's normal there;
 * each outline edge gives a quad. */
typedef void (*pov_sweep_fn)(void *user, const double xy[2], const double nrm[2], int h, double p[3], double n[3]);
void pov_outline_walls(const pov_outline *o, pov_smesh *m, pov_sweep_fn sweep, void *user);

/* ---- surfaces of revolution (revolve.c) -------------------------------------------------------- */

/* A profile r(t), y(t) for t in [0, 1] per segment, swept around the y axis. eval sets r, y and
 * the direction of travel (dr, dy) (any length) at t of segment seg. */
typedef void (*pov_profile_fn)(void *user, int seg, double t, double *r, double *y, double *dr, double *dy);

/* The surface of revolution of nseg profile segments: normals from the profile's derivative,
 * uv = (angle / 2 pi, (seg + t) / nseg) as POV-Ray's lathe and sor map them. The profile's
 * outside is on its right (seen with y up and r to the right); `flip`: on its left. tol is
 * absolute. Returns 0 when out of memory. */
int pov_revolve(pov_smesh *m, pov_profile_fn eval, void *user, int nseg, double tol, int flip);
/* A flat cap closing a surface of revolution made by pov_revolve (vertices from first_vertex on):
 * the rim at its start (top = 0, uv v = 0) or end (top = 1, v = 1), fanned from (0, y, 0) with
 * the normal (0, normal_y, 0). Returns 0 when out of memory. */
int pov_revolve_cap(pov_smesh *m, uint32_t first_vertex, int top, double y, double normal_y);

/* ---- solids and deferred shapes (shape_solid.c) ---------------------------------------------- */

/* A shape's block: its own items in `rows` (their target is the shape's state, whose first
 * member is a pov_mods), then the transforms and object modifiers. */
#define POV_SHAPE_BLOCK(name, rows)                                                                                    \
    static const pov_row *const name##_tables[] = {rows, pov_transform_rows, pov_modifier_rows, NULL};                 \
    static const pov_block name = {.tables = name##_tables,                                                            \
                                   .before = pov_modifier_appearance,                                                  \
                                   .transform = pov_modifier_transform}

/* Makes a shape's primitive once its items and modifiers are read. */
typedef vbnl_result (*pov_make_fn)(const pov_shape *s, pov_mods *mods, pov_prim *pr);

/* Adds the shape's primitive (a mesh, so that the modifiers' transforms reach it), reads the block
 * (after the shape's leading values) with `mods` as the target, calls make, then applies
 * clipped_by. `mods` must be zeroed; it is cleared before returning. */
vbnl_result pov_shape_deferred(const pov_shape *s, const pov_block *block, pov_mods *mods, pov_make_fn make);

/* Sets the primitive's mesh from an smesh (freed) with a solid (taken; NULL: no inside), reporting
 * out of memory, and a warning when refinement stopped at the cap. */
vbnl_result pov_shape_set_mesh(const pov_shape *s, pov_prim *pr, pov_smesh *m, int with_uv, pov_solid *solid);

/* Sets the primitive's mesh to the implicit surface and its solid to fn with *data (taken: NULL
 * afterwards) and the bounds lo..hi; reports errors as "<keyword>: <reason>". */
vbnl_result pov_shape_implicit(const pov_shape *s, pov_prim *pr, const pov_implicit *im, const pov_solid_fn *fn,
                               void **data, const double lo[3], const double hi[3]);

/* A `contained_by { box { A, B } | sphere { C, r } }` (isosurface, parametric). */
typedef struct pov_container {
    int sphere;
    double lo[3], hi[3]; /* box */
    double c[3], r;      /* sphere */
} pov_container;
void pov_container_default(pov_container *c); /* POV-Ray's box { -1, 1 } */
/* The block after the keyword `contained_by` (a row handler's item). */
vbnl_result pov_container_parse(const pov_item *it, pov_container *c);
void pov_container_bounds(const pov_container *c, double lo[3], double hi[3]);
/* The container's signed distance (negative inside). */
double pov_container_dist(const pov_container *c, const double q[3]);
/* Adds the container, placed as the shape's primitive pr, to the shape's clipped_by shapes: the
 * shape is cut at it. */
vbnl_result pov_container_clip(const pov_shape *s, pov_mods *mods, const pov_prim *pr, const pov_container *c);

/* The shape's bounding radius: half the diagonal of lo..hi (tolerances are fractions of it). */
double pov_box_radius(const double lo[3], const double hi[3]);

/* Finds a file a shape names (a font, a height field image): next to the file that names it,
 * then in the scene's include folders; in each, the name as given, then with `ext` appended
 * (NULL: none; POV-Ray's ".ttf" for fonts). Returns a malloc'd path, or NULL after reporting
 * "<what>: cannot find '<name>' (searched: <folders>)" at loc. */
char *pov_shape_find_file(pov_loader *L, const char *name, const char *ext, const vbnl_sdl_loc *loc, const char *what);

/* ---- sharing (shape_cache.c) ----------------------------------------------------------------- */

typedef struct pov_shape_cache pov_shape_cache;
/* The mesh and solid made before for the same key bytes (references taken): 1, else 0. */
int pov_shape_cache_get(pov_loader *L, const void *key, size_t len, pov_mesh **mesh, pov_solid **solid);
/* Keeps a mesh and solid (references taken) for the key; out of memory just shares nothing. */
void pov_shape_cache_put(pov_loader *L, const void *key, size_t len, pov_mesh *mesh, pov_solid *solid);
/* The same for a CSG's pieces: appends copies (meshes and solids shared) to out; *oom on failure. */
int pov_shape_cache_get_obj(pov_loader *L, const void *key, size_t len, pov_obj *out, int *oom);
void pov_shape_cache_put_obj(pov_loader *L, const void *key, size_t len, const pov_obj *o);

/* A key being built (bytes appended; `failed` when memory ran out: nothing is cached). */
typedef struct pov_key {
    unsigned char *b;
    size_t n, cap;
    int failed;
} pov_key;
void pov_key_add(pov_key *k, const void *p, size_t n);
void pov_key_free(pov_key *k);

#endif
