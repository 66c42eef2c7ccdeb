/* vbnl object layer: isosurface { function { F } [contained_by { box { A, B } | sphere { C, r } }]
 *                                 [threshold t] [accuracy a] [max_gradient g] [evaluate a, b, c]
 *                                 [open] [max_trace n | all_intersections] modifiers }
 *
 * The surface F(p) = t inside the container (POV-Ray's default: box { -1, 1 }), F < t inside.
 * F is the language's own function (language/func.c), evaluated through vbnl_sdl_function_call.
 * The surface is polygonised by dual contouring (implicit.c) of max(F - t, d(p)), where d is the
 * container's signed distance, so that the container closes the shape where F < t reaches it, as
 * in POV-Ray; with `open` the surface of F alone is made and cut at the container (clipped_by).
 * max_gradient bounds |grad F| as in POV-Ray: cells further than (F - t) / max_gradient from the
 * surface are not visited; a surface found in one cell is followed through all the others even
 * where the bound is too low. Grid: 64 cells along the container's longest side (features
 * thinner than a cell can be lost), then refinement to POV_TESS_TOL of the container's radius.
 * `accuracy`, `evaluate`, `max_trace` and `all_intersections` tune POV-Ray's ray marching and
 * change nothing here. */
#include <stdlib.h>
#include <string.h>

#include "pov_surface.h"
#include "sdl_internal.h"

typedef struct iso_data {
    vbnl_sdl_parser *p;
    vbnl_sdl_function *fn;
    double t;
    pov_container cont;
    int with_container; /* the field includes the container (closed) */
} iso_data;

static double iso_f(const iso_data *d, const double q[3])
{
    double v = 0;
    if (vbnl_sdl_function_call(d->p, d->fn, q, 3, &v) != VBNL_OK)
        return 1e30;
    return v - d->t;
}

static double iso_field(void *user, const double q[3])
{
    const iso_data *d = user;
    double v = iso_f(d, q);
    return d->with_container ? fmax(v, pov_container_dist(&d->cont, q)) : v;
}

static int iso_inside(const void *data, const double q[3])
{
    const iso_data *d = data;
    return pov_container_dist(&d->cont, q) <= 0 && iso_f(d, q) < 0;
}

static void iso_destroy(void *data)
{
    iso_data *d = data;
    sdl_function_release(d->p, d->fn);
    free(d);
}

static const pov_solid_fn iso_fn = {iso_inside, iso_destroy, NULL};

/* ---- parsing --------------------------------------------------------------------------------- */

typedef struct iso_shape {
    pov_mods mods;
    iso_data *d;
    double max_gradient, accuracy, dummy;
    int open;
} iso_shape;

static vbnl_result iso_contained_by(const pov_item *it)
{
    return pov_container_parse(it, &((iso_shape *)it->target)->d->cont);
}

static vbnl_result iso_evaluate(const pov_item *it)
{
    double v[3];
    vbnl_sdl_next(it->p);
    for (int k = 0; k < 3; ++k) {
        if (k)
            pov_comma(it->ctx);
        if (pov_float(it->ctx, &v[k]) != VBNL_OK)
            return VBNL_ERR_PARSE;
    }
    return VBNL_OK;
}

static vbnl_result iso_open(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    ((iso_shape *)it->target)->open = 1;
    return VBNL_OK;
}

static vbnl_result iso_threshold(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_float(it->ctx, &((iso_shape *)it->target)->d->t);
}

static const pov_row iso_rows[] = {
    {"contained_by", iso_contained_by, 0},
    {"threshold", iso_threshold, 0},
    {"accuracy", pov_item_float, offsetof(iso_shape, accuracy)},
    {"max_gradient", pov_item_float, offsetof(iso_shape, max_gradient)},
    {"evaluate", iso_evaluate, 0},
    {"open", iso_open, 0},
    {"max_trace", pov_item_float, offsetof(iso_shape, dummy)},
    {"all_intersections", pov_item_word, 0},
    {NULL, NULL, 0},
};
POV_SHAPE_BLOCK(iso_block, iso_rows);

static vbnl_result iso_open_clip(const pov_shape *s, pov_mods *mods, pov_prim *pr, const iso_data *d);

static vbnl_result iso_make(const pov_shape *s, pov_mods *mods, pov_prim *pr)
{
    iso_shape *is = (iso_shape *)mods;
    pov_loader *L = s->L;
    iso_data *d = is->d;
    double lo[3], hi[3];
    pov_container_bounds(&d->cont, lo, hi);
    if (!(is->max_gradient > 0))
        return vbnl_sdl_error(L->c.parser, &s->loc, "isosurface: max_gradient must be positive, got %g",
                              is->max_gradient);
    d->with_container = !is->open;
    /* an equal isosurface made before (a macro's): shared */
    pov_key key = {0};
    unsigned char fk[8192];
    size_t fkn = sdl_function_key(d->fn, fk, sizeof fk);
    pov_key_add(&key, "iso", 4);
    pov_key_add(&key, fk, fkn);
    pov_key_add(&key, &d->t, sizeof d->t);
    pov_key_add(&key, &d->cont.sphere, sizeof d->cont.sphere);
    pov_key_add(&key, lo, sizeof lo);
    pov_key_add(&key, hi, sizeof hi);
    pov_key_add(&key, &is->max_gradient, sizeof is->max_gradient);
    pov_key_add(&key, &is->open, sizeof is->open);
    int cacheable = fkn > 0 && !key.failed;
    if (cacheable && pov_shape_cache_get(L, key.b, key.n, &pr->mesh, &pr->solid)) {
        pov_key_free(&key);
        return iso_open_clip(s, mods, pr, d);
    }
    pov_implicit im;
    memset(&im, 0, sizeof im);
    im.f = iso_field;
    im.user = d;
    memcpy(im.lo, lo, sizeof lo);
    memcpy(im.hi, hi, sizeof hi);
    double r = pov_box_radius(lo, hi);
    im.depth = 6;
    im.lipschitz = fmax(is->max_gradient, 1.0);
    im.tol = POV_TESS_TOL * r;
    im.grad_step = 1e-5 * r;
    im.max_evals = 40000000;
    vbnl_result res = pov_shape_implicit(s, pr, &im, &iso_fn, (void **)&is->d, lo, hi);
    if (res != VBNL_OK) {
        pov_key_free(&key);
        return res;
    }
    if (cacheable)
        pov_shape_cache_put(L, key.b, key.n, pr->mesh, pr->solid);
    pov_key_free(&key);
    return iso_open_clip(s, mods, pr, d);
}

/* With `open`: cut at the container, a clipped_by shape in the shape's space. */
static vbnl_result iso_open_clip(const pov_shape *s, pov_mods *mods, pov_prim *pr, const iso_data *d)
{
    return ((iso_shape *)mods)->open ? pov_container_clip(s, mods, pr, &d->cont) : VBNL_OK;
}

vbnl_result pov_shape_isosurface(const pov_shape *s)
{
    pov_loader *L = s->L;
    vbnl_sdl_parser *p = L->c.parser;
    iso_shape is;
    memset(&is, 0, sizeof is);
    is.max_gradient = 1.1; /* POV-Ray's defaults */
    is.accuracy = 0.001;
    if (!pov_is_word(vbnl_sdl_peek(p), "function"))
        return vbnl_sdl_error(p, NULL, "isosurface: expected 'function { ... }' first");
    if (!(is.d = calloc(1, sizeof *is.d)))
        return pov_oom(L);
    is.d->p = p;
    pov_container_default(&is.d->cont);
    vbnl_sdl_value fv;
    vbnl_sdl_loc floc = vbnl_sdl_peek(p)->loc;
    if (!sdl_parse_function(p, &fv, &floc)) {
        free(is.d);
        return VBNL_ERR_PARSE;
    }
    is.d->fn = fv.u.fn;
    vbnl_result r = pov_shape_deferred(s, &iso_block, &is.mods, iso_make);
    if (is.d)
        iso_destroy(is.d);
    return r;
}
