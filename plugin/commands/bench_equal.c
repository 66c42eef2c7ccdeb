/* `vbnl bench --equal-time`: path tracing against VBNL, its ablations and the many-light
 * baselines (vpl, vpl with Georgiev-Slusallek acceptance, vsl, richvsl when registered) at equal
 * time (the paper's Fig. 18 on this machine). For every scene: a cached converged `path`
 * reference, then every method at every time budget (preparation included), rMAE as the paper
 * defines it, the stage times of `vbnl` (the paper's Table 1), the images, and a log-log plot
 * (SVG) with one line per method. With --equal-count N, also every virtual-light method with the
 * same number N of virtual lights at a fixed sample count (the paper's Figs. 1 and 12):
 * preparation time per stage, shading time, storage and rMAE. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "commands.h"
#include "image_io.h"
#include "module.h"

typedef struct bench_scene {
    const char *name, *file, *camera;
} bench_scene;

/* The methods, one line each. `lights` marks a virtual-light method: at equal time it sizes its
 * `virtual_lights` to the budget itself; in the equal-count run it is set to N (when `count` is
 * also set). A method whose
 * integrator is not registered is skipped with a note. The clamp bound of the VPL-type methods is
 * the same for all of them (the notes §7.4): 2 in the units of the bench scenes (boxes about 2
 * units wide), i.e. G is bounded for VPLs closer than about 0.7 units. */
typedef struct bench_method {
    const char *label;
    const char *integrator;
    const char *extra; /* space-separated key=value settings, or NULL */
    int lights;        /* a virtual-light method */
    int count;         /* part of the equal-count run */
} bench_method;

#define BENCH_SEED 7u /* of the first run; run k of an equal-time cell uses BENCH_SEED + k */
#define BENCH_CLAMP "clamp=2"
static const bench_method methods[] = {
    {"path", "path", NULL, 0, 0},
    {"vbnl", "vbnl", NULL, 1, 1},
    {"vbnl no elimination", "vbnl", "elimination=none", 1, 0},
    {"vbnl uniform elimination", "vbnl", "elimination=uniform", 1, 0},
    {"vbnl no path extension", "vbnl", "path_extension=off", 1, 0},
    {"vpl", "vpl", BENCH_CLAMP, 1, 1},
    {"vpl acceptance", "vpl", BENCH_CLAMP " acceptance=on", 1, 1},
    {"vsl", "vsl", NULL, 1, 1},
    {"richvsl", "richvsl", BENCH_CLAMP, 1, 1},
};
#define N_METHODS (sizeof(methods) / sizeof(methods[0]))
static const char *const colours[] = {"#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e",
                                      "#8c564b", "#e377c2", "#7f7f7f", "#17becf", "#bcbd22"};

/* Methods chosen with --methods (labels, comma-separated); NULL = all. */
static int method_selected(const bench_method *m, const char *list)
{
    if (!list)
        return 1;
    size_t n = strlen(m->label);
    for (const char *p = list; *p;) {
        const char *comma = strchr(p, ',');
        size_t len = comma ? (size_t)(comma - p) : strlen(p);
        if (len == n && !strncmp(p, m->label, n))
            return 1;
        if (!comma)
            break;
        p = comma + 1;
    }
    return 0;
}

static int method_available(const bench_method *m, const char *list)
{
    return method_selected(m, list) && vbnl_integrator_find(m->integrator) != NULL;
}

static double rmae(const float *img, const float *ref, size_t n) { return cmd_rmae(img, ref, n); }

/* Sets the space-separated key=value list `extra`. */
static void set_extra(vbnl_params *p, const char *extra)
{
    if (!extra)
        return;
    char buf[256];
    snprintf(buf, sizeof(buf), "%s", extra);
    for (char *tok = strtok(buf, " "); tok; tok = strtok(NULL, " "))
        vbnl_params_set_text(p, tok, "bench", NULL);
}

typedef struct run_result {
    double rmae, seconds;
    uint32_t spp;
    vbnl_render_stats stats;
    char stages[512];       /* every stage with its time */
    char prep_stages[512];  /* the preparation stages only */
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

/* Index of the run of median rMAE among n (the lower median for even n; failed runs, NaN, count
 * as the largest). */
static uint32_t median_run(const run_result *r, uint32_t n)
{
    uint32_t idx[128];
    n = n < 128 ? n : 128;
    for (uint32_t i = 0; i < n; ++i)
        idx[i] = i;
    for (uint32_t i = 1; i < n; ++i) /* insertion sort by rMAE, NaN last */
        for (uint32_t j = i; j > 0; --j) {
            double a = r[idx[j - 1]].rmae, b = r[idx[j]].rmae;
            if (!(isnan(a) ? !isnan(b) : (!isnan(b) && b < a)))
                break;
            uint32_t t = idx[j];
            idx[j] = idx[j - 1];
            idx[j - 1] = t;
        }
    return idx[(n - 1) / 2];
}

/* One render: under a time budget (budget > 0) or, for the equal-count run, with `count` virtual
 * lights and `spp` samples. */
static int run_one(vbnl_context *ctx, const vbnl_scene *scene, const bench_method *m, double budget,
                   uint32_t count, uint32_t spp, uint32_t size, vbnl_sampler_kind sampler, uint64_t seed,
                   const float *ref, const char *png, run_result *out)
{
    vbnl_params *p;
    vbnl_params_create(&p, NULL);
    /* Under a time budget every method sizes its own work, exactly as `vbnl render --time` does
     * (docs/time-budget.md): nothing is set here but the method's own settings. */
    if (!(budget > 0.0) && m->lights) {
        vbnl_params_set_number(p, "virtual_lights", count, "bench", NULL);
        if (!strcmp(m->integrator, "vbnl")) /* the paper's ratio: 20M photons for 130K lights */
            vbnl_params_set_number(p, "photon_paths", fmin(2e7, fmax(1e5, 150.0 * count)), "bench", NULL);
    }
    set_extra(p, m->extra);
    vbnl_render_settings s;
    vbnl_render_settings_init(&s);
    s.width = s.height = size;
    s.spp = budget > 0.0 ? 0 : spp;
    s.time_budget = budget > 0.0 ? budget : 0.0;
    s.seed = seed;
    s.sampler = sampler;
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
    out->stages[0] = out->prep_stages[0] = '\0';
    for (uint32_t i = 0; i < out->stats.stage_count; ++i) {
        size_t n = strlen(out->stages);
        snprintf(out->stages + n, sizeof(out->stages) - n, "%s%s %.2fs", i ? ", " : "",
                 out->stats.stages[i].name, out->stats.stages[i].seconds);
        if (strcmp(out->stats.stages[i].name, "render") != 0) {
            n = strlen(out->prep_stages);
            snprintf(out->prep_stages + n, sizeof(out->prep_stages) - n, "%s%s %.2fs", n ? ", " : "",
                     out->stats.stages[i].name, out->stats.stages[i].seconds);
        }
    }
    /* the stage names belong to the renderer, destroyed below */
    out->stats.stages = NULL;
    out->stats.stage_count = 0;
    if (img && png) {
        uint8_t *px8 = malloc((size_t)size * size * 3);
        if (px8 && vbi_linear_to_srgb8(img, size, size, 4, 0.0f, 1, px8, 3, NULL) == VBNL_OK)
            vbi_png_write(png, size, size, 3, 8, px8, NULL);
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
    for (unsigned m = 0, row = 0; m < N_METHODS; ++m) {
        if (!(res[m][0].seconds > 0.0))
            continue; /* not run */
        fprintf(f, "<polyline fill='none' stroke='%s' stroke-width='2' points='", colours[m]);
        for (int b = 0; b < nb; ++b)
            if (isfinite(res[m][b].rmae) && res[m][b].rmae > 0)
                fprintf(f, "%.1f,%.1f ", PX(res[m][b].seconds), PY(res[m][b].rmae));
        fprintf(f, "'/>\n");
        fprintf(f, "<rect x='%.0f' y='%.0f' width='14' height='4' fill='%s'/><text x='%.0f' y='%.0f'>%s</text>\n",
                W - R + 14, T + 20.0 * row + 6, colours[m], W - R + 34, T + 20.0 * row + 12, methods[m].label);
        row++;
    }
    fprintf(f, "</svg>\n");
#undef PX
#undef PY
    fclose(f);
}

static void png_name(char *out, size_t size, const char *dir, const char *scene, const char *label, const char *what)
{
    snprintf(out, size, "%s/%s-%s-%s.png", dir, scene, label, what);
    for (char *c = out + strlen(dir) + 1; *c; ++c)
        if (*c == ' ')
            *c = '_';
}

/* The equal-count run: every selected virtual-light method with `count` lights, `spp` samples. */
static void equal_count(vbnl_context *ctx, const vbnl_scene *scene, const char *scene_name, const cmd_bench_equal_opts *o,
                        const float *ref)
{
    printf("  equal count: %u virtual lights, %u spp, %ux%u (times are noisy on a shared machine)\n", o->count,
           o->count_spp, o->size, o->size);
    printf("  %-16s %10s %10s %12s %10s  %s\n", "method", "prepare s", "shading s", "storage KB", "rMAE",
           "preparation stages");
    for (unsigned m = 0; m < N_METHODS; ++m) {
        const bench_method *bm = &methods[m];
        if (!bm->count || !method_selected(bm, o->methods))
            continue;
        if (!vbnl_integrator_find(bm->integrator)) {
            printf("  %-16s (integrator '%s' not registered in this build: skipped)\n", bm->label, bm->integrator);
            continue;
        }
        char png[1400];
        char what[64];
        snprintf(what, sizeof(what), "count%u", o->count);
        png_name(png, sizeof(png), o->out_dir, scene_name, bm->label, what);
        run_result r;
        memset(&r, 0, sizeof(r));
        if (run_one(ctx, scene, bm, 0.0, o->count, o->count_spp, o->size, o->sampler, BENCH_SEED, ref, png, &r) != 0)
            continue;
        printf("  %-16s %10.2f %10.2f %12.1f %10.4f  %s\n", bm->label, r.stats.prepare_seconds, r.stats.render_seconds,
               (double)r.stats.storage_bytes / 1024.0, r.rmae, r.prep_stages);
        fflush(stdout);
    }
}

int cmd_bench_equal_time(const cmd_bench_equal_opts *o)
{
    const char *out_dir = o->out_dir;
    const uint32_t size = o->size;
    const double *budgets = o->budgets;
    const int nb = o->nb;
    const bench_scene scenes[] = {
        {"cornell", "examples/cornell-box.obj", "0,1,3.6,0,1,0,39"},
        {"glossy", "examples/mcguire/CornellBox-Glossy-Floor.obj", "0,1,3.5,0,1,0,40"},
        {"door-ajar", "examples/door-ajar.obj", "3.6,1.3,1.6,0,1,-0.2,60"},
    };
    for (unsigned m = 0; m < N_METHODS; ++m)
        if (method_selected(&methods[m], o->methods) && !vbnl_integrator_find(methods[m].integrator))
            printf("note: method '%s' skipped: integrator '%s' is not registered in this build\n", methods[m].label,
                   methods[m].integrator);
    if (mkdir(out_dir, 0777) != 0 && errno != EEXIST) {
        fprintf(stderr, "vbnl bench: cannot create '%s': %s\n", out_dir, strerror(errno));
        return VBI_EXIT_FAILURE;
    }
    vbnl_context *ctx;
    vbnl_error err = {0};
    if (vbnl_context_create(NULL, &ctx, &err) != VBNL_OK) {
        fprintf(stderr, "vbnl bench: %s\n", err.message);
        return VBI_EXIT_FAILURE;
    }
    printf("equal-time benchmark, %ux%u, %u threads, sampler %s, budgets include preparation\n\n", size, size,
           vbnl_context_thread_count(ctx), vbnl_sampler_name(o->sampler));
    int rc = VBI_EXIT_OK;
    for (unsigned si = 0; si < sizeof(scenes) / sizeof(scenes[0]); ++si) {
        const bench_scene *bs = &scenes[si];
        if (o->only_scene && strcmp(o->only_scene, bs->name) != 0)
            continue;
        module_camera cam = {1, {0}, {0}, 0.0f};
        cli_parse_camera(bs->camera, cam.position, cam.target, &cam.fov_y);
        vbnl_scene *scene = NULL;
        if (module_load_scene(ctx, bs->file, &cam, 1.0f, &scene, &err) != VBNL_OK) {
            fprintf(stderr, "vbnl bench: %s\n", err.message);
            rc = VBI_EXIT_SCENE;
            continue;
        }
        /* reference: cached by scene, size and time or sample count */
        char ref_path[1200];
        if (o->ref_spp > 0)
            snprintf(ref_path, sizeof(ref_path), "%s/%s-reference-%u-%uspp.exr", out_dir, bs->name, size, o->ref_spp);
        else
            snprintf(ref_path, sizeof(ref_path), "%s/%s-reference-%u-%gs.exr", out_dir, bs->name, size, o->ref_time);
        float *ref = NULL;
        uint32_t ref_spp = 0;
        vbi_exr_image ex;
        if (vbi_exr_read(ref_path, &ex, NULL) == VBNL_OK && ex.width == size && ex.height == size) {
            ref = malloc(sizeof(float) * 4 * size * size);
            const char *names[4] = {"R", "G", "B", "A"};
            for (int c = 0; c < 4; ++c) {
                const vbi_exr_channel *ch = vbi_exr_image_channel(&ex, names[c]);
                for (size_t i = 0; i < (size_t)size * size; ++i)
                    ref[4 * i + c] = ch ? ch->data[i] : 1.0f;
            }
            const vbi_image_attr *a = vbi_exr_image_attr(&ex, "vbnl/spp");
            ref_spp = a ? (uint32_t)a->value.i : 0;
            vbi_exr_image_free(&ex);
        } else {
            vbnl_render_settings s;
            vbnl_render_settings_init(&s);
            s.width = s.height = size;
            s.spp = o->ref_spp;
            s.time_budget = o->ref_spp > 0 ? 0.0 : o->ref_time;
            s.seed = 1000003;
            vbnl_renderer *r;
            if (vbnl_renderer_create(ctx, scene, &s, &r, &err) != VBNL_OK ||
                vbnl_renderer_render(r, NULL, NULL, &err) != VBNL_OK) {
                fprintf(stderr, "vbnl bench: reference: %s\n", err.message);
                vbnl_scene_destroy(scene);
                rc = VBI_EXIT_FAILURE;
                continue;
            }
            ref = read_rgba(r, size, size);
            vbnl_render_stats st;
            vbnl_renderer_get_stats(r, &st, NULL);
            ref_spp = st.spp;
            printf("scene %s: reference rendered, %u spp in %.0f s\n", bs->name, st.spp, st.render_seconds);
            module_write_outputs(r, &s, scene, ref_path, NULL, 0.0f, 0, 0, NULL);
            vbnl_renderer_destroy(r);
        }
        printf("scene %s (%s): reference `path` %u spp (%s)\n", bs->name, bs->file, ref_spp, ref_path);
        if (nb > 0) {
            /* Rounds outside, then budgets, methods inside: the methods of a budget run one
             * after another, and every round visits every cell, so that a machine whose speed
             * drifts (a shared VM) treats the methods alike. Run k uses seed BENCH_SEED + k. */
            const uint32_t runs = o->runs ? o->runs : 1;
            run_result *all = calloc((size_t)N_METHODS * 8 * runs, sizeof(run_result));
            run_result res[N_METHODS][8];
            memset(res, 0, sizeof(res));
            if (!all) {
                fprintf(stderr, "vbnl bench: out of memory\n");
                free(ref);
                vbnl_scene_destroy(scene);
                rc = VBI_EXIT_FAILURE;
                continue;
            }
#define CELL(m, b, k) all[((size_t)(m) * 8 + (size_t)(b)) * runs + (k)]
            for (uint32_t k = 0; k < runs; ++k)
                for (int b = 0; b < nb; ++b)
                    for (unsigned m = 0; m < N_METHODS; ++m) {
                        if (!method_available(&methods[m], o->methods))
                            continue;
                        char png[1400], what[32];
                        snprintf(what, sizeof(what), "%gs", budgets[b]);
                        png_name(png, sizeof(png), out_dir, bs->name, methods[m].label, what);
                        run_result *rr = &CELL(m, b, k);
                        if (run_one(ctx, scene, &methods[m], budgets[b], 0, 0, size, o->sampler, BENCH_SEED + k, ref,
                                    png, rr) != 0)
                            rr->rmae = NAN;
                        fprintf(stderr, "  run %u/%u %gs %-26s rMAE %.4f, %u spp\n", k + 1, runs, budgets[b],
                                methods[m].label, rr->rmae, rr->spp);
                    }
            /* each cell: the run of median rMAE (the lower one of an even count) */
            for (unsigned m = 0; m < N_METHODS; ++m)
                for (int b = 0; b < nb; ++b)
                    res[m][b] = CELL(m, b, median_run(&CELL(m, b, 0), runs));
            if (runs > 1)
                printf("  every cell: the run of median rMAE of %u (seeds %u..%u; images: the last run)\n", runs,
                       BENCH_SEED, BENCH_SEED + runs - 1);
            printf("  %-26s", "method \\ budget");
            for (int b = 0; b < nb; ++b)
                printf(" %8gs rMAE   spp prep", budgets[b]);
            printf("\n");
            for (unsigned m = 0; m < N_METHODS; ++m) {
                if (!method_available(&methods[m], o->methods))
                    continue;
                printf("  %-26s", methods[m].label);
                for (int b = 0; b < nb; ++b) /* prep: preparation's share of the budget */
                    printf(" %14.4f %5u %3.0f%%", res[m][b].rmae, res[m][b].spp,
                           100.0 * res[m][b].stats.prepare_seconds / budgets[b]);
                printf("\n");
            }
            fflush(stdout);
            if (method_available(&methods[1], o->methods)) {
                printf("  stage times of `vbnl` (paper Table 1):\n");
                for (int b = 0; b < nb; ++b)
                    printf("    %gs budget: %s\n", budgets[b], res[1][b].stages);
                for (int b = 0; b < nb; ++b)
                    if (res[1][b].rmae > 0 && res[0][b].rmae > 0) {
                        printf("  path/vbnl rMAE ratio at %gs: %.2f", budgets[b], res[0][b].rmae / res[1][b].rmae);
                        if (runs > 1) { /* the ratio of each round, to show the spread */
                            printf(" (rounds:");
                            for (uint32_t k = 0; k < runs; ++k)
                                printf(" %.2f", CELL(0, b, k).rmae / CELL(1, b, k).rmae);
                            printf(")");
                        }
                        printf("\n");
                    }
            }
#undef CELL
            free(all);
            char svg[1200];
            snprintf(svg, sizeof(svg), "%s/%s-equal-time.svg", out_dir, bs->name);
            write_svg(svg, bs->name, budgets, nb, res);
            printf("  plot: %s\n", svg);
        }
        if (o->count > 0)
            equal_count(ctx, scene, bs->name, o, ref);
        printf("\n");
        free(ref);
        vbnl_scene_destroy(scene);
    }
    vbnl_context_destroy(ctx);
    return rc;
}
