/* Write-to-temporary-then-rename, shared by the EXR and PNG writers. */
#ifndef _GNU_SOURCE
#define _GNU_SOURCE
#endif
#include <errno.h>
#include <fcntl.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "image_io.h"

static uint64_t vbnl_mix64(uint64_t x)
{
    /* splitmix64 finaliser */
    x += 0x9e3779b97f4a7c15ull;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
}

vbnl_result vbnl_atomic_file_open(vbnl_atomic_file *f, const char *path, vbnl_error *err)
{
    static const char digits[] = "0123456789abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ";
    f->fd = -1;
    f->path = path;
    size_t n = strlen(path);
    f->tmp_path = malloc(n + sizeof(".tmp-XXXXXX"));
    if (!f->tmp_path)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "cannot write '%s': out of memory", path);

    /* Not mkstemp: it creates mode 0600, and restoring 0666 & ~umask would need the process-wide
     * umask() (racy between threads). O_EXCL with our own suffix applies the umask naturally. */
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    uint64_t seed = vbnl_mix64(((uint64_t)ts.tv_sec << 32) ^ (uint64_t)ts.tv_nsec ^
                               ((uint64_t)getpid() << 16) ^ (uint64_t)(uintptr_t)f);
    int e = EEXIST;
    for (int attempt = 0; attempt < 100 && e == EEXIST; attempt++) {
        uint64_t r = vbnl_mix64(seed + (uint64_t)attempt);
        memcpy(f->tmp_path, path, n);
        memcpy(f->tmp_path + n, ".tmp-", 5);
        for (int i = 0; i < 6; i++, r /= 62)
            f->tmp_path[n + 5 + i] = digits[r % 62];
        f->tmp_path[n + 11] = '\0';
        f->fd = open(f->tmp_path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        e = f->fd < 0 ? errno : 0;
    }
    if (f->fd < 0) {
        free(f->tmp_path);
        f->tmp_path = NULL;
        return vbnl_error_set(err, VBNL_ERR_IO, "cannot write '%s': %s", path, strerror(e));
    }
    return VBNL_OK;
}

vbnl_result vbnl_atomic_file_commit(vbnl_atomic_file *f, vbnl_error *err)
{
    if (f->fd < 0 || !f->tmp_path)
        return vbnl_error_set(err, VBNL_ERR_IO, "cannot write '%s': file not open", f->path);
    /* fsync before rename, or a crash could leave a renamed but empty file. */
    if (fsync(f->fd) != 0) {
        int e = errno;
        vbnl_atomic_file_discard(f);
        return vbnl_error_set(err, VBNL_ERR_IO, "cannot write '%s': %s", f->path, strerror(e));
    }
    int fd = f->fd;
    f->fd = -1;
    if (close(fd) != 0) {
        int e = errno;
        vbnl_atomic_file_discard(f);
        return vbnl_error_set(err, VBNL_ERR_IO, "cannot write '%s': %s", f->path, strerror(e));
    }
    if (rename(f->tmp_path, f->path) != 0) {
        int e = errno;
        vbnl_atomic_file_discard(f);
        return vbnl_error_set(err, VBNL_ERR_IO, "cannot write '%s': %s", f->path, strerror(e));
    }
    free(f->tmp_path);
    f->tmp_path = NULL;
    return VBNL_OK;
}

void vbnl_atomic_file_discard(vbnl_atomic_file *f)
{
    if (f->fd >= 0) {
        close(f->fd);
        f->fd = -1;
    }
    if (f->tmp_path) {
        unlink(f->tmp_path);
        free(f->tmp_path);
        f->tmp_path = NULL;
    }
}
