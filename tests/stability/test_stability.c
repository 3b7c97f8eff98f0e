/* The numerical-stability suite (tests/stability/cases.h): one test per
 * case of the table, each asserting that the case passes its stated
 * tolerance, that no rendered value is NaN or infinite and that every
 * render reported stats.nonfinite == 0. The cases, their properties and
 * tolerances are listed in tests/stability/case_list.h and, with measured
 * values, in docs/stability.md (`make stability`). Run from the repository
 * root (scenes/extreme/). */
#include <criterion/criterion.h>

#include "stability/cases.h"

static void check(const char *name)
{
    const rd_case *c = rd_case_find(name);
    cr_assert(c, "no stability case named %s", name);
    rd_case_result r;
    rd_case_run(c, &r);
    cr_assert(!r.error, "%s: %s", name, r.detail);
    cr_expect_eq(r.bad_values, 0, "%s: %llu non-finite values in the images: %s", name,
                 (unsigned long long)r.bad_values, r.detail);
    cr_expect_eq(r.nonfinite, 0, "%s: stats.nonfinite = %llu: %s", name, (unsigned long long)r.nonfinite, r.detail);
    cr_assert(r.pass, "%s: %s\n  measured worst %g (%s), tolerance %g: %s", name, c->property, r.worst, c->unit,
              c->tolerance, r.detail);
}

/* One test per case of tests/stability/case_list.h, named after it. */
#define RD_CASE(name, ...)                                                                                             \
    Test(stability, name, .timeout = 120) { check(#name); }
#include "stability/case_list.h"
#undef RD_CASE
