/* One render through the public API for the tests (header-only, cmocka): the film's beauty
 * image (RGBA) or one of its layers (RGB), malloc'd; a failure fails the test with the error. */
#ifndef VBI_TEST_TS_RENDER_H
#define VBI_TEST_TS_RENDER_H

#include <stdlib.h>

#include "vbnl/vbnl.h"

/* `settings` is a NULL-terminated list of "key=value" integrator parameters (or NULL); `layer`
 * "" reads the beauty image. */
static inline float *ts_render_layer(vbnl_context *ctx, const vbnl_scene *s, const char *integrator, uint32_t w,
                                     uint32_t h, uint32_t spp, uint64_t seed, const char *const *settings,
                                     const char *layer)
{
    vbnl_params *p;
    vbnl_params_create(&p, NULL);
    for (const char *const *kv = settings; kv && *kv; ++kv)
        assert_int_equal(vbnl_params_set_text(p, *kv, NULL, NULL), VBNL_OK);
    vbnl_render_settings rs;
    vbnl_render_settings_init(&rs);
    rs.width = w;
    rs.height = h;
    rs.spp = spp;
    rs.seed = seed;
    rs.integrator = integrator;
    rs.params = p;
    vbnl_renderer *r;
    vbnl_error err = {0};
    if (vbnl_renderer_create(ctx, s, &rs, &r, &err) != VBNL_OK || vbnl_renderer_render(r, NULL, NULL, &err) != VBNL_OK)
        fail_msg("%s: %s", integrator, err.message);
    int channels = layer[0] ? 3 : 4;
    float *out = malloc(sizeof(float) * channels * w * h);
    assert_non_null(out);
    assert_int_equal(vbnl_film_read(vbnl_renderer_film(r), layer, out, (size_t)channels * w * h, NULL), VBNL_OK);
    vbnl_renderer_destroy(r);
    vbnl_params_destroy(p);
    return out;
}

static inline float *ts_render(vbnl_context *ctx, const vbnl_scene *s, const char *integrator, uint32_t w,
                               uint32_t h, uint32_t spp, uint64_t seed, const char *const *settings)
{
    return ts_render_layer(ctx, s, integrator, w, h, spp, seed, settings, "");
}

#endif
