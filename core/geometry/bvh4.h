/* The binary BVH collapsed to four children per node, whose four boxes a
 * ray tests at once with SIMD (AVX2 when the CPU has it, SSE2 otherwise,
 * chosen at run time, so one binary runs on any x86-64).
 *
 * The test is the binary BVH's robust slab test (bvh.h) done in four lanes
 * with the same double operations in the same order, so it accepts exactly
 * the boxes rd_bvh_box_hit accepts: a box is only a filter, and the hit
 * that shades is still found by the primitives' own tests.
 *
 * Ownership: rd_bvh4_build allocates, rd_bvh4_free releases. */
#ifndef RD_BVH4_H
#define RD_BVH4_H

#include <float.h>
#include <immintrin.h>
#include <stddef.h>
#include <stdint.h>

#include "bvh.h"

/* A walk pushes at most three more entries than it pops per level. */
#define RD_BVH4_STACK (3 * RD_BVH_STACK + 4)

/* 128 bytes. Boxes by axis, then child, so one load reads an axis of all
 * four; an unused slot has an empty box (lo +inf, hi -inf), which no ray
 * meets. */
typedef struct {
    float lo[3][4], hi[3][4];
    uint32_t child[4]; /* count 0: a node index; else the first index into prims */
    uint16_t count[4]; /* primitives of a leaf child; 0 for an inner one */
    /* Of a leaf of at most RD_BVH4_KINDS primitives, bit j set when its
     * j-th is a sphere (the world fills it in), so that its spheres and
     * its triangles are each tested by their own code without reading
     * their ids. */
    uint16_t spheres[4];
} rd_bvh4_node;

#define RD_BVH4_KINDS 16

typedef struct {
    rd_bvh4_node *nodes; /* the root is nodes[0] */
    size_t nnodes;
} rd_bvh4;

/* Collapses b (which keeps its prims array, shared by both). */
rd_error_code rd_bvh4_build(rd_bvh4 *w, const rd_bvh *b, rd_error *err);
void rd_bvh4_free(rd_bvh4 *w);

/* Which children of n the ray meets within [0, tmax]: bit i set for child
 * i, tnear[i] its entry distance. Inline, so that each traversal compiled
 * for an instruction set has its test in its loop. */
#define RD_BVH4_WIDEN (1.0 + 2.0 * (3 * DBL_EPSILON / 2) / (1 - 3 * DBL_EPSILON / 2))

static inline __attribute__((always_inline)) unsigned rd_bvh4_test_sse2(const rd_bvh4_node *n, const rd_bvh_ray *r,
                                                                        double tmax, double tnear[4])
{
    const double o[3] = {r->o.x, r->o.y, r->o.z}, inv[3] = {r->inv.x, r->inv.y, r->inv.z};
    __m128d t0[2] = {_mm_setzero_pd(), _mm_setzero_pd()}, t1[2] = {_mm_set1_pd(tmax), _mm_set1_pd(tmax)};
    __m128d in[2] = {_mm_castsi128_pd(_mm_set1_epi32(-1)), _mm_castsi128_pd(_mm_set1_epi32(-1))};
    const __m128d widen = _mm_set1_pd(RD_BVH4_WIDEN);
    for (int k = 0; k < 3; k++) {
        const float *lo = r->neg[k] ? n->hi[k] : n->lo[k], *hi = r->neg[k] ? n->lo[k] : n->hi[k];
        __m128d ok = _mm_set1_pd(o[k]), ik = _mm_set1_pd(inv[k]);
        for (int h = 0; h < 2; h++) {
            __m128d l = _mm_cvtps_pd(_mm_castpd_ps(_mm_load_sd((const double *)(const void *)(lo + 2 * h))));
            __m128d u = _mm_cvtps_pd(_mm_castpd_ps(_mm_load_sd((const double *)(const void *)(hi + 2 * h))));
            if (r->flat[k]) {
                /* A flat axis is never neg: lo and hi are not swapped. */
                in[h] = _mm_and_pd(in[h], _mm_and_pd(_mm_cmpge_pd(ok, l), _mm_cmple_pd(ok, u)));
                continue;
            }
            __m128d a = _mm_mul_pd(_mm_sub_pd(l, ok), ik);
            __m128d b = _mm_mul_pd(_mm_mul_pd(_mm_sub_pd(u, ok), ik), widen);
            /* maxpd and minpd return their second operand when the first
             * is NaN, as rd_bvh_box_hit's comparisons keep t0 and t1. */
            t0[h] = _mm_max_pd(a, t0[h]);
            t1[h] = _mm_min_pd(b, t1[h]);
        }
    }
    unsigned mask = 0;
    for (int h = 0; h < 2; h++) {
        _mm_storeu_pd(tnear + 2 * h, t0[h]);
        mask |= (unsigned)_mm_movemask_pd(_mm_and_pd(in[h], _mm_cmple_pd(t0[h], t1[h]))) << (2 * h);
    }
    return mask;
}

static inline __attribute__((always_inline, target("avx2"))) unsigned
rd_bvh4_test_avx2(const rd_bvh4_node *n, const rd_bvh_ray *r, double tmax, double tnear[4])
{
    const double o[3] = {r->o.x, r->o.y, r->o.z}, inv[3] = {r->inv.x, r->inv.y, r->inv.z};
    __m256d t0 = _mm256_setzero_pd(), t1 = _mm256_set1_pd(tmax);
    __m256d in = _mm256_castsi256_pd(_mm256_set1_epi32(-1));
    const __m256d widen = _mm256_set1_pd(RD_BVH4_WIDEN);
    for (int k = 0; k < 3; k++) {
        const float *lo = r->neg[k] ? n->hi[k] : n->lo[k], *hi = r->neg[k] ? n->lo[k] : n->hi[k];
        __m256d l = _mm256_cvtps_pd(_mm_loadu_ps(lo)), u = _mm256_cvtps_pd(_mm_loadu_ps(hi));
        __m256d ok = _mm256_set1_pd(o[k]), ik = _mm256_set1_pd(inv[k]);
        if (r->flat[k]) {
            in = _mm256_and_pd(in, _mm256_and_pd(_mm256_cmp_pd(ok, l, _CMP_GE_OQ), _mm256_cmp_pd(ok, u, _CMP_LE_OQ)));
            continue;
        }
        __m256d a = _mm256_mul_pd(_mm256_sub_pd(l, ok), ik);
        __m256d b = _mm256_mul_pd(_mm256_mul_pd(_mm256_sub_pd(u, ok), ik), widen);
        t0 = _mm256_max_pd(a, t0);
        t1 = _mm256_min_pd(b, t1);
    }
    _mm256_storeu_pd(tnear, t0);
    return (unsigned)_mm256_movemask_pd(_mm256_and_pd(in, _mm256_cmp_pd(t0, t1, _CMP_LE_OQ)));
}

/* A ray as the AVX2 walk tests it: origin and reciprocal broadcast once,
 * and per axis the byte offsets in a node of the near and far bounds, so
 * that the test has no branch. Only for rays without a flat axis
 * (rd_bvh_ray.flat); the others take rd_bvh4_test_avx2. */
typedef struct {
    __m256d o[3], inv[3];
    uint32_t near[3], far[3];
} rd_bvh4_ray_avx2;

static inline __attribute__((always_inline, target("avx2"))) void rd_bvh4_ray_avx2_make(const rd_bvh_ray *b,
                                                                                        rd_bvh4_ray_avx2 *q)
{
    const double o[3] = {b->o.x, b->o.y, b->o.z}, inv[3] = {b->inv.x, b->inv.y, b->inv.z};
    for (int k = 0; k < 3; k++) {
        uint32_t lo = (uint32_t)(offsetof(rd_bvh4_node, lo) + sizeof(float[4]) * (size_t)k);
        uint32_t hi = (uint32_t)(offsetof(rd_bvh4_node, hi) + sizeof(float[4]) * (size_t)k);
        q->o[k] = _mm256_set1_pd(o[k]);
        q->inv[k] = _mm256_set1_pd(inv[k]);
        q->near[k] = b->neg[k] ? hi : lo;
        q->far[k] = b->neg[k] ? lo : hi;
    }
}

/* rd_bvh4_test_avx2 for such a ray: the same operations in the same order
 * (a flat axis's mask is all ones), so the same boxes and entries. */
static inline __attribute__((always_inline, target("avx2"))) unsigned
rd_bvh4_test_avx2_ray(const rd_bvh4_node *n, const rd_bvh4_ray_avx2 *q, double tmax, double tnear[4])
{
    const char *base = (const char *)n;
    __m256d t0 = _mm256_setzero_pd(), t1 = _mm256_set1_pd(tmax);
    const __m256d widen = _mm256_set1_pd(RD_BVH4_WIDEN);
    for (int k = 0; k < 3; k++) {
        __m256d l = _mm256_cvtps_pd(_mm_loadu_ps((const float *)(const void *)(base + q->near[k])));
        __m256d u = _mm256_cvtps_pd(_mm_loadu_ps((const float *)(const void *)(base + q->far[k])));
        __m256d a = _mm256_mul_pd(_mm256_sub_pd(l, q->o[k]), q->inv[k]);
        __m256d b = _mm256_mul_pd(_mm256_mul_pd(_mm256_sub_pd(u, q->o[k]), q->inv[k]), widen);
        t0 = _mm256_max_pd(a, t0);
        t1 = _mm256_min_pd(b, t1);
    }
    _mm256_storeu_pd(tnear, t0);
    return (unsigned)_mm256_movemask_pd(_mm256_cmp_pd(t0, t1, _CMP_LE_OQ));
}

/* 1 when this CPU runs the AVX2 test. */
int rd_bvh4_cpu_has_avx2(void);

/* 1 when this CPU runs AVX-512 (packet.c's eight-ray node test). */
int rd_bvh4_cpu_has_avx512(void);

#endif
