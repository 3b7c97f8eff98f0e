/* Unit tests for api/image/compare.h. Expected values come from the
 * formulas: with n = 3·pixels channels and differences d,
 * rmse = sqrt(Σd² / n) / 255 and psnr = 20·log10(1 / rmse). */
#include <criterion/criterion.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "compare.h"

#define assert_near(a, b, tol)                                                                                         \
    cr_assert(fabs((double)(a) - (double)(b)) <= (tol), "%s = %.17g, expected %.17g", #a, (double)(a), (double)(b))

/* A few ulps of the values compared (a square root, a logarithm). */
#define TOL (8 * DBL_EPSILON)

Test(compare, identical_images)
{
    uint8_t a[12] = {0, 10, 20, 30, 40, 50, 60, 70, 80, 90, 100, 255};
    rd_compare_result r;
    rd_compare_rgb8(a, a, 4, &r);
    cr_assert_eq(r.pixels, 4);
    cr_assert_eq(r.rmse, 0.0);
    cr_assert(isinf(r.psnr_db) && r.psnr_db > 0, "psnr of identical images is %g, expected +inf", r.psnr_db);
    cr_assert_eq(r.max_diff, 0);
    cr_assert_eq(r.differing_pixels, 0);
    cr_assert_eq(r.differing_pixels_over_1, 0);
    /* Mean of the 12 values: 805 / 12 levels. */
    assert_near(r.mean_a, 805.0 / 12 / 255, TOL);
    assert_near(r.mean_b, r.mean_a, 0);
}

Test(compare, one_pixel_off_by_51_in_2x2)
{
    uint8_t a[12], b[12];
    memset(a, 100, sizeof a);
    memcpy(b, a, sizeof b);
    b[4] = 151; /* pixel 1, green */
    rd_compare_result r;
    rd_compare_rgb8(a, b, 4, &r);
    /* Σd² = 51² over 12 channels: rmse = 51 / (255·√12) = 0.2 / √12. */
    double rmse = 0.2 / sqrt(12.0);
    assert_near(r.rmse, rmse, TOL);
    /* 20·log10(√12 / 0.2) = 24.7712... dB */
    assert_near(r.psnr_db, 20 * log10(sqrt(12.0) / 0.2), 1e-12);
    assert_near(r.psnr_db, 24.771212547196626, 1e-12);
    cr_assert_eq(r.max_diff, 51);
    cr_assert_eq(r.differing_pixels, 1);
    cr_assert_eq(r.differing_pixels_over_1, 1);
    assert_near(r.mean_a, 100.0 / 255, TOL);
    assert_near(r.mean_b, (100.0 * 12 + 51) / 12 / 255, TOL);
}

Test(compare, black_against_white_is_rmse_1_psnr_0)
{
    uint8_t a[6] = {0, 0, 0, 0, 0, 0}, b[6] = {255, 255, 255, 255, 255, 255};
    rd_compare_result r;
    rd_compare_rgb8(a, b, 2, &r);
    assert_near(r.rmse, 1.0, 0);
    assert_near(r.psnr_db, 0.0, 0);
    cr_assert_eq(r.max_diff, 255);
    cr_assert_eq(r.differing_pixels, 2);
    cr_assert_eq(r.mean_a, 0.0);
    cr_assert_eq(r.mean_b, 1.0);
}

/* A pixel counts once however many of its channels differ; one level of
 * difference counts as differing but not "over 1"; the sign of a
 * difference does not matter. */
Test(compare, pixel_counts_and_signs)
{
    uint8_t a[9] = {10, 10, 10, 10, 10, 10, 10, 10, 10};
    uint8_t b[9] = {11, 9, 11, 10, 10, 10, 7, 13, 10};
    rd_compare_result r;
    rd_compare_rgb8(a, b, 3, &r);
    cr_assert_eq(r.differing_pixels, 2);
    cr_assert_eq(r.differing_pixels_over_1, 1);
    cr_assert_eq(r.max_diff, 3);
    /* Σd² = 1 + 1 + 1 + 9 + 9 = 21 over 9 channels. */
    assert_near(r.rmse, sqrt(21.0 / 9) / 255, TOL);
    rd_compare_result s;
    rd_compare_rgb8(b, a, 3, &s);
    cr_assert_eq(s.rmse, r.rmse);
    cr_assert_eq(s.max_diff, r.max_diff);
}

Test(compare, no_pixels)
{
    uint8_t a[1] = {0};
    rd_compare_result r;
    rd_compare_rgb8(a, a, 0, &r);
    cr_assert_eq(r.pixels, 0);
    cr_assert_eq(r.rmse, 0.0);
    cr_assert(isinf(r.psnr_db));
    cr_assert_eq(r.differing_pixels, 0);
}

/* The sums are integers: a large image of one-level differences gives
 * exactly 1/255, not an accumulated rounding error. */
Test(compare, large_image_exact)
{
    size_t n = 1000 * 1000;
    uint8_t *a = calloc(n, 3), *b = malloc(n * 3);
    cr_assert(a && b);
    memset(b, 1, n * 3);
    rd_compare_result r;
    rd_compare_rgb8(a, b, n, &r);
    cr_assert_eq(r.rmse, 1.0 / 255);
    cr_assert_eq(r.differing_pixels, n);
    cr_assert_eq(r.differing_pixels_over_1, 0);
    free(a);
    free(b);
}

/* What grade and compare print: capped at 99 dB, which identical images get. */
Test(compare, reported_psnr_is_capped_at_99_db_for_identical_images)
{
    cr_assert_eq(rd_psnr_db_reported(0), RD_PSNR_CAP_DB);
    cr_assert_eq(RD_PSNR_CAP_DB, 99.0);
    assert_near(rd_psnr_db_reported(0.2 / sqrt(12.0)), 24.771212547196626, 1e-12);
    cr_assert_eq(rd_psnr_db_reported(1e-9), 99.0, "a tiny difference is not reported above identical images");
}
