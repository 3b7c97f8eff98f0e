#include "triangle.h"

#include <float.h>

double rd_tri_intersect(const rd_vec3 v[3], rd_ray r, double tmax, double bary[3])
{
    rd_tri_ray t = rd_tri_ray_make(r);
    return rd_tri_intersect_ray(v, &t, tmax, bary);
}
