/* What the `vbnl` executable's front ends share (plugin/host/, private to the executable): the
 * loaded plugin, the signal handling of a render, the identity of files, and one render from
 * start to written outputs with the options of `vbnl render` (host_render.c). main.c is the
 * `vbnl <command>` front end; pov_cli.c is POV-Ray's command line and .ini files.
 *
 * Threads: everything here runs on the program's main thread, except the signal handler, which
 * may run on any thread and touches only lock-free atomics and async-signal-safe calls. */
#ifndef VBI_HOST_H
#define VBI_HOST_H

#include <getopt.h>
#include <limits.h>
#include <stdint.h>

#include "vbnl/vbnl_plugin.h"

#define HOST_MSG_SIZE 2048

typedef struct plugin {
    void *handle;
    const vbnl_plugin_api *api;
    char path[PATH_MAX];
} plugin;

/* ---- signals --------------------------------------------------------------------------------- */

/* Installs the handler of SIGINT, SIGTERM (a host's stop button: Blender sends it) and SIGHUP for
 * a render with `api`: the first signal makes host_interrupted() true, so that the progress
 * callback cancels and the partial image is written; the second ends the process at once with
 * status 130 after the module's abandon_writes (when it has one) removed the temporary file of a
 * write under way. */
void host_signals_install(const vbnl_plugin_api *api);
/* The number of signals received since the program started. */
int host_interrupted(void);
/* VBNL_TEST_PAUSE=interrupt (tests only): after the first signal, say so on stderr and wait 30 s
 * before the render is told to stop, so that a test can send the second one while the render
 * surely runs. Does nothing unless the variable is set. */
void host_test_pause(void);

/* ---- files ----------------------------------------------------------------------------------- */


/* ---- one render ------------------------------------------------------------------------------ */

enum { HOST_MAX_SETS = 256, HOST_MAX_SCENE_OPTIONS = 512 };

/* Everything one render takes: the plugin's options and view, integrator parameters, settings of
 * the scene load, the scene and the outputs. Filled by host_render_job_init and
 * host_render_option; strings are borrowed (they must outlive host_render_run). */
typedef struct host_render_job {
    const char *who;              /* message prefix: "vbnl render" */
    vbnl_plugin_options opt;
    vbnl_plugin_view view;
    const char *scene;
    const char *exr, *png;        /* outputs; at least one */
    const char *save_lights, *load_lights;
    int half, quiet, spp_given, time_given;
    const char *sets[HOST_MAX_SETS];        /* "key=value" */
    const char *set_where[HOST_MAX_SETS];   /* "--set", "--save-lights", ... */
    char lights_buf[2][PATH_MAX + 16];
    int nsets;
    const char *scene_keys[HOST_MAX_SCENE_OPTIONS], *scene_values[HOST_MAX_SCENE_OPTIONS];
    int nscene;
    /* how the render talks: progress (NULL: none), scene messages (NULL: none), and every error
     * and result line (NULL: stderr) */
    vbnl_plugin_progress_fn progress;
    void *progress_user;
    void (*progress_end)(void *progress_user); /* after preparing and rendering (NULL: nothing) */
    vbnl_plugin_message_fn message;
    void *message_user;
    void (*say)(void *user, int error, const char *line); /* error: 1 for errors, 0 for the result line */
    void *say_user;
} host_render_job;

/* The options of `vbnl render` that set a job, for getopt_long (ends with a zero row), and the
 * lines of `vbnl render --help` that describe them. */
extern const struct option host_render_options[];
extern const char host_render_options_help[];

/* Defaults of the plugin's options and view, no parameters, no outputs. */
void host_render_job_init(host_render_job *job, const vbnl_plugin_api *api, const char *who);
/* Applies one option of host_render_options (`code` its getopt value, `arg` its argument or
 * NULL). Returns 0, or an exit status (VBI_EXIT_USAGE) after saying why. The options of a file
 * name (-o, --png, --save-lights, --load-lights) keep `arg`. */
int host_render_option(host_render_job *job, int code, const char *arg);
/* A setting of the scene load (the plugin's set_scene_option). Returns 0, or VBI_EXIT_USAGE
 * when there are too many. */
int host_render_scene_option(host_render_job *job, const char *key, const char *value);
/* Renders: checks that no output names an input or another output and that every output can be
 * written, creates a renderer, loads the scene, refuses bad parameters and views before the heavy
 * work, prepares and renders with the job's progress callback (which cancels on a signal), writes
 * the outputs (a partial image after the first signal) and says the statistics unless quiet.
 * `stats` (may be NULL) receives them. Returns the process exit status (cli.h). */
int host_render_run(const vbnl_plugin_api *api, host_render_job *job, vbnl_plugin_stats *stats);

/* A formatted line through job->say (stderr when NULL), prefixed "<who>: ". */
void host_say(const host_render_job *job, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

#endif
