/* The error estimate (render.h: rd_render_stats.error_estimate; job.c: two
 * independent half-sets of samples per pixel) against errors we can know.
 *
 * (a) A synthetic scene whose every sample is a Bernoulli variable with a
 *     probability set by geometry, so the variance of every pixel is known
 *     by hand (see bernoulli_scene), and the estimate's mean and its spread
 *     over the pixels can be computed exactly.
 * (b) Real scenes: the estimate at 4..32 samples against the true error,
 *     the RMSE of the display values against a 1024-sample reference with
 *     the reference's own estimated error taken out in quadrature (the
 *     definition of daemon/cli/cmd_converge.c).
 * (c) The true error falls with the sample count at a log-log slope between
 *     -1.1 and -0.45.
 * (d) One sample per pixel gives an estimate of exactly 0.
 * (e) The converged image does not depend on the sample count (an unbiased
 *     pixel estimate: otherwise no variance estimate can predict the error
 *     against a converged render).
 * (f) The same on a noisy scene built in code (soft_shadow_scene): 0 with
 *     one sample, 1/√n, the RMSE against a converged render at 4 samples.
 *
 * Every test runs from the repository root. Images are small (the machine
 * is shared); the tolerances are derived below, never tuned to pass. */
#include <criterion/criterion.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "compare.h"
#include "rayd/render.h"
#include "rayd/scene.h"
#include "support/load.h"
#include "support/scene_fixture.h"
#include "support/true_error.h"

/* ---- helpers -------------------------------------------------------------------- */

/* P(S = k) for S ~ Binomial(n, p). */
static double binom_pmf(int n, int k, double p)
{
    double lc = lgamma(n + 1.0) - lgamma(k + 1.0) - lgamma(n - k + 1.0);
    if (p == 0)
        return k == 0;
    if (p == 1)
        return k == n;
    return exp(lc + k * log(p) + (n - k) * log1p(-p));
}

/* ---- (a) a synthetic scene with a known per-sample variance --------------------------
 *
 * The camera looks straight down at a diffuse floor (y = 0). The only light
 * is an "area" light of one point per sample (samples = 1) on a segment of
 * length 16 at height 1e4, crossing the vertical plane x = 50 (an infinite
 * blocker, outside the view): every floor point sees the part of the segment
 * with x < 50 and not the rest, whatever its position (a plane splits space
 * into two convex halves: a shadow ray crosses it exactly when the light
 * point lies on the other side). The segment is placed so that a fraction p
 * of it lies before the plane. A sample's light point is uniform on the
 * segment (rd_light_sample_at: corner + u·edge1, u from the sample's own
 * generator), so each sample of each pixel is, per channel,
 *
 *     value = ambient + X · kd · cos θ,   X ~ Bernoulli(p), independent,
 *
 * with cos θ = 1 - 1.25e-5 everywhere to within 1e-6 (the light is 1e4 up
 * and at most 60 across). Nothing else varies inside a pixel: the floor is
 * uniform, so the camera jitter changes nothing. With gamma 1 and no value
 * above 1, display = linear value, and the per-sample variance is
 * (kd·cos θ)² p(1-p) per channel: that is the variance we know by hand. */

#define BW 64
#define BH 64

static double bernoulli_cos(double p)
{
    /* cos θ toward the middle of the visible part of the segment, seen from
     * the floor's origin (the image spans |x|,|z| < 1.4: changes < 1e-6). */
    double x = 50 - 8 * p, y = 1e4;
    return y / sqrt(x * x + y * y);
}

static void bernoulli_scene(rd_scene *s, double p, rd_rgb kd, rd_rgb ambient, double gamma, int samples, uint64_t seed)
{
    fixture_scene(s, BW, BH);
    s->render.samples = samples;
    s->render.gamma = gamma;
    s->render.seed = seed;
    s->camera.eye = v3(0, 5, 0);
    s->camera.target = v3(0, 0, 0);
    s->camera.up = v3(0, 0, -1);
    s->camera.fov_deg = 30;
    int floor_m = add_diffuse(s, kd, ambient);
    int blocker_m = add_material(s, RD_MAT_DIFFUSE);
    add_plane(s, v3(0, 0, 0), v3(0, 1, 0), floor_m);
    add_plane(s, v3(50, 0, 0), v3(1, 0, 0), blocker_m); /* the blocker: x = 50 */
    /* u < p: x < 50, visible */
    add_area_light(s, v3(50 - 16 * p, 1e4, 0), v3(16, 0, 0), v3(0, 0, 0), 1, v3(1, 1, 1));
}

/* The exact mean and variance, over one pixel, of that pixel's term in the
 * squared estimate, k·D² with D = (mean of half A) - (mean of half B) of
 * Bernoulli(p) values, a and b samples, k = ab/(a+b)² (job.c). The
 * channel factor (kd cos θ)² is left out. */
static void half_term_moments(int a, int b, double p, double *mean, double *var)
{
    double k = (double)a * b / ((double)(a + b) * (a + b));
    double m1 = 0, m2 = 0;
    for (int i = 0; i <= a; i++)
        for (int j = 0; j <= b; j++) {
            double pr = binom_pmf(a, i, p) * binom_pmf(b, j, p);
            double d = (double)i / a - (double)j / b;
            double t = k * d * d;
            m1 += pr * t;
            m2 += pr * t * t;
        }
    *mean = m1;
    *var = m2 - m1 * m1;
}

/* The same for the image's own squared error (S/n - p)², S ~ Binomial(n, p). */
static void mean_sq_error_moments(int n, double p, double *mean, double *var)
{
    double m1 = 0, m2 = 0;
    for (int i = 0; i <= n; i++) {
        double pr = binom_pmf(n, i, p);
        double d = (double)i / n - p;
        m1 += pr * d * d;
        m2 += pr * d * d * d * d;
    }
    *mean = m1;
    *var = m2 - m1 * m1;
}

/* Renders the Bernoulli scene and checks, with a tolerance of 5 standard
 * deviations of the quantity itself (computed exactly above: the pixels are
 * independent, so a mean over P = 4096 pixels has the per-pixel variance
 * over P; a false failure has probability < 1e-6 per check):
 *   estimate² against E[estimate²] = K p(1-p)/n;
 *   true²  (the image's MSE against the known converged image) against
 *          E[true²] = K p(1-p)/n as well;
 * where K is the mean over channels of (kd cos θ)². */
static void check_bernoulli(double p, int n, int progressive)
{
    rd_rgb kd = v3(0.8, 0.5, 0.25), amb = v3(0.1, 0.1, 0.1);
    rd_scene s;
    bernoulli_scene(&s, p, kd, amb, 1.0, n, 1000 + (uint64_t)n + 77 * (uint64_t)progressive);
    rd_render_options o = {0};
    o.threads = 2;
    if (progressive)
        o.target_error = 1e-12; /* passes 2, 2, 4, ... up to n */
    rd_image img;
    rd_render_stats st;
    render_ok(&s, &o, &img, &st);
    cr_assert_eq(st.mean_samples, (double)n);

    double c = bernoulli_cos(p);
    double K = (kd.x * kd.x + kd.y * kd.y + kd.z * kd.z) / 3 * c * c;
    /* Halves: progressive passes are even, a fixed pass gives half A
     * ceil(n/2) samples (job.c alternates by the running count). */
    int a = (n + 1) / 2, b = n / 2;
    double P = (double)BW * BH;
    double hm, hv, em, ev;
    half_term_moments(a, b, p, &hm, &hv);
    mean_sq_error_moments(n, p, &em, &ev);
    cr_assert(fabs(hm - p * (1 - p) / n) < 1e-12 * hm + 1e-15, "derivation: %g vs %g", hm, p * (1 - p) / n);

    double est2 = st.error_estimate * st.error_estimate;
    double want2 = K * hm, sd2 = K * sqrt(hv / P);

    double sum = 0;
    double mu[3] = {amb.x + p * kd.x * c, amb.y + p * kd.y * c, amb.z + p * kd.z * c};
    for (size_t i = 0; i < (size_t)BW * BH; i++)
        for (int ch = 0; ch < 3; ch++) {
            double d = img.rgb[3 * i + ch] - mu[ch];
            sum += d * d;
        }
    double true2 = sum / (3 * P);
    double twant2 = K * em, tsd2 = K * sqrt(ev / P);

    printf("bernoulli p=%.3f n=%3d %s: estimate %.6f expected %.6f (%+.2f sd) | true %.6f expected %.6f (%+.2f sd)\n",
           p, n, progressive ? "progressive" : "fixed      ", st.error_estimate, sqrt(want2), (est2 - want2) / sd2,
           sqrt(true2), sqrt(twant2), (true2 - twant2) / tsd2);
    cr_assert(fabs(est2 - want2) <= 5 * sd2, "p=%g n=%d %s: estimate %.6f, expected %.6f ± %.6f (5 sd on the square)",
              p, n, progressive ? "progressive" : "fixed", st.error_estimate, sqrt(want2),
              sqrt(want2 + 5 * sd2) - sqrt(want2));
    cr_assert(fabs(true2 - twant2) <= 5 * tsd2,
              "p=%g n=%d: the image's RMSE against the known converged image is %.6f, expected %.6f: the pixel "
              "means are not unbiased means of independent samples",
              p, n, sqrt(true2), sqrt(twant2));
    rd_image_free(&img);
    rd_scene_free(&s);
}

Test(estimate, bernoulli_fixed_matches_known_variance)
{
    int ns[] = {2, 4, 8, 16, 32};
    for (size_t i = 0; i < sizeof ns / sizeof ns[0]; i++)
        check_bernoulli(0.5, ns[i], 0);
    check_bernoulli(0.25, 8, 0);
    check_bernoulli(0.25, 7, 0); /* unequal halves: 4 and 3 */
}

Test(estimate, bernoulli_progressive_matches_known_variance)
{
    int ns[] = {2, 4, 8, 16, 32};
    for (size_t i = 0; i < sizeof ns / sizeof ns[0]; i++)
        check_bernoulli(0.5, ns[i], 1);
    check_bernoulli(0.25, 16, 1);
}

/* The same scene with gamma 2.2, no ambient and kd 1: a sample's value is
 * 0 or c = cos θ, the converged display value is g(p·c) with
 * g(x) = x^(1/2.2), and the image's display value is g(S·c/n), S ~
 * Binomial(n, p). The expected squared true error is therefore the exact
 * sum over S of P(S)·(g(Sc/n) - g(pc))². render.h promises that the
 * estimate, "in output units (after clamp and gamma)", predicts the RMSE of
 * the image against a converged one; (b) below allows a factor 1.5 either
 * way, and so does this test.
 *
 * What it tells apart: job.c compares the two half-sets' linear means as
 * displayed, g(mean A) - g(mean B), as the image is g of the mean. An
 * estimate from the samples' own display values (g of each sample) would
 * have E[est²] = g(c)² p(1-p)/n: 1.8 times the true error for p = 3/4 at 16
 * samples, half of it for p = 1/8, and a ratio that does not tend to 1 as n
 * grows (it tends to g(c)/(c·g'(pc)), the delta method). */
Test(estimate, bernoulli_gamma_predicts_image_rmse)
{
    double ps[] = {0.75, 0.5, 0.25, 0.125};
    int n = 16;
    int bad = 0;
    char msg[1024] = "";
    for (size_t t = 0; t < sizeof ps / sizeof ps[0]; t++) {
        double p = ps[t];
        rd_scene s;
        bernoulli_scene(&s, p, v3(1, 1, 1), v3(0, 0, 0), 2.2, n, 500 + t);
        rd_render_options o = {0};
        o.threads = 2;
        rd_image img;
        rd_render_stats st;
        render_ok(&s, &o, &img, &st);
        double c = bernoulli_cos(p), g = 1 / 2.2;
        double conv = pow(p * c, g);
        double sum = 0;
        for (size_t i = 0; i < (size_t)BW * BH * 3; i++) {
            double d = rd_display(img.rgb[i], 2.2) - conv;
            sum += d * d;
        }
        double measured = sqrt(sum / (BW * BH * 3.0));
        double exact = 0;
        for (int k = 0; k <= n; k++) {
            double d = pow(k * c / n, g) - conv;
            exact += binom_pmf(n, k, p) * d * d;
        }
        exact = sqrt(exact);
        double est_expected = pow(c, g) * sqrt(p * (1 - p) / n);
        double ratio = st.error_estimate / measured;
        printf("gamma 2.2, p=%.3f n=%d: estimate %.5f (expected from job.c's formula %.5f), true %.5f (exact %.5f), "
               "estimate/true %.3f\n",
               p, n, st.error_estimate, est_expected, measured, exact, ratio);
        /* My derivation of the true error must hold (64·64 pixels: the
         * measured RMSE is within a few % of its expectation). */
        cr_assert(fabs(measured / exact - 1) < 0.1, "p=%g: true error %.5f, derived %.5f", p, measured, exact);
        if (!(ratio >= 1 / 1.5 && ratio <= 1.5)) {
            bad++;
            size_t len = strlen(msg);
            snprintf(msg + len, sizeof msg - len, " p=%g: estimate %.5f, true %.5f (ratio %.2f);", p, st.error_estimate,
                     measured, ratio);
        }
        rd_image_free(&img);
        rd_scene_free(&s);
    }
    cr_expect_eq(bad, 0, "gamma 2.2: the estimate does not predict the image's RMSE within a factor 1.5:%s", msg);
}

/* ---- (b), (c): real scenes against a 1024-sample reference ------------------------------
 *
 * Each scene at 64x48. The reference uses another seed than the renders it
 * judges, a precaution: with the same seed (as `rayd converge` does) a
 * render and its reference share the area-light jitter of sample k; the
 * true errors measured both ways differ by under 1% on these scenes.
 *
 * rd_cmj fills every stratum for any count (see (e)), so the reference has
 * no bias of its own to put a floor under the true errors; its estimated
 * error is taken out in quadrature. */

#define SW 64
#define SH 48

static void check_scene(rd_scene *s, const char *name)
{
    s->render.width = SW;
    s->render.height = SH;
    rd_render_options o = {0};
    o.threads = 2;
    rd_render_stats rst;
    double *refd = render_reference(s, 1024, &rst);

    int ns[] = {4, 8, 16, 32};
    double x[4], tr[4], es[4];
    printf("%s %dx%d, reference 1024 samples (own estimate %.6f, %.0f ms)\n", name, SW, SH, rst.error_estimate,
           rst.wall_ms);
    printf("  samples   estimate       true  est/true\n");
    for (int i = 0; i < 4; i++) {
        s->render.samples = ns[i];
        rd_image img;
        rd_render_stats st;
        render_ok(s, &o, &img, &st);
        x[i] = ns[i];
        es[i] = st.error_estimate;
        tr[i] = true_error(&img, refd, rst.error_estimate, s->render.gamma);
        printf("  %7d %10.6f %10.6f %9.3f\n", ns[i], es[i], tr[i], es[i] / tr[i]);
        rd_image_free(&img);
    }
    double slope = rd_loglog_slope(x, tr, 4);
    printf("  slope of log(true) against log(samples): %.3f (estimate: %.3f)\n", slope, rd_loglog_slope(x, es, 4));
    /* The reference must be much better than the renders it judges. */
    cr_assert(rst.error_estimate < tr[3] / 3, "%s: reference estimate %g, true error at 32 samples %g", name,
              rst.error_estimate, tr[3]);
    for (int i = 0; i < 4; i++)
        cr_expect(tr[i] > 0 && es[i] / tr[i] >= 1 / 1.5 && es[i] / tr[i] <= 1.5,
                  "%s at %d samples: estimate %.6f, true error %.6f (ratio %.3f, allowed [0.667, 1.5])", name, ns[i],
                  es[i], tr[i], es[i] / tr[i]);
    cr_expect(slope >= -1.1 && slope <= -0.45, "%s: true error slope %.3f, expected in [-1.1, -0.45]", name, slope);
    free(refd);
}

Test(estimate, area_light_cfg, .timeout = 120)
{
    rd_scene s;
    load_cfg("scenes/area_light.cfg", &s);
    check_scene(&s, "scenes/area_light.cfg");
    rd_scene_free(&s);
}

Test(estimate, phong_cfg_antialiased, .timeout = 120)
{
    /* Point lights only: the noise is the anti-aliasing of the edges. */
    rd_scene s;
    load_cfg("scenes/phong.cfg", &s);
    check_scene(&s, "scenes/phong.cfg (anti-aliased)");
    rd_scene_free(&s);
}

/* cook_torrance.cfg with its key light made a 2x2 area light: glossy
 * highlights of an area light (the fill light stays a point). */
static void glossy_area_scene(rd_scene *s)
{
    load_cfg("scenes/cook_torrance.cfg", s);
    cr_assert(s->light_count >= 1 && s->lights[0].type == RD_LIGHT_POINT);
    rd_light *l = &s->lights[0];
    l->type = RD_LIGHT_AREA;
    l->corner = v3(4, 10, 6);
    l->edge1 = v3(4, 0, 0);
    l->edge2 = v3(0, 0, 4);
    l->samples = 2;
}

Test(estimate, glossy_cook_torrance_area_light, .timeout = 120)
{
    rd_scene s;
    glossy_area_scene(&s);
    check_scene(&s, "cook_torrance.cfg with an area key light");
    rd_scene_free(&s);
}

/* ---- (d) one sample: exactly 0 ------------------------------------------------------------ */

Test(estimate, one_sample_is_exactly_zero)
{
    const char *paths[] = {"scenes/area_light.cfg", "scenes/phong.cfg"};
    for (int progressive = 0; progressive < 2; progressive++) {
        for (size_t i = 0; i < 3; i++) {
            rd_scene s;
            if (i < 2)
                load_cfg(paths[i], &s);
            else
                glossy_area_scene(&s);
            s.render.width = SW;
            s.render.height = SH;
            s.render.samples = 1;
            rd_render_options o = {0};
            o.threads = 2;
            /* A progressive render capped at one sample runs one jittered
             * pass of one sample: still nothing to measure a variance with. */
            if (progressive)
                o.target_error = 1e-12;
            rd_image img;
            rd_render_stats st;
            render_ok(&s, &o, &img, &st);
            cr_assert_eq(st.mean_samples, 1.0);
            cr_assert_eq(st.error_estimate, 0.0, "%s (%s): estimate %.17g with one sample", i < 2 ? paths[i] : "glossy",
                         progressive ? "progressive" : "fixed", st.error_estimate);
            cr_assert_eq(st.curve_len, 1);
            cr_assert_eq(st.curve[0].error, 0.0);
            rd_image_free(&img);
            rd_scene_free(&s);
        }
    }
    rd_scene s;
    bernoulli_scene(&s, 0.5, v3(0.8, 0.8, 0.8), v3(0, 0, 0), 1.0, 1, 3);
    rd_image img;
    rd_render_stats st;
    render_ok(&s, NULL, &img, &st);
    cr_assert_eq(st.error_estimate, 0.0);
    rd_image_free(&img);
    rd_scene_free(&s);
}

/* ---- (e) the converged image does not depend on the sample count --------------------------
 *
 * A 1024x1 image of a white half-plane (ambient 1, no light, so exactly 1)
 * whose edge is the horizontal line through the centre of every pixel, on a
 * black background: a pixel's value is the fraction of its samples in its
 * top half. For uniformly distributed samples its expectation is 1/2 exactly,
 * whatever the count; its standard deviation is at most that of random
 * samples, 0.5/√n, so the mean over 1024 independent pixels is within
 * 5·0.5/√(1024 n) of 1/2 (< 1e-6 false failures).
 *
 * What it guards: rd_cmj (core/render/sampler.c) uses an m×k grid with
 * m·k = n exactly. A grid of m = ⌊√n⌋, k = ⌈n/m⌉ instead leaves its last
 * row of strata, the bottom band [(k-1)/k, 1) of the pixel, with fewer
 * points than the others whenever m·k > n: the pixel mean is then biased
 * toward the top. job.c draws each half-set with its own count, so a fixed
 * render of 2h samples would be biased whenever h is not m·k: 10 samples
 * (h = 5, 2x3 with one empty cell: 3/5 on top, bias 0.1), 20 (h = 10), 64
 * (h = 32: 5x7 with 3 empty: 17.5/32 on top, bias 0.047), 256, 1024. The
 * error estimate cannot see a bias, so the true error of such renders
 * would be well above the estimate. */
Test(estimate, converged_image_does_not_depend_on_sample_count)
{
    int ns[] = {2, 4, 6, 8, 10, 12, 16, 20, 32, 64, 128, 256};
    int bad = 0;
    char msg[1024] = "";
    for (size_t t = 0; t < sizeof ns / sizeof ns[0]; t++) {
        int n = ns[t];
        rd_scene s;
        fixture_scene(&s, 1024, 1);
        s.render.samples = n;
        s.render.seed = 42 + (uint64_t)n;
        s.camera.fov_deg = 0.05; /* the row spans |x| < 2.8 at z = 0 */
        int m = add_diffuse(&s, v3(0, 0, 0), v3(1, 1, 1));
        /* edge on y = 0, the half-plane y > 0 */
        add_triangle(&s, v3(-100, 0, 0), v3(100, 0, 0), v3(0, 100, 0), m);
        rd_render_options opt = {0};
        opt.threads = 2;
        rd_image img;
        rd_render_stats st;
        render_ok(&s, &opt, &img, &st);
        double mean = 0;
        for (int x = 0; x < 1024; x++)
            mean += img.rgb[3 * x];
        mean /= 1024;
        double tol = 5 * 0.5 / sqrt(1024.0 * n);
        printf("half-plane edge, %3d samples: mean coverage %.5f (want 0.5 ± %.5f)\n", n, mean, tol);
        if (fabs(mean - 0.5) > tol) {
            bad++;
            size_t len = strlen(msg);
            snprintf(msg + len, sizeof msg - len, " %d samples: %.4f;", n, mean);
        }
        rd_image_free(&img);
        rd_scene_free(&s);
    }
    cr_expect_eq(bad, 0, "pixel means are biased (coverage of a half-covered pixel, expected 0.5):%s", msg);
}

/* ---- (f) a noisy scene built in code ----------------------------------------------------
 *
 * soft_shadow_scene (tests/support/scene_fixture.h): the estimate is 0 with
 * one sample, falls like 1/√n, and is within a factor 2 of the RMSE
 * against a 1024-sample reference at 4 samples. */

static double error_estimate_for(int samples)
{
    rd_scene s;
    soft_shadow_scene(&s, samples);
    rd_image img;
    rd_render_stats st;
    render_ok(&s, NULL, &img, &st);
    cr_assert_eq(st.samples, samples);
    rd_image_free(&img);
    rd_scene_free(&s);
    return st.error_estimate;
}

Test(estimate, soft_shadow_zero_with_one_sample) { cr_assert_eq(error_estimate_for(1), 0.0); }

Test(estimate, soft_shadow_falls_as_one_over_root_samples)
{
    /* The standard error of a mean falls like 1/√n: ×4 samples ≈ ×0.5 error. */
    double e4 = error_estimate_for(4), e16 = error_estimate_for(16), e64 = error_estimate_for(64);
    cr_log_info("error estimates: 4 -> %g, 16 -> %g, 64 -> %g", e4, e16, e64);
    cr_assert(e4 > 1e-3, "e4 = %g: the scene should be noisy", e4);
    cr_assert(e16 < e4 && e64 < e16, "not decreasing: %g, %g, %g", e4, e16, e64);
    cr_assert(e16 / e4 > 0.3 && e16 / e4 < 0.7, "e16/e4 = %g, expected about 0.5", e16 / e4);
    cr_assert(e64 / e16 > 0.3 && e64 / e16 < 0.7, "e64/e16 = %g, expected about 0.5", e64 / e16);
}

Test(estimate, soft_shadow_predicts_rmse_against_converged)
{
    /* The estimate predicts the RMSE (display units) of the image against a
     * converged one: check it to within a factor of two at 4 samples,
     * using 1024 samples as the reference. */
    rd_scene s;
    soft_shadow_scene(&s, 4);
    rd_image img4;
    rd_render_stats st4, stref;
    render_ok(&s, NULL, &img4, &st4);
    double *refd = render_reference(&s, 1024, &stref);
    double rmse = rmse_display(&img4, refd, s.render.gamma);
    cr_log_info("4 samples: estimate %g, RMSE against 1024 samples %g", st4.error_estimate, rmse);
    cr_assert(st4.error_estimate > 0.5 * rmse && st4.error_estimate < 2 * rmse, "estimate %g, measured RMSE %g",
              st4.error_estimate, rmse);
    rd_image_free(&img4);
    free(refd);
    rd_scene_free(&s);
}
