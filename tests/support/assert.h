/* Assertions with a tolerance for the Criterion suites. Each failure names
 * the expression and prints both values to 17 digits, so the message alone
 * says by how much a value missed. A NaN never passes. */
#ifndef RD_TEST_ASSERT_H
#define RD_TEST_ASSERT_H

#include <criterion/criterion.h>
#include <math.h>

#include "rayd/vec3.h"

/* |a - b| <= tol. */
#define assert_near(a, b, tol)                                                                                         \
    cr_assert(fabs((double)(a) - (double)(b)) <= (tol), "%s = %.17g, expected %.17g (tol %g)", #a, (double)(a),        \
              (double)(b), (double)(tol))

/* |a - b| <= rel·|b|: b is the expected value. */
#define assert_rel(a, b, rel)                                                                                          \
    cr_assert(fabs((double)(a) - (double)(b)) <= (rel)*fabs((double)(b)),                                              \
              "%s = %.17g, expected %.17g (relative tol %g)", #a, (double)(a), (double)(b), (double)(rel))

/* Each component of the vector (or colour) v within tol of ex, ey, ez; the
 * message names v and the component. */
#define assert_vec_near(v, ex, ey, ez, tol)                                                                            \
    do {                                                                                                               \
        rd_vec3 v_ = (v);                                                                                              \
        const double got_[3] = {v_.x, v_.y, v_.z}, want_[3] = {(ex), (ey), (ez)};                                      \
        for (int k_ = 0; k_ < 3; k_++)                                                                                 \
            cr_assert(fabs(got_[k_] - want_[k_]) <= (tol), "%s.%c = %.17g, expected %.17g (tol %g)", #v, "xyz"[k_],    \
                      got_[k_], want_[k_], (double)(tol));                                                             \
    } while (0)

#endif
