/* Write-to-temporary-then-rename (atomic_file.h), shared by every file the project writes: the
 * virtual-light files of the core (vl_file.c) and the plugin's EXR and PNG writers; and the
 * registry of the temporary files in progress that lets a signal handler remove them before the
 * process ends. */
#ifndef _GNU_SOURCE
#define _GNU_SOURCE
#endif
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "atomic_file.h"

/* ---- the registry of temporary files in progress ------------------------------------------------
 *
 * A signal handler is given no context, so this table is the project's one piece of process-wide
 * mutable state (the style rule is "no globals"; a handler cannot be passed one). Being in the
 * core, it covers every file the core and the plugin write.
 * It has fixed-size slots and is walked by vbi_atomic_file_abandon_all() with lock-free atomics
 * and unlink() only, both async-signal-safe.
 *
 * A slot goes FREE -> BUSY (a writer claimed it) -> ARMED (its path names a temporary file this
 * process created) -> BUSY (the writer renames or removes it) -> FREE, or ARMED -> ABANDONED (the
 * handler removed it; final). Every change is a compare-and-swap or a store by the slot's owner.
 * BUSY covers only the open() of the temporary and its rename() or unlink(): the writer blocks
 * signals on its thread for that window, so a handler that finds a slot BUSY runs on another
 * thread and may wait for it (a few system calls). The handler never reads a path it has not won
 * by a compare-and-swap, so it never sees a half-copied one, and never removes a file that this
 * process did not create (a name taken by someone else, EEXIST, is never ARMED).
 *
 * g_abandoned is raised before the walk, and writers test it after they made their slot BUSY
 * (sequentially consistent on both sides): a writer either sees it and backs out, or the walk
 * sees its slot BUSY and waits for it. So no temporary file is created, and none is renamed into
 * place, once the walk has started. */

enum { VBI_SLOT_FREE, VBI_SLOT_BUSY, VBI_SLOT_ARMED, VBI_SLOT_ABANDONED };

#define VBI_ATOMIC_SLOTS 16

_Static_assert(ATOMIC_INT_LOCK_FREE == 2, "the signal-handler path needs lock-free atomic ints");

typedef struct vbi_temp_slot {
    atomic_int state;
    char path[PATH_MAX]; /* open() refuses longer paths (ENAMETOOLONG) */
} vbi_temp_slot;

static vbi_temp_slot g_temps[VBI_ATOMIC_SLOTS];
static atomic_int g_abandoned;

/* Blocks the asynchronous signals on this thread; faults stay deliverable (a fault while blocked
 * would kill the process without its handler). */
static void vbi_block_signals(sigset_t *old)
{
    sigset_t set;
    sigfillset(&set);
    sigdelset(&set, SIGSEGV);
    sigdelset(&set, SIGBUS);
    sigdelset(&set, SIGFPE);
    sigdelset(&set, SIGILL);
    sigdelset(&set, SIGTRAP);
    pthread_sigmask(SIG_BLOCK, &set, old);
}

static void vbi_restore_signals(const sigset_t *old)
{
    pthread_sigmask(SIG_SETMASK, old, NULL);
}

/* A FREE slot made BUSY, or -1 when every slot is taken or the path cannot fit (open() will fail
 * on such a path anyway). Signals must be blocked. */
static int vbi_slot_claim(size_t tmp_len)
{
    if (tmp_len >= PATH_MAX)
        return -1;
    for (int i = 0; i < VBI_ATOMIC_SLOTS; i++) {
        int expected = VBI_SLOT_FREE;
        if (atomic_compare_exchange_strong(&g_temps[i].state, &expected, VBI_SLOT_BUSY))
            return i;
    }
    return -1;
}

/* ARMED -> BUSY before the owner renames or removes its temporary. 0 when the handler took it
 * (ABANDONED: it removes the file). Signals must be blocked. */
static int vbi_slot_disarm(int slot)
{
    if (slot < 0)
        return 1;
    int expected = VBI_SLOT_ARMED;
    return atomic_compare_exchange_strong(&g_temps[slot].state, &expected, VBI_SLOT_BUSY);
}

static void vbi_slot_release(int slot)
{
    if (slot >= 0)
        atomic_store(&g_temps[slot].state, VBI_SLOT_FREE);
}

void vbi_atomic_file_abandon_all(void)
{
    atomic_store(&g_abandoned, 1);
    for (int i = 0; i < VBI_ATOMIC_SLOTS; i++) {
        for (;;) {
            int s = atomic_load(&g_temps[i].state);
            if (s == VBI_SLOT_BUSY)
                continue; /* another thread is inside open() or rename(), signals blocked */
            if (s != VBI_SLOT_ARMED)
                break;
            int expected = VBI_SLOT_ARMED;
            if (atomic_compare_exchange_strong(&g_temps[i].state, &expected, VBI_SLOT_ABANDONED)) {
                unlink(g_temps[i].path);
                break;
            }
        }
    }
}

/* ---- test hook ------------------------------------------------------------------------------------
 * The pause of VBNL_TEST_HOOK_PAUSE_WRITES (atomic_file.h): every commit (EXR, PNG, virtual-light
 * file) waits 30 s with its temporary file complete and not yet renamed, after saying so on
 * stderr, so that a test can interrupt a write at a known point without depending on timing. */
static atomic_int g_test_pause;

void vbi_atomic_file_set_test_pause(int on) { atomic_store(&g_test_pause, on != 0); }

static void vbi_test_pause_in_write(const vbi_atomic_file *f)
{
    if (!atomic_load(&g_test_pause))
        return;
    fprintf(stderr, "vbnl: test pause (write): '%s' written, not yet renamed to '%s'\n", f->tmp_path, f->path);
    struct timespec left = {30, 0};
    while (nanosleep(&left, &left) != 0 && errno == EINTR) {
    }
}

/* ---- atomic files ---------------------------------------------------------------------------------- */

static uint64_t vbi_mix64(uint64_t x)
{
    /* splitmix64 finaliser */
    x += 0x9e3779b97f4a7c15ull;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
}

static vbnl_result vbi_abandoned_error(vbnl_error *err, const char *path)
{
    return vbnl_error_set(err, VBNL_ERR_CANCELLED, "cannot write '%s': writes were abandoned (the process is ending)",
                          path);
}

vbnl_result vbi_atomic_file_open(vbi_atomic_file *f, const char *path, vbnl_error *err)
{
    static const char digits[] = "0123456789abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ";
    f->fd = -1;
    f->slot = -1;
    f->path = path;
    f->target = NULL;
    f->tmp_path = NULL;
    /* What the rename will replace: a link's file, never the link; nothing but a regular file. */
    struct stat st;
    int replaces = 0;
    mode_t keep_mode = 0;
    if (lstat(path, &st) == 0) {
        if (S_ISLNK(st.st_mode)) {
            f->target = realpath(path, NULL);
            if (!f->target) {
                int e = errno;
                return vbnl_error_set(err, e == ENOMEM ? VBNL_ERR_OUT_OF_MEMORY : VBNL_ERR_IO,
                                      e == ENOENT ? "cannot write '%s': it is a symbolic link to a missing file"
                                                  : "cannot write '%s': %s",
                                      path, strerror(e));
            }
            if (stat(f->target, &st) != 0) {
                int e = errno;
                free(f->target);
                f->target = NULL;
                return vbnl_error_set(err, VBNL_ERR_IO, "cannot write '%s': %s", path, strerror(e));
            }
        }
        if (!S_ISREG(st.st_mode)) {
            free(f->target);
            f->target = NULL;
            return vbnl_error_set(err, VBNL_ERR_IO,
                                  S_ISDIR(st.st_mode) ? "cannot write '%s': it is a folder"
                                                      : "cannot write '%s': not a regular file (a device, FIFO or "
                                                        "socket is never replaced)",
                                  path);
        }
        replaces = 1;
        keep_mode = st.st_mode & 0777;
    }
    if (!f->target && !(f->target = strdup(path)))
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "cannot write '%s': out of memory", path);
    const char *target = f->target;
    size_t n = strlen(target);
    f->tmp_path = malloc(n + sizeof(".tmp-XXXXXX"));
    if (!f->tmp_path) {
        free(f->target);
        f->target = NULL;
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "cannot write '%s': out of memory", path);
    }

    /* Not mkstemp: it creates mode 0600, and restoring 0666 & ~umask would need the process-wide
     * umask() (racy between threads). O_EXCL with our own suffix applies the umask naturally. */
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    uint64_t seed = vbi_mix64(((uint64_t)ts.tv_sec << 32) ^ (uint64_t)ts.tv_nsec ^
                               ((uint64_t)getpid() << 16) ^ (uint64_t)(uintptr_t)f);

    /* Created and registered with signals blocked: a handler never sees the file without its slot. */
    sigset_t old;
    vbi_block_signals(&old);
    int slot = vbi_slot_claim(n + sizeof(".tmp-XXXXXX") - 1);
    if (atomic_load(&g_abandoned)) {
        vbi_slot_release(slot);
        vbi_restore_signals(&old);
        free(f->tmp_path);
        f->tmp_path = NULL;
        free(f->target);
        f->target = NULL;
        return vbi_abandoned_error(err, path);
    }
    int e = EEXIST;
    for (int attempt = 0; attempt < 100 && e == EEXIST; attempt++) {
        uint64_t r = vbi_mix64(seed + (uint64_t)attempt);
        memcpy(f->tmp_path, target, n);
        memcpy(f->tmp_path + n, ".tmp-", 5);
        for (int i = 0; i < 6; i++, r /= 62)
            f->tmp_path[n + 5 + i] = digits[r % 62];
        f->tmp_path[n + 11] = '\0';
        f->fd = open(f->tmp_path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        e = f->fd < 0 ? errno : 0;
    }
    if (f->fd >= 0 && slot >= 0) {
        memcpy(g_temps[slot].path, f->tmp_path, n + sizeof(".tmp-XXXXXX"));
        atomic_store(&g_temps[slot].state, VBI_SLOT_ARMED);
        f->slot = slot;
    } else {
        vbi_slot_release(slot);
    }
    vbi_restore_signals(&old);
    if (f->fd < 0) {
        free(f->tmp_path);
        f->tmp_path = NULL;
        free(f->target);
        f->target = NULL;
        return vbnl_error_set(err, VBNL_ERR_IO, "cannot write '%s': %s", path, strerror(e));
    }
    /* A replaced file keeps its permission bits (the umask applies only to new files). */
    if (replaces && fchmod(f->fd, keep_mode) != 0) {
        int ce = errno;
        vbi_atomic_file_discard(f);
        return vbnl_error_set(err, VBNL_ERR_IO, "cannot write '%s': %s", path, strerror(ce));
    }
    return VBNL_OK;
}

vbnl_result vbi_atomic_file_commit(vbi_atomic_file *f, vbnl_error *err)
{
    if (f->fd < 0 || !f->tmp_path)
        return vbnl_error_set(err, VBNL_ERR_IO, "cannot write '%s': file not open", f->path);
    vbi_test_pause_in_write(f);
    /* fsync before rename, or a crash could leave a renamed but empty file. */
    if (fsync(f->fd) != 0) {
        int e = errno;
        vbi_atomic_file_discard(f);
        return vbnl_error_set(err, VBNL_ERR_IO, "cannot write '%s': %s", f->path, strerror(e));
    }
    int fd = f->fd;
    f->fd = -1;
    if (close(fd) != 0) {
        int e = errno;
        vbi_atomic_file_discard(f);
        return vbnl_error_set(err, VBNL_ERR_IO, "cannot write '%s': %s", f->path, strerror(e));
    }
    sigset_t old;
    vbi_block_signals(&old);
    if (!vbi_slot_disarm(f->slot)) {
        /* abandoned: the walk has removed the temporary file */
        vbi_restore_signals(&old);
        f->slot = -1;
        free(f->tmp_path);
        f->tmp_path = NULL;
        free(f->target);
        f->target = NULL;
        return vbi_abandoned_error(err, f->path);
    }
    int e = 0;
    if (atomic_load(&g_abandoned))
        e = -1; /* the walk started after we took the slot: nothing may be renamed into place now */
    else if (rename(f->tmp_path, f->target) != 0)
        e = errno;
    if (e != 0)
        unlink(f->tmp_path);
    vbi_slot_release(f->slot);
    vbi_restore_signals(&old);
    f->slot = -1;
    free(f->tmp_path);
    f->tmp_path = NULL;
    free(f->target);
    f->target = NULL;
    if (e < 0)
        return vbi_abandoned_error(err, f->path);
    if (e > 0)
        return vbnl_error_set(err, VBNL_ERR_IO, "cannot write '%s': %s", f->path, strerror(e));
    return VBNL_OK;
}

void vbi_atomic_file_discard(vbi_atomic_file *f)
{
    if (f->fd >= 0) {
        close(f->fd);
        f->fd = -1;
    }
    if (f->tmp_path) {
        sigset_t old;
        vbi_block_signals(&old);
        if (vbi_slot_disarm(f->slot)) { /* else abandoned: the walk removed it */
            unlink(f->tmp_path);
            vbi_slot_release(f->slot);
        }
        vbi_restore_signals(&old);
        f->slot = -1;
        free(f->tmp_path);
        f->tmp_path = NULL;
    }
    free(f->target);
    f->target = NULL;
}
