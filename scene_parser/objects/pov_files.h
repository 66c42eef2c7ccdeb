/* Files a scene names (private header of the object layer): `vbnl_mesh`, `image_map` and the
 * integrator's `save_lights` / `load_lights`.
 *
 * A scene file is untrusted input, so the files it names lie in the folder of the file that
 * names them, or below it, as POV-Ray's default I/O restriction keeps a scene to its own folder:
 * an absolute name, a ".." component, and a name that a symbolic link carries out of that folder
 * are refused with the reason. Paths outside come from the user, on the command line
 * (`--save-lights`, `--load-lights`, `vbnl render FILE`). */
#ifndef VBNL_POV_FILES_H
#define VBNL_POV_FILES_H

#include "sdl_internal.h"

typedef enum { POV_FILE_READ, POV_FILE_WRITE } pov_file_use;

/* The path of `name` as the file at `loc` names it (malloc'd), or NULL with *why set to the
 * reason (a static string; "out of memory" too). A READ file must exist; a WRITE file may not
 * exist yet, and an existing one must not be a symbolic link. */
/* True when `name` is absolute or has a ".." component (it would leave the folder). */
int pov_file_name_escapes(const char *name);

char *pov_file_resolve(const vbnl_sdl_loc *loc, const char *name, pov_file_use use, const char **why);

#endif
