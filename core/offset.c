#include "ray.h"

rd_vec3 rd_offset_origin(const rd_hit *h, rd_vec3 dir)
{
    rd_vec3 n = h->ng;
    /* Twice the error bound projected on the normal: the true surface lies
     * within perr of p in every component. */
    double d = 2.0 * h->perr * (fabs(n.x) + fabs(n.y) + fabs(n.z));
    if (v3_dot(n, dir) < 0)
        d = -d;
    rd_vec3 o = v3_add(h->p, v3_scale(n, d));
    /* Rounding the sum may pull a component back toward the surface: step
     * each one ulp further along the push. */
    double c[3] = {o.x, o.y, o.z};
    double nn[3] = {n.x * d, n.y * d, n.z * d};
    for (int i = 0; i < 3; i++) {
        if (nn[i] > 0)
            c[i] = nextafter(c[i], INFINITY);
        else if (nn[i] < 0)
            c[i] = nextafter(c[i], -INFINITY);
    }
    return v3(c[0], c[1], c[2]);
}
