/* The block reader (pov_block.h) on its own, through a statement hook that reads test blocks:
 * the order in which rows and hooks are tried, the first table winning, the generic handlers,
 * the closing token (consumed, kept, ']'), pov_block_prefix, pov_row_dispatch, and the exact
 * text and place of the unknown-item and end-of-file reports. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdio.h>
#include <string.h>

#include "pov_block.h"

typedef struct target {
    double a, v[3];
    int words, numbers, strings, second_table;
} target;

/* A number item read by `before`, a string item by `after`. */
static int before(const pov_item *it)
{
    if (it->tok->kind != VBNL_SDL_TOK_NUMBER)
        return 0;
    vbnl_sdl_next(it->p);
    ((target *)it->target)->numbers++;
    return 1;
}

static int after(const pov_item *it)
{
    if (it->tok->kind != VBNL_SDL_TOK_STRING)
        return 0;
    vbnl_sdl_next(it->p);
    ((target *)it->target)->strings++;
    return 1;
}

static vbnl_result word(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    ((target *)it->target)->words++;
    return VBNL_OK;
}

static vbnl_result second(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    ((target *)it->target)->second_table++;
    return VBNL_OK;
}

static const pov_row first_rows[] = {
    {"a", pov_item_float, offsetof(target, a)},
    {"v", pov_item_vec3, offsetof(target, v)},
    {"w", word, 0},
    {"skip", pov_item_skip, 0},
    {NULL, NULL, 0},
};
static const pov_row second_rows[] = {{"w", second, 0}, {"x", second, 0}, {NULL, NULL, 0}};
static const pov_row *const tables[] = {first_rows, second_rows, NULL};

static const pov_block plain = {.name = "t", .tables = tables, .before = before, .after = after};
static const pov_block worded = {.name = "u", .tables = tables, .unknown = pov_block_unexpected_word,
                                 .eof = "unexpected end of file in u", .close = ']'};
static const pov_block kept = {.name = "k", .tables = tables, .keep_close = 1};

static target g_t;

/* t { ... }, u [ ... ], k { ... } (the hook reads k's '}'), p { prefix items } */
static int statement(vbnl_sdl_parser *p, const vbnl_sdl_token *tok, void *user)
{
    (void)user;
    char w[8];
    snprintf(w, sizeof w, "%s", tok->text);
    vbnl_sdl_next(p);
    vbnl_result r = VBNL_ERR_PARSE;
    if (!strcmp(w, "t") && vbnl_sdl_expect(p, '{', "after 't'") == VBNL_OK)
        r = pov_block_parse(&plain, p, NULL, &g_t, NULL);
    else if (!strcmp(w, "n") && vbnl_sdl_expect(p, '{', "after 'n'") == VBNL_OK)
        r = pov_block_parse(&plain, p, NULL, &g_t, "named");
    else if (!strcmp(w, "u") && vbnl_sdl_expect(p, '[', "after 'u'") == VBNL_OK)
        r = pov_block_parse(&worded, p, NULL, &g_t, NULL);
    else if (!strcmp(w, "k") && vbnl_sdl_expect(p, '{', "after 'k'") == VBNL_OK &&
             pov_block_parse(&kept, p, NULL, &g_t, NULL) == VBNL_OK)
        r = vbnl_sdl_expect(p, '}', "after the items of 'k'");
    else if (!strcmp(w, "p") && vbnl_sdl_expect(p, '{', "after 'p'") == VBNL_OK &&
             pov_block_prefix(&plain, p, NULL, &g_t) == VBNL_OK)
        r = vbnl_sdl_expect(p, '}', "after the items of 'p'");
    else if (!strcmp(w, "d")) {
        int d = pov_row_dispatch(first_rows, p, NULL, &g_t);
        assert_int_equal(pov_row_dispatch(first_rows, p, NULL, &g_t), 0); /* ';' names no row */
        r = d == 1 && vbnl_sdl_expect(p, ';', "after 'd'") == VBNL_OK ? VBNL_OK : VBNL_ERR_PARSE;
    }
    return r == VBNL_OK ? 1 : -1;
}

/* Parses text; returns the first line of the error ("" when none). */
static const char *run(const char *text)
{
    static char first[VBNL_ERROR_MESSAGE_SIZE];
    memset(&g_t, 0, sizeof g_t);
    vbnl_sdl_parser *p = NULL;
    assert_int_equal(vbnl_sdl_parser_create(&p, NULL), VBNL_OK);
    vbnl_sdl_hooks h = {NULL, statement, NULL, NULL};
    vbnl_sdl_set_hooks(p, &h);
    vbnl_error err = {0};
    vbnl_result r = vbnl_sdl_parse_text(p, "test.pov", text, strlen(text), &err);
    snprintf(first, sizeof first, "%s", r == VBNL_OK ? "" : err.message);
    vbnl_sdl_parser_destroy(p);
    return first;
}

static void test_rows_and_hooks(void **state)
{
    (void)state;
    assert_string_equal(run("t { a 2 v <1, 2, 3> 7 w \"s\" 8 x skip { any thing } }"), "");
    assert_true(g_t.a == 2 && g_t.v[0] == 1 && g_t.v[1] == 2 && g_t.v[2] == 3);
    assert_int_equal(g_t.numbers, 2);
    assert_int_equal(g_t.strings, 1);
    assert_int_equal(g_t.words, 1);        /* `w` is in both tables: the first one wins */
    assert_int_equal(g_t.second_table, 1); /* `x` only in the second */
    assert_string_equal(run("p { a 1 w a 3 }"), "");
    assert_true(g_t.a == 3 && g_t.words == 1);
    assert_string_equal(run("k { w w }"), "");
    assert_int_equal(g_t.words, 2);
    assert_string_equal(run("u [ a 5 ]"), "");
    assert_true(g_t.a == 5);
    assert_string_equal(run("d a 4;"), "");
    assert_true(g_t.a == 4);
}

static void test_reports(void **state)
{
    (void)state;
    assert_string_equal(run("t { a 1 zzz }"), "test.pov:1:9: unexpected 'zzz' in 't'");
    assert_string_equal(run("n { ; }"), "test.pov:1:5: unexpected ';' in 'named'");
    assert_string_equal(run("t { a 1"), "test.pov:1:8: missing '}' at the end of 't'");
    assert_string_equal(run("u [ w zz ]"), "test.pov:1:7: unexpected 'zz' in u");
    assert_string_equal(run("u [ w"), "test.pov:1:6: unexpected end of file in u");
    assert_string_equal(run("p { a 1 \"s\" }"), "test.pov:1:9: expected '}' after the items of 'p', found string \"s\"");
    assert_string_equal(run("t { a }"), "test.pov:1:7: expected an expression, found '}'");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rows_and_hooks),
        cmocka_unit_test(test_reports),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
