/* vbnl object layer: parametric { function { X(u, v) }, function { Y(u, v) }, function { Z(u, v) }
 *                                 <u1, v1>, <u2, v2> [contained_by { box | sphere }]
 *                                 [max_gradient g] [accuracy a] [precompute n, x, y, z] modifiers }
 *
 * The patch (X, Y, Z)(u, v) over [u1, u2] x [v1, v2], cut at its container (POV-Ray's default
 * box { -1, 1 }: the part outside is not drawn). It is made as a 32 x 32 grid refined to
 * POV_TESS_TOL of the container's radius; normals from the partial derivatives (central
 * differences), uv_mapping gets (u, v). A patch has no inside (as in POV-Ray). max_gradient,
 * accuracy and precompute tune POV-Ray's root finder and change nothing here. */
#include <stdlib.h>
#include <string.h>

#include "pov_surface.h"
#include "sdl_internal.h"

typedef struct par_data {
    vbnl_sdl_parser *p;
    vbnl_sdl_function *fn[3];
    double ulo[2], uhi[2];
    pov_container cont;
} par_data;

static void par_point(const par_data *d, double u, double v, double out[3])
{
    double a[2] = {u, v};
    for (int k = 0; k < 3; ++k)
        if (vbnl_sdl_function_call(d->p, d->fn[k], a, 2, &out[k]) != VBNL_OK || !isfinite(out[k]))
            out[k] = 0;
}

static void par_eval(void *user, pov_svert *v)
{
    const par_data *d = user;
    double u = v->s[0], w = v->s[1];
    double hu = 1e-5 * (d->uhi[0] - d->ulo[0]), hv = 1e-5 * (d->uhi[1] - d->ulo[1]);
    double a[3], b[3], c[3], e[3], du[3], dv[3];
    par_point(d, u, w, v->p);
    par_point(d, u + hu, w, a);
    par_point(d, u - hu, w, b);
    par_point(d, u, w + hv, c);
    par_point(d, u, w - hv, e);
    for (int k = 0; k < 3; ++k) {
        du[k] = a[k] - b[k];
        dv[k] = c[k] - e[k];
    }
    pov_cross3(du, dv, v->n);
    double l = pov_len3(v->n);
    if (l > 0)
        pov_scale3(v->n, 1 / l);
    else
        pov_set3(v->n, 0, 1, 0);
    v->uv[0] = u;
    v->uv[1] = w;
}

typedef struct par_shape {
    pov_mods mods;
    par_data *d;
    double dummy;
} par_shape;

static void par_free(par_data *d)
{
    for (int k = 0; k < 3; ++k)
        sdl_function_release(d->p, d->fn[k]);
    free(d);
}

static vbnl_result par_contained_by(const pov_item *it)
{
    return pov_container_parse(it, &((par_shape *)it->target)->d->cont);
}

static vbnl_result par_precompute(const pov_item *it)
{
    double depth;
    vbnl_sdl_next(it->p);
    if (pov_float(it->ctx, &depth) != VBNL_OK)
        return VBNL_ERR_PARSE;
    for (int k = 0; k < 3; ++k) { /* [, x] [, y] [, z] */
        if (!vbnl_sdl_accept(it->p, ','))
            break;
        const vbnl_sdl_token *t = vbnl_sdl_peek(it->p);
        if (pov_is_word(t, "x") || pov_is_word(t, "y") || pov_is_word(t, "z"))
            vbnl_sdl_next(it->p);
    }
    return VBNL_OK;
}

static const pov_row par_rows[] = {
    {"contained_by", par_contained_by, 0},
    {"max_gradient", pov_item_float, offsetof(par_shape, dummy)},
    {"accuracy", pov_item_float, offsetof(par_shape, dummy)},
    {"precompute", par_precompute, 0},
    {NULL, NULL, 0},
};
POV_SHAPE_BLOCK(par_block, par_rows);

static vbnl_result par_make(const pov_shape *s, pov_mods *mods, pov_prim *pr)
{
    par_data *d = ((par_shape *)mods)->d;
    pov_loader *L = s->L;
    double lo[3], hi[3];
    pov_container_bounds(&d->cont, lo, hi);
    pov_smesh sm;
    memset(&sm, 0, sizeof sm);
    pov_smesh_grid(&sm, par_eval, d, d->ulo, d->uhi, 32, 32);
    pov_param pp = {par_eval, d};
    pov_smesh_refine(&sm, 0, pov_param_mid, &pp, POV_TESS_TOL * pov_box_radius(lo, hi), 10);
    if (vbnl_sdl_failed(L->c.parser)) {
        pov_smesh_free(&sm);
        return VBNL_ERR_PARSE;
    }
    vbnl_result r = pov_shape_set_mesh(s, pr, &sm, 1, NULL);
    if (r != VBNL_OK)
        return r;
    /* cut at the container: a clipped_by shape in the shape's space */
    return pov_container_clip(s, mods, pr, &d->cont);
}

vbnl_result pov_shape_parametric(const pov_shape *s)
{
    pov_loader *L = s->L;
    vbnl_sdl_parser *p = L->c.parser;
    par_shape ps;
    memset(&ps, 0, sizeof ps);
    if (!(ps.d = calloc(1, sizeof *ps.d)))
        return pov_oom(L);
    ps.d->p = p;
    pov_container_default(&ps.d->cont);
    vbnl_result r = VBNL_OK;
    for (int k = 0; k < 3 && r == VBNL_OK; ++k) {
        if (k)
            pov_comma(L);
        vbnl_sdl_loc floc = vbnl_sdl_peek(p)->loc;
        vbnl_sdl_value fv;
        if (!pov_is_word(vbnl_sdl_peek(p), "function"))
            r = vbnl_sdl_error(p, &floc, "parametric: expected 'function { ... }' (%d of 3)", k + 1);
        else if (!sdl_parse_function(p, &fv, &floc))
            r = VBNL_ERR_PARSE;
        else
            ps.d->fn[k] = fv.u.fn;
    }
    double a[2], b[2];
    if (r == VBNL_OK) {
        pov_comma(L);
        if (vbnl_sdl_parse_vector(p, 2, a) != VBNL_OK || (pov_comma(L), vbnl_sdl_parse_vector(p, 2, b)) != VBNL_OK)
            r = VBNL_ERR_PARSE;
    }
    if (r == VBNL_OK) {
        for (int k = 0; k < 2; ++k) {
            ps.d->ulo[k] = fmin(a[k], b[k]);
            ps.d->uhi[k] = fmax(a[k], b[k]);
        }
        r = pov_shape_deferred(s, &par_block, &ps.mods, par_make);
    }
    par_free(ps.d);
    return r;
}
