/* OpenColorIO behind a C interface (the project's only C++ lives in ocio_shim.cpp).
 *
 * vbi_ocio_apply converts scene-linear Rec.709 pixels in place to the display-referred values of
 * a display/view pair. The config is, in this order: `config_path` when non-NULL, the file named
 * by $OCIO when set and non-empty, else the embedded config (builtin_config.yaml, made only of
 * OpenColorIO 2.1 built-in transforms): display "sRGB" with views "Standard" (the sRGB curve, no
 * tone mapping), "ACES 1.0 SDR-video" (the ACES 1.0 output transform) and "Raw" (identity).
 * The input colour space is the config's scene_linear role.
 *
 * Errors: a non-zero result and one sentence in msg. Unknown display or view: VBNL_ERR_UNKNOWN_NAME,
 * listing the config's displays and views; an unreadable or invalid config: VBNL_ERR_BACKEND.
 * Every C++ exception is caught inside the shim.
 *
 * Thread-safety: calls share nothing; each builds its own config and processor. */
#ifndef VBI_OCIO_SHIM_H
#define VBI_OCIO_SHIM_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The embedded config's YAML text. */
const char *vbi_ocio_builtin_config(void);

/* display/view NULL: the config's default display and that display's default view. rgba holds
 * width*height*channels floats (channels 3 or 4; the 4th is left alone). Returns a vbnl_result. */
int vbi_ocio_apply(const char *config_path, const char *display, const char *view, float *pixels,
                    uint32_t width, uint32_t height, uint32_t channels, char *msg, size_t msg_size);

/* "display: view, view; display: ..." of the chosen config, into buf. Returns a vbnl_result. */
int vbi_ocio_describe(const char *config_path, char *buf, size_t buf_size, char *msg, size_t msg_size);

#ifdef __cplusplus
}
#endif
#endif
