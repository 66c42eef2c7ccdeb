/* What the module's files share beyond the plugin ABI (module/plugin.c, the table) and what its
 * commands (plugin/commands/) use: loading scenes and writing a render's files with the core's
 * public API. Internal to the module: nothing here is exported. */
#ifndef VBNL_MODULE_H
#define VBNL_MODULE_H

#include "vbnl/vbnl.h"

typedef struct module_camera {
    int given;
    float position[3], target[3];
    float fov_y;
} module_camera;

/* 1 when `path` is a POV-Ray scene file (.pov or .inc, any case). */
int module_is_pov(const char *path);

/* Loads FILE (a POV-Ray scene, diagnostics to stderr, or a mesh file through assimp) into a
 * committed scene. Without a camera a mesh file is framed from +z with a 40 degree vertical field
 * of view. */
vbnl_result module_load_scene(vbnl_context *ctx, const char *path, const module_camera *cam, float aspect,
                              vbnl_scene **out, vbnl_error *err);

/* Writes the film as EXR (all layers, settings as attributes) and, if png_path, an sRGB PNG. */
vbnl_result module_write_outputs(const vbnl_renderer *r, const vbnl_render_settings *s,
                                 const char *exr_path, const char *png_path, float exposure, int half,
                                 int partial, vbnl_error *err);

/* Checks that a file can be created at `path` (so a render does not fail at the very end). */
vbnl_result module_check_writable(const char *path, vbnl_error *err);

#endif
