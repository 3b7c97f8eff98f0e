#include "material.h"

double rd_pow_cos(rd_vec3 a, rd_vec3 b, double n)
{
    double c = v3_dot(a, b);
    if (n == 0)
        return 1;
    if (!(c > 0))
        return 0;
    /* 1 - cos = |a - b|²/2 exactly for unit vectors, without the
     * cancellation of 1 - a·b when the angle is tiny. */
    rd_vec3 d = v3_sub(a, b);
    double x = 0.5 * v3_dot(d, d);
    if (x >= 1)
        return 0;
    /* Far from the peak the dot product itself is the accurate one. */
    if (x > 0.5)
        return exp(n * log(c > 1 ? 1 : c));
    return exp(n * log1p(-x));
}
