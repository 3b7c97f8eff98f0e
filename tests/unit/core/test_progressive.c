/* Progressive rendering (core/include/rayd/progress.h, core/render/render.c): the stop rules
 * (time budget, target error, samples), the error-against-time curve,
 * determinism across threads and tiles, and adaptive sampling against the
 * true error.
 *
 * The machine running these tests is shared and busy: nothing here asserts
 * on speed. The time-budget checks compare the render's own measured pass
 * times with its budget; their only slack is for the work after the last
 * pass (copying a 48x36 image), and for the gap between the renderer's
 * clock readings and the curve's. Every test runs from the repository root. */
#include <criterion/criterion.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rayd/render.h"
#include "rayd/scene.h"
#include "support/load.h"
#include "support/scene_fixture.h"
#include "support/true_error.h"

#define W 48
#define H 36

/* Milliseconds allowed for what the renderer does outside the measured
 * passes (the estimate, the final image copy) on a loaded machine. */
#define SLACK_MS 25.0

/* A scene file at W x H. */
static void load_small(const char *path, rd_scene *s)
{
    load_cfg(path, s);
    s->render.width = W;
    s->render.height = H;
}

/* The curve: one point per pass, ms and samples increasing, errors finite,
 * the last point the final statistics. For a non-adaptive render the
 * samples follow 2, 2, 4, 8, ... capped at `cap` (or one fixed pass). */
static void check_curve(const rd_render_stats *st, int cap, int adaptive, int progressive, const char *what)
{
    cr_assert(st->passes >= 1, "%s: %d passes", what, st->passes);
    cr_assert_eq(st->curve_len, st->passes < RD_CURVE_MAX ? st->passes : RD_CURVE_MAX, "%s: %d points, %d passes",
                 what, st->curve_len, st->passes);
    for (int i = 0; i < st->curve_len; i++) {
        const rd_curve_point *c = &st->curve[i];
        cr_assert(isfinite(c->ms) && c->ms >= 0 && isfinite(c->error) && c->error >= 0, "%s: point %d", what, i);
        cr_assert(c->ms <= st->wall_ms, "%s: point %d at %g ms, the render took %g", what, i, c->ms, st->wall_ms);
        if (i > 0) {
            cr_assert(c->ms > st->curve[i - 1].ms, "%s: ms not increasing at %d: %g then %g", what, i,
                      st->curve[i - 1].ms, c->ms);
            cr_assert(c->samples > st->curve[i - 1].samples, "%s: samples not increasing at %d: %g then %g", what,
                      i, st->curve[i - 1].samples, c->samples);
        }
        if (!adaptive) {
            double want = !progressive ? cap : (i == 0 ? (cap < 2 ? cap : 2) : fmin(2 * st->curve[i - 1].samples, cap));
            /* A time-budgeted pass that would not fit shrinks to what does;
             * later passes double from there. */
            if (progressive && i > 0 && st->stopped_by == RD_STOP_TIME_BUDGET)
                cr_assert(c->samples <= want, "%s: pass %d ends at %g samples, more than %g", what, i, c->samples,
                          want);
            else
                cr_assert_eq(c->samples, want, "%s: pass %d ends at %g samples, want %g", what, i, c->samples, want);
        }
    }
    const rd_curve_point *last = &st->curve[st->curve_len - 1];
    cr_assert_eq(last->samples, st->mean_samples, "%s: last point %g samples, stats %g", what, last->samples,
                 st->mean_samples);
    cr_assert_eq(last->error, st->error_estimate, "%s: last point error %.17g, stats %.17g", what, last->error,
                 st->error_estimate);
    cr_assert_eq(st->samples, (int)floor(st->mean_samples + 0.5));
}


/* ---- time budget ------------------------------------------------------------------------ */

/* scenes/area_light.cfg at 48x36: 16 shadow rays per sample, passes of
 * 2, 2, 4, 8 ... samples take about 10, 10, 20, 40 ... ms here (more when
 * the machine is busy). The cap is far away, so only the budget stops it. */
static void check_budget(double budget)
{
    rd_scene s;
    load_small("scenes/area_light.cfg", &s);
    int cap = 1 << 16;
    s.render.samples = cap;
    rd_render_options o = {0};
    o.threads = 2;
    o.time_budget_ms = budget;
    rd_image img;
    rd_render_stats st;
    render_ok(&s, &o, &img, &st);
    char what[64];
    snprintf(what, sizeof what, "budget %g ms", budget);
    check_curve(&st, cap, 0, 1, what);

    int L = st.curve_len - 1;
    double last_start = L > 0 ? st.curve[L - 1].ms : 0;
    double last_pass = st.curve[L].ms - last_start;
    printf("budget %4.0f ms: %d passes, %g samples, wall %.1f ms (last pass %.1f ms, started at %.1f), "
           "estimate %.5f, stopped by %s\n",
           budget, st.passes, st.mean_samples, st.wall_ms, last_pass, last_start, st.error_estimate,
           rd_stop_reason_name(st.stopped_by));
    cr_assert(st.mean_samples < cap);
    cr_assert_eq(st.stopped_by, RD_STOP_TIME_BUDGET, "%s: stopped by %s", what, rd_stop_reason_name(st.stopped_by));
    /* Within one pass of the budget: the last pass started before it ... */
    cr_assert(last_start < budget, "%s: the last pass started at %.1f ms", what, last_start);
    /* ... so the render ends by the budget plus that pass. */
    cr_assert(st.wall_ms <= budget + last_pass + SLACK_MS, "%s: wall %.1f ms > budget + last pass %.1f ms", what,
              st.wall_ms, last_pass);
    /* Each pass after the first was predicted (last pass's time per sample
     * times its samples) to end by the budget. */
    for (int i = 1; i <= L; i++) {
        double prev = st.curve[i - 1].ms - (i > 1 ? st.curve[i - 2].ms : 0);
        double prev_spp = st.curve[i - 1].samples - (i > 1 ? st.curve[i - 2].samples : 0);
        double spp = st.curve[i].samples - st.curve[i - 1].samples;
        double predicted_end = st.curve[i - 1].ms + prev / prev_spp * spp;
        /* pass 0's time includes the plan, so this prediction is the larger one */
        cr_assert(predicted_end <= budget + SLACK_MS, "%s: pass %d was started though predicted to end at %.1f ms",
                  what, i, predicted_end);
    }
    /* And it did not stop early: even one more sample per pixel, at the
     * last pass's speed, would have ended past the budget (a doubled pass
     * that does not fit is shrunk, progress.h). */
    double last_spp = st.curve[L].samples - (L > 0 ? st.curve[L - 1].samples : 0);
    double next_end = st.curve[L].ms + last_pass / last_spp * 1;
    cr_assert(next_end > budget - SLACK_MS, "%s: stopped at %.1f ms though the next pass would end at %.1f ms", what,
              st.curve[L].ms, next_end);
    rd_image_free(&img);
    rd_scene_free(&s);
}

Test(progressive, time_budget_50ms, .timeout = 60)
{
    check_budget(50);
}

Test(progressive, time_budget_200ms, .timeout = 60)
{
    check_budget(200);
}

Test(progressive, time_budget_800ms, .timeout = 60)
{
    check_budget(800);
}

Test(progressive, time_budget_samples_run_out_first)
{
    rd_scene s;
    load_small("scenes/area_light.cfg", &s);
    s.render.samples = 8;
    rd_render_options o = {0};
    o.threads = 2;
    o.time_budget_ms = 60000;
    rd_image img;
    rd_render_stats st;
    render_ok(&s, &o, &img, &st);
    check_curve(&st, 8, 0, 1, "budget 60 s, 8 samples");
    cr_assert_eq(st.stopped_by, RD_STOP_SAMPLES, "stopped by %s", rd_stop_reason_name(st.stopped_by));
    cr_assert_eq(st.mean_samples, 8.0);
    cr_assert_eq(st.passes, 3);
    rd_image_free(&img);
    rd_scene_free(&s);
}

/* ---- target error ------------------------------------------------------------------------ */

Test(progressive, target_error_is_met, .timeout = 60)
{
    double targets[] = {0.02, 0.01, 0.005};
    int cap = 4096;
    for (size_t i = 0; i < sizeof targets / sizeof targets[0]; i++) {
        rd_scene s;
        load_small("scenes/area_light.cfg", &s);
        s.render.samples = cap;
        rd_render_options o = {0};
        o.threads = 2;
        o.target_error = targets[i];
        rd_image img;
        rd_render_stats st;
        render_ok(&s, &o, &img, &st);
        char what[64];
        snprintf(what, sizeof what, "target %g", targets[i]);
        check_curve(&st, cap, 0, 1, what);
        printf("target %.3f: %d passes, %g samples, estimate %.5f, stopped by %s\n", targets[i], st.passes,
               st.mean_samples, st.error_estimate, rd_stop_reason_name(st.stopped_by));
        cr_assert_eq(st.stopped_by, RD_STOP_TARGET_ERROR, "%s: stopped by %s", what,
                     rd_stop_reason_name(st.stopped_by));
        cr_assert(st.error_estimate <= targets[i], "%s: final estimate %g", what, st.error_estimate);
        /* It stopped at the first pass that met the target. */
        for (int k = 0; k + 1 < st.curve_len; k++)
            cr_assert(st.curve[k].error > targets[i], "%s: the target was met after pass %d (%g) but it went on",
                      what, k, st.curve[k].error);
        rd_image_free(&img);
        rd_scene_free(&s);
    }
}

Test(progressive, target_met_after_first_pass_stops_there)
{
    rd_scene s;
    load_small("scenes/area_light.cfg", &s);
    s.render.samples = 4096;
    rd_render_options o = {0};
    o.threads = 2;
    o.target_error = 0.5; /* two samples are far better than that */
    rd_image img;
    rd_render_stats st;
    render_ok(&s, &o, &img, &st);
    check_curve(&st, 4096, 0, 1, "target 0.5");
    cr_assert_eq(st.passes, 1);
    cr_assert_eq(st.mean_samples, 2.0);
    cr_assert_eq(st.stopped_by, RD_STOP_TARGET_ERROR, "stopped by %s", rd_stop_reason_name(st.stopped_by));
    cr_assert(st.error_estimate > 0 && st.error_estimate <= 0.5, "estimate %g", st.error_estimate);
    rd_image_free(&img);
    rd_scene_free(&s);
}

/* ---- samples cap ------------------------------------------------------------------------- */

Test(progressive, samples_cap_reached)
{
    int caps[] = {1, 2, 3, 10, 16};
    int passes[] = {1, 1, 2, 4, 4};
    for (size_t i = 0; i < sizeof caps / sizeof caps[0]; i++) {
        for (int adaptive = 0; adaptive < 2; adaptive++) {
            rd_scene s;
            load_small("scenes/phong.cfg", &s);
            s.render.samples = caps[i];
            rd_render_options o = {0};
            o.threads = 2;
            o.target_error = 1e-9; /* never met */
            o.adaptive = adaptive;
            rd_image img;
            rd_render_stats st;
            render_ok(&s, &o, &img, &st);
            char what[64];
            snprintf(what, sizeof what, "cap %d%s", caps[i], adaptive ? " adaptive" : "");
            check_curve(&st, caps[i], adaptive, 1, what);
            cr_assert_eq(st.stopped_by, RD_STOP_SAMPLES, "%s: stopped by %s", what,
                         rd_stop_reason_name(st.stopped_by));
            cr_assert_eq(st.passes, passes[i], "%s: %d passes", what, st.passes);
            if (!adaptive)
                cr_assert_eq(st.mean_samples, (double)caps[i], "%s: %g samples", what, st.mean_samples);
            rd_image_free(&img);
            rd_scene_free(&s);
        }
    }
}

/* An adaptive pass of n samples gives pixel i about n(1/4 + 3/4 w_i/mean w)
 * samples, "n samples per pixel on average" (job.h), so an adaptive render
 * stopped by its samples has taken the scene's samples per pixel on
 * average, give or take the random rounding of the shares (a mean over
 * 1728 pixels: well under 10%).
 *
 * FINDING (this test fails): job.c caps a pixel's share at 8n and drops the
 * excess instead of giving it to the other pixels (the random rounding of
 * the shares is unbiased; the cap is what loses samples). In images where
 * a few pixels hold the noise (edges, penumbrae: w_i above about 10x the
 * mean), an adaptive render of 32 samples per pixel ends with about half of
 * them, and still reports stopped_by = samples. */
Test(progressive, adaptive_takes_the_scenes_samples_on_average, .timeout = 60)
{
    const char *paths[] = {"scenes/phong.cfg", "scenes/area_light.cfg"};
    int caps[] = {3, 10, 16, 32};
    int bad = 0;
    char msg[1024] = "";
    for (int p = 0; p < 2; p++)
        for (size_t i = 0; i < sizeof caps / sizeof caps[0]; i++) {
            rd_scene s;
            load_small(paths[p], &s);
            s.render.samples = caps[i];
            rd_render_options o = {0};
            o.threads = 2;
            o.target_error = 1e-9;
            o.adaptive = 1;
            rd_image img;
            rd_render_stats st;
            render_ok(&s, &o, &img, &st);
            cr_assert_eq(st.stopped_by, RD_STOP_SAMPLES, "stopped by %s", rd_stop_reason_name(st.stopped_by));
            printf("adaptive %s, samples %d: mean %.3f samples per pixel (%.0f%%), %d passes\n", paths[p], caps[i],
                   st.mean_samples, 100 * st.mean_samples / caps[i], st.passes);
            if (fabs(st.mean_samples - caps[i]) > 0.1 * caps[i]) {
                bad++;
                size_t len = strlen(msg);
                snprintf(msg + len, sizeof msg - len, " %s %d: %.2f;", paths[p] + 7, caps[i], st.mean_samples);
            }
            rd_image_free(&img);
            rd_scene_free(&s);
        }
    cr_expect_eq(bad, 0, "adaptive renders stopped by their samples took fewer per pixel on average:%s", msg);
}

Test(progressive, fixed_render_is_one_pass)
{
    rd_scene s;
    load_small("scenes/area_light.cfg", &s);
    s.render.samples = 6;
    rd_image img;
    rd_render_stats st;
    rd_render_options o = {0};
    o.threads = 2;
    render_ok(&s, &o, &img, &st);
    check_curve(&st, 6, 0, 0, "fixed 6");
    cr_assert_eq(st.passes, 1);
    cr_assert_eq(st.stopped_by, RD_STOP_SAMPLES, "stopped by %s", rd_stop_reason_name(st.stopped_by));
    cr_assert(st.error_estimate > 0);
    rd_image_free(&img);
    rd_scene_free(&s);
}

/* ---- determinism ------------------------------------------------------------------------- */

typedef struct {
    const char *name;
    int samples;
    double target;
    int adaptive;
} mode;

static const mode modes[] = {
    {"fixed 8", 8, 0, 0},
    {"progressive to target 0.004", 4096, 0.004, 0},
    {"progressive to 24 samples", 24, 1e-12, 0},
    {"adaptive to 32 samples", 32, 1e-12, 1},
    {"adaptive to target 0.007", 4096, 0.007, 1},
};

static uint8_t *render_mode(const mode *m, uint64_t seed, int threads, int tile, rd_render_stats *st)
{
    rd_scene s;
    load_small("scenes/area_light.cfg", &s);
    s.render.samples = m->samples;
    s.render.seed = seed;
    rd_render_options o = {0};
    o.threads = threads;
    o.tile = tile;
    o.target_error = m->target;
    o.adaptive = m->adaptive;
    rd_image img;
    render_ok(&s, &o, &img, st);
    uint8_t *b = image_bytes(&img, s.render.gamma);
    rd_image_free(&img);
    rd_scene_free(&s);
    return b;
}

Test(progressive, same_seed_same_bytes_any_threads_and_tiles, .timeout = 120)
{
    size_t nbytes = (size_t)W * H * 3;
    for (size_t mi = 0; mi < sizeof modes / sizeof modes[0]; mi++) {
        const mode *m = &modes[mi];
        rd_render_stats st0;
        uint8_t *b0 = render_mode(m, 7, 1, 8, &st0);
        int configs[][2] = {{1, 16}, {2, 8}, {2, 16}};
        for (int c = 0; c < 3; c++) {
            rd_render_stats st;
            uint8_t *b = render_mode(m, 7, configs[c][0], configs[c][1], &st);
            size_t diff = 0;
            for (size_t i = 0; i < nbytes; i++)
                diff += b[i] != b0[i];
            cr_assert_eq(diff, 0, "%s: threads %d tile %d differ from threads 1 tile 8 in %zu bytes", m->name,
                         configs[c][0], configs[c][1], diff);
            cr_assert_eq(st.passes, st0.passes, "%s: %d passes vs %d", m->name, st.passes, st0.passes);
            cr_assert_eq(st.mean_samples, st0.mean_samples, "%s", m->name);
            cr_assert_eq(st.error_estimate, st0.error_estimate, "%s: estimate %.17g vs %.17g", m->name,
                         st.error_estimate, st0.error_estimate);
            cr_assert_eq(st.stopped_by, st0.stopped_by, "%s", m->name);
            free(b);
        }
        /* Another seed, another image (the area light's jitter and the
         * pixel patterns change). */
        rd_render_stats st1;
        uint8_t *b1 = render_mode(m, 8, 2, 16, &st1);
        size_t diff = 0;
        for (size_t i = 0; i < nbytes; i++)
            diff += b1[i] != b0[i];
        printf("%s: %d passes, %g samples, estimate %.5f, stopped by %s; seed 8 differs from seed 7 in %zu of %zu "
               "bytes\n",
               m->name, st0.passes, st0.mean_samples, st0.error_estimate, rd_stop_reason_name(st0.stopped_by), diff,
               nbytes);
        cr_assert(diff > nbytes / 20, "%s: seeds 7 and 8 differ in only %zu bytes", m->name, diff);
        free(b1);
        free(b0);
    }
}

/* ---- adaptive against non-adaptive ------------------------------------------------------------
 *
 * The true error (RMSE of display values against a 1024-sample reference of
 * another seed, its own estimate taken out in quadrature, as in
 * daemon/cli/cmd_converge.c). The assertion: at the same mean samples per
 * pixel, adaptive gives the lower true error. Comparisons at equal time
 * belong to the benchmark (bench/), which measures time on a quiet machine;
 * here two timed renders would not get the same CPU. */

static double run_true(rd_scene *s, const rd_render_options *o, const double *ref, double ref_est,
                       rd_render_stats *st)
{
    rd_image img;
    render_ok(s, o, &img, st);
    double t = true_error(&img, ref, ref_est, s->render.gamma);
    rd_image_free(&img);
    return t;
}

/* Loads a scene at W x H and renders its 1024-sample reference; returns
 * the reference's display values (malloc'ed). */
static double *reference(const char *path, rd_scene *s, double *ref_est)
{
    load_small(path, s);
    rd_render_stats rst;
    double *refd = render_reference(s, 1024, &rst);
    *ref_est = rst.error_estimate;
    printf("%s %dx%d: reference 1024 samples, own estimate %.6f\n", path, W, H, rst.error_estimate);
    return refd;
}

static void compare_adaptive(const char *path)
{
    rd_scene s;
    double ref_est;
    double *refd = reference(path, &s, &ref_est);
    rd_render_options o = {0};
    o.threads = 2;
    int caps[] = {16, 32};
    int worse = 0;
    char msg[512] = "";
    for (int c = 0; c < 2; c++) {
        /* The adaptive render first: it takes fewer samples than its cap
         * (see adaptive_takes_the_scenes_samples_on_average), so the uniform
         * render it is compared with is capped at its mean. */
        rd_render_stats sn, sa;
        s.render.samples = caps[c];
        o.target_error = 1e-12;
        o.adaptive = 1;
        double ta = run_true(&s, &o, refd, ref_est, &sa);
        s.render.samples = (int)floor(sa.mean_samples + 0.5);
        o.adaptive = 0;
        double tn = run_true(&s, &o, refd, ref_est, &sn);
        /* What rounding leaves of the difference in samples, scaled as 1/√n. */
        double ta_eq = ta * sqrt(sa.mean_samples / sn.mean_samples);
        printf("  %s, equal samples: adaptive (cap %2d) %.2f spp true %.6f | uniform %.0f spp true %.6f | "
               "adaptive/uniform at equal samples %.3f\n",
               path, caps[c], sa.mean_samples, ta, sn.mean_samples, tn, ta_eq / tn);
        if (!(ta_eq < tn)) {
            worse++;
            size_t len = strlen(msg);
            snprintf(msg + len, sizeof msg - len, " %.1f spp: adaptive %.6f vs uniform %.6f;", sa.mean_samples,
                     ta_eq, tn);
        }
    }
    cr_expect_eq(worse, 0, "%s: adaptive sampling is not better than uniform at equal samples:%s", path, msg);
    free(refd);
    rd_scene_free(&s);
}

Test(progressive, adaptive_beats_uniform_area_light, .timeout = 120)
{
    compare_adaptive("scenes/area_light.cfg");
}

Test(progressive, adaptive_beats_uniform_antialiased_edges, .timeout = 120)
{
    compare_adaptive("scenes/phong.cfg");
}

/* The estimate of an adaptive render against its true error.
 *
 * Adaptive sampling spends samples where the pixels' own samples disagree,
 * and the estimate is measured on those same samples: a pixel whose few
 * samples happened to agree (an edge pixel whose samples all fell on one
 * side) gets only the uniform half of a pass and its half-sets agree too,
 * so it adds little to the estimate while its error is real. That
 * selection makes the adaptive estimate optimistic; measured on these
 * scenes it is 0.55 to 0.75 of the true error (uniform renders of the
 * same scenes at the same samples: 0.85 to 1.2, printed). docs/rendering.md
 * states this; the bound here is a factor 2, so a worse bias still fails. */
Test(progressive, adaptive_estimate_predicts_true_error, .timeout = 120)
{
    const char *paths[] = {"scenes/area_light.cfg", "scenes/phong.cfg"};
    int bad = 0;
    char msg[1024] = "";
    for (int p = 0; p < 2; p++) {
        rd_scene s;
        double ref_est;
        double *refd = reference(paths[p], &s, &ref_est);
        rd_render_options o = {0};
        o.threads = 2;
        o.target_error = 1e-12;
        int caps[] = {8, 16, 32};
        for (int c = 0; c < 3; c++) {
            rd_render_stats sa, sn;
            s.render.samples = caps[c];
            o.adaptive = 1;
            double ta = run_true(&s, &o, refd, ref_est, &sa);
            s.render.samples = (int)floor(sa.mean_samples + 0.5);
            o.adaptive = 0;
            double tn = run_true(&s, &o, refd, ref_est, &sn);
            double r = sa.error_estimate / ta;
            printf("  %s adaptive cap %2d: %.2f spp, estimate %.6f, true %.6f, est/true %.3f | uniform %.0f spp: "
                   "estimate %.6f, true %.6f, est/true %.3f\n",
                   paths[p], caps[c], sa.mean_samples, sa.error_estimate, ta, r, sn.mean_samples, sn.error_estimate,
                   tn, sn.error_estimate / tn);
            if (!(r >= 1 / 2.0 && r <= 2.0)) {
                bad++;
                size_t len = strlen(msg);
                snprintf(msg + len, sizeof msg - len, " %s cap %d (%.1f spp): estimate %.6f, true %.6f;",
                         paths[p] + 7, caps[c], sa.mean_samples, sa.error_estimate, ta);
            }
        }
        free(refd);
        rd_scene_free(&s);
    }
    cr_expect_eq(bad, 0, "adaptive renders: the estimate is not within a factor 2 of the true error:%s", msg);
}
