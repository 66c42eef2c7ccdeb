/* Named integrator parameters (vbnl/params.h, core/src/params.c): text parsing, validation against
 * a spec table with messages that name the origin and the closest valid name, defaults, later
 * settings replacing earlier ones, appending lists, reading settings back. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <stdio.h>
#include <string.h>

#include "vbnl/params.h"

/* Setting, validating and reading back: the scene and command-line path. */
static void test_validate(void **state)
{
    (void)state;
    static const char *const modes[] = {"adaptive", "uniform", "none", NULL};
    static const vbnl_param_spec spec[] = {
        {"virtual_lights", VBNL_PARAM_INT, 1000, NULL, 1, 1e9, NULL, "N"},
        {"early_stop", VBNL_PARAM_FLOAT, 0.8, NULL, 0, 1, NULL, "p"},
        {"lazy", VBNL_PARAM_BOOL, 1, NULL, 0, 1, NULL, "lazy"},
        {"elimination", VBNL_PARAM_ENUM, 0, "adaptive", 0, 0, modes, "mode"},
    };
    vbnl_params *p;
    vbnl_error err = {0};
    assert_int_equal(vbnl_params_create(&p, &err), VBNL_OK);
    assert_int_equal(vbnl_params_validate(p, spec, 4, "x", &err), VBNL_OK);
    assert_float_equal(vbnl_params_number(p, spec, 4, "early_stop"), 0.8, 0);
    assert_string_equal(vbnl_params_string(p, spec, 4, "elimination"), "adaptive");
    assert_false(vbnl_params_has(p, "virtual_lights")); /* defaulted, not set */
    assert_false(vbnl_params_has(NULL, "virtual_lights"));
    assert_int_equal(vbnl_params_set_text(p, "virtual_lights=5e4", "a.pov:3:7", &err), VBNL_OK);
    assert_true(vbnl_params_has(p, "virtual_lights"));
    assert_false(vbnl_params_has(p, "early_stop"));
    assert_int_equal(vbnl_params_set_text(p, "lazy=off", NULL, &err), VBNL_OK);
    assert_int_equal(vbnl_params_set_text(p, "elimination=uniform", NULL, &err), VBNL_OK);
    assert_int_equal(vbnl_params_validate(p, spec, 4, "vbnl", &err), VBNL_OK);
    assert_float_equal(vbnl_params_number(p, spec, 4, "virtual_lights"), 50000.0, 0);
    assert_float_equal(vbnl_params_number(p, spec, 4, "lazy"), 0.0, 0);
    assert_string_equal(vbnl_params_string(p, spec, 4, "elimination"), "uniform");
    /* a later setting replaces an earlier one */
    assert_int_equal(vbnl_params_set_text(p, "virtual_lights=7", NULL, &err), VBNL_OK);
    assert_float_equal(vbnl_params_number(p, spec, 4, "virtual_lights"), 7.0, 0);
    assert_int_equal(vbnl_params_count(p), 3);
    /* unknown name: closest valid one and the list, with the origin */
    vbnl_params_set_text(p, "virtual_light=5", "scene.pov:12:40", NULL);
    assert_int_equal(vbnl_params_validate(p, spec, 4, "integrator 'vbnl'", &err), VBNL_ERR_UNKNOWN_NAME);
    assert_non_null(strstr(err.message, "scene.pov:12:40: unknown parameter 'virtual_light'"));
    assert_non_null(strstr(err.message, "did you mean 'virtual_lights'?"));
    assert_non_null(strstr(err.message, "early_stop"));
    vbnl_params_destroy(p);
    /* types and ranges */
    const char *bad[] = {"virtual_lights=0", "virtual_lights=2.5", "early_stop=1.5", "lazy=2",
                         "elimination=fast", "virtual_lights=lots"};
    const char *expect[] = {"must lie in [1", "takes an integer", "must lie in [0, 1]", "on/off",
                            "must be one of adaptive, uniform, none", "takes an integer"};
    for (int i = 0; i < 6; ++i) {
        vbnl_params_create(&p, NULL);
        assert_int_equal(vbnl_params_set_text(p, bad[i], NULL, &err), VBNL_OK);
        assert_int_equal(vbnl_params_validate(p, spec, 4, "vbnl", &err), VBNL_ERR_INVALID_ARGUMENT);
        if (!strstr(err.message, expect[i]))
            fail_msg("'%s' gave '%s'", bad[i], err.message);
        vbnl_params_destroy(p);
    }
    vbnl_params_create(&p, NULL);
    assert_int_equal(vbnl_params_set_text(p, "novalue", NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_params_set_text(p, "=3", NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_params_destroy(p);
}

/* Appending, reading back and what is copied. */
static void test_append_and_get(void **state)
{
    (void)state;
    vbnl_params *a = NULL, *b = NULL;
    vbnl_error err = {0};
    assert_int_equal(vbnl_params_create(&a, &err), VBNL_OK);
    assert_int_equal(vbnl_params_create(&b, &err), VBNL_OK);
    char name[16] = "spp", where[16] = "a.pov:1:2", text[16] = "fast";
    assert_int_equal(vbnl_params_set_number(a, name, 4, where, &err), VBNL_OK);
    assert_int_equal(vbnl_params_set_string(a, "mode", text, NULL, &err), VBNL_OK);
    /* the list keeps copies: the caller's buffers may change */
    strcpy(name, "xxx");
    strcpy(where, "elsewhere");
    strcpy(text, "slow");
    assert_int_equal(vbnl_params_set_number(b, "spp", 9, "cli", &err), VBNL_OK);
    assert_int_equal(vbnl_params_set_text(b, "extra=yes", NULL, &err), VBNL_OK);
    assert_int_equal(vbnl_params_append(a, b, &err), VBNL_OK);
    /* b's "spp" replaced a's (later settings win); "extra" is new */
    assert_int_equal(vbnl_params_count(a), 3);
    const char *n = NULL, *str = NULL, *w = NULL;
    int is_string = -1;
    double num = -1;
    int seen_spp = 0, seen_mode = 0, seen_extra = 0;
    for (uint32_t i = 0; i < vbnl_params_count(a); ++i) {
        assert_int_equal(vbnl_params_get(a, i, &n, &is_string, &num, &str, &w), VBNL_OK);
        if (!strcmp(n, "spp")) {
            seen_spp = 1;
            assert_false(is_string);
            assert_float_equal(num, 9.0, 0.0);
            assert_string_equal(w, "cli");
        } else if (!strcmp(n, "mode")) {
            seen_mode = 1;
            assert_true(is_string);
            assert_string_equal(str, "fast");
            assert_null(w);
        } else if (!strcmp(n, "extra")) {
            seen_extra = 1;
            assert_false(is_string);
            assert_float_equal(num, 1.0, 0.0); /* yes = 1 */
        }
    }
    assert_true(seen_spp && seen_mode && seen_extra);
    assert_int_equal(vbnl_params_get(a, 3, &n, NULL, NULL, NULL, NULL), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_params_get(NULL, 0, &n, NULL, NULL, NULL, NULL), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_params_count(NULL), 0);
    vbnl_params_destroy(a);
    vbnl_params_destroy(b);
    vbnl_params_destroy(NULL);
}

/* Types: a string for a number is refused and the reverse; an unset parameter reads its default;
 * a list of nothing validates. */
static void test_types_and_defaults(void **state)
{
    (void)state;
    static const char *const modes[] = {"a", "b", NULL};
    static const vbnl_param_spec spec[] = {
        {"n", VBNL_PARAM_INT, 3, NULL, 0, 10, NULL, "n"},
        {"mode", VBNL_PARAM_ENUM, 0, "b", 0, 0, modes, "m"},
        {"file", VBNL_PARAM_STRING, 0, "x.vls", 0, 0, NULL, "f"},
    };
    vbnl_params *p = NULL;
    vbnl_error err = {0};
    assert_int_equal(vbnl_params_validate(NULL, spec, 3, "t", &err), VBNL_OK);
    assert_float_equal(vbnl_params_number(NULL, spec, 3, "n"), 3.0, 0.0);
    assert_string_equal(vbnl_params_string(NULL, spec, 3, "mode"), "b");
    assert_string_equal(vbnl_params_string(NULL, spec, 3, "file"), "x.vls");
    assert_float_equal(vbnl_params_number(NULL, spec, 3, "absent"), 0.0, 0.0);
    assert_null(vbnl_params_string(NULL, spec, 3, "absent"));
    vbnl_params_create(&p, NULL);
    assert_int_equal(vbnl_params_set_text(p, "n=many", "x:1:1", NULL), VBNL_OK); /* a string */
    assert_int_equal(vbnl_params_validate(p, spec, 3, "integrator 't'", &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "x:1:1: parameter 'n' of integrator 't' takes"));
    vbnl_params_destroy(p);
    vbnl_params_create(&p, NULL);
    assert_int_equal(vbnl_params_set_number(p, "mode", 1, NULL, NULL), VBNL_OK); /* a number */
    assert_int_equal(vbnl_params_validate(p, spec, 3, "t", &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "'mode'"));
    vbnl_params_destroy(p);
    vbnl_params_create(&p, NULL);
    assert_int_equal(vbnl_params_set_text(p, "file=out/lights.vls", NULL, NULL), VBNL_OK);
    assert_int_equal(vbnl_params_set_text(p, "mode=a", NULL, NULL), VBNL_OK);
    assert_int_equal(vbnl_params_validate(p, spec, 3, "t", &err), VBNL_OK);
    assert_string_equal(vbnl_params_string(p, spec, 3, "file"), "out/lights.vls");
    assert_string_equal(vbnl_params_string(p, spec, 3, "mode"), "a");
    assert_float_equal(vbnl_params_number(p, spec, 3, "n"), 3.0, 0.0);
    /* an unknown name far from every valid one: no suggestion, the list */
    assert_int_equal(vbnl_params_set_text(p, "zzzzzzzzzz=1", NULL, NULL), VBNL_OK);
    assert_int_equal(vbnl_params_validate(p, spec, 3, "t", &err), VBNL_ERR_UNKNOWN_NAME);
    assert_null(strstr(err.message, "did you mean"));
    assert_non_null(strstr(err.message, "(valid: n, mode, file)"));
    vbnl_params_destroy(p);
    /* bad calls */
    vbnl_params_create(&p, NULL);
    assert_int_equal(vbnl_params_set_number(p, "", 1, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_params_set_number(p, NULL, 1, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_params_set_string(p, "s", NULL, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_params_set_text(p, "a=", NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_params_count(p), 0); /* refused settings leave nothing */
    assert_int_equal(vbnl_params_create(NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_params_append(p, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_params_destroy(p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_validate),
        cmocka_unit_test(test_append_and_get),
        cmocka_unit_test(test_types_and_defaults),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
