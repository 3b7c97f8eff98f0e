/* Double-precision 3-vectors and RGB colours. Every function is pure. */
#ifndef RD_VEC3_H
#define RD_VEC3_H

#include <math.h>

typedef struct {
    double x, y, z;
} rd_vec3;
/* Colours share the representation; products of colours are per channel. */
typedef rd_vec3 rd_rgb;

static inline rd_vec3 v3(double x, double y, double z)
{
    rd_vec3 r = {x, y, z};
    return r;
}
static inline rd_vec3 v3_add(rd_vec3 a, rd_vec3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline rd_vec3 v3_sub(rd_vec3 a, rd_vec3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline rd_vec3 v3_mul(rd_vec3 a, rd_vec3 b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }
static inline rd_vec3 v3_scale(rd_vec3 a, double s) { return v3(a.x * s, a.y * s, a.z * s); }
static inline rd_vec3 v3_neg(rd_vec3 a) { return v3(-a.x, -a.y, -a.z); }
static inline double v3_dot(rd_vec3 a, rd_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline rd_vec3 v3_cross(rd_vec3 a, rd_vec3 b)
{
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline double v3_len(rd_vec3 a) { return sqrt(v3_dot(a, a)); }
/* Largest |component|; inline comparisons (libm's fmax is a call on the hot
 * path). A NaN component is passed over, as with fmax. */
static inline double v3_max_abs(rd_vec3 a)
{
    double x = fabs(a.x), y = fabs(a.y), z = fabs(a.z);
    double m = x > y ? x : (y == y ? y : x);
    return z > m ? z : (m == m ? m : z);
}
static inline int v3_is_finite(rd_vec3 a) { return isfinite(a.x) && isfinite(a.y) && isfinite(a.z); }
static inline int v3_eq(rd_vec3 a, rd_vec3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; }

/* Unit vector along a. Vectors of any finite length normalise, from
 * subnormal to near DBL_MAX: a very small or very large one is first scaled
 * by an exact power of two. Returns the zero vector for a zero or
 * non-finite input. */
static inline rd_vec3 v3_normalize(rd_vec3 a)
{
    if (!v3_is_finite(a))
        return v3(0, 0, 0);
    double m = v3_max_abs(a);
    if (!(m > 0))
        return v3(0, 0, 0);
    if (m < 0x1p-500)
        a = v3_scale(a, 0x1p+600);
    else if (m > 0x1p+500)
        a = v3_scale(a, 0x1p-600);
    double len = v3_len(a);
    return v3_scale(a, 1.0 / len);
}

/* reflect(i, n) = i - 2(i·n)n, as in the course's my_algebra.h. */
static inline rd_vec3 v3_reflect(rd_vec3 i, rd_vec3 n) { return v3_sub(i, v3_scale(n, 2.0 * v3_dot(i, n))); }

static inline double rd_clamp01(double x) { return x < 0 ? 0 : (x > 1 ? 1 : x); }

#endif
