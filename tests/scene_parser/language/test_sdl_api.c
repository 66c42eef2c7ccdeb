/* vbnl: SDL language layer public API — bad arguments, hooks for the object layer, opaque
 * values, the token/value API, independence of parsers. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <pthread.h>

#include "sdl_test_util.h"

static void test_bad_arguments(void **state)
{
    (void)state;
    vbnl_error err = { 0 };
    assert_int_equal(vbnl_sdl_parser_create(NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_true(strlen(err.message) > 0);
    vbnl_sdl_parser_destroy(NULL);
    vbnl_sdl_parser *p = NULL;
    assert_int_equal(vbnl_sdl_parser_create(&p, NULL), VBNL_OK);
    assert_int_equal(vbnl_sdl_parse_file(p, "/no/such/scene.pov", &err), VBNL_ERR_IO);
    assert_string_equal(err.message, "cannot open scene file '/no/such/scene.pov': No such file or directory");
    assert_int_equal(vbnl_sdl_parse_file(p, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_sdl_parse_text(p, "x", NULL, 5, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_sdl_limits l;
    vbnl_sdl_limits_default(&l);
    l.max_macro_depth = 0;
    assert_int_equal(vbnl_sdl_set_limits(p, &l), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_sdl_set_limits(NULL, &l), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_sdl_add_include_dir(p, ""), VBNL_ERR_INVALID_ARGUMENT);
    assert_null(vbnl_sdl_lookup(p, "nothing"));
    assert_null(vbnl_sdl_lookup(NULL, "x"));
    assert_null(vbnl_sdl_diag_get(p, 0));
    assert_int_equal(vbnl_sdl_peek(NULL)->kind, VBNL_SDL_TOK_EOF);
    assert_int_equal(vbnl_sdl_next(p)->kind, VBNL_SDL_TOK_EOF); /* no parse running */
    assert_int_equal(vbnl_sdl_skip_block(p), VBNL_ERR_STATE);
    double d;
    assert_int_equal(vbnl_sdl_parse_float(NULL, &d), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_sdl_parse_vector(p, 7, &d), VBNL_ERR_INVALID_ARGUMENT);
    /* an empty scene is fine */
    assert_int_equal(vbnl_sdl_parse_text(p, "empty.pov", "", 0, &err), VBNL_OK);
    vbnl_sdl_parser_destroy(p);
}

static void test_reparse_after_error(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = NULL;
    assert_int_equal(vbnl_sdl_parser_create(&p, NULL), VBNL_OK);
    vbnl_error err = { 0 };
    const char *bad = "#declare A = 1;\n#declare B = ;\n";
    assert_int_equal(vbnl_sdl_parse_text(p, "a.pov", bad, strlen(bad), &err), VBNL_ERR_PARSE);
    assert_string_equal(err.message, "a.pov:2:14: expected an expression, found ';'");
    const char *good = "#declare C = A + 1;\n";
    assert_int_equal(vbnl_sdl_parse_text(p, "b.pov", good, strlen(good), &err), VBNL_OK);
    SDL_T_NEAR(sdl_t_float(p, "C"), 2); /* symbols persist across parses */
    vbnl_sdl_parser_destroy(p);
}

typedef struct thread_job {
    const char *text;
    double expect;
    int ok;
} thread_job;

static void *thread_main(void *arg)
{
    thread_job *j = arg;
    vbnl_sdl_parser *p = NULL;
    if (vbnl_sdl_parser_create(&p, NULL) != VBNL_OK)
        return NULL;
    j->ok = 1;
    for (int i = 0; i < 20 && j->ok; i++) {
        if (vbnl_sdl_parse_text(p, "t.pov", j->text, strlen(j->text), NULL) != VBNL_OK)
            j->ok = 0;
        const vbnl_sdl_value *v = vbnl_sdl_lookup(p, "R");
        if (!v || v->kind != VBNL_SDL_FLOAT || v->v[0] != j->expect)
            j->ok = 0;
    }
    vbnl_sdl_parser_destroy(p);
    return NULL;
}

static void test_two_parsers_do_not_interfere(void **state)
{
    (void)state;
    thread_job a = { "#declare S = seed(1); #declare R = 0; #for (I, 1, 500) #declare R = R + 1; #end", 500, 0 };
    thread_job b = { "#macro M(X) X * 2 #end #declare R = 0; #for (I, 1, 300) #declare R = M(R) - R + 1; #end", 300, 0 };
    pthread_t ta, tb;
    assert_int_equal(pthread_create(&ta, NULL, thread_main, &a), 0);
    assert_int_equal(pthread_create(&tb, NULL, thread_main, &b), 0);
    pthread_join(ta, NULL);
    pthread_join(tb, NULL);
    assert_int_equal(a.ok, 1);
    assert_int_equal(b.ok, 1);
}

/* ---- hooks: a miniature object layer ---------------------------------------------------- */

typedef struct mini {
    int spheres;
    int live_textures;
    int copies;
    double camera[3];
} mini;

typedef struct tex {
    double color[5];
    mini *owner;
} tex;

static void tex_destroy(void *ptr, void *user)
{
    (void)user;
    tex *t = ptr;
    t->owner->live_textures--;
    free(t);
}

static void *tex_copy(const void *ptr, void *user)
{
    (void)user;
    const tex *t = ptr;
    tex *c = malloc(sizeof *c);
    if (c) {
        *c = *t;
        c->owner->live_textures++;
        c->owner->copies++;
    }
    return c;
}

static const vbnl_sdl_opaque_type tex_type = { "texture", tex_destroy, tex_copy, NULL, NULL };

static int stmt_hook(vbnl_sdl_parser *p, const vbnl_sdl_token *tok, void *user)
{
    mini *m = user;
    if (strcmp(tok->text, "sphere") == 0) {
        vbnl_sdl_next(p);
        m->spheres++;
        return vbnl_sdl_skip_block(p) == VBNL_OK ? 1 : -1;
    }
    if (strcmp(tok->text, "camera") == 0) {
        vbnl_sdl_next(p);
        if (vbnl_sdl_expect(p, '{', "after camera") != VBNL_OK)
            return -1;
        const vbnl_sdl_token *t = vbnl_sdl_next(p);
        if (t->kind != VBNL_SDL_TOK_IDENT || strcmp(t->text, "location") != 0) {
            vbnl_sdl_error(p, &t->loc, "expected location");
            return -1;
        }
        if (vbnl_sdl_parse_vector(p, 3, m->camera) != VBNL_OK || vbnl_sdl_expect(p, '}', "to close camera") != VBNL_OK)
            return -1;
        return 1;
    }
    return 0;
}

static int rvalue_hook(vbnl_sdl_parser *p, const vbnl_sdl_token *tok, vbnl_sdl_value *out, void *user)
{
    mini *m = user;
    if (strcmp(tok->text, "texture") != 0)
        return 0;
    vbnl_sdl_next(p);
    tex *t = calloc(1, sizeof *t);
    if (!t)
        return -1;
    t->owner = m;
    m->live_textures++;
    if (vbnl_sdl_expect(p, '{', "after texture") != VBNL_OK || vbnl_sdl_parse_color(p, t->color) != VBNL_OK ||
        vbnl_sdl_expect(p, '}', "to close texture") != VBNL_OK) {
        tex_destroy(t, NULL);
        return -1;
    }
    vbnl_sdl_value_object(out, t, &tex_type, 1);
    return 1;
}

static void test_hooks_and_opaque_values(void **state)
{
    (void)state;
    mini m = { 0 };
    vbnl_sdl_parser *p = NULL;
    assert_int_equal(vbnl_sdl_parser_create(&p, NULL), VBNL_OK);
    vbnl_sdl_hooks h = { &m, stmt_hook, rvalue_hook, NULL };
    vbnl_sdl_set_hooks(p, &h);
    const char *src = "#declare Pos = <1, 2, 3>;\n"
                      "#macro Ball() sphere { Pos, 1 } #end\n"
                      "camera { location Pos * 2 }\n"
                      "Ball() Ball()\n"
                      "#declare T1 = texture { color rgb <1, 0, 0> filter 0.5 }\n"
                      "#declare T2 = T1;\n"
                      "#declare Arr = array[2] { T1, T2 }\n"
                      "#declare T1 = 5;\n";
    vbnl_error err = { 0 };
    vbnl_result r = vbnl_sdl_parse_text(p, "h.pov", src, strlen(src), &err);
    if (r != VBNL_OK)
        fail_msg("%s", err.message);
    assert_int_equal(m.spheres, 2);
    SDL_T_NEAR(m.camera[0], 2);
    SDL_T_NEAR(m.camera[2], 6);
    const vbnl_sdl_value *t2 = sdl_t_value(p, "T2", VBNL_SDL_OBJECT);
    assert_ptr_equal(t2->u.obj.type, &tex_type);
    assert_int_equal(t2->u.obj.tag, 1);
    SDL_T_NEAR(((tex *)t2->u.obj.ptr)->color[0], 1);
    SDL_T_NEAR(((tex *)t2->u.obj.ptr)->color[3], 0.5);
    assert_int_equal(m.live_textures, 3); /* T2 and two array copies; T1 was replaced */
    vbnl_sdl_parser_destroy(p);
    assert_int_equal(m.live_textures, 0);
}

static void test_hook_error_location(void **state)
{
    (void)state;
    mini m = { 0 };
    vbnl_sdl_parser *p = NULL;
    assert_int_equal(vbnl_sdl_parser_create(&p, NULL), VBNL_OK);
    vbnl_sdl_hooks h = { &m, stmt_hook, rvalue_hook, NULL };
    vbnl_sdl_set_hooks(p, &h);
    const char *src = "camera {\n  look_at 0\n}\n";
    assert_int_equal(vbnl_sdl_parse_text(p, "c.pov", src, strlen(src), NULL), VBNL_ERR_PARSE);
    assert_string_equal(sdl_t_error_text(p), "c.pov:2:3: error: expected location\n  look_at 0\n  ^\n");
    vbnl_sdl_parser_destroy(p);
}

typedef struct probe {
    int n;
    vbnl_sdl_token toks[32];
    char texts[32][32];
} probe;

static int probe_hook(vbnl_sdl_parser *p, const vbnl_sdl_token *tok, void *user)
{
    probe *pr = user;
    if (strcmp(tok->text, "probe") != 0)
        return 0;
    vbnl_sdl_next(p);
    if (vbnl_sdl_expect(p, '{', "after probe") != VBNL_OK)
        return -1;
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_next(p);
        if (t->kind == VBNL_SDL_TOK_EOF)
            return -1;
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '}')
            return 1;
        if (pr->n < 32) {
            pr->toks[pr->n] = *t;
            snprintf(pr->texts[pr->n], sizeof pr->texts[0], "%.*s", (int)t->len, t->text);
            pr->n++;
        }
    }
}

static void test_token_api(void **state)
{
    (void)state;
    probe pr = { 0 };
    vbnl_sdl_parser *p = NULL;
    assert_int_equal(vbnl_sdl_parser_create(&p, NULL), VBNL_OK);
    vbnl_sdl_hooks h = { &pr, probe_hook, NULL, NULL };
    vbnl_sdl_set_hooks(p, &h);
    const char *src = "#macro Two() 2.5e1 #end\n"
                      "probe { name \"s\\u0041\\t\" <= >= != Two()\n"
                      "  #if (0) skipped #else kept #end }\n";
    vbnl_error err = { 0 };
    vbnl_result r = vbnl_sdl_parse_text(p, "tok.pov", src, strlen(src), &err);
    if (r != VBNL_OK)
        fail_msg("%s", err.message);
    assert_int_equal(pr.n, 7);
    assert_int_equal(pr.toks[0].kind, VBNL_SDL_TOK_IDENT);
    assert_string_equal(pr.texts[0], "name");
    assert_int_equal(pr.toks[0].loc.line, 2);
    assert_int_equal(pr.toks[0].loc.col, 9);
    assert_string_equal(pr.toks[0].loc.file, "tok.pov");
    assert_int_equal(pr.toks[1].kind, VBNL_SDL_TOK_STRING);
    assert_string_equal(pr.texts[1], "sA\t");
    assert_int_equal(pr.toks[2].op, VBNL_SDL_OP_LE);
    assert_int_equal(pr.toks[3].op, VBNL_SDL_OP_GE);
    assert_int_equal(pr.toks[4].op, VBNL_SDL_OP_NE);
    assert_int_equal(pr.toks[5].kind, VBNL_SDL_TOK_NUMBER); /* from the macro body */
    SDL_T_NEAR(pr.toks[5].number, 25);
    assert_int_equal(pr.toks[5].loc.line, 1);
    assert_int_equal(pr.toks[5].loc.col, 14);
    assert_string_equal(pr.texts[6], "kept");
    assert_int_equal(pr.toks[6].loc.line, 3);
    vbnl_sdl_parser_destroy(p);
}

static int diag_calls;
static void count_diag(const vbnl_sdl_diag *d, void *user)
{
    (void)d;
    (void)user;
    diag_calls++;
}

static void test_diag_callback(void **state)
{
    (void)state;
    vbnl_sdl_parser *p = NULL;
    assert_int_equal(vbnl_sdl_parser_create(&p, NULL), VBNL_OK);
    vbnl_sdl_set_diag_callback(p, count_diag, NULL);
    diag_calls = 0;
    const char *src = "#for (I, 1, 3) #debug \"x\" #end\n#warning \"w\"\n";
    assert_int_equal(vbnl_sdl_parse_text(p, "d.pov", src, strlen(src), NULL), VBNL_OK);
    assert_int_equal(diag_calls, 4);
    assert_int_equal(vbnl_sdl_diag_count(p), 4);
    vbnl_sdl_parser_destroy(p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bad_arguments),           cmocka_unit_test(test_reparse_after_error),
        cmocka_unit_test(test_two_parsers_do_not_interfere), cmocka_unit_test(test_hooks_and_opaque_values),
        cmocka_unit_test(test_hook_error_location),     cmocka_unit_test(test_diag_callback),
        cmocka_unit_test(test_token_api),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
