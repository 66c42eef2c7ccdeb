/* vbnl: loading a POV-Ray 3.7 scene file into a vbnl_scene.
 *
 * This is the object layer's public face: it runs the SDL language layer (vbnl/sdl.h) with the
 * object layer's hooks, maps the scene's camera, lights, objects and textures onto the core's
 * scene-building API (vbnl/scene.h), commits the scene, and returns it together with the
 * integrator the scene selected in `global_settings { integrator { "name" key value ... } }`
 * (vbnl when the scene has no integrator block) and that integrator's parameters.
 *
 * Ownership: a vbnl_pov_scene owns its vbnl_scene, parameters and diagnostics until
 * vbnl_pov_scene_destroy, unless vbnl_pov_scene_take_scene hands the scene to the caller.
 *
 * Threads: loading is single-threaded per call (the parse runs on a private thread with a large
 * stack); distinct loads share nothing and may run concurrently. The diagnostics callback is
 * called on the parse thread, one diagnostic at a time.
 *
 * Errors: VBNL_ERR_PARSE for scene errors; err->message holds the first line of the error
 * diagnostic ("file:line:col: error: message"); the full text (source line, caret, chain of
 * include/macro locations) goes to the diagnostics callback. */
#ifndef VBNL_POV_SCENE_H
#define VBNL_POV_SCENE_H

#include <stddef.h>

#include "vbnl/params.h"
#include "vbnl/result.h"
#include "vbnl/scene.h"
#include "vbnl/sdl.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vbnl_pov_scene vbnl_pov_scene;

/* A constant declared before the parse (POV-Ray's Declare=NAME=VALUE): a string when `string` is
 * non-NULL, else the float `number`. */
typedef struct vbnl_pov_declare {
    const char *name;
    const char *string;
    double number;
} vbnl_pov_declare;

typedef struct vbnl_pov_options {
    const char *const *include_dirs; /* searched after the scene's folder, before the system dir */
    size_t include_dir_count;
    const char *system_include_dir;  /* NULL: the detected POV-Ray include directory */
    int width, height;               /* image_width / image_height as the scene sees them */
    double clock;                    /* clock (0) */
    /* the other animation identifiers as POV-Ray's front end sets them (all 0 for a still) */
    double clock_delta, initial_clock, final_clock;
    int frame_number, initial_frame, final_frame, clock_on;
    const vbnl_pov_declare *declares; /* declared in order before the parse */
    size_t declare_count;
    /* folders opened to the scene (vbnl_sdl_permit_dir): read, and read and write */
    const char *const *read_dirs;
    size_t read_dir_count;
    const char *const *write_dirs;
    size_t write_dir_count;
    const vbnl_sdl_limits *limits;   /* NULL: vbnl_sdl_limits_default */
    vbnl_sdl_diag_fn diag;           /* every warning, note and error (may be NULL) */
    int no_commit;                   /* 1: build the scene but do not commit it (parser tests) */
    int includes_disabled;           /* 1: #include and vbnl_mesh are refused (fuzzing, untrusted input) */
    void *diag_user;
} vbnl_pov_options;

/* Zero include dirs, 640x480, every animation identifier 0, no declares, no opened folders,
 * default limits, no callback, commit, includes on. */
void vbnl_pov_options_init(vbnl_pov_options *o);

/* Parses `path` and builds a committed scene in `ctx`. */
vbnl_result vbnl_pov_load_file(vbnl_context *ctx, const char *path, const vbnl_pov_options *opt,
                               vbnl_pov_scene **out, vbnl_error *err);
/* Same for a scene held in memory; `name` labels it in messages and its folder is searched
 * first for includes. */
vbnl_result vbnl_pov_load_text(vbnl_context *ctx, const char *name, const char *text, size_t len,
                               const vbnl_pov_options *opt, vbnl_pov_scene **out, vbnl_error *err);

/* Frees the loaded scene, and its committed scene unless taken (accepts NULL). */
void vbnl_pov_scene_destroy(vbnl_pov_scene *s);

/* The committed scene (owned by s unless taken). */
const vbnl_scene *vbnl_pov_scene_get(const vbnl_pov_scene *s);
/* Hands the scene to the caller (who destroys it); later calls return NULL. */
vbnl_scene *vbnl_pov_scene_take_scene(vbnl_pov_scene *s);
/* The integrator the scene selected ("vbnl" without an integrator block). */
const char *vbnl_pov_scene_integrator(const vbnl_pov_scene *s);
/* Its parameters as written in the scene, already validated against the integrator's specs
 * (each setting's origin is "file:line:col"). Never NULL. */
const vbnl_params *vbnl_pov_scene_params(const vbnl_pov_scene *s);
/* Warnings and notes produced by the parse and the mapping. */
size_t vbnl_pov_scene_diag_count(const vbnl_pov_scene *s);
const char *vbnl_pov_scene_diag_text(const vbnl_pov_scene *s, size_t i);

#ifdef __cplusplus
}
#endif
#endif
