/* Ray-triangle intersection. */
#ifndef RD_TRIANGLE_H
#define RD_TRIANGLE_H

#include "ray.h"

typedef struct {
    rd_vec3 v0, v1, v2;
    rd_vec3 n0, n1, n2;     /* shading normals, when has_normals */
    double uv[3][2];
    int has_normals, has_uv;
} rd_triangle;

/* Watertight test of Woop, Benthin & Wald (JCGT 2(1), 2013): a ray through a
 * shared edge or vertex hits at least one of the triangles that share it.
 * Returns t in (0, tmax) or 0, and the barycentric weights of v0, v1, v2.
 * Degenerate (zero-area) triangles never hit. */
double rd_triangle_intersect(const rd_triangle *tr, rd_ray r, double tmax, double bary[3]);

/* The same test on three corners. */
double rd_tri_intersect(const rd_vec3 v[3], rd_ray r, double tmax, double bary[3]);

void rd_triangle_fill_hit(const rd_triangle *tr, const double bary[3], rd_hit *h);

#endif
