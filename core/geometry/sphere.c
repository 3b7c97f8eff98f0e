#include "sphere.h"

#include <float.h>

double rd_sphere_intersect(const rd_sphere *s, rd_ray r, double tmax)
{
    rd_vec3 f = v3_sub(r.o, s->c);
    double a = v3_dot(r.d, r.d);
    double b = v3_dot(f, r.d);
    /* r² - |f - (b/a)d|² equals the discriminant over a, without the
     * cancellation of b² - a·c when the sphere is small or far away. */
    rd_vec3 l = v3_sub(f, v3_scale(r.d, b / a));
    double disc = a * (s->r - v3_len(l)) * (s->r + v3_len(l));
    if (!(disc >= 0))
        return 0;
    double q = -b - copysign(sqrt(disc), b);
    double c = v3_dot(f, f) - s->r * s->r;
    double t0, t1;
    if (q == 0) {
        /* Ray origin at the centre's foot with zero discriminant: only when
         * the origin lies on the sphere; treat as no hit ahead. */
        return 0;
    }
    t0 = c / q;
    t1 = q / a;
    if (t0 > t1) {
        double tmp = t0;
        t0 = t1;
        t1 = tmp;
    }
    if (t0 > 0 && t0 < tmax)
        return t0;
    if (t1 > 0 && t1 < tmax)
        return t1;
    return 0;
}

void rd_sphere_fill_hit(const rd_sphere *s, rd_ray r, rd_hit *h)
{
    rd_vec3 p = rd_ray_at(r, h->t);
    rd_vec3 n = v3_normalize(v3_sub(p, s->c));
    /* Re-project onto the surface: the error then depends on the sphere's
     * size and place, not on how far the ray travelled. */
    h->p = v3_add(s->c, v3_scale(n, s->r));
    h->ng = n;
    h->perr = 8 * DBL_EPSILON * (v3_max_abs(s->c) + s->r);
}

void rd_sphere_uv(const rd_sphere *s, rd_hit *h)
{
    rd_vec3 n = v3_normalize(v3_sub(h->p, s->c));
    h->u = 0.5 + atan2(n.z, n.x) / (2 * M_PI);
    h->v = acos(fmax(-1.0, fmin(1.0, n.y))) / M_PI;
}
