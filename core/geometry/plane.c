#include "plane.h"

#include <float.h>

void rd_plane_make(rd_plane *pl, rd_vec3 point, rd_vec3 normal)
{
    pl->q = point;
    pl->n = v3_normalize(normal);
    /* The axis least aligned with n gives a stable tangent. */
    rd_vec3 a = fabs(pl->n.x) < 0.5 ? v3(1, 0, 0) : (fabs(pl->n.y) < 0.5 ? v3(0, 1, 0) : v3(0, 0, 1));
    pl->tu = v3_normalize(v3_cross(a, pl->n));
    pl->tv = v3_cross(pl->n, pl->tu);
}

double rd_plane_intersect(const rd_plane *pl, rd_ray r, double tmax)
{
    double dn = v3_dot(r.d, pl->n);
    if (dn == 0 || !isfinite(dn))
        return 0;
    double t = v3_dot(v3_sub(pl->q, r.o), pl->n) / dn;
    return (t > 0 && t < tmax) ? t : 0;
}

void rd_plane_fill_hit(const rd_plane *pl, rd_ray r, rd_hit *h)
{
    rd_vec3 p = rd_ray_at(r, h->t);
    /* Project onto the plane so the error bound depends only on where the
     * point is, not on the ray's length. */
    p = v3_sub(p, v3_scale(pl->n, v3_dot(v3_sub(p, pl->q), pl->n)));
    h->p = p;
    h->ng = pl->n;
    h->perr = 8 * DBL_EPSILON * (v3_max_abs(p) + v3_max_abs(pl->q));
}

void rd_plane_uv(const rd_plane *pl, rd_hit *h)
{
    rd_vec3 rel = v3_sub(h->p, pl->q);
    h->u = v3_dot(rel, pl->tu);
    h->v = v3_dot(rel, pl->tv);
}
