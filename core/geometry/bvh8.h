/* The binary BVH collapsed to eight children per node (256 bytes, Embree's
 * layout), whose inner boxes a ray tests in float, eight at once, with AVX2.
 *
 * The float test only filters: it accepts every box the robust double slab
 * test (bvh.h) accepts, and its entry is never beyond the double one. Each
 * ray's margin makes it so: per axis, M = 2^-21·(R + |o|)·|1/d| + 2^-120,
 * where R bounds every box coordinate on that axis (the root's), is folded
 * into the constants of a·x + c, rounded outward to float once per ray.
 * The errors it covers: 1/d rounded to float (2^-24 relative), the product
 * and the sum rounded (2^-24 each of values below (R + |o|)·|1/d| + M),
 * the double test's own two roundings (2^-52) and its far widening
 * (4.5e-16); 8·2^-24 exceeds their sum, and 2^-120 the absolute error of
 * values in the subnormal range. So a leaf the double walk reaches has
 * every ancestor accepted here, and a box skipped for entering beyond the
 * cut holds nothing that wins (prim.h): the walk's answers are the double
 * walk's. Leaves are still decided by the double test, which also gives
 * their floors.
 *
 * Rays the margin cannot cover use the double walk: a flat axis (d = 0),
 * |1/d| beyond [2^-100, 2^100], or M beyond 2^100 (R infinite: a scene
 * beyond float range). rd_bvh8_ray_make says which.
 *
 * Ownership: rd_bvh8_build allocates, rd_bvh8_free releases. */
#ifndef RD_BVH8_H
#define RD_BVH8_H

#include <immintrin.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "bvh.h"

/* A walk pushes at most seven more entries than it pops per level. */
#define RD_BVH8_STACK (7 * RD_BVH_STACK + 8)

/* Boxes by axis, then child; an unused slot has an empty box (lo +inf,
 * hi -inf), which the float test rejects (its values are infinite, never
 * NaN, for the rays it takes). */
typedef struct {
    float lo[3][8], hi[3][8];
    uint32_t child[8]; /* count 0: a node index; else the first index into prims */
    uint16_t count[8]; /* primitives of a leaf child; 0 for an inner one */
    uint32_t pad[4];
} rd_bvh8_node;

typedef struct {
    rd_bvh8_node *nodes; /* the root is nodes[0] */
    size_t nnodes;
    double r[3]; /* per axis, the largest |coordinate| of any box */
} rd_bvh8;

/* Collapses b (which keeps its prims array, shared). */
rd_error_code rd_bvh8_build(rd_bvh8 *t, const rd_bvh *b, rd_error *err);
void rd_bvh8_free(rd_bvh8 *t);

/* A ray as the float test takes it. */
typedef struct {
    __m256 inv[3], near_c[3], far_c[3];
    uint32_t near[3], far[3]; /* byte offsets in a node of the near and far bounds */
} rd_bvh8_ray;

/* The float just below (down) or above x, unless x is exactly one. */
static inline float rd_float_out(double x, int up)
{
    float f = (float)x;
    if (up ? (double)f >= x : (double)f <= x)
        return f;
    uint32_t bits;
    memcpy(&bits, &f, sizeof bits);
    if (f == 0)
        bits = up ? 1u : 0x80000001u;
    else
        bits += ((f > 0) == up) ? 1u : (uint32_t)-1;
    memcpy(&f, &bits, sizeof f);
    return f;
}

/* 1 and q filled when the float test covers this ray; 0 when it must take
 * the double walk. */
static inline __attribute__((always_inline, target("avx2"))) int rd_bvh8_ray_make(const rd_bvh8 *t, const rd_bvh_ray *b,
                                                                                  rd_bvh8_ray *q)
{
    const double o[3] = {b->o.x, b->o.y, b->o.z}, inv[3] = {b->inv.x, b->inv.y, b->inv.z};
    for (int k = 0; k < 3; k++) {
        double ai = fabs(inv[k]);
        double m = 0x1p-21 * (t->r[k] + fabs(o[k])) * ai + 0x1p-120;
        if (b->flat[k] || !(ai <= 0x1p100 && ai >= 0x1p-100) || !(m <= 0x1p100))
            return 0;
        double c = -o[k] * inv[k];
        q->inv[k] = _mm256_set1_ps((float)inv[k]);
        q->near_c[k] = _mm256_set1_ps(rd_float_out(c - m, 0));
        q->far_c[k] = _mm256_set1_ps(rd_float_out(c + m, 1));
        uint32_t lo = (uint32_t)(offsetof(rd_bvh8_node, lo) + sizeof(float[8]) * (size_t)k);
        uint32_t hi = (uint32_t)(offsetof(rd_bvh8_node, hi) + sizeof(float[8]) * (size_t)k);
        q->near[k] = b->neg[k] ? hi : lo;
        q->far[k] = b->neg[k] ? lo : hi;
    }
    return 1;
}

/* Which children of n the ray may meet within [0, tmax] (a float at or
 * above the double tmax): bit i for child i, tnear[i] at or before its
 * double entry. */
static inline __attribute__((always_inline, target("avx2"))) unsigned
rd_bvh8_test(const rd_bvh8_node *n, const rd_bvh8_ray *q, float tmax, float tnear[8])
{
    const char *base = (const char *)n;
    __m256 t0 = _mm256_setzero_ps(), t1 = _mm256_set1_ps(tmax);
    for (int k = 0; k < 3; k++) {
        __m256 l = _mm256_loadu_ps((const float *)(const void *)(base + q->near[k]));
        __m256 u = _mm256_loadu_ps((const float *)(const void *)(base + q->far[k]));
        t0 = _mm256_max_ps(_mm256_add_ps(_mm256_mul_ps(l, q->inv[k]), q->near_c[k]), t0);
        t1 = _mm256_min_ps(_mm256_add_ps(_mm256_mul_ps(u, q->inv[k]), q->far_c[k]), t1);
    }
    _mm256_storeu_ps(tnear, t0);
    return (unsigned)_mm256_movemask_ps(_mm256_cmp_ps(t0, t1, _CMP_LE_OQ));
}

/* The double test of child i's box (a leaf's), as rd_bvh_box_hit does it. */
static inline int rd_bvh8_leaf_hit(const rd_bvh8_node *n, int i, const rd_bvh_ray *r, double tmax, double *tnear)
{
    rd_bvh_node box;
    for (int k = 0; k < 3; k++) {
        box.lo[k] = n->lo[k][i];
        box.hi[k] = n->hi[k][i];
    }
    return rd_bvh_box_hit(&box, r, tmax, tnear);
}

#endif
