/* vbnl: SDL error messages — exact text, location, source line, caret and include/macro chain;
 * limits that turn runaway scenes into clear errors. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <unistd.h>

#include "sdl_test_util.h"

static void test_unterminated_comment(void **state)
{
    (void)state;
    sdl_t_expect_error("#declare A = 1;\n/* open /* nested */ still open\n#declare B = 2;\n",
                       "test.pov:2:1: error: unterminated comment (missing '*/')\n/* open /* nested */ still open\n^\n");
}

static void test_unterminated_string(void **state)
{
    (void)state;
    sdl_t_expect_error("#declare S = \"abc;\n#declare B = 2;\n",
                       "test.pov:1:14: error: unterminated string (missing closing '\"')\n#declare S = \"abc;\n             ^\n");
}

static void test_missing_end(void **state)
{
    (void)state;
    sdl_t_expect_error("#declare A = 1;\n#if (A)\n  #declare B = 2;\n",
                       "test.pov:2:1: error: missing #end for #if (reached the end of 'test.pov')\n#if (A)\n^\n");
}

static void test_undeclared_suggestion(void **state)
{
    (void)state;
    sdl_t_expect_error("#declare Foo_Bar = 1;\n#declare B = foo_bar * 2;\n",
                       "test.pov:2:14: error: undeclared identifier 'foo_bar'; did you mean 'Foo_Bar'?\n#declare B = foo_bar * 2;\n             ^\n");
}

static void test_bad_vector(void **state)
{
    (void)state;
    sdl_t_expect_error("#declare V = <1, 2 foo>;\n",
                       "test.pov:1:20: error: expected ',' or '>' in vector, found 'foo'\n#declare V = <1, 2 foo>;\n                   ^\n");
}

static void test_division_by_zero(void **state)
{
    (void)state;
    sdl_t_expect_error("#declare Z = 0;\n#declare Q = 1 / Z;\n",
                       "test.pov:2:16: error: division by zero\n#declare Q = 1 / Z;\n               ^\n");
}

static void test_macro_arg_count(void **state)
{
    (void)state;
    sdl_t_expect_error("#macro M(A, B) A + B #end\n#declare X = M(1, 2, 3);\n",
                       "test.pov:2:14: error: macro 'M' expects 2 arguments, got 3 (defined at test.pov:1:8)\n#declare X = M(1, 2, 3);\n             ^\n");
}

static void test_error_directive(void **state)
{
    (void)state;
    sdl_t_expect_error("#declare A = 1;\n#error concat(\"bad value \", str(A, 0, 0))\n",
                       "test.pov:2:1: error: #error: bad value 1\n#error concat(\"bad value \", str(A, 0, 0))\n^\n");
}

static void test_unknown_directive(void **state)
{
    (void)state;
    sdl_t_expect_error("#delcare A = 1;\n",
                       "test.pov:1:2: error: unknown directive '#delcare'\n#delcare A = 1;\n ^\n");
}

static void test_else_without_if(void **state)
{
    (void)state;
    sdl_t_expect_error("#declare A = 1;\n#else\n",
                       "test.pov:2:1: error: #else without matching #if\n#else\n^\n");
}

static void test_end_without_if(void **state)
{
    (void)state;
    sdl_t_expect_error("#end\n",
                       "test.pov:1:1: error: #end without matching #if, #while, #for, #switch or #macro\n#end\n^\n");
}

static void test_expected_equals(void **state)
{
    (void)state;
    sdl_t_expect_error("#declare A 5;\n",
                       "test.pov:1:12: error: expected '=' after the name in #declare, found '5'\n#declare A 5;\n           ^\n");
}

static void test_array_index(void **state)
{
    (void)state;
    sdl_t_expect_error("#declare A = array[3];\n#declare B = A[3];\n",
                       "test.pov:2:16: error: index 3 out of range for dimension 1 of array 'A' (size 3)\n#declare B = A[3];\n               ^\n");
}

static void test_uninitialized_element(void **state)
{
    (void)state;
    sdl_t_expect_error("#declare A = array[3];\n#declare B = A[1] + 1;\n",
                       "test.pov:2:14: error: element of array 'A' used before it was initialized\n#declare B = A[1] + 1;\n             ^\n");
}

static void test_sqrt_domain(void **state)
{
    (void)state;
    sdl_t_expect_error("#declare A = sqrt(-4);\n",
                       "test.pov:1:19: error: argument -4 is outside the domain of sqrt()\n#declare A = sqrt(-4);\n                  ^\n");
}

static void test_string_plus_float(void **state)
{
    (void)state;
    sdl_t_expect_error("#declare A = \"a\" + 1;\n",
                       "test.pov:1:18: error: operator '+' cannot combine a string and a float\n#declare A = \"a\" + 1;\n                 ^\n");
}

static void test_builtin_arg_count(void **state)
{
    (void)state;
    sdl_t_expect_error("#declare A = sin(1, 2);\n",
                       "test.pov:1:14: error: sin() expects 1 argument, got 2\n#declare A = sin(1, 2);\n             ^\n");
}

static void test_missing_paren(void **state)
{
    (void)state;
    sdl_t_expect_error("#declare A = (1 + 2;\n",
                       "test.pov:1:20: error: expected ')' to close '(', found ';'\n#declare A = (1 + 2;\n                   ^\n");
}

static void test_keyword_as_name(void **state)
{
    (void)state;
    sdl_t_expect_error("#declare x = 1;\n",
                       "test.pov:1:10: error: 'x' is a reserved keyword and cannot be used as an identifier\n#declare x = 1;\n         ^\n");
}

static void test_statement(void **state)
{
    (void)state;
    sdl_t_expect_error("#declare A = 1;\n42\n",
                       "test.pov:2:1: error: expected a statement such as an object, camera or light_source, found '42'\n42\n^\n");
}

static void test_condition_vector(void **state)
{
    (void)state;
    sdl_t_expect_error("#if (<1, 2, 3>) #end\n",
                       "test.pov:1:6: error: expected a float condition, found a vector\n#if (<1, 2, 3>) #end\n     ^\n");
}

static void test_unterminated_block(void **state)
{
    (void)state;
    sdl_t_expect_error("sphere { 0, 1\n",
                       "test.pov:1:8: error: missing '}' for the block opened here\nsphere { 0, 1\n       ^\n");
}

static void test_macro_error_chain(void **state)
{
    (void)state;
    sdl_t_expect_error("#macro Inner(A)\n  #declare R = A + Missing;\n#end\n#macro Outer(B) Inner(B) #end\nOuter(1)\n",
                       "test.pov:2:20: error: undeclared identifier 'Missing'\n  #declare R = A + Missing;\n                   ^\n  in macro 'Inner' invoked from test.pov:4:17\n  in macro 'Outer' invoked from test.pov:5:1\n");
}

static void write_file(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

static void test_error_in_include_shows_chain(void **state)
{
    (void)state;
    char dir[] = "/tmp/vbnl_sdl_errXXXXXX";
    assert_non_null(mkdtemp(dir));
    char inner[512], outer[512], scene[512], expected[2048];
    snprintf(inner, sizeof inner, "%s/inner.inc", dir);
    snprintf(outer, sizeof outer, "%s/outer.inc", dir);
    snprintf(scene, sizeof scene, "%s/scene.pov", dir);
    write_file(inner, "#declare Ok = 1;\n#declare Bad = Ok + <1, 2;\n");
    write_file(outer, "// outer\n#include \"inner.inc\"\n");
    write_file(scene, "#declare A = 1;\n#include \"outer.inc\"\n");
    vbnl_sdl_parser *p = NULL;
    assert_int_equal(vbnl_sdl_parser_create(&p, NULL), VBNL_OK);
    vbnl_error err = { 0 };
    assert_int_equal(vbnl_sdl_parse_file(p, scene, &err), VBNL_ERR_PARSE);
    snprintf(expected, sizeof expected,
             "%s/inner.inc:2:26: error: expected ',' or '>' in vector, found ';'\n"
             "#declare Bad = Ok + <1, 2;\n"
             "                         ^\n"
             "  included from %s/outer.inc:2:1\n"
             "  included from %s/scene.pov:2:1\n",
             dir, dir, dir);
    assert_string_equal(sdl_t_error_text(p), expected);
    snprintf(expected, sizeof expected, "%s/inner.inc:2:26: expected ',' or '>' in vector, found ';'", dir);
    assert_string_equal(err.message, expected);
    vbnl_sdl_parser_destroy(p);
    remove(inner);
    remove(outer);
    remove(scene);
    rmdir(dir);
}

static void test_include_not_found_lists_search_path(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = NULL;
    assert_int_equal(vbnl_sdl_parser_create(&p, NULL), VBNL_OK);
    assert_int_equal(vbnl_sdl_set_system_include_dir(p, "/opt/povray/include"), VBNL_OK);
    assert_int_equal(vbnl_sdl_add_include_dir(p, "/srv/scenes/lib/"), VBNL_OK);
    const char *src = "#declare A = 1;\n#include \"missing.inc\"\n";
    assert_int_equal(vbnl_sdl_parse_text(p, "/home/u/scene.pov", src, strlen(src), NULL), VBNL_ERR_PARSE);
    assert_string_equal(sdl_t_error_text(p),
                        "/home/u/scene.pov:2:1: error: cannot find include file 'missing.inc' (searched: /home/u, "
                        "/srv/scenes/lib, /opt/povray/include)\n#include \"missing.inc\"\n^\n");
    vbnl_sdl_parser_destroy(p);
}

static vbnl_sdl_parser *limited(const vbnl_sdl_limits *l)
{
    vbnl_sdl_parser *p = NULL;
    assert_int_equal(vbnl_sdl_parser_create(&p, NULL), VBNL_OK);
    assert_int_equal(vbnl_sdl_set_limits(p, l), VBNL_OK);
    return p;
}

static void test_infinite_while_hits_limit(void **state)
{
    (void)state;
    vbnl_sdl_limits l;
    vbnl_sdl_limits_default(&l);
    l.max_loop_iterations = 1000;
    vbnl_sdl_parser *p = limited(&l);
    const char *src = "#declare I = 0;\n#while (I >= 0)\n  #declare I = I + 1;\n#end\n";
    assert_int_equal(vbnl_sdl_parse_text(p, "test.pov", src, strlen(src), NULL), VBNL_ERR_PARSE);
    assert_string_equal(sdl_t_error_text(p), "test.pov:2:1: error: loop iteration limit exceeded (1000 iterations "
                                             "in total; infinite #while?)\n#while (I >= 0)\n^\n");
    vbnl_sdl_parser_destroy(p);
}

static void test_runaway_recursion_hits_limit(void **state)
{
    (void)state;
    vbnl_sdl_limits l;
    vbnl_sdl_limits_default(&l);
    l.max_macro_depth = 3;
    vbnl_sdl_parser *p = limited(&l);
    const char *src = "#macro R(N)\n  R(N + 1)\n#end\nR(0)\n";
    assert_int_equal(vbnl_sdl_parse_text(p, "test.pov", src, strlen(src), NULL), VBNL_ERR_PARSE);
    assert_string_equal(sdl_t_error_text(p),
                        "test.pov:2:3: error: macro recursion limit exceeded (3 nested invocations of 'R' and others)\n"
                        "  R(N + 1)\n  ^\n"
                        "  in macro 'R' invoked from test.pov:2:3\n"
                        "  in macro 'R' invoked from test.pov:2:3\n"
                        "  in macro 'R' invoked from test.pov:4:1\n");
    vbnl_sdl_parser_destroy(p);
    /* default limits: deep recursion inside expressions stops cleanly, no stack overflow */
    vbnl_result r;
    p = sdl_t_parse("#macro F(N) F(N + 1) + 1 #end\n#declare X = F(0);\n", &r);
    assert_int_equal(r, VBNL_ERR_PARSE);
    assert_non_null(strstr(sdl_t_error_text(p), "macro recursion limit exceeded (256 nested"));
    assert_non_null(strstr(sdl_t_error_text(p), "... 244 more levels ...\n"));
    vbnl_sdl_parser_destroy(p);
}

static void test_nesting_limit(void **state)
{
    (void)state;
    size_t n = 100000;
    char *src = malloc(n * 2 + 64);
    assert_non_null(src);
    strcpy(src, "#declare A = ");
    size_t o = strlen(src);
    for (size_t i = 0; i < n; i++)
        src[o++] = '(';
    src[o++] = '1';
    for (size_t i = 0; i < n; i++)
        src[o++] = ')';
    strcpy(src + o, ";\n");
    vbnl_result r;
    vbnl_sdl_parser *p = sdl_t_parse(src, &r);
    assert_int_equal(r, VBNL_ERR_PARSE);
    assert_non_null(strstr(sdl_t_error_text(p), "error: nesting too deep (more than 512 levels"));
    vbnl_sdl_parser_destroy(p);
    /* unary operators and blocks too */
    memset(src, '-', n);
    strcpy(src + n, "1");
    char *decl = malloc(n + 64);
    assert_non_null(decl);
    snprintf(decl, n + 64, "#declare B = %s;", src);
    p = sdl_t_parse(decl, &r);
    assert_int_equal(r, VBNL_ERR_PARSE);
    vbnl_sdl_parser_destroy(p);
    for (size_t i = 0; i < n; i++)
        src[i] = '{';
    src[n] = 0;
    snprintf(decl, n + 64, "union %s", src);
    p = sdl_t_parse(decl, &r);
    assert_int_equal(r, VBNL_ERR_PARSE);
    assert_non_null(strstr(sdl_t_error_text(p), "blocks nested too deeply"));
    vbnl_sdl_parser_destroy(p);
    free(decl);
    free(src);
}

static void test_memory_and_token_limits(void **state)
{
    (void)state;
    vbnl_sdl_limits l;
    vbnl_sdl_limits_default(&l);
    l.max_memory = 1 << 20;
    vbnl_sdl_parser *p = limited(&l);
    const char *src = "#declare A = array[1000000];\n";
    assert_int_equal(vbnl_sdl_parse_text(p, "test.pov", src, strlen(src), NULL), VBNL_ERR_PARSE);
    assert_non_null(strstr(sdl_t_error_text(p), "memory limit exceeded"));
    vbnl_sdl_parser_destroy(p);
    p = limited(&l);
    src = "#declare S = \"xxxxxxxxxxxxxxxx\";\n#while (1) #declare S = concat(S, S); #end\n";
    assert_int_equal(vbnl_sdl_parse_text(p, "test.pov", src, strlen(src), NULL), VBNL_ERR_PARSE);
    assert_non_null(strstr(sdl_t_error_text(p), "memory limit exceeded"));
    vbnl_sdl_parser_destroy(p);
    vbnl_sdl_limits_default(&l);
    l.max_tokens = 50;
    p = limited(&l);
    src = "#declare I = 0; #while (I < 100) #declare I = I + 1; #end\n";
    assert_int_equal(vbnl_sdl_parse_text(p, "test.pov", src, strlen(src), NULL), VBNL_ERR_PARSE);
    assert_non_null(strstr(sdl_t_error_text(p), "token limit exceeded (50 tokens)"));
    vbnl_sdl_parser_destroy(p);
    vbnl_sdl_limits_default(&l);
    l.max_include_depth = 4;
    p = limited(&l);
    char path[] = "/tmp/vbnl_sdl_selfXXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    close(fd);
    char text[600];
    snprintf(text, sizeof text, "#include \"%s\"\n", path);
    write_file(path, text);
    assert_int_equal(vbnl_sdl_parse_file(p, path, NULL), VBNL_ERR_PARSE);
    assert_non_null(strstr(sdl_t_error_text(p), "include depth limit exceeded (4 nested files)"));
    vbnl_sdl_parser_destroy(p);
    remove(path);
}

static void test_warning_format(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("#macro W() #warning \"inside\" #end\n  W()\n");
    const vbnl_sdl_diag *d = sdl_t_find_diag(p, VBNL_SDL_WARNING);
    assert_non_null(d);
    assert_string_equal(d->text, "test.pov:1:12: warning: inside\n#macro W() #warning \"inside\" #end\n           ^\n"
                                 "  in macro 'W' invoked from test.pov:2:3\n");
    assert_int_equal(d->loc.line, 1);
    assert_int_equal(d->loc.col, 12);
    vbnl_sdl_parser_destroy(p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_unterminated_comment),
        cmocka_unit_test(test_unterminated_string),
        cmocka_unit_test(test_missing_end),
        cmocka_unit_test(test_undeclared_suggestion),
        cmocka_unit_test(test_bad_vector),
        cmocka_unit_test(test_division_by_zero),
        cmocka_unit_test(test_macro_arg_count),
        cmocka_unit_test(test_error_directive),
        cmocka_unit_test(test_unknown_directive),
        cmocka_unit_test(test_else_without_if),
        cmocka_unit_test(test_end_without_if),
        cmocka_unit_test(test_expected_equals),
        cmocka_unit_test(test_array_index),
        cmocka_unit_test(test_uninitialized_element),
        cmocka_unit_test(test_sqrt_domain),
        cmocka_unit_test(test_string_plus_float),
        cmocka_unit_test(test_builtin_arg_count),
        cmocka_unit_test(test_missing_paren),
        cmocka_unit_test(test_keyword_as_name),
        cmocka_unit_test(test_statement),
        cmocka_unit_test(test_condition_vector),
        cmocka_unit_test(test_unterminated_block),
        cmocka_unit_test(test_macro_error_chain),
        cmocka_unit_test(test_error_in_include_shows_chain),
        cmocka_unit_test(test_include_not_found_lists_search_path),
        cmocka_unit_test(test_infinite_while_hits_limit),
        cmocka_unit_test(test_runaway_recursion_hits_limit),
        cmocka_unit_test(test_nesting_limit),
        cmocka_unit_test(test_memory_and_token_limits),
        cmocka_unit_test(test_warning_format),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
