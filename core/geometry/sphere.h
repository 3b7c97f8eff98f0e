/* Ray-sphere intersection. */
#ifndef RD_SPHERE_H
#define RD_SPHERE_H

#include "ray.h"

typedef struct {
    rd_vec3 c;
    double r;
} rd_sphere;

/* Nearest t in (0, tmax) where r meets the sphere, or 0 when there is none.
 * Uses the cancellation-free forms of Haines, Günther & Akenine-Möller
 * (Ray Tracing Gems ch. 7): tangent rays count as hits, a ray starting
 * inside gets its exit point. */
double rd_sphere_intersect(const rd_sphere *s, rd_ray r, double tmax);

/* Completes h (p, ng, perr) for a hit at h->t. */
void rd_sphere_fill_hit(const rd_sphere *s, rd_ray r, rd_hit *h);

/* Sets h->u, h->v from the outward normal at h->p:
 * u = 0.5 + atan2(n.z, n.x)/2π, v = acos(n.y)/π. */
void rd_sphere_uv(const rd_sphere *s, rd_hit *h);

#endif
