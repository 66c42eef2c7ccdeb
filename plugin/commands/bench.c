/* `vbnl bench`: the path tracer's throughput next to the raw Embree ray rate of the same scene.
 * The machine is noisy: every figure is the median of --repeat runs. */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "commands.h"
#include "module.h"

/* Scene paths, here and in bench_equal.c, are relative to the working directory: the bench runs
 * from the repository's root. */
#define DEFAULT_SCENE "examples/mcguire/CornellBox-Original.obj"
#define DEFAULT_CAMERA "0,1,3.5,0,1,0,40"

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof(double), cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* A whole number for option `opt` in [min, max], the whole argument (cli_parse_u32): 0, or -1
 * after saying what the option takes. */
static int bench_u32(const char *opt, const char *arg, uint32_t *out, uint32_t min, uint32_t max)
{
    if (cli_parse_u32(arg, out, min, max) == 0)
        return 0;
    fprintf(stderr, "vbnl bench: --%s takes a whole number in %u..%u, got '%s'\n", opt, min, max, arg);
    return -1;
}

/* Seconds for option `opt`, a finite number > 0 up to 1e7, the whole argument: 0, or -1 after
 * saying so. */
static int bench_seconds(const char *opt, const char *arg, double *out)
{
    if (cli_parse_double(arg, out, 0.0, 1e7) == 0 && *out > 0.0)
        return 0;
    fprintf(stderr, "vbnl bench: --%s takes seconds, more than 0 and at most 1e7, got '%s'\n", opt, arg);
    return -1;
}

static void bench_usage(FILE *f)
{
    fprintf(f,
            "usage: vbnl bench [options]\n"
            "\n"
            "Renders a scene with `path` and prints samples/s and rays/s next to the raw Embree\n"
            "incoherent ray rate measured on the same scene by the same program (medians), and\n"
            "next to the raw rate of path's own mixture of camera packets, closest-hit bounce\n"
            "rays and shadow rays (each kind measured on its own: the fair ceiling).\n"
            "\n"
            "  --scene FILE       mesh file (default " DEFAULT_SCENE ")\n"
            "  --camera px,py,pz,tx,ty,tz,fov   (default " DEFAULT_CAMERA ")\n"
            "  --width W --height H   image size (default 256x256)\n"
            "  --spp N            samples per pixel per run (default 16)\n"
            "  --repeat N         runs per figure (default 3; with --equal-time: rounds of every\n"
            "                     method and budget with seeds 7, 8, ..., each cell the run of\n"
            "                     median rMAE, default 1)\n"
            "  --threads N        worker threads (default 0 = one per core)\n"
            "  --sampler NAME     sobol (default) or random: the renders' sampler (also of the\n"
            "                     equal-time methods; references always use the default)\n"
            "\n"
            "  --equal-time       instead: path, vbnl, its ablations and the many-light baselines (vpl,\n"
            "                     vpl acceptance, vsl, richvsl) at equal time on the cornell, glossy and\n"
            "                     door-ajar scenes, rMAE against a cached path reference\n"
            "  --budgets LIST     time budgets in seconds (default 10,30,100; 'none': no equal-time runs)\n"
            "  --equal-count N    also render the virtual-light methods with N lights each (paper Figs. 1,\n"
            "                     12): preparation per stage, shading time, storage, rMAE\n"
            "  --count-spp N      samples per pixel of the equal-count renders (default 16)\n"
            "  --methods LIST     only these methods (labels as printed, comma-separated)\n"
            "  --size N           image side (default 512)\n"
            "  --ref-time S       seconds for each reference (default 1200; cached in --out)\n"
            "  --ref-spp N        instead: references of N samples per pixel (cached by N; unlike\n"
            "                     --ref-time, the same reference whatever else the machine runs)\n"
            "  --out DIR          images, references and plots (default bench-out)\n"
            "  --only NAME        one scene: cornell, glossy or door-ajar\n");
}

int cmd_bench(int argc, char **argv)
{
    static const struct option opts[] = {
        {"scene", required_argument, 0, 's'}, {"camera", required_argument, 0, 'c'},
        {"width", required_argument, 0, 'W'}, {"height", required_argument, 0, 'H'},
        {"spp", required_argument, 0, 'n'},   {"repeat", required_argument, 0, 'r'},
        {"threads", required_argument, 0, 'T'}, {"help", no_argument, 0, 'h'},
        {"equal-time", no_argument, 0, 'E'}, {"budgets", required_argument, 0, 'B'},
        {"size", required_argument, 0, 'Z'}, {"ref-time", required_argument, 0, 'F'},
        {"out", required_argument, 0, 'O'}, {"only", required_argument, 0, 'Y'},
        {"equal-count", required_argument, 0, 'C'},
        {"count-spp", required_argument, 0, 'P'}, {"methods", required_argument, 0, 'M'},
        {"ref-spp", required_argument, 0, 'S'}, {"sampler", required_argument, 0, 'm'}, {0, 0, 0, 0}};
    int equal_time = 0, nb = 0, no_budgets = 0, repeat_set = 0;
    uint32_t count = 0, count_spp = 16, ref_spp = 0;
    const char *methods = NULL;
    double budgets[8];
    uint32_t size = 512;
    double ref_time = 1200.0;
    const char *out_dir = "bench-out", *only = NULL;
    const char *scene_path = DEFAULT_SCENE;
    module_camera cam = {1, {0}, {0}, 0.0f};
    cli_parse_camera(DEFAULT_CAMERA, cam.position, cam.target, &cam.fov_y);
    uint32_t width = 256, height = 256, spp = 16, repeat = 3, threads = 0;
    vbnl_sampler_kind sampler = VBNL_SAMPLER_SOBOL;
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "h", opts, NULL)) != -1) {
        switch (c) {
        case 's': scene_path = optarg; break;
        case 'c':
            if (cli_parse_camera(optarg, cam.position, cam.target, &cam.fov_y)) {
                fprintf(stderr, "vbnl bench: bad --camera '%s'\n", optarg);
                return VBI_EXIT_USAGE;
            }
            break;
        case 'W':
            if (bench_u32("width", optarg, &width, 1, 16384))
                return VBI_EXIT_USAGE;
            break;
        case 'H':
            if (bench_u32("height", optarg, &height, 1, 16384))
                return VBI_EXIT_USAGE;
            break;
        case 'n':
            if (bench_u32("spp", optarg, &spp, 1, 1u << 30))
                return VBI_EXIT_USAGE;
            break;
        case 'r':
            if (bench_u32("repeat", optarg, &repeat, 1, 99))
                return VBI_EXIT_USAGE;
            repeat_set = 1;
            break;
        case 'T':
            if (bench_u32("threads", optarg, &threads, 0, 1024))
                return VBI_EXIT_USAGE;
            break;
        case 'm': {
            vbnl_error e = {0};
            if (vbnl_sampler_find(optarg, &sampler, &e) != VBNL_OK) {
                fprintf(stderr, "vbnl bench: %s\n", e.message);
                return VBI_EXIT_USAGE;
            }
            break;
        }
        case 'h': bench_usage(stdout); return VBI_EXIT_OK;
        case 'E': equal_time = 1; break;
        case 'C':
            if (bench_u32("equal-count", optarg, &count, 0, 50000000))
                return VBI_EXIT_USAGE;
            break;
        case 'P':
            if (bench_u32("count-spp", optarg, &count_spp, 1, 1000000))
                return VBI_EXIT_USAGE;
            break;
        case 'M': methods = optarg; break;
        case 'B': {
            nb = 0;
            if (!strcmp(optarg, "none")) {
                no_budgets = 1;
                break;
            }
            no_budgets = 0;
            /* every item a number of seconds, at most 8, increasing; no empty item */
            const char *q = optarg;
            int bad = !*q;
            while (!bad && *q) {
                char item[64];
                size_t len = strcspn(q, ",");
                bad = nb == 8 || len == 0 || len >= sizeof(item);
                if (!bad) {
                    memcpy(item, q, len);
                    item[len] = '\0';
                    bad = cli_parse_double(item, &budgets[nb], 0.0, 1e7) != 0 || !(budgets[nb] > 0.0) ||
                          (nb && budgets[nb] <= budgets[nb - 1]);
                    ++nb;
                }
                q += len;
                if (!bad && *q == ',')
                    bad = !*++q; /* a trailing comma */
            }
            if (bad) {
                fprintf(stderr, "vbnl bench: --budgets takes up to 8 increasing seconds, e.g. 10,30,100, got '%s'\n",
                        optarg);
                return VBI_EXIT_USAGE;
            }
            break;
        }
        case 'Z':
            if (bench_u32("size", optarg, &size, 1, 8192))
                return VBI_EXIT_USAGE;
            break;
        case 'F':
            if (bench_seconds("ref-time", optarg, &ref_time))
                return VBI_EXIT_USAGE;
            break;
        case 'S':
            if (bench_u32("ref-spp", optarg, &ref_spp, 1, 16777216))
                return VBI_EXIT_USAGE;
            break;
        case 'O': out_dir = optarg; break;
        case 'Y': only = optarg; break;
        default: bench_usage(stderr); return VBI_EXIT_USAGE;
        }
    }
    if (equal_time) {
        if (nb == 0 && !no_budgets) {
            budgets[0] = 10;
            budgets[1] = 30;
            budgets[2] = 100;
            nb = 3;
        }
        cmd_bench_equal_opts o = {out_dir, size, budgets, nb, ref_time, ref_spp, only, methods,
                                  count, count_spp, sampler, repeat_set ? repeat : 1u};
        return cmd_bench_equal_time(&o);
    }
    vbnl_error err = {0};
    vbnl_context *ctx = NULL;
    vbnl_scene *scene = NULL;
    vbnl_context_desc cd;
    vbnl_context_desc_init(&cd);
    cd.threads = threads;
    int rc = VBI_EXIT_FAILURE;
    if (vbnl_context_create(&cd, &ctx, &err) != VBNL_OK ||
        module_load_scene(ctx, scene_path, &cam, (float)width / (float)height, &scene, &err) != VBNL_OK) {
        fprintf(stderr, "vbnl bench: %s\n", err.message);
        goto done;
    }
    vbnl_scene_info info;
    vbnl_scene_get_info(scene, &info, NULL);
    printf("scene       %s (%llu triangles, %u lights)\n", scene_path, (unsigned long long)info.triangle_count,
           info.light_count);
    printf("image       %ux%u, %u spp per run, %u runs, %u threads, sampler %s\n\n", width, height, spp, repeat,
           vbnl_context_thread_count(ctx), vbnl_sampler_name(sampler));
    double raw[99], raw_pkt[99], sps[99], rps[99], raw_cam[99], raw_shadow[99], raw_mix[99], mix_frac[3][99];
    for (unsigned i = 0; i < repeat; ++i) {
        vbnl_ray_rates rr;
        if (vbnl_scene_measure_ray_rates(ctx, scene, 1u << 20, width, height, &rr, &err) != VBNL_OK) {
            fprintf(stderr, "vbnl bench: %s\n", err.message);
            goto done;
        }
        vbnl_render_settings s;
        vbnl_render_settings_init(&s);
        s.width = width;
        s.height = height;
        s.spp = spp;
        s.seed = i + 1;
        s.sampler = sampler;
        vbnl_renderer *r;
        if (vbnl_renderer_create(ctx, scene, &s, &r, &err) != VBNL_OK ||
            vbnl_renderer_render(r, NULL, NULL, &err) != VBNL_OK) {
            fprintf(stderr, "vbnl bench: %s\n", err.message);
            goto done;
        }
        vbnl_render_stats st;
        vbnl_renderer_get_stats(r, &st, NULL);
        sps[i] = (double)st.samples / st.render_seconds;
        rps[i] = (double)st.rays / st.render_seconds;
        /* path's own mixture of ray kinds, each at its raw rate: the fair ceiling */
        uint64_t closest = st.rays - st.camera_rays - st.shadow_rays;
        raw[i] = rr.closest;
        raw_pkt[i] = rr.closest_packet;
        raw_cam[i] = rr.camera;
        raw_shadow[i] = rr.shadow;
        raw_mix[i] = vbnl_ray_rates_mix(&rr, st.camera_rays, closest, st.shadow_rays);
        mix_frac[0][i] = st.rays ? (double)st.camera_rays / (double)st.rays : 0.0;
        mix_frac[1][i] = st.rays ? (double)closest / (double)st.rays : 0.0;
        mix_frac[2][i] = st.rays ? (double)st.shadow_rays / (double)st.rays : 0.0;
        vbnl_renderer_destroy(r);
    }
    double m_raw = median(raw, (int)repeat), m_sps = median(sps, (int)repeat), m_rps = median(rps, (int)repeat);
    double m_mix = median(raw_mix, (int)repeat);
    printf("%-34s %14s\n", "figure (median)", "value");
    printf("%-34s %11.2f M/s\n", "raw Embree incoherent rays", m_raw / 1e6);
    printf("%-34s %11.2f M/s\n", "raw Embree incoherent, 8-packets", median(raw_pkt, (int)repeat) / 1e6);
    printf("%-34s %11.2f M/s\n", "raw Embree camera packets", median(raw_cam, (int)repeat) / 1e6);
    printf("%-34s %11.2f M/s\n", "raw Embree shadow rays", median(raw_shadow, (int)repeat) / 1e6);
    printf("%-34s %11.2f M/s\n", "raw Embree at path's ray mixture", m_mix / 1e6);
    printf("%-34s %4.0f/%.0f/%.0f %%\n", "path: camera/bounce/shadow rays", 100.0 * median(mix_frac[0], (int)repeat),
           100.0 * median(mix_frac[1], (int)repeat), 100.0 * median(mix_frac[2], (int)repeat));
    printf("%-34s %11.2f M/s\n", "path: rays (camera + bounce + shadow)", m_rps / 1e6);
    printf("%-34s %11.3f M/s\n", "path: samples", m_sps / 1e6);
    printf("%-34s %13.0f%%\n", "path rays / raw Embree rays", 100.0 * m_rps / m_raw);
    printf("%-34s %13.0f%%\n", "path rays / raw at path's mixture", m_mix > 0.0 ? 100.0 * m_rps / m_mix : 0.0);
    rc = VBI_EXIT_OK;
done:
    vbnl_scene_destroy(scene);
    vbnl_context_destroy(ctx);
    return rc;
}
