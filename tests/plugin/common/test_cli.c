/* The command line's conventions (plugin/common/cli.c), shared by `vbnl render` and the module's
 * commands: the --camera parser (seven finite comma-separated numbers, nothing else; a refused
 * text leaves the outputs as they were), whole numbers in a range, whether two paths name one
 * file. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

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

static void test_u32(void **state)
{
    (void)state;
    uint32_t v = 7;
    assert_int_equal(cli_parse_u32("65536", &v, 1, 65536), 0);
    assert_int_equal(v, 65536);
    static const char *const bad[] = {"", "0", "65537", "-1", "12x", "3.5", "99999999999999999999"};
    for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); ++i) {
        v = 7;
        if (cli_parse_u32(bad[i], &v, 1, 65536) != -1)
            fail_msg("'%s' was accepted", bad[i]);
        assert_int_equal(v, 7);
    }
}

/* The same file through another name, a link, "./" and a name not yet created; not another one. */
static void test_same_file(void **state)
{
    (void)state;
    char dir[] = "/tmp/vbnl-cli-XXXXXX", a[64], b[64], link[64], dotted[80], fresh[64], fresh2[80];
    assert_non_null(mkdtemp(dir));
    snprintf(a, sizeof(a), "%s/a", dir);
    snprintf(b, sizeof(b), "%s/b", dir);
    snprintf(link, sizeof(link), "%s/l", dir);
    snprintf(dotted, sizeof(dotted), "%s/./a", dir);
    snprintf(fresh, sizeof(fresh), "%s/new", dir);
    snprintf(fresh2, sizeof(fresh2), "%s/../%s/new", dir, strrchr(dir, '/') + 1);
    fclose(fopen(a, "w"));
    fclose(fopen(b, "w"));
    assert_int_equal(symlink(a, link), 0);
    assert_true(cli_same_file(a, link));
    assert_true(cli_same_file(a, dotted));
    assert_false(cli_same_file(a, b));
    assert_true(cli_same_file(fresh, fresh2)); /* not created yet: by folder and name */
    assert_false(cli_same_file(fresh, a));
    unlink(link);
    unlink(a);
    unlink(b);
    rmdir(dir);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_camera_parsed),
        cmocka_unit_test(test_camera_refused),
        cmocka_unit_test(test_u32),
        cmocka_unit_test(test_same_file),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
