/* The command line's conventions, shared by the `vbnl` executable (plugin/host/) and the commands
 * that run inside the module (plugin/commands/): exit codes, the --camera argument, whether two
 * paths name one file. The executable links no module code, so cli.c is compiled into both. */
#ifndef VBI_CLI_H
#define VBI_CLI_H

#include <stdint.h>

/* Exit codes of the `vbnl` command (documented in `vbnl --help` and the README). */
enum {
    VBI_EXIT_OK = 0,
    VBI_EXIT_FAILURE = 1,     /* the render or a file operation failed */
    VBI_EXIT_USAGE = 2,       /* bad command line */
    VBI_EXIT_SCENE = 3,       /* the scene could not be loaded */
    VBI_EXIT_PLUGIN = 4,      /* the plugin module is missing or has another ABI */
    VBI_EXIT_INTERRUPTED = 130,
};

/* Parses --camera "px,py,pz,tx,ty,tz,fov_degrees": position, target and vertical field of view.
 * Returns 0 on success; -1, leaving the outputs unchanged, unless the text is exactly seven
 * comma-separated finite numbers. */
int cli_parse_camera(const char *text, float position[3], float target[3], float *fov_y);

/* Parses a whole number in [min, max] (decimal, no sign) into *out: 0, or -1 leaving it unchanged. */
int cli_parse_u32(const char *s, uint32_t *out, uint32_t min, uint32_t max);

/* Parses a finite number in [min, max] (the whole text, as strtod reads it) into *out: 0, or -1
 * leaving it unchanged. */
int cli_parse_double(const char *s, double *out, double min, double max);

/* 1 when `a` and `b` name one file: the same inode when both exist (links and hard links
 * included), else the same canonical path of the folder and name (a file about to be created).
 * An output is never an input or another output. */
int cli_same_file(const char *a, const char *b);

#endif
