/* vbnl: replays every input in tests/scene_parser/language/regressions/ (fuzzer crashes, leaks
 * and slow inputs) with the fuzz target's limits. Each must finish with VBNL_OK or
 * VBNL_ERR_PARSE; run the suite under AddressSanitizer/UBSan to catch memory errors. The directory defaults to the
 * one next to this source file; VBNL_SDL_REGRESSIONS overrides it. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <dirent.h>
#include <time.h>

#include "sdl_test_util.h"

static char *read_all(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    size_t cap = 1 << 16, n = 0;
    char *buf = malloc(cap);
    size_t r;
    while (buf && (r = fread(buf + n, 1, cap - n, f)) > 0) {
        n += r;
        if (n == cap) {
            char *q = realloc(buf, cap *= 2);
            if (!q) {
                free(buf);
                buf = NULL;
            }
            buf = q;
        }
    }
    fclose(f);
    *len = n;
    return buf;
}

static void replay(const char *path)
{
    size_t len = 0;
    char *text = read_all(path, &len);
    assert_non_null(text);
    vbnl_sdl_parser *p = NULL;
    assert_int_equal(vbnl_sdl_parser_create(&p, NULL), VBNL_OK);
    vbnl_sdl_limits l;
    vbnl_sdl_limits_default(&l);
    l.max_loop_iterations = 2000;
    l.max_tokens = 50000;
    l.max_memory = (size_t)64 << 20;
    l.max_macro_depth = 64;
    l.max_nesting = 200;
    l.stack_bytes = (size_t)16 << 20;
    assert_int_equal(vbnl_sdl_set_limits(p, &l), VBNL_OK);
    vbnl_sdl_set_includes_enabled(p, 0);
    clock_t t0 = clock();
    for (int pass = 0; pass < 2; pass++) { /* a parser can parse again after an error */
        vbnl_result r = vbnl_sdl_parse_text(p, "fuzz.pov", text, len, NULL);
        assert_true(r == VBNL_OK || r == VBNL_ERR_PARSE);
    }
    double seconds = (double)(clock() - t0) / CLOCKS_PER_SEC;
    if (seconds > 20)
        fail_msg("%s took %.1f s", path, seconds);
    vbnl_sdl_parser_destroy(p);
    free(text);
}

static void test_regressions(void **state)
{
    (void)state;
    char dir[1024];
    const char *env = getenv("VBNL_SDL_REGRESSIONS");
    if (env) {
        snprintf(dir, sizeof dir, "%s", env);
    } else {
        snprintf(dir, sizeof dir, "%s", __FILE__);
        char *slash = strrchr(dir, '/');
        if (slash)
            snprintf(slash + 1, sizeof dir - (size_t)(slash + 1 - dir), "regressions");
        else
            snprintf(dir, sizeof dir, "regressions");
    }
    DIR *d = opendir(dir);
    if (!d)
        fail_msg("cannot open regression directory %s", dir);
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.')
            continue;
        char path[2048];
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        replay(path);
        n++;
    }
    closedir(d);
    assert_true(n > 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = { cmocka_unit_test(test_regressions) };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
