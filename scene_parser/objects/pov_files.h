/* Files a scene names (private header of the object layer): `vbnl_mesh`, `image_map` and the
 * integrator's `save_lights` / `load_lights`.
 *
 * A scene file is untrusted input, so the files it names lie in the folder of the file that
 * names them, or below it, as POV-Ray's default I/O restriction keeps a scene to its own folder:
 * an absolute name, a ".." component, and a name that a symbolic link carries out of that folder
 * are refused with the reason. The user widens this as POV-Ray's I/O restriction settings do, by
 * opening folders to the scene (vbnl_sdl_permit_dir; the command line's --read-dir and
 * --write-dir): a name that leads into one of them is accepted. */
#ifndef VBI_POV_FILES_H
#define VBI_POV_FILES_H

#include "sdl_internal.h"

typedef enum { POV_FILE_READ, POV_FILE_WRITE } pov_file_use;

/* True when `name` is absolute or has a ".." component (it would leave the folder). */
int pov_file_name_escapes(const char *name);

/* The path of `name` as the file at `loc` names it (malloc'd), or NULL with *why set to the
 * reason (a static string; "out of memory" too). A READ file must exist; a WRITE file may not
 * exist yet, and an existing one must not be a symbolic link. `p` holds the folders the user
 * opened to the scene. */
char *pov_file_resolve(const vbnl_sdl_parser *p, const vbnl_sdl_loc *loc, const char *name, pov_file_use use,
                       const char **why);

#endif
