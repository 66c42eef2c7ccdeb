/* Large arrays on transparent huge pages: bigalloc.h. */
#include "bigalloc.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#if defined(__linux__)
#include <sys/mman.h>
#endif

void *vbi_big_alloc(size_t bytes)
{
    if (bytes < VBI_BIG_ALLOC_MIN)
        return aligned_alloc(64, (bytes + 63) & ~(size_t)63);
    const size_t huge = VBI_BIG_ALLOC_MIN;
    size_t rounded = (bytes + huge - 1) & ~(huge - 1);
    void *p = aligned_alloc(huge, rounded);
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    if (p)
        (void)madvise(p, rounded, MADV_HUGEPAGE); /* advice only: failure changes nothing */
#endif
    return p;
}

void *vbi_big_calloc(size_t count, size_t size)
{
    if (size && count > SIZE_MAX / size)
        return NULL;
    size_t bytes = count * size;
    void *p = vbi_big_alloc(bytes);
    if (p)
        memset(p, 0, bytes);
    return p;
}
