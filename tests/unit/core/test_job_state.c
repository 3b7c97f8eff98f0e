/* A tile's state and the pass schedule as values (core/include/rayd/job.h):
 * a render split over two jobs of the same scene ("two daemons") that
 * exchange them gives what one job gives alone, to the byte; and what is
 * loaded from elsewhere is checked as hostile.
 *
 * The scene is soft_shadow_scene (32x24, an area light: every sample
 * differs) in tiles of 10, so that the last column and row of tiles are 2
 * and 4 pixels wide. Passes are ended with rd_job_end_pass_at on a made-up
 * clock, the same for the farm and for the job alone: the curves then
 * agree in their times too. */
#include <criterion/criterion.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rayd/job.h"
#include "rayd/render.h"
#include "support/rng.h"
#include "support/scene_fixture.h"

#define TILE 10
#define FAKE_PASS_MS 12.5

static double fake_elapsed(int pass) { return 40 + FAKE_PASS_MS * (pass + 1); }

typedef struct {
    const char *name;
    int samples;
    double target;
    int adaptive;
    int min_passes; /* fewer, and the mode would not test what it is for */
} mode;

static const mode modes[] = {
    {"fixed 1 sample", 1, 0, 0, 1},
    {"fixed 8 samples", 8, 0, 0, 1},
    {"progressive to target 0.006", 4096, 0.006, 0, 4},
    {"adaptive to 32 samples", 32, 1e-12, 1, 5},
    {"adaptive to target 0.006", 4096, 0.006, 1, 6},
};

static rd_job *make_job(const rd_scene *s, const mode *m)
{
    rd_job_options o = {TILE, {s->render.samples, 0, m->target, m->adaptive}, 1, 0, NULL};
    rd_job *j;
    rd_error err = {0};
    rd_error_code rc = rd_job_create(s, &o, &j, &err);
    cr_assert_eq(rc, RD_OK, "%s: rd_job_create: %s", m->name, err.message);
    return j;
}

static void render_all_tiles(rd_job *j)
{
    rd_job_counts c = {0};
    for (int t = 0; t < rd_job_tile_count(j); t++)
        cr_assert(rd_job_render_tile(j, t, &c), "tile %d did not finish", t);
}

static unsigned char *save_tile(const rd_job *j, int t, size_t *len)
{
    *len = rd_job_tile_state_bytes(j, t);
    cr_assert_gt(*len, 0, "tile %d: no state", t);
    unsigned char *b = malloc(*len);
    cr_assert(b);
    rd_job_tile_state_save(j, t, b);
    return b;
}

/* ---- what a render ends with ------------------------------------------------------------ */

typedef struct {
    uint8_t *rgb;
    double error;
    rd_render_stats st;
    rd_job_schedule sc;
} outcome;

static void outcome_of(const rd_job *j, outcome *o)
{
    o->rgb = malloc((size_t)rd_job_width(j) * rd_job_height(j) * 3);
    cr_assert(o->rgb);
    rd_job_rgb8(j, o->rgb);
    o->error = rd_job_error_estimate(j);
    memset(&o->st, 0, sizeof o->st);
    rd_job_stats(j, &o->st);
    rd_job_schedule_get(j, &o->sc);
}

static void check_same_schedule(const rd_job_schedule *a, const rd_job_schedule *b, const char *what)
{
    cr_assert(a->pass == b->pass && a->pass_samples == b->pass_samples && a->spp == b->spp &&
                  a->passes_done == b->passes_done && a->stopped_by == b->stopped_by && a->curve_len == b->curve_len,
              "%s: pass %d/%d, %d/%d samples, spp %d/%d, %d/%d done, stopped by %d/%d, %d/%d points", what, a->pass,
              b->pass, a->pass_samples, b->pass_samples, a->spp, b->spp, a->passes_done, b->passes_done,
              (int)a->stopped_by, (int)b->stopped_by, a->curve_len, b->curve_len);
    cr_assert(a->mean_weight == b->mean_weight && a->error == b->error && a->last_pass_ms == b->last_pass_ms,
              "%s: mean weight %.17g/%.17g, error %.17g/%.17g, last pass %g/%g ms", what, a->mean_weight,
              b->mean_weight, a->error, b->error, a->last_pass_ms, b->last_pass_ms);
    for (int i = 0; i < a->curve_len; i++)
        cr_assert(a->curve[i].ms == b->curve[i].ms && a->curve[i].samples == b->curve[i].samples &&
                      a->curve[i].error == b->curve[i].error,
                  "%s: curve point %d: %g/%g ms, %.17g/%.17g samples, error %.17g/%.17g", what, i, a->curve[i].ms,
                  b->curve[i].ms, a->curve[i].samples, b->curve[i].samples, a->curve[i].error, b->curve[i].error);
}

/* Everything but wall times: those of the plan are each job's own. */
static void check_same_outcome(const outcome *a, const outcome *b, size_t nbytes, const char *what)
{
    size_t diff = 0;
    for (size_t i = 0; i < nbytes; i++)
        diff += a->rgb[i] != b->rgb[i];
    cr_assert_eq(diff, 0, "%s: %zu of %zu bytes differ", what, diff, nbytes);
    cr_assert(a->error == b->error, "%s: estimate %.17g vs %.17g", what, a->error, b->error);
    const rd_render_stats *s = &a->st, *t = &b->st;
    cr_assert(s->samples == t->samples && s->mean_samples == t->mean_samples && s->passes == t->passes &&
                  s->error_estimate == t->error_estimate && s->stopped_by == t->stopped_by &&
                  s->curve_len == t->curve_len,
              "%s: stats: %d/%d samples (mean %.17g/%.17g), %d/%d passes, estimate %.17g/%.17g, stopped by %d/%d, "
              "%d/%d points",
              what, s->samples, t->samples, s->mean_samples, t->mean_samples, s->passes, t->passes, s->error_estimate,
              t->error_estimate, (int)s->stopped_by, (int)t->stopped_by, s->curve_len, t->curve_len);
    for (int i = 0; i < s->curve_len; i++)
        cr_assert(s->curve[i].samples == t->curve[i].samples && s->curve[i].error == t->curve[i].error &&
                      s->curve[i].ms == t->curve[i].ms,
                  "%s: stats curve point %d differs", what, i);
    check_same_schedule(&a->sc, &b->sc, what);
}

/* ---- one job alone ----------------------------------------------------------------------- */

static void render_alone(const mode *m, outcome *o)
{
    rd_scene s;
    soft_shadow_scene(&s, m->samples);
    rd_job *j = make_job(&s, m);
    int p = 0;
    for (int n = rd_job_first_pass(j); n > 0; p++) {
        render_all_tiles(j);
        n = rd_job_end_pass_at(j, fake_elapsed(p), FAKE_PASS_MS);
    }
    outcome_of(j, o);
    rd_job_free(j);
    rd_scene_free(&s);
}

/* ---- two jobs ------------------------------------------------------------------------------
 *
 * Each pass, every tile goes to one of the two at random; a tile whose
 * latest state is on the other job is moved first. The job that ends the
 * pass (each in turn) gathers every tile, ends it, and hands the schedule
 * to the other. After pass 0 the other gets every tile too, so that from
 * then on both hold every tile, some stale: only the schedule may tell the
 * other the next pass's mean weight. */

typedef struct {
    rd_scene scene[2];
    rd_job *job[2];
    char *fresh[2]; /* fresh[k][t]: job k holds tile t's latest state */
    int tiles;
    int migrated; /* tiles moved to be rendered on the job that did not render their last pass */
    int stale;    /* tiles stale on a job given the schedule of pass 2 or later (before, it may never have had them) */
} farm;

static void move_tile(farm *f, int from, int to, int t)
{
    size_t len;
    unsigned char *b = save_tile(f->job[from], t, &len);
    cr_assert_eq(rd_job_tile_state_bytes(f->job[to], t), len);
    rd_error err = {0};
    rd_error_code rc = rd_job_tile_state_load(f->job[to], t, b, len, &err);
    cr_assert_eq(rc, RD_OK, "tile %d: %s", t, err.message);
    unsigned char *back = save_tile(f->job[to], t, &len);
    cr_assert(memcmp(b, back, len) == 0, "tile %d: the loaded state saves as other bytes", t);
    f->fresh[to][t] = 1;
    free(back);
    free(b);
}

static void gather(farm *f, int into)
{
    for (int t = 0; t < f->tiles; t++)
        if (!f->fresh[into][t])
            move_tile(f, 1 - into, into, t);
}

static void hand_schedule(farm *f, int from, const char *what)
{
    rd_job_schedule sc, back;
    rd_job_schedule_get(f->job[from], &sc);
    rd_error err = {0};
    rd_error_code rc = rd_job_schedule_set(f->job[1 - from], &sc, &err);
    cr_assert_eq(rc, RD_OK, "%s: schedule_set: %s", what, err.message);
    rd_job_schedule_get(f->job[1 - from], &back);
    check_same_schedule(&sc, &back, what);
    cr_assert_eq(rd_job_pass_samples(f->job[1 - from]), sc.pass_samples);
    cr_assert_eq(rd_job_samples_done(f->job[1 - from]), sc.spp);
}

static void farm_pass(farm *f, int p, test_rng *g)
{
    int on[2] = {0, 0};
    for (int t = 0; t < f->tiles; t++) {
        int k = rng_int(g, 2);
        if (p > 0 && !f->fresh[k][t]) {
            move_tile(f, 1 - k, k, t);
            f->migrated++;
        }
        rd_job_counts c = {0};
        cr_assert(rd_job_render_tile(f->job[k], t, &c));
        f->fresh[k][t] = 1;
        f->fresh[1 - k][t] = 0;
        on[k]++;
    }
    cr_assert(on[0] > 0 && on[1] > 0, "pass %d went to one job only: take another seed", p);
}

static int count_stale(const farm *f, int k)
{
    int n = 0;
    for (int t = 0; t < f->tiles; t++)
        n += !f->fresh[k][t];
    return n;
}

/* The farm's outcome on both jobs, once each holds every tile. */
static void render_farm(const mode *m, uint64_t seed, farm *f, outcome o[2])
{
    memset(f, 0, sizeof *f);
    for (int k = 0; k < 2; k++) {
        soft_shadow_scene(&f->scene[k], m->samples);
        f->job[k] = make_job(&f->scene[k], m);
    }
    f->tiles = rd_job_tile_count(f->job[0]);
    for (int k = 0; k < 2; k++) {
        f->fresh[k] = calloc((size_t)f->tiles, 1);
        cr_assert(f->fresh[k]);
    }
    test_rng g = {seed};
    int n = rd_job_first_pass(f->job[0]), last = 0;
    hand_schedule(f, 0, m->name);
    for (int p = 0; n > 0; p++) {
        farm_pass(f, p, &g);
        last = p % 2;
        gather(f, last);
        n = rd_job_end_pass_at(f->job[last], fake_elapsed(p), FAKE_PASS_MS);
        if (p > 0)
            f->stale += count_stale(f, 1 - last);
        hand_schedule(f, last, m->name);
        if (p == 0)
            gather(f, 1 - last);
    }
    gather(f, 1 - last);
    for (int k = 0; k < 2; k++)
        outcome_of(f->job[k], &o[k]);
    for (int k = 0; k < 2; k++) {
        rd_job_free(f->job[k]);
        rd_scene_free(&f->scene[k]);
        free(f->fresh[k]);
    }
}

static void check_farm(const mode *m)
{
    outcome alone, two[2];
    render_alone(m, &alone);
    farm f;
    render_farm(m, 0x5eed0000u + (uint64_t)m->samples, &f, two);
    size_t nbytes = 32 * 24 * 3;
    printf("%s: %d passes, %g samples, estimate %.6f, stopped by %s; %d tiles migrated, %d stale at a hand-over\n",
           m->name, alone.st.passes, alone.st.mean_samples, alone.error, rd_stop_reason_name(alone.st.stopped_by),
           f.migrated, f.stale);
    cr_assert_geq(alone.st.passes, m->min_passes, "%s: %d passes", m->name, alone.st.passes);
    if (alone.st.passes > 1)
        cr_assert_gt(f.migrated, 0, "%s: no tile moved between passes", m->name);
    if (m->adaptive)
        cr_assert_gt(f.stale, 0, "%s: the schedule was never handed to a job with stale tiles", m->name);
    char what[96];
    for (int k = 0; k < 2; k++) {
        snprintf(what, sizeof what, "%s, job %c of the farm against one job", m->name, 'A' + k);
        check_same_outcome(&two[k], &alone, nbytes, what);
        free(two[k].rgb);
    }

    /* The job alone renders what rd_render does (rd_job_end_pass, the real
     * clock: without a budget, the schedule does not depend on it). */
    rd_scene s;
    soft_shadow_scene(&s, m->samples);
    rd_render_options ro = {.threads = 2, .tile = 8, .target_error = m->target, .adaptive = m->adaptive};
    rd_render_stats rst;
    uint8_t *b = render_bytes(&s, &ro, NULL, &rst);
    cr_assert(memcmp(b, alone.rgb, nbytes) == 0, "%s: rd_render gives other bytes", m->name);
    cr_assert(rst.error_estimate == alone.error && rst.passes == alone.st.passes &&
                  rst.mean_samples == alone.st.mean_samples && rst.stopped_by == alone.st.stopped_by,
              "%s: rd_render: estimate %.17g, %d passes, %g samples", m->name, rst.error_estimate, rst.passes,
              rst.mean_samples);
    free(b);
    rd_scene_free(&s);
    free(alone.rgb);
}

Test(job_state, farm_fixed_one_sample) { check_farm(&modes[0]); }

Test(job_state, farm_fixed_eight_samples) { check_farm(&modes[1]); }

Test(job_state, farm_progressive_to_target, .timeout = 60) { check_farm(&modes[2]); }

Test(job_state, farm_adaptive_to_samples, .timeout = 60) { check_farm(&modes[3]); }

Test(job_state, farm_adaptive_to_target, .timeout = 60) { check_farm(&modes[4]); }

/* ---- loading checks what it is given -------------------------------------------------------- */

/* A job of the mode in the scene, its first pass rendered and ended. */
static rd_job *job_after_first_pass(rd_scene *s, const mode *m)
{
    soft_shadow_scene(s, m->samples);
    rd_job *j = make_job(s, m);
    rd_job_first_pass(j);
    render_all_tiles(j);
    rd_job_end_pass_at(j, fake_elapsed(0), FAKE_PASS_MS);
    return j;
}

/* Loads len bytes into tile t and expects rc; a rejection must say why and
 * leave the tile as it was. */
static void expect_load(rd_job *j, int t, const void *in, size_t len, rd_error_code want, const char *what)
{
    size_t before_len;
    unsigned char *before = save_tile(j, t, &before_len);
    rd_error err = {0};
    rd_error_code rc = rd_job_tile_state_load(j, t, in, len, &err);
    cr_assert_eq(rc, want, "%s: load gave %s (%s), want %s", what, rd_error_name(rc), err.message, rd_error_name(want));
    size_t after_len;
    unsigned char *after = save_tile(j, t, &after_len);
    if (rc != RD_OK) {
        cr_assert_eq(err.code, rc, "%s", what);
        cr_assert(err.message[0], "%s: rejected without a message", what);
        cr_assert(memcmp(before, after, before_len) == 0, "%s: a rejected load changed the tile", what);
    } else {
        cr_assert(memcmp(in, after, after_len) == 0, "%s: the tile does not hold what was loaded", what);
    }
    free(after);
    free(before);
}

Test(job_state, state_sizes_are_the_arrays_the_job_keeps)
{
    /* Per pixel: mean 24 and count 4 bytes; the half-sets 24 + 8 once there
     * is an estimate; the display statistics 24 more when adaptive. The last
     * tile is 2x4 pixels. */
    const struct {
        const mode *m;
        size_t per_pixel;
    } cases[] = {{&modes[0], 28}, {&modes[1], 60}, {&modes[2], 60}, {&modes[3], 84}};
    for (size_t c = 0; c < sizeof cases / sizeof *cases; c++) {
        rd_scene s;
        soft_shadow_scene(&s, cases[c].m->samples);
        rd_job *j = make_job(&s, cases[c].m);
        int last = rd_job_tile_count(j) - 1;
        cr_assert_eq(last, 11);
        cr_assert_eq(rd_job_tile_state_bytes(j, 0), 100 * cases[c].per_pixel, "%s", cases[c].m->name);
        cr_assert_eq(rd_job_tile_state_bytes(j, last), 8 * cases[c].per_pixel, "%s", cases[c].m->name);
        cr_assert_eq(rd_job_tile_state_bytes(j, -1), 0);
        cr_assert_eq(rd_job_tile_state_bytes(j, last + 1), 0);
        rd_job_free(j);
        rd_scene_free(&s);
    }
}

Test(job_state, load_rejects_wrong_sizes_and_tiles)
{
    rd_scene s;
    rd_job *j = job_after_first_pass(&s, &modes[3]);
    size_t len, small_len;
    unsigned char *b = save_tile(j, 0, &len), *small = save_tile(j, 11, &small_len);
    unsigned char *big = calloc(len + 1, 1);
    memcpy(big, b, len);
    expect_load(j, 0, b, len, RD_OK, "tile 0 as saved");
    expect_load(j, 11, small, small_len, RD_OK, "tile 11 as saved");
    expect_load(j, 0, b, len - 1, RD_ERR_INVALID, "one byte short");
    expect_load(j, 0, big, len + 1, RD_ERR_INVALID, "one byte over");
    expect_load(j, 0, b, 0, RD_ERR_INVALID, "empty");
    expect_load(j, 0, small, small_len, RD_ERR_INVALID, "the 2x4 tile's state into a 10x10 tile");
    expect_load(j, 11, b, len, RD_ERR_INVALID, "a 10x10 tile's state into the 2x4 tile");
    rd_error err = {0};
    cr_assert_eq(rd_job_tile_state_load(j, -1, b, len, &err), RD_ERR_INVALID);
    cr_assert_eq(rd_job_tile_state_load(j, 12, small, small_len, &err), RD_ERR_INVALID);
    free(big);
    free(small);
    free(b);
    rd_job_free(j);
    rd_scene_free(&s);
}

/* Where a value lies in the state of a tile of npix pixels (the layout
 * job.h gives), with all the arrays present. */
enum { A_MEAN, A_N, A_HALF, A_NH, A_STAT };

static size_t at(int array, size_t npix, size_t pixel, size_t k)
{
    const size_t per[] = {24, 4, 24, 8, 24}, elem[] = {8, 4, 4, 4, 4};
    size_t off = 0;
    for (int a = 0; a < array; a++)
        off += per[a] * npix;
    return off + pixel * per[array] + k * elem[array];
}

static void poke_f64(unsigned char *b, size_t off, double v) { memcpy(b + off, &v, sizeof v); }
static void poke_f32(unsigned char *b, size_t off, float v) { memcpy(b + off, &v, sizeof v); }
static void poke_u32(unsigned char *b, size_t off, uint32_t v) { memcpy(b + off, &v, sizeof v); }
static uint32_t peek_u32(const unsigned char *b, size_t off)
{
    uint32_t v;
    memcpy(&v, b + off, sizeof v);
    return v;
}

typedef void (*poke_fn)(unsigned char *b, size_t npix);

static void mean_nan(unsigned char *b, size_t np) { poke_f64(b, at(A_MEAN, np, 37, 1), NAN); }
static void mean_inf(unsigned char *b, size_t np) { poke_f64(b, at(A_MEAN, np, 0, 0), INFINITY); }
static void mean_ninf(unsigned char *b, size_t np) { poke_f64(b, at(A_MEAN, np, 99, 2), -INFINITY); }
static void half_nan(unsigned char *b, size_t np) { poke_f32(b, at(A_HALF, np, 5, 4), NAN); }
static void half_inf(unsigned char *b, size_t np) { poke_f32(b, at(A_HALF, np, 63, 0), INFINITY); }
static void dmean_nan(unsigned char *b, size_t np) { poke_f32(b, at(A_STAT, np, 12, 0), NAN); }
static void dmean_over(unsigned char *b, size_t np) { poke_f32(b, at(A_STAT, np, 12, 2), 1.5f); }
static void dmean_under(unsigned char *b, size_t np) { poke_f32(b, at(A_STAT, np, 12, 1), -0.25f); }
static void m2_inf(unsigned char *b, size_t np) { poke_f32(b, at(A_STAT, np, 40, 3), INFINITY); }
static void m2_nan(unsigned char *b, size_t np) { poke_f32(b, at(A_STAT, np, 40, 5), NAN); }
static void m2_huge(unsigned char *b, size_t np) { poke_f32(b, at(A_STAT, np, 40, 4), 1e6f); }
static void m2_very_negative(unsigned char *b, size_t np) { poke_f32(b, at(A_STAT, np, 41, 4), -3.0f); }
static void nh_plus_one(unsigned char *b, size_t np)
{
    poke_u32(b, at(A_NH, np, 7, 0), peek_u32(b, at(A_NH, np, 7, 0)) + 1);
}
static void n_plus_one(unsigned char *b, size_t np)
{
    poke_u32(b, at(A_N, np, 7, 0), peek_u32(b, at(A_N, np, 7, 0)) + 1);
}
/* Counts that add up, split the wrong way round: 3 samples are 2 in half 0. */
static void halves_swapped(unsigned char *b, size_t np)
{
    poke_u32(b, at(A_N, np, 8, 0), 3);
    poke_u32(b, at(A_NH, np, 8, 0), 1);
    poke_u32(b, at(A_NH, np, 8, 1), 2);
}
/* Consistent counts, over what 32 samples can give (64 x 32 = 2048). */
static void n_over_the_schedule(unsigned char *b, size_t np)
{
    poke_u32(b, at(A_N, np, 9, 0), 2050);
    poke_u32(b, at(A_NH, np, 9, 0), 1025);
    poke_u32(b, at(A_NH, np, 9, 1), 1025);
}
static void n_wraps(unsigned char *b, size_t np)
{
    poke_u32(b, at(A_N, np, 9, 0), UINT32_MAX);
    poke_u32(b, at(A_NH, np, 9, 0), 1u << 31);
    poke_u32(b, at(A_NH, np, 9, 1), (1u << 31) - 1);
}
/* What the renderer can write: negative linear colours (a scene's
 * background or light may be), the most a pass can give a pixel, a
 * rounding below zero in a sum of squares, display means at the ends. */
static void mean_negative(unsigned char *b, size_t np) { poke_f64(b, at(A_MEAN, np, 37, 1), -0.5); }
static void half_negative(unsigned char *b, size_t np) { poke_f32(b, at(A_HALF, np, 37, 4), -0.5f); }
static void mean_huge(unsigned char *b, size_t np) { poke_f64(b, at(A_MEAN, np, 37, 0), DBL_MAX); }
static void n_at_the_schedule(unsigned char *b, size_t np)
{
    poke_u32(b, at(A_N, np, 9, 0), 2048);
    poke_u32(b, at(A_NH, np, 9, 0), 1024);
    poke_u32(b, at(A_NH, np, 9, 1), 1024);
}
static void m2_rounding(unsigned char *b, size_t np) { poke_f32(b, at(A_STAT, np, 40, 3), -1e-7f); }
static void dmean_ends(unsigned char *b, size_t np)
{
    poke_f32(b, at(A_STAT, np, 12, 0), 0.0f);
    poke_f32(b, at(A_STAT, np, 12, 1), 1.0f);
}

Test(job_state, load_rejects_what_no_render_writes)
{
    const struct {
        const char *what;
        poke_fn poke;
        rd_error_code want;
    } cases[] = {
        {"NaN mean", mean_nan, RD_ERR_INVALID},
        {"infinite mean", mean_inf, RD_ERR_INVALID},
        {"-infinite mean", mean_ninf, RD_ERR_INVALID},
        {"NaN half-set mean", half_nan, RD_ERR_INVALID},
        {"infinite half-set mean", half_inf, RD_ERR_INVALID},
        {"NaN display mean", dmean_nan, RD_ERR_INVALID},
        {"display mean 1.5", dmean_over, RD_ERR_INVALID},
        {"display mean -0.25", dmean_under, RD_ERR_INVALID},
        {"infinite sum of squares", m2_inf, RD_ERR_INVALID},
        {"NaN sum of squares", m2_nan, RD_ERR_INVALID},
        {"sum of squares 1e6", m2_huge, RD_ERR_INVALID},
        {"sum of squares -3", m2_very_negative, RD_ERR_INVALID},
        {"a half-set count one over", nh_plus_one, RD_ERR_INVALID},
        {"a count one over its halves", n_plus_one, RD_ERR_INVALID},
        {"halves split the wrong way round", halves_swapped, RD_ERR_INVALID},
        {"2050 samples of 32 adaptive", n_over_the_schedule, RD_ERR_INVALID},
        {"2^32 - 1 samples", n_wraps, RD_ERR_INVALID},
        {"a negative linear mean", mean_negative, RD_OK},
        {"a negative half-set mean", half_negative, RD_OK},
        {"a mean of DBL_MAX (a non-finite sample replaced)", mean_huge, RD_OK},
        {"2048 samples of 32 adaptive", n_at_the_schedule, RD_OK},
        {"a sum of squares rounded below 0", m2_rounding, RD_OK},
        {"display means 0 and 1", dmean_ends, RD_OK},
    };
    rd_scene s;
    rd_job *j = job_after_first_pass(&s, &modes[3]);
    size_t len;
    unsigned char *orig = save_tile(j, 0, &len), *b = malloc(len);
    cr_assert_eq(len, 100 * 84);
    for (size_t c = 0; c < sizeof cases / sizeof *cases; c++) {
        memcpy(b, orig, len);
        cases[c].poke(b, 100);
        cr_assert(memcmp(b, orig, len) != 0, "%s: the poke changed nothing", cases[c].what);
        expect_load(j, 0, b, len, cases[c].want, cases[c].what);
        expect_load(j, 0, orig, len, RD_OK, "the state as saved");
    }
    free(b);
    free(orig);
    rd_job_free(j);
    rd_scene_free(&s);
}

Test(job_state, load_bounds_counts_by_the_schedule)
{
    /* One centre sample, no half-sets: a count is 0 or 1. */
    rd_scene s;
    rd_job *j = job_after_first_pass(&s, &modes[0]);
    size_t len;
    unsigned char *b = save_tile(j, 0, &len);
    cr_assert_eq(len, 100 * 28);
    size_t n_at = 100 * 24 + 4 * 5;
    cr_assert_eq(peek_u32(b, n_at), 1);
    poke_u32(b, n_at, 0);
    expect_load(j, 0, b, len, RD_OK, "0 samples of 1");
    poke_u32(b, n_at, 2);
    expect_load(j, 0, b, len, RD_ERR_INVALID, "2 samples of 1");
    poke_u32(b, n_at, UINT32_MAX);
    expect_load(j, 0, b, len, RD_ERR_INVALID, "2^32 - 1 samples of 1");
    free(b);
    rd_job_free(j);
    rd_scene_free(&s);
}

Test(job_state, negative_background_round_trips)
{
    /* The scene format takes any colour; display clamps a negative one to
     * black. What such a render writes loads into another job. */
    rd_scene s;
    soft_shadow_scene(&s, 8);
    s.render.background = v3(-0.5, 0.25, -2);
    s.camera.target = v3(0, 4, 0); /* the sky above the horizon */
    rd_job *a = make_job(&s, &modes[1]), *b = make_job(&s, &modes[1]);
    rd_job_first_pass(a);
    render_all_tiles(a);
    int negative = 0;
    for (int t = 0; t < rd_job_tile_count(a); t++) {
        size_t len;
        unsigned char *st = save_tile(a, t, &len);
        /* 60 bytes a pixel, the means first. */
        for (size_t i = 0; i < len / 60 * 3; i++) {
            double v;
            memcpy(&v, st + 8 * i, sizeof v);
            negative += v < 0;
        }
        rd_error err = {0};
        cr_assert_eq(rd_job_tile_state_load(b, t, st, len, &err), RD_OK, "tile %d: %s", t, err.message);
        free(st);
    }
    cr_assert_gt(negative, 0, "no negative mean: the test shows nothing");
    rd_job_free(b);
    rd_job_free(a);
    rd_scene_free(&s);
}

/* ---- hostile bytes ------------------------------------------------------------------------- */

/* An aligned value of the state replaced with one that tends to break
 * things, or random bytes anywhere. */
static void mutate(unsigned char *b, size_t len, test_rng *g)
{
    static const double doubles[] = {NAN, INFINITY, -INFINITY, DBL_MAX, -DBL_MAX, 0.0, -0.0, 1e300, 5e-324, -1};
    static const float floats[] = {NAN, INFINITY, -INFINITY, FLT_MAX, -FLT_MAX, 1.0f, 1.0000001f, -1e-30f, 1e-45f, 2};
    static const uint32_t counts[] = {0, 1, 2, 3, 0x7fffffff, 0x80000000, 0xffffffff, 2048, 2049, 4096};
    int kind = rng_int(g, 4);
    if (kind == 0 && len >= 8) {
        poke_f64(b, 8 * (size_t)rng_int(g, (int)(len / 8)), doubles[rng_int(g, 10)]);
    } else if (kind == 1) {
        poke_f32(b, 4 * (size_t)rng_int(g, (int)(len / 4)), floats[rng_int(g, 10)]);
    } else if (kind == 2) {
        poke_u32(b, 4 * (size_t)rng_int(g, (int)(len / 4)), counts[rng_int(g, 10)]);
    } else {
        for (int k = 1 + rng_int(g, 4); k > 0; k--)
            b[rng_int(g, (int)len)] = (unsigned char)rng_u64(g);
    }
}

/* Loads mutated and random states into tile t of j; whatever is accepted is
 * rendered on (when the job is in a pass that reads its pixels), and must
 * then still load. Counts the loads accepted and rejected. */
static void hostile_loads(rd_job *j, int t, int render_on, test_rng *g, int rounds, int counts[2])
{
    size_t len;
    unsigned char *orig = save_tile(j, t, &len), *b = malloc(len);
    for (int r = 0; r < rounds; r++) {
        if (r % 4 == 3) {
            for (size_t i = 0; i < len; i++)
                b[i] = (unsigned char)rng_u64(g);
        } else {
            memcpy(b, orig, len);
            for (int k = 1 + rng_int(g, 3); k > 0; k--)
                mutate(b, len, g);
        }
        rd_error err = {0};
        rd_error_code rc = rd_job_tile_state_load(j, t, b, len, &err);
        cr_assert(rc == RD_OK || rc == RD_ERR_INVALID, "round %d: %s", r, rd_error_name(rc));
        counts[rc == RD_OK]++;
        size_t got_len;
        unsigned char *got = save_tile(j, t, &got_len);
        cr_assert(memcmp(got, rc == RD_OK ? b : orig, len) == 0, "round %d: the tile holds %s", r,
                  rc == RD_OK ? "other bytes than it accepted" : "other bytes after a rejection");
        free(got);
        if (rc == RD_OK && render_on) {
            rd_job_counts c = {0};
            cr_assert(rd_job_render_tile(j, t, &c));
            cr_assert(isfinite(rd_job_error_estimate(j)), "round %d: the estimate is not finite", r);
            unsigned char *after = save_tile(j, t, &got_len);
            rc = rd_job_tile_state_load(j, t, after, len, &err);
            cr_assert_eq(rc, RD_OK, "round %d: an accepted state, rendered on, is rejected: %s", r, err.message);
            free(after);
        }
        if (rc == RD_OK)
            expect_load(j, t, orig, len, RD_OK, "the state as saved");
    }
    free(b);
    free(orig);
}

Test(job_state, load_survives_hostile_bytes, .timeout = 120)
{
    /* Every layout: no half-sets, half-sets, and the adaptive statistics in
     * a pass that weighs them; a whole tile and the 2x4 one. */
    const mode *ms[] = {&modes[0], &modes[2], &modes[3]};
    test_rng g = {0xbadb17e5};
    for (int i = 0; i < 3; i++) {
        rd_scene s;
        rd_job *j = job_after_first_pass(&s, ms[i]);
        rd_job_schedule sc;
        rd_job_schedule_get(j, &sc);
        int render_on = sc.pass > 0 && sc.passes_done == sc.pass;
        cr_assert_eq(render_on, ms[i]->target > 0, "%s: pass %d, %d done", ms[i]->name, sc.pass, sc.passes_done);
        int counts[2] = {0, 0};
        hostile_loads(j, 0, render_on, &g, 1500, counts);
        hostile_loads(j, 11, render_on, &g, 1500, counts);
        printf("%s: %d hostile states rejected, %d accepted\n", ms[i]->name, counts[0], counts[1]);
        cr_assert(counts[0] > 0 && counts[1] > 0, "%s: %d rejected, %d accepted: the fuzz tests one side only",
                  ms[i]->name, counts[0], counts[1]);
        rd_job_free(j);
        rd_scene_free(&s);
    }
}

/* ---- the schedule -------------------------------------------------------------------------- */

typedef void (*sched_fn)(rd_job_schedule *sc);

/* Each change breaks one rule only: the rest of the schedule still agrees. */
static void pass_negative(rd_job_schedule *sc)
{
    sc->pass = -1;
    sc->passes_done = sc->curve_len = 0;
    sc->mean_weight = 0;
    sc->stopped_by = RD_STOP_SAMPLES;
}
static void samples_zero(rd_job_schedule *sc) { sc->pass_samples = 0; }
static void samples_negative(rd_job_schedule *sc) { sc->pass_samples = -3; }
static void samples_over_cap(rd_job_schedule *sc) { sc->pass_samples = 33; }
static void done_two_ahead(rd_job_schedule *sc)
{
    sc->passes_done = sc->pass + 2;
    sc->spp = 8;
    sc->stopped_by = RD_STOP_SAMPLES;
    sc->curve[1] = (rd_curve_point){60, 4, 0.02};
    sc->curve[2] = (rd_curve_point){70, 8, 0.01};
    sc->curve_len = 3;
}
static void done_behind(rd_job_schedule *sc)
{
    sc->passes_done = sc->pass - 1;
    sc->curve_len = 0;
    sc->stopped_by = RD_STOP_SAMPLES;
}
static void spp_negative(rd_job_schedule *sc) { sc->spp = -1; }
static void spp_over_cap(rd_job_schedule *sc) { sc->spp = 33; }
static void spp_under_passes(rd_job_schedule *sc) { sc->spp = 0; }
static void curve_negative(rd_job_schedule *sc) { sc->curve_len = -1; }
static void curve_over_max(rd_job_schedule *sc) { sc->curve_len = RD_CURVE_MAX + 1; }
static void curve_short(rd_job_schedule *sc) { sc->curve_len = 0; }
static void curve_long(rd_job_schedule *sc) { sc->curve_len = 2; }
static void weight_nan(rd_job_schedule *sc) { sc->mean_weight = NAN; }
static void weight_inf(rd_job_schedule *sc) { sc->mean_weight = INFINITY; }
static void error_nan(rd_job_schedule *sc) { sc->error = NAN; }
static void error_negative(rd_job_schedule *sc) { sc->error = -1e-3; }
static void error_inf(rd_job_schedule *sc) { sc->error = INFINITY; }
static void last_ms_nan(rd_job_schedule *sc) { sc->last_pass_ms = NAN; }
static void last_ms_negative(rd_job_schedule *sc) { sc->last_pass_ms = -1; }
static void point_ms_nan(rd_job_schedule *sc) { sc->curve[0].ms = NAN; }
static void point_samples_inf(rd_job_schedule *sc) { sc->curve[0].samples = INFINITY; }
static void point_error_negative(rd_job_schedule *sc) { sc->curve[0].error = -1; }
static void stop_in_progress(rd_job_schedule *sc) { sc->stopped_by = RD_STOP_SAMPLES; }
/* The last pass ended: rd_job_end_pass leaves passes_done = pass + 1. */
static void ended(rd_job_schedule *sc)
{
    sc->passes_done = sc->pass + 1;
    sc->spp += sc->pass_samples;
    sc->stopped_by = RD_STOP_TARGET_ERROR;
    sc->curve[sc->curve_len++] = (rd_curve_point){80, 4, 0.01};
}
static void ended_without_reason(rd_job_schedule *sc)
{
    ended(sc);
    sc->stopped_by = RD_STOP_NONE;
}
static void stop_negative(rd_job_schedule *sc)
{
    ended(sc);
    sc->stopped_by = (rd_stop_reason)-1;
}
static void stop_past_enum(rd_job_schedule *sc)
{
    ended(sc);
    sc->stopped_by = (rd_stop_reason)(RD_STOP_CANCELLED + 1);
}
/* More passes than the curve keeps (1-sample passes: 70 of 32 samples are
 * over the cap, so 30). */
static void long_render(rd_job_schedule *sc)
{
    sc->pass = sc->passes_done = 30;
    sc->spp = 30;
    sc->pass_samples = 2;
    sc->curve_len = 30;
    for (int i = 1; i < 30; i++)
        sc->curve[i] = (rd_curve_point){50.0 + i, 2.0 + i, 0.01};
}
static void weight_negative(rd_job_schedule *sc) { sc->mean_weight = -1e-9; }

Test(job_state, schedule_set_checks_what_it_is_given)
{
    const struct {
        const char *what;
        sched_fn change;
        rd_error_code want;
    } cases[] = {
        {"a negative pass", pass_negative, RD_ERR_INVALID},
        {"0 samples", samples_zero, RD_ERR_INVALID},
        {"-3 samples", samples_negative, RD_ERR_INVALID},
        {"33 samples of 32", samples_over_cap, RD_ERR_INVALID},
        {"two passes more done than begun", done_two_ahead, RD_ERR_INVALID},
        {"fewer passes done than the one in progress", done_behind, RD_ERR_INVALID},
        {"spp -1", spp_negative, RD_ERR_INVALID},
        {"spp over the cap", spp_over_cap, RD_ERR_INVALID},
        {"fewer samples than passes done", spp_under_passes, RD_ERR_INVALID},
        {"curve_len -1", curve_negative, RD_ERR_INVALID},
        {"curve_len over RD_CURVE_MAX", curve_over_max, RD_ERR_INVALID},
        {"no curve point for the pass done", curve_short, RD_ERR_INVALID},
        {"two curve points for one pass done", curve_long, RD_ERR_INVALID},
        {"NaN mean weight", weight_nan, RD_ERR_INVALID},
        {"infinite mean weight", weight_inf, RD_ERR_INVALID},
        {"NaN error", error_nan, RD_ERR_INVALID},
        {"negative error", error_negative, RD_ERR_INVALID},
        {"infinite error", error_inf, RD_ERR_INVALID},
        {"NaN pass time", last_ms_nan, RD_ERR_INVALID},
        {"negative pass time", last_ms_negative, RD_ERR_INVALID},
        {"NaN curve time", point_ms_nan, RD_ERR_INVALID},
        {"infinite curve samples", point_samples_inf, RD_ERR_INVALID},
        {"negative curve error", point_error_negative, RD_ERR_INVALID},
        {"stop reason -1", stop_negative, RD_ERR_INVALID},
        {"stop reason past the enum", stop_past_enum, RD_ERR_INVALID},
        {"a stop reason with a pass in progress", stop_in_progress, RD_ERR_INVALID},
        {"the render ended without a stop reason", ended_without_reason, RD_ERR_INVALID},
        {"the render ended (passes done = pass + 1)", ended, RD_OK},
        {"30 passes", long_render, RD_OK},
        {"a negative mean weight (rounding)", weight_negative, RD_OK},
    };
    rd_scene s;
    rd_job *j = job_after_first_pass(&s, &modes[3]), *other = make_job(&s, &modes[3]);
    rd_job_schedule base;
    rd_job_schedule_get(j, &base);
    cr_assert(base.pass == 1 && base.passes_done == 1 && base.curve_len == 1 && base.mean_weight > 0 &&
                  base.stopped_by == RD_STOP_NONE && base.spp == 2 && base.pass_samples == 2,
              "the adaptive job after its first pass: pass %d, %d done, %d points, weight %g", base.pass,
              base.passes_done, base.curve_len, base.mean_weight);
    for (size_t c = 0; c < sizeof cases / sizeof *cases; c++) {
        rd_job_schedule sc = base, before, after;
        cases[c].change(&sc);
        rd_job_schedule_get(other, &before);
        rd_error err = {0};
        rd_error_code rc = rd_job_schedule_set(other, &sc, &err);
        cr_assert_eq(rc, cases[c].want, "%s: %s (%s)", cases[c].what, rd_error_name(rc), err.message);
        rd_job_schedule_get(other, &after);
        if (rc) {
            cr_assert(err.message[0], "%s: rejected without a message", cases[c].what);
            check_same_schedule(&after, &before, cases[c].what);
        } else {
            check_same_schedule(&after, &sc, cases[c].what);
        }
    }
    rd_job_free(other);
    rd_job_free(j);
    rd_scene_free(&s);
}

Test(job_state, schedule_set_takes_no_weight_where_no_pass_weighs)
{
    /* begin_pass weighs pixels only in adaptive passes after the first. */
    rd_scene s;
    rd_job *j = job_after_first_pass(&s, &modes[2]);
    rd_job_schedule sc;
    rd_job_schedule_get(j, &sc);
    rd_error err = {0};
    cr_assert_eq(rd_job_schedule_set(j, &sc, &err), RD_OK, "%s", err.message);
    sc.mean_weight = 0.5;
    cr_assert_eq(rd_job_schedule_set(j, &sc, &err), RD_ERR_INVALID, "a weight for a uniform render");
    rd_job_free(j);
    rd_scene_free(&s);

    soft_shadow_scene(&s, 32);
    j = make_job(&s, &modes[3]);
    rd_job_first_pass(j);
    rd_job_schedule_get(j, &sc);
    cr_assert_eq(rd_job_schedule_set(j, &sc, &err), RD_OK, "%s", err.message);
    sc.mean_weight = 0.5;
    cr_assert_eq(rd_job_schedule_set(j, &sc, &err), RD_ERR_INVALID, "a weight for an adaptive render's first pass");
    rd_job_free(j);
    rd_scene_free(&s);
}

Test(job_state, any_mean_weight_renders)
{
    /* A pixel whose sums of squares rounded below 0 has a negative weight;
     * over a tiny mean from a schedule its share is far below -1 samples
     * (the sanitizer build checks the conversion to a count). */
    const double weights[] = {1e-300, 1e300, 5e-324, -1};
    for (int w = 0; w < 4; w++) {
        rd_scene s;
        rd_job *j = job_after_first_pass(&s, &modes[3]);
        size_t len;
        unsigned char *b = save_tile(j, 0, &len);
        for (int k = 3; k < 6; k++)
            poke_f32(b, at(A_STAT, 100, 40, (size_t)k), -1e-7f);
        expect_load(j, 0, b, len, RD_OK, "negative sums of squares");
        rd_job_schedule sc;
        rd_job_schedule_get(j, &sc);
        sc.mean_weight = weights[w];
        rd_error err = {0};
        cr_assert_eq(rd_job_schedule_set(j, &sc, &err), RD_OK, "%s", err.message);
        render_all_tiles(j);
        cr_assert(isfinite(rd_job_error_estimate(j)));
        for (int t = 0; t < rd_job_tile_count(j); t++) {
            size_t tl;
            unsigned char *st = save_tile(j, t, &tl);
            expect_load(j, t, st, tl, RD_OK, "a tile rendered with any weight");
            free(st);
        }
        free(b);
        rd_job_free(j);
        rd_scene_free(&s);
    }
}

/* ---- the caller's clock -------------------------------------------------------------------- */

Test(job_state, end_pass_at_takes_the_callers_clock)
{
    /* A budget of 1000 ms. The first pass (2 samples) took 995 ms by the
     * caller's clock, 10 ms after the start: a doubled pass would not fit
     * in the 990 ms left, one sample does. Then at 2000 ms nothing is left. */
    rd_scene s;
    soft_shadow_scene(&s, 4096);
    rd_job_options o = {TILE, {4096, 1000, 0, 0}, 1, 0, NULL};
    rd_job *j;
    rd_error err = {0};
    cr_assert_eq(rd_job_create(&s, &o, &j, &err), RD_OK, "%s", err.message);
    cr_assert_eq(rd_job_first_pass(j), 2);
    render_all_tiles(j);
    cr_assert_eq(rd_job_end_pass_at(j, 10, 995), 1);
    rd_job_schedule sc;
    rd_job_schedule_get(j, &sc);
    cr_assert(sc.last_pass_ms == 995 && sc.curve_len == 1 && sc.curve[0].ms == 10 && sc.curve[0].samples == 2,
              "pass time %g, %d points, the first at %g ms", sc.last_pass_ms, sc.curve_len, sc.curve[0].ms);
    render_all_tiles(j);
    cr_assert_eq(rd_job_end_pass_at(j, 2000, 1), 0);
    rd_render_stats st;
    rd_job_stats(j, &st);
    cr_assert(st.stopped_by == RD_STOP_TIME_BUDGET && st.passes == 2 && st.curve[1].ms == 2000 && st.mean_samples == 3,
              "stopped by %s after %d passes, at %g ms, %g samples", rd_stop_reason_name(st.stopped_by), st.passes,
              st.curve[1].ms, st.mean_samples);
    rd_job_free(j);
    rd_scene_free(&s);
}
