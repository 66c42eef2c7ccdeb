/* Opening a file to read it (private header; never installed): the read-side companion of
 * atomic_file.h. Every file vbnl reads from a name a user or a scene gives goes through here: the
 * core's virtual-light files (vl_file.c); the parser's scenes, include files, mesh files (assimp's
 * file functions), images, height fields, density files and fonts; the plugin's EXR and PNG
 * images, OpenColorIO configs and POV-Ray .ini files. Its only dependency is the C library, so
 * the `vbnl` executable, which links no renderer code, compiles this file too (for .ini files).
 *
 * A name may lead to a FIFO, a device, a socket or a folder. Opening a FIFO for reading waits for
 * a writer (forever, for a FIFO nobody writes), reading a terminal waits for input, and opening
 * some devices acts on them (a tape rewinds). So the file is looked at first (stat, following
 * links) and only a regular file is opened; the open itself uses O_NONBLOCK (it cannot wait even
 * if the name is replaced by a FIFO in between), O_NOCTTY and O_CLOEXEC, the descriptor is checked
 * again with fstat, and O_NONBLOCK is cleared before the caller reads.
 *
 * Errors: -1 (or NULL) with *why set to one phrase that fits "cannot read '<path>': <why>": the C
 * library's text of errno ("No such file or directory", "Permission denied", ...) or "it is a
 * folder", "it is a FIFO, not a regular file", "it is a device, not a regular file", "it is a
 * socket, not a regular file". *why is a constant string or strerror's (valid until the thread's
 * next strerror call); errno is left as the failing call set it (EISDIR, ENXIO, ... for the
 * refusals).
 *
 * Threads: any thread; no state. */
#ifndef VBI_READ_FILE_H
#define VBI_READ_FILE_H

#include <stdio.h>
#include <sys/stat.h>

#ifdef __cplusplus
extern "C" {
#endif

/* A read-only descriptor of the regular file `path` (close it with close()), its status in *st
 * when st is not NULL; or -1 with *why set. */
int vbi_read_open(const char *path, struct stat *st, const char **why);

/* The same as a stream opened "rb" (close it with fclose()). */
FILE *vbi_read_fopen(const char *path, struct stat *st, const char **why);

#ifdef __cplusplus
}
#endif
#endif
