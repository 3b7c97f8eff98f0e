/* Rays and the record of a ray's hit with a surface. */
#ifndef RD_RAY_H
#define RD_RAY_H

#include <stddef.h>

#include "rayd/vec3.h"

typedef struct {
    rd_vec3 o; /* origin */
    rd_vec3 d; /* direction; not necessarily unit (shadow rays span 0..1) */
} rd_ray;

static inline rd_vec3 rd_ray_at(rd_ray r, double t) { return v3_add(r.o, v3_scale(r.d, t)); }

/* 1 when every component of r is finite. No primitive is hit by any other
 * ray, and a box test of one (NaN everywhere) accepts every box, the empty
 * slots of a node too: the walks turn such rays away first (the plain
 * loops of a world without a BVH need not). */
static inline int rd_ray_finite(rd_ray r)
{
    double z =
        (r.o.x - r.o.x) + (r.o.y - r.o.y) + (r.o.z - r.o.z) + (r.d.x - r.d.x) + (r.d.y - r.d.y) + (r.d.z - r.d.z);
    return z == 0;
}

/* The course's HitRecord. */
typedef struct {
    double t;
    rd_vec3 p;   /* hit point */
    rd_vec3 ng;  /* unit geometric normal, as the primitive defines it */
    rd_vec3 n;   /* unit shading normal turned to face the ray (N·dir < 0) */
    int front;   /* 1 when ng faces the ray */
    double perr; /* bound on the absolute error of each component of p */
    double u, v; /* texture coordinates */
    int material;
    int object;
    /* which primitive, for attributes computed only when needed (uv) */
    int prim_kind;
    size_t prim;
    double bary[3];
} rd_hit;

/* A ray origin on the hit's surface, pushed off it along the geometric
 * normal to the side that `dir` leaves towards, far enough that the surface
 * cannot be met again at t > 0 (after Pharr, Jakob & Humphreys, PBR 3rd ed.
 * §3.9.5, and Wächter & Binder, Ray Tracing Gems ch. 6). The push is
 * relative to the hit's error bound, so it scales with the scene. */
rd_vec3 rd_offset_origin(const rd_hit *h, rd_vec3 dir);

/* The side rd_offset_origin pushes to for `dir`: 1 below the surface (the
 * side -ng points to), 0 above. The push depends on dir only through this,
 * so a hit that sends many rays can compute each side's origin once. */
static inline int rd_offset_below(const rd_hit *h, rd_vec3 dir) { return v3_dot(h->ng, dir) < 0; }

/* rd_offset_origin for every dir of side `below` (rd_offset_below). */
rd_vec3 rd_offset_side(const rd_hit *h, int below);

#endif
