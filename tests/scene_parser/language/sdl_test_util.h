/* vbnl: helpers shared by the SDL language-layer tests (cmocka). Include after cmocka.h. */
#ifndef VBI_SDL_TEST_UTIL_H
#define VBI_SDL_TEST_UTIL_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vbnl/sdl.h"

/* Parses `text` as "test.pov"; returns the parser (caller destroys) and the result in *r. */
#define SDL_T_UNUSED __attribute__((unused))

SDL_T_UNUSED static vbnl_sdl_parser *sdl_t_parse(const char *text, vbnl_result *r)
{
    vbnl_sdl_parser *p = NULL;
    assert_int_equal(vbnl_sdl_parser_create(&p, NULL), VBNL_OK);
    vbnl_error err = { 0 };
    *r = vbnl_sdl_parse_text(p, "test.pov", text, strlen(text), &err);
    return p;
}

/* Parses text that must succeed. */
SDL_T_UNUSED static vbnl_sdl_parser *sdl_t_ok(const char *text)
{
    vbnl_result r;
    vbnl_sdl_parser *p = sdl_t_parse(text, &r);
    if (r != VBNL_OK) {
        for (size_t i = 0; i < vbnl_sdl_diag_count(p); i++)
            fprintf(stderr, "%s", vbnl_sdl_diag_get(p, i)->text);
    }
    assert_int_equal(r, VBNL_OK);
    return p;
}

/* The full text of the error diagnostic (the parse must have failed). */
SDL_T_UNUSED static const char *sdl_t_error_text(vbnl_sdl_parser *p)
{
    for (size_t i = 0; i < vbnl_sdl_diag_count(p); i++)
        if (vbnl_sdl_diag_get(p, i)->severity == VBNL_SDL_ERROR)
            return vbnl_sdl_diag_get(p, i)->text;
    fail_msg("no error diagnostic");
    return "";
}

SDL_T_UNUSED static const vbnl_sdl_diag *sdl_t_find_diag(vbnl_sdl_parser *p, vbnl_sdl_severity sev)
{
    for (size_t i = 0; i < vbnl_sdl_diag_count(p); i++)
        if (vbnl_sdl_diag_get(p, i)->severity == sev)
            return vbnl_sdl_diag_get(p, i);
    return NULL;
}

/* Parses text that must fail and checks the complete error text. */
SDL_T_UNUSED static void sdl_t_expect_error(const char *text, const char *expected)
{
    vbnl_result r;
    vbnl_sdl_parser *p = sdl_t_parse(text, &r);
    assert_int_equal(r, VBNL_ERR_PARSE);
    assert_string_equal(sdl_t_error_text(p), expected);
    vbnl_sdl_parser_destroy(p);
}

SDL_T_UNUSED static double sdl_t_float(vbnl_sdl_parser *p, const char *name)
{
    const vbnl_sdl_value *v = vbnl_sdl_lookup(p, name);
    if (!v)
        fail_msg("'%s' is undeclared", name);
    if (v->kind != VBNL_SDL_FLOAT)
        fail_msg("'%s' is a %s, not a float", name, vbnl_sdl_kind_name(v->kind));
    return v->v[0];
}

SDL_T_UNUSED static const vbnl_sdl_value *sdl_t_value(vbnl_sdl_parser *p, const char *name, vbnl_sdl_kind kind)
{
    const vbnl_sdl_value *v = vbnl_sdl_lookup(p, name);
    if (!v)
        fail_msg("'%s' is undeclared", name);
    if (v->kind != kind)
        fail_msg("'%s' is a %s, expected a %s", name, vbnl_sdl_kind_name(v->kind), vbnl_sdl_kind_name(kind));
    return v;
}

SDL_T_UNUSED static const char *sdl_t_string(vbnl_sdl_parser *p, const char *name)
{
    return sdl_t_value(p, name, VBNL_SDL_STRING)->u.str.s;
}

#define SDL_T_NEAR(a, b) assert_true(fabs((double)(a) - (double)(b)) < 1e-9)

SDL_T_UNUSED static void sdl_t_vec(vbnl_sdl_parser *p, const char *name, int dim, double a, double b, double c)
{
    const vbnl_sdl_value *v = sdl_t_value(p, name, VBNL_SDL_VECTOR);
    assert_int_equal(v->dim, dim);
    SDL_T_NEAR(v->v[0], a);
    SDL_T_NEAR(v->v[1], b);
    if (dim > 2)
        SDL_T_NEAR(v->v[2], c);
}

#endif
