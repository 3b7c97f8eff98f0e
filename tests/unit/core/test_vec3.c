/* Unit tests for core/include/rayd/vec3.h: normalisation over the whole double range,
 * reflection, cross and dot products. Expected values are exact where the
 * arithmetic is exact (small integers, powers of two) and within a few ulps
 * otherwise. */
#include <criterion/criterion.h>
#include <float.h>
#include <math.h>

#include "rayd/vec3.h"
#include "support/assert.h"

/* A few ulps of 1: the result of a normalisation is a unit vector rounded
 * in two divisions, a multiplication and a square root. */
#define UNIT_TOL (4 * DBL_EPSILON)

Test(vec3, normalize_ordinary_vector)
{
    /* (3, 4, 12) has length 13: the unit vector is (3/13, 4/13, 12/13). */
    rd_vec3 n = v3_normalize(v3(3, 4, 12));
    assert_vec_near(n, 3.0 / 13, 4.0 / 13, 12.0 / 13, UNIT_TOL);
    assert_near(v3_len(n), 1.0, UNIT_TOL);
}

Test(vec3, normalize_keeps_sign_and_axis)
{
    /* A vector along -y stays exactly -y: the largest component divides itself. */
    rd_vec3 n = v3_normalize(v3(0, -7.5, 0));
    cr_assert(n.x == 0 && n.y == -1 && n.z == 0, "got (%g, %g, %g)", n.x, n.y, n.z);
}

Test(vec3, normalize_huge_1e200)
{
    /* |(1e200,1e200,1e200)|² = 3e400 overflows a double; the scaled form must
     * still give 1/sqrt(3) in each component. */
    rd_vec3 n = v3_normalize(v3(1e200, 1e200, 1e200));
    double e = 1 / sqrt(3.0);
    assert_vec_near(n, e, e, e, UNIT_TOL);
    /* Largest finite components: the direction (3, -4, 0)·DBL_MAX/4. */
    n = v3_normalize(v3(DBL_MAX * 0.75, -DBL_MAX, 0));
    assert_vec_near(n, 0.6, -0.8, 0.0, UNIT_TOL);
}

Test(vec3, normalize_tiny_1e_minus_200)
{
    /* |(3e-200, 4e-200, 0)|² = 2.5e-399 underflows to 0; the answer is (0.6, 0.8, 0). */
    rd_vec3 n = v3_normalize(v3(3e-200, 4e-200, 0));
    assert_vec_near(n, 0.6, 0.8, 0.0, UNIT_TOL);
    n = v3_normalize(v3(-1e-200, 1e-200, -1e-200));
    double e = 1 / sqrt(3.0);
    assert_vec_near(n, -e, e, -e, UNIT_TOL);
}

Test(vec3, normalize_smallest_normal_doubles)
{
    /* DBL_MIN (2.2e-308) is still a normal number: unit result expected. */
    rd_vec3 n = v3_normalize(v3(0, 0, DBL_MIN));
    cr_assert(n.x == 0 && n.y == 0 && n.z == 1, "got (%g, %g, %g)", n.x, n.y, n.z);
}

Test(vec3, normalize_subnormal_vector)
{
    /* A non-zero finite vector must normalise (the header: only zero or
     * non-finite input gives the zero vector). With components below
     * ~5.6e-309, 1/max overflows to +inf and inf·0 gives NaN, so this
     * exposes scaling by the reciprocal instead of dividing. */
    rd_vec3 n = v3_normalize(v3(3e-309, 4e-309, 0));
    cr_assert(v3_is_finite(n), "normalize(3e-309, 4e-309, 0) = (%g, %g, %g): not finite", n.x, n.y, n.z);
    assert_vec_near(n, 0.6, 0.8, 0.0, 1e-6); /* 3e-309 is subnormal: ~1e-9 relative precision */
    n = v3_normalize(v3(5e-324, 0, 0));      /* the smallest positive double */
    cr_assert(n.x == 1 && n.y == 0 && n.z == 0, "normalize(5e-324, 0, 0) = (%g, %g, %g), expected (1, 0, 0)", n.x, n.y,
              n.z);
}

Test(vec3, normalize_zero_and_infinite_give_zero)
{
    rd_vec3 z = v3_normalize(v3(0, 0, 0));
    cr_assert(z.x == 0 && z.y == 0 && z.z == 0);
    z = v3_normalize(v3(-0.0, 0, -0.0));
    cr_assert(z.x == 0 && z.y == 0 && z.z == 0);
    z = v3_normalize(v3(INFINITY, 1, 0));
    cr_assert(z.x == 0 && z.y == 0 && z.z == 0, "inf input gave (%g, %g, %g)", z.x, z.y, z.z);
    z = v3_normalize(v3(0, -INFINITY, 0));
    cr_assert(z.x == 0 && z.y == 0 && z.z == 0, "-inf input gave (%g, %g, %g)", z.x, z.y, z.z);
}

Test(vec3, normalize_nan_gives_zero)
{
    /* NaN is non-finite too, so the header promises the zero vector. The
     * largest-component test uses fmax, which ignores a NaN argument: a NaN
     * next to a finite component slips through and the result is all NaN. */
    rd_vec3 ins[] = {v3(NAN, 1, 0), v3(1, 2, NAN), v3(0, NAN, 0), v3(NAN, NAN, NAN)};
    for (int i = 0; i < 4; i++) {
        rd_vec3 z = v3_normalize(ins[i]);
        cr_expect(z.x == 0 && z.y == 0 && z.z == 0, "normalize(%g, %g, %g) = (%g, %g, %g), expected (0, 0, 0)",
                  ins[i].x, ins[i].y, ins[i].z, z.x, z.y, z.z);
    }
}

Test(vec3, normalize_unit_length_across_exponents)
{
    /* One direction at every power-of-ten scale from 1e-300 to 1e300: the
     * result must not depend on the scale by more than rounding. */
    rd_vec3 ref = v3_normalize(v3(1, -2, 2)); /* (1, -2, 2)/3 */
    assert_vec_near(ref, 1.0 / 3, -2.0 / 3, 2.0 / 3, UNIT_TOL);
    for (int e = -300; e <= 300; e += 10) {
        double s = pow(10, e);
        rd_vec3 n = v3_normalize(v3(s, -2 * s, 2 * s));
        assert_vec_near(n, 1.0 / 3, -2.0 / 3, 2.0 / 3, UNIT_TOL);
    }
}

Test(vec3, reflect_mirror_about_normal)
{
    /* reflect(i, n) = i - 2(i·n)n. i = (1, -1, 0), n = (0, 1, 0):
     * i·n = -1, so i + 2n = (1, 1, 0). */
    rd_vec3 r = v3_reflect(v3(1, -1, 0), v3(0, 1, 0));
    cr_assert(r.x == 1 && r.y == 1 && r.z == 0, "got (%g, %g, %g)", r.x, r.y, r.z);
    /* Head-on: i = -n reflects to n. */
    r = v3_reflect(v3(0, 0, -1), v3(0, 0, 1));
    cr_assert(r.x == 0 && r.y == 0 && r.z == 1);
    /* Tangent: i ⟂ n is unchanged. */
    r = v3_reflect(v3(2, 0, 3), v3(0, 1, 0));
    cr_assert(r.x == 2 && r.y == 0 && r.z == 3);
}

Test(vec3, reflect_oblique_normal)
{
    /* n = (0.6, 0.8, 0) (unit, exact in binary up to rounding of 0.6, 0.8),
     * i = (0, -1, 0): i·n = -0.8, r = i + 1.6 n = (0.96, 0.28, 0). */
    rd_vec3 r = v3_reflect(v3(0, -1, 0), v3(0.6, 0.8, 0));
    assert_vec_near(r, 0.96, 0.28, 0.0, 4 * DBL_EPSILON);
    /* Reflection preserves length and flips the normal component only. */
    assert_near(v3_len(r), 1.0, 4 * DBL_EPSILON);
    assert_near(v3_dot(r, v3(0.6, 0.8, 0)), 0.8, 4 * DBL_EPSILON);
}

Test(vec3, reflect_involution)
{
    /* reflect(reflect(i, n), n) = i for a unit n. */
    rd_vec3 n = v3_normalize(v3(1, 2, 2)); /* (1,2,2)/3 */
    rd_vec3 i = v3(0.3, -0.7, 0.2);
    rd_vec3 rr = v3_reflect(v3_reflect(i, n), n);
    assert_vec_near(rr, i.x, i.y, i.z, 8 * DBL_EPSILON);
}

Test(vec3, cross_basis_is_right_handed)
{
    rd_vec3 c = v3_cross(v3(1, 0, 0), v3(0, 1, 0));
    cr_assert(c.x == 0 && c.y == 0 && c.z == 1, "x×y = (%g, %g, %g)", c.x, c.y, c.z);
    c = v3_cross(v3(0, 1, 0), v3(0, 0, 1));
    cr_assert(c.x == 1 && c.y == 0 && c.z == 0, "y×z = (%g, %g, %g)", c.x, c.y, c.z);
    c = v3_cross(v3(0, 0, 1), v3(1, 0, 0));
    cr_assert(c.x == 0 && c.y == 1 && c.z == 0, "z×x = (%g, %g, %g)", c.x, c.y, c.z);
}

Test(vec3, cross_integer_vectors)
{
    /* (2,3,4)×(5,6,7) = (3·7-4·6, 4·5-2·7, 2·6-3·5) = (-3, 6, -3). */
    rd_vec3 a = v3(2, 3, 4), b = v3(5, 6, 7);
    rd_vec3 c = v3_cross(a, b);
    cr_assert(c.x == -3 && c.y == 6 && c.z == -3, "got (%g, %g, %g)", c.x, c.y, c.z);
    /* Anti-commutative, orthogonal to both, and zero for parallel vectors. */
    rd_vec3 d = v3_cross(b, a);
    cr_assert(d.x == 3 && d.y == -6 && d.z == 3);
    cr_assert(v3_dot(c, a) == 0 && v3_dot(c, b) == 0);
    rd_vec3 z = v3_cross(a, v3_scale(a, 4));
    cr_assert(z.x == 0 && z.y == 0 && z.z == 0);
}

Test(vec3, dot_values)
{
    /* (1,2,3)·(4,-5,6) = 4 - 10 + 18 = 12. */
    cr_assert(v3_dot(v3(1, 2, 3), v3(4, -5, 6)) == 12);
    cr_assert(v3_dot(v3(1, 0, 0), v3(0, 1, 0)) == 0);
    /* |(2,3,6)| = 7 exactly. */
    cr_assert(v3_len(v3(2, 3, 6)) == 7);
    cr_assert(v3_max_abs(v3(-9, 3, 8)) == 9);
}
