#include "sphere.h"

#include "sphere4.h"

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

void rd_sphere4_pack(const rd_sphere *s, size_t n, rd_sphere4 *out)
{
    for (size_t i = 0; i < (n + 3) / 4 * 4; i++) {
        rd_sphere4 *p = &out[i / 4];
        int lane = (int)(i % 4);
        p->cx[lane] = i < n ? s[i].c.x : 0;
        p->cy[lane] = i < n ? s[i].c.y : 0;
        p->cz[lane] = i < n ? s[i].c.z : 0;
        p->r[lane] = i < n ? s[i].r : NAN;
    }
}
