/* Worker thread pool owned by a vbnl_context (private header).
 *
 * vbi_pool_run hands items 0..count-1 to the workers in increasing order (an atomic counter) and
 * blocks the calling thread, which meanwhile calls `poll` every `interval` seconds and once at the
 * end. When poll returns non-zero, or *cancel becomes non-zero, no further item is started; items
 * in flight finish. Results must not depend on which worker ran an item: that is what makes
 * renders deterministic for any thread count. */
#ifndef VBI_POOL_H
#define VBI_POOL_H

#include <stdint.h>

typedef struct vbi_pool vbi_pool;

/* Runs item `item` on worker `thread` (0 .. thread_count-1). */
typedef void (*vbi_pool_fn)(void *user, uint64_t item, unsigned thread);
/* Called on the calling thread with the number of finished items; non-zero cancels. */
typedef int (*vbi_pool_poll_fn)(void *user, uint64_t finished, uint64_t count);

vbi_pool *vbi_pool_create(unsigned threads);
void vbi_pool_destroy(vbi_pool *pool);
unsigned vbi_pool_thread_count(const vbi_pool *pool);

/* Returns the number of items that ran (count unless cancelled). */
uint64_t vbi_pool_run(vbi_pool *pool, uint64_t count, vbi_pool_fn fn, void *user,
                       vbi_pool_poll_fn poll, void *poll_user, double interval);

/* Monotonic seconds. */
double vbi_now(void);

#endif
