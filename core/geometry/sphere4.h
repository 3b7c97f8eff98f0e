/* Four spheres tested at once (AVX2): rd_sphere_intersect's operations in
 * its order in each lane (IEEE division and square root give a lane the
 * bits the scalar code gets), up to the choice between the two roots,
 * which waits for each sphere's tmax: a closest-hit search shrinks it
 * from one sphere to the next.
 *
 * Ownership: the world makes the packs (rd_sphere4_pack) and frees them. */
#ifndef RD_SPHERE4_H
#define RD_SPHERE4_H

#include <immintrin.h>
#include <stddef.h>

#include "sphere.h"

/* Spheres 4k to 4k + 3 by coordinate; a lane past the last has a NaN
 * radius, which no ray hits. */
typedef struct rd_sphere4_s {
    double cx[4], cy[4], cz[4], r[4];
} rd_sphere4;

/* ceil(n / 4) packs of s[0..n) into out (the caller's). */
void rd_sphere4_pack(const rd_sphere *s, size_t n, rd_sphere4 *out);

/* The two roots of each lane, t0 <= t1 as the scalar test orders them;
 * bit i of the result set when lane i has roots to choose from. */
typedef struct {
    double t0[4], t1[4];
} rd_sphere4_roots;

/* The same from four spheres whose centres and radii are at cx[0..4),
 * cy[0..4), cz[0..4) and r[0..4), wherever those lie. */
static inline __attribute__((always_inline, target("avx2"))) unsigned
rd_sphere4_roots_at(const double *cx, const double *cy, const double *cz, const double *rad, const rd_ray *ray,
                    rd_sphere4_roots *out)
{
    const __m256d sign = _mm256_set1_pd(-0.0);
    __m256d dx = _mm256_set1_pd(ray->d.x), dy = _mm256_set1_pd(ray->d.y), dz = _mm256_set1_pd(ray->d.z);
    __m256d fx = _mm256_sub_pd(_mm256_set1_pd(ray->o.x), _mm256_loadu_pd(cx));
    __m256d fy = _mm256_sub_pd(_mm256_set1_pd(ray->o.y), _mm256_loadu_pd(cy));
    __m256d fz = _mm256_sub_pd(_mm256_set1_pd(ray->o.z), _mm256_loadu_pd(cz));
    __m256d r = _mm256_loadu_pd(rad);
    double aa = ray->d.x * ray->d.x + ray->d.y * ray->d.y + ray->d.z * ray->d.z;
    __m256d a = _mm256_set1_pd(aa);
    __m256d b = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(fx, dx), _mm256_mul_pd(fy, dy)), _mm256_mul_pd(fz, dz));
    __m256d ba = _mm256_div_pd(b, a);
    __m256d lx = _mm256_sub_pd(fx, _mm256_mul_pd(dx, ba)), ly = _mm256_sub_pd(fy, _mm256_mul_pd(dy, ba));
    __m256d lz = _mm256_sub_pd(fz, _mm256_mul_pd(dz, ba));
    __m256d len = _mm256_sqrt_pd(
        _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(lx, lx), _mm256_mul_pd(ly, ly)), _mm256_mul_pd(lz, lz)));
    __m256d disc = _mm256_mul_pd(_mm256_mul_pd(a, _mm256_sub_pd(r, len)), _mm256_add_pd(r, len));
    __m256d root = _mm256_sqrt_pd(disc);
    /* copysign(root, b), then -b - it. */
    __m256d signed_root = _mm256_or_pd(_mm256_andnot_pd(sign, root), _mm256_and_pd(sign, b));
    __m256d q = _mm256_sub_pd(_mm256_xor_pd(b, sign), signed_root);
    __m256d c =
        _mm256_sub_pd(_mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(fx, fx), _mm256_mul_pd(fy, fy)), _mm256_mul_pd(fz, fz)),
                      _mm256_mul_pd(r, r));
    __m256d t0 = _mm256_div_pd(c, q), t1 = _mm256_div_pd(q, a);
    __m256d swap = _mm256_cmp_pd(t0, t1, _CMP_GT_OQ);
    _mm256_storeu_pd(out->t0, _mm256_blendv_pd(t0, t1, swap));
    _mm256_storeu_pd(out->t1, _mm256_blendv_pd(t1, t0, swap));
    __m256d ok = _mm256_and_pd(_mm256_cmp_pd(disc, _mm256_setzero_pd(), _CMP_GE_OQ),
                               _mm256_cmp_pd(q, _mm256_setzero_pd(), _CMP_NEQ_UQ));
    return (unsigned)_mm256_movemask_pd(ok);
}

static inline __attribute__((always_inline, target("avx2"))) unsigned
rd_sphere4_roots_of(const rd_sphere4 *p, const rd_ray *ray, rd_sphere4_roots *out)
{
    return rd_sphere4_roots_at(p->cx, p->cy, p->cz, p->r, ray, out);
}

/* rd_sphere_intersect's answer from a lane's roots, for tmax. */
static inline double rd_sphere4_pick(const rd_sphere4_roots *q, int lane, double tmax)
{
    double t0 = q->t0[lane], t1 = q->t1[lane];
    if (t0 > 0 && t0 < tmax)
        return t0;
    if (t1 > 0 && t1 < tmax)
        return t1;
    return 0;
}

#endif
