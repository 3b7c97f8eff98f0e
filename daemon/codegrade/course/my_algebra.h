/* The course's vector library, as far as calcReflectedLight uses it: Real,
 * vec3 and the free functions dot, cross, length, normalize, reflect and
 * mult. Header-only C++11. */
#ifndef MY_ALGEBRA_H
#define MY_ALGEBRA_H

#include <algorithm>
#include <cmath>

typedef double Real;

/* std::max and std::min, also unqualified as the course's code writes them. */
using std::max;
using std::min;

class vec3
{
  public:
    Real x, y, z;

    vec3() : x(0), y(0), z(0) {}
    vec3(Real v) : x(v), y(v), z(v) {}
    vec3(Real x_, Real y_, Real z_) : x(x_), y(y_), z(z_) {}

    /* v[0], v[1], v[2] are x, y, z. */
    Real &operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
    const Real &operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }

    vec3 &operator+=(const vec3 &b)
    {
        x += b.x;
        y += b.y;
        z += b.z;
        return *this;
    }
    vec3 &operator-=(const vec3 &b)
    {
        x -= b.x;
        y -= b.y;
        z -= b.z;
        return *this;
    }
    vec3 &operator*=(Real s)
    {
        x *= s;
        y *= s;
        z *= s;
        return *this;
    }
    vec3 &operator/=(Real s)
    {
        x /= s;
        y /= s;
        z /= s;
        return *this;
    }

    Real dot(const vec3 &b) const { return x * b.x + y * b.y + z * b.z; }
    Real length() const { return std::sqrt(dot(*this)); }
    /* Makes this vector unit length and returns it (a zero vector becomes NaN). */
    vec3 &normalize() { return *this /= length(); }
    /* A unit-length copy; this vector is unchanged. */
    vec3 normalized() const { return vec3(*this) /= length(); }
};

inline vec3 operator+(const vec3 &a, const vec3 &b) { return vec3(a.x + b.x, a.y + b.y, a.z + b.z); }
inline vec3 operator-(const vec3 &a, const vec3 &b) { return vec3(a.x - b.x, a.y - b.y, a.z - b.z); }
inline vec3 operator-(const vec3 &a) { return vec3(-a.x, -a.y, -a.z); }
inline vec3 operator+(const vec3 &a) { return a; }
inline vec3 operator*(const vec3 &a, Real s) { return vec3(a.x * s, a.y * s, a.z * s); }
inline vec3 operator*(Real s, const vec3 &a) { return vec3(a.x * s, a.y * s, a.z * s); }
inline vec3 operator/(const vec3 &a, Real s) { return vec3(a.x / s, a.y / s, a.z / s); }
/* No vec3 * vec3: the componentwise product is mult(). */

inline Real dot(const vec3 &a, const vec3 &b) { return a.dot(b); }
inline vec3 cross(const vec3 &a, const vec3 &b)
{
    return vec3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
inline Real length(const vec3 &a) { return a.length(); }
inline vec3 normalize(const vec3 &a) { return a.normalized(); }
/* The mirror direction of i about the unit normal n: i - 2 (i·n) n. */
inline vec3 reflect(const vec3 &i, const vec3 &n) { return i - 2 * dot(i, n) * n; }
/* out = a * b componentwise; out may be a or b: mult(c, c, light). */
inline void mult(vec3 &out, const vec3 &a, const vec3 &b) { out = vec3(a.x * b.x, a.y * b.y, a.z * b.z); }

#endif
