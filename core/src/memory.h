/* Large arrays read at random (private header).
 *
 * Rendering and photon splitting read the per-light arrays (render records, emission maps, the
 * light index) at random places: with 4 KiB pages an array of tens of megabytes misses the TLB
 * on nearly every access, on top of the cache miss. vbnl_alloc_large aligns arrays of at least
 * VBNL_LARGE_BYTES to 2 MiB and asks the kernel for transparent huge pages (madvise; a hint: with
 * huge pages off the memory is ordinary). Release with free(). Smaller arrays are only aligned
 * to a cache line. */
#ifndef VBNL_MEMORY_H
#define VBNL_MEMORY_H

#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

#define VBNL_LARGE_BYTES ((size_t)4 << 20)
#define VBNL_HUGE_PAGE ((size_t)2 << 20)

/* bytes rounded up to the alignment; NULL when out of memory (or bytes is 0) */
static inline void *vbnl_alloc_large(size_t bytes)
{
    if (bytes == 0)
        return NULL;
    if (bytes < VBNL_LARGE_BYTES)
        return aligned_alloc(64, (bytes + 63) & ~(size_t)63);
    size_t rounded = (bytes + VBNL_HUGE_PAGE - 1) & ~(VBNL_HUGE_PAGE - 1);
    void *p = aligned_alloc(VBNL_HUGE_PAGE, rounded);
#ifdef MADV_HUGEPAGE
    if (p)
        madvise(p, rounded, MADV_HUGEPAGE);
#endif
    return p;
}

/* vbnl_alloc_large, zero-filled */
static inline void *vbnl_calloc_large(size_t bytes)
{
    void *p = vbnl_alloc_large(bytes);
    if (p)
        memset(p, 0, bytes);
    return p;
}

#endif
