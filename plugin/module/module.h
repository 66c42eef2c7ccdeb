/* What the module's files share beyond the plugin ABI (module/plugin.c, the table) and what its
 * commands (plugin/commands/) use: loading scenes and writing a render's files with the core's
 * public API. Internal to the module: nothing here is exported. */
#ifndef VBI_MODULE_H
#define VBI_MODULE_H

#include "vbnl/vbnl.h"
#include "vbnl/vbnl_plugin.h"

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

/* Writes the film as EXR (all layers, settings as attributes; a crop as the data window inside
 * the whole image's display window) and, if png_path, an sRGB PNG of the whole image. `scene`
 * (may be NULL) gives the scene and camera fingerprints of the header. */
vbnl_result module_write_outputs(const vbnl_renderer *r, const vbnl_render_settings *s, const vbnl_scene *scene,
                                 const char *exr_path, const char *png_path, float exposure, int half,
                                 int partial, vbnl_error *err);

/* Checks that a file can be created at `path` (so a render does not fail at the very end). */
vbnl_result module_check_writable(const char *path, vbnl_error *err);

/* ---- the module's own table, for its commands (plugin.c) ---- */

/* The function table vbnl_plugin_entry hands to hosts: the commands drive renderers through it
 * as a host does. */
const vbnl_plugin_api *module_api(void);
/* The settings of a configured renderer (the resolved integrator, the merged parameters), NULL
 * before configure. Owned by the renderer. */
const vbnl_render_settings *module_renderer_settings(const vbnl_plugin_renderer *r);
/* Writes w x h RGBA floats (changed in place: exposure, then the view) as the PNG that write_png
 * writes of a render: through the OpenColorIO display/view, clamped, dithered, quantised. Errors
 * as write_png's, in msg. With path NULL the view is only applied: a check that it exists. */
vbnl_result module_write_png(const char *path, float *rgba, uint32_t w, uint32_t h, const vbnl_plugin_view *view,
                             char *msg, size_t n);

#endif
