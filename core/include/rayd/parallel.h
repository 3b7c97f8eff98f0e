/* Work cut into pieces for threads that exist only for the call: the OBJ
 * reader's ranges, a big file's pieces, the world's triangles and the BVH's
 * records. Each piece runs once, whether or not its thread could be
 * started (one that cannot is run by the caller), and the call returns when
 * every piece is done. No errors: a piece reports its own through ctx. */
#ifndef RD_PARALLEL_H
#define RD_PARALLEL_H

#include <stddef.h>

/* At most this many pieces a call. */
enum { RD_PIECES_MAX = 16 };

/* fn(ctx, i) for i in [0, k) (k at most RD_PIECES_MAX): i = 0 on the
 * calling thread, the others each on a new one. */
void rd_run_each(int k, void (*fn)(void *ctx, int i), void *ctx);

/* fn over [0, n) in up to `threads` contiguous runs of at least min
 * indices each (one run when n < 2·min). */
typedef void (*rd_run_fn)(void *ctx, size_t first, size_t count);
void rd_parallel_runs(size_t n, size_t min, int threads, rd_run_fn fn, void *ctx);

#endif
