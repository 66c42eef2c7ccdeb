/* The object layer's tests: loading scene text through vbnl_pov_load_text with the diagnostics
 * collected, and looking at the scene built (scene_internal.h). Included by one test file each. */
#ifndef VBI_POV_TEST_H
#define VBI_POV_TEST_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scene_internal.h"
#include "vbnl/pov_scene.h"
#include "vbnl/render.h"

#define POV_T_UNUSED __attribute__((unused))

static vbnl_context *g_ctx;
static char g_diags[16384];

POV_T_UNUSED static void collect(const vbnl_sdl_diag *d, void *user)
{
    (void)user;
    size_t n = strlen(g_diags);
    snprintf(g_diags + n, sizeof g_diags - n, "%s", d->text);
}

/* A camera and a light so that every snippet commits. */
#define BASE "camera { location <0, 0, -10> look_at <0, 0, 0> }\nlight_source { <0, 50, -50> rgb 1 }\n"
/* The same with a distant light, which does not enter the scene bounds. */
#define BASE_B "camera { location <0, 0, -10> look_at <0, 0, 0> }\nlight_source { <0, 50, -50> rgb 1 parallel point_at 0 }\n"

POV_T_UNUSED static vbnl_result load(const char *text, vbnl_pov_scene **s, vbnl_error *err)
{
    vbnl_pov_options o;
    vbnl_pov_options_init(&o);
    o.diag = collect;
    g_diags[0] = 0;
    memset(err, 0, sizeof *err);
    return vbnl_pov_load_text(g_ctx, "test.pov", text, strlen(text), &o, s, err);
}

POV_T_UNUSED static vbnl_pov_scene *ok(const char *text)
{
    vbnl_pov_scene *s = NULL;
    vbnl_error err;
    vbnl_result r = load(text, &s, &err);
    if (r != VBNL_OK)
        fprintf(stderr, "# %s\n%s", err.message, g_diags);
    assert_int_equal(r, VBNL_OK);
    return s;
}

POV_T_UNUSED static const vbnl_scene *sc(vbnl_pov_scene *s) { return vbnl_pov_scene_get(s); }

POV_T_UNUSED static vbnl_scene_info info(vbnl_pov_scene *s)
{
    vbnl_scene_info i;
    assert_int_equal(vbnl_scene_get_info(sc(s), &i, NULL), VBNL_OK);
    return i;
}

POV_T_UNUSED static void expect_error(const char *text, const char *message)
{
    vbnl_pov_scene *s = NULL;
    vbnl_error err;
    assert_int_equal(load(text, &s, &err), VBNL_ERR_PARSE);
    assert_null(s);
    assert_string_equal(err.message, message);
}

POV_T_UNUSED static int hit(vbnl_pov_scene *s, float ox, float oy, float oz, float dx, float dy, float dz, vbi_hit *h)
{
    return vbi_scene_intersect(sc(s), v3(ox, oy, oz), v3(dx, dy, dz), INFINITY, h);
}

#define NEAR(a, b) assert_float_equal((a), (b), 1e-3)

/* Group set-up and tear-down: a two-thread context in g_ctx. */
POV_T_UNUSED static int pov_t_setup(void **state)
{
    (void)state;
    vbnl_context_desc cd;
    vbnl_context_desc_init(&cd);
    cd.threads = 2;
    return vbnl_context_create(&cd, &g_ctx, NULL) == VBNL_OK ? 0 : -1;
}

POV_T_UNUSED static int pov_t_teardown(void **state)
{
    (void)state;
    vbnl_context_destroy(g_ctx);
    return 0;
}

#endif
