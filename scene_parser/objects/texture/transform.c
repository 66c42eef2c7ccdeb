/* vbnl object layer, texture part: transforms inside pigments, textures and materials. They move
 * the pattern (pattern space -> POV world). Unlike an object's transforms (../transform.c), a
 * scale by 0 is an error here and `transform` takes a block, not a declared identifier. */
#include <string.h>

#include "pov_texture.h"

static vbnl_result give(const pov_item *it, const double m[16])
{
    it->block->transform(it, m);
    return VBNL_OK;
}

static vbnl_result read_matrix(const pov_item *it)
{
    vbnl_sdl_parser *p = it->p;
    double v[12], m[16];
    vbnl_sdl_next(p);
    if (vbnl_sdl_expect(p, '<', "after 'matrix'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    for (int i = 0; i < 12; ++i) {
        if (i > 0 && vbnl_sdl_expect(p, ',', "between matrix values") != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (vbnl_sdl_parse_float(p, &v[i]) != VBNL_OK)
            return VBNL_ERR_PARSE;
    }
    if (vbnl_sdl_expect(p, '>', "after the 12 matrix values") != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_m4_from_pov(v, m);
    return give(it, m);
}

/* ---- transform { items [inverse] } ------------------------------------------------------------- */

static const pov_row *const block_tables[] = {pov_inverse_rows, pov_pattern_transform_rows, NULL};
static const pov_block transform_block = {.name = "transform",
                                          .tables = block_tables,
                                          .unknown = pov_block_unexpected_word,
                                          .transform = pov_xform_compose};

static vbnl_result read_transform(const pov_item *it)
{
    vbnl_sdl_parser *p = it->p;
    vbnl_sdl_next(p);
    const vbnl_sdl_token *n = vbnl_sdl_peek(p);
    if (!pov_is_punct(n, '{'))
        return vbnl_sdl_error(p, &n->loc, "'transform' in an appearance takes a { } block here");
    vbnl_sdl_next(p);
    pov_xform x;
    double m[16];
    pov_m4_identity(x.m);
    x.inverse = 0;
    if (pov_block_parse(&transform_block, p, it->ctx, &x, NULL) != VBNL_OK || pov_xform_result(p, &x, m) != VBNL_OK)
        return VBNL_ERR_PARSE;
    return give(it, m);
}

const pov_row pov_pattern_transform_rows[] = {
    {"translate", pov_transform_vector, POV_TRANSLATE},
    {"scale", pov_transform_vector, POV_SCALE_NONZERO},
    {"rotate", pov_transform_vector, POV_ROTATE},
    {"matrix", read_matrix, 0},
    {"transform", read_transform, 0},
    {NULL, NULL, 0},
};
