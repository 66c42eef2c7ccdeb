/* vbnl: SDL directives and macros. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <unistd.h>

#include "sdl_test_util.h"

static void test_declare_local_undef(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("#declare A = 1;\n"
                                  "#local B = 2;\n" /* top level: global */
                                  "#declare C = A + B\n" /* semicolon optional */
                                  "#declare D = 4;\n"
                                  "#undef D\n"
                                  "#declare deprecated once \"old\" E = 5;\n");
    SDL_T_NEAR(sdl_t_float(p, "A"), 1);
    SDL_T_NEAR(sdl_t_float(p, "B"), 2);
    SDL_T_NEAR(sdl_t_float(p, "C"), 3);
    assert_null(vbnl_sdl_lookup(p, "D"));
    SDL_T_NEAR(sdl_t_float(p, "E"), 5);
    vbnl_sdl_parser_destroy(p);
}

static void test_if_family(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("#declare A = 0; #declare B = 0; #declare C = 0; #declare D = 0;\n"
                                  "#if (1) #declare A = 1; #else #declare A = 2; #end\n"
                                  "#if (0) #declare B = 1; #elseif (0) #declare B = 2; #elseif (1) #declare B = 3; #else #declare B = 4; #end\n"
                                  "#if (0) #if (1) #declare C = 9; #end #else #declare C = 5; #end\n"
                                  "#ifdef (A) #declare D = D + 1; #end\n"
                                  "#ifndef (Nope) #declare D = D + 10; #end\n"
                                  "#ifdef (Nope) #declare D = 100; #else #declare D = D + 1000; #end\n"
                                  "#if (0) \"#end inside a string\" /* #end */ #declare D = -1; #end\n"
                                  "#if (defined(A) & !defined(Nope)) #declare E = 1; #end\n");
    SDL_T_NEAR(sdl_t_float(p, "A"), 1);
    SDL_T_NEAR(sdl_t_float(p, "B"), 3);
    SDL_T_NEAR(sdl_t_float(p, "C"), 5);
    SDL_T_NEAR(sdl_t_float(p, "D"), 1011);
    SDL_T_NEAR(sdl_t_float(p, "E"), 1);
    vbnl_sdl_parser_destroy(p);
}

static void test_loops(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("#declare S = 0; #declare I = 0;\n"
                                  "#while (I < 10) #declare S = S + I; #declare I = I + 1; #end\n"
                                  "#declare T = 0;\n"
                                  "#for (J, 1, 10) #declare T = T + J; #end\n"
                                  "#declare U = 0;\n"
                                  "#for (J, 10, 0, -2.5) #declare U = U + J; #end\n"
                                  "#declare W = 0;\n"
                                  "#for (J, 5, 1) #declare W = 1; #end\n" /* no iteration */
                                  "#declare N = 0;\n"
                                  "#for (Y, 1, 3) #for (X, 1, 4) #declare N = N + 1; #end #end\n"
                                  "#declare K = 0;\n"
                                  "#while (1) #declare K = K + 1; #if (K = 7) #break #end #end\n"
                                  "#declare L = 0;\n"
                                  "#for (J, 1, 100) #if (J > 3) #break #end #declare L = J; #end\n");
    SDL_T_NEAR(sdl_t_float(p, "S"), 45);
    SDL_T_NEAR(sdl_t_float(p, "T"), 55);
    SDL_T_NEAR(sdl_t_float(p, "U"), 10 + 7.5 + 5 + 2.5 + 0);
    SDL_T_NEAR(sdl_t_float(p, "W"), 0);
    SDL_T_NEAR(sdl_t_float(p, "N"), 12);
    SDL_T_NEAR(sdl_t_float(p, "K"), 7);
    SDL_T_NEAR(sdl_t_float(p, "L"), 3);
    vbnl_sdl_parser_destroy(p);
}

static void test_switch(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("#macro Classify(V)\n"
                                  "  #switch (V)\n"
                                  "    #case (1) 10 #break\n"
                                  "    #case (2)\n"
                                  "    #case (3) 20 #break\n"       /* 2 falls through into 3 */
                                  "    #range (4, 6) 30 #break\n"
                                  "    #else -1\n"
                                  "  #end\n"
                                  "#end\n"
                                  "#declare A = Classify(1); #declare B = Classify(2); #declare C = Classify(3);\n"
                                  "#declare D = Classify(5); #declare E = Classify(9);\n"
                                  "#declare F = 0;\n"
                                  "#switch (1) #case (1) #declare F = F + 1; #case (2) #declare F = F + 10; #break #case (3) #declare F = 100; #end\n");
    SDL_T_NEAR(sdl_t_float(p, "A"), 10);
    SDL_T_NEAR(sdl_t_float(p, "B"), 20);
    SDL_T_NEAR(sdl_t_float(p, "C"), 20);
    SDL_T_NEAR(sdl_t_float(p, "D"), 30);
    SDL_T_NEAR(sdl_t_float(p, "E"), -1);
    SDL_T_NEAR(sdl_t_float(p, "F"), 11);
    vbnl_sdl_parser_destroy(p);
}

static void test_version_and_messages(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("#declare Old = version;\n"
                                  "#version 3.5;\n"
                                  "#declare Mid = version;\n"
                                  "#version Old;\n"
                                  "#debug concat(\"hello \", str(42, 0, 0), \"\\n\")\n"
                                  "#warning \"careful\"\n");
    SDL_T_NEAR(sdl_t_float(p, "Mid"), 3.5);
    SDL_T_NEAR(vbnl_sdl_language_version(p), 3.7);
    const vbnl_sdl_diag *d = sdl_t_find_diag(p, VBNL_SDL_NOTE);
    assert_non_null(d);
    assert_string_equal(d->message, "hello 42\n");
    d = sdl_t_find_diag(p, VBNL_SDL_WARNING);
    assert_non_null(d);
    assert_string_equal(d->text, "test.pov:6:1: warning: careful\n#warning \"careful\"\n^\n");
    assert_int_equal(vbnl_sdl_warning_count(p), 1);
    vbnl_sdl_parser_destroy(p);
}

/* Scene text reaches a terminal escaped: a control character (ESC of a colour or screen-clearing
 * sequence, BEL, CR, the C1 CSI) shows as \xHH instead of acting; newline and tab stay. */
static void test_messages_escape_control_characters(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("#debug concat(chr(27), \"[2J\\tx\\n\")\n"
                                  "#warning concat(\"bell\", chr(7), chr(13), chr(155), \"[31m \", chr(233))\n");
    const vbnl_sdl_diag *d = sdl_t_find_diag(p, VBNL_SDL_NOTE);
    assert_non_null(d);
    assert_string_equal(d->message, "\\x1b[2J\tx\n");
    d = sdl_t_find_diag(p, VBNL_SDL_WARNING);
    assert_non_null(d);
    /* U+009B is C2 9B in UTF-8, escaped byte by byte; U+00E9 (C3 A9) is printable and kept */
    assert_string_equal(d->message, "bell\\x07\\x0d\\xc2\\x9b[31m \xc3\xa9");
    vbnl_sdl_parser_destroy(p);
    /* #error; a raw ESC in the source line under the message, the caret still under the column */
    sdl_t_expect_error("#error concat(\"stop\", chr(27), \"]0;title\", chr(7))\n",
                       "test.pov:1:1: error: #error: stop\\x1b]0;title\\x07\n"
                       "#error concat(\"stop\", chr(27), \"]0;title\", chr(7))\n"
                       "^\n");
    sdl_t_expect_error("#declare A = \"\x1b[2J\"; #declare B = C;\n",
                       "test.pov:1:35: error: undeclared identifier 'C'; did you mean 'A'?\n"
                       "#declare A = \"\\x1b[2J\"; #declare B = C;\n"
                       "                                     ^\n");
}

static void test_default_and_blocks(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("#default { finish { ambient 0.1 diffuse 0.6 } }\n"
                                  "#declare T = texture { pigment { color rgb 1 } } texture { pigment { rgbt 1 } }\n"
                                  "#declare O = union { sphere { 0, 1 } #declare Inside = 5; box { -1, 1 } }\n"
                                  "#declare O2 = O;\n"
                                  "camera { location <0, 0, -5> look_at 0 }\n"
                                  "sphere { 0, 1 #if (1) translate x #end }\n"
                                  "object { O2 }\n");
    assert_int_equal(vbnl_sdl_default_count(p), 1);
    assert_int_equal(vbnl_sdl_default_get(p, 0)->kind, VBNL_SDL_BLOCK);
    const vbnl_sdl_value *t = sdl_t_value(p, "T", VBNL_SDL_BLOCK);
    assert_string_equal(vbnl_sdl_block_keyword(t->u.block), "texture");
    assert_int_equal(vbnl_sdl_block_loc(t->u.block).line, 2);
    assert_string_equal(vbnl_sdl_block_keyword(sdl_t_value(p, "O2", VBNL_SDL_BLOCK)->u.block), "union");
    SDL_T_NEAR(sdl_t_float(p, "Inside"), 5); /* directives inside declared blocks run */
    vbnl_sdl_parser_destroy(p);
}

static void test_macros(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("#macro Add(A, B) (A + B) #end\n"
                                  "#macro Twice(V) #local T = V * 2; T #end\n"       /* local returned */
                                  "#macro Fact(N) #if (N <= 1) 1 #else N * Fact(N - 1) #end #end\n"
                                  "#macro SetG(V) #declare G = V; #end\n"
                                  "#macro Opt(A, optional B) #ifdef (B) A + B #else A #end #end\n"
                                  "#macro Swap(P, Q) #local Tmp = P; #declare P = Q; #declare Q = Tmp; #end\n"
                                  "#macro Vec(X) <X, X + 1, X + 2> #end\n"
                                  "#declare A = Add(1, 2) * 10;\n"
                                  "#declare B = Twice(4) + Twice(Twice(1));\n"
                                  "#declare C = Fact(6);\n"
                                  "SetG(7)\n"
                                  "#declare O1 = Opt(1); #declare O2 = Opt(1, 5);\n"
                                  "#declare X1 = 1; #declare X2 = 2; Swap(X1, X2)\n"
                                  "#declare V = Vec(1).z;\n"
                                  "#declare T = 99;\n"
                                  "#declare Tw = Twice(1);\n"); /* the macro's local T hides nothing outside */
    SDL_T_NEAR(sdl_t_float(p, "A"), 30);
    SDL_T_NEAR(sdl_t_float(p, "B"), 8 + 4);
    SDL_T_NEAR(sdl_t_float(p, "C"), 720);
    SDL_T_NEAR(sdl_t_float(p, "G"), 7);
    SDL_T_NEAR(sdl_t_float(p, "O1"), 1);
    SDL_T_NEAR(sdl_t_float(p, "O2"), 6);
    SDL_T_NEAR(sdl_t_float(p, "X1"), 2);
    SDL_T_NEAR(sdl_t_float(p, "X2"), 1);
    SDL_T_NEAR(sdl_t_float(p, "V"), 3);
    SDL_T_NEAR(sdl_t_float(p, "T"), 99);
    SDL_T_NEAR(sdl_t_float(p, "Tw"), 2);
    assert_int_equal(vbnl_sdl_lookup(p, "Add")->kind, VBNL_SDL_MACRO);
    vbnl_sdl_parser_destroy(p);
}

static void test_macro_scoping(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("#macro Count(N)\n"
                                  "  #local K = 0;\n"
                                  "  #while (K < N) #declare K = K + 1; #end\n" /* #declare updates the local */
                                  "  K\n"
                                  "#end\n"
                                  "#declare R = Count(5);\n"
                                  "#macro Inner() Y #end\n"
                                  "#macro Outer(Y) Inner() #end\n" /* dynamic scope, as POV-Ray */
                                  "#declare D = Outer(42);\n"
                                  "#macro Sum(A) #local S = 0; #for (I, 0, dimension_size(A, 1) - 1) #local S = S + A[I]; #end S #end\n"
                                  "#declare Arr = array[4] {1, 2, 3, 4};\n"
                                  "#declare S = Sum(Arr);\n"
                                  "#macro Fill(A) #for (I, 0, 3) #declare A[I] = I * I; #end #end\n"
                                  "Fill(Arr)\n" /* arrays passed by identifier are references */
                                  "#declare Sq = Arr[3];\n");
    SDL_T_NEAR(sdl_t_float(p, "R"), 5);
    assert_null(vbnl_sdl_lookup(p, "K"));
    SDL_T_NEAR(sdl_t_float(p, "D"), 42);
    SDL_T_NEAR(sdl_t_float(p, "S"), 10);
    SDL_T_NEAR(sdl_t_float(p, "Sq"), 9);
    vbnl_sdl_parser_destroy(p);
}

static void test_macro_statement_text(void **state)
{
    (void)state;
    /* macros produce scene text: blocks at statement level and inside blocks */
    vbnl_sdl_parser *p = sdl_t_ok("#macro Ball(R) sphere { 0, R } #end\n"
                                  "#macro Shift() translate <1, 2, 3> #end\n"
                                  "Ball(1)\n"
                                  "object { Ball(2) Shift() }\n"
                                  "#declare B = Ball(3)\n"
                                  "#declare Done = 1;\n");
    assert_string_equal(vbnl_sdl_block_keyword(sdl_t_value(p, "B", VBNL_SDL_BLOCK)->u.block), "sphere");
    SDL_T_NEAR(sdl_t_float(p, "Done"), 1);
    vbnl_sdl_parser_destroy(p);
}

static void test_include_and_search_path(void **state)
{
    (void)state;
    char dir[] = "/tmp/vbnl_sdl_incXXXXXX";
    assert_non_null(mkdtemp(dir));
    char path[512];
    snprintf(path, sizeof path, "%s/lib.inc", dir);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs("#local Hidden = 5;\n#declare FromInc = Hidden + 1;\n#macro IncMacro(X) X * 3 #end\n", f);
    fclose(f);
    vbnl_sdl_parser *p = NULL;
    assert_int_equal(vbnl_sdl_parser_create(&p, NULL), VBNL_OK);
    assert_int_equal(vbnl_sdl_add_include_dir(p, dir), VBNL_OK);
    const char *src = "#include \"lib.inc\"\n#declare M = IncMacro(2);\n#include \"colors.inc\"\n#declare R = Red;\n";
    vbnl_error err = { 0 };
    vbnl_result r = vbnl_sdl_parse_text(p, "main.pov", src, strlen(src), &err);
    if (r != VBNL_OK)
        fail_msg("%s", err.message);
    SDL_T_NEAR(sdl_t_float(p, "FromInc"), 6);
    assert_null(vbnl_sdl_lookup(p, "Hidden")); /* #local in an include stays there */
    SDL_T_NEAR(sdl_t_float(p, "M"), 6);
    assert_int_equal(sdl_t_value(p, "R", VBNL_SDL_COLOR)->v[0], 1);
    vbnl_sdl_parser_destroy(p);
    remove(path);
    rmdir(dir);
}

static void test_standard_includes(void **state)
{
    (void)state;
    static const char *const incs[] = { "colors.inc", "textures.inc", "finish.inc", "metals.inc", "glass.inc",
                                         "woods.inc", "stones.inc", "shapes.inc", "rad_def.inc", "math.inc",
                                         "functions.inc", "transforms.inc", "strings.inc", "arrays.inc" };
    for (size_t i = 0; i < sizeof incs / sizeof incs[0]; i++) {
        char src[128];
        snprintf(src, sizeof src, "#include \"%s\"\n", incs[i]);
        vbnl_sdl_parser *p = sdl_t_ok(src);
        assert_int_equal(vbnl_sdl_warning_count(p), 0);
        vbnl_sdl_parser_destroy(p);
    }
    vbnl_sdl_parser *p = sdl_t_ok("#include \"math.inc\"\n#include \"colors.inc\"\n#include \"metals.inc\"\n"
                                  "#declare E = even(4) + odd(4) * 10;\n"
                                  "#declare P = VPerp_To_Vector(<1, 2, 3>);\n"
                                  "#declare Dot = vdot(P, <1, 2, 3>);\n");
    SDL_T_NEAR(sdl_t_float(p, "E"), 1);
    assert_true(fabs(sdl_t_float(p, "Dot")) < 1e-12);
    sdl_t_value(p, "T_Gold_1A", VBNL_SDL_BLOCK);
    sdl_t_value(p, "MediumOrchid", VBNL_SDL_COLOR);
    vbnl_sdl_parser_destroy(p);
}

static void test_vbnl_version(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = NULL;
    assert_int_equal(vbnl_sdl_parser_create(&p, NULL), VBNL_OK);
    vbnl_sdl_set_vbnl_version(p, 1.5);
    const char *src = "#ifdef (vbnl_version) #declare V = vbnl_version; #else #declare V = 0; #end\n";
    assert_int_equal(vbnl_sdl_parse_text(p, "v.pov", src, strlen(src), NULL), VBNL_OK);
    SDL_T_NEAR(sdl_t_float(p, "V"), 1.5);
    vbnl_sdl_parser_destroy(p);
}

/* A scene reads only its own folder, the include path and POV-Ray's folder: an include outside is
 * refused without reading it (its text never reaches a message), and file_exists does not see
 * outside files. */
static void test_reads_confined(void **state)
{
    (void)state;
    sdl_t_expect_error("#include \"/etc/passwd\"\n",
                       "test.pov:1:1: error: include file '/etc/passwd' is outside the folders a scene may read (its "
                       "own, the include path, POV-Ray's)\n#include \"/etc/passwd\"\n^\n");
    vbnl_sdl_parser *p = sdl_t_ok("#declare E = file_exists(\"/etc/passwd\");\n");
    assert_float_equal(sdl_t_float(p, "E"), 0.0, 0.0);
    vbnl_sdl_parser_destroy(p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_declare_local_undef), cmocka_unit_test(test_if_family),
        cmocka_unit_test(test_loops),               cmocka_unit_test(test_switch),
        cmocka_unit_test(test_version_and_messages), cmocka_unit_test(test_default_and_blocks),
        cmocka_unit_test(test_messages_escape_control_characters),
        cmocka_unit_test(test_macros),              cmocka_unit_test(test_macro_scoping),
        cmocka_unit_test(test_macro_statement_text), cmocka_unit_test(test_include_and_search_path),
        cmocka_unit_test(test_standard_includes),   cmocka_unit_test(test_vbnl_version),
        cmocka_unit_test(test_reads_confined),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
