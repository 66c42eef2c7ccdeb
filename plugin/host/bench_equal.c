/* `vbnl bench --equal-time`: path tracing against VBNL and its ablations at equal time (the
 * paper's Fig. 18 on this machine). For every scene: a cached converged `path` reference, then
 * every method at every time budget (preparation included), rMAE as the paper defines it, the
 * stage times of `vbnl` (the paper's Table 1), the images, and a log-log plot (SVG). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "host.h"
#include "image_io.h"

typedef struct bench_scene {
    const char *name, *file, *camera;
} bench_scene;

typedef struct bench_method {
    const char *label;
    const char *integrator;
    const char *extra; /* one extra key=value, or NULL */
} bench_method;

static const bench_method methods[] = {
    {"path", "path", NULL},
    {"vbnl", "vbnl", NULL},
    {"vbnl no elimination", "vbnl", "elimination=none"},
    {"vbnl uniform elimination", "vbnl", "elimination=uniform"},
    {"vbnl no path extension", "vbnl", "path_extension=off"},
};
#define N_METHODS (sizeof(methods) / sizeof(methods[0]))
static const char *const colours[N_METHODS] = {"#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e"};

static double rmae(const float *img, const float *ref, size_t n) { return host_rmae(img, ref, n); }

/* The preparation of `vbnl` scaled to the budget on a 2-core CPU (the paper's defaults, 130K
 * lights and 20M photon paths, are sized for a GPU): lights and photons grow with the budget so
 * that preparation takes roughly a third of it. */
static void vbnl_budget_params(vbnl_params *p, double budget)
{
    double lights = fmin(130000.0, 4000.0 * budget);
    double photons = fmin(2e7, 40000.0 * budget);
    vbnl_params_set_number(p, "virtual_lights", floor(lights), "bench", NULL);
    vbnl_params_set_number(p, "photon_paths", floor(photons), "bench", NULL);
}

typedef struct run_result {
    double rmae, seconds;
    uint32_t spp;
    vbnl_render_stats stats;
    char stages[512];
} run_result;

static float *read_rgba(const vbnl_renderer *r, uint32_t w, uint32_t h)
{
    float *px = malloc(sizeof(float) * 4 * w * h);
    if (px && vbnl_film_read(vbnl_renderer_film(r), "", px, (size_t)4 * w * h, NULL) != VBNL_OK) {
        free(px);
        return NULL;
    }
    return px;
}

static int run_one(vbnl_context *ctx, const vbnl_scene *scene, const bench_method *m, double budget,
                   uint32_t size, const float *ref, const char *png, run_result *out)
{
    vbnl_params *p;
    vbnl_params_create(&p, NULL);
    if (!strcmp(m->integrator, "vbnl"))
        vbnl_budget_params(p, budget);
    if (m->extra)
        vbnl_params_set_text(p, m->extra, "bench", NULL);
    vbnl_render_settings s;
    vbnl_render_settings_init(&s);
    s.width = s.height = size;
    s.spp = 0;
    s.time_budget = budget;
    s.seed = 7;
    s.integrator = m->integrator;
    s.params = p;
    vbnl_renderer *r = NULL;
    vbnl_error err = {0};
    int ok = vbnl_renderer_create(ctx, scene, &s, &r, &err) == VBNL_OK &&
             vbnl_renderer_render(r, NULL, NULL, &err) == VBNL_OK;
    if (!ok) {
        fprintf(stderr, "vbnl bench: %s: %s\n", m->label, err.message);
        vbnl_renderer_destroy(r);
        vbnl_params_destroy(p);
        return -1;
    }
    float *img = read_rgba(r, size, size);
    vbnl_renderer_get_stats(r, &out->stats, NULL);
    out->spp = out->stats.spp;
    out->seconds = out->stats.prepare_seconds + out->stats.render_seconds;
    out->rmae = img ? rmae(img, ref, (size_t)size * size) : NAN;
    out->stages[0] = '\0';
    for (uint32_t i = 0; i < out->stats.stage_count; ++i) {
        size_t n = strlen(out->stages);
        snprintf(out->stages + n, sizeof(out->stages) - n, "%s%s %.2fs", i ? ", " : "",
                 out->stats.stages[i].name, out->stats.stages[i].seconds);
    }
    if (img && png) {
        uint8_t *px8 = malloc((size_t)size * size * 3);
        if (px8 && vbnl_linear_to_srgb8(img, size, size, 4, 0.0f, 1, px8, 3, NULL) == VBNL_OK)
            vbnl_png_write(png, size, size, 3, 8, px8, NULL);
        free(px8);
    }
    free(img);
    vbnl_renderer_destroy(r);
    vbnl_params_destroy(p);
    return 0;
}

/* A log-log plot of rMAE against time, one line per method. */
static void write_svg(const char *path, const char *scene, const double *budgets, int nb,
                      run_result res[][8])
{
    FILE *f = fopen(path, "w");
    if (!f)
        return;
    const double W = 640, H = 420, L = 70, R = 190, T = 40, B = 50;
    double tmin = budgets[0] * 0.8, tmax = budgets[nb - 1] * 1.25, emin = 1e9, emax = 0;
    for (unsigned m = 0; m < N_METHODS; ++m)
        for (int b = 0; b < nb; ++b)
            if (isfinite(res[m][b].rmae) && res[m][b].rmae > 0) {
                emin = fmin(emin, res[m][b].rmae);
                emax = fmax(emax, res[m][b].rmae);
            }
    if (!(emax > 0)) {
        fclose(f);
        return;
    }
    emin = pow(10, floor(log10(emin))), emax = pow(10, ceil(log10(emax)));
    if (emax <= emin)
        emax = emin * 10;
#define PX(t) (L + (log10(t) - log10(tmin)) / (log10(tmax) - log10(tmin)) * (W - L - R))
#define PY(e) (H - B - (log10(e) - log10(emin)) / (log10(emax) - log10(emin)) * (H - T - B))
    fprintf(f, "<svg xmlns='http://www.w3.org/2000/svg' width='%.0f' height='%.0f' font-family='sans-serif' font-size='12'>\n", W, H);
    fprintf(f, "<rect width='100%%' height='100%%' fill='white'/>\n");
    fprintf(f, "<text x='%.0f' y='22' font-size='15'>%s: rMAE against time (log-log)</text>\n", L, scene);
    fprintf(f, "<line x1='%.1f' y1='%.1f' x2='%.1f' y2='%.1f' stroke='black'/>\n", L, H - B, W - R, H - B);
    fprintf(f, "<line x1='%.1f' y1='%.1f' x2='%.1f' y2='%.1f' stroke='black'/>\n", L, T, L, H - B);
    for (int b = 0; b < nb; ++b)
        fprintf(f, "<text x='%.1f' y='%.1f' text-anchor='middle'>%g s</text>\n", PX(budgets[b]), H - B + 18, budgets[b]);
    for (double e = emin; e <= emax * 1.001; e *= 10)
        fprintf(f, "<text x='%.1f' y='%.1f' text-anchor='end'>%g</text>\n", L - 6, PY(e) + 4, e);
    fprintf(f, "<text x='%.1f' y='%.1f' text-anchor='middle'>time (preparation + rendering)</text>\n",
            (L + W - R) / 2, H - 12);
    for (unsigned m = 0; m < N_METHODS; ++m) {
        fprintf(f, "<polyline fill='none' stroke='%s' stroke-width='2' points='", colours[m]);
        for (int b = 0; b < nb; ++b)
            if (isfinite(res[m][b].rmae) && res[m][b].rmae > 0)
                fprintf(f, "%.1f,%.1f ", PX(res[m][b].seconds), PY(res[m][b].rmae));
        fprintf(f, "'/>\n");
        fprintf(f, "<rect x='%.0f' y='%.0f' width='14' height='4' fill='%s'/><text x='%.0f' y='%.0f'>%s</text>\n",
                W - R + 14, T + 20.0 * m + 6, colours[m], W - R + 34, T + 20.0 * m + 12, methods[m].label);
    }
    fprintf(f, "</svg>\n");
#undef PX
#undef PY
    fclose(f);
}

int host_bench_equal_time(const char *out_dir, uint32_t size, const double *budgets, int nb, double ref_time,
                          const char *shared_dir, const char *only_scene)
{
    char cornell[1024], glossy[1024];
    snprintf(cornell, sizeof(cornell), "examples/cornell-box.obj");
    snprintf(glossy, sizeof(glossy), "%s/scenes/cornell-box-mcguire/CornellBox-Glossy-Floor.obj", shared_dir);
    const bench_scene scenes[] = {
        {"cornell", cornell, "0,1,3.6,0,1,0,39"},
        {"glossy", glossy, "0,1,3.5,0,1,0,40"},
        {"door-ajar", "examples/door-ajar.obj", "3.6,1.3,1.6,0,1,-0.2,60"},
    };
    if (mkdir(out_dir, 0777) != 0 && errno != EEXIST) {
        fprintf(stderr, "vbnl bench: cannot create '%s': %s\n", out_dir, strerror(errno));
        return VBNL_EXIT_FAILURE;
    }
    vbnl_context *ctx;
    vbnl_error err = {0};
    vbnl_context_desc cd = {0};
    if (vbnl_context_create(&cd, &ctx, &err) != VBNL_OK) {
        fprintf(stderr, "vbnl bench: %s\n", err.message);
        return VBNL_EXIT_FAILURE;
    }
    printf("equal-time benchmark, %ux%u, %u threads, budgets include preparation\n\n", size, size,
           vbnl_context_thread_count(ctx));
    int rc = VBNL_EXIT_OK;
    for (unsigned si = 0; si < sizeof(scenes) / sizeof(scenes[0]); ++si) {
        const bench_scene *bs = &scenes[si];
        if (only_scene && strcmp(only_scene, bs->name) != 0)
            continue;
        host_camera cam = {0};
        host_parse_camera(bs->camera, &cam);
        vbnl_scene *scene = NULL;
        if (host_load_scene(ctx, bs->file, &cam, 1.0f, &scene, &err) != VBNL_OK) {
            fprintf(stderr, "vbnl bench: %s\n", err.message);
            rc = VBNL_EXIT_SCENE;
            continue;
        }
        /* reference: cached by scene, size and time */
        char ref_path[1200];
        snprintf(ref_path, sizeof(ref_path), "%s/%s-reference-%u-%gs.exr", out_dir, bs->name, size, ref_time);
        float *ref = NULL;
        uint32_t ref_spp = 0;
        vbnl_exr_image ex;
        if (vbnl_exr_read(ref_path, &ex, NULL) == VBNL_OK && ex.width == size && ex.height == size) {
            ref = malloc(sizeof(float) * 4 * size * size);
            const char *names[4] = {"R", "G", "B", "A"};
            for (int c = 0; c < 4; ++c) {
                const vbnl_exr_channel *ch = vbnl_exr_image_channel(&ex, names[c]);
                for (size_t i = 0; i < (size_t)size * size; ++i)
                    ref[4 * i + c] = ch ? ch->data[i] : 1.0f;
            }
            const vbnl_image_attr *a = vbnl_exr_image_attr(&ex, "vbnl/spp");
            ref_spp = a ? (uint32_t)a->value.i : 0;
            vbnl_exr_image_free(&ex);
        } else {
            vbnl_render_settings s;
            vbnl_render_settings_init(&s);
            s.width = s.height = size;
            s.spp = 0;
            s.time_budget = ref_time;
            s.seed = 1000003;
            vbnl_renderer *r;
            if (vbnl_renderer_create(ctx, scene, &s, &r, &err) != VBNL_OK ||
                vbnl_renderer_render(r, NULL, NULL, &err) != VBNL_OK) {
                fprintf(stderr, "vbnl bench: reference: %s\n", err.message);
                vbnl_scene_destroy(scene);
                rc = VBNL_EXIT_FAILURE;
                continue;
            }
            ref = read_rgba(r, size, size);
            vbnl_render_stats st;
            vbnl_renderer_get_stats(r, &st, NULL);
            ref_spp = st.spp;
            host_write_outputs(r, &s, ref_path, NULL, 0.0f, 0, 0, NULL);
            vbnl_renderer_destroy(r);
        }
        printf("scene %s (%s): reference `path` %u spp (%s)\n", bs->name, bs->file, ref_spp, ref_path);
        printf("  %-26s", "method \\ budget");
        for (int b = 0; b < nb; ++b)
            printf(" %8gs rMAE   spp", budgets[b]);
        printf("\n");
        run_result res[N_METHODS][8];
        memset(res, 0, sizeof(res));
        for (unsigned m = 0; m < N_METHODS; ++m) {
            printf("  %-26s", methods[m].label);
            fflush(stdout);
            for (int b = 0; b < nb; ++b) {
                char png[1400];
                snprintf(png, sizeof(png), "%s/%s-%s-%gs.png", out_dir, bs->name, methods[m].label, budgets[b]);
                for (char *c = png + strlen(out_dir) + 1; *c; ++c)
                    if (*c == ' ')
                        *c = '_';
                if (run_one(ctx, scene, &methods[m], budgets[b], size, ref, png, &res[m][b]) != 0)
                    res[m][b].rmae = NAN;
                printf(" %14.4f %5u", res[m][b].rmae, res[m][b].spp);
                fflush(stdout);
            }
            printf("\n");
        }
        printf("  stage times of `vbnl` (paper Table 1):\n");
        for (int b = 0; b < nb; ++b)
            printf("    %gs budget: %s\n", budgets[b], res[1][b].stages);
        for (int b = 0; b < nb; ++b)
            if (res[1][b].rmae > 0 && res[0][b].rmae > 0)
                printf("  path/vbnl rMAE ratio at %gs: %.2f\n", budgets[b], res[0][b].rmae / res[1][b].rmae);
        char svg[1200];
        snprintf(svg, sizeof(svg), "%s/%s-equal-time.svg", out_dir, bs->name);
        write_svg(svg, bs->name, budgets, nb, res);
        printf("  plot: %s\n\n", svg);
        free(ref);
        vbnl_scene_destroy(scene);
    }
    vbnl_context_destroy(ctx);
    return rc;
}
