/* The render options of the farm's commands: farm_args.h. The names, ranges and messages are
 * those of `vbnl render` (docs/command-line.md). */
#include "farm_args.h"

#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "atomic_file.h"
#include "cli.h"
#include "module.h"

enum {
    OPT_INTEGRATOR, OPT_SET, OPT_WIDTH, OPT_HEIGHT, OPT_SEED, OPT_THREADS, OPT_CAMERA, OPT_DECLARE,
    OPT_INCLUDE_DIR, OPT_READ_DIR, OPT_WRITE_DIR, OPT_BUILTIN, OPT_SPP, OPT_SAMPLER, OPT_HALF, OPT_PNG_BITS,
    OPT_PNG_ALPHA, OPT_DISPLAY, OPT_VIEW, OPT_OCIO, OPT_EXPOSURE, OPT_OUTPUT, OPT_PNG, OPT_CROP, OPT_TIME,
    OPT_SAVE_LIGHTS, OPT_LOAD_LIGHTS, OPT_QUIET
};

const char *const farm_builtins[8] = {"clock",         "clock_delta", "clock_on",      "frame_number",
                                      "initial_clock", "final_clock", "initial_frame", "final_frame"};

typedef struct render_option {
    const char *name, *alias;
    int has_arg, id;
    unsigned cls;
} render_option;

static const render_option render_options[] = {
    {"--integrator", NULL, 1, OPT_INTEGRATOR, FARM_OPT_SCENE},
    {"--set", NULL, 1, OPT_SET, FARM_OPT_SCENE},
    {"--width", NULL, 1, OPT_WIDTH, FARM_OPT_SCENE},
    {"--height", NULL, 1, OPT_HEIGHT, FARM_OPT_SCENE},
    {"--seed", NULL, 1, OPT_SEED, FARM_OPT_SCENE},
    {"--threads", NULL, 1, OPT_THREADS, FARM_OPT_SCENE},
    {"--camera", NULL, 1, OPT_CAMERA, FARM_OPT_SCENE},
    {"--declare", NULL, 1, OPT_DECLARE, FARM_OPT_SCENE},
    {"--include-dir", NULL, 1, OPT_INCLUDE_DIR, FARM_OPT_SCENE},
    {"--read-dir", NULL, 1, OPT_READ_DIR, FARM_OPT_SCENE},
    {"--write-dir", NULL, 1, OPT_WRITE_DIR, FARM_OPT_SCENE},
    {"--builtin", NULL, 1, OPT_BUILTIN, FARM_OPT_SCENE},
    {"--spp", NULL, 1, OPT_SPP, FARM_OPT_RENDER},
    {"--sampler", NULL, 1, OPT_SAMPLER, FARM_OPT_RENDER},
    {"--half", NULL, 0, OPT_HALF, FARM_OPT_VIEW},
    {"--png-bits", NULL, 1, OPT_PNG_BITS, FARM_OPT_VIEW},
    {"--png-alpha", NULL, 0, OPT_PNG_ALPHA, FARM_OPT_VIEW},
    {"--display", NULL, 1, OPT_DISPLAY, FARM_OPT_VIEW},
    {"--view", NULL, 1, OPT_VIEW, FARM_OPT_VIEW},
    {"--ocio", NULL, 1, OPT_OCIO, FARM_OPT_VIEW},
    {"--exposure", NULL, 1, OPT_EXPOSURE, FARM_OPT_VIEW},
    {"--output", "-o", 1, OPT_OUTPUT, FARM_OPT_OUTPUT},
    {"--png", NULL, 1, OPT_PNG, FARM_OPT_OUTPUT},
    {"--crop", NULL, 1, OPT_CROP, FARM_OPT_SINGLE},
    {"--time", NULL, 1, OPT_TIME, FARM_OPT_SINGLE},
    {"--save-lights", NULL, 1, OPT_SAVE_LIGHTS, FARM_OPT_SINGLE},
    {"--load-lights", NULL, 1, OPT_LOAD_LIGHTS, FARM_OPT_SINGLE},
    {"--quiet", "-q", 0, OPT_QUIET, FARM_OPT_QUIET},
};
#define N_RENDER_OPTIONS (sizeof(render_options) / sizeof(render_options[0]))

/* One render option's value into `a`; 0, or VBI_EXIT_USAGE after printing why. */
static int take(farm_args *a, const char *cmd, const render_option *ro, const char *v)
{
    vbnl_plugin_options *o = &a->o;
    char *end;
    switch (ro->id) {
    case OPT_INTEGRATOR: o->integrator = v; return 0;
    case OPT_SAMPLER: o->sampler = v; return 0;
    case OPT_DISPLAY: a->view.display = v; return 0;
    case OPT_VIEW: a->view.view = v; return 0;
    case OPT_OCIO: a->view.config = v; return 0;
    case OPT_OUTPUT: a->exr = v; return 0;
    case OPT_PNG: a->png = v; return 0;
    case OPT_HALF: a->half = 1; return 0;
    case OPT_QUIET: a->quiet = 1; return 0;
    case OPT_SET:
    case OPT_SAVE_LIGHTS:
    case OPT_LOAD_LIGHTS:
        if (a->nsets == FARM_MAX_SETS) {
            fprintf(stderr, "%s: more than %d parameters\n", cmd, FARM_MAX_SETS);
            return VBI_EXIT_USAGE;
        }
        if (ro->id != OPT_SET) {
            const int save = ro->id == OPT_SAVE_LIGHTS;
            if (!*v || strlen(v) > 4096) {
                fprintf(stderr, "%s: %s takes a file path\n", cmd, ro->name);
                return VBI_EXIT_USAGE;
            }
            snprintf(a->owned[save], sizeof(a->owned[save]), "%s=%s", save ? "save_lights" : "load_lights", v);
            v = a->owned[save];
        }
        a->sets[a->nsets] = v;
        a->set_where[a->nsets++] = ro->name;
        return 0;
    case OPT_WIDTH:
    case OPT_HEIGHT:
        if (cli_parse_u32(v, ro->id == OPT_WIDTH ? &o->width : &o->height, 1, 65536)) {
            fprintf(stderr, "%s: %s takes 1..65536, got '%s'\n", cmd, ro->name, v);
            return VBI_EXIT_USAGE;
        }
        return 0;
    case OPT_SEED:
        errno = 0;
        o->seed = strtoull(v, &end, 10);
        if (errno || *end || end == v || v[0] == '-') {
            fprintf(stderr, "%s: --seed takes a whole number >= 0, got '%s'\n", cmd, v);
            return VBI_EXIT_USAGE;
        }
        return 0;
    case OPT_THREADS:
        if (cli_parse_u32(v, &o->threads, 0, 1024)) {
            fprintf(stderr, "%s: --threads takes 0..1024, got '%s'\n", cmd, v);
            return VBI_EXIT_USAGE;
        }
        a->threads_given = 1;
        return 0;
    case OPT_SPP:
        if (cli_parse_u32(v, &o->spp, 1, 1u << 30)) {
            fprintf(stderr, "%s: --spp takes a whole number >= 1, got '%s'\n", cmd, v);
            return VBI_EXIT_USAGE;
        }
        return 0;
    case OPT_CAMERA:
        if (cli_parse_camera(v, o->camera_position, o->camera_target, &o->camera_fov_y)) {
            fprintf(stderr, "%s: --camera takes px,py,pz,tx,ty,tz,fov_degrees, got '%s'\n", cmd, v);
            return VBI_EXIT_USAGE;
        }
        o->camera_given = 1;
        return 0;
    case OPT_DECLARE:
    case OPT_INCLUDE_DIR:
    case OPT_READ_DIR:
    case OPT_WRITE_DIR:
    case OPT_BUILTIN: {
        /* settings of the .pov load (the plugin's set_scene_option), checked when it is made */
        static const char *const keys[] = {"declare", "include_dir", "read_dir", "write_dir"};
        const char *key = ro->id != OPT_BUILTIN ? keys[ro->id - OPT_DECLARE] : NULL;
        if (ro->id == OPT_BUILTIN) {
            const char *eq = strchr(v, '=');
            for (size_t k = 0; eq && k < sizeof(farm_builtins) / sizeof(farm_builtins[0]) && !key; ++k)
                if (strlen(farm_builtins[k]) == (size_t)(eq - v) && !strncmp(v, farm_builtins[k], (size_t)(eq - v)))
                    key = farm_builtins[k];
            if (!key) {
                fprintf(stderr, "%s: --builtin takes NAME=VALUE with NAME one of POV-Ray's animation identifiers, "
                                "got '%s'\n", cmd, v);
                return VBI_EXIT_USAGE;
            }
            if (!strcmp(key, "clock"))
                a->clock_given = 1;
            v = eq + 1;
        }
        if (a->nscene == FARM_MAX_SETS) {
            fprintf(stderr, "%s: more than %d scene settings\n", cmd, FARM_MAX_SETS);
            return VBI_EXIT_USAGE;
        }
        a->scene_key[a->nscene] = key;
        a->scene_value[a->nscene++] = v;
        return 0;
    }
    case OPT_PNG_ALPHA: a->view.alpha = 1; return 0;
    case OPT_EXPOSURE:
        a->view.exposure = strtof(v, &end);
        if (*end || end == v || !(a->view.exposure > -64.0f && a->view.exposure < 64.0f)) {
            fprintf(stderr, "%s: --exposure takes stops in (-64, 64), got '%s'\n", cmd, v);
            return VBI_EXIT_USAGE;
        }
        return 0;
    case OPT_PNG_BITS:
        if (cli_parse_u32(v, &a->view.png_bits, 8, 16) || (a->view.png_bits != 8 && a->view.png_bits != 16)) {
            fprintf(stderr, "%s: --png-bits takes 8 or 16, got '%s'\n", cmd, v);
            return VBI_EXIT_USAGE;
        }
        return 0;
    case OPT_TIME:
        o->time_budget = strtod(v, &end);
        if (*end || !(o->time_budget > 0.0) || o->time_budget > 1e7) {
            fprintf(stderr, "%s: --time takes seconds > 0, got '%s'\n", cmd, v);
            return VBI_EXIT_USAGE;
        }
        return 0;
    case OPT_CROP: {
        unsigned c[4];
        char extra;
        if (sscanf(v, "%u,%u,%u,%u%c", &c[0], &c[1], &c[2], &c[3], &extra) != 4 || strchr(v, '-') || c[0] >= c[2] ||
            c[1] >= c[3]) {
            fprintf(stderr, "%s: --crop takes X0,Y0,X1,Y1 with X0 < X1 and Y0 < Y1, got '%s'\n", cmd, v);
            return VBI_EXIT_USAGE;
        }
        memcpy(o->crop, c, sizeof(o->crop));
        return 0;
    }
    }
    return 0;
}

/* The option `arg` names ("--name" or "--name=value"), with `len` the length of its name part. */
static int matches(const char *arg, size_t len, const char *name)
{
    return name && strlen(name) == len && !strncmp(arg, name, len);
}

int farm_args_parse(farm_args *a, int argc, char **argv, const char *cmd, unsigned accept, const farm_option *own,
                    farm_own_fn on_own, void *user)
{
    memset(a, 0, sizeof(*a));
    module_api()->options_init(&a->o);
    module_api()->view_init(&a->view);
    for (int i = 1; i < argc; ++i) {
        const char *arg = argv[i];
        if (arg[0] != '-' || !arg[1]) {
            if (a->scene) {
                fprintf(stderr, "%s: expected one scene FILE, got '%s' and '%s'\n", cmd, a->scene, arg);
                return VBI_EXIT_USAGE;
            }
            a->scene = arg;
            continue;
        }
        const char *eq = arg[1] == '-' ? strchr(arg, '=') : NULL;
        size_t len = eq ? (size_t)(eq - arg) : strlen(arg);
        const farm_option *fo = NULL;
        for (const farm_option *k = own; k && k->name && !fo; ++k)
            if (matches(arg, len, k->name))
                fo = k;
        const render_option *ro = NULL;
        for (size_t k = 0; !fo && k < N_RENDER_OPTIONS && !ro; ++k)
            if (matches(arg, len, render_options[k].name) || matches(arg, len, render_options[k].alias))
                ro = &render_options[k];
        if (!fo && !ro) {
            fprintf(stderr, "%s: unknown option '%.*s' (`vbnl %s --help` lists them)\n", cmd, (int)len, arg,
                    strchr(cmd, ' ') ? strchr(cmd, ' ') + 1 : cmd);
            return VBI_EXIT_USAGE;
        }
        const int has_arg = fo ? fo->has_arg : ro->has_arg;
        const char *v = NULL;
        if (has_arg) {
            if (eq)
                v = eq + 1;
            else if (i + 1 < argc)
                v = argv[++i];
            else {
                fprintf(stderr, "%s: %.*s takes a value\n", cmd, (int)len, arg);
                return VBI_EXIT_USAGE;
            }
        } else if (eq) {
            fprintf(stderr, "%s: %.*s takes no value\n", cmd, (int)len, arg);
            return VBI_EXIT_USAGE;
        }
        if (fo) {
            int rc = on_own(user, fo->id, v);
            if (rc)
                return rc;
            continue;
        }
        if (!(ro->cls & accept)) {
            fprintf(stderr, "%s: %s is not an option of this command\n", cmd, ro->name);
            return VBI_EXIT_USAGE;
        }
        if (a->count == FARM_MAX_ARGS) {
            fprintf(stderr, "%s: more than %d options\n", cmd, FARM_MAX_ARGS);
            return VBI_EXIT_USAGE;
        }
        if ((ro->cls & FARM_OPT_SINGLE) && !a->single)
            a->single = ro->name;
        int rc = take(a, cmd, ro, v);
        if (rc)
            return rc;
        a->name[a->count] = ro->name;
        a->value[a->count] = v;
        a->cls[a->count++] = ro->cls;
    }
    return 0;
}

static void on_message(void *user, vbnl_plugin_severity severity, const char *text)
{
    (void)user;
    (void)severity;
    size_t n = strlen(text);
    fprintf(stderr, "%s%s", text, n && text[n - 1] == '\n' ? "" : "\n");
}

int farm_args_renderer(const farm_args *a, const char *cmd, const char *const *extra, uint32_t n_extra,
                       const char *where, vbnl_plugin_renderer **out)
{
    const vbnl_plugin_api *api = module_api();
    char msg[2048];
    vbnl_plugin_renderer *r = NULL;
    *out = NULL;
    if (!a->scene) {
        fprintf(stderr, "%s: expected a scene FILE\n", cmd);
        return VBI_EXIT_USAGE;
    }
    if (api->renderer_create(&r, msg, sizeof(msg)) != VBNL_PLUGIN_OK) {
        fprintf(stderr, "%s: %s\n", cmd, msg);
        return VBI_EXIT_FAILURE;
    }
    int rc = VBI_EXIT_USAGE;
    vbnl_plugin_result res = api->set_options(r, &a->o, msg, sizeof(msg));
    if (res != VBNL_PLUGIN_OK)
        goto fail;
    api->set_message_callback(r, on_message, NULL, msg, sizeof(msg));
    for (uint32_t i = 0; i < a->nscene; ++i)
        if ((res = api->set_scene_option(r, a->scene_key[i], a->scene_value[i], msg, sizeof(msg))) != VBNL_PLUGIN_OK)
            goto fail;
    for (uint32_t i = 0; i < a->nsets; ++i)
        if ((res = api->set_param(r, a->sets[i], a->set_where[i], msg, sizeof(msg))) != VBNL_PLUGIN_OK)
            goto fail;
    for (uint32_t i = 0; i < n_extra; ++i)
        if ((res = api->set_param(r, extra[i], where, msg, sizeof(msg))) != VBNL_PLUGIN_OK)
            goto fail;
    if ((res = api->load_scene_file(r, a->scene, msg, sizeof(msg))) != VBNL_PLUGIN_OK) {
        rc = VBI_EXIT_SCENE;
        goto fail;
    }
    if ((res = api->configure(r, msg, sizeof(msg))) != VBNL_PLUGIN_OK) {
        rc = res == VBNL_PLUGIN_ERR_UNKNOWN_NAME || res == VBNL_PLUGIN_ERR_INVALID_ARGUMENT ? VBI_EXIT_USAGE
                                                                                             : VBI_EXIT_FAILURE;
        goto fail;
    }
    *out = r;
    return 0;
fail:
    fprintf(stderr, "%s: %s\n", cmd, msg);
    api->renderer_destroy(r);
    return rc;
}

void farm_shell_word(FILE *f, const char *s)
{
    fputc('\'', f);
    for (; *s; ++s) {
        if (*s == '\'')
            fputs("'\\''", f);
        else
            fputc(*s, f);
    }
    fputc('\'', f);
}

void farm_args_write(const farm_args *a, unsigned classes, FILE *f)
{
    for (uint32_t i = 0; i < a->count; ++i) {
        if (!(a->cls[i] & classes))
            continue;
        fputc(' ', f);
        fputs(a->name[i], f);
        if (a->value[i]) {
            fputc(' ', f);
            farm_shell_word(f, a->value[i]);
        }
    }
}

static void on_signal(int sig)
{
    (void)sig;
    vbi_atomic_file_abandon_all();
    _exit(VBI_EXIT_INTERRUPTED);
}

void farm_on_signals(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof(sa));
    sa.sa_handler = on_signal;
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGHUP, &sa, NULL);
}

double farm_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}
