/* Pieces of work on threads (rayd/parallel.h): every index once, runs
 * contiguous and covering [0, n), no more runs than asked or than min
 * allows. */
#include <criterion/criterion.h>
#include <stdatomic.h>
#include <string.h>

#include "rayd/parallel.h"

typedef struct {
    atomic_int hits[RD_PIECES_MAX];
} each_seen;

static void mark(void *ctx, int i)
{
    each_seen *s = ctx;
    atomic_fetch_add(&s->hits[i], 1);
}

Test(parallel, each_index_once)
{
    for (int k = 0; k <= RD_PIECES_MAX; k++) {
        each_seen s;
        for (int i = 0; i < RD_PIECES_MAX; i++)
            atomic_init(&s.hits[i], 0);
        rd_run_each(k, mark, &s);
        for (int i = 0; i < RD_PIECES_MAX; i++)
            cr_assert_eq(atomic_load(&s.hits[i]), i < k, "k=%d: index %d ran %d times", k, i, atomic_load(&s.hits[i]));
    }
}

typedef struct {
    atomic_int runs;
    unsigned char seen[100000];
} run_seen;

static void cover(void *ctx, size_t first, size_t count)
{
    run_seen *s = ctx;
    atomic_fetch_add(&s->runs, 1);
    for (size_t i = first; i < first + count; i++)
        s->seen[i]++;
}

static void check_runs(size_t n, size_t min, int threads, int want_runs)
{
    static run_seen s;
    memset(s.seen, 0, sizeof s.seen);
    atomic_init(&s.runs, 0);
    rd_parallel_runs(n, min, threads, cover, &s);
    cr_assert_eq(atomic_load(&s.runs), want_runs, "n=%zu min=%zu threads=%d: %d runs, expected %d", n, min, threads,
                 atomic_load(&s.runs), want_runs);
    for (size_t i = 0; i < n; i++)
        cr_assert_eq(s.seen[i], 1, "n=%zu threads=%d: index %zu done %d times", n, threads, i, s.seen[i]);
    for (size_t i = n; i < sizeof s.seen; i++)
        cr_assert_eq(s.seen[i], 0, "index %zu past n=%zu was done", i, n);
}

Test(parallel, runs_cover_once_within_their_bounds)
{
    check_runs(100000, 1000, 2, 2);
    check_runs(99999, 1000, 3, 3);
    check_runs(100000, 1000, 64, RD_PIECES_MAX);
    check_runs(1999, 1000, 2, 1);
    check_runs(2000, 1000, 2, 2);
    check_runs(5000, 1000, 8, 5);
    check_runs(7, 0, 4, 4);
    check_runs(0, 1000, 2, 1);
    check_runs(100, 10, 0, 1);
}
