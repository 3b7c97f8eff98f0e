/* Ray-triangle intersection. */
#ifndef RD_TRIANGLE_H
#define RD_TRIANGLE_H

#include <float.h>
#include <math.h>

#include "ray.h"

/* Watertight test of Woop, Benthin & Wald (JCGT 2(1), 2013) on the corners
 * v[0], v[1], v[2]: a ray through a shared edge or vertex hits at least one
 * of the triangles that share it. Returns t in (0, tmax) or 0, and the
 * barycentric weights of the three corners. Degenerate (zero-area)
 * triangles never hit. The world fills in the hit (world.c, fill_tri). */
double rd_tri_intersect(const rd_vec3 v[3], rd_ray r, double tmax, double bary[3]);

/* What the test needs of the ray alone (the axis permutation and the
 * shear), computed once per ray instead of once per triangle. ok is 0 for a
 * ray no triangle can be hit by (a zero or non-finite dominant component). */
typedef struct {
    rd_vec3 o;
    int kx, ky, kz, ok;
    double sx, sy, sz;
} rd_tri_ray;

static inline double rd_tri_comp(rd_vec3 v, int k) { return k == 0 ? v.x : (k == 1 ? v.y : v.z); }

/* Inline: every ray that reaches a triangle makes one. */
static inline rd_tri_ray rd_tri_ray_make(rd_ray r)
{
    /* Permute so that z is the ray's dominant axis, then shear the
     * triangle into the ray's frame, where the test is 2D. */
    rd_tri_ray t = {r.o, 0, 0, 0, 0, 0, 0, 0};
    int kz = 0;
    double ax = fabs(r.d.x), ay = fabs(r.d.y), az = fabs(r.d.z);
    if (ay > ax && ay >= az)
        kz = 1;
    else if (az > ax && az > ay)
        kz = 2;
    int kx = (kz + 1) % 3, ky = (kx + 1) % 3;
    double dz = rd_tri_comp(r.d, kz);
    if (dz == 0 || !isfinite(dz))
        return t;
    if (dz < 0) {
        int tmp = kx;
        kx = ky;
        ky = tmp;
    }
    t.kx = kx;
    t.ky = ky;
    t.kz = kz;
    t.ok = 1;
    t.sx = rd_tri_comp(r.d, kx) / dz;
    t.sy = rd_tri_comp(r.d, ky) / dz;
    t.sz = 1.0 / dz;
    return t;
}

/* rd_tri_intersect with the ray's part done: the same operations in the
 * same order, so the same answers to the bit. Inline, so that the walks
 * test a leaf's triangles without a call (and, in the AVX2 walks, without
 * leaving their instruction set for a legacy-SSE function). */
static inline __attribute__((always_inline)) double rd_tri_intersect_ray(const rd_vec3 v[3], const rd_tri_ray *r,
                                                                         double tmax, double bary[3])
{
    if (!r->ok)
        return 0;
    const int kx = r->kx, ky = r->ky, kz = r->kz;
    const double sx = r->sx, sy = r->sy, sz = r->sz;
    rd_vec3 A = v3_sub(v[0], r->o), B = v3_sub(v[1], r->o), C = v3_sub(v[2], r->o);
    double Ax = rd_tri_comp(A, kx) - sx * rd_tri_comp(A, kz), Ay = rd_tri_comp(A, ky) - sy * rd_tri_comp(A, kz);
    double Bx = rd_tri_comp(B, kx) - sx * rd_tri_comp(B, kz), By = rd_tri_comp(B, ky) - sy * rd_tri_comp(B, kz);
    double Cx = rd_tri_comp(C, kx) - sx * rd_tri_comp(C, kz), Cy = rd_tri_comp(C, ky) - sy * rd_tri_comp(C, kz);
    double U = Cx * By - Cy * Bx;
    double V = Ax * Cy - Ay * Cx;
    double W = Bx * Ay - By * Ax;
    if ((U < 0 || V < 0 || W < 0) && (U > 0 || V > 0 || W > 0))
        return 0;
    double det = U + V + W;
    if (det == 0 || !isfinite(det))
        return 0;
    /* A sliver whose corners are collinear up to rounding, or a ray in the
     * triangle's plane: U, V, W are then rounding noise, and so is their
     * sum. No hit unless det clearly exceeds that noise. */
    double noise = 8 * DBL_EPSILON *
                   (fabs(Cx * By) + fabs(Cy * Bx) + fabs(Ax * Cy) + fabs(Ay * Cx) + fabs(Bx * Ay) + fabs(By * Ax));
    if (fabs(det) <= noise)
        return 0;
    double T = U * sz * rd_tri_comp(A, kz) + V * sz * rd_tri_comp(B, kz) + W * sz * rd_tri_comp(C, kz);
    /* t = T/det must lie in (0, tmax); compare without dividing. */
    if (det < 0) {
        T = -T;
        det = -det;
        U = -U;
        V = -V;
        W = -W;
    }
    if (T <= 0 || !(T < tmax * det * (1 + 4 * DBL_EPSILON)))
        return 0;
    /* Corners that are exactly collinear can still shear into a sliver
     * with det != 0 by rounding; such a triangle has no normal and must
     * never be hit. Checked only for hits, so misses stay cheap. */
    rd_vec3 ng = v3_cross(v3_sub(v[1], v[0]), v3_sub(v[2], v[0]));
    if (ng.x == 0 && ng.y == 0 && ng.z == 0)
        return 0;
    double inv = 1.0 / det;
    double t = T * inv;
    /* Decide on the t returned, so tmax means the same for every triangle. */
    if (!(t > 0 && t < tmax))
        return 0;
    bary[0] = U * inv;
    bary[1] = V * inv;
    bary[2] = W * inv;
    return t;
}

#endif
