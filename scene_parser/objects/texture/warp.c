/* vbnl object layer, texture part: warp { } (reference manual, "Warps"): turbulence, repeat,
 * black_hole, spherical, cylindrical, toroidal, planar and cubic, with POV-Ray's parser rules
 * (Parse_Warp and Check_BH_Parameters of its parstxtr.cpp). A warp acts on the point before
 * everything the pattern had so far. */
#include <string.h>

#include "pov_texture.h"

/* turbulence <v> [octaves n] [omega w] [lambda l] */
static vbnl_result turbulence(pov_ctx *c, vbnl_warp_desc *w)
{
    vbnl_sdl_parser *p = c->parser;
    w->kind = VBNL_WARP_TURBULENCE;
    if (vbnl_sdl_parse_vector(p, 3, w->turbulence.amount) != VBNL_OK)
        return VBNL_ERR_PARSE;
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        double v;
        if (pov_is_word(t, "octaves")) {
            vbnl_sdl_next(p);
            if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
                return VBNL_ERR_PARSE;
            w->turbulence.octaves = v < 1.0 ? 1 : (v > 10.0 ? 10 : (int)v);
        } else if (pov_is_word(t, "omega") || pov_is_word(t, "lambda")) {
            int omega = pov_is_word(t, "omega");
            vbnl_sdl_next(p);
            if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
                return VBNL_ERR_PARSE;
            *(omega ? &w->turbulence.omega : &w->turbulence.lambda) = (float)v;
        } else {
            return VBNL_OK;
        }
    }
}

/* repeat <v> [offset <v>] [flip <v>]: along the one non-zero axis of v */
static vbnl_result repeat(pov_ctx *c, vbnl_warp_desc *w, const vbnl_sdl_loc *loc)
{
    vbnl_sdl_parser *p = c->parser;
    double v[3];
    w->kind = VBNL_WARP_REPEAT;
    if (vbnl_sdl_parse_vector(p, 3, v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    int axis = -1;
    for (int i = 0; i < 3; ++i) {
        if (v[i] == 0.0)
            continue;
        if (axis >= 0)
            return vbnl_sdl_error(p, loc, "warp repeat can only repeat along one axis");
        axis = i;
    }
    if (axis < 0)
        return vbnl_sdl_error(p, loc, "warp repeat needs an axis (a non-zero vector)");
    w->repeat.axis = axis;
    w->repeat.width = (float)v[axis];
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        if (pov_is_word(t, "offset")) {
            vbnl_sdl_next(p);
            if (vbnl_sdl_parse_vector(p, 3, w->repeat.offset) != VBNL_OK)
                return VBNL_ERR_PARSE;
        } else if (pov_is_word(t, "flip")) {
            vbnl_sdl_next(p);
            double f[3];
            if (vbnl_sdl_parse_vector(p, 3, f) != VBNL_OK)
                return VBNL_ERR_PARSE;
            for (int i = 0; i < 3; ++i)
                w->repeat.flip[i] = f[i] != 0.0;
        } else {
            return VBNL_OK;
        }
    }
}

/* POV-Ray's Check_BH_Parameters: on each repeated axis the centre is at least the radius, and
 * the period at least centre + radius + turbulence (raised, with a warning). */
static void black_hole_check(pov_ctx *c, vbnl_warp_desc *w, const vbnl_sdl_loc *loc)
{
    double *ctr = w->black_hole.center, *rep = w->black_hole.repeat, *unc = w->black_hole.turbulence;
    const double r = w->black_hole.radius;
    for (int i = 0; i < 3; ++i) {
        if (!(rep[i] > 0.0))
            continue;
        if (ctr[i] < r)
            ctr[i] = r;
        if (rep[i] < ctr[i] + r + unc[i]) {
            rep[i] = ctr[i] + r + unc[i];
            vbnl_sdl_warning(c->parser, loc, "black_hole repeat vector %c too small: increased to %g", "xyz"[i], rep[i]);
        }
    }
}

/* black_hole <centre>, radius [strength s] [falloff f] [inverse] [type t] [repeat <v>]
 * [turbulence <v>] */
static vbnl_result black_hole(pov_ctx *c, vbnl_warp_desc *w, const vbnl_sdl_loc *loc)
{
    vbnl_sdl_parser *p = c->parser;
    double r;
    w->kind = VBNL_WARP_BLACK_HOLE;
    if (vbnl_sdl_parse_vector(p, 3, w->black_hole.center) != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_sdl_accept(p, ',');
    if (vbnl_sdl_parse_float(p, &r) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(r > 0.0))
        return vbnl_sdl_error(p, loc, "black_hole radius must be > 0 (got %g)", r);
    w->black_hole.radius = r;
    int repeated = 0;
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        vbnl_sdl_loc tl = t->loc;
        double v;
        if (pov_is_word(t, "strength") || pov_is_word(t, "falloff") || pov_is_word(t, "type")) {
            int which = pov_is_word(t, "strength") ? 0 : pov_is_word(t, "falloff") ? 1 : 2;
            vbnl_sdl_next(p);
            if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
                return VBNL_ERR_PARSE;
            if (which == 0)
                w->black_hole.strength = v;
            else if (which == 1)
                w->black_hole.falloff = v;
            else if (v != 0.0)
                vbnl_sdl_warning(p, &tl, "black_hole type %g has no effect (POV-Ray defines type 0 only)", v);
        } else if (pov_is_word(t, "inverse")) {
            vbnl_sdl_next(p);
            w->black_hole.inverse = 1;
        } else if (pov_is_word(t, "repeat") || pov_is_word(t, "turbulence")) {
            int rep = pov_is_word(t, "repeat");
            vbnl_sdl_next(p);
            if (vbnl_sdl_parse_vector(p, 3, rep ? w->black_hole.repeat : w->black_hole.turbulence) != VBNL_OK)
                return VBNL_ERR_PARSE;
            repeated |= rep;
            if (repeated)
                black_hole_check(c, w, &tl);
        } else {
            return VBNL_OK;
        }
    }
}

/* spherical / cylindrical / toroidal [orientation <v>] [dist_exp d] [major_radius r];
 * planar [<v>, offset] */
static vbnl_result mapping(pov_ctx *c, vbnl_warp_desc *w, vbnl_warp_kind kind)
{
    vbnl_sdl_parser *p = c->parser;
    w->kind = kind;
    if (kind == VBNL_WARP_PLANAR) { /* planar [VECTOR, FLOAT]: anything but the closing brace starts them */
        if (pov_is_punct(vbnl_sdl_peek(p), '}'))
            return VBNL_OK;
        if (vbnl_sdl_parse_vector(p, 3, w->mapping.orientation) != VBNL_OK)
            return VBNL_ERR_PARSE;
        vbnl_sdl_accept(p, ',');
        return vbnl_sdl_parse_float(p, &w->mapping.offset);
    }
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        if (pov_is_word(t, "orientation")) {
            vbnl_sdl_loc tl = t->loc;
            vbnl_sdl_next(p);
            double *o = w->mapping.orientation;
            if (vbnl_sdl_parse_vector(p, 3, o) != VBNL_OK)
                return VBNL_ERR_PARSE;
            if (o[0] == 0.0 && o[1] == 0.0 && o[2] == 0.0)
                return vbnl_sdl_error(p, &tl, "warp orientation must be a non-zero vector");
        } else if (pov_is_word(t, "dist_exp") || (kind == VBNL_WARP_TOROIDAL && pov_is_word(t, "major_radius"))) {
            double *dst = pov_is_word(t, "dist_exp") ? &w->mapping.dist_exp : &w->mapping.major_radius;
            vbnl_sdl_next(p);
            if (vbnl_sdl_parse_float(p, dst) != VBNL_OK)
                return VBNL_ERR_PARSE;
        } else {
            return VBNL_OK;
        }
    }
}

vbnl_result pov_warp_parse(pov_ctx *c, pov_pattern *pat)
{
    vbnl_sdl_parser *p = c->parser;
    if (vbnl_sdl_expect(p, '{', "after 'warp'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    vbnl_sdl_loc loc = t->loc;
    vbnl_warp_desc w;
    vbnl_warp_desc_init(&w);
    vbnl_result r;
    if (pov_is_word(t, "turbulence")) {
        vbnl_sdl_next(p);
        r = turbulence(c, &w);
    } else if (pov_is_word(t, "repeat")) {
        vbnl_sdl_next(p);
        r = repeat(c, &w, &loc);
    } else if (pov_is_word(t, "black_hole")) {
        vbnl_sdl_next(p);
        r = black_hole(c, &w, &loc);
    } else if (pov_is_word(t, "spherical") || pov_is_word(t, "cylindrical") || pov_is_word(t, "toroidal") ||
               pov_is_word(t, "planar")) {
        vbnl_warp_kind k = pov_is_word(t, "spherical")     ? VBNL_WARP_SPHERICAL
                           : pov_is_word(t, "cylindrical") ? VBNL_WARP_CYLINDRICAL
                           : pov_is_word(t, "toroidal")    ? VBNL_WARP_TOROIDAL
                                                           : VBNL_WARP_PLANAR;
        vbnl_sdl_next(p);
        r = mapping(c, &w, k);
    } else if (pov_is_word(t, "cubic")) {
        vbnl_sdl_next(p);
        w.kind = VBNL_WARP_CUBIC;
        r = VBNL_OK;
    } else {
        return vbnl_sdl_error(p, &loc, "expected a warp type (turbulence, repeat, black_hole, spherical, cylindrical, "
                                       "toroidal, planar or cubic), found '%s'",
                              t->text ? t->text : "?");
    }
    if (r != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (vbnl_sdl_expect(p, '}', "to close the warp") != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!pov_pattern_prepend_warp(pat, &w))
        return vbnl_sdl_error(p, &loc, "a pattern has at most %d warps and transforms", POV_WARP_MAX);
    return VBNL_OK;
}
