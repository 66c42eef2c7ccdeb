/* Loading POV-Ray scene files: placeholder until the object layer lands (see pov_scene.h). */
#include "vbnl/pov_scene.h"

#include <string.h>

void vbnl_pov_options_init(vbnl_pov_options *o)
{
    memset(o, 0, sizeof(*o));
    o->width = 640;
    o->height = 480;
}

vbnl_result vbnl_pov_load_file(vbnl_context *ctx, const char *path, const vbnl_pov_options *opt,
                               vbnl_pov_scene **out, vbnl_error *err)
{
    (void)ctx;
    (void)opt;
    *out = NULL;
    return vbnl_error_set(err, VBNL_ERR_UNSUPPORTED,
                          "%s: the scene language's object layer is not available in this build",
                          path);
}

vbnl_result vbnl_pov_load_text(vbnl_context *ctx, const char *name, const char *text, size_t len,
                               const vbnl_pov_options *opt, vbnl_pov_scene **out, vbnl_error *err)
{
    (void)text;
    (void)len;
    return vbnl_pov_load_file(ctx, name, opt, out, err);
}

void vbnl_pov_scene_destroy(vbnl_pov_scene *s) { (void)s; }
const vbnl_scene *vbnl_pov_scene_get(const vbnl_pov_scene *s) { (void)s; return NULL; }
vbnl_scene *vbnl_pov_scene_take_scene(vbnl_pov_scene *s) { (void)s; return NULL; }
const char *vbnl_pov_scene_integrator(const vbnl_pov_scene *s) { (void)s; return "vbnl"; }
const vbnl_params *vbnl_pov_scene_params(const vbnl_pov_scene *s) { (void)s; return NULL; }
size_t vbnl_pov_scene_diag_count(const vbnl_pov_scene *s) { (void)s; return 0; }
const char *vbnl_pov_scene_diag_text(const vbnl_pov_scene *s, size_t i) { (void)s; (void)i; return NULL; }
