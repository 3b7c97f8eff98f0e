#include "ray.h"

#include <stdint.h>
#include <string.h>

/* The next double after x toward +inf (up) or -inf, for finite x: the same
 * value as nextafter(), without a library call per component. */
static inline double step(double x, int up)
{
    if (x == 0)
        return up ? 0x1p-1074 : -0x1p-1074;
    uint64_t b;
    memcpy(&b, &x, sizeof b);
    b += ((x > 0) == up) ? 1 : (uint64_t)-1;
    memcpy(&x, &b, sizeof x);
    return x;
}

rd_vec3 rd_offset_side(const rd_hit *h, int below)
{
    rd_vec3 n = h->ng;
    /* Twice the error bound projected on the normal: the true surface lies
     * within perr of p in every component. */
    double d = 2.0 * h->perr * (fabs(n.x) + fabs(n.y) + fabs(n.z));
    if (below)
        d = -d;
    rd_vec3 o = v3_add(h->p, v3_scale(n, d));
    /* Rounding the sum may pull a component back toward the surface: step
     * each one ulp further along the push. */
    double c[3] = {o.x, o.y, o.z};
    double nn[3] = {n.x * d, n.y * d, n.z * d};
    for (int i = 0; i < 3; i++) {
        if (!isfinite(c[i]))
            continue;
        if (nn[i] > 0)
            c[i] = step(c[i], 1);
        else if (nn[i] < 0)
            c[i] = step(c[i], 0);
    }
    return v3(c[0], c[1], c[2]);
}

rd_vec3 rd_offset_origin(const rd_hit *h, rd_vec3 dir) { return rd_offset_side(h, rd_offset_below(h, dir)); }
