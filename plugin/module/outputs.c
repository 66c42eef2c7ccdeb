/* Writing a render's film: EXR with every layer and the settings, plus a display PNG. A crop
 * render's EXR holds its window as the data window, and every EXR names the scene and camera it
 * was rendered from (and the virtual lights it loaded), so that parts rendered apart can be
 * checked and joined (`vbnl merge-tiles`, docs/farm.md). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "atomic_file.h"
#include "image_io.h"
#include "module.h"
#include "vl_file_tools.h"

vbnl_result module_check_writable(const char *path, vbnl_error *err)
{
    vbi_atomic_file f;
    vbnl_result r = vbi_atomic_file_open(&f, path, err);
    if (r == VBNL_OK)
        vbi_atomic_file_discard(&f);
    return r;
}

#define MAX_ATTRS 64

/* What a render that loaded virtual lights says about them (vl_file_tools.h): the set and
 * preparation fingerprints, the photon paths summed over its files, what preparing them took.
 * The render has read and verified the files already, so their headers are read without the
 * checksum pass. 0 when the parameters load none or a header cannot be read. */
typedef struct lights_info {
    char set[24], preparation[24], photons[96];
    const char *files;
    double placement, elimination, photon_seconds, photon_rays;
} lights_info;

static int read_lights_info(const vbnl_params *p, lights_info *li)
{
    const char *load = NULL;
    for (uint32_t i = 0; p && i < vbnl_params_count(p); ++i) {
        const char *name, *str;
        int is_string;
        double num;
        vbnl_params_get(p, i, &name, &is_string, &num, &str, NULL);
        if (is_string && !strcmp(name, "load_lights"))
            load = str; /* the last setting wins */
    }
    if (!load || !*load)
        return 0;
    char list[4096];
    snprintf(list, sizeof(list), "%s", load);
    memset(li, 0, sizeof(*li));
    li->files = load;
    uint64_t first = UINT64_MAX, count = 0, paths = 0, set = 0, prep = 0;
    int n = 0;
    for (char *save = NULL, *f = strtok_r(list, ":", &save); f; f = strtok_r(NULL, ":", &save), ++n) {
        vbi_vl_file_header h;
        if (vbi_vl_file_read_header(f, 0, &h, NULL) != VBNL_OK)
            return 0;
        first = h.photon_count && h.photon_first < first ? h.photon_first : first;
        count += h.photon_count;
        paths = h.photon_paths;
        set = h.set;
        prep = h.preparation;
        li->placement = h.placement_seconds;
        li->elimination = h.elimination_seconds;
        li->photon_seconds += h.photon_seconds;
        li->photon_rays += h.photon_rays;
    }
    if (n == 0)
        return 0;
    snprintf(li->set, sizeof(li->set), "%016llx", (unsigned long long)set);
    snprintf(li->preparation, sizeof(li->preparation), "%016llx", (unsigned long long)prep);
    snprintf(li->photons, sizeof(li->photons), "%llu,%llu,%llu", (unsigned long long)(count ? first : 0),
             (unsigned long long)count, (unsigned long long)paths);
    return 1;
}

/* The window rows of a width-wide layer of `channels` floats, packed. */
static float *window_of(const float *full, uint32_t width, uint32_t channels, const uint32_t win[4])
{
    const size_t row = (size_t)(win[2] - win[0]) * channels;
    float *out = malloc(sizeof(float) * row * (win[3] - win[1]));
    for (uint32_t y = win[1]; out && y < win[3]; ++y)
        memcpy(out + (y - win[1]) * row, full + ((size_t)y * width + win[0]) * channels, sizeof(float) * row);
    return out;
}

vbnl_result module_write_outputs(const vbnl_renderer *r, const vbnl_render_settings *s, const vbnl_scene *scene,
                                 const char *exr_path, const char *png_path, float exposure, int half,
                                 int partial, vbnl_error *err)
{
    const vbnl_film *film = vbnl_renderer_film(r);
    uint32_t w = vbnl_film_width(film), h = vbnl_film_height(film);
    uint32_t nl = vbnl_film_layer_count(film);
    vbi_image_layer layers[16];
    float *data[16] = {0}, *part[16] = {0};
    vbnl_result res = VBNL_OK;
    /* a crop render writes its window as the EXR's data window (the display window is the image) */
    const int cropped = (s->crop[0] | s->crop[1] | s->crop[2] | s->crop[3]) != 0 &&
                        (s->crop[0] > 0 || s->crop[1] > 0 || s->crop[2] < w || s->crop[3] < h);
    const uint32_t whole[4] = {0, 0, w, h};
    const uint32_t *win = cropped ? s->crop : whole;
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
        if (cropped && !(part[i] = window_of(data[i], w, info.channels, win))) {
            res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
            goto done;
        }
        layers[i].name = info.name;
        layers[i].channels = info.channels;
        layers[i].channel_names = info.channel_names;
        layers[i].data = cropped ? part[i] : data[i];
    }
    if (exr_path) {
        vbnl_render_stats st;
        vbnl_renderer_get_stats(r, &st, NULL);
        vbi_image_attr attrs[MAX_ATTRS];
        uint32_t na = 0;
        char params[2048] = "", seed[32], stage_names[32][64], work_names[8][2][96];
        char scene_fp[24], camera_fp[24], crop[64];
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
        attrs[na++] = (vbi_image_attr){"vbnl/version", VBI_IMAGE_ATTR_STRING, {.s = VBNL_VERSION_STRING}};
        attrs[na++] = (vbi_image_attr){"vbnl/integrator", VBI_IMAGE_ATTR_STRING,
                                        {.s = s->integrator ? s->integrator : "path"}};
        attrs[na++] = (vbi_image_attr){"vbnl/parameters", VBI_IMAGE_ATTR_STRING, {.s = params}};
        attrs[na++] = (vbi_image_attr){"vbnl/seed", VBI_IMAGE_ATTR_STRING, {.s = seed}};
        attrs[na++] = (vbi_image_attr){"vbnl/sampler", VBI_IMAGE_ATTR_STRING, {.s = vbnl_sampler_name(s->sampler)}};
        attrs[na++] = (vbi_image_attr){"vbnl/spp", VBI_IMAGE_ATTR_INT, {.i = (int32_t)st.spp}};
        attrs[na++] = (vbi_image_attr){"vbnl/passes", VBI_IMAGE_ATTR_INT, {.i = (int32_t)st.passes}};
        attrs[na++] = (vbi_image_attr){"vbnl/rays", VBI_IMAGE_ATTR_DOUBLE, {.d = (double)st.rays}};
        attrs[na++] = (vbi_image_attr){"vbnl/partial", VBI_IMAGE_ATTR_INT, {.i = partial ? 1 : 0}};
        attrs[na++] = (vbi_image_attr){"vbnl/time_budget", VBI_IMAGE_ATTR_DOUBLE, {.d = s->time_budget}};
        attrs[na++] = (vbi_image_attr){"vbnl/time/prepare", VBI_IMAGE_ATTR_DOUBLE, {.d = st.prepare_seconds}};
        lights_info li;
        const int lights = read_lights_info(p, &li);
        /* what a part of an image belongs to (docs/farm.md: `vbnl merge-tiles` joins only parts
         * that agree); a whole image rendered here needs no such check, and the scene's
         * fingerprint reads all its geometry */
        if (scene && (cropped || lights)) {
            snprintf(scene_fp, sizeof(scene_fp), "%016llx", (unsigned long long)vbi_vl_file_scene_fingerprint(scene));
            snprintf(camera_fp, sizeof(camera_fp), "%016llx",
                     (unsigned long long)vbi_vl_file_camera_fingerprint(scene));
            attrs[na++] = (vbi_image_attr){"vbnl/scene/fingerprint", VBI_IMAGE_ATTR_STRING, {.s = scene_fp}};
            attrs[na++] = (vbi_image_attr){"vbnl/camera/fingerprint", VBI_IMAGE_ATTR_STRING, {.s = camera_fp}};
        }
        if (cropped) {
            snprintf(crop, sizeof(crop), "%u,%u,%u,%u", win[0], win[1], win[2], win[3]);
            attrs[na++] = (vbi_image_attr){"vbnl/crop", VBI_IMAGE_ATTR_STRING, {.s = crop}};
        }
        if (lights) {
            attrs[na++] = (vbi_image_attr){"vbnl/lights/fingerprint", VBI_IMAGE_ATTR_STRING, {.s = li.set}};
            attrs[na++] = (vbi_image_attr){"vbnl/lights/preparation", VBI_IMAGE_ATTR_STRING, {.s = li.preparation}};
            attrs[na++] = (vbi_image_attr){"vbnl/lights/photons", VBI_IMAGE_ATTR_STRING, {.s = li.photons}};
            attrs[na++] = (vbi_image_attr){"vbnl/lights/files", VBI_IMAGE_ATTR_STRING, {.s = li.files}};
            attrs[na++] = (vbi_image_attr){"vbnl/lights/time/placement", VBI_IMAGE_ATTR_DOUBLE, {.d = li.placement}};
            attrs[na++] = (vbi_image_attr){"vbnl/lights/time/elimination", VBI_IMAGE_ATTR_DOUBLE,
                                            {.d = li.elimination}};
            attrs[na++] = (vbi_image_attr){"vbnl/lights/time/photons", VBI_IMAGE_ATTR_DOUBLE,
                                            {.d = li.photon_seconds}};
            attrs[na++] = (vbi_image_attr){"vbnl/lights/rays/photons", VBI_IMAGE_ATTR_DOUBLE, {.d = li.photon_rays}};
        }
        /* under a budget: the preparation's bound, what the integrator chose and why, and whether
         * the last pass was cut at the budget (docs/time-budget.md) */
        char choice_names[8][2][96];
        if (s->time_budget > 0.0) {
            attrs[na++] = (vbi_image_attr){"vbnl/budget/prepare_limit", VBI_IMAGE_ATTR_DOUBLE, {.d = st.prepare_limit}};
            attrs[na++] = (vbi_image_attr){"vbnl/budget/cut", VBI_IMAGE_ATTR_INT, {.i = st.budget_cut ? 1 : 0}};
            for (uint32_t i = 0; i < st.choice_count && i < 8 && na + 2 <= MAX_ATTRS; ++i) {
                snprintf(choice_names[i][0], sizeof(choice_names[i][0]), "vbnl/budget/%s", st.choices[i].name);
                snprintf(choice_names[i][1], sizeof(choice_names[i][1]), "vbnl/budget/%s/why", st.choices[i].name);
                attrs[na++] = (vbi_image_attr){choice_names[i][0], VBI_IMAGE_ATTR_DOUBLE, {.d = st.choices[i].value}};
                attrs[na++] = (vbi_image_attr){choice_names[i][1], VBI_IMAGE_ATTR_STRING, {.s = st.choices[i].why}};
            }
        }
        for (uint32_t i = 0; i < st.stage_count && na < MAX_ATTRS && i < 32; ++i) {
            snprintf(stage_names[i], sizeof(stage_names[i]), "vbnl/time/%s", st.stages[i].name);
            attrs[na++] = (vbi_image_attr){stage_names[i], VBI_IMAGE_ATTR_DOUBLE, {.d = st.stages[i].seconds}};
        }
        /* the stages that counted their work: the count and the rate per second beside the time
         * (the photon stage's rays/s, to compare with `vbnl bench`'s raw Embree rates) */
        for (uint32_t i = 0, k = 0; i < st.stage_count && na + 2 <= MAX_ATTRS && k < 8; ++i) {
            const vbnl_stage_time *sg = &st.stages[i];
            if (!(sg->work > 0.0) || !sg->work_unit)
                continue;
            snprintf(work_names[k][0], sizeof(work_names[k][0]), "vbnl/%s/%s", sg->work_unit, sg->name);
            snprintf(work_names[k][1], sizeof(work_names[k][1]), "vbnl/%s_per_second/%s", sg->work_unit, sg->name);
            attrs[na++] = (vbi_image_attr){work_names[k][0], VBI_IMAGE_ATTR_DOUBLE, {.d = sg->work}};
            attrs[na++] = (vbi_image_attr){work_names[k][1], VBI_IMAGE_ATTR_DOUBLE,
                                            {.d = sg->seconds > 0.0 ? sg->work / sg->seconds : 0.0}};
            ++k;
        }
        if ((res = vbi_exr_write_window(exr_path, w, h, win, layers, nl, attrs, na, half, err)) != VBNL_OK)
            goto done;
    }
    if (png_path) {
        uint8_t *px = malloc((size_t)w * h * 3);
        if (!px) {
            res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
            goto done;
        }
        res = vbi_linear_to_srgb8(data[0], w, h, 4, exposure, 1, px, 3, err);
        if (res == VBNL_OK)
            res = vbi_png_write(png_path, w, h, 3, 8, px, err);
        free(px);
    }
done:
    for (uint32_t i = 0; i < 16; ++i) {
        free(data[i]);
        free(part[i]);
    }
    return res;
}
