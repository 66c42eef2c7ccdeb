/* A tiny second host: loads the plugin module by path with dlopen (as any host renderer would),
 * only through vbnl/vbnl_plugin.h, and renders the example Cornell box. It checks the ABI handshake,
 * a fake module of another ABI, the integrator table, options, parameters, rendering, progress and
 * cancellation, the framebuffer, EXR and PNG output (read back with the project's readers), the
 * colour views, and bad arguments.
 * Environment: VBNL_PLUGIN_PATH, VBNL_FAKE_PLUGIN_PATH, VBNL_SOURCE_DIR. */
#ifndef _GNU_SOURCE
#define _GNU_SOURCE
#endif
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "image_io.h" /* only to read the written files back */
#include "vbnl/vbnl_plugin.h"

enum { W = 24, H = 18 };

static void *g_so;
static const vbnl_plugin_api *api;
static char g_scene[1024], g_dir[64];

static vbnl_plugin_entry_fn open_entry(const char *path, void **so)
{
    *so = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!*so) {
        print_message("# dlopen %s: %s\n", path, dlerror());
        return NULL;
    }
    vbnl_plugin_entry_fn entry;
    *(void **)&entry = dlsym(*so, VBNL_PLUGIN_ENTRY_NAME);
    return entry;
}

static int group_setup(void **state)
{
    (void)state;
    const char *path = getenv("VBNL_PLUGIN_PATH"), *src = getenv("VBNL_SOURCE_DIR");
    if (!path || !src)
        return -1;
    snprintf(g_scene, sizeof(g_scene), "%s/examples/cornell-box.obj", src);
    vbnl_plugin_entry_fn entry = open_entry(path, &g_so);
    if (!entry)
        return -1;
    api = entry(VBNL_PLUGIN_ABI_MAJOR, NULL);
    snprintf(g_dir, sizeof(g_dir), "/tmp/vbnl-host-XXXXXX");
    return api && mkdtemp(g_dir) ? 0 : -1;
}

static int group_teardown(void **state)
{
    (void)state;
    char cmd[128];
    snprintf(cmd, sizeof(cmd), "rm -rf '%s'", g_dir);
    if (system(cmd) != 0)
        return -1;
    return 0; /* the module stays loaded: its strings may still be referenced by cmocka output */
}

static void test_handshake(void **state)
{
    (void)state;
    assert_int_equal(api->abi_major, VBNL_PLUGIN_ABI_MAJOR);
    assert_int_equal(api->abi_minor, VBNL_PLUGIN_ABI_MINOR);
    assert_int_equal(api->size, sizeof(vbnl_plugin_api));
    assert_true(VBNL_PLUGIN_HAS(api, run_command));
    assert_true(VBNL_PLUGIN_HAS(api, abandon_writes));
    assert_string_equal(api->version(), "0.1.0");
    vbnl_plugin_entry_fn entry;
    *(void **)&entry = dlsym(g_so, VBNL_PLUGIN_ENTRY_NAME);
    const char *why = NULL;
    assert_null(entry(VBNL_PLUGIN_ABI_MAJOR + 1, &why));
    assert_non_null(why);
    assert_non_null(strstr(why, "newer plugin ABI major"));
    why = NULL;
    assert_null(entry(0, &why));
    assert_non_null(strstr(why, "older plugin ABI major"));
    assert_null(entry(7, NULL)); /* why may be NULL */
    /* nothing but the entry symbol is visible */
    assert_null(dlsym(g_so, "vbnl_renderer_create"));
    assert_null(dlsym(g_so, "vbi_ocio_apply"));
}

static void test_fake_plugin_refused(void **state)
{
    (void)state;
    void *so;
    vbnl_plugin_entry_fn entry = open_entry(getenv("VBNL_FAKE_PLUGIN_PATH"), &so);
    assert_non_null(entry);
    const char *why = NULL;
    assert_null(entry(VBNL_PLUGIN_ABI_MAJOR, &why));
    assert_string_equal(why, "fake module built for plugin ABI 99.0");
    dlclose(so);
}

static void test_integrators(void **state)
{
    (void)state;
    int found_path = 0, found_vbnl = 0;
    char msg[256];
    for (uint32_t i = 0; i < api->integrator_count(); ++i) {
        vbnl_plugin_integrator_info info;
        assert_int_equal(api->integrator_info(i, &info, msg, sizeof(msg)), VBNL_PLUGIN_OK);
        assert_true(strlen(info.summary) > 0);
        found_vbnl |= !strcmp(info.name, "vbnl");
        if (strcmp(info.name, "path") != 0)
            continue;
        found_path = 1;
        int has_depth = 0;
        for (uint32_t k = 0; k < info.param_count; ++k) {
            vbnl_plugin_param_info p;
            assert_int_equal(api->integrator_param(i, k, &p, msg, sizeof(msg)), VBNL_PLUGIN_OK);
            assert_non_null(p.doc);
            if (!strcmp(p.name, "max_depth")) {
                has_depth = 1;
                assert_int_equal(p.type, VBNL_PLUGIN_PARAM_INT);
                assert_true(p.min <= p.default_number && p.default_number <= p.max);
            }
        }
        assert_true(has_depth);
        vbnl_plugin_param_info p;
        assert_int_equal(api->integrator_param(i, info.param_count, &p, msg, sizeof(msg)),
                         VBNL_PLUGIN_ERR_INVALID_ARGUMENT);
    }
    assert_true(found_path && found_vbnl);
    vbnl_plugin_integrator_info info;
    assert_int_equal(api->integrator_info(api->integrator_count(), &info, msg, sizeof(msg)),
                     VBNL_PLUGIN_ERR_INVALID_ARGUMENT);
}

/* Creates a renderer for the Cornell box at W x H, with options.size = options_size (a host of an
 * older minor passes a shorter struct) and options.sampler = sampler. */
static vbnl_plugin_renderer *make_with(uint32_t threads, uint32_t spp, const char *integrator, const char *sampler,
                                       uint32_t options_size)
{
    vbnl_plugin_renderer *r = NULL;
    char msg[1024] = "";
    assert_int_equal(api->renderer_create(&r, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    vbnl_plugin_options o;
    api->options_init(&o);
    o.size = options_size;
    o.sampler = sampler;
    o.width = W;
    o.height = H;
    o.spp = spp;
    o.seed = 3;
    o.threads = threads;
    o.integrator = integrator;
    assert_int_equal(api->set_options(r, &o, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    assert_int_equal(api->set_param(r, "max_depth=4", "test", msg, sizeof(msg)), VBNL_PLUGIN_OK);
    if (api->load_scene_file(r, g_scene, msg, sizeof(msg)) != VBNL_PLUGIN_OK)
        fail_msg("load %s: %s", g_scene, msg);
    return r;
}

static vbnl_plugin_renderer *make(uint32_t threads, uint32_t spp, const char *integrator)
{
    return make_with(threads, spp, integrator, NULL, sizeof(vbnl_plugin_options));
}

typedef struct progress_log {
    int calls, cancel_after;
    char first_stage[32];
} progress_log;

static int log_progress(void *user, const vbnl_plugin_progress *p)
{
    progress_log *l = user;
    if (l->calls++ == 0)
        snprintf(l->first_stage, sizeof(l->first_stage), "%s", p->stage);
    return l->cancel_after > 0 && l->calls >= l->cancel_after;
}

static float *render_beauty(uint32_t threads)
{
    vbnl_plugin_renderer *r = make(threads, 2, NULL);
    char msg[1024];
    progress_log log = {0};
    assert_int_equal(api->prepare(r, log_progress, &log, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    assert_int_equal(api->render(r, log_progress, &log, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    assert_true(log.calls > 0);
    assert_string_equal(log.first_stage, "render");
    float *px = malloc(sizeof(float) * 4 * W * H);
    assert_int_equal(api->read_layer(r, "", px, 4 * W * H, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    api->renderer_destroy(r);
    return px;
}

static void test_render_and_framebuffer(void **state)
{
    (void)state;
    vbnl_plugin_renderer *r = make(2, 2, "path");
    char msg[1024];
    assert_int_equal(api->prepare(r, NULL, NULL, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    assert_int_equal(api->render(r, NULL, NULL, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    vbnl_plugin_stats st = {.size = sizeof(st)};
    assert_int_equal(api->get_stats(r, &st, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    assert_int_equal(st.spp, 2);
    assert_int_equal(st.threads, 2);
    assert_int_equal(st.partial, 0);
    assert_true(st.rays > 0 && st.samples == 2u * W * H);
    assert_true(api->layer_count(r) >= 4);
    const char *name;
    uint32_t ch;
    assert_int_equal(api->layer_info(r, 0, &name, &ch, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    assert_string_equal(name, "");
    assert_int_equal(ch, 4);
    float *px = malloc(sizeof(float) * 4 * W * H);
    assert_int_equal(api->read_layer(r, "", px, 4 * W * H, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    double sum = 0.0;
    for (int i = 0; i < W * H; ++i)
        for (int c = 0; c < 3; ++c) {
            assert_true(isfinite(px[4 * i + c]) && px[4 * i + c] >= 0.0f);
            sum += px[4 * i + c];
        }
    assert_true(sum > 0.0);
    assert_int_equal(api->read_layer(r, "nosuchlayer", px, 4 * W * H, msg, sizeof(msg)), VBNL_PLUGIN_ERR_UNKNOWN_NAME);
    assert_int_equal(api->read_layer(r, "", px, 10, msg, sizeof(msg)), VBNL_PLUGIN_ERR_INVALID_ARGUMENT);
    free(px);
    api->renderer_destroy(r);
    /* the same seed gives the same image with 1 thread */
    float *a = render_beauty(1), *b = render_beauty(2);
    assert_memory_equal(a, b, sizeof(float) * 4 * W * H);
    free(a);
    free(b);
}

/* options.sampler (ABI 1.2): "random" and "sobol" give different images, each deterministic; a
 * host built for ABI 1.1 passes the shorter struct and gets the default, "sobol". */
static float *render_with(const char *sampler, uint32_t options_size)
{
    vbnl_plugin_renderer *r = make_with(2, 2, "path", sampler, options_size);
    char msg[1024] = "";
    assert_int_equal(api->prepare(r, NULL, NULL, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    assert_int_equal(api->render(r, NULL, NULL, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    float *px = malloc(sizeof(float) * 4 * W * H);
    assert_int_equal(api->read_layer(r, "", px, 4 * W * H, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    api->renderer_destroy(r);
    return px;
}

static void test_sampler_option(void **state)
{
    (void)state;
    const uint32_t full = sizeof(vbnl_plugin_options), v11 = offsetof(vbnl_plugin_options, sampler);
    float *sobol = render_with("sobol", full), *deflt = render_with(NULL, full), *old = render_with("random", v11);
    float *random = render_with("random", full), *random2 = render_with("random", full);
    const size_t bytes = sizeof(float) * 4 * W * H;
    assert_memory_equal(sobol, deflt, bytes);
    assert_memory_equal(sobol, old, bytes); /* the 1.1 struct ends before `sampler` */
    assert_memory_equal(random, random2, bytes);
    assert_memory_not_equal(sobol, random, bytes);
    free(sobol);
    free(deflt);
    free(old);
    free(random);
    free(random2);
}

static float oetf(float v)
{
    v = v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v;
    return v <= 0.0031308f ? 12.92f * v : 1.055f * powf(v, 1.0f / 2.4f) - 0.055f;
}

/* EXR keeps the linear values bit for bit; the PNG goes through the view; both read back. */
static void test_outputs_round_trip(void **state)
{
    (void)state;
    vbnl_plugin_renderer *r = make(0, 2, NULL);
    char msg[1024], exr[128], png8[128], png16[128];
    assert_int_equal(api->prepare(r, NULL, NULL, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    assert_int_equal(api->render(r, NULL, NULL, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    float *px = malloc(sizeof(float) * 4 * W * H);
    assert_int_equal(api->read_layer(r, "", px, 4 * W * H, msg, sizeof(msg)), VBNL_PLUGIN_OK);

    snprintf(exr, sizeof(exr), "%s/a.exr", g_dir);
    assert_int_equal(api->write_exr(r, exr, 0, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    vbi_exr_image img;
    assert_int_equal(vbi_exr_read(exr, &img, NULL), VBNL_OK);
    const vbi_exr_channel *R = vbi_exr_image_channel(&img, "R"), *B = vbi_exr_image_channel(&img, "B");
    assert_non_null(R);
    for (int i = 0; i < W * H; ++i)
        assert_true(R->data[i] == px[4 * i] && B->data[i] == px[4 * i + 2]);
    assert_non_null(vbi_exr_image_channel(&img, "albedo.R"));
    assert_int_equal(vbi_exr_image_attr(&img, "vbnl/partial")->value.i, 0);
    assert_string_equal(vbi_exr_image_attr(&img, "vbnl/integrator")->value.s, "path");
    assert_true(img.has_chromaticities && fabsf(img.chromaticities[0] - 0.64f) < 1e-6f);
    vbi_exr_image_free(&img);

    /* Raw view, 16 bits, no dither: exactly round(65535 * clamp(linear)) */
    vbnl_plugin_view v;
    api->view_init(&v);
    v.view = "Raw";
    v.png_bits = 16;
    v.dither = 0;
    snprintf(png16, sizeof(png16), "%s/raw16.png", g_dir);
    assert_int_equal(api->write_png(r, png16, &v, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    vbi_png_image p;
    assert_int_equal(vbi_png_read(png16, &p, NULL), VBNL_OK);
    assert_int_equal(p.width, W);
    assert_int_equal(p.bit_depth, 16);
    assert_int_equal(p.channels, 3);
    assert_true(p.has_srgb);
    for (int i = 0; i < W * H; ++i)
        for (int c = 0; c < 3; ++c) {
            float l = px[4 * i + c];
            uint16_t want = (uint16_t)floorf((l > 1.0f ? 1.0f : l) * 65535.0f + 0.5f);
            assert_int_equal(((uint16_t *)p.pixels)[3 * i + c], want);
        }
    vbi_png_image_free(&p);

    /* Standard view, 8 bits, dithered, one stop brighter: the sRGB curve within the dither */
    api->view_init(&v);
    v.exposure = 1.0f;
    snprintf(png8, sizeof(png8), "%s/std8.png", g_dir);
    assert_int_equal(api->write_png(r, png8, &v, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    assert_int_equal(vbi_png_read(png8, &p, NULL), VBNL_OK);
    assert_int_equal(p.bit_depth, 8);
    for (int i = 0; i < W * H; ++i)
        for (int c = 0; c < 3; ++c) {
            float want = 255.0f * oetf(2.0f * px[4 * i + c]);
            assert_true(fabsf(((uint8_t *)p.pixels)[3 * i + c] - want) <= 1.6f);
        }
    vbi_png_image_free(&p);

    /* apply_view: unclamped display values */
    float *d = malloc(sizeof(float) * 4 * W * H);
    api->view_init(&v);
    assert_int_equal(api->apply_view(r, &v, d, 4 * W * H, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    for (int i = 0; i < W * H; ++i)
        if (px[4 * i] <= 1.0f)
            assert_true(fabsf(d[4 * i] - oetf(px[4 * i])) < 2e-3f);
    v.view = "Filmic";
    assert_int_equal(api->apply_view(r, &v, d, 4 * W * H, msg, sizeof(msg)), VBNL_PLUGIN_ERR_UNKNOWN_NAME);
    assert_non_null(strstr(msg, "'Standard', 'ACES 1.0 SDR-video', 'Raw'"));
    v.view = NULL;
    v.png_bits = 12;
    assert_int_equal(api->write_png(r, png8, &v, msg, sizeof(msg)), VBNL_PLUGIN_ERR_INVALID_ARGUMENT);
    free(d);
    free(px);
    api->renderer_destroy(r);
}

/* view.alpha (ABI 1.3): an RGBA PNG whose alpha is the beauty image's, full size around a crop
 * window (outside it transparent, as POV-Ray writes a partial render); a 1.2 host's shorter view
 * gets RGB. */
static void test_png_alpha(void **state)
{
    (void)state;
    vbnl_plugin_renderer *r = NULL;
    char msg[1024] = "", png[128];
    assert_int_equal(api->renderer_create(&r, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    vbnl_plugin_options o;
    api->options_init(&o);
    o.width = W;
    o.height = H;
    o.spp = 1;
    o.integrator = "path";
    uint32_t crop[4] = {4, 2, 12, 10};
    memcpy(o.crop, crop, sizeof(crop));
    assert_int_equal(api->set_options(r, &o, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    assert_int_equal(api->load_scene_file(r, g_scene, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    assert_int_equal(api->prepare(r, NULL, NULL, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    assert_int_equal(api->render(r, NULL, NULL, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    vbnl_plugin_view v;
    api->view_init(&v);
    assert_int_equal(v.alpha, 0);
    v.alpha = 1;
    snprintf(png, sizeof(png), "%s/alpha.png", g_dir);
    assert_int_equal(api->write_png(r, png, &v, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    vbi_png_image p;
    assert_int_equal(vbi_png_read(png, &p, NULL), VBNL_OK);
    assert_int_equal(p.width, W);
    assert_int_equal(p.height, H);
    assert_int_equal(p.channels, 4);
    for (uint32_t y = 0; y < H; ++y)
        for (uint32_t x = 0; x < W; ++x) {
            int in = x >= crop[0] && x < crop[2] && y >= crop[1] && y < crop[3];
            assert_int_equal(((uint8_t *)p.pixels)[4 * (y * W + x) + 3], in ? 255 : 0);
        }
    vbi_png_image_free(&p);
    v.size = offsetof(vbnl_plugin_view, alpha);
    assert_int_equal(api->write_png(r, png, &v, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    assert_int_equal(vbi_png_read(png, &p, NULL), VBNL_OK);
    assert_int_equal(p.channels, 3);
    vbi_png_image_free(&p);
    api->renderer_destroy(r);
}

/* set_scene_option (ABI 1.3): the animation identifiers, declared constants and include folders
 * reach the scene (it stops with #error unless each has the value set); bad keys and values are
 * refused by name. */
static void test_scene_options(void **state)
{
    (void)state;
    vbnl_plugin_renderer *r = NULL;
    char msg[1024] = "", inc[160];
    assert_true(VBNL_PLUGIN_HAS(api, set_scene_option));
    assert_int_equal(api->renderer_create(&r, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    snprintf(inc, sizeof(inc), "%s/lib", g_dir);
    char cmd[512];
    snprintf(cmd, sizeof(cmd), "mkdir -p '%s' && echo '#declare FromLib = 5;' > '%s/lib.inc'", inc, inc);
    assert_int_equal(system(cmd), 0);
    const char *kv[][2] = {{"clock", "0.25"},        {"clock_delta", "0.05"}, {"initial_clock", "0"},
                           {"final_clock", "1"},     {"frame_number", "6"},   {"initial_frame", "1"},
                           {"final_frame", "21"},    {"clock_on", "1"},       {"declare", "Size=2.5"},
                           {"declare", "Name=\"ab\""}, {"include_dir", inc}};
    for (size_t i = 0; i < sizeof(kv) / sizeof(kv[0]); ++i)
        assert_int_equal(api->set_scene_option(r, kv[i][0], kv[i][1], msg, sizeof(msg)), VBNL_PLUGIN_OK);
    static const char scene[] =
        "#include \"lib.inc\"\n"
        "#if (clock != 0.25 | clock_delta != 0.05 | final_clock != 1 | frame_number != 6) #error \"clock\" #end\n"
        "#if (initial_frame != 1 | final_frame != 21 | !clock_on | Size != 2.5 | FromLib != 5) #error \"frames\" #end\n"
        "#if (strcmp(Name, \"ab\")) #error \"name\" #end\n"
        "camera { location <0, 0, -3> look_at 0 } light_source { <0, 5, -5> rgb 1 } sphere { 0, 1 }\n";
    assert_int_equal(api->load_scene_text(r, "anim.pov", scene, sizeof(scene) - 1, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    /* another value is seen: the scene stops at its check */
    assert_int_equal(api->set_scene_option(r, "clock", "0.5", msg, sizeof(msg)), VBNL_PLUGIN_OK);
    assert_int_equal(api->load_scene_text(r, "anim.pov", scene, sizeof(scene) - 1, msg, sizeof(msg)),
                     VBNL_PLUGIN_ERR_PARSE);
    assert_non_null(strstr(msg, "clock"));
    assert_int_equal(api->set_scene_option(r, "clocks", "1", msg, sizeof(msg)), VBNL_PLUGIN_ERR_UNKNOWN_NAME);
    assert_non_null(strstr(msg, "unknown scene option 'clocks'"));
    assert_int_equal(api->set_scene_option(r, "frame_number", "1.5", msg, sizeof(msg)),
                     VBNL_PLUGIN_ERR_INVALID_ARGUMENT);
    assert_int_equal(api->set_scene_option(r, "clock", "soon", msg, sizeof(msg)), VBNL_PLUGIN_ERR_INVALID_ARGUMENT);
    assert_int_equal(api->set_scene_option(r, "declare", "3x=1", msg, sizeof(msg)), VBNL_PLUGIN_ERR_INVALID_ARGUMENT);
    assert_int_equal(api->set_scene_option(r, "declare", "X=abc", msg, sizeof(msg)),
                     VBNL_PLUGIN_ERR_INVALID_ARGUMENT);
    assert_int_equal(api->set_scene_option(r, "read_dir", "/no/such/folder", msg, sizeof(msg)),
                     VBNL_PLUGIN_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg, "is not an existing folder"));
    /* a reserved word is refused when the scene is read */
    assert_int_equal(api->set_scene_option(r, "declare", "clock=1", msg, sizeof(msg)), VBNL_PLUGIN_OK);
    assert_int_not_equal(api->load_scene_text(r, "anim.pov", scene, sizeof(scene) - 1, msg, sizeof(msg)),
                         VBNL_PLUGIN_OK);
    assert_non_null(strstr(msg, "Declare=clock"));
    api->renderer_destroy(r);
}

static void test_cancel_writes_partial(void **state)
{
    (void)state;
    vbnl_plugin_renderer *r = make(0, 1u << 20, NULL);
    char msg[1024], exr[128];
    progress_log log = {.cancel_after = 2};
    assert_int_equal(api->prepare(r, log_progress, &log, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    assert_int_equal(api->render(r, log_progress, &log, msg, sizeof(msg)), VBNL_PLUGIN_ERR_CANCELLED);
    vbnl_plugin_stats st = {.size = sizeof(st)};
    assert_int_equal(api->get_stats(r, &st, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    assert_int_equal(st.partial, 1);
    assert_true(st.spp < (1u << 20));
    snprintf(exr, sizeof(exr), "%s/partial.exr", g_dir);
    assert_int_equal(api->write_exr(r, exr, 1, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    vbi_exr_image img;
    assert_int_equal(vbi_exr_read(exr, &img, NULL), VBNL_OK);
    assert_int_equal(vbi_exr_image_attr(&img, "vbnl/partial")->value.i, 1);
    vbi_exr_image_free(&img);
    api->renderer_destroy(r);
}

static void test_bad_arguments(void **state)
{
    (void)state;
    char msg[1024] = "", tiny[8];
    vbnl_plugin_renderer *r = NULL;
    assert_int_equal(api->renderer_create(NULL, msg, sizeof(msg)), VBNL_PLUGIN_ERR_INVALID_ARGUMENT);
    api->renderer_destroy(NULL);
    assert_int_equal(api->renderer_create(&r, NULL, 0), VBNL_PLUGIN_OK);
    /* nothing loaded yet */
    assert_int_equal(api->prepare(r, NULL, NULL, msg, sizeof(msg)), VBNL_PLUGIN_ERR_STATE);
    assert_non_null(strstr(msg, "no scene"));
    assert_int_equal(api->render(r, NULL, NULL, msg, sizeof(msg)), VBNL_PLUGIN_ERR_STATE);
    assert_int_equal(api->write_exr(r, "/tmp/x.exr", 0, msg, sizeof(msg)), VBNL_PLUGIN_ERR_STATE);
    assert_int_equal(api->layer_count(r), 0);
    vbnl_plugin_options o;
    api->options_init(&o);
    o.size = 12;
    assert_int_equal(api->set_options(r, &o, msg, sizeof(msg)), VBNL_PLUGIN_ERR_INVALID_ARGUMENT);
    api->options_init(&o);
    o.width = 0;
    assert_int_equal(api->set_options(r, &o, msg, sizeof(msg)), VBNL_PLUGIN_ERR_INVALID_ARGUMENT);
    api->options_init(&o);
    o.spp = 0;
    assert_int_equal(api->set_options(r, &o, msg, sizeof(msg)), VBNL_PLUGIN_ERR_INVALID_ARGUMENT);
    api->options_init(&o);
    o.crop[2] = o.width + 1;
    o.crop[3] = 4;
    assert_int_equal(api->set_options(r, &o, msg, sizeof(msg)), VBNL_PLUGIN_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg, "crop window"));
    api->options_init(&o);
    o.integrator = "pathh";
    assert_int_equal(api->set_options(r, &o, msg, sizeof(msg)), VBNL_PLUGIN_ERR_UNKNOWN_NAME);
    assert_non_null(strstr(msg, "unknown integrator 'pathh' (available: path"));
    api->options_init(&o);
    o.sampler = "halton";
    assert_int_equal(api->set_options(r, &o, msg, sizeof(msg)), VBNL_PLUGIN_ERR_UNKNOWN_NAME);
    assert_non_null(strstr(msg, "unknown sampler 'halton' (valid: sobol, random)"));
    /* the message is truncated to the caller's buffer and NUL-terminated */
    assert_int_equal(api->set_options(r, &o, tiny, sizeof(tiny)), VBNL_PLUGIN_ERR_UNKNOWN_NAME);
    assert_int_equal(strlen(tiny), sizeof(tiny) - 1);
    assert_int_equal(api->set_param(r, "=3", "test", msg, sizeof(msg)), VBNL_PLUGIN_ERR_INVALID_ARGUMENT);
    assert_int_equal(api->set_param(r, "max_dpth=3", "--set", msg, sizeof(msg)), VBNL_PLUGIN_OK);
    assert_int_equal(api->load_scene_file(r, "/nonexistent/scene.obj", msg, sizeof(msg)), VBNL_PLUGIN_ERR_IO);
    assert_non_null(strstr(msg, "/nonexistent/scene.obj"));
    assert_int_equal(api->load_scene_file(r, g_scene, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    /* an unknown parameter is found by configure, with a suggestion */
    assert_int_equal(api->configure(r, msg, sizeof(msg)), VBNL_PLUGIN_ERR_UNKNOWN_NAME);
    assert_non_null(strstr(msg, "did you mean 'max_depth'"));
    /* threads are fixed once a scene is loaded */
    api->options_init(&o);
    o.threads = 3;
    assert_int_equal(api->set_options(r, &o, msg, sizeof(msg)), VBNL_PLUGIN_ERR_STATE);
    /* scene text that is not a scene is refused with a message, never a crash */
    static const char junk[] = "camera { location <0,0,-3 look_at ";
    assert_int_not_equal(api->load_scene_text(r, "junk.pov", junk, sizeof(junk) - 1, msg, sizeof(msg)),
                         VBNL_PLUGIN_OK);
    assert_true(strlen(msg) > 0);
    assert_int_equal(api->check_writable("/nonexistent/dir/a.exr", msg, sizeof(msg)), VBNL_PLUGIN_ERR_IO);
    assert_non_null(strstr(msg, "cannot write"));
    vbnl_plugin_stats st = {.size = 4};
    assert_int_equal(api->get_stats(r, &st, msg, sizeof(msg)), VBNL_PLUGIN_ERR_INVALID_ARGUMENT);
    api->renderer_destroy(r);
}

/* abandon_writes, as a host's signal handler calls it before _exit(). It cannot be undone in a
 * process: this test runs last. Later writes fail and leave nothing; the old file stays. */
static void test_abandon_writes(void **state)
{
    (void)state;
    vbnl_plugin_renderer *r = make(1, 1, NULL);
    char msg[1024], exr[128], png[128];
    assert_int_equal(api->prepare(r, NULL, NULL, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    assert_int_equal(api->render(r, NULL, NULL, msg, sizeof(msg)), VBNL_PLUGIN_OK);
    snprintf(exr, sizeof(exr), "%s/abandoned.exr", g_dir);
    snprintf(png, sizeof(png), "%s/abandoned.png", g_dir);
    FILE *old = fopen(exr, "w");
    assert_non_null(old);
    fputs("previous render", old);
    fclose(old);
    api->abandon_writes();
    assert_int_equal(api->write_exr(r, exr, 0, msg, sizeof(msg)), VBNL_PLUGIN_ERR_CANCELLED);
    assert_non_null(strstr(msg, "abandoned"));
    assert_int_equal(api->write_png(r, png, NULL, msg, sizeof(msg)), VBNL_PLUGIN_ERR_CANCELLED);
    assert_int_equal(api->check_writable(png, msg, sizeof(msg)), VBNL_PLUGIN_ERR_CANCELLED);
    char text[32] = "";
    old = fopen(exr, "r");
    assert_non_null(old);
    assert_non_null(fgets(text, sizeof(text), old));
    fclose(old);
    assert_string_equal(text, "previous render");
    assert_int_equal(access(png, F_OK), -1);
    char cmd[160];
    snprintf(cmd, sizeof(cmd), "ls '%s' | grep -q tmp-", g_dir);
    assert_int_not_equal(system(cmd), 0);
    api->renderer_destroy(r);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_handshake),           cmocka_unit_test(test_fake_plugin_refused),
        cmocka_unit_test(test_integrators),         cmocka_unit_test(test_render_and_framebuffer),
        cmocka_unit_test(test_outputs_round_trip),  cmocka_unit_test(test_cancel_writes_partial),
        cmocka_unit_test(test_sampler_option),      cmocka_unit_test(test_bad_arguments),
        cmocka_unit_test(test_png_alpha),           cmocka_unit_test(test_scene_options),
        cmocka_unit_test(test_abandon_writes), /* last: writes fail after it */
    };
    return cmocka_run_group_tests(tests, group_setup, group_teardown);
}
