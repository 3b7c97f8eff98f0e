/* Progressive rendering (core/include/rayd/progress.h, core/render/render.c): the stop rules
 * (time budget, target error, samples), the error-against-time curve,
 * determinism across threads and tiles, and adaptive sampling against the
 * true error.
 *
 * The machine running these tests is shared and busy: nothing here asserts
 * on speed or on how long a render took. Renders with a time budget are
 * checked for what holds at any load (stopped by the budget, the last pass
 * started before it); the rule that decides each pass is checked on
 * made-up pass times (schedule_*), where the answer is exact. Every test
 * runs from the repository root. */
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
    cr_assert_eq(st->curve_len, st->passes < RD_CURVE_MAX ? st->passes : RD_CURVE_MAX, "%s: %d points, %d passes", what,
                 st->curve_len, st->passes);
    for (int i = 0; i < st->curve_len; i++) {
        const rd_curve_point *c = &st->curve[i];
        cr_assert(isfinite(c->ms) && c->ms >= 0 && isfinite(c->error) && c->error >= 0, "%s: point %d", what, i);
        cr_assert(c->ms <= st->wall_ms, "%s: point %d at %g ms, the render took %g", what, i, c->ms, st->wall_ms);
        if (i > 0) {
            cr_assert(c->ms > st->curve[i - 1].ms, "%s: ms not increasing at %d: %g then %g", what, i,
                      st->curve[i - 1].ms, c->ms);
            cr_assert(c->samples > st->curve[i - 1].samples, "%s: samples not increasing at %d: %g then %g", what, i,
                      st->curve[i - 1].samples, c->samples);
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
    /* Within one pass of the budget: the last pass started before it. The
     * renderer reads the clock for rd_progress_next after taking the
     * previous curve point and starts a pass only while time is left, so
     * this holds however slowly the machine runs. Whether each pass was
     * predicted to fit and the render stopped only when not one more
     * sample fitted is rd_progress_next's rule, checked by the schedule_*
     * tests below on histories where every duration is known: measured on
     * this render's curve it would depend on the machine's load (the
     * curve's pass times include the estimate after each pass, the
     * renderer's do not, and either can be stretched by other work). */
    cr_assert(last_start < budget, "%s: the last pass started at %.1f ms", what, last_start);
    rd_image_free(&img);
    rd_scene_free(&s);
}

Test(progressive, time_budget_50ms, .timeout = 60) { check_budget(50); }

Test(progressive, time_budget_200ms, .timeout = 60) { check_budget(200); }

Test(progressive, time_budget_800ms, .timeout = 60) { check_budget(800); }

/* ---- the pass schedule for a given history ----------------------------------------------
 *
 * render.c's pass loop with a made-up clock: rd_progress_next decides each
 * pass from the numbers it is given (progress.h), so these histories give
 * exact answers. pass_ms(k, n) is how long pass k of n samples takes; the
 * plan takes plan_ms before the first pass; nothing else takes time. */

typedef struct {
    int passes, n[64], spp;
    double start[64], ms[64], end_ms;
    rd_stop_reason why;
} schedule;

typedef double (*pass_time)(int pass, int n, void *user);

static void run_schedule(const rd_progress_settings *ps, double plan_ms, pass_time pass_ms, void *user, schedule *out)
{
    memset(out, 0, sizeof *out);
    double now = plan_ms, last_ms = 0;
    int spp = 0, last_spp = 0;
    for (int k = 0;; k++) {
        cr_assert_lt(k, 64, "the schedule did not stop after 64 passes");
        int n = rd_progress_next(ps, k, spp, last_ms, last_spp, now, 1.0, &out->why);
        if (n == 0)
            break;
        out->n[k] = n;
        out->start[k] = now;
        out->ms[k] = last_ms = pass_ms(k, n, user);
        now += last_ms;
        spp += n;
        last_spp = n;
        out->passes = k + 1;
    }
    out->spp = spp;
    out->end_ms = now;
}

/* Every sample of every pass costs the same. */
static double constant_cost(int pass, int n, void *user)
{
    (void)pass;
    return n * *(const double *)user;
}

Test(progressive, schedule_constant_cost_fills_the_budget)
{
    /* With a constant cost c per sample the prediction is exact: every pass
     * after the first ends by the budget, and the render stops with less
     * than one sample's time c left. Passes double (2, 2, 4, 8 ...) until one
     * would not fit, which shrinks to what does. */
    double costs[] = {0.0625, 0.37, 1, 3.3, 30};
    double budgets[] = {50, 200, 800};
    double plans[] = {0, 7.5};
    for (size_t ci = 0; ci < sizeof costs / sizeof *costs; ci++)
        for (size_t bi = 0; bi < sizeof budgets / sizeof *budgets; bi++)
            for (size_t pi = 0; pi < sizeof plans / sizeof *plans; pi++) {
                double c = costs[ci], budget = budgets[bi];
                rd_progress_settings ps = {1 << 20, budget, 0, 0};
                schedule sc;
                run_schedule(&ps, plans[pi], constant_cost, &c, &sc);
                char what[96];
                snprintf(what, sizeof what, "cost %g ms per sample, budget %g ms, plan %g ms", c, budget, plans[pi]);
                cr_assert_eq(sc.why, RD_STOP_TIME_BUDGET, "%s: stopped by %s", what, rd_stop_reason_name(sc.why));
                cr_assert_eq(sc.n[0], 2, "%s: first pass of %d", what, sc.n[0]);
                int spp = 2;
                for (int k = 1; k < sc.passes; k++) {
                    cr_assert(sc.n[k] == spp || (k == sc.passes - 1 && sc.n[k] < spp),
                              "%s: pass %d of %d samples after %d", what, k, sc.n[k], spp);
                    cr_assert_leq(sc.start[k] + sc.ms[k], budget * (1 + 1e-12), "%s: pass %d ends at %.17g ms", what, k,
                                  sc.start[k] + sc.ms[k]);
                    spp += sc.n[k];
                }
                cr_assert_gt(sc.end_ms + c, budget * (1 - 1e-12), "%s: stopped at %.17g ms with room for more", what,
                             sc.end_ms);
            }
}

/* A loaded machine: pass k runs slow[k] times slower than the one before. */
static double slowed_cost(int pass, int n, void *user)
{
    const double *slow = user;
    double c = 0.5;
    for (int k = 0; k <= pass; k++)
        c *= slow[k % 8];
    return n * c;
}

Test(progressive, schedule_follows_the_last_pass_whatever_the_load)
{
    /* Pass times that jump by factors of 1/4 to 20 between passes. Each pass
     * after the first is started only when the last pass's time per sample
     * says it ends by the budget, and the render stops only once even one
     * more sample at that rate would not. The rule holds against what was
     * measured, so a render overruns its budget only by as much as its last
     * pass ran slower than predicted. */
    const double slows[3][8] = {
        {1, 20, 0.25, 3, 1, 7, 0.5, 1}, {4, 1, 1, 12, 0.3, 1, 2, 0.25}, {1, 1, 1, 1, 20, 20, 0.25, 1}};
    for (int v = 0; v < 3; v++)
        for (double budget = 20; budget <= 2000; budget *= 3) {
            rd_progress_settings ps = {1 << 20, budget, 0, 0};
            schedule sc;
            run_schedule(&ps, 1, slowed_cost, (void *)slows[v], &sc);
            cr_assert_eq(sc.why, RD_STOP_TIME_BUDGET, "variant %d budget %g: stopped by %s", v, budget,
                         rd_stop_reason_name(sc.why));
            for (int k = 1; k < sc.passes; k++) {
                double rate = sc.ms[k - 1] / sc.n[k - 1];
                cr_assert_leq(sc.start[k] + rate * sc.n[k], budget * (1 + 1e-12),
                              "variant %d budget %g: pass %d started at %g though predicted to end at %g", v, budget, k,
                              sc.start[k], sc.start[k] + rate * sc.n[k]);
            }
            int L = sc.passes - 1;
            double rate = sc.ms[L] / sc.n[L];
            cr_assert_gt(sc.end_ms + rate, budget * (1 - 1e-12),
                         "variant %d budget %g: stopped at %g ms though one more sample would end at %g", v, budget,
                         sc.end_ms, sc.end_ms + rate);
        }
}

Test(progressive, schedule_caps_and_targets)
{
    /* The cap ends the doubling with the samples that are left: 10 samples
     * are 2, 2, 4, 2, and a budget that is never reached changes nothing. */
    double c = 1;
    rd_progress_settings ps = {10, 1e9, 0, 0};
    schedule sc;
    run_schedule(&ps, 0, constant_cost, &c, &sc);
    cr_assert_eq(sc.why, RD_STOP_SAMPLES);
    cr_assert(sc.passes == 4 && sc.n[0] == 2 && sc.n[1] == 2 && sc.n[2] == 4 && sc.n[3] == 2, "%d passes: %d %d %d %d",
              sc.passes, sc.n[0], sc.n[1], sc.n[2], sc.n[3]);
    /* A first pass that overruns the whole budget still runs, and is the only one. */
    rd_progress_settings tight = {1 << 20, 5, 0, 0};
    c = 10;
    run_schedule(&tight, 0, constant_cost, &c, &sc);
    cr_assert(sc.passes == 1 && sc.why == RD_STOP_TIME_BUDGET, "%d passes, stopped by %s", sc.passes,
              rd_stop_reason_name(sc.why));
    /* Not progressive: one pass of the scene's samples. */
    rd_progress_settings fixed = {6, 0, 0, 0};
    c = 1;
    run_schedule(&fixed, 0, constant_cost, &c, &sc);
    cr_assert(sc.passes == 1 && sc.n[0] == 6 && sc.why == RD_STOP_SAMPLES, "%d passes of %d, stopped by %s", sc.passes,
              sc.n[0], rd_stop_reason_name(sc.why));
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
            cr_assert(st.curve[k].error > targets[i], "%s: the target was met after pass %d (%g) but it went on", what,
                      k, st.curve[k].error);
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
            cr_assert_eq(st.stopped_by, RD_STOP_SAMPLES, "%s: stopped by %s", what, rd_stop_reason_name(st.stopped_by));
            cr_assert_eq(st.passes, passes[i], "%s: %d passes", what, st.passes);
            if (!adaptive)
                cr_assert_eq(st.mean_samples, (double)caps[i], "%s: %g samples", what, st.mean_samples);
            rd_image_free(&img);
            rd_scene_free(&s);
        }
    }
}

/* An adaptive pass of n samples gives pixel i about n(1/2 + 1/2 w_i/mean w)
 * samples, at most 64n, "n samples per pixel on average" (job.h), so an
 * adaptive render stopped by its samples has taken the scene's samples per
 * pixel on average, give or take the random rounding of the shares (a mean
 * over 1728 pixels: well under 10%).
 *
 * What it guards: a cap on a pixel's share that drops the excess loses
 * samples (the random rounding of the shares is unbiased; the cap is what
 * would lose them). With a cap of 8n, in images where a few pixels hold the
 * noise (edges, penumbrae: w_i above about 10x the mean), an adaptive
 * render of 32 samples per pixel ended with about half of them and still
 * reported stopped_by = samples. */
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

static double run_true(rd_scene *s, const rd_render_options *o, const double *ref, double ref_est, rd_render_stats *st)
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
        /* The adaptive render first: it meets its cap only on average
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
            snprintf(msg + len, sizeof msg - len, " %.1f spp: adaptive %.6f vs uniform %.6f;", sa.mean_samples, ta_eq,
                     tn);
        }
    }
    cr_expect_eq(worse, 0, "%s: adaptive sampling is not better than uniform at equal samples:%s", path, msg);
    free(refd);
    rd_scene_free(&s);
}

Test(progressive, adaptive_beats_uniform_area_light, .timeout = 120) { compare_adaptive("scenes/area_light.cfg"); }

Test(progressive, adaptive_beats_uniform_antialiased_edges, .timeout = 120) { compare_adaptive("scenes/phong.cfg"); }

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
                   paths[p], caps[c], sa.mean_samples, sa.error_estimate, ta, r, sn.mean_samples, sn.error_estimate, tn,
                   sn.error_estimate / tn);
            if (!(r >= 1 / 2.0 && r <= 2.0)) {
                bad++;
                size_t len = strlen(msg);
                snprintf(msg + len, sizeof msg - len, " %s cap %d (%.1f spp): estimate %.6f, true %.6f;", paths[p] + 7,
                         caps[c], sa.mean_samples, sa.error_estimate, ta);
            }
        }
        free(refd);
        rd_scene_free(&s);
    }
    cr_expect_eq(bad, 0, "adaptive renders: the estimate is not within a factor 2 of the true error:%s", msg);
}
