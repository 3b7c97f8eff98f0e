#include "parallel.h"

#include <pthread.h>

enum { MAX_RUNS = 8 };

typedef struct {
    rd_run_fn fn;
    void *ctx;
    size_t first, count;
} run;

static void *run_main(void *arg)
{
    const run *r = arg;
    r->fn(r->ctx, r->first, r->count);
    return NULL;
}

void rd_parallel_runs(size_t n, size_t min, int threads, rd_run_fn fn, void *ctx)
{
    size_t k = threads < 1 ? 1 : (threads > MAX_RUNS ? MAX_RUNS : (size_t)threads);
    if (min > 0 && n / min < k)
        k = n / min ? n / min : 1;
    run rs[MAX_RUNS];
    pthread_t th[MAX_RUNS];
    int started[MAX_RUNS] = {0};
    for (size_t i = 0; i < k; i++)
        rs[i] = (run){fn, ctx, n / k * i, i == k - 1 ? n - n / k * i : n / k};
    for (size_t i = 1; i < k; i++)
        started[i] = pthread_create(&th[i], NULL, run_main, &rs[i]) == 0;
    run_main(&rs[0]);
    for (size_t i = 1; i < k; i++) {
        if (started[i])
            pthread_join(th[i], NULL);
        else
            run_main(&rs[i]);
    }
}
