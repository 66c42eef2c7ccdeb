/* `vbnl`: the command-line host. It links no renderer code: it loads the plugin module with
 * dlopen and drives it through the table of vbnl_plugin.h.
 *
 *   vbnl [--plugin PATH] render FILE -o out.exr [--png out.png] [options]
 *   vbnl [--plugin PATH] info
 *   vbnl [--plugin PATH] bench ...      (commands that run inside the module)
 *   vbnl [--plugin PATH] [FILE.ini ...] [+/-switches ...] [FILE.pov]   (POV-Ray's command line: pov_cli.c)
 *
 * The module is looked for in this order: --plugin, $VBNL_PLUGIN, beside this executable, in
 * <executable>/../<libdir>/vbnl (an installed tree, wherever it was moved), in the configured
 * install directory.
 *
 * A render (host_render.c) handles Ctrl-C (or SIGTERM, SIGHUP): the first stops it after the
 * tiles in flight and the partial image is written (exit 130); the second ends the process at once
 * from the signal handler (exit 130), after the module's abandon_writes has removed the temporary
 * file of a write under way. An output never names the scene, a --load-lights file or another
 * output. */
#include <dlfcn.h>
#include <errno.h>
#include <getopt.h>
#include <libgen.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"
#include "host.h"
#include "pov_cli.h"
#include "vbnl/vbnl_plugin.h"

#ifndef VBNL_PLUGIN_FILE
#define VBNL_PLUGIN_FILE "vbnl_plugin.so"
#endif
#ifndef VBNL_PLUGIN_LIBDIR
#define VBNL_PLUGIN_LIBDIR "lib/vbnl"
#endif
#ifndef VBNL_PLUGIN_INSTALL_DIR
#define VBNL_PLUGIN_INSTALL_DIR "/usr/local/lib/vbnl"
#endif

#define MSG_SIZE HOST_MSG_SIZE

/* ---- loading the plugin ------------------------------------------------------------------------ */

static int g_silent; /* `vbnl --help`: no message when the plugin cannot be loaded */

#define PLUGIN_ERROR(...) (g_silent ? 0 : fprintf(stderr, __VA_ARGS__))

/* Opens one candidate. Returns 0 on success, -1 when the file does not exist (try the next one),
 * 1 on a hard error (message printed). */
static int try_plugin(const char *path, plugin *pl, int must_exist)
{
    if (access(path, F_OK) != 0) {
        if (must_exist) {
            PLUGIN_ERROR("vbnl: plugin '%s': %s\n", path, strerror(errno));
            return 1;
        }
        return -1;
    }
    void *h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!h) {
        PLUGIN_ERROR("vbnl: cannot load plugin '%s': %s\n", path, dlerror());
        return 1;
    }
    vbnl_plugin_entry_fn entry;
    *(void **)&entry = dlsym(h, VBNL_PLUGIN_ENTRY_NAME);
    if (!entry) {
        PLUGIN_ERROR("vbnl: '%s' is not a vbnl plugin (no %s symbol)\n", path, VBNL_PLUGIN_ENTRY_NAME);
        dlclose(h);
        return 1;
    }
    const char *why = NULL;
    const vbnl_plugin_api *api = entry(VBNL_PLUGIN_ABI_MAJOR, &why);
    if (!api || api->abi_major != VBNL_PLUGIN_ABI_MAJOR || api->size < offsetof(vbnl_plugin_api, run_command)) {
        char table[96];
        if (api)
            snprintf(table, sizeof(table), "its table has ABI %u.%u and %u bytes", api->abi_major,
                     api->abi_minor, api->size);
        PLUGIN_ERROR("vbnl: plugin '%s' has another ABI (this host needs ABI major %u): %s\n", path,
                     VBNL_PLUGIN_ABI_MAJOR, !api ? (why ? why : "the module refused") : table);
        dlclose(h);
        return 1;
    }
    pl->handle = h;
    pl->api = api;
    snprintf(pl->path, sizeof(pl->path), "%s", path);
    return 0;
}

static int load_plugin(const char *given, plugin *pl)
{
    if (given)
        return try_plugin(given, pl, 1) == 0 ? 0 : -1;
    const char *env = getenv("VBNL_PLUGIN");
    if (env && *env)
        return try_plugin(env, pl, 1) == 0 ? 0 : -1;
    char exe[PATH_MAX], cand[PATH_MAX + 256];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof(exe) - 1);
    int rc;
    if (n > 0) {
        exe[n] = '\0';
        const char *dir = dirname(exe);
        snprintf(cand, sizeof(cand), "%s/%s", dir, VBNL_PLUGIN_FILE);
        if ((rc = try_plugin(cand, pl, 0)) >= 0)
            return rc == 0 ? 0 : -1;
        snprintf(cand, sizeof(cand), "%s/../%s/%s", dir, VBNL_PLUGIN_LIBDIR, VBNL_PLUGIN_FILE);
        if ((rc = try_plugin(cand, pl, 0)) >= 0)
            return rc == 0 ? 0 : -1;
    }
    snprintf(cand, sizeof(cand), "%s/%s", VBNL_PLUGIN_INSTALL_DIR, VBNL_PLUGIN_FILE);
    if ((rc = try_plugin(cand, pl, 0)) >= 0)
        return rc == 0 ? 0 : -1;
    PLUGIN_ERROR(
            "vbnl: plugin %s not found beside the executable or in %s; give --plugin PATH or set "
            "$VBNL_PLUGIN\n",
            VBNL_PLUGIN_FILE, VBNL_PLUGIN_INSTALL_DIR);
    return -1;
}

/* ---- progress lines ---------------------------------------------------------------------------- */

typedef struct progress_state {
    int quiet, tty;
    double last_plain;
    char last_stage[64];
    int announced;        /* the first Ctrl-C has been reported */
} progress_state;

static void format_eta(double s, char *buf, size_t n)
{
    if (s < 0.0)
        snprintf(buf, n, "--");
    else if (s < 60.0)
        snprintf(buf, n, "%.0fs", s);
    else
        snprintf(buf, n, "%.0fm%02.0fs", floor(s / 60.0), s - 60.0 * floor(s / 60.0));
}

/* Called on the thread that called prepare/render (this program's main thread). On a terminal:
 * one line per stage, rewritten in place; otherwise a plain line at a stage's start and end and
 * every 5 seconds. Returns non-zero after Ctrl-C, which cancels the render; the first call that
 * sees it says so on stderr (the point after which a second Ctrl-C counts as the second). */
static int on_progress(void *user, const vbnl_plugin_progress *p)
{
    progress_state *ps = user;
    int interrupted = host_interrupted() > 0;
    if (interrupted && !ps->announced) {
        ps->announced = 1;
        if (!ps->quiet) {
            if (ps->tty && ps->last_stage[0])
                fputc('\n', stderr);
            fprintf(stderr, "vbnl: interrupted, finishing the current tiles (Ctrl-C again to quit without writing)\n");
        }
        host_test_pause();
    }
    if (!ps->quiet) {
        char eta[32];
        format_eta(p->eta, eta, sizeof(eta));
        int new_stage = strcmp(ps->last_stage, p->stage) != 0;
        char pct[16] = "";
        if (p->total > 0.0)
            snprintf(pct, sizeof(pct), "%5.1f%%", 100.0 * p->done / p->total);
        if (ps->tty) {
            if (ps->last_stage[0] && new_stage)
                fputc('\n', stderr);
            fprintf(stderr, "\r%-12s %6s  %.4g %s  %.3g/s  ETA %s\033[K", p->stage, pct, p->done, p->unit,
                    p->rate, eta);
            fflush(stderr);
        } else if (new_stage || p->elapsed - ps->last_plain >= 5.0 || (p->total > 0.0 && p->done >= p->total)) {
            fprintf(stderr, "%s: %s%s%.4g %s, %.3g/s, ETA %s)\n", p->stage, pct, pct[0] ? " (" : "(", p->done,
                    p->unit, p->rate, eta);
            ps->last_plain = p->elapsed;
        }
        if (new_stage)
            snprintf(ps->last_stage, sizeof(ps->last_stage), "%s", p->stage);
    }
    return interrupted;
}

/* Scene notes, warnings and errors in full (source line, caret, include chain). */
static void on_message(void *user, vbnl_plugin_severity severity, const char *text)
{
    (void)user;
    (void)severity;
    size_t n = strlen(text);
    fprintf(stderr, "%s%s", text, n && text[n - 1] == '\n' ? "" : "\n");
}

/* ---- usage --------------------------------------------------------------------------------------- */

static void usage(FILE *f, const plugin *pl)
{
    fprintf(f,
            "usage: vbnl [--plugin PATH] <command> [options]\n"
            "\n"
            "commands:\n"
            "  render FILE -o OUT.exr   render a scene (.pov scene file, or a mesh file: OBJ/MTL, PLY, glTF)\n"
            "  info                     list the integrators and their parameters\n"
            "  [FILE.ini] [+/-SWITCHES] [FILE.pov]  POV-Ray's command line and .ini files\n"
            "                           (docs/povray-command-line.md)\n");
    const char *summary;
    const char *name;
    for (uint32_t i = 0; pl && pl->api && (name = pl->api->command_at(i, &summary)); ++i)
        fprintf(f, "  %-24s %s\n", name, summary);
    fprintf(f,
            "\n"
            "  --plugin PATH            the plugin module (default: $VBNL_PLUGIN, else " VBNL_PLUGIN_FILE
            " beside\n"
            "                           this program or in " VBNL_PLUGIN_INSTALL_DIR ")\n"
            "  --version                versions of the program, the plugin and its ABI\n"
            "\n"
            "`vbnl render --help` and `vbnl bench --help` list their options.\n"
            "exit status: 0 success, 1 render or file error, 2 bad command line, 3 scene error,\n"
            "4 plugin missing or of another ABI, 130 interrupted (Ctrl-C; the partial image is written).\n");
}

/* The line ends the render's progress left open on a terminal. */
static void progress_end(void *user)
{
    const progress_state *ps = user;
    if (!ps->quiet && ps->tty && ps->last_stage[0])
        fputc('\n', stderr);
}

static void render_usage(FILE *f)
{
    fprintf(f,
            "usage: vbnl render FILE [-o OUT.exr] [--png OUT.png] [options]\n"
            "\n"
            "FILE is a POV-Ray scene (.pov) or a mesh file (OBJ/MTL, PLY, glTF). A scene file may choose\n"
            "its integrator and parameters; --integrator and --set override them.\n"
            "\n"
            "%s"
            "  -h, --help               this help\n",
            host_render_options_help);
}

/* ---- render -------------------------------------------------------------------------------------- */

static int cmd_render(const plugin *pl, int argc, char **argv)
{
    struct option opts[64];
    size_t n = 0;
    for (; host_render_options[n].name; ++n)
        opts[n] = host_render_options[n];
    opts[n++] = (struct option){"help", no_argument, 0, 'h'};
    opts[n] = (struct option){0, 0, 0, 0};
    host_render_job job;
    host_render_job_init(&job, pl->api, "vbnl render");
    int c, rc;
    optind = 1;
    while ((c = getopt_long(argc, argv, "o:qh", opts, NULL)) != -1) {
        if (c == 'h') {
            render_usage(stdout);
            return VBI_EXIT_OK;
        }
        if (c == '?' || c == ':') {
            render_usage(stderr);
            return VBI_EXIT_USAGE;
        }
        if ((rc = host_render_option(&job, c, optarg)) != 0)
            return rc;
    }
    if (optind != argc - 1) {
        fprintf(stderr, "vbnl render: expected exactly one scene FILE\n");
        render_usage(stderr);
        return VBI_EXIT_USAGE;
    }
    if (!job.exr && !job.png) {
        fprintf(stderr, "vbnl render: give an output: -o OUT.exr and/or --png OUT.png\n");
        return VBI_EXIT_USAGE;
    }
    job.scene = argv[optind];
    progress_state ps = {job.quiet, isatty(STDERR_FILENO), -1e9, "", 0};
    job.progress = on_progress;
    job.progress_user = &ps;
    job.progress_end = progress_end;
    job.message = on_message;
    return host_render_run(pl->api, &job, NULL);
}

/* ---- info ---------------------------------------------------------------------------------------- */

static const char *type_text(const vbnl_plugin_param_info *p, char *buf, size_t n)
{
    switch (p->type) {
    case VBNL_PLUGIN_PARAM_INT: snprintf(buf, n, "int [%g, %g], default %g", p->min, p->max, p->default_number); break;
    case VBNL_PLUGIN_PARAM_FLOAT: snprintf(buf, n, "float [%g, %g], default %g", p->min, p->max, p->default_number); break;
    case VBNL_PLUGIN_PARAM_BOOL: snprintf(buf, n, "bool, default %s", p->default_number != 0.0 ? "on" : "off"); break;
    case VBNL_PLUGIN_PARAM_ENUM: {
        size_t len = (size_t)snprintf(buf, n, "one of");
        for (const char *const *c = p->choices; c && *c && len < n; ++c)
            len += (size_t)snprintf(buf + len, n - len, " %s", *c);
        if (len < n)
            snprintf(buf + len, n - len, ", default %s", p->default_string);
        break;
    }
    case VBNL_PLUGIN_PARAM_STRING:
        snprintf(buf, n, "string, default '%s'", p->default_string ? p->default_string : "");
        break;
    default: snprintf(buf, n, "(type %d)", (int)p->type); break;
    }
    return buf;
}

static int cmd_info(const plugin *pl, int argc, char **argv)
{
    (void)argv;
    if (argc > 1) {
        fprintf(stderr, "vbnl info: takes no arguments\n");
        return VBI_EXIT_USAGE;
    }
    const vbnl_plugin_api *api = pl->api;
    printf("vbnl %s, plugin %s (ABI %u.%u)\n\n", api->version(), pl->path, api->abi_major, api->abi_minor);
    char msg[MSG_SIZE];
    for (uint32_t i = 0; i < api->integrator_count(); ++i) {
        vbnl_plugin_integrator_info info;
        if (api->integrator_info(i, &info, msg, sizeof(msg)) != VBNL_PLUGIN_OK)
            continue;
        printf("%s: %s\n", info.name, info.summary);
        for (uint32_t k = 0; k < info.param_count; ++k) {
            vbnl_plugin_param_info p;
            char t[256];
            if (api->integrator_param(i, k, &p, msg, sizeof(msg)) == VBNL_PLUGIN_OK)
                printf("  %-16s %s\n  %-16s %s\n", p.name, type_text(&p, t, sizeof(t)), "", p.doc);
        }
        printf("\n");
    }
    return VBI_EXIT_OK;
}

/* ---- dispatch ------------------------------------------------------------------------------------ */

typedef struct host_command {
    const char *name;
    int (*run)(const plugin *pl, int argc, char **argv);
} host_command;

/* Commands of this program; any other name is looked up among the module's commands. */
static const host_command host_commands[] = {
    {"render", cmd_render},
    {"info", cmd_info},
};

int main(int argc, char **argv)
{
    const char *plugin_path = NULL;
    int a = 1;
    while (a < argc && !strncmp(argv[a], "--plugin", 8)) {
        if (argv[a][8] == '=')
            plugin_path = argv[a] + 9;
        else if (!argv[a][8] && a + 1 < argc)
            plugin_path = argv[++a];
        else
            break;
        ++a;
    }
    plugin pl = {0};
    if (a >= argc) {
        usage(stderr, NULL);
        return VBI_EXIT_USAGE;
    }
    const char *cmd = argv[a];
    if (!strcmp(cmd, "-h") || !strcmp(cmd, "--help") || !strcmp(cmd, "help")) {
        /* help works without a plugin; with one it also lists the module's commands */
        g_silent = 1;
        int ok = load_plugin(plugin_path, &pl) == 0;
        usage(stdout, ok ? &pl : NULL);
        return VBI_EXIT_OK;
    }
    if (load_plugin(plugin_path, &pl) != 0)
        return VBI_EXIT_PLUGIN;
    if (!strcmp(cmd, "--version")) {
        printf("vbnl %s (plugin %s, ABI %u.%u)\n", pl.api->version(), pl.path, pl.api->abi_major, pl.api->abi_minor);
        return VBI_EXIT_OK;
    }
    for (size_t i = 0; i < sizeof(host_commands) / sizeof(host_commands[0]); ++i)
        if (!strcmp(cmd, host_commands[i].name))
            return host_commands[i].run(&pl, argc - a, argv + a);
    const char *name;
    for (uint32_t i = 0; (name = pl.api->command_at(i, NULL)); ++i)
        if (!strcmp(cmd, name))
            return pl.api->run_command(cmd, argc - a, argv + a);
    if (pov_cli_applies(argc - a, argv + a)) /* POV-Ray's command line: .ini, +/- switches, KEY=VALUE, .pov */
        return pov_cli_main(&pl, argc - a, argv + a);
    fprintf(stderr, "vbnl: unknown command '%s'\n", cmd);
    usage(stderr, &pl);
    return VBI_EXIT_USAGE;
}
