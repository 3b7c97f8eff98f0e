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

void rd_plane_fill_hit(const rd_plane *pl, rd_ray r, rd_hit *h);

/* Sets h->u, h->v: the hit's coordinates along tu and tv from q. */
void rd_plane_uv(const rd_plane *pl, rd_hit *h);

#endif
