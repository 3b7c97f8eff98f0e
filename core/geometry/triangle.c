#include "triangle.h"

#include <float.h>

double rd_tri_intersect(const rd_vec3 v[3], rd_ray r, double tmax, double bary[3])
{
    rd_tri_ray t = rd_tri_ray_make(r);
    return rd_tri_intersect_ray(v, &t, tmax, bary);
}

double rd_tri_intersect_ray(const rd_vec3 v[3], const rd_tri_ray *r, double tmax, double bary[3])
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
