/* Files a scene names, kept to the naming file's folder and the folders the user opened
 * (pov_files.h). */
#ifndef _GNU_SOURCE
#define _GNU_SOURCE
#endif
#include "pov_files.h"

#include <errno.h>
#include <limits.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* True when a component of `name` is "..". */
static int climbs(const char *name)
{
    for (const char *c = name; *c;) {
        size_t n = strcspn(c, "/");
        if (n == 2 && c[0] == '.' && c[1] == '.')
            return 1;
        c += n;
        while (*c == '/')
            ++c;
    }
    return 0;
}

/* True when the canonical form of `path` lies inside the canonical folder `dir`. */
static int inside(const char *dir, const char *path)
{
    size_t n = strlen(dir);
    return !strncmp(path, dir, n) && (path[n] == '/' || (n == 1 && dir[0] == '/'));
}

int pov_file_name_escapes(const char *name) { return name[0] == '/' || climbs(name); }

/* The reason a name that leads to `real` (canonical; NULL when it does not resolve) is refused,
 * or NULL when it is allowed: inside the naming folder `cdir` by a name that stays there, or in a
 * folder the user opened to the scene. */
static const char *refusal(const vbnl_sdl_parser *p, const char *cdir, const char *real, const char *name,
                           pov_file_use use)
{
    int write = use == POV_FILE_WRITE;
    if (real && sdl_path_permitted(p, real, write))
        return NULL;
    if (name[0] == '/')
        return write ? "an absolute path: a scene writes inside its own folder and the folders opened to it with "
                       "--write-dir (give other paths on the command line)"
                     : "an absolute path: a scene names files inside its own folder and the folders opened to it "
                       "with --read-dir (give other paths on the command line)";
    if (climbs(name))
        return write ? "a path that leaves the scene's folder ('..'): a scene writes inside its own folder and the "
                       "folders opened to it with --write-dir"
                     : "a path that leaves the scene's folder ('..'): a scene names files inside its own folder and "
                       "the folders opened to it with --read-dir";
    if (real && (inside(cdir, real) || !strcmp(cdir, real)))
        return NULL;
    return "a path that a symbolic link carries out of the scene's folder";
}

char *pov_file_resolve(const vbnl_sdl_parser *p, const vbnl_sdl_loc *loc, const char *name, pov_file_use use,
                       const char **why)
{
    *why = NULL;
    if (!name[0]) {
        *why = "an empty file name";
        return NULL;
    }
    /* the naming file's folder, and the path as it names it */
    const char *file = loc && loc->file ? loc->file : "";
    const char *slash = strrchr(file, '/');
    size_t dl = slash ? (size_t)(slash - file) : 0;
    char *path = malloc(dl + 1 + strlen(name) + 1);
    char *dir = malloc(dl + 2);
    if (!path || !dir) {
        free(path);
        free(dir);
        *why = "out of memory";
        return NULL;
    }
    if (slash) {
        memcpy(dir, file, dl ? dl : 1);
        dir[dl ? dl : 1] = '\0';
    } else {
        strcpy(dir, ".");
    }
    if (name[0] == '/')
        strcpy(path, name);
    else if (slash) {
        memcpy(path, file, dl + 1);
        strcpy(path + dl + 1, name);
    } else {
        strcpy(path, name);
    }
    char cdir[PATH_MAX], cpath[PATH_MAX];
    if (!realpath(dir, cdir)) {
        *why = "a file in a folder that cannot be read";
    } else if (use == POV_FILE_WRITE) {
        struct stat st;
        if (lstat(path, &st) == 0 && S_ISLNK(st.st_mode))
            *why = "a symbolic link: a scene writes only plain files in its own folder and the folders opened to it";
        else {
            /* the folder the file goes into decides (a linked subfolder may lead out) */
            char *sub = strdup(path), *cut = sub ? strrchr(sub, '/') : NULL;
            if (!sub)
                *why = "out of memory";
            else {
                if (cut)
                    *cut = '\0';
                if (!realpath(cut ? (sub[0] ? sub : "/") : ".", cpath))
                    *why = pov_file_name_escapes(name) ? refusal(p, cdir, NULL, name, use)
                                                       : "a file in a folder that does not exist";
                else
                    *why = refusal(p, cdir, cpath, name, use);
                free(sub);
            }
        }
    } else if (!realpath(path, cpath)) {
        *why = pov_file_name_escapes(name) ? refusal(p, cdir, NULL, name, use)
               : errno == ENOENT           ? "a file that does not exist"
                                           : "a file that cannot be read";
    } else {
        *why = refusal(p, cdir, cpath, name, use);
    }
    free(dir);
    if (*why) {
        free(path);
        return NULL;
    }
    return path;
}
