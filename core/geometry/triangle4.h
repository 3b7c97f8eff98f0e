/* Up to four triangles tested at once (AVX2): rd_tri_intersect_ray's
 * operations in its order in each lane, up to its comparison with tmax,
 * which a closest-hit search shrinks from one triangle to the next: that
 * comparison is made with the tmax a leaf is entered with, as a filter
 * (the bound it compares with only grows with tmax, rounding being
 * monotone), and made again with the tmax of the lane's turn when the
 * lane is finished alone (rd_tri4_finish), with the rest of the scalar
 * test. So each triangle gets the bits the scalar test gives it. */
#ifndef RD_TRIANGLE4_H
#define RD_TRIANGLE4_H

#include <immintrin.h>
#include <string.h>

#include "triangle.h"

/* What the four lanes found before the comparison with tmax: the signed
 * volume's numerator T, det and U, V, W, made positive as the scalar test
 * makes them. */
typedef struct {
    double T[4], det[4], U[4], V[4], W[4];
} rd_tri4_part;

/* Coordinate k of a corner, by the byte offset of k. */
static inline double rd_tri4_at(const rd_vec3 *c, size_t off)
{
    double x;
    memcpy(&x, (const char *)c + off, sizeof x);
    return x;
}

/* Corner c of the four triangles v[0..4) on the axis at byte offset off,
 * less the ray's origin on it. */
static inline __attribute__((always_inline, target("avx2"))) __m256d rd_tri4_rel(const rd_vec3 *const v[4], int c,
                                                                                 size_t off, double o)
{
    __m256d x = _mm256_set_pd(rd_tri4_at(&v[3][c], off), rd_tri4_at(&v[2][c], off), rd_tri4_at(&v[1][c], off),
                              rd_tri4_at(&v[0][c], off));
    return _mm256_sub_pd(x, _mm256_set1_pd(o));
}

/* Bit i set when triangle v[i] (its three corners) passes every check of
 * rd_tri_intersect_ray before the normal's, with tmax; r->ok must hold. */
static inline __attribute__((always_inline, target("avx2"))) unsigned
rd_tri4_part_of(const rd_vec3 *const v[4], const rd_tri_ray *r, double tmax, rd_tri4_part *out)
{
    const size_t off[3] = {sizeof(double) * (size_t)r->kx, sizeof(double) * (size_t)r->ky,
                           sizeof(double) * (size_t)r->kz};
    const double o[3] = {rd_tri_comp(r->o, r->kx), rd_tri_comp(r->o, r->ky), rd_tri_comp(r->o, r->kz)};
    const __m256d sx = _mm256_set1_pd(r->sx), sy = _mm256_set1_pd(r->sy), sz = _mm256_set1_pd(r->sz);
    const __m256d sign = _mm256_set1_pd(-0.0), zero = _mm256_setzero_pd();
    __m256d x[3], y[3], z[3];
    for (int c = 0; c < 3; c++) {
        z[c] = rd_tri4_rel(v, c, off[2], o[2]);
        x[c] = _mm256_sub_pd(rd_tri4_rel(v, c, off[0], o[0]), _mm256_mul_pd(sx, z[c]));
        y[c] = _mm256_sub_pd(rd_tri4_rel(v, c, off[1], o[1]), _mm256_mul_pd(sy, z[c]));
    }
    /* A, B, C are corners 0, 1, 2. */
    __m256d p[6] = {_mm256_mul_pd(x[2], y[1]), _mm256_mul_pd(y[2], x[1]), _mm256_mul_pd(x[0], y[2]),
                    _mm256_mul_pd(y[0], x[2]), _mm256_mul_pd(x[1], y[0]), _mm256_mul_pd(y[1], x[0])};
    __m256d U = _mm256_sub_pd(p[0], p[1]), V = _mm256_sub_pd(p[2], p[3]), W = _mm256_sub_pd(p[4], p[5]);
    __m256d neg = _mm256_or_pd(_mm256_or_pd(_mm256_cmp_pd(U, zero, _CMP_LT_OQ), _mm256_cmp_pd(V, zero, _CMP_LT_OQ)),
                               _mm256_cmp_pd(W, zero, _CMP_LT_OQ));
    __m256d pos = _mm256_or_pd(_mm256_or_pd(_mm256_cmp_pd(U, zero, _CMP_GT_OQ), _mm256_cmp_pd(V, zero, _CMP_GT_OQ)),
                               _mm256_cmp_pd(W, zero, _CMP_GT_OQ));
    __m256d det = _mm256_add_pd(_mm256_add_pd(U, V), W), adet = _mm256_andnot_pd(sign, det);
    __m256d ok = _mm256_andnot_pd(_mm256_and_pd(neg, pos), _mm256_cmp_pd(det, zero, _CMP_NEQ_OQ));
    ok = _mm256_and_pd(ok, _mm256_cmp_pd(adet, _mm256_set1_pd(INFINITY), _CMP_LT_OQ));
    __m256d noise = _mm256_andnot_pd(sign, p[0]);
    for (int i = 1; i < 6; i++)
        noise = _mm256_add_pd(noise, _mm256_andnot_pd(sign, p[i]));
    noise = _mm256_mul_pd(_mm256_set1_pd(8 * DBL_EPSILON), noise);
    ok = _mm256_and_pd(ok, _mm256_cmp_pd(adet, noise, _CMP_NLE_UQ));
    __m256d T = _mm256_add_pd(
        _mm256_add_pd(_mm256_mul_pd(_mm256_mul_pd(U, sz), z[0]), _mm256_mul_pd(_mm256_mul_pd(V, sz), z[1])),
        _mm256_mul_pd(_mm256_mul_pd(W, sz), z[2]));
    __m256d flip = _mm256_and_pd(_mm256_cmp_pd(det, zero, _CMP_LT_OQ), sign);
    T = _mm256_xor_pd(T, flip);
    det = _mm256_xor_pd(det, flip);
    ok = _mm256_and_pd(ok, _mm256_cmp_pd(T, zero, _CMP_GT_OQ));
    __m256d bound = _mm256_mul_pd(_mm256_mul_pd(_mm256_set1_pd(tmax), det), _mm256_set1_pd(1 + 4 * DBL_EPSILON));
    ok = _mm256_and_pd(ok, _mm256_cmp_pd(T, bound, _CMP_LT_OQ));
    _mm256_storeu_pd(out->T, T);
    _mm256_storeu_pd(out->det, det);
    _mm256_storeu_pd(out->U, _mm256_xor_pd(U, flip));
    _mm256_storeu_pd(out->V, _mm256_xor_pd(V, flip));
    _mm256_storeu_pd(out->W, _mm256_xor_pd(W, flip));
    return (unsigned)_mm256_movemask_pd(ok);
}

/* rd_tri_intersect_ray's answer for a lane rd_tri4_part_of passed, whose
 * corners are v, within tmax (at most the tmax the lanes were tested
 * with). */
static inline double rd_tri4_finish(const rd_tri4_part *q, int lane, const rd_vec3 v[3], double tmax, double bary[3])
{
    double T = q->T[lane], det = q->det[lane];
    if (!(T < tmax * det * (1 + 4 * DBL_EPSILON)))
        return 0;
    rd_vec3 ng = v3_cross(v3_sub(v[1], v[0]), v3_sub(v[2], v[0]));
    if (ng.x == 0 && ng.y == 0 && ng.z == 0)
        return 0;
    double inv = 1.0 / det;
    double t = T * inv;
    if (!(t > 0 && t < tmax))
        return 0;
    bary[0] = q->U[lane] * inv;
    bary[1] = q->V[lane] * inv;
    bary[2] = q->W[lane] * inv;
    return t;
}

#endif
