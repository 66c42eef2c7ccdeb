/* The cost of the directional environment (built, not run as a test): for each sky, the time of
 * its bake at commit (the scene loaded with the sky minus the same scene with a constant
 * background, medians of 5 loads) and the time per call of what rendering does with it: a light
 * sample (table draw and the exact pattern's radiance), the radiance alone (camera and BSDF rays
 * that leave the scene) and the pdf alone (MIS weights).
 *
 *     bench_environment [calls]     (default 200000 calls per measurement; one thread) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "lights.h"
#include "rng.h"
#include "scene_internal.h"
#include "vbnl/pov_scene.h"
#include "vbnl/render.h"

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

#define HEAD "camera { location <0, 1, -4> look_at 0 }\nsphere { 0, 1 pigment { rgb 0.5 } }\n"

static const struct {
    const char *name, *sky;
} cases[] = {
    {"background (constant)", "background { rgb <0.4, 0.6, 1> }"},
    {"solid sky_sphere", "sky_sphere { pigment { rgb <0.4, 0.6, 1> } }"},
    {"gradient y", "sky_sphere { pigment { gradient y color_map { [0 rgb 1] [1 rgb <0.1, 0.3, 1>] } } }"},
    {"bozo clouds, turbulence 0.6, 7 octaves",
     "sky_sphere { pigment { gradient y color_map { [0 rgb <0.6, 0.7, 1>] [1 rgb <0, 0.1, 0.8>] } }"
     " pigment { bozo turbulence 0.6 octaves 7 omega 0.5 lambda 2.5 color_map { [0 rgbf <0.8, 0.8, 0.8, 0.1>]"
     " [0.4 rgbf <0.9, 0.9, 0.9, 0.9>] [0.7 rgbf 1] } scale <0.6, 0.2, 0.2> } }"},
    {"granite, 3 layers",
     "sky_sphere { pigment { gradient y color_map { [0 rgb 1] [1 rgb <0.1, 0.3, 1>] } }"
     " pigment { granite color_map { [0 rgbt <1, 1, 1, 0.5>] [1 rgbt 1] } scale 0.5 }"
     " pigment { wrinkles turbulence 0.3 color_map { [0 rgbt 1] [0.8 rgbt 1] [1 rgbt <1, 1, 1, 0.2>] } } }"},
};

static double load_ms(vbnl_context *ctx, const char *sky, vbnl_pov_scene **keep)
{
    char text[2048];
    snprintf(text, sizeof text, HEAD "%s\n", sky);
    double t[5];
    for (int run = 0; run < 5; ++run) {
        vbnl_pov_options opt;
        vbnl_pov_options_init(&opt);
        vbnl_pov_scene *s = NULL;
        vbnl_error err = {0};
        double t0 = now();
        if (vbnl_pov_load_text(ctx, "bench.pov", text, strlen(text), &opt, &s, &err) != VBNL_OK) {
            fprintf(stderr, "%s\n", err.message);
            exit(1);
        }
        t[run] = (now() - t0) * 1e3;
        if (keep && run == 4)
            *keep = s;
        else
            vbnl_pov_scene_destroy(s);
    }
    qsort(t, 5, sizeof t[0], cmp_d);
    return t[2];
}

int main(int argc, char **argv)
{
    uint32_t n = argc > 1 ? (uint32_t)atoi(argv[1]) : 200000;
    vbnl_context *ctx;
    vbnl_context_desc cdesc;
    vbnl_context_desc_init(&cdesc);
    cdesc.threads = 1;
    if (vbnl_context_create(&cdesc, &ctx, NULL) != VBNL_OK)
        return 1;
    double base = load_ms(ctx, "background { rgb 1 }", NULL);
    printf("%-40s %9s %12s %10s %10s\n", "sky", "bake ms", "sample ns", "Le ns", "pdf ns");
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; ++c) {
        vbnl_pov_scene *s = NULL;
        double ms = load_ms(ctx, cases[c].sky, &s);
        const vbnl_scene *sc = vbnl_pov_scene_get(s);
        const vbi_light *l = &sc->lights[sc->env_light];
        vbi_rng rng = vbi_rng_make(1, 2);
        double sink = 0.0, t0 = now();
        for (uint32_t i = 0; i < n; ++i) {
            vbi_light_li_sample ls;
            vec2 u = {vbi_rng_next(&rng), vbi_rng_next(&rng)};
            if (vbi_light_sample_li(l, v3s(0.0f), u, &ls))
                sink += ls.Li.x / ls.pdf;
        }
        double t_sample = (now() - t0) * 1e9 / n;
        t0 = now();
        for (uint32_t i = 0; i < n; ++i) {
            vec3 w = sample_uniform_sphere((vec2){vbi_rng_next(&rng), vbi_rng_next(&rng)});
            sink += vbi_light_Le(l, v3s(0.0f), w).y;
        }
        double t_le = (now() - t0) * 1e9 / n;
        t0 = now();
        for (uint32_t i = 0; i < n; ++i) {
            vec3 w = sample_uniform_sphere((vec2){vbi_rng_next(&rng), vbi_rng_next(&rng)});
            sink += vbi_light_pdf_li(l, v3s(0.0f), v3s(0.0f), v3s(0.0f), w);
        }
        double t_pdf = (now() - t0) * 1e9 / n;
        printf("%-40s %9.1f %12.1f %10.1f %10.1f%s\n", cases[c].name, ms - base, t_sample, t_le, t_pdf,
               sink == 0.0 ? " (no light)" : "");
        vbnl_pov_scene_destroy(s);
    }
    vbnl_context_destroy(ctx);
    return 0;
}
