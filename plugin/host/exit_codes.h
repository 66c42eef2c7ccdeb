/* Exit codes of the `vbnl` command (documented in `vbnl --help` and the README). */
#ifndef VBNL_HOST_EXIT_CODES_H
#define VBNL_HOST_EXIT_CODES_H

enum {
    VBNL_EXIT_OK = 0,
    VBNL_EXIT_FAILURE = 1,     /* the render or a file operation failed */
    VBNL_EXIT_USAGE = 2,       /* bad command line */
    VBNL_EXIT_SCENE = 3,       /* the scene could not be loaded */
    VBNL_EXIT_PLUGIN = 4,      /* the plugin module is missing or has another ABI */
    VBNL_EXIT_INTERRUPTED = 130,
};

#endif
