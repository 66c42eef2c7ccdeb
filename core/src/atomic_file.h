/* Atomic files (private header; never installed): every file the project writes goes through here,
 * the core's virtual-light files (vl_file.c) and the plugin's EXR and PNG images alike, so that one
 * signal-safe table knows every temporary file in progress.
 *
 * A write creates "<target>.tmp-XXXXXX" next to its target (same folder, so the rename is atomic)
 * with O_EXCL (concurrent writers never share one); the caller writes through `fd`; commit fsyncs,
 * closes and renames it over the target. On any failure the temporary is removed and an existing
 * file stays as it was: a reader never sees a half-written file. The target is `path`, or, when
 * `path` is a symbolic link, the file it names (the link stays a link). Only regular files are
 * replaced: an existing directory, device, FIFO or socket at the target is refused before
 * anything is created (an output never turns /dev/null into a file). A new file gets mode
 * 0666 & ~umask; a replaced one keeps its permission bits (a 0600 file stays 0600).
 *
 * While it exists, a temporary is listed in a fixed table of at most 16 (more are written
 * untracked), so that vbi_atomic_file_abandon_all can remove it from a signal handler (the
 * plugin's abandon_writes, a second Ctrl-C in the `vbnl` host). That table is the only
 * process-wide mutable state of the project: a signal handler cannot be handed a context.
 *
 * Errors: "cannot write '<path>': <reason>" in `err`; VBNL_ERR_IO (open, fsync, close or rename
 * failed), VBNL_ERR_OUT_OF_MEMORY, VBNL_ERR_CANCELLED (writes were abandoned).
 *
 * Threads: any number of atomic files may be open at once on any threads; one vbi_atomic_file is
 * used by one thread at a time.
 *
 * Test hook: after vbi_atomic_file_set_test_pause(1) (a context created with the test hook
 * VBNL_TEST_HOOK_PAUSE_WRITES, vbnl/render.h), every commit first says so on stderr ("vbnl: test
 * pause (write): '<tmp>' written, not yet renamed to '<path>'") and waits 30 s, so that a test
 * can interrupt a write at a known point (docs/tests.md). */
#ifndef VBI_ATOMIC_FILE_H
#define VBI_ATOMIC_FILE_H

#include "vbnl/result.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vbi_atomic_file {
    int fd;           /* -1 when not open */
    char *tmp_path;   /* malloc'ed */
    const char *path; /* borrowed from the caller of open: the name messages use */
    char *target;     /* malloc'ed: the file the rename replaces (path, or what its link names) */
    int slot;         /* its entry in the table of temporaries, -1 when untracked */
} vbi_atomic_file;

/* Creates the temporary file. On failure nothing needs discarding: VBNL_ERR_IO ("cannot write
 * '<path>': <errno text>", "... not a regular file", "... a symbolic link to a missing file"),
 * VBNL_ERR_OUT_OF_MEMORY or VBNL_ERR_CANCELLED. */
vbnl_result vbi_atomic_file_open(vbi_atomic_file *f, const char *path, vbnl_error *err);
/* fsyncs, closes and renames the temporary file over `path`; on failure behaves like discard. */
vbnl_result vbi_atomic_file_commit(vbi_atomic_file *f, vbnl_error *err);
/* Closes and removes the temporary file (if any). Safe to call twice. */
void vbi_atomic_file_discard(vbi_atomic_file *f);

/* For a signal handler just before _exit(): removes the temporary file of every atomic file of
 * this process that is open and not yet committed or discarded, on any thread. From then on every
 * open and commit fails with VBNL_ERR_CANCELLED and leaves no file (targets keep their previous
 * content, or stay absent); there is no way back. Async-signal-safe: lock-free atomics and
 * unlink() only, no lock, no allocation; it may wait while another thread is inside the open() or
 * rename() of a temporary (that thread blocks signals for those calls only). */
void vbi_atomic_file_abandon_all(void);

/* The test hook above, for the whole process (the table of temporaries is process-wide):
 * on != 0 turns it on, 0 off. Any thread. */
void vbi_atomic_file_set_test_pause(int on);

#ifdef __cplusplus
}
#endif
#endif
