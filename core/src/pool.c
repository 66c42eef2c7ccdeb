#include "pool.h"

#include <errno.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <time.h>
#include <unistd.h>

struct vbi_pool {
    unsigned thread_count;
    pthread_t *threads;
    pthread_mutex_t lock;
    pthread_cond_t work_cv;   /* workers wait for a new job */
    pthread_cond_t done_cv;   /* the caller waits for progress / completion */
    uint64_t generation;      /* bumped per job */
    int shutdown;
    /* the current job */
    vbi_pool_fn fn;
    void *user;
    uint64_t count;
    atomic_uint_fast64_t next;
    atomic_uint_fast64_t finished;
    atomic_int stop;
    unsigned active;          /* workers still inside the current job */
};

double vbi_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

typedef struct worker_arg {
    vbi_pool *pool;
    unsigned index;
} worker_arg;

static void *worker_main(void *p)
{
    worker_arg *arg = p;
    vbi_pool *pool = arg->pool;
    unsigned index = arg->index;
    free(arg);
    uint64_t seen = 0;
    pthread_mutex_lock(&pool->lock);
    for (;;) {
        while (!pool->shutdown && pool->generation == seen)
            pthread_cond_wait(&pool->work_cv, &pool->lock);
        if (pool->shutdown)
            break;
        seen = pool->generation;
        pthread_mutex_unlock(&pool->lock);
        for (;;) {
            if (atomic_load(&pool->stop))
                break;
            uint64_t item = atomic_fetch_add(&pool->next, 1);
            if (item >= pool->count)
                break;
            pool->fn(pool->user, item, index);
            atomic_fetch_add(&pool->finished, 1);
            pthread_mutex_lock(&pool->lock);
            pthread_cond_signal(&pool->done_cv);
            pthread_mutex_unlock(&pool->lock);
        }
        pthread_mutex_lock(&pool->lock);
        pool->active--;
        pthread_cond_signal(&pool->done_cv);
    }
    pthread_mutex_unlock(&pool->lock);
    return NULL;
}

vbi_pool *vbi_pool_create(unsigned threads)
{
    if (threads == 0) {
        long n = sysconf(_SC_NPROCESSORS_ONLN);
        threads = n > 0 ? (unsigned)n : 1u;
    }
    vbi_pool *pool = calloc(1, sizeof(*pool));
    if (!pool)
        return NULL;
    pool->threads = calloc(threads, sizeof(pthread_t));
    if (!pool->threads) {
        free(pool);
        return NULL;
    }
    pthread_mutex_init(&pool->lock, NULL);
    pthread_condattr_t attr;
    pthread_condattr_init(&attr);
    pthread_condattr_setclock(&attr, CLOCK_MONOTONIC);
    pthread_cond_init(&pool->done_cv, &attr);
    pthread_condattr_destroy(&attr);
    pthread_cond_init(&pool->work_cv, NULL);
    for (unsigned i = 0; i < threads; ++i) {
        worker_arg *arg = malloc(sizeof(*arg));
        if (arg) {
            arg->pool = pool;
            arg->index = i;
        }
        if (!arg || pthread_create(&pool->threads[i], NULL, worker_main, arg) != 0) {
            free(arg);
            pool->thread_count = i;
            vbi_pool_destroy(pool);
            return NULL;
        }
        pool->thread_count = i + 1;
    }
    return pool;
}

void vbi_pool_destroy(vbi_pool *pool)
{
    if (!pool)
        return;
    pthread_mutex_lock(&pool->lock);
    pool->shutdown = 1;
    pthread_cond_broadcast(&pool->work_cv);
    pthread_mutex_unlock(&pool->lock);
    for (unsigned i = 0; i < pool->thread_count; ++i)
        pthread_join(pool->threads[i], NULL);
    pthread_mutex_destroy(&pool->lock);
    pthread_cond_destroy(&pool->work_cv);
    pthread_cond_destroy(&pool->done_cv);
    free(pool->threads);
    free(pool);
}

unsigned vbi_pool_thread_count(const vbi_pool *pool) { return pool ? pool->thread_count : 0; }

uint64_t vbi_pool_run(vbi_pool *pool, uint64_t count, vbi_pool_fn fn, void *user,
                       vbi_pool_poll_fn poll, void *poll_user, double interval)
{
    if (count == 0) {
        if (poll)
            poll(poll_user, 0, 0);
        return 0;
    }
    if (interval <= 0.0)
        interval = 0.25;
    pthread_mutex_lock(&pool->lock);
    pool->fn = fn;
    pool->user = user;
    pool->count = count;
    atomic_store(&pool->next, 0);
    atomic_store(&pool->finished, 0);
    atomic_store(&pool->stop, 0);
    pool->active = pool->thread_count;
    pool->generation++;
    pthread_cond_broadcast(&pool->work_cv);
    double next_poll = vbi_now() + interval;
    while (pool->active > 0) {
        if (!poll) {
            /* nothing to report: sleep until a worker signals (no timed wake-ups) */
            pthread_cond_wait(&pool->done_cv, &pool->lock);
            continue;
        }
        struct timespec ts;
        double when = next_poll;
        ts.tv_sec = (time_t)when;
        ts.tv_nsec = (long)((when - (double)ts.tv_sec) * 1e9);
        int rc = pthread_cond_timedwait(&pool->done_cv, &pool->lock, &ts);
        if (rc == ETIMEDOUT || vbi_now() >= next_poll) {
            uint64_t fin = atomic_load(&pool->finished);
            pthread_mutex_unlock(&pool->lock);
            if (poll(poll_user, fin, count))
                atomic_store(&pool->stop, 1);
            pthread_mutex_lock(&pool->lock);
            next_poll = vbi_now() + interval;
        }
    }
    pthread_mutex_unlock(&pool->lock);
    uint64_t fin = atomic_load(&pool->finished);
    if (poll)
        poll(poll_user, fin, count);
    return fin;
}
