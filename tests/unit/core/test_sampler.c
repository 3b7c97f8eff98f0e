/* Unit tests for the deterministic samplers (core/render/sampler.h): Kensler's
 * correlated multi-jittered points and the SplitMix-style generator.
 *
 * CMJ with n = m² samples puts exactly one point in each cell of the m×m
 * grid AND one point in each of the n columns of width 1/n and each of the
 * n rows of height 1/n (the n-rooks property). Any other n uses an m×k grid
 * with m·k = n (m the largest divisor of n up to √n): one point in each of
 * its cells, and still one in each of the n fine columns and rows. */
#include <criterion/criterion.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "sampler.h"

static void cmj_points(uint32_t n, uint32_t p, double *xs, double *ys)
{
    for (uint32_t s = 0; s < n; s++)
        rd_cmj(s, n, p, &xs[s], &ys[s]);
}

Test(sampler, cmj_points_in_unit_square)
{
    double xs[1024], ys[1024];
    uint32_t ns[] = {1, 2, 3, 4, 5, 7, 16, 17, 64, 100, 1000, 1024};
    for (size_t i = 0; i < sizeof ns / sizeof ns[0]; i++)
        for (uint32_t p = 0; p < 50; p++) {
            uint32_t pat = p * 2654435761u;
            cmj_points(ns[i], pat, xs, ys);
            for (uint32_t s = 0; s < ns[i]; s++)
                cr_assert(xs[s] >= 0 && xs[s] < 1 && ys[s] >= 0 && ys[s] < 1,
                          "n=%u p=%u s=%u: (%.17g, %.17g) outside [0,1)²", ns[i], pat, s, xs[s], ys[s]);
        }
}

/* Each of the n columns [j/n, (j+1)/n) and rows holds exactly one point,
 * and each cell of the √n × √n grid holds exactly one point. */
static void check_square(uint32_t n, uint32_t pat)
{
    uint32_t m = (uint32_t)llround(sqrt((double)n));
    cr_assert_eq(m * m, n);
    double *xs = malloc(n * sizeof *xs), *ys = malloc(n * sizeof *ys);
    int *col = calloc(n, sizeof(int)), *row = calloc(n, sizeof(int)), *cell = calloc(n, sizeof(int));
    cr_assert(xs && ys && col && row && cell);
    cmj_points(n, pat, xs, ys);
    for (uint32_t s = 0; s < n; s++) {
        uint32_t cx = (uint32_t)floor(xs[s] * n), cy = (uint32_t)floor(ys[s] * n);
        cr_assert(cx < n && cy < n);
        col[cx]++;
        row[cy]++;
        cell[(uint32_t)floor(ys[s] * m) * m + (uint32_t)floor(xs[s] * m)]++;
    }
    for (uint32_t j = 0; j < n; j++) {
        cr_assert_eq(col[j], 1, "n=%u pattern %u: column %u of width 1/%u holds %d points", n, pat, j, n, col[j]);
        cr_assert_eq(row[j], 1, "n=%u pattern %u: row %u of height 1/%u holds %d points", n, pat, j, n, row[j]);
        cr_assert_eq(cell[j], 1, "n=%u pattern %u: cell %u of the %ux%u grid holds %d points", n, pat, j, m, m,
                     cell[j]);
    }
    free(xs);
    free(ys);
    free(col);
    free(row);
    free(cell);
}

Test(sampler, cmj_stratified_n16)
{
    for (uint32_t p = 0; p < 1000; p++)
        check_square(16, p * 0x9e3779b9u + 1);
}

Test(sampler, cmj_stratified_perfect_squares)
{
    uint32_t ns[] = {1, 4, 9, 25, 64, 256, 1024, 4096};
    for (size_t i = 0; i < sizeof ns / sizeof ns[0]; i++)
        for (uint32_t p = 0; p < 20; p++)
            check_square(ns[i], rd_pattern(7, p));
}

/* The grid core/render/sampler.c uses for n samples: m×k with m·k = n and
 * m the largest divisor of n up to √n (a prime n gives 1×n). */
static void cmj_grid(uint32_t n, uint32_t *m, uint32_t *k)
{
    *m = (uint32_t)floor(sqrt((double)n));
    while (*m > 1 && n % *m)
        (*m)--;
    *k = n / *m;
}

Test(sampler, cmj_non_square_counts_fill_every_cell)
{
    /* n = 8 uses a 2x4 grid, n = 12 a 3x4, n = 5 (prime) a 1x5. Each of the
     * n fine columns and rows of width 1/n holds exactly one point, and each
     * of the m×k cells exactly one: no cell is left empty (an empty cell
     * would bias the pixel mean). */
    uint32_t ns[] = {2, 3, 5, 6, 7, 8, 10, 12, 20, 50, 97, 1000};
    for (size_t i = 0; i < sizeof ns / sizeof ns[0]; i++) {
        uint32_t n = ns[i], m, k;
        cmj_grid(n, &m, &k);
        for (uint32_t p = 0; p < 20; p++) {
            double xs[1000], ys[1000];
            int col[1000] = {0}, row[1000] = {0}, cell[1000] = {0};
            cmj_points(n, rd_pattern(3, p), xs, ys);
            for (uint32_t s = 0; s < n; s++) {
                uint32_t cx = (uint32_t)floor(xs[s] * n), cy = (uint32_t)floor(ys[s] * n);
                cr_assert(cx < n && cy < n, "n=%u: point %u at (%.17g, %.17g)", n, s, xs[s], ys[s]);
                col[cx]++;
                row[cy]++;
                cell[(uint32_t)floor(ys[s] * k) * m + (uint32_t)floor(xs[s] * m)]++;
            }
            for (uint32_t j = 0; j < n; j++) {
                cr_assert(col[j] == 1, "n=%u: fine column %u of %u holds %d points", n, j, n, col[j]);
                cr_assert(row[j] == 1, "n=%u: fine row %u of %u holds %d points", n, j, n, row[j]);
                cr_assert(cell[j] == 1, "n=%u: cell %u of the %ux%u grid holds %d points", n, j, m, k, cell[j]);
            }
        }
    }
}

Test(sampler, cmj_every_count_up_to_512_is_n_rooks)
{
    /* Whatever n, the n points fill the n columns [j/n, (j+1)/n) and the n
     * rows once each, so in either axis the point set is as even as n
     * points can be: the fraction below any stratum boundary j/n is exactly
     * j/n. */
    for (uint32_t n = 1; n <= 512; n++)
        for (uint32_t p = 0; p < 4; p++) {
            double xs[512], ys[512];
            int col[512] = {0}, row[512] = {0};
            cmj_points(n, rd_pattern(11, p), xs, ys);
            for (uint32_t s = 0; s < n; s++) {
                uint32_t cx = (uint32_t)floor(xs[s] * n), cy = (uint32_t)floor(ys[s] * n);
                cr_assert(cx < n && cy < n, "n=%u: point %u at (%.17g, %.17g)", n, s, xs[s], ys[s]);
                col[cx]++;
                row[cy]++;
            }
            for (uint32_t j = 0; j < n; j++)
                cr_assert(col[j] == 1 && row[j] == 1, "n=%u pattern %u: column %u holds %d points, row %u holds %d", n,
                          p, j, col[j], j, row[j]);
        }
}

Test(sampler, cmj_deterministic_and_pattern_dependent)
{
    /* Same (s, n, p) -> the same bits; another pattern -> another point set. */
    double x1, y1, x2, y2;
    int differ = 0;
    for (uint32_t s = 0; s < 16; s++) {
        rd_cmj(s, 16, 1234, &x1, &y1);
        rd_cmj(s, 16, 1234, &x2, &y2);
        cr_assert(x1 == x2 && y1 == y2);
        rd_cmj(s, 16, 98765, &x2, &y2);
        differ += x1 != x2 || y1 != y2;
    }
    cr_assert(differ >= 8, "patterns 1234 and 98765 share %d of 16 points", 16 - differ);
    cr_assert_eq(rd_pattern(1, 2), rd_pattern(1, 2));
    cr_assert_neq(rd_pattern(1, 2), rd_pattern(1, 3));
    cr_assert_neq(rd_pattern(1, 2), rd_pattern(2, 2));
}

Test(sampler, cmj_mean_is_centred)
{
    /* A stratified set of 1024 points has a mean within 1/(2·32) of 0.5 per
     * axis (one point per 1/1024 column, so much closer in fact). */
    double xs[1024], ys[1024];
    cmj_points(1024, 5, xs, ys);
    double mx = 0, my = 0;
    for (int s = 0; s < 1024; s++) {
        mx += xs[s];
        my += ys[s];
    }
    mx /= 1024;
    my /= 1024;
    cr_assert(fabs(mx - 0.5) < 1.0 / 1024 && fabs(my - 0.5) < 1.0 / 1024, "mean (%g, %g)", mx, my);
}

Test(sampler, rng_range_and_determinism)
{
    rd_rng a = rd_rng_make(1, 2, 3), b = rd_rng_make(1, 2, 3);
    double lo = 1, hi = 0, sum = 0;
    const int N = 200000;
    for (int i = 0; i < N; i++) {
        double x = rd_rng_next(&a);
        cr_assert(x >= 0 && x < 1, "rd_rng_next gave %.17g", x);
        cr_assert(x == rd_rng_next(&b), "same key, different stream at %d", i);
        lo = fmin(lo, x);
        hi = fmax(hi, x);
        sum += x;
    }
    /* Uniform: the mean of 2e5 draws is 0.5 ± 0.00065 (1 σ); allow 5 σ. */
    cr_assert(fabs(sum / N - 0.5) < 0.0033, "mean %g", sum / N);
    cr_assert(lo < 1e-4 && hi > 1 - 1e-4, "range [%g, %g]", lo, hi);
}

Test(sampler, rng_histogram_is_flat)
{
    /* 16 bins of 1e5 draws: each 6250 ± 77 (1 σ); allow 6 σ. */
    rd_rng r = rd_rng_make(0, 0, 0);
    int bins[16] = {0};
    for (int i = 0; i < 100000; i++)
        bins[(int)(rd_rng_next(&r) * 16)]++;
    for (int b = 0; b < 16; b++)
        cr_assert(abs(bins[b] - 6250) < 470, "bin %d holds %d of 100000", b, bins[b]);
}

Test(sampler, rng_keys_give_independent_streams)
{
    /* Changing any key changes the stream. */
    rd_rng base = rd_rng_make(5, 6, 7);
    rd_rng other[3] = {rd_rng_make(6, 6, 7), rd_rng_make(5, 7, 7), rd_rng_make(5, 6, 8)};
    double b0 = rd_rng_next(&base);
    for (int i = 0; i < 3; i++)
        cr_assert(rd_rng_next(&other[i]) != b0, "key change %d kept the first draw", i);
}
