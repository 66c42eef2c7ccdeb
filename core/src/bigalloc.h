/* Large scratch and data arrays on transparent huge pages (private header).
 *
 * The photon-splitting deposit and the VBNL gathers read the virtual lights' records, sums,
 * index listings and incident maps at random: tens to hundreds of megabytes. With 4 KB pages
 * nearly every such access also misses the TLB (a second-level TLB covers about 12 MB), so
 * arrays of at least VBI_BIG_ALLOC_MIN bytes are aligned to 2 MB and advised to the kernel as
 * huge-page candidates (madvise(MADV_HUGEPAGE); Linux with THP in "madvise" or "always" mode;
 * elsewhere, or when the kernel declines, they are ordinary pages and nothing else changes).
 * Freed with free(). */
#ifndef VBI_BIGALLOC_H
#define VBI_BIGALLOC_H

#include <stddef.h>

#define VBI_BIG_ALLOC_MIN ((size_t)2 << 20)

/* `bytes` bytes aligned to 64 (to 2 MB from VBI_BIG_ALLOC_MIN on), not initialised; NULL when
 * out of memory. */
void *vbi_big_alloc(size_t bytes);
/* The same, zeroed. */
void *vbi_big_calloc(size_t count, size_t size);

#endif
