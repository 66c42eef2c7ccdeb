/* The command line's --camera parser (plugin/common/cli.c), shared by `vbnl render` and
 * `vbnl bench`: seven finite comma-separated numbers, nothing else; a refused text leaves the
 * outputs as they were. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include "cli.h"

static void test_camera_parsed(void **state)
{
    (void)state;
    float pos[3] = {0}, target[3] = {0}, fov = 0.0f;
    assert_int_equal(cli_parse_camera("0,1,3.5,0,1,-0.25,40", pos, target, &fov), 0);
    assert_true(pos[0] == 0.0f && pos[1] == 1.0f && pos[2] == 3.5f);
    assert_true(target[0] == 0.0f && target[1] == 1.0f && target[2] == -0.25f);
    assert_true(fov == 40.0f);
}

static void test_camera_refused(void **state)
{
    (void)state;
    static const char *const bad[] = {
        "",  "1,2,3", "1,2,3,4,5,6", "1,2,3,4,5,6,7,8", "1,2,3,4,5,6,7x", "1,2,3,4,5,6,7,", "a,2,3,4,5,6,7",
        "1,2,3,4,5,6,inf", "nan,2,3,4,5,6,7", "1e39,2,3,4,5,6,7",
    };
    for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); ++i) {
        float pos[3] = {9, 9, 9}, target[3] = {9, 9, 9}, fov = 9.0f;
        if (cli_parse_camera(bad[i], pos, target, &fov) != -1)
            fail_msg("'%s' was accepted", bad[i]);
        assert_true(pos[0] == 9.0f && pos[2] == 9.0f && target[1] == 9.0f && fov == 9.0f);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_camera_parsed),
        cmocka_unit_test(test_camera_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
