/* Ray-triangle intersection. */
#ifndef RD_TRIANGLE_H
#define RD_TRIANGLE_H

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
 * same order, so the same answers to the bit. */
double rd_tri_intersect_ray(const rd_vec3 v[3], const rd_tri_ray *r, double tmax, double bary[3]);

#endif
