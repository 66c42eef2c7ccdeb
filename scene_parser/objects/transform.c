/* vbnl object layer: transforms of objects, lights and cameras (translate rotate scale matrix
 * transform) and `transform { }` blocks. Patterns have their own reading (texture/transform.c). */
#include <string.h>

#include "pov_loader.h"
#include "sdl_internal.h"

/* Hands a transform item's matrix to the block that read it. */
static vbnl_result give(const pov_item *it, vbnl_result r, const double m[16])
{
    if (r != VBNL_OK)
        return VBNL_ERR_PARSE;
    it->block->transform(it, m);
    return VBNL_OK;
}

vbnl_result pov_transform_vector(const pov_item *it)
{
    double v[3], m[16];
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_vector(it->p, 3, v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    int zero = v[0] == 0 || v[1] == 0 || v[2] == 0;
    switch (it->arg) {
    case POV_TRANSLATE:
        pov_m4_translate(v, m);
        break;
    case POV_ROTATE:
        pov_m4_rotate(v, m);
        break;
    case POV_SCALE:
        if (zero)
            vbnl_sdl_warning(it->p, &it->loc, "scale by 0 changed to 1 (as POV-Ray does)");
        for (int i = 0; i < 3; ++i)
            if (v[i] == 0)
                v[i] = 1;
        pov_m4_scale(v, m);
        break;
    default:
        if (zero)
            return vbnl_sdl_error(it->p, &it->loc, "scale by zero");
        pov_m4_scale(v, m);
        break;
    }
    it->block->transform(it, m);
    return VBNL_OK;
}

static vbnl_result read_matrix(const pov_item *it)
{
    vbnl_sdl_parser *p = it->p;
    double v[12], m[16], inv[16];
    vbnl_sdl_next(p);
    if (vbnl_sdl_expect(p, '<', "to open the 12 values of 'matrix'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    p->in_vector++; /* '>' closes the list */
    for (int i = 0; i < 12; ++i) {
        if ((i && vbnl_sdl_expect(p, ',', "between the 12 values of 'matrix'") != VBNL_OK) ||
            vbnl_sdl_parse_float(p, &v[i]) != VBNL_OK) {
            p->in_vector--;
            return VBNL_ERR_PARSE;
        }
    }
    p->in_vector--;
    if (vbnl_sdl_expect(p, '>', "after the 12 values of 'matrix'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_m4_from_pov(v, m);
    if (!pov_m4_invert(m, inv))
        return vbnl_sdl_error(p, &it->loc, "matrix is singular");
    return give(it, VBNL_OK, m);
}

/* transform ID or transform { } */
static vbnl_result read_transform(const pov_item *it)
{
    pov_loader *L = it->ctx;
    double m[16];
    vbnl_sdl_next(it->p);
    const double *d = pov_declared(L, vbnl_sdl_peek(it->p), &pov_transform_type);
    if (d) {
        vbnl_sdl_next(it->p);
        memcpy(m, d, sizeof m);
        return give(it, VBNL_OK, m);
    }
    return give(it, pov_transform_block(L, m), m);
}

const pov_row pov_transform_rows[] = {
    {"translate", pov_transform_vector, POV_TRANSLATE},
    {"rotate", pov_transform_vector, POV_ROTATE},
    {"scale", pov_transform_vector, POV_SCALE},
    {"matrix", read_matrix, 0},
    {"transform", read_transform, 0},
    {NULL, NULL, 0},
};

/* ---- transform { } ------------------------------------------------------------------------------ */

void pov_xform_compose(const pov_item *it, const double m[16])
{
    pov_xform *x = it->target;
    pov_m4_mul(m, x->m, x->m);
}

static vbnl_result read_inverse(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    ((pov_xform *)it->target)->inverse ^= 1;
    return VBNL_OK;
}

const pov_row pov_inverse_rows[] = {{"inverse", read_inverse, 0}, {NULL, NULL, 0}};

vbnl_result pov_xform_result(vbnl_sdl_parser *p, const pov_xform *x, double out[16])
{
    memcpy(out, x->m, sizeof x->m);
    if (x->inverse && !pov_m4_invert(x->m, out))
        return vbnl_sdl_error(p, NULL, "cannot invert a singular transform");
    return VBNL_OK;
}

static int declared_transform(const pov_item *it)
{
    const double *d = pov_declared(it->ctx, it->tok, &pov_transform_type);
    if (!d)
        return 0;
    vbnl_sdl_next(it->p);
    pov_xform_compose(it, d);
    return 1;
}

static vbnl_result not_transform(const pov_item *it)
{
    char buf[80];
    return vbnl_sdl_error(it->p, &it->loc, "expected translate, rotate, scale, matrix, transform or inverse in 'transform', found %s",
                          sdl_token_describe(it->tok, buf, sizeof buf));
}

static const pov_row *const block_tables[] = {pov_inverse_rows, pov_transform_rows, NULL};
static const pov_block transform_block = {.name = "transform",
                                          .tables = block_tables,
                                          .before = declared_transform,
                                          .unknown = not_transform,
                                          .transform = pov_xform_compose};

vbnl_result pov_transform_block(pov_loader *L, double m[16])
{
    vbnl_sdl_parser *p = L->c.parser;
    if (vbnl_sdl_expect(p, '{', "after 'transform'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_xform x;
    pov_m4_identity(x.m);
    x.inverse = 0;
    if (pov_block_parse(&transform_block, p, L, &x, NULL) != VBNL_OK)
        return VBNL_ERR_PARSE;
    return pov_xform_result(p, &x, m);
}
