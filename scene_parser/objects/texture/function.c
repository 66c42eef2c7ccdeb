/* vbnl object layer, texture part: pattern and pigment functions (reference manual, "Functions":
 * `function { pattern { PATTERN [MODIFIERS] } }` gives the pattern's value, `function { pigment
 * { ... } }` its colour). The language layer hands the body's block here (its function_block
 * hook); the pattern or pigment is built into a pattern set of its own (vbnl/scene.h), which the
 * function evaluates during the parse and, in detached copies, while rendering. */
#include <string.h>

#include "pov_texture.h"

int pov_function_block(pov_ctx *c, const vbnl_sdl_token *tok, vbnl_sdl_fn_block *out)
{
    const int pigment = pov_is_word(tok, "pigment");
    if (!pigment && !pov_is_word(tok, "pattern"))
        return 0;
    vbnl_sdl_parser *p = c->parser;
    vbnl_sdl_loc loc = tok->loc;
    pov_pigment *g = pov_pigment_new();
    if (!g) {
        vbnl_sdl_error(p, &loc, "out of memory");
        return -1;
    }
    if (pov_pigment_parse(c, g) != VBNL_OK) {
        pov_pigment_free(g);
        return -1;
    }
    if (!pigment && g->kind != POV_PIG_MAP) {
        pov_pigment_free(g);
        vbnl_sdl_error(p, &loc, "a pattern function needs a pattern");
        return -1;
    }
    vbnl_error err = {0};
    vbnl_result r = pov_function_block_build(c, g, pigment, out, &err);
    pov_pigment_free(g);
    if (r != VBNL_OK) {
        vbnl_sdl_error(p, &loc, "%s", err.message);
        return -1;
    }
    return 1;
}
