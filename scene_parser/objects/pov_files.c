/* Files a scene names, kept to the naming file's folder (pov_files.h). */
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

char *pov_file_resolve(const vbnl_sdl_loc *loc, const char *name, pov_file_use use, const char **why)
{
    if (!name[0]) {
        *why = "an empty file name";
        return NULL;
    }
    if (name[0] == '/') {
        *why = "an absolute path: a scene names files inside its own folder (give other paths on the command line)";
        return NULL;
    }
    if (climbs(name)) {
        *why = "a path that leaves the scene's folder ('..'): a scene names files inside its own folder";
        return NULL;
    }
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
        memcpy(path, file, dl + 1);
        strcpy(path + dl + 1, name);
    } else {
        strcpy(dir, ".");
        strcpy(path, name);
    }
    char cdir[PATH_MAX], cpath[PATH_MAX];
    *why = NULL;
    if (!realpath(dir, cdir)) {
        *why = "a file in a folder that cannot be read";
    } else if (use == POV_FILE_WRITE) {
        struct stat st;
        if (lstat(path, &st) == 0 && S_ISLNK(st.st_mode))
            *why = "a symbolic link: a scene writes only plain files in its own folder";
        else {
            /* the folder the file goes into must itself stay inside (a linked subfolder) */
            char *sub = strdup(path), *cut = sub ? strrchr(sub, '/') : NULL;
            if (!sub)
                *why = "out of memory";
            else {
                if (cut)
                    *cut = '\0';
                if (!realpath(cut ? sub : ".", cpath))
                    *why = "a file in a folder that does not exist";
                else if (strcmp(cpath, cdir) != 0 && !inside(cdir, cpath))
                    *why = "a path that a symbolic link carries out of the scene's folder";
                free(sub);
            }
        }
    } else if (!realpath(path, cpath)) {
        *why = errno == ENOENT ? "a file that does not exist" : "a file that cannot be read";
    } else if (!inside(cdir, cpath)) {
        *why = "a path that a symbolic link carries out of the scene's folder";
    }
    free(dir);
    if (*why) {
        free(path);
        return NULL;
    }
    return path;
}
