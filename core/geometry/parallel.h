/* One loop over [0, n) cut into runs for the build's threads: the world's
 * triangles and the BVH's records are written this way, so that their
 * pages are first touched (and zeroed by the kernel) on every thread at
 * once rather than on one.
 *
 * Errors: none; a thread that cannot be started leaves its run to the
 * caller's thread, so every index is done exactly once either way. */
#ifndef RD_PARALLEL_H
#define RD_PARALLEL_H

#include <stddef.h>

typedef void (*rd_run_fn)(void *ctx, size_t first, size_t count);

/* fn over [0, n) in up to `threads` contiguous runs (at most 8), each of at
 * least min indices; returns when all are done. */
void rd_parallel_runs(size_t n, size_t min, int threads, rd_run_fn fn, void *ctx);

#endif
