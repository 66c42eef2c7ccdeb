/* `vbnl`: the command-line host.
 *
 *   vbnl render FILE -o out.exr [--png out.png] [options]
 *   vbnl info
 *   vbnl bench [options]
 *
 * Until the plugin module lands, the host links the core directly. */
#include <errno.h>
#include <getopt.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "host.h"

static volatile sig_atomic_t g_interrupts; /* the signal handler's only state */

static void on_sigint(int sig)
{
    (void)sig;
    if (++g_interrupts >= 2)
        _exit(VBNL_EXIT_INTERRUPTED); /* second Ctrl-C: leave at once, write nothing */
}

typedef struct progress_state {
    int quiet, tty;
    double last_plain;
    const char *last_stage;
} progress_state;

static void format_eta(double s, char *buf, size_t n)
{
    if (s < 0.0)
        snprintf(buf, n, "--");
    else if (s < 60.0)
        snprintf(buf, n, "%.0fs", s);
    else
        snprintf(buf, n, "%.0fm%02.0fs", s / 60.0, s - 60.0 * (int)(s / 60.0));
}

static int on_progress(void *user, const vbnl_progress *p)
{
    progress_state *ps = user;
    if (!ps->quiet) {
        char eta[32];
        format_eta(p->eta, eta, sizeof(eta));
        double pct = p->total > 0.0 ? 100.0 * p->done / p->total : 0.0;
        if (ps->tty) {
            if (ps->last_stage && strcmp(ps->last_stage, p->stage) != 0)
                fputc('\n', stderr);
            fprintf(stderr, "\r%-10s %5.1f%%  %.4g %s  %.3g/s  ETA %s   ", p->stage, pct, p->done,
                    p->unit, p->rate, eta);
            fflush(stderr);
        } else if (p->elapsed - ps->last_plain >= 5.0 || !ps->last_stage ||
                   strcmp(ps->last_stage, p->stage) != 0) {
            fprintf(stderr, "%s: %.1f%% (%.4g %s, %.3g/s, ETA %s)\n", p->stage, pct, p->done, p->unit,
                    p->rate, eta);
            ps->last_plain = p->elapsed;
        }
        ps->last_stage = p->stage;
    }
    return g_interrupts > 0;
}

static void usage(FILE *f)
{
    fprintf(f,
            "usage: vbnl <command> [options]\n"
            "\n"
            "commands:\n"
            "  render FILE -o OUT.exr   render a scene (for now a mesh file: OBJ/MTL, PLY, glTF)\n"
            "  info                     list the integrators and their parameters\n"
            "  bench                    path tracer speed against the raw Embree ray rate\n"
            "  compare REF.exr CAND.exr ...  error metrics, error maps and a montage\n"
            "\n"
            "`vbnl render --help` and `vbnl bench --help` list their options.\n"
            "exit status: 0 success, 1 render or file error, 2 bad command line, 3 scene error,\n"
            "130 interrupted (Ctrl-C; the partial image is written).\n");
}

static void render_usage(FILE *f)
{
    fprintf(f,
            "usage: vbnl render FILE -o OUT.exr [options]\n"
            "\n"
            "  -o, --output PATH        EXR output (scene-linear, every layer, settings in the header)\n"
            "      --png PATH           sRGB PNG of the beauty image\n"
            "      --integrator NAME    integrator (default: the .pov scene's, else path); see `vbnl info`\n"
            "      --set KEY=VALUE      integrator parameter (repeatable)\n"
            "      --save-lights PATH   vbnl: save the prepared virtual lights and photons (--set save_lights=PATH)\n"
            "      --load-lights PATH   vbnl: load them instead of preparing; A:B:... sums the photon ranges of\n"
            "                           several files (--set load_lights=PATH; see photon_first, photon_count)\n"
            "      --spp N              samples per pixel (default 16)\n"
            "      --time SECONDS       time budget for preparation plus rendering, instead of --spp\n"
            "      --width W, --height H  image size (default 512x512)\n"
            "      --seed S             random seed (default 1); same seed, same image, any thread count\n"
            "      --threads N          worker threads (default 0 = one per core)\n"
            "      --camera px,py,pz,tx,ty,tz,fov   camera position, target and vertical fov in degrees\n"
            "      --exposure STOPS     exposure applied to the PNG only\n"
            "      --half               write half-float EXR channels\n"
            "  -q, --quiet              no progress output\n"
            "  -h, --help               this help\n");
}

static int parse_u32(const char *s, uint32_t *out, uint32_t min, uint32_t max)
{
    char *end;
    errno = 0;
    unsigned long long v = strtoull(s, &end, 10);
    if (errno || *end || end == s || v < min || v > max || s[0] == '-')
        return -1;
    *out = (uint32_t)v;
    return 0;
}

static int cmd_render(int argc, char **argv)
{
    static const struct option opts[] = {
        {"output", required_argument, 0, 'o'}, {"png", required_argument, 0, 'p'},
        {"integrator", required_argument, 0, 'i'}, {"set", required_argument, 0, 's'},
        {"spp", required_argument, 0, 'n'}, {"time", required_argument, 0, 't'},
        {"width", required_argument, 0, 'W'}, {"height", required_argument, 0, 'H'},
        {"seed", required_argument, 0, 'S'}, {"threads", required_argument, 0, 'T'},
        {"camera", required_argument, 0, 'c'}, {"exposure", required_argument, 0, 'e'},
        {"half", no_argument, 0, 'f'}, {"quiet", no_argument, 0, 'q'},
        {"save-lights", required_argument, 0, 'L'}, {"load-lights", required_argument, 0, 'l'},
        {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
    const char *exr = NULL, *png = NULL, *save_lights = NULL;
    vbnl_render_settings s;
    vbnl_render_settings_init(&s);
    vbnl_params *params = NULL;
    vbnl_params_create(&params, NULL);
    host_camera cam = {0};
    float exposure = 0.0f;
    int half = 0, quiet = 0, spp_given = 0, time_given = 0;
    unsigned threads = 0;
    int c, rc = VBNL_EXIT_USAGE;
    vbnl_error err = {0};
    optind = 1;
    while ((c = getopt_long(argc, argv, "o:qh", opts, NULL)) != -1) {
        switch (c) {
        case 'o': exr = optarg; break;
        case 'p': png = optarg; break;
        case 'i': s.integrator = optarg; break;
        case 's':
            if (vbnl_params_set_text(params, optarg, "--set", &err) != VBNL_OK) {
                fprintf(stderr, "vbnl render: --set: %s\n", err.message);
                goto out;
            }
            break;
        case 'L':
        case 'l':
            if (!*optarg) {
                fprintf(stderr, "vbnl render: --%s takes a file path\n", c == 'L' ? "save-lights" : "load-lights");
                goto out;
            }
            if (c == 'L')
                save_lights = optarg;
            if (vbnl_params_set_string(params, c == 'L' ? "save_lights" : "load_lights", optarg,
                                       c == 'L' ? "--save-lights" : "--load-lights", &err) != VBNL_OK) {
                fprintf(stderr, "vbnl render: %s\n", err.message);
                goto out;
            }
            break;
        case 'n':
            if (parse_u32(optarg, &s.spp, 1, 1u << 30)) {
                fprintf(stderr, "vbnl render: --spp takes a whole number >= 1, got '%s'\n", optarg);
                goto out;
            }
            spp_given = 1;
            break;
        case 't': {
            char *end;
            s.time_budget = strtod(optarg, &end);
            if (*end || !(s.time_budget > 0.0) || s.time_budget > 1e7) {
                fprintf(stderr, "vbnl render: --time takes seconds > 0, got '%s'\n", optarg);
                goto out;
            }
            time_given = 1;
            break;
        }
        case 'W':
            if (parse_u32(optarg, &s.width, 1, 65536)) {
                fprintf(stderr, "vbnl render: --width takes 1..65536, got '%s'\n", optarg);
                goto out;
            }
            break;
        case 'H':
            if (parse_u32(optarg, &s.height, 1, 65536)) {
                fprintf(stderr, "vbnl render: --height takes 1..65536, got '%s'\n", optarg);
                goto out;
            }
            break;
        case 'S': {
            char *end;
            errno = 0;
            s.seed = strtoull(optarg, &end, 10);
            if (errno || *end || optarg[0] == '-') {
                fprintf(stderr, "vbnl render: --seed takes a whole number >= 0, got '%s'\n", optarg);
                goto out;
            }
            break;
        }
        case 'T': {
            uint32_t t;
            if (parse_u32(optarg, &t, 0, 1024)) {
                fprintf(stderr, "vbnl render: --threads takes 0..1024, got '%s'\n", optarg);
                goto out;
            }
            threads = t;
            break;
        }
        case 'c':
            if (host_parse_camera(optarg, &cam)) {
                fprintf(stderr, "vbnl render: --camera takes px,py,pz,tx,ty,tz,fov_degrees, got '%s'\n", optarg);
                goto out;
            }
            break;
        case 'e': {
            char *end;
            exposure = strtof(optarg, &end);
            if (*end || !(exposure > -64.0f && exposure < 64.0f)) {
                fprintf(stderr, "vbnl render: --exposure takes stops in (-64, 64), got '%s'\n", optarg);
                goto out;
            }
            break;
        }
        case 'f': half = 1; break;
        case 'q': quiet = 1; break;
        case 'h':
            render_usage(stdout);
            rc = VBNL_EXIT_OK;
            goto out;
        default:
            render_usage(stderr);
            goto out;
        }
    }
    if (optind != argc - 1) {
        fprintf(stderr, "vbnl render: expected exactly one scene FILE\n");
        render_usage(stderr);
        goto out;
    }
    if (!exr && !png) {
        fprintf(stderr, "vbnl render: give an output: -o OUT.exr and/or --png OUT.png\n");
        goto out;
    }
    if (time_given && !spp_given)
        s.spp = 0;
    const char *scene_path = argv[optind];
    s.params = params;
    /* Refuse what cannot work before any heavy work: unwritable outputs, bad integrator names
     * and parameters (vbnl_renderer_create validates those before the scene is built). */
    if ((exr && host_check_writable(exr, &err) != VBNL_OK) || (png && host_check_writable(png, &err) != VBNL_OK) ||
        (save_lights && host_check_writable(save_lights, &err) != VBNL_OK)) {
        fprintf(stderr, "vbnl render: %s\n", err.message);
        rc = VBNL_EXIT_FAILURE;
        goto out;
    }
    /* A .pov scene names its integrator and parameters; --integrator and --set override them,
     * so without --integrator validation waits for the scene. */
    int pov = host_is_pov(scene_path);
    const char *iname = s.integrator ? s.integrator : "path";
    const vbnl_integrator_class *cls = vbnl_integrator_find(iname);
    if (!(pov && !s.integrator)) {
        if (!cls) {
            fprintf(stderr, "vbnl render: unknown integrator '%s' (see `vbnl info`)\n", iname);
            goto out;
        }
        if (vbnl_params_validate(params, cls->params, cls->param_count, iname, &err) != VBNL_OK) {
            fprintf(stderr, "vbnl render: %s\n", err.message);
            goto out;
        }
    }

    vbnl_context *ctx = NULL;
    vbnl_scene *scene = NULL;
    vbnl_renderer *r = NULL;
    vbnl_context_desc cd = {threads};
    rc = VBNL_EXIT_FAILURE;
    if (vbnl_context_create(&cd, &ctx, &err) != VBNL_OK) {
        fprintf(stderr, "vbnl render: %s\n", err.message);
        goto out;
    }
    char scene_integrator[64] = "";
    vbnl_params *scene_params = NULL;
    if ((pov ? host_load_pov(ctx, scene_path, s.width, s.height, &scene, scene_integrator,
                             sizeof scene_integrator, &scene_params, &err)
             : host_load_scene(ctx, scene_path, &cam, (float)s.width / (float)s.height, &scene, &err)) != VBNL_OK) {
        fprintf(stderr, "vbnl render: %s\n", err.message);
        rc = VBNL_EXIT_SCENE;
        goto cleanup;
    }
    if (pov) {
        /* The scene's settings first, then the command line's (later settings win). */
        if (!s.integrator || strcmp(s.integrator, scene_integrator) == 0) {
            s.integrator = s.integrator ? s.integrator : scene_integrator;
            if (vbnl_params_append(scene_params, params, &err) != VBNL_OK) {
                fprintf(stderr, "vbnl render: %s\n", err.message);
                vbnl_params_destroy(scene_params);
                goto cleanup;
            }
            vbnl_params_destroy(params);
            params = scene_params;
            s.params = params;
        } else {
            if (vbnl_params_count(scene_params))
                fprintf(stderr, "vbnl render: note: --integrator %s replaces the scene's '%s' and its parameters\n",
                        s.integrator, scene_integrator);
            vbnl_params_destroy(scene_params);
        }
        iname = s.integrator;
        cls = vbnl_integrator_find(iname);
        if (!cls || vbnl_params_validate(params, cls->params, cls->param_count, iname, &err) != VBNL_OK) {
            fprintf(stderr, "vbnl render: %s\n", cls ? err.message : "unknown integrator");
            goto cleanup;
        }
    }
    if (vbnl_renderer_create(ctx, scene, &s, &r, &err) != VBNL_OK) {
        fprintf(stderr, "vbnl render: %s\n", err.message);
        goto cleanup;
    }
    struct sigaction sa;
    memset(&sa, 0, sizeof(sa));
    sa.sa_handler = on_sigint;
    sigaction(SIGINT, &sa, NULL);
    progress_state ps = {quiet, isatty(STDERR_FILENO), -1e9, NULL};
    vbnl_result res = vbnl_renderer_prepare(r, on_progress, &ps, &err);
    if (res == VBNL_OK)
        res = vbnl_renderer_render(r, on_progress, &ps, &err);
    if (!quiet && ps.tty)
        fputc('\n', stderr);
    int partial = res == VBNL_ERR_CANCELLED;
    if (res != VBNL_OK && !partial) {
        fprintf(stderr, "vbnl render: %s\n", err.message);
        goto cleanup;
    }
    vbnl_render_stats st;
    vbnl_renderer_get_stats(r, &st, NULL);
    if (host_write_outputs(r, &s, exr, png, exposure, half, partial, &err) != VBNL_OK) {
        fprintf(stderr, "vbnl render: %s\n", err.message);
        goto cleanup;
    }
    if (!quiet)
        fprintf(stderr, "%s%u spp in %.2f s (prepare %.2f s), %.3g rays/s, %u threads%s\n",
                partial ? "interrupted: " : "", st.spp, st.render_seconds, st.prepare_seconds,
                st.render_seconds > 0 ? (double)st.rays / st.render_seconds : 0.0,
                vbnl_context_thread_count(ctx), partial ? " (partial image written)" : "");
    rc = partial ? VBNL_EXIT_INTERRUPTED : VBNL_EXIT_OK;
cleanup:
    vbnl_renderer_destroy(r);
    vbnl_scene_destroy(scene);
    vbnl_context_destroy(ctx);
out:
    vbnl_params_destroy(params);
    return rc;
}

static const char *type_text(const vbnl_param_spec *p, char *buf, size_t n)
{
    switch (p->type) {
    case VBNL_PARAM_INT: snprintf(buf, n, "int [%g, %g], default %g", p->min, p->max, p->default_number); break;
    case VBNL_PARAM_FLOAT: snprintf(buf, n, "float [%g, %g], default %g", p->min, p->max, p->default_number); break;
    case VBNL_PARAM_BOOL: snprintf(buf, n, "bool, default %s", p->default_number != 0.0 ? "on" : "off"); break;
    case VBNL_PARAM_ENUM: {
        size_t len = (size_t)snprintf(buf, n, "one of");
        for (const char *const *c = p->choices; c && *c && len < n; ++c)
            len += (size_t)snprintf(buf + len, n - len, " %s", *c);
        if (len < n)
            snprintf(buf + len, n - len, ", default %s", p->default_string);
        break;
    }
    case VBNL_PARAM_STRING: snprintf(buf, n, "string, default '%s'", p->default_string ? p->default_string : ""); break;
    }
    return buf;
}

static int cmd_info(void)
{
    printf("vbnl %s, integrator ABI %u.%u\n\n", VBNL_VERSION_STRING, VBNL_INTEGRATOR_ABI_MAJOR,
           VBNL_INTEGRATOR_ABI_MINOR);
    for (uint32_t i = 0; i < vbnl_integrator_count(); ++i) {
        const vbnl_integrator_class *c = vbnl_integrator_at(i);
        printf("%s: %s\n", c->name, c->summary);
        for (uint32_t k = 0; k < c->param_count; ++k) {
            char t[256];
            printf("  %-16s %s\n  %-16s %s\n", c->params[k].name, type_text(&c->params[k], t, sizeof(t)), "",
                   c->params[k].doc);
        }
        printf("\n");
    }
    return VBNL_EXIT_OK;
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        usage(stderr);
        return VBNL_EXIT_USAGE;
    }
    const char *cmd = argv[1];
    if (!strcmp(cmd, "-h") || !strcmp(cmd, "--help") || !strcmp(cmd, "help")) {
        usage(stdout);
        return VBNL_EXIT_OK;
    }
    if (!strcmp(cmd, "--version")) {
        printf("vbnl %s\n", VBNL_VERSION_STRING);
        return VBNL_EXIT_OK;
    }
    if (!strcmp(cmd, "render"))
        return cmd_render(argc - 1, argv + 1);
    if (!strcmp(cmd, "info"))
        return cmd_info();
    if (!strcmp(cmd, "bench"))
        return host_bench_main(argc - 1, argv + 1);
    if (!strcmp(cmd, "compare"))
        return host_compare_main(argc - 1, argv + 1);
    fprintf(stderr, "vbnl: unknown command '%s'\n", cmd);
    usage(stderr);
    return VBNL_EXIT_USAGE;
}
