/* vbnl object layer, texture part: normal { }. Bump perturbation is not rendered: the block is
 * read (directives and macros in it run) and dropped, with one warning per load. */
#include "pov_texture.h"

vbnl_result pov_normal_parse(pov_ctx *c, const vbnl_sdl_loc *loc)
{
    if (vbnl_sdl_skip_block(c->parser) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!c->tex->normal_warned) {
        c->tex->normal_warned = 1;
        vbnl_sdl_warning(c->parser, loc, "'normal' (bump perturbation) is not rendered: ignored (reported once)");
    }
    return VBNL_OK;
}
