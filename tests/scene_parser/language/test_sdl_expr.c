/* vbnl: SDL expressions — floats, vectors, colours, strings, arrays, built-ins, functions. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include "sdl_test_util.h"

static void test_float_arithmetic(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("#declare A = 1 + 2 * 3 - 4 / 2;\n"
                                  "#declare B = -(2 + 3) * +2;\n"
                                  "#declare C = 1e3 + .5 + 2.;\n"
                                  "#declare D = 2 < 3 & 3 <= 3 & !(1 > 2) | 0;\n"
                                  "#declare E = (1 = 1) + (1 == 1) + (1 != 2) + (3 >= 4);\n"
                                  "#declare F = 1 ? 10 : 20;\n"
                                  "#declare G = 0 ? 10 : 1 ? 30 : 40;\n"
                                  "#declare H = pi + tau;\n"
                                  "#declare I = true + yes + on + false + no + off;\n");
    SDL_T_NEAR(sdl_t_float(p, "A"), 5);
    SDL_T_NEAR(sdl_t_float(p, "B"), -10);
    SDL_T_NEAR(sdl_t_float(p, "C"), 1002.5);
    SDL_T_NEAR(sdl_t_float(p, "D"), 1);
    SDL_T_NEAR(sdl_t_float(p, "E"), 3);
    SDL_T_NEAR(sdl_t_float(p, "F"), 10);
    SDL_T_NEAR(sdl_t_float(p, "G"), 30);
    SDL_T_NEAR(sdl_t_float(p, "H"), 3 * M_PI);
    SDL_T_NEAR(sdl_t_float(p, "I"), 3);
    vbnl_sdl_parser_destroy(p);
}

static void test_vectors(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("#declare V = <1, 2, 3>;\n"
                                  "#declare W = V * 2 + 1;\n"
                                  "#declare N = <1 2 3>;\n" /* POV-Ray tolerates missing commas */
                                  "#declare T = <1, 2, 3,>;\n" /* and a comma before '>' (float4.pov) */
                                  "#declare U = <1, 2>;\n"
                                  "#declare P = U + <1,1,1>;\n" /* shorter vector padded */
                                  "#declare X = x + 2*y - z;\n"
                                  "#declare Vx = V.x + V.y * 10 + V.z * 100;\n"
                                  "#declare Q = <1, 2, 3, 4, 5>;\n"
                                  "#declare Qt = Q.t;\n"
                                  "#declare D = <(2 > 1), -V.x>;\n"
                                  "#declare Cmp = <1,2,3> = <1,5,3>;\n");
    sdl_t_vec(p, "V", 3, 1, 2, 3);
    sdl_t_vec(p, "W", 3, 3, 5, 7);
    sdl_t_vec(p, "N", 3, 1, 2, 3);
    sdl_t_vec(p, "T", 3, 1, 2, 3);
    sdl_t_vec(p, "U", 2, 1, 2, 0);
    sdl_t_vec(p, "P", 3, 2, 3, 1);
    sdl_t_vec(p, "X", 3, 1, 2, -1);
    SDL_T_NEAR(sdl_t_float(p, "Vx"), 321);
    SDL_T_NEAR(sdl_t_float(p, "Qt"), 4);
    assert_int_equal(sdl_t_value(p, "Q", VBNL_SDL_VECTOR)->dim, 5);
    sdl_t_vec(p, "D", 2, 1, -1, 0);
    sdl_t_vec(p, "Cmp", 3, 1, 0, 1);
    vbnl_sdl_parser_destroy(p);
}

static void test_colors(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("#declare A = rgb <1, 0.5, 0>;\n"
                                  "#declare B = rgb 1;\n"
                                  "#declare C = color red 1 green 0.5 filter 0.25;\n"
                                  "#declare D = colour rgbft <0.1, 0.2, 0.3, 0.4, 0.5>;\n"
                                  "#declare E = A * 0.5 + B * 0.5;\n"
                                  "#declare F = color A transmit 0.3;\n"
                                  "#declare G = rgbt <1, 1, 1, 0.7>;\n"
                                  "#declare H = rgbf <1, 1, 1, 0.6>;\n"
                                  "#declare R = A.red + A.green * 10;\n"
                                  "#declare Gr = rgb <1, 1, 1>;\n"
                                  "#declare Gray = Gr.gray;\n"
                                  "#declare T = D.transmit + D.filter;\n");
    const vbnl_sdl_value *v = sdl_t_value(p, "A", VBNL_SDL_COLOR);
    SDL_T_NEAR(v->v[0], 1); SDL_T_NEAR(v->v[1], 0.5); SDL_T_NEAR(v->v[2], 0); SDL_T_NEAR(v->v[3], 0);
    v = sdl_t_value(p, "B", VBNL_SDL_COLOR);
    SDL_T_NEAR(v->v[0], 1); SDL_T_NEAR(v->v[2], 1); SDL_T_NEAR(v->v[4], 0);
    v = sdl_t_value(p, "C", VBNL_SDL_COLOR);
    SDL_T_NEAR(v->v[0], 1); SDL_T_NEAR(v->v[1], 0.5); SDL_T_NEAR(v->v[2], 0); SDL_T_NEAR(v->v[3], 0.25);
    v = sdl_t_value(p, "D", VBNL_SDL_COLOR);
    SDL_T_NEAR(v->v[4], 0.5);
    v = sdl_t_value(p, "E", VBNL_SDL_COLOR);
    SDL_T_NEAR(v->v[0], 1); SDL_T_NEAR(v->v[1], 0.75); SDL_T_NEAR(v->v[2], 0.5);
    v = sdl_t_value(p, "F", VBNL_SDL_COLOR);
    SDL_T_NEAR(v->v[0], 1); SDL_T_NEAR(v->v[4], 0.3);
    v = sdl_t_value(p, "G", VBNL_SDL_COLOR);
    SDL_T_NEAR(v->v[3], 0); SDL_T_NEAR(v->v[4], 0.7);
    v = sdl_t_value(p, "H", VBNL_SDL_COLOR);
    SDL_T_NEAR(v->v[3], 0.6); SDL_T_NEAR(v->v[4], 0);
    SDL_T_NEAR(sdl_t_float(p, "R"), 6);
    SDL_T_NEAR(sdl_t_float(p, "Gray"), 1);
    SDL_T_NEAR(sdl_t_float(p, "T"), 0.9);
    double c[5];
    vbnl_sdl_parser_destroy(p);
    (void)c;
}

/* srgb, srgbf, srgbt and srgbft decode their colour channels from sRGB into vbnl's linear space
 * (POV-Ray's SRGBGammaCurve with assumed_gamma 1); filter, transmit and the channel keywords after
 * them are kept as written. */
static void test_srgb_colors(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("#declare A = srgb <1, 0.5, 0.02>;\n"
                                  "#declare B = srgbf <0.5, 0.5, 0.5, 0.5>;\n"
                                  "#declare C = srgbt <0.25, 0.75, 0.04045, 0.3>;\n"
                                  "#declare D = srgbft <0.5, 0.5, 0.5, 0.2, 0.6>;\n"
                                  "#declare E = srgb 0.5 filter 0.5;\n"
                                  "#declare F = color srgb <0.5, 0.5, 0.5> green 0.5;\n");
    const double half = pow((0.5 + 0.055) / 1.055, 2.4); /* 0.21404 */
    const vbnl_sdl_value *v = sdl_t_value(p, "A", VBNL_SDL_COLOR);
    SDL_T_NEAR(v->v[0], 1); SDL_T_NEAR(v->v[1], half); SDL_T_NEAR(v->v[2], 0.02 / 12.92);
    assert_true(fabs(half - 0.214041) < 1e-6);
    v = sdl_t_value(p, "B", VBNL_SDL_COLOR);
    SDL_T_NEAR(v->v[0], half); SDL_T_NEAR(v->v[3], 0.5); SDL_T_NEAR(v->v[4], 0);
    v = sdl_t_value(p, "C", VBNL_SDL_COLOR);
    SDL_T_NEAR(v->v[0], pow((0.25 + 0.055) / 1.055, 2.4)); SDL_T_NEAR(v->v[1], pow((0.75 + 0.055) / 1.055, 2.4));
    SDL_T_NEAR(v->v[2], pow((0.04045 + 0.055) / 1.055, 2.4)); SDL_T_NEAR(v->v[3], 0); SDL_T_NEAR(v->v[4], 0.3);
    v = sdl_t_value(p, "D", VBNL_SDL_COLOR);
    SDL_T_NEAR(v->v[2], half); SDL_T_NEAR(v->v[3], 0.2); SDL_T_NEAR(v->v[4], 0.6);
    v = sdl_t_value(p, "E", VBNL_SDL_COLOR);
    SDL_T_NEAR(v->v[1], half); SDL_T_NEAR(v->v[3], 0.5);
    v = sdl_t_value(p, "F", VBNL_SDL_COLOR);
    SDL_T_NEAR(v->v[0], half); SDL_T_NEAR(v->v[1], 0.5);
    vbnl_sdl_parser_destroy(p);
}

/* A whole-colour keyword after a colour has begun starts the next one (POV-Ray's Parse_Colour):
 * `rgb <1, 0, 0> rgb <0, 0, 1>` is two colours, as `checker` reads them without a comma. */
static void test_color_ends_at_next_color_keyword(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("#declare B = rgbt <0, 1, 0, 0.5> red 1;\n");
    const vbnl_sdl_value *v = sdl_t_value(p, "B", VBNL_SDL_COLOR);
    SDL_T_NEAR(v->v[0], 1); SDL_T_NEAR(v->v[1], 1); SDL_T_NEAR(v->v[4], 0.5);
    vbnl_sdl_parser_destroy(p);
    p = sdl_t_ok("#declare A = array[3] { rgb <1, 0, 0> rgb <0, 0, 1> srgbt <1, 1, 1, 0.5> }\n"
                 "#declare A0 = A[0]; #declare A1 = A[1]; #declare A2 = A[2];\n");
    v = sdl_t_value(p, "A0", VBNL_SDL_COLOR);
    SDL_T_NEAR(v->v[0], 1); SDL_T_NEAR(v->v[2], 0);
    v = sdl_t_value(p, "A1", VBNL_SDL_COLOR);
    SDL_T_NEAR(v->v[0], 0); SDL_T_NEAR(v->v[2], 1);
    v = sdl_t_value(p, "A2", VBNL_SDL_COLOR);
    SDL_T_NEAR(v->v[1], 1); SDL_T_NEAR(v->v[4], 0.5);
    vbnl_sdl_parser_destroy(p);
}

static void test_strings(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("#declare S = concat(\"ab\", \"cd\", str(3.14159, 0, 2));\n"
                                  "#declare T = \"tab\\there\\n\\\\ \\\"q\\\" \\'s\\'\";\n"
                                  "#declare U = strupr(\"MiXed\");\n"
                                  "#declare L = strlwr(\"MiXed\");\n"
                                  "#declare Sub = substr(\"abcdef\", 2, 3);\n"
                                  "#declare N = strlen(\"hello\") + val(\"2.5\") + asc(\"A\");\n"
                                  "#declare Ch = chr(66);\n"
                                  "#declare V = vstr(3, <1, 2, 3>, \", \", 0, 1);\n"
                                  "#declare Z = str(5, -4, 0);\n"
                                  "#declare Cmp = strcmp(\"a\", \"b\") + (\"x\" = \"x\") * 10;\n"
                                  "#declare Ex = file_exists(\"/definitely/not/here.inc\");\n");
    assert_string_equal(sdl_t_string(p, "S"), "abcd3.14");
    assert_string_equal(sdl_t_string(p, "T"), "tab\there\n\\ \"q\" 's'");
    assert_string_equal(sdl_t_string(p, "U"), "MIXED");
    assert_string_equal(sdl_t_string(p, "L"), "mixed");
    assert_string_equal(sdl_t_string(p, "Sub"), "bcd");
    SDL_T_NEAR(sdl_t_float(p, "N"), 5 + 2.5 + 65);
    assert_string_equal(sdl_t_string(p, "Ch"), "B");
    assert_string_equal(sdl_t_string(p, "V"), "1.0, 2.0, 3.0");
    assert_string_equal(sdl_t_string(p, "Z"), "0005");
    SDL_T_NEAR(sdl_t_float(p, "Cmp"), 9);
    SDL_T_NEAR(sdl_t_float(p, "Ex"), 0);
    vbnl_sdl_parser_destroy(p);
}

static void test_math_builtins(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("#declare A = sin(pi/2) + cos(0) + tan(0);\n"
                                  "#declare B = atan2(1, 1);\n"
                                  "#declare C = degrees(pi) + radians(180);\n"
                                  "#declare D = sqrt(16) + pow(2, 10) + exp(0) + log(100) + ln(1);\n"
                                  "#declare E = abs(-3) + min(4, 2, 8) + max(1, 9, 3);\n"
                                  "#declare F = mod(7, 3) + int(-2.5) * 10 + floor(-2.5) * 100 + ceil(2.1) * 1000;\n"
                                  "#declare G = div(7, 2) + select(-1, 10, 20) + select(0, 1, 2, 3) * 100;\n"
                                  "#declare H = bitwise_and(12, 10) + bitwise_or(12, 10) * 100 + bitwise_xor(12, 10) * 10000;\n"
                                  "#declare I = sinh(0) + cosh(0) + tanh(0) + asinh(0) + acosh(1) + atanh(0) + asin(1) + acos(1);\n");
    SDL_T_NEAR(sdl_t_float(p, "A"), 2);
    SDL_T_NEAR(sdl_t_float(p, "B"), M_PI / 4);
    SDL_T_NEAR(sdl_t_float(p, "C"), 180 + M_PI);
    SDL_T_NEAR(sdl_t_float(p, "D"), 4 + 1024 + 1 + 2 + 0);
    SDL_T_NEAR(sdl_t_float(p, "E"), 3 + 2 + 9);
    SDL_T_NEAR(sdl_t_float(p, "F"), 1 - 20 - 300 + 3000);
    SDL_T_NEAR(sdl_t_float(p, "G"), 3 + 10 + 200);
    SDL_T_NEAR(sdl_t_float(p, "H"), 8 + 1400 + 60000);
    SDL_T_NEAR(sdl_t_float(p, "I"), 1 + M_PI / 2);
    vbnl_sdl_parser_destroy(p);
}

static void test_vector_builtins(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("#declare L = vlength(<3, 4, 0>);\n"
                                  "#declare N = vnormalize(<0, 0, 5>);\n"
                                  "#declare C = vcross(x, y);\n"
                                  "#declare D = vdot(<1, 2, 3>, <4, 5, 6>);\n"
                                  "#declare R = vrotate(<1, 0, 0>, <0, 0, 90>);\n"
                                  "#declare R2 = vrotate(<1, 0, 0>, <0, 90, 0>);\n"
                                  "#declare R3 = vrotate(<0, 1, 0>, <90, 0, 90>);\n"
                                  "#declare A = vaxis_rotate(<1, 0, 0>, <0, 0, 1>, 90);\n"
                                  "#declare A2 = vaxis_rotate(<1, 0, 0>, <1, 1, 0>, 180);\n");
    SDL_T_NEAR(sdl_t_float(p, "L"), 5);
    sdl_t_vec(p, "N", 3, 0, 0, 1);
    sdl_t_vec(p, "C", 3, 0, 0, 1);
    SDL_T_NEAR(sdl_t_float(p, "D"), 32);
    sdl_t_vec(p, "R", 3, 0, 1, 0);
    sdl_t_vec(p, "R2", 3, 0, 0, -1); /* POV-Ray's left-handed rotate: x about y goes to -z */
    sdl_t_vec(p, "R3", 3, 0, 0, 1); /* x first: y -> z, then z: z stays */
    sdl_t_vec(p, "A", 3, 0, 1, 0);
    sdl_t_vec(p, "A2", 3, 0, 1, 0);
    vbnl_sdl_parser_destroy(p);
}

static void test_rand_deterministic(void **state)
{
    (void)state;
    const char *src = "#declare R = seed(123);\n"
                      "#declare A = rand(R);\n#declare B = rand(R);\n"
                      "#declare R2 = seed(123);\n#declare C = rand(R2);\n"
                      "#declare Ok = 1;\n"
                      "#for (I, 1, 1000) #declare X = rand(R); #if (X < 0 | X > 1) #declare Ok = 0; #end #end\n";
    vbnl_sdl_parser *p = sdl_t_ok(src);
    vbnl_sdl_parser *q = sdl_t_ok(src);
    double a = sdl_t_float(p, "A"), b = sdl_t_float(p, "B");
    assert_true(a >= 0 && a <= 1 && b >= 0 && b <= 1);
    assert_true(a != b);
    SDL_T_NEAR(sdl_t_float(p, "C"), a);        /* same seed, same stream */
    SDL_T_NEAR(sdl_t_float(q, "A"), a);        /* deterministic across parsers */
    SDL_T_NEAR(sdl_t_float(q, "X"), sdl_t_float(p, "X"));
    SDL_T_NEAR(sdl_t_float(p, "Ok"), 1);
    vbnl_sdl_parser_destroy(p);
    vbnl_sdl_parser_destroy(q);
}

static void test_arrays(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("#declare A = array[3] {1, 2, 3};\n"
                                  "#declare M = array[2][3] { {1, 2, 3}, {4, 5, 6} };\n"
                                  "#declare S = A[0] + A[2] * 10 + M[1][2] * 100 + M[0][1] * 1000;\n"
                                  "#declare N = dimension_size(M, 1) * 10 + dimension_size(M, 2) + dimensions(M) * 100;\n"
                                  "#declare E = array[4];\n"
                                  "#declare E[2] = \"two\";\n"
                                  "#declare Has = defined(E) + 0;\n"
                                  "#declare B = A;\n"
                                  "#declare B[0] = 100;\n" /* copies: A unchanged */
                                  "#declare Copy0 = A[0];\n"
                                  "#declare V = array[2] { <1,2,3> <4,5,6> };\n" /* no commas */
                                  "#declare Vs = V[1].y;\n"
                                  "#ifdef (E[2]) #declare E2 = 1; #else #declare E2 = 0; #end\n"
                                  "#ifdef (E[1]) #declare E1 = 1; #else #declare E1 = 0; #end\n");
    SDL_T_NEAR(sdl_t_float(p, "S"), 1 + 30 + 600 + 2000);
    SDL_T_NEAR(sdl_t_float(p, "N"), 20 + 3 + 200);
    const vbnl_sdl_value *e = sdl_t_value(p, "E", VBNL_SDL_ARRAY);
    assert_int_equal(vbnl_sdl_array_size(e->u.array, 0), 4);
    assert_int_equal(vbnl_sdl_array_at(e->u.array, 0)->kind, VBNL_SDL_NONE);
    assert_string_equal(vbnl_sdl_array_at(e->u.array, 2)->u.str.s, "two");
    SDL_T_NEAR(sdl_t_float(p, "Copy0"), 1);
    SDL_T_NEAR(sdl_t_float(p, "Vs"), 5);
    SDL_T_NEAR(sdl_t_float(p, "E2"), 1);
    SDL_T_NEAR(sdl_t_float(p, "E1"), 0);
    vbnl_sdl_parser_destroy(p);
}

static void test_functions(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("#declare K = 2;\n"
                                  "#declare F = function { x * x + y * K + z };\n"
                                  "#declare G = function(a, b) { a * 10 + b + F(a, 0, 0) };\n"
                                  "#declare H = function(u, v) { select(u, -1, 1) * max(u, v) + (u > v ? 100 : 0) };\n"
                                  "#declare A = F(3, 1, 1);\n"
                                  "#declare B = G(2, 1);\n"
                                  "#declare C = H(5, 2) + H(-1, 3);\n"
                                  "#declare Fd = function { sin(x) + sqrt(abs(y)) + pow(z, 2) };\n"
                                  "#declare D = Fd(0, -4, 3);\n"
                                  "#declare P = function { pattern { bumps } };\n");
    SDL_T_NEAR(sdl_t_float(p, "A"), 9 + 2 + 1);
    SDL_T_NEAR(sdl_t_float(p, "B"), 21 + 4);
    SDL_T_NEAR(sdl_t_float(p, "C"), 105 - 3);
    SDL_T_NEAR(sdl_t_float(p, "D"), 2 + 9);
    const vbnl_sdl_value *f = sdl_t_value(p, "F", VBNL_SDL_FUNCTION);
    assert_int_equal(vbnl_sdl_function_arity(f->u.fn), 3);
    double args[3] = { 1, 2, 3 }, out = 0;
    assert_int_equal(vbnl_sdl_function_call(p, f->u.fn, args, 3, &out), VBNL_OK);
    SDL_T_NEAR(out, 1 + 4 + 3);
    sdl_t_value(p, "P", VBNL_SDL_FUNCTION);
    vbnl_sdl_parser_destroy(p);
}

static void test_splines(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("#declare S = spline { linear_spline 0, <0,0,0> 1, <10,20,30>, 2, <0,0,0> }\n"
                                  "#declare A = S(0.5);\n#declare B = S(1.5);\n#declare C = S(-1);\n"
                                  "#declare Cu = spline { cubic_spline -1, <-1,-1> 0, <0,0> 1, <1,1> 2, <2,2> 3, <3,3> }\n"
                                  "#declare E = Cu(0.5);\n#declare F = Cu(2.5);\n"
                                  "#declare N = spline { natural_spline 0, 0 1, 1 2, 0 }\n"
                                  "#declare G = N(1);\n"
                                  "#declare S2 = spline { S }\n#declare H = S2(1);\n");
    sdl_t_vec(p, "A", 3, 5, 10, 15);
    sdl_t_vec(p, "B", 3, 5, 10, 15);
    sdl_t_vec(p, "C", 3, 0, 0, 0);
    sdl_t_vec(p, "E", 2, 0.5, 0.5, 0); /* Catmull-Rom on a line stays on it */
    sdl_t_vec(p, "F", 2, 2, 2, 0);     /* cubic: defined between the 2nd and 2nd-last keys */
    SDL_T_NEAR(sdl_t_float(p, "G"), 1);
    sdl_t_vec(p, "H", 3, 10, 20, 30);
    vbnl_sdl_parser_destroy(p);
}

static void test_builtin_identifiers(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = NULL;
    assert_int_equal(vbnl_sdl_parser_create(&p, NULL), VBNL_OK);
    vbnl_sdl_set_image_size(p, 640, 480);
    vbnl_sdl_set_clock(p, 0.5, 0.1, 0.25, 2, 5, 1);
    vbnl_sdl_set_frames(p, 3, 12);
    /* Declare=Size=2.5 and Declare=Name="x" of POV-Ray's command line */
    assert_int_equal(vbnl_sdl_declare_constant(p, "Size", NULL, 2.5), VBNL_OK);
    assert_int_equal(vbnl_sdl_declare_constant(p, "Name", "x", 0), VBNL_OK);
    assert_int_equal(vbnl_sdl_declare_constant(p, "clock", NULL, 1), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_sdl_declare_constant(p, "2a", NULL, 1), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_sdl_declare_constant(p, "", NULL, 1), VBNL_ERR_INVALID_ARGUMENT);
    const char *src = "#declare W = image_width * 1000 + image_height;\n"
                      "#declare Cl = clock + clock_delta * 10 + frame_number * 100 + clock_on * 1000;\n"
                      "#declare Fr = initial_frame * 100 + final_frame + initial_clock * 10000 + final_clock * 1e5;\n"
                      "#declare Dc = Size + strlen(Name);\n"
                      "#declare Ver = version;\n"
                      "#declare Now = now > 8000;\n"
                      "#declare Tv = t;\n#declare Uv = u + v;\n";
    assert_int_equal(vbnl_sdl_parse_text(p, "t.pov", src, strlen(src), NULL), VBNL_OK);
    SDL_T_NEAR(sdl_t_float(p, "W"), 640480);
    SDL_T_NEAR(sdl_t_float(p, "Cl"), 0.5 + 1 + 500 + 1000);
    SDL_T_NEAR(sdl_t_float(p, "Fr"), 312 + 2500 + 2e5);
    SDL_T_NEAR(sdl_t_float(p, "Dc"), 3.5);
    SDL_T_NEAR(sdl_t_float(p, "Ver"), 3.7);
    SDL_T_NEAR(sdl_t_float(p, "Now"), 1);
    const vbnl_sdl_value *tv = sdl_t_value(p, "Tv", VBNL_SDL_VECTOR);
    assert_int_equal(tv->dim, 4);
    SDL_T_NEAR(tv->v[3], 1);
    sdl_t_vec(p, "Uv", 2, 1, 1, 0);
    vbnl_sdl_parser_destroy(p);
}

static void test_comments_and_numbers(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = sdl_t_ok("// line comment #declare X = 1;\n"
                                  "/* block /* nested */ still comment #declare Y = 1; */\n"
                                  "#declare A = 1e5 + 2.5E-1 + .5 + 7.;\n"
                                  "#declare/*inline*/B = 2; // trailing\n");
    assert_null(vbnl_sdl_lookup(p, "X"));
    assert_null(vbnl_sdl_lookup(p, "Y"));
    SDL_T_NEAR(sdl_t_float(p, "A"), 100000 + 0.25 + 0.5 + 7);
    SDL_T_NEAR(sdl_t_float(p, "B"), 2);
    vbnl_sdl_parser_destroy(p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_float_arithmetic),  cmocka_unit_test(test_vectors),
        cmocka_unit_test(test_colors),            cmocka_unit_test(test_srgb_colors),
        cmocka_unit_test(test_color_ends_at_next_color_keyword), cmocka_unit_test(test_strings),
        cmocka_unit_test(test_math_builtins),     cmocka_unit_test(test_vector_builtins),
        cmocka_unit_test(test_rand_deterministic), cmocka_unit_test(test_arrays),
        cmocka_unit_test(test_functions),         cmocka_unit_test(test_builtin_identifiers),
        cmocka_unit_test(test_comments_and_numbers), cmocka_unit_test(test_splines),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
