/* Opening a file to read it: regular files only, never blocking on the open (read_file.h). */
#ifndef _GNU_SOURCE
#define _GNU_SOURCE
#endif
#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <unistd.h>

#include "read_file.h"

/* Why a file of this type is not read, or NULL for a regular file. */
static const char *refusal(mode_t mode)
{
    if (S_ISREG(mode))
        return NULL;
    if (S_ISDIR(mode))
        return "it is a folder";
    if (S_ISFIFO(mode))
        return "it is a FIFO, not a regular file";
    if (S_ISSOCK(mode))
        return "it is a socket, not a regular file";
    if (S_ISCHR(mode) || S_ISBLK(mode))
        return "it is a device, not a regular file";
    return "not a regular file";
}

int vbi_read_open(const char *path, struct stat *st, const char **why)
{
    struct stat own;
    if (!st)
        st = &own;
    *why = NULL;
    /* a special file is refused before it is opened: opening some acts on them */
    if (stat(path, st) != 0) {
        *why = strerror(errno);
        return -1;
    }
    if ((*why = refusal(st->st_mode)) != NULL) {
        errno = S_ISDIR(st->st_mode) ? EISDIR : ENXIO;
        return -1;
    }
    /* the name may have changed since: an open that cannot wait, and the descriptor checked */
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
    if (fd < 0) {
        *why = strerror(errno);
        return -1;
    }
    int flags;
    if (fstat(fd, st) != 0 || (flags = fcntl(fd, F_GETFL)) < 0 || fcntl(fd, F_SETFL, flags & ~O_NONBLOCK) != 0) {
        int e = errno;
        close(fd);
        errno = e;
        *why = strerror(e);
        return -1;
    }
    if ((*why = refusal(st->st_mode)) != NULL) {
        close(fd);
        errno = S_ISDIR(st->st_mode) ? EISDIR : ENXIO;
        return -1;
    }
    return fd;
}

FILE *vbi_read_fopen(const char *path, struct stat *st, const char **why)
{
    int fd = vbi_read_open(path, st, why);
    if (fd < 0)
        return NULL;
    FILE *f = fdopen(fd, "rb");
    if (!f) {
        int e = errno;
        close(fd);
        errno = e;
        *why = strerror(e);
    }
    return f;
}
