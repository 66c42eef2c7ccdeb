/* The worker pool (core/src/pool.h): every item runs once on a worker of the pool, the caller
 * polls with growing counts (and sleeps between polls, also without a poll function), a poll can
 * cancel, items never run after a cancel is seen, 0 threads means one per core. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <pthread.h>
#include <stdatomic.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "pool.h"

typedef struct probe {
    atomic_int hits[10000];
    atomic_uint bad_thread; /* items run with a thread index out of range */
    unsigned threads;
    uint64_t stop_after;
    /* polls */
    pthread_t caller;
    int polls, not_caller, backwards;
    uint64_t last_finished, last_count;
} probe;

static void item(void *user, uint64_t i, unsigned thread)
{
    probe *p = user;
    atomic_fetch_add(&p->hits[i], 1);
    if (thread >= p->threads)
        atomic_fetch_add(&p->bad_thread, 1);
}

static void slow_item(void *user, uint64_t i, unsigned thread)
{
    item(user, i, thread);
    struct timespec ts = {0, 2000000};
    nanosleep(&ts, NULL);
}

static int poll_fn(void *user, uint64_t finished, uint64_t count)
{
    probe *p = user;
    p->polls++;
    p->not_caller += !pthread_equal(pthread_self(), p->caller);
    p->backwards += finished < p->last_finished;
    p->last_finished = finished;
    p->last_count = count;
    return p->stop_after && finished >= p->stop_after;
}

static probe g_probe;

static void reset(probe *p, unsigned threads)
{
    memset(p, 0, sizeof(*p));
    p->threads = threads;
    p->caller = pthread_self();
}

static void test_every_item_once(void **state)
{
    (void)state;
    vbi_pool *pool = vbi_pool_create(3);
    assert_non_null(pool);
    assert_int_equal(vbi_pool_thread_count(pool), 3);
    probe *p = &g_probe;
    reset(p, 3);
    for (int round = 0; round < 3; ++round)
        assert_int_equal(vbi_pool_run(pool, 10000, item, p, NULL, NULL, 0.1), 10000);
    for (int i = 0; i < 10000; ++i)
        assert_int_equal(atomic_load(&p->hits[i]), 3);
    assert_int_equal(atomic_load(&p->bad_thread), 0);
    vbi_pool_destroy(pool);
    vbi_pool_destroy(NULL);
    assert_int_equal(vbi_pool_thread_count(NULL), 0);
}

/* The caller polls on its own thread with finished counts that never go back, and a last time at
 * the end with every item finished; no items: one poll (0, 0). */
static void test_polls(void **state)
{
    (void)state;
    vbi_pool *pool = vbi_pool_create(2);
    probe *p = &g_probe;
    reset(p, 2);
    assert_int_equal(vbi_pool_run(pool, 100, slow_item, p, poll_fn, p, 0.01), 100);
    assert_true(p->polls >= 2); /* 100 items of 2 ms on 2 threads: ~100 ms, polls every 10 ms */
    assert_int_equal(p->not_caller, 0);
    assert_int_equal(p->backwards, 0);
    assert_int_equal(p->last_finished, 100);
    assert_int_equal(p->last_count, 100);
    reset(p, 2);
    assert_int_equal(vbi_pool_run(pool, 0, item, p, poll_fn, p, 0.01), 0);
    assert_int_equal(p->polls, 1);
    assert_int_equal(p->last_finished, 0);
    assert_int_equal(p->last_count, 0);
    vbi_pool_destroy(pool);
}

/* A poll that returns non-zero stops the handing out of items: the run returns how many ran,
 * exactly the items that ran once, and no item runs after it. */
static void test_cancel(void **state)
{
    (void)state;
    vbi_pool *pool = vbi_pool_create(3);
    probe *p = &g_probe;
    reset(p, 3);
    p->stop_after = 1;
    uint64_t ran = vbi_pool_run(pool, 2000, slow_item, p, poll_fn, p, 0.01);
    assert_true(ran < 2000);
    uint64_t counted = 0;
    for (int i = 0; i < 2000; ++i)
        counted += (uint64_t)atomic_load(&p->hits[i]);
    assert_int_equal(counted, ran);
    struct timespec ts = {0, 20000000};
    nanosleep(&ts, NULL); /* nothing still running adds to the counts */
    uint64_t later = 0;
    for (int i = 0; i < 2000; ++i)
        later += (uint64_t)atomic_load(&p->hits[i]);
    assert_int_equal(later, ran);
    /* the pool works again after a cancelled run */
    reset(p, 3);
    assert_int_equal(vbi_pool_run(pool, 50, item, p, NULL, NULL, 0.1), 50);
    vbi_pool_destroy(pool);
}

/* Without a poll function the caller sleeps until the workers are done (no timed wake-ups): its
 * thread's CPU time stays far below the run's wall time. */
static void test_caller_sleeps(void **state)
{
    (void)state;
    vbi_pool *pool = vbi_pool_create(1);
    probe *p = &g_probe;
    reset(p, 1);
    struct timespec c0, c1;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c0);
    double t0 = vbi_now();
    assert_int_equal(vbi_pool_run(pool, 60, slow_item, p, NULL, NULL, 0.001), 60);
    double wall = vbi_now() - t0;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c1);
    double cpu = (double)(c1.tv_sec - c0.tv_sec) + 1e-9 * (double)(c1.tv_nsec - c0.tv_nsec);
    print_message("# caller: %.1f ms of CPU over %.1f ms\n", 1e3 * cpu, 1e3 * wall);
    assert_true(wall >= 0.11);     /* 60 items of 2 ms on one worker */
    assert_true(cpu < 0.25 * wall); /* a spinning caller would use all of it */
    vbi_pool_destroy(pool);
}

/* 0 threads: one per online core. vbi_now: monotonic seconds. */
static void test_defaults(void **state)
{
    (void)state;
    vbi_pool *pool = vbi_pool_create(0);
    assert_non_null(pool);
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    assert_int_equal(vbi_pool_thread_count(pool), (unsigned)(n > 0 ? n : 1));
    vbi_pool_destroy(pool);
    double a = vbi_now();
    struct timespec ts = {0, 20000000};
    nanosleep(&ts, NULL);
    double b = vbi_now();
    assert_true(b - a >= 0.019 && b - a < 5.0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_item_once), cmocka_unit_test(test_polls),
        cmocka_unit_test(test_cancel),          cmocka_unit_test(test_caller_sleeps),
        cmocka_unit_test(test_defaults),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
