/* One render from options to written outputs, shared by `vbnl render` (main.c) and POV-Ray's
 * command line (pov_cli.c): the signal handling of a render, the identity of files, the options
 * of `vbnl render` and the sequence of plugin calls (host.h). */
#include <errno.h>
#include <signal.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "cli.h"
#include "host.h"

/* ---- signals --------------------------------------------------------------------------------- */

/* The signal handler's state. Lock-free atomics: the handler may run on any thread, the module's
 * workers included, while the main thread reads the count. g_abandon_writes is the module's
 * abandon_writes (NULL for a 1.0 module), set before the handler is installed. */
_Static_assert(ATOMIC_INT_LOCK_FREE == 2 && ATOMIC_POINTER_LOCK_FREE == 2, "the handler needs lock-free atomics");
static atomic_int g_interrupts;
static void (*_Atomic g_abandon_writes)(void);

/* First signal: the progress callback cancels, the partial image is written. Second: leave at
 * once, writing nothing; the module removes the temporary file of a write under way (only
 * async-signal-safe calls here). */
static void on_signal(int sig)
{
    (void)sig;
    if (atomic_fetch_add(&g_interrupts, 1) + 1 >= 2) {
        void (*abandon)(void) = atomic_load(&g_abandon_writes);
        if (abandon)
            abandon();
        _exit(VBI_EXIT_INTERRUPTED);
    }
}

void host_signals_install(const vbnl_plugin_api *api)
{
    atomic_store(&g_abandon_writes, VBNL_PLUGIN_HAS(api, abandon_writes) ? api->abandon_writes : NULL);
    struct sigaction sa;
    memset(&sa, 0, sizeof(sa));
    sa.sa_handler = on_signal;
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL); /* a host's stop button (Blender sends SIGTERM) */
    sigaction(SIGHUP, &sa, NULL);  /* the terminal closed */
}

int host_interrupted(void) { return atomic_load(&g_interrupts); }

void host_test_pause(void)
{
    const char *pause = getenv("VBNL_TEST_PAUSE");
    if (!pause || strcmp(pause, "interrupt"))
        return;
    fprintf(stderr, "vbnl: test pause (interrupt): the render has not been stopped yet\n");
    struct timespec left = {30, 0};
    while (nanosleep(&left, &left) != 0 && errno == EINTR) {
    }
}

/* ---- outputs that never replace an input or each other ----------------------------------------- */

void host_say(const host_render_job *job, const char *fmt, ...)
{
    char line[HOST_MSG_SIZE + 512];
    int n = snprintf(line, sizeof(line), "%s: ", job->who);
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(line + n, sizeof(line) - (size_t)n, fmt, ap);
    va_end(ap);
    if (job->say)
        job->say(job->say_user, 1, line);
    else
        fprintf(stderr, "%s\n", line);
}

/* 0 when no output (name[i], path[i], NULL paths skipped) names the scene, one of the ':'-separated
 * --load-lights files, or another output; else says why and returns -1. */
static int outputs_distinct(const host_render_job *job, const char *const name[3], const char *const path[3])
{
    for (int i = 0; i < 3; ++i) {
        if (!path[i])
            continue;
        if (cli_same_file(path[i], job->scene)) {
            host_say(job, "%s '%s' is the scene file; an output never replaces an input", name[i], path[i]);
            return -1;
        }
        if (job->load_lights) {
            char list[PATH_MAX * 2];
            snprintf(list, sizeof(list), "%s", job->load_lights);
            for (char *save = NULL, *f = strtok_r(list, ":", &save); f; f = strtok_r(NULL, ":", &save))
                if (cli_same_file(path[i], f)) {
                    host_say(job, "%s '%s' is the --load-lights file '%s'; an output never replaces an input",
                             name[i], path[i], f);
                    return -1;
                }
        }
        for (int j = 0; j < i; ++j)
            if (path[j] && cli_same_file(path[i], path[j])) {
                host_say(job, "%s '%s' and %s '%s' name the same file; give each output its own", name[j], path[j],
                         name[i], path[i]);
                return -1;
            }
    }
    return 0;
}

/* ---- the options of `vbnl render` -------------------------------------------------------------- */

const struct option host_render_options[] = {
    {"output", required_argument, 0, 'o'},       {"png", required_argument, 0, 'p'},
    {"integrator", required_argument, 0, 'i'},   {"set", required_argument, 0, 's'},
    {"spp", required_argument, 0, 'n'},          {"time", required_argument, 0, 't'},
    {"width", required_argument, 0, 'W'},        {"height", required_argument, 0, 'H'},
    {"seed", required_argument, 0, 'S'},         {"threads", required_argument, 0, 'T'},
    {"sampler", required_argument, 0, 'm'},      {"camera", required_argument, 0, 'c'},
    {"exposure", required_argument, 0, 'e'},     {"half", no_argument, 0, 'f'},
    {"quiet", no_argument, 0, 'q'},              {"save-lights", required_argument, 0, 'L'},
    {"load-lights", required_argument, 0, 'l'},  {"display", required_argument, 0, 'd'},
    {"view", required_argument, 0, 'v'},         {"ocio", required_argument, 0, 'O'},
    {"png-bits", required_argument, 0, 'b'},     {"png-alpha", no_argument, 0, 'a'},
    {"crop", required_argument, 0, 'C'},         {"declare", required_argument, 0, 'D'},
    {"include-dir", required_argument, 0, 'I'},  {"read-dir", required_argument, 0, 'R'},
    {"write-dir", required_argument, 0, 'X'},    {"builtin", required_argument, 0, 'B'},
    {0, 0, 0, 0}};

const char host_render_options_help[] =
    "  -o, --output PATH        EXR output (scene-linear Rec.709, every layer, settings in the header)\n"
    "      --png PATH           PNG of the beauty image through the colour view (display-referred)\n"
    "      --png-bits 8|16      PNG bit depth (default 8)\n"
    "      --png-alpha          RGBA PNG with the image's alpha (default RGB)\n"
    "      --integrator NAME    integrator (default: the scene's, else path); see `vbnl info`\n"
    "      --set KEY=VALUE      integrator parameter (repeatable)\n"
    "      --save-lights PATH   vbnl: save the prepared virtual lights and photons (--set save_lights=PATH)\n"
    "      --load-lights PATH   vbnl: load them instead of preparing; A:B:... sums the photon ranges of\n"
    "                           several files (--set load_lights=PATH; see photon_first, photon_count)\n"
    "      --spp N              samples per pixel (default 16)\n"
    "      --time SECONDS       time budget for preparation plus rendering, instead of --spp\n"
    "      --width W, --height H  image size (default 512x512)\n"
    "      --crop X0,Y0,X1,Y1   render only this window (pixels, X1 and Y1 exclusive)\n"
    "      --seed S             random seed (default 1); same seed, same image, any thread count\n"
    "      --sampler NAME       sobol (default: stratified low-discrepancy points for each sample's\n"
    "                           first draws) or random (independent numbers)\n"
    "      --threads N          worker threads (default 0 = one per core)\n"
    "      --camera px,py,pz,tx,ty,tz,fov   mesh files: camera position, target, vertical fov (degrees)\n"
    "      --display NAME       OpenColorIO display (default sRGB)\n"
    "      --view NAME          OpenColorIO view (default Standard; also 'ACES 1.0 SDR-video', Raw)\n"
    "      --ocio CONFIG        OpenColorIO config file (default $OCIO, else the embedded config)\n"
    "      --exposure STOPS     exposure applied before the view (PNG only)\n"
    "      --half               write half-float EXR channels\n"
    "      --declare NAME=VALUE .pov scenes: declare a float, or a string in double quotes (repeatable)\n"
    "      --include-dir DIR    .pov scenes: search DIR for #include after the scene's folder (repeatable)\n"
    "      --read-dir DIR       .pov scenes: the scene may also read files in DIR and below (repeatable)\n"
    "      --write-dir DIR      .pov scenes: the scene may also read and write files in DIR and below\n"
    "      --builtin NAME=VALUE .pov scenes: one of POV-Ray's animation identifiers (clock, clock_delta,\n"
    "                           clock_on, frame_number, initial_clock, final_clock, initial_frame,\n"
    "                           final_frame) as POV-Ray's front end sets it for a frame (vbnl farm)\n"
    "  -q, --quiet              no progress output\n";

void host_render_job_init(host_render_job *job, const vbnl_plugin_api *api, const char *who)
{
    memset(job, 0, sizeof(*job));
    job->who = who;
    api->options_init(&job->opt);
    const char *pause = getenv("VBNL_TEST_PAUSE");
    if (pause && !strcmp(pause, "write"))
        job->opt.test_hooks |= VBNL_PLUGIN_TEST_PAUSE_WRITES;
    api->view_init(&job->view);
}

int host_render_scene_option(host_render_job *job, const char *key, const char *value)
{
    if (job->nscene == HOST_MAX_SCENE_OPTIONS) {
        host_say(job, "more than %d scene settings", HOST_MAX_SCENE_OPTIONS);
        return VBI_EXIT_USAGE;
    }
    job->scene_keys[job->nscene] = key;
    job->scene_values[job->nscene++] = value;
    return 0;
}

int host_render_option(host_render_job *job, int c, const char *arg)
{
    vbnl_plugin_options *o = &job->opt;
    vbnl_plugin_view *view = &job->view;
    switch (c) {
    case 'o': job->exr = arg; break;
    case 'p': job->png = arg; break;
    case 'i': o->integrator = arg; break;
    case 'm': o->sampler = arg; break;
    case 's':
    case 'L':
    case 'l':
        if (job->nsets == HOST_MAX_SETS) {
            host_say(job, "more than %d parameters", HOST_MAX_SETS);
            return VBI_EXIT_USAGE;
        }
        if (c == 's') {
            job->sets[job->nsets] = arg;
            job->set_where[job->nsets++] = "--set";
            break;
        }
        if (!*arg) {
            host_say(job, "--%s takes a file path", c == 'L' ? "save-lights" : "load-lights");
            return VBI_EXIT_USAGE;
        }
        snprintf(job->lights_buf[c == 'L'], sizeof(job->lights_buf[0]), "%s=%s",
                 c == 'L' ? "save_lights" : "load_lights", arg);
        if (c == 'L')
            job->save_lights = arg;
        else
            job->load_lights = arg;
        job->sets[job->nsets] = job->lights_buf[c == 'L'];
        job->set_where[job->nsets++] = c == 'L' ? "--save-lights" : "--load-lights";
        break;
    case 'n':
        if (cli_parse_u32(arg, &o->spp, 1, 1u << 30)) {
            host_say(job, "--spp takes a whole number >= 1, got '%s'", arg);
            return VBI_EXIT_USAGE;
        }
        job->spp_given = 1;
        break;
    case 't': {
        char *end;
        o->time_budget = strtod(arg, &end);
        if (*end || !(o->time_budget > 0.0) || o->time_budget > 1e7) {
            host_say(job, "--time takes seconds > 0, got '%s'", arg);
            return VBI_EXIT_USAGE;
        }
        job->time_given = 1;
        break;
    }
    case 'W':
    case 'H':
        if (cli_parse_u32(arg, c == 'W' ? &o->width : &o->height, 1, 65536)) {
            host_say(job, "--%s takes 1..65536, got '%s'", c == 'W' ? "width" : "height", arg);
            return VBI_EXIT_USAGE;
        }
        break;
    case 'S': {
        char *end;
        errno = 0;
        o->seed = strtoull(arg, &end, 10);
        if (errno || *end || end == arg || arg[0] == '-') {
            host_say(job, "--seed takes a whole number >= 0, got '%s'", arg);
            return VBI_EXIT_USAGE;
        }
        break;
    }
    case 'T':
        if (cli_parse_u32(arg, &o->threads, 0, 1024)) {
            host_say(job, "--threads takes 0..1024, got '%s'", arg);
            return VBI_EXIT_USAGE;
        }
        break;
    case 'c':
        if (cli_parse_camera(arg, o->camera_position, o->camera_target, &o->camera_fov_y)) {
            host_say(job, "--camera takes px,py,pz,tx,ty,tz,fov_degrees, got '%s'", arg);
            return VBI_EXIT_USAGE;
        }
        o->camera_given = 1;
        break;
    case 'C': {
        unsigned v[4];
        char extra;
        if (sscanf(arg, "%u,%u,%u,%u%c", &v[0], &v[1], &v[2], &v[3], &extra) != 4 || strchr(arg, '-') ||
            v[0] >= v[2] || v[1] >= v[3]) {
            host_say(job, "--crop takes X0,Y0,X1,Y1 with X0 < X1 and Y0 < Y1, got '%s'", arg);
            return VBI_EXIT_USAGE;
        }
        memcpy(o->crop, v, sizeof(o->crop));
        break;
    }
    case 'e': {
        char *end;
        view->exposure = strtof(arg, &end);
        if (*end || end == arg || !(view->exposure > -64.0f && view->exposure < 64.0f)) {
            host_say(job, "--exposure takes stops in (-64, 64), got '%s'", arg);
            return VBI_EXIT_USAGE;
        }
        break;
    }
    case 'd': view->display = arg; break;
    case 'v': view->view = arg; break;
    case 'O': view->config = arg; break;
    case 'b':
        if (cli_parse_u32(arg, &view->png_bits, 8, 16) || (view->png_bits != 8 && view->png_bits != 16)) {
            host_say(job, "--png-bits takes 8 or 16, got '%s'", arg);
            return VBI_EXIT_USAGE;
        }
        break;
    case 'a': view->alpha = 1; break;
    case 'f': job->half = 1; break;
    case 'q': job->quiet = 1; break;
    case 'D': return host_render_scene_option(job, "declare", arg);
    case 'I': return host_render_scene_option(job, "include_dir", arg);
    case 'R': return host_render_scene_option(job, "read_dir", arg);
    case 'X': return host_render_scene_option(job, "write_dir", arg);
    case 'B': {
        /* the key is one of the plugin's set_scene_option names: kept as that constant string */
        static const char *const builtins[] = {"clock",         "clock_delta", "clock_on",      "frame_number",
                                               "initial_clock", "final_clock", "initial_frame", "final_frame"};
        const char *eq = strchr(arg, '=');
        for (size_t k = 0; eq && k < sizeof(builtins) / sizeof(builtins[0]); ++k)
            if (strlen(builtins[k]) == (size_t)(eq - arg) && !strncmp(arg, builtins[k], (size_t)(eq - arg)))
                return host_render_scene_option(job, builtins[k], eq + 1);
        host_say(job, "--builtin takes NAME=VALUE with NAME one of clock, clock_delta, clock_on, frame_number, "
                      "initial_clock, final_clock, initial_frame, final_frame; got '%s'", arg);
        return VBI_EXIT_USAGE;
    }
    default: return VBI_EXIT_USAGE;
    }
    return 0;
}

/* ---- the render -------------------------------------------------------------------------------- */

int host_render_run(const vbnl_plugin_api *api, host_render_job *job, vbnl_plugin_stats *stats)
{
    vbnl_plugin_options *o = &job->opt;
    char msg[HOST_MSG_SIZE];
    if (job->time_given && !job->spp_given)
        o->spp = 0;
    if (o->crop[2] > o->width || o->crop[3] > o->height) {
        host_say(job, "--crop window reaches outside the %ux%u image", o->width, o->height);
        return VBI_EXIT_USAGE;
    }
    /* Refuse what cannot work before any heavy work: unwritable outputs first (within the first
     * second), then options, parameters, the scene, the colour view. */
    const char *outs[3] = {job->exr, job->png, job->save_lights};
    const char *const out_names[3] = {"-o", "--png", "--save-lights"};
    if (outputs_distinct(job, out_names, outs) != 0)
        return VBI_EXIT_USAGE;
    for (int i = 0; i < 3; ++i)
        if (outs[i] && api->check_writable(outs[i], msg, sizeof(msg)) != VBNL_PLUGIN_OK) {
            host_say(job, "%s", msg);
            return VBI_EXIT_FAILURE;
        }
    if (job->nscene && !VBNL_PLUGIN_HAS(api, set_scene_option)) {
        host_say(job, "the plugin (ABI %u.%u) takes no scene settings (ABI 1.3)", api->abi_major, api->abi_minor);
        return VBI_EXIT_PLUGIN;
    }
    if (job->view.alpha && job->view.size < offsetof(vbnl_plugin_view, alpha) + sizeof(job->view.alpha)) {
        host_say(job, "the plugin (ABI %u.%u) writes no RGBA PNG (ABI 1.3)", api->abi_major, api->abi_minor);
        return VBI_EXIT_PLUGIN;
    }
    vbnl_plugin_renderer *r = NULL;
    vbnl_plugin_result res;
    int rc = VBI_EXIT_USAGE;
    if (api->renderer_create(&r, msg, sizeof(msg)) != VBNL_PLUGIN_OK) {
        host_say(job, "%s", msg);
        return VBI_EXIT_FAILURE;
    }
    if (api->set_options(r, o, msg, sizeof(msg)) != VBNL_PLUGIN_OK) {
        host_say(job, "%s", msg);
        goto cleanup;
    }
    api->set_message_callback(r, job->message, job->message_user, msg, sizeof(msg));
    for (int i = 0; i < job->nsets; ++i)
        if (api->set_param(r, job->sets[i], job->set_where[i], msg, sizeof(msg)) != VBNL_PLUGIN_OK) {
            host_say(job, "%s: %s", job->set_where[i], msg);
            goto cleanup;
        }
    for (int i = 0; i < job->nscene; ++i)
        if (api->set_scene_option(r, job->scene_keys[i], job->scene_values[i], msg, sizeof(msg)) != VBNL_PLUGIN_OK) {
            host_say(job, "%s", msg);
            goto cleanup;
        }
    if (api->load_scene_file(r, job->scene, msg, sizeof(msg)) != VBNL_PLUGIN_OK) {
        host_say(job, "%s", msg);
        rc = VBI_EXIT_SCENE;
        goto cleanup;
    }
    if ((res = api->configure(r, msg, sizeof(msg))) != VBNL_PLUGIN_OK) {
        host_say(job, "%s", msg);
        rc = res == VBNL_PLUGIN_ERR_UNKNOWN_NAME || res == VBNL_PLUGIN_ERR_INVALID_ARGUMENT ? VBI_EXIT_USAGE
                                                                                             : VBI_EXIT_FAILURE;
        goto cleanup;
    }
    if (job->png) {
        /* the display and view are checked on the empty framebuffer, before rendering */
        size_t n = (size_t)o->width * o->height * 4;
        float *probe = malloc(sizeof(float) * n);
        res = probe ? api->apply_view(r, &job->view, probe, n, msg, sizeof(msg)) : VBNL_PLUGIN_ERR_OUT_OF_MEMORY;
        free(probe);
        if (res != VBNL_PLUGIN_OK) {
            host_say(job, "%s", probe ? msg : "out of memory");
            rc = res == VBNL_PLUGIN_ERR_UNKNOWN_NAME ? VBI_EXIT_USAGE : VBI_EXIT_FAILURE;
            goto cleanup;
        }
    }

    rc = VBI_EXIT_FAILURE;
    host_signals_install(api);
    res = api->prepare(r, job->progress, job->progress_user, msg, sizeof(msg));
    if (res == VBNL_PLUGIN_OK)
        res = api->render(r, job->progress, job->progress_user, msg, sizeof(msg));
    if (job->progress_end)
        job->progress_end(job->progress_user);
    int partial = res == VBNL_PLUGIN_ERR_CANCELLED;
    if (res != VBNL_PLUGIN_OK && !partial) {
        host_say(job, "%s", msg);
        goto cleanup;
    }
    if ((job->exr && api->write_exr(r, job->exr, job->half, msg, sizeof(msg)) != VBNL_PLUGIN_OK) ||
        (job->png && api->write_png(r, job->png, &job->view, msg, sizeof(msg)) != VBNL_PLUGIN_OK)) {
        host_say(job, "%s", msg);
        goto cleanup;
    }
    vbnl_plugin_stats st = {.size = sizeof(st)};
    if (api->get_stats(r, &st, msg, sizeof(msg)) == VBNL_PLUGIN_OK) {
        if (stats)
            *stats = st;
        if (!job->quiet) {
            char line[512];
            snprintf(line, sizeof(line), "%s%u spp in %.2f s (prepare %.2f s), %.3g rays/s, %u threads%s",
                     partial ? "interrupted: " : "", st.spp, st.render_seconds, st.prepare_seconds,
                     st.render_seconds > 0 ? (double)st.rays / st.render_seconds : 0.0, st.threads,
                     partial ? " (partial image written)" : "");
            if (job->say)
                job->say(job->say_user, 0, line);
            else
                fprintf(stderr, "%s\n", line);
        }
    }
    rc = partial ? VBI_EXIT_INTERRUPTED : VBI_EXIT_OK;
cleanup:
    api->renderer_destroy(r);
    return rc;
}
