/* Writing a render's film: EXR with every layer and the settings, plus a display PNG. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "atomic_file.h"
#include "image_io.h"
#include "module.h"

vbnl_result module_check_writable(const char *path, vbnl_error *err)
{
    vbnl_atomic_file f;
    vbnl_result r = vbnl_atomic_file_open(&f, path, err);
    if (r == VBNL_OK)
        vbnl_atomic_file_discard(&f);
    return r;
}

#define MAX_ATTRS 64

vbnl_result module_write_outputs(const vbnl_renderer *r, const vbnl_render_settings *s,
                                 const char *exr_path, const char *png_path, float exposure, int half,
                                 int partial, vbnl_error *err)
{
    const vbnl_film *film = vbnl_renderer_film(r);
    uint32_t w = vbnl_film_width(film), h = vbnl_film_height(film);
    uint32_t nl = vbnl_film_layer_count(film);
    vbnl_image_layer layers[16];
    float *data[16] = {0};
    vbnl_result res = VBNL_OK;
    if (nl > 16)
        nl = 16;
    for (uint32_t i = 0; i < nl; ++i) {
        vbnl_layer_info info;
        if ((res = vbnl_film_layer(film, i, &info, err)) != VBNL_OK)
            goto done;
        size_t n = (size_t)w * h * info.channels;
        data[i] = malloc(sizeof(float) * n);
        if (!data[i]) {
            res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
            goto done;
        }
        if ((res = vbnl_film_read(film, info.name, data[i], n, err)) != VBNL_OK)
            goto done;
        layers[i].name = info.name;
        layers[i].channels = info.channels;
        layers[i].channel_names = info.channel_names;
        layers[i].data = data[i];
    }
    if (exr_path) {
        vbnl_render_stats st;
        vbnl_renderer_get_stats(r, &st, NULL);
        vbnl_image_attr attrs[MAX_ATTRS];
        uint32_t na = 0;
        char params[2048] = "", seed[32], stage_names[32][64], work_names[8][2][96];
        const vbnl_params *p = s->params;
        for (uint32_t i = 0; p && i < vbnl_params_count(p); ++i) {
            const char *name, *str;
            int is_string;
            double num;
            vbnl_params_get(p, i, &name, &is_string, &num, &str, NULL);
            size_t len = strlen(params);
            if (is_string)
                snprintf(params + len, sizeof(params) - len, "%s%s=%s", len ? " " : "", name, str);
            else
                snprintf(params + len, sizeof(params) - len, "%s%s=%.17g", len ? " " : "", name, num);
        }
        snprintf(seed, sizeof(seed), "%llu", (unsigned long long)s->seed);
        attrs[na++] = (vbnl_image_attr){"vbnl/version", VBNL_IMAGE_ATTR_STRING, {.s = VBNL_VERSION_STRING}};
        attrs[na++] = (vbnl_image_attr){"vbnl/integrator", VBNL_IMAGE_ATTR_STRING,
                                        {.s = s->integrator ? s->integrator : "path"}};
        attrs[na++] = (vbnl_image_attr){"vbnl/parameters", VBNL_IMAGE_ATTR_STRING, {.s = params}};
        attrs[na++] = (vbnl_image_attr){"vbnl/seed", VBNL_IMAGE_ATTR_STRING, {.s = seed}};
        attrs[na++] = (vbnl_image_attr){"vbnl/sampler", VBNL_IMAGE_ATTR_STRING, {.s = vbnl_sampler_name(s->sampler)}};
        attrs[na++] = (vbnl_image_attr){"vbnl/spp", VBNL_IMAGE_ATTR_INT, {.i = (int32_t)st.spp}};
        attrs[na++] = (vbnl_image_attr){"vbnl/passes", VBNL_IMAGE_ATTR_INT, {.i = (int32_t)st.passes}};
        attrs[na++] = (vbnl_image_attr){"vbnl/rays", VBNL_IMAGE_ATTR_DOUBLE, {.d = (double)st.rays}};
        attrs[na++] = (vbnl_image_attr){"vbnl/partial", VBNL_IMAGE_ATTR_INT, {.i = partial ? 1 : 0}};
        attrs[na++] = (vbnl_image_attr){"vbnl/time_budget", VBNL_IMAGE_ATTR_DOUBLE, {.d = s->time_budget}};
        attrs[na++] = (vbnl_image_attr){"vbnl/time/prepare", VBNL_IMAGE_ATTR_DOUBLE, {.d = st.prepare_seconds}};
        /* under a budget: the preparation's bound, what the integrator chose and why, and whether
         * the last pass was cut at the budget (docs/time-budget.md) */
        char choice_names[8][2][96];
        if (s->time_budget > 0.0) {
            attrs[na++] = (vbnl_image_attr){"vbnl/budget/prepare_limit", VBNL_IMAGE_ATTR_DOUBLE, {.d = st.prepare_limit}};
            attrs[na++] = (vbnl_image_attr){"vbnl/budget/cut", VBNL_IMAGE_ATTR_INT, {.i = st.budget_cut ? 1 : 0}};
            for (uint32_t i = 0; i < st.choice_count && i < 8 && na + 2 <= MAX_ATTRS; ++i) {
                snprintf(choice_names[i][0], sizeof(choice_names[i][0]), "vbnl/budget/%s", st.choices[i].name);
                snprintf(choice_names[i][1], sizeof(choice_names[i][1]), "vbnl/budget/%s/why", st.choices[i].name);
                attrs[na++] = (vbnl_image_attr){choice_names[i][0], VBNL_IMAGE_ATTR_DOUBLE, {.d = st.choices[i].value}};
                attrs[na++] = (vbnl_image_attr){choice_names[i][1], VBNL_IMAGE_ATTR_STRING, {.s = st.choices[i].why}};
            }
        }
        for (uint32_t i = 0; i < st.stage_count && na < MAX_ATTRS && i < 32; ++i) {
            snprintf(stage_names[i], sizeof(stage_names[i]), "vbnl/time/%s", st.stages[i].name);
            attrs[na++] = (vbnl_image_attr){stage_names[i], VBNL_IMAGE_ATTR_DOUBLE, {.d = st.stages[i].seconds}};
        }
        /* the stages that counted their work: the count and the rate per second beside the time
         * (the photon stage's rays/s, to compare with `vbnl bench`'s raw Embree rates) */
        for (uint32_t i = 0, k = 0; i < st.stage_count && na + 2 <= MAX_ATTRS && k < 8; ++i) {
            const vbnl_stage_time *sg = &st.stages[i];
            if (!(sg->work > 0.0) || !sg->work_unit)
                continue;
            snprintf(work_names[k][0], sizeof(work_names[k][0]), "vbnl/%s/%s", sg->work_unit, sg->name);
            snprintf(work_names[k][1], sizeof(work_names[k][1]), "vbnl/%s_per_second/%s", sg->work_unit, sg->name);
            attrs[na++] = (vbnl_image_attr){work_names[k][0], VBNL_IMAGE_ATTR_DOUBLE, {.d = sg->work}};
            attrs[na++] = (vbnl_image_attr){work_names[k][1], VBNL_IMAGE_ATTR_DOUBLE,
                                            {.d = sg->seconds > 0.0 ? sg->work / sg->seconds : 0.0}};
            ++k;
        }
        if ((res = vbnl_exr_write(exr_path, w, h, layers, nl, attrs, na, half, err)) != VBNL_OK)
            goto done;
    }
    if (png_path) {
        uint8_t *px = malloc((size_t)w * h * 3);
        if (!px) {
            res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
            goto done;
        }
        res = vbnl_linear_to_srgb8(data[0], w, h, 4, exposure, 1, px, 3, err);
        if (res == VBNL_OK)
            res = vbnl_png_write(png_path, w, h, 3, 8, px, err);
        free(px);
    }
done:
    for (uint32_t i = 0; i < 16; ++i)
        free(data[i]);
    return res;
}
