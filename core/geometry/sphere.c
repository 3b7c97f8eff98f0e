#include "sphere.h"

#include <float.h>

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
