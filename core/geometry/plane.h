/* Ray-plane intersection; planes are two-sided. */
#ifndef RD_PLANE_H
#define RD_PLANE_H

#include "ray.h"

typedef struct {
    rd_vec3 q;      /* a point on the plane */
    rd_vec3 n;      /* unit normal */
    rd_vec3 tu, tv; /* unit axes in the plane, for texture coordinates */
} rd_plane;

/* Sets up n, tu and tv from a point and a non-zero normal. */
void rd_plane_make(rd_plane *pl, rd_vec3 point, rd_vec3 normal);

/* t in (0, tmax) of the hit, or 0; a ray parallel to the plane misses. */
double rd_plane_intersect(const rd_plane *pl, rd_ray r, double tmax);

/* rd_plane_intersect(pl, r, tmax) > 0, for shadow rays, without the
 * division where the signs already say no: t = num/dn is > 0 only when num
 * and dn are both non-zero, not NaN and of one sign. Everything else gives
 * t <= 0 or NaN, or is a dn that rd_plane_intersect refuses (zero, NaN).
 * The signs only reject: a quotient of one sign may still be 0 (underflow,
 * or dn infinite: which is why dn needs no finiteness test here) or NaN
 * (inf/inf), so the division decides the rest as it always did. */
static inline int rd_plane_blocks(const rd_plane *pl, rd_ray r, double tmax)
{
    double dn = v3_dot(r.d, pl->n);
    double num = v3_dot(v3_sub(pl->q, r.o), pl->n);
    if (!((num > 0 && dn > 0) || (num < 0 && dn < 0)))
        return 0;
    double t = num / dn;
    return t > 0 && t < tmax;
}

void rd_plane_fill_hit(const rd_plane *pl, rd_ray r, rd_hit *h);

/* Sets h->u, h->v: the hit's coordinates along tu and tv from q. */
void rd_plane_uv(const rd_plane *pl, rd_hit *h);

#endif
