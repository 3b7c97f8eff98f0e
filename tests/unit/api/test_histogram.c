/* The duration histograms (api/util/histogram.h): bounds reach what they
 * must cover, values land in the first bucket whose bound holds them. */
#include <criterion/criterion.h>

#include "histogram.h"

static void assert_increasing(const rd_hist *h)
{
    for (int b = 1; b < h->n; b++)
        cr_assert_gt(h->le[b], h->le[b - 1], "bound %d (%g) after %g", b, h->le[b], h->le[b - 1]);
}

Test(histogram, short_cover_keeps_the_fixed_bounds)
{
    rd_hist h;
    rd_hist_init(&h, 0);
    cr_assert_eq(h.n, 12);
    cr_assert_eq(h.le[0], 0.005);
    cr_assert_eq(h.le[11], 30);
    rd_hist_init(&h, 30);
    cr_assert_eq(h.n, 12, "30 s is covered by the fixed set");
    assert_increasing(&h);
}

Test(histogram, bounds_double_until_they_cover)
{
    static const double covers[] = {31, 120, 600, 3600, 86400, 1e7};
    for (size_t i = 0; i < sizeof covers / sizeof covers[0]; i++) {
        rd_hist h;
        rd_hist_init(&h, covers[i]);
        assert_increasing(&h);
        cr_assert_geq(h.le[h.n - 1], covers[i], "cover %g: last bound %g", covers[i], h.le[h.n - 1]);
        cr_assert_lt(h.le[h.n - 2], covers[i], "cover %g: one bound too many (%g)", covers[i], h.le[h.n - 2]);
        cr_assert_eq(h.le[h.n - 1], 2 * h.le[h.n - 2]);
    }
    rd_hist h;
    rd_hist_init(&h, 120);
    cr_assert_eq(h.n, 14, "30, 60, 120: the default job timeout is a bound");
    cr_assert_eq(h.le[13], 120);
}

Test(histogram, cover_beyond_the_slots_is_capped)
{
    rd_hist h;
    rd_hist_init(&h, 1e300);
    cr_assert_eq(h.n, RD_HIST_MAX);
    assert_increasing(&h);
}

Test(histogram, values_land_in_their_bucket)
{
    rd_hist h;
    rd_hist_init(&h, 120);
    rd_hist_observe(&h, 0.005); /* on a bound: that bucket (le is inclusive) */
    rd_hist_observe(&h, 0.0051);
    rd_hist_observe(&h, 100);
    rd_hist_observe(&h, 1000); /* above every bound: only in the total */
    cr_assert_eq(h.count[0], 1);
    cr_assert_eq(h.count[1], 1);
    cr_assert_eq(h.count[13], 1);
    uint64_t sum = 0;
    for (int b = 0; b < h.n; b++)
        sum += h.count[b];
    cr_assert_eq(sum, 3);
    cr_assert_eq(h.total, 4);
    cr_assert_float_eq(h.sum, 1100.0101, 1e-9);
}
