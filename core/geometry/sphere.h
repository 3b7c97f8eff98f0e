/* Ray-sphere intersection. */
#ifndef RD_SPHERE_H
#define RD_SPHERE_H

#include <math.h>

#include "ray.h"

typedef struct {
    rd_vec3 c;
    double r;
} rd_sphere;

/* Nearest t in (0, tmax) where r meets the sphere, or 0 when there is none.
 * Uses the cancellation-free forms of Haines, Günther & Akenine-Möller
 * (Ray Tracing Gems ch. 7): tangent rays count as hits, a ray starting
 * inside gets its exit point. Inline: called by value on every sphere a
 * ray meets, the copy of the ray cost more than the test. */
static inline __attribute__((always_inline)) double rd_sphere_intersect(const rd_sphere *s, rd_ray r, double tmax)
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

/* Completes h (p, ng, perr) for a hit at h->t. */
void rd_sphere_fill_hit(const rd_sphere *s, rd_ray r, rd_hit *h);

/* Sets h->u, h->v from the outward normal at h->p:
 * u = 0.5 + atan2(n.z, n.x)/2π, v = acos(n.y)/π. */
void rd_sphere_uv(const rd_sphere *s, rd_hit *h);

#endif
