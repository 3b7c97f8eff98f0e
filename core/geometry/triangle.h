/* Ray-triangle intersection. */
#ifndef RD_TRIANGLE_H
#define RD_TRIANGLE_H

#include "ray.h"

/* Watertight test of Woop, Benthin & Wald (JCGT 2(1), 2013) on the corners
 * v[0], v[1], v[2]: a ray through a shared edge or vertex hits at least one
 * of the triangles that share it. Returns t in (0, tmax) or 0, and the
 * barycentric weights of the three corners. Degenerate (zero-area)
 * triangles never hit. The world fills in the hit (world.c, fill_tri). */
double rd_tri_intersect(const rd_vec3 v[3], rd_ray r, double tmax, double bary[3]);

#endif
