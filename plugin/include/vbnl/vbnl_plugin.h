/* vbnl_plugin.h: the interface a host renderer uses to load and drive the vbnl plugin module.
 *
 * Purpose
 *   The vbnl renderer ships as one shared module (vbnl_plugin.so). It exports exactly one symbol,
 *   vbnl_plugin_entry; everything else is reached through the const table of function pointers
 *   that symbol returns. A host needs only this header (C11 or C++) and dlopen():
 *
 *     void *so = dlopen(path, RTLD_NOW | RTLD_LOCAL);
 *     vbnl_plugin_entry_fn entry = (vbnl_plugin_entry_fn)dlsym(so, VBNL_PLUGIN_ENTRY_NAME);
 *     const char *why = NULL;
 *     const vbnl_plugin_api *api = entry(VBNL_PLUGIN_ABI_MAJOR, &why);
 *     if (!api) { fprintf(stderr, "%s\n", why); ... }
 *
 *   then: renderer_create -> set_options / set_param -> load_scene_file (or load_scene_text)
 *         -> prepare -> render -> read_layer / write_exr / apply_view / write_png -> renderer_destroy.
 *
 * Versioning
 *   The table starts with abi_major, abi_minor and its own size, and only ever grows at the end
 *   (a function whose signature changes gets a new name and a new slot). A host built for ABI
 *   major M asks for M; a module of another major returns NULL and a reason. A host built for
 *   minor m may use every slot that existed in m; before using a slot added later it checks
 *   VBNL_PLUGIN_HAS(api, slot). Structs passed in (options, view) start with their own size so that
 *   they can grow the same way: initialise them with the table's *_init functions.
 *
 * Ownership
 *   A vbnl_plugin_renderer is an opaque handle created by renderer_create and released by
 *   renderer_destroy (which accepts NULL). It owns its scene, parameters and framebuffer. Strings
 *   the module returns (names, summaries, docs, version) are constant and live as long as the
 *   module stays loaded. Every buffer a host passes in is borrowed for the call only.
 *
 * Errors
 *   Every fallible function returns a vbnl_plugin_result. When it is not VBNL_PLUGIN_OK and `msg`
 *   is non-NULL, msg (of msg_size bytes, caller-owned) receives one NUL-terminated English
 *   sentence, truncated to fit; scene errors start with "file:line:col:". There is no global
 *   "last error". Nothing in the module calls exit() or abort() on bad input.
 *
 * Threads
 *   The table's functions that take no renderer may be called from any thread. One renderer must
 *   be driven by one thread at a time; distinct renderers are independent. prepare and render
 *   spread their work over the renderer's own worker threads and return when done. The progress
 *   callback is called on the thread that called prepare or render, never on a worker thread.
 *   A host may cancel from a signal handler by setting a flag its progress callback returns, and
 *   may end the process from one: abandon_writes (ABI 1.1) is async-signal-safe and removes the
 *   temporary files of writes under way before the host calls _exit().
 *
 * Colour
 *   The framebuffer and the EXR are scene-linear Rec.709 primaries, D65 white. apply_view and
 *   write_png produce display-referred values through an OpenColorIO display/view: the module's
 *   embedded config (display "sRGB"; views "Standard", "ACES 1.0 SDR-video", "Raw"), the file
 *   named by $OCIO, or an explicit config file. */
#ifndef VBNL_PLUGIN_H
#define VBNL_PLUGIN_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define VBNL_PLUGIN_ABI_MAJOR 1u
#define VBNL_PLUGIN_ABI_MINOR 3u
#define VBNL_PLUGIN_ENTRY_NAME "vbnl_plugin_entry"

/* True when the table has `field` (it was built with at least that minor version's layout). */
#define VBNL_PLUGIN_HAS(api, field) \
    ((api)->size >= offsetof(vbnl_plugin_api, field) + sizeof((api)->field) && (api)->field != NULL)

/* Result codes; the values equal the core's vbnl_result codes. */
typedef int vbnl_plugin_result;
enum {
    VBNL_PLUGIN_OK = 0,
    VBNL_PLUGIN_ERR_INVALID_ARGUMENT = 1, /* NULL handle, out-of-range value, bad option */
    VBNL_PLUGIN_ERR_OUT_OF_MEMORY = 2,
    VBNL_PLUGIN_ERR_IO = 3,               /* a file could not be read or written */
    VBNL_PLUGIN_ERR_UNKNOWN_NAME = 4,     /* unknown integrator, parameter, layer, display, view */
    VBNL_PLUGIN_ERR_UNSUPPORTED = 5,
    VBNL_PLUGIN_ERR_BACKEND = 6,          /* Embree, OpenEXR, OpenColorIO, assimp reported an error */
    VBNL_PLUGIN_ERR_CANCELLED = 7,        /* the progress callback asked to stop */
    VBNL_PLUGIN_ERR_STATE = 8,            /* call out of order (render before a scene is loaded ...) */
    VBNL_PLUGIN_ERR_PARSE = 9,            /* the scene text could not be understood */
    VBNL_PLUGIN_ERR_CORRUPT = 10          /* a file is damaged or from another version */
};

typedef struct vbnl_plugin_renderer vbnl_plugin_renderer;

/* ---- integrators and their parameters -------------------------------------------------------- */

typedef enum vbnl_plugin_param_type {
    VBNL_PLUGIN_PARAM_INT = 0,
    VBNL_PLUGIN_PARAM_FLOAT = 1,
    VBNL_PLUGIN_PARAM_BOOL = 2,
    VBNL_PLUGIN_PARAM_ENUM = 3,  /* one string of `choices` */
    VBNL_PLUGIN_PARAM_STRING = 4
} vbnl_plugin_param_type;

typedef struct vbnl_plugin_param_info {
    const char *name;
    vbnl_plugin_param_type type;
    double default_number;       /* INT, FLOAT, BOOL (0 or 1) */
    const char *default_string;  /* ENUM, STRING */
    double min, max;             /* inclusive range of INT and FLOAT */
    const char *const *choices;  /* ENUM: NULL-terminated; otherwise NULL */
    const char *doc;             /* one line */
} vbnl_plugin_param_info;

typedef struct vbnl_plugin_integrator_info {
    const char *name;            /* e.g. "path", "vbnl" */
    const char *summary;         /* one line */
    uint32_t param_count;
} vbnl_plugin_integrator_info;

/* ---- options --------------------------------------------------------------------------------- */

/* Render options. Fill with options_init, change what you need, pass to set_options. */
typedef struct vbnl_plugin_options {
    uint32_t size;               /* sizeof(vbnl_plugin_options) as the host was built */
    uint32_t threads;            /* worker threads; 0 = one per core. Fixed once a scene is loaded */
    uint64_t seed;               /* same seed, same image, for any thread count */
    uint32_t spp;                /* samples per pixel; 0 = until the time budget ends (default 16) */
    double time_budget;          /* seconds for prepare + render; 0 = no limit */
    uint32_t width, height;      /* image size, 1 .. 65536 (default 512 x 512) */
    uint32_t crop[4];            /* x0, y0, x1, y1 (exclusive); all zero = the whole image */
    const char *integrator;      /* NULL: the scene's choice (mesh files: "path"); copied */
    int camera_given;            /* mesh files only: camera from the three fields below */
    float camera_position[3], camera_target[3];
    float camera_fov_y;          /* degrees; up is +y */
    /* ---- ABI 1.2 (a 1.1 host's shorter struct leaves these at their defaults) ---- */
    const char *sampler;         /* "sobol" (NULL: the default) or "random"; checked by set_options
                                    (VBNL_PLUGIN_ERR_UNKNOWN_NAME); copied */
    /* ---- ABI 1.3 ---- */
    uint32_t test_hooks;         /* VBNL_PLUGIN_TEST_* bits, for tests only; 0. Fixed once a scene is
                                    loaded, like threads */
} vbnl_plugin_options;

/* options.test_hooks: every file the module writes (write_exr, write_png, the save_lights file)
 * waits 30 s with its temporary file complete and not yet renamed, after saying so on stderr
 * ("vbnl: test pause (write): '<temporary>' written, not yet renamed to '<path>'"), so that a
 * test can interrupt a write at a known point. It holds for the whole process from the first
 * scene loaded with it. */
#define VBNL_PLUGIN_TEST_PAUSE_WRITES 1u

/* ---- progress -------------------------------------------------------------------------------- */

typedef struct vbnl_plugin_progress {
    const char *stage;           /* "placement", "elimination", "photons", "profiles", "render" ... */
    double done, total;          /* work units; total may be 0 when unknown */
    const char *unit;            /* "samples/pixel", "photons", ... */
    double elapsed;              /* seconds in this stage so far */
    double rate;                 /* units per second */
    double eta;                  /* seconds left in this stage, < 0 when unknown */
} vbnl_plugin_progress;

/* Called on the thread that called prepare/render, at most every 0.25 s and once at the end of
 * every stage. Return non-zero to cancel: work stops after the tiles in flight, and the
 * framebuffer keeps every finished sample. The pointer is valid during the call only. */
typedef int (*vbnl_plugin_progress_fn)(void *user, const vbnl_plugin_progress *progress);

typedef struct vbnl_plugin_stats {
    uint32_t size;               /* set by the caller: sizeof(vbnl_plugin_stats) */
    uint32_t spp;                /* samples per pixel finished in every pixel */
    uint32_t passes;
    uint32_t threads;
    uint64_t samples, rays;
    double prepare_seconds, render_seconds;
    int partial;                 /* the last prepare/render was cancelled */
} vbnl_plugin_stats;

/* ---- scene messages -------------------------------------------------------------------------- */

typedef enum vbnl_plugin_severity {
    VBNL_PLUGIN_NOTE = 0,        /* the scene's #debug output */
    VBNL_PLUGIN_WARNING = 1,
    VBNL_PLUGIN_ERROR = 2
} vbnl_plugin_severity;

/* Receives the full text of every note, warning and error of a scene load ("file:line:col: ...",
 * the source line, a caret, the chain of includes and macros). Called while load_scene_file or
 * load_scene_text runs, one message at a time, possibly on a thread of the module (the parser runs
 * on its own thread with a large stack) while the calling thread waits. `text` is valid during
 * the call only. */
typedef void (*vbnl_plugin_message_fn)(void *user, vbnl_plugin_severity severity, const char *text);

/* ---- colour-managed view --------------------------------------------------------------------- */

typedef struct vbnl_plugin_view {
    uint32_t size;               /* sizeof(vbnl_plugin_view) as the host was built */
    const char *config;          /* OCIO config file; NULL: $OCIO if set, else the embedded config */
    const char *display;         /* NULL: the config's default display */
    const char *view;            /* NULL: the display's default view */
    float exposure;              /* stops applied before the view */
    uint32_t png_bits;           /* write_png: 8 (default) or 16 */
    int dither;                  /* write_png: triangular dither before quantising (default 1) */
    /* ---- ABI 1.3 (a 1.2 host's shorter struct leaves this at its default) ---- */
    int alpha;                   /* write_png: 1 writes RGBA with the beauty image's alpha (default 0: RGB) */
} vbnl_plugin_view;

/* ---- the table ------------------------------------------------------------------------------- */

typedef struct vbnl_plugin_api {
    uint32_t abi_major, abi_minor;
    uint32_t size;               /* sizeof(vbnl_plugin_api) the module was built with */

    /* "0.1.0" */
    const char *(*version)(void);

    uint32_t (*integrator_count)(void);
    vbnl_plugin_result (*integrator_info)(uint32_t index, vbnl_plugin_integrator_info *out,
                                          char *msg, size_t msg_size);
    vbnl_plugin_result (*integrator_param)(uint32_t index, uint32_t param, vbnl_plugin_param_info *out,
                                           char *msg, size_t msg_size);

    void (*options_init)(vbnl_plugin_options *o);
    void (*view_init)(vbnl_plugin_view *v);

    vbnl_plugin_result (*renderer_create)(vbnl_plugin_renderer **out, char *msg, size_t msg_size);
    void (*renderer_destroy)(vbnl_plugin_renderer *r);

    /* Copies the options. The image size and camera must be set before the scene is loaded (mesh
     * files are framed for the aspect ratio); threads cannot change after it. The integrator name
     * is checked against the registry at once (VBNL_PLUGIN_ERR_UNKNOWN_NAME). */
    vbnl_plugin_result (*set_options)(vbnl_plugin_renderer *r, const vbnl_plugin_options *o,
                                      char *msg, size_t msg_size);
    /* One integrator parameter as "key=value" (numbers, true/false/on/off, or text). `where` labels
     * it in messages ("--set"). These override the scene's own parameters; they are validated
     * against the integrator's table by configure. */
    vbnl_plugin_result (*set_param)(vbnl_plugin_renderer *r, const char *key_equals_value,
                                    const char *where, char *msg, size_t msg_size);

    /* Where the scene's messages go (NULL: nowhere). Kept until changed. */
    vbnl_plugin_result (*set_message_callback)(vbnl_plugin_renderer *r, vbnl_plugin_message_fn fn,
                                               void *user, char *msg, size_t msg_size);

    /* Loads a scene: files named .pov or .inc through the POV-Ray scene language (the scene may select its
     * integrator and parameters), anything else as a mesh file (OBJ/MTL, PLY, glTF, ...), framed
     * from +z unless a camera is given. Replaces a previously loaded scene. Errors:
     * VBNL_PLUGIN_ERR_PARSE / _IO / _BACKEND with "file:line:col:" where known. */
    vbnl_plugin_result (*load_scene_file)(vbnl_plugin_renderer *r, const char *path, char *msg,
                                          size_t msg_size);
    /* The same for scene-language text held in memory; `name` labels it in messages and its
     * folder is searched for includes. */
    vbnl_plugin_result (*load_scene_text)(vbnl_plugin_renderer *r, const char *name, const char *text,
                                          size_t length, char *msg, size_t msg_size);

    /* Resolves the integrator (options, else the scene's, else "path"), merges the scene's
     * parameters with set_param's (set_param wins), validates them and allocates the framebuffer.
     * Called by prepare when needed; call it early to report bad parameters before heavy work. */
    vbnl_plugin_result (*configure)(vbnl_plugin_renderer *r, char *msg, size_t msg_size);
    /* Scene-dependent preparation (VBNL: placement, elimination, photons, profiles). */
    vbnl_plugin_result (*prepare)(vbnl_plugin_renderer *r, vbnl_plugin_progress_fn progress, void *user,
                                  char *msg, size_t msg_size);
    /* Progressive passes until spp or the time budget. VBNL_PLUGIN_ERR_CANCELLED when cancelled;
     * the framebuffer then holds every finished sample and may be written (marked partial). */
    vbnl_plugin_result (*render)(vbnl_plugin_renderer *r, vbnl_plugin_progress_fn progress, void *user,
                                 char *msg, size_t msg_size);
    vbnl_plugin_result (*get_stats)(const vbnl_plugin_renderer *r, vbnl_plugin_stats *out, char *msg,
                                    size_t msg_size);

    /* Framebuffer: layer 0 is the beauty image "" (RGBA), then AOVs ("albedo", "normal", "depth",
     * ...). Valid after configure. */
    uint32_t (*layer_count)(const vbnl_plugin_renderer *r);
    vbnl_plugin_result (*layer_info)(const vbnl_plugin_renderer *r, uint32_t index, const char **name,
                                     uint32_t *channels, char *msg, size_t msg_size);
    /* width * height * channels interleaved floats, row 0 at the top; dst_count must be at least
     * that. Width and height are the options' image size. */
    vbnl_plugin_result (*read_layer)(const vbnl_plugin_renderer *r, const char *layer, float *dst,
                                     size_t dst_count, char *msg, size_t msg_size);

    /* Checks that a file can be created at `path` without creating it (a temporary file is made
     * and removed), so that a render does not fail at its end. */
    vbnl_plugin_result (*check_writable)(const char *path, char *msg, size_t msg_size);
    /* Scene-linear EXR of every layer (FLOAT, or HALF when half != 0), Rec.709 chromaticities,
     * the settings as vbnl/... attributes, vbnl/partial = 1 after a cancelled render. Atomic. */
    vbnl_plugin_result (*write_exr)(const vbnl_plugin_renderer *r, const char *path, int half,
                                    char *msg, size_t msg_size);
    /* The beauty image through exposure and the OpenColorIO display/view: width * height * 4
     * display-referred floats (alpha copied), not clamped. Unknown displays or views fail with
     * VBNL_PLUGIN_ERR_UNKNOWN_NAME and a message listing the available ones. */
    vbnl_plugin_result (*apply_view)(const vbnl_plugin_renderer *r, const vbnl_plugin_view *view,
                                     float *dst, size_t dst_count, char *msg, size_t msg_size);
    /* apply_view, clamped to [0, 1], dithered and quantised to 8 or 16 bits, written as an RGB
     * PNG with an sRGB chunk. Atomic. */
    vbnl_plugin_result (*write_png)(const vbnl_plugin_renderer *r, const char *path,
                                    const vbnl_plugin_view *view, char *msg, size_t msg_size);

    /* Developer commands that run inside the module ("bench", ...): name and a one-line summary of
     * command i, or NULL past the end. run_command prints to stdout/stderr and returns a process
     * exit status (argv[0] is the command name). Called from the host's main thread. */
    const char *(*command_at)(uint32_t index, const char **summary);
    int (*run_command)(const char *name, int argc, char **argv);

    /* ---- ABI 1.1 ---- */

    /* For a host that ends the process from a signal handler (a second Ctrl-C): call it just
     * before _exit(). It removes the temporary file of every write_exr, write_png and
     * check_writable under way in this process, on any thread, and of the save_lights file a
     * prepare is writing, so that the interrupted write leaves neither a temporary file nor a
     * half-written target: the target keeps its previous content, or stays absent. Every write
     * that starts or would finish afterwards fails with VBNL_PLUGIN_ERR_CANCELLED and leaves
     * nothing; there is no way back, so call it only when the process is about to end.
     * Async-signal-safe: lock-free atomics and unlink() only, no lock, no allocation, no stdio.
     * It may wait while another thread is inside the open() or rename() of a temporary file (that
     * thread blocks signals for those calls only). At most 16 writes at a time are tracked; more
     * are written untracked. Hosts built for 1.0 modules check VBNL_PLUGIN_HAS(api, abandon_writes). */
    void (*abandon_writes)(void);

    /* ---- ABI 1.3 ---- */

    /* One setting of the POV-Ray scene the next load_scene_file / load_scene_text reads, as
     * POV-Ray's front end passes them to its parser. Kept until the renderer is destroyed; a key
     * set again replaces its value, except the lists (declare, include_dir, read_dir, write_dir),
     * which grow. Keys:
     *   clock, clock_delta, initial_clock, final_clock           numbers (the identifiers of the
     *   frame_number, initial_frame, final_frame, clock_on       same names; all 0 by default)
     *   declare      "NAME=VALUE": a float, or a string in double quotes (POV-Ray's Declare=)
     *   include_dir  a folder searched for #include after the scene's own (POV-Ray's Library_Path)
     *   read_dir     a folder (and below) the scene may read          (POV-Ray's I/O restriction
     *   write_dir    a folder (and below) the scene may read and write  settings; the folder must exist)
     * Errors: VBNL_PLUGIN_ERR_UNKNOWN_NAME for another key; VBNL_PLUGIN_ERR_INVALID_ARGUMENT for a
     * value that is not a number, a declare that is not NAME=VALUE with NAME an identifier that
     * is no reserved word, or a folder that does not exist. Mesh files ignore these settings. */
    vbnl_plugin_result (*set_scene_option)(vbnl_plugin_renderer *r, const char *key, const char *value, char *msg,
                                           size_t msg_size);
} vbnl_plugin_api;

/* The one exported symbol. Returns the table when host_abi_major equals the module's ABI major,
 * otherwise NULL and, if `why` is non-NULL, a constant sentence naming both versions. */
typedef const vbnl_plugin_api *(*vbnl_plugin_entry_fn)(uint32_t host_abi_major, const char **why);

#ifdef __cplusplus
}
#endif
#endif
