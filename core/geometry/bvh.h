/* A bounding volume hierarchy over bounded primitives (spheres, triangles):
 * binned SAH build (Wald, "On fast Construction of SAH-based Bounding Volume
 * Hierarchies", IEEE RT 2007), flattened depth-first with the left child
 * next to its parent, traversed near child first.
 *
 * Ownership: rd_bvh_build allocates, rd_bvh_free releases. */
#ifndef RD_BVH_H
#define RD_BVH_H

#include <emmintrin.h>
#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "ray.h"
#include "rayd/error.h"

/* Entries of a traversal stack: the builder keeps every leaf shallower than
 * RD_BVH_STACK - 8, so a depth-first walk pushing one node per level (and
 * two at the last) never overflows a stack of this size. */
#define RD_BVH_STACK 128

/* 32 bytes. Bounds are floats rounded outward from the double bounds, so a
 * box always contains its primitives. */
typedef struct {
    float lo[3], hi[3];
    uint32_t offset; /* leaf: first index into prims; inner: right child */
    uint16_t count;  /* leaf: primitive count; inner: 0 */
    uint16_t axis;   /* inner: split axis, for near-first order */
} rd_bvh_node;

typedef struct {
    rd_bvh_node *nodes;
    size_t nnodes;
    uint32_t *prims; /* primitive ids in leaf order */
    size_t nprims;
} rd_bvh;

/* Builds over n primitives whose double bounds are lo[i], hi[i]. */
rd_error_code rd_bvh_build(rd_bvh *b, const rd_vec3 *lo, const rd_vec3 *hi, size_t n, rd_error *err);

/* The same on up to `threads` threads: subtrees are built apart and joined
 * in depth-first order, so the tree is the one rd_bvh_build makes. */
rd_error_code rd_bvh_build_threads(rd_bvh *b, const rd_vec3 *lo, const rd_vec3 *hi, size_t n, int threads,
                                   rd_error *err);
/* The same with the bounds asked for in runs: fn writes the double bounds
 * of primitives [first, first + count) (count at most RD_BVH_RUN) into lo
 * and hi. It is called from up to `threads` threads at once, on disjoint
 * runs, so a big scene needs no array of all its bounds. */
enum { RD_BVH_RUN = 256 };
typedef void (*rd_bvh_bounds_fn)(const void *ctx, size_t first, size_t count, rd_vec3 *lo, rd_vec3 *hi);
rd_error_code rd_bvh_build_from(rd_bvh *b, size_t n, rd_bvh_bounds_fn fn, const void *ctx, int threads, rd_error *err);
void rd_bvh_free(rd_bvh *b);

/* Precomputed for slab tests: 1/d, and for a zero direction component a
 * flag: such a ray is inside that slab for every t when its origin is
 * (faces included), and never otherwise. No 0·∞ = NaN can arise. */
typedef struct {
    rd_vec3 o, inv;
    int neg[3];
    int flat[3]; /* direction component exactly 0: the slab is all or nothing */
} rd_bvh_ray;

/* Inline, the divisions two at a time: every ray of a BVH walk starts
 * here. IEEE division gives each lane the bits the scalar 1/d gives. */
static inline rd_bvh_ray rd_bvh_ray_make(rd_ray r)
{
    rd_bvh_ray b;
    b.o = r.o;
    double d[3] = {r.d.x, r.d.y, r.d.z}, inv[3];
    _mm_storeu_pd(inv, _mm_div_pd(_mm_set1_pd(1.0), _mm_loadu_pd(d)));
    inv[2] = 1.0 / d[2];
    for (int k = 0; k < 3; k++) {
        b.flat[k] = d[k] == 0;
        if (b.flat[k])
            inv[k] = 0;
        /* A subnormal component overflows 1/d: huge but finite keeps the
         * products free of NaN. */
        else if (!(fabs(inv[k]) <= DBL_MAX))
            inv[k] = copysign(DBL_MAX, d[k]);
        b.neg[k] = inv[k] < 0;
    }
    b.inv = v3(inv[0], inv[1], inv[2]);
    return b;
}

/* Whether the ray meets node n's box within [0, tmax]; *tnear gets the
 * entry. Robust slab test (Ize, "Robust BVH Ray Traversal", JCGT 2(2),
 * 2013): the far distance is widened by 1 + 2γ(3), so rounding never drops
 * a box the ray touches. Inline: it is the hottest function of a mesh
 * render. */
static inline int rd_bvh_box_hit(const rd_bvh_node *n, const rd_bvh_ray *r, double tmax, double *tnear)
{
    const double widen = 1.0 + 2.0 * (3 * DBL_EPSILON / 2) / (1 - 3 * DBL_EPSILON / 2);
    double t0 = 0, t1 = tmax;
    const double o[3] = {r->o.x, r->o.y, r->o.z}, inv[3] = {r->inv.x, r->inv.y, r->inv.z};
    for (int k = 0; k < 3; k++) {
        if (r->flat[k]) {
            if (o[k] < n->lo[k] || o[k] > n->hi[k]) {
                *tnear = INFINITY;
                return 0;
            }
            continue;
        }
        double lo = r->neg[k] ? n->hi[k] : n->lo[k];
        double hi = r->neg[k] ? n->lo[k] : n->hi[k];
        double a = (lo - o[k]) * inv[k];
        double b = (hi - o[k]) * inv[k] * widen;
        t0 = a > t0 ? a : t0;
        t1 = b < t1 ? b : t1;
    }
    *tnear = t0;
    return t0 <= t1;
}

#endif
