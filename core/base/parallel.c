#include "rayd/parallel.h"

#include <pthread.h>

typedef struct {
    void (*fn)(void *ctx, int i);
    void *ctx;
    int i;
} piece;

static void *piece_main(void *arg)
{
    const piece *p = arg;
    p->fn(p->ctx, p->i);
    return NULL;
}

void rd_run_each(int k, void (*fn)(void *ctx, int i), void *ctx)
{
    if (k > RD_PIECES_MAX)
        k = RD_PIECES_MAX;
    piece ps[RD_PIECES_MAX];
    pthread_t th[RD_PIECES_MAX];
    int started[RD_PIECES_MAX] = {0};
    for (int i = 0; i < k; i++)
        ps[i] = (piece){fn, ctx, i};
    for (int i = 1; i < k; i++)
        started[i] = pthread_create(&th[i], NULL, piece_main, &ps[i]) == 0;
    if (k > 0)
        fn(ctx, 0);
    for (int i = 1; i < k; i++) {
        if (started[i])
            pthread_join(th[i], NULL);
        else
            fn(ctx, i);
    }
}

typedef struct {
    rd_run_fn fn;
    void *ctx;
    size_t n, k;
} runs;

static void one_run(void *arg, int i)
{
    const runs *r = arg;
    size_t first = r->n / r->k * (size_t)i;
    r->fn(r->ctx, first, (size_t)i == r->k - 1 ? r->n - first : r->n / r->k);
}

void rd_parallel_runs(size_t n, size_t min, int threads, rd_run_fn fn, void *ctx)
{
    size_t k = threads < 1 ? 1 : (threads > RD_PIECES_MAX ? RD_PIECES_MAX : (size_t)threads);
    if (min > 0 && n / min < k)
        k = n / min ? n / min : 1;
    runs r = {fn, ctx, n, k};
    rd_run_each((int)k, one_run, &r);
}
