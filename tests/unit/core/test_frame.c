/* The frame a render writes into (core/render/job.c): a one-sample render
 * stores its sample without the running mean's division, and one whose
 * caller wants only 8-bit pixels (rd_render_rgb8, rd_job_options.rgb8)
 * writes them straight, without a linear image or counts. Each must give
 * the bytes, counts and statistics of the general path, stopped or not. */
#include <criterion/criterion.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "camera.h"
#include "rayd/job.h"
#include "rayd/render.h"
#include "support/load.h"
#include "support/scene_fixture.h"
#include "trace.h"

/* A ball under a point light whose misses are (-0, -0.25, 0.5): a negative
 * zero the frame must store as +0, and a negative channel it must keep. */
static void signed_scene(rd_scene *s)
{
    fixture_scene(s, 9, 7);
    s->render.background = v3(-0.0, -0.25, 0.5);
    add_sphere(s, v3(0, 0, 0), 1, add_diffuse(s, v3(0.8, 0.3, 0.1), v3(0.05, 0, 0.01)));
    add_point_light(s, v3(2, 3, 5), v3(1, 1, 1));
}

static double general_mean(double c)
{
    /* pixel_add's running mean of a first sample, kept from being folded. */
    volatile uint32_t n = 1;
    double mean = 0;
    double v = isfinite(c) ? c : (isnan(c) ? 0 : (c > 0 ? DBL_MAX : -DBL_MAX));
    return mean + (v - mean) / n;
}

Test(frame, one_sample_mean_has_the_bits_of_the_general_mean)
{
    rd_scene s;
    signed_scene(&s);
    rd_image img;
    render_ok(&s, NULL, &img, NULL);
    rd_plan p;
    rd_pinhole cam;
    rd_error err = {0};
    cr_assert_eq(rd_plan_build(&p, &s, &err), RD_OK, "%s", err.message);
    cr_assert_eq(rd_pinhole_make(&cam, &s.camera, s.render.width, s.render.height, &err), RD_OK, "%s", err.message);
    int misses = 0;
    for (int y = 0; y < s.render.height; y++)
        for (int x = 0; x < s.render.width; x++) {
            rd_rng rng = {0};
            rd_ray_counts rc;
            rd_counts_init(&rc, 0, NULL);
            rd_rgb c = rd_trace(&p, rd_pinhole_ray(&cam, x + 0.5, y + 0.5), 0, &rng, &rc);
            double want[3] = {general_mean(c.x), general_mean(c.y), general_mean(c.z)};
            const double *got = &img.rgb[3 * ((size_t)y * (size_t)s.render.width + (size_t)x)];
            cr_assert(memcmp(got, want, sizeof want) == 0, "pixel (%d, %d): (%a, %a, %a), general (%a, %a, %a)", x, y,
                      got[0], got[1], got[2], want[0], want[1], want[2]);
            misses += signbit(c.x) != 0;
        }
    cr_assert_gt(misses, 0, "no pixel saw the -0 background");
    rd_plan_free(&p);
    rd_image_free(&img);
    rd_scene_free(&s);
}

/* ---- rd_render_rgb8 against rd_render ------------------------------------------------------ */

static void check_same_stats(const rd_render_stats *a, const rd_render_stats *b, const char *what)
{
    cr_assert(a->camera_rays == b->camera_rays && a->shadow_rays == b->shadow_rays &&
                  a->secondary_rays == b->secondary_rays && a->nonfinite == b->nonfinite,
              "%s: rays %llu/%llu camera, %llu/%llu shadow, %llu/%llu secondary", what,
              (unsigned long long)a->camera_rays, (unsigned long long)b->camera_rays,
              (unsigned long long)a->shadow_rays, (unsigned long long)b->shadow_rays,
              (unsigned long long)a->secondary_rays, (unsigned long long)b->secondary_rays);
    cr_assert(a->samples == b->samples && a->mean_samples == b->mean_samples && a->passes == b->passes &&
                  a->error_estimate == b->error_estimate && a->stopped_by == b->stopped_by,
              "%s: %d/%d samples (mean %.17g/%.17g), %d/%d passes, error %.17g/%.17g", what, a->samples, b->samples,
              a->mean_samples, b->mean_samples, a->passes, b->passes, a->error_estimate, b->error_estimate);
}

/* s rendered both ways with opt: the same bytes and statistics. */
static void check_rgb8_render(const rd_scene *s, const rd_render_options *opt, const char *what)
{
    rd_image img;
    rd_render_stats st, st8;
    render_ok(s, opt, &img, &st);
    size_t nbytes = (size_t)s->render.width * (size_t)s->render.height * 3;
    uint8_t *want = image_bytes(&img, s->render.gamma), *got = malloc(nbytes);
    cr_assert(got);
    memset(got, 0xa5, nbytes);
    rd_error err = {0};
    cr_assert_eq(rd_render_rgb8(s, opt, got, &st8, &err), RD_OK, "%s: %s", what, err.message);
    size_t diff = 0, first = 0;
    for (size_t i = nbytes; i-- > 0;)
        if (got[i] != want[i])
            diff++, first = i;
    cr_assert_eq(diff, 0, "%s: %zu of %zu bytes differ, the first at %zu (%d, want %d)", what, diff, nbytes, first,
                 got[first], want[first]);
    check_same_stats(&st8, &st, what);
    free(got);
    free(want);
    rd_image_free(&img);
}

/* Every scene at 176x128: 67,584 values, enough for the gamma table. */
static void check_scene_both_ways(rd_scene *s, const char *name)
{
    const double gammas[] = {1, 2.2};
    const int samples[] = {1, 3};
    int k = 0;
    s->render.width = 176;
    s->render.height = 128;
    for (int gi = 0; gi < 2; gi++)
        for (int si = 0; si < 2; si++, k++) {
            s->render.gamma = gammas[gi];
            s->render.samples = samples[si];
            rd_render_options o = {.threads = 1 + k % 2, .tile = k % 2 ? 16 : 7};
            o.packets = k % 3 == 0 ? RD_PACKETS_CAMERA | RD_PACKETS_SHADOW : 0;
            char what[160];
            snprintf(what, sizeof what, "%s, gamma %g, %d samples, %d threads, packets %u", name, s->render.gamma,
                     s->render.samples, o.threads, o.packets);
            check_rgb8_render(s, &o, what);
        }
    /* Progressive with a cap of one sample: a jittered sample, no shortcut. */
    s->render.samples = 1;
    rd_render_options prog = {.threads = 2, .target_error = 1e-9};
    check_rgb8_render(s, &prog, name);
}

Test(frame, rgb8_render_gives_rd_render_bytes_and_statistics, .timeout = 120)
{
    const char *files[] = {"scenes/phong.cfg", "scenes/mesh.cfg", "scenes/area_light.cfg", "scenes/textured_phong.cfg",
                           "scenes/specular_refraction.cfg"};
    for (size_t i = 0; i < sizeof files / sizeof *files; i++) {
        rd_scene s;
        load_cfg(files[i], &s);
        check_scene_both_ways(&s, files[i]);
        rd_scene_free(&s);
    }
    rd_scene s;
    signed_scene(&s);
    check_scene_both_ways(&s, "signed background");
    rd_scene_free(&s);
}

/* ---- a direct job ---------------------------------------------------------------------------- */

static rd_job *job_of(const rd_scene *s, uint8_t *rgb8)
{
    rd_job_options o = {10, {0}, 1, 0, rgb8};
    rd_job *j;
    rd_error err = {0};
    cr_assert_eq(rd_job_create(s, &o, &j, &err), RD_OK, "%s", err.message);
    cr_assert_eq(rd_job_first_pass(j), 1);
    return j;
}

/* A deadline long past stops each tile after its first few units of work:
 * the direct job leaves the same pixels black as the general one and
 * counts as many samples. */
Test(frame, stopped_direct_job_matches_the_general_job)
{
    rd_scene s;
    soft_shadow_scene(&s, 1);
    size_t nbytes = (size_t)s.render.width * (size_t)s.render.height * 3;
    uint8_t *direct = malloc(nbytes), *want = malloc(nbytes), *got = malloc(nbytes);
    cr_assert(direct && want && got);
    memset(direct, 0xa5, nbytes);
    rd_job *d = job_of(&s, direct), *g = job_of(&s, NULL);
    rd_job_counts cd = {0}, cg = {0};
    rd_job_set_deadline(d, 1);
    rd_job_set_deadline(g, 1);
    int stopped = 0;
    for (int t = 0; t < rd_job_tile_count(g); t++) {
        int a = rd_job_render_tile(d, t, &cd), b = rd_job_render_tile(g, t, &cg);
        cr_assert_eq(a, b, "tile %d: finished %d, general %d", t, a, b);
        stopped += !a;
    }
    cr_assert_gt(stopped, 0, "no tile was stopped");
    cr_assert(memcmp(&cd, &cg, sizeof cd) == 0, "counts differ");
    rd_job_rgb8(g, want);
    cr_assert(memcmp(direct, want, nbytes) == 0, "the frames differ");
    rd_job_rgb8(d, got);
    cr_assert(memcmp(got, want, nbytes) == 0, "rd_job_rgb8 of the direct job differs");
    double md = rd_job_mean_samples(d), mg = rd_job_mean_samples(g);
    cr_assert(md == mg && md > 0 && md < 1, "mean samples %.17g, general %.17g", md, mg);
    rd_job_free(d);
    rd_job_free(g);
    free(direct);
    free(want);
    free(got);
    rd_scene_free(&s);
}

Test(frame, direct_job_keeps_no_linear_state)
{
    rd_scene s;
    soft_shadow_scene(&s, 1);
    size_t npix = (size_t)s.render.width * (size_t)s.render.height;
    uint8_t *direct = malloc(3 * npix), *want = calloc(3 * npix, 1), *got = calloc(3 * npix, 1);
    cr_assert(direct && want && got);
    rd_job_options od = {10, {0}, 1, 0, direct}, og = {10, {0}, 1, 0, NULL};
    cr_assert_eq(rd_job_estimate_bytes(&s, &og) - rd_job_estimate_bytes(&s, &od), npix * (3 * sizeof(double) + 4));
    rd_job *d = job_of(&s, direct), *g = job_of(&s, NULL);
    rd_job_counts c = {0};
    for (int t = 0; t < rd_job_tile_count(g); t++) {
        cr_assert(rd_job_render_tile(d, t, &c) && rd_job_render_tile(g, t, &c));
        cr_assert_eq(rd_job_tile_state_bytes(d, t), 0, "tile %d has a state", t);
        rd_error err = {0};
        unsigned char byte = 0;
        cr_assert_eq(rd_job_tile_state_load(d, t, &byte, 1, &err), RD_ERR_INVALID);
    }
    cr_assert_eq(rd_job_end_pass(d), 0);
    cr_assert_eq(rd_job_end_pass(g), 0);
    /* Tile by tile, as the daemon assembles partial images. */
    for (int t = 0; t < rd_job_tile_count(g); t += 2) {
        rd_job_tile_rgb8(d, t, got);
        rd_job_tile_rgb8(g, t, want);
    }
    cr_assert(memcmp(got, want, 3 * npix) == 0, "tile bytes differ");
    rd_render_stats sd, sg;
    rd_job_stats(d, &sd);
    rd_job_stats(g, &sg);
    cr_assert(sd.mean_samples == 1 && sg.mean_samples == 1 && sd.samples == 1, "mean samples %g, general %g",
              sd.mean_samples, sg.mean_samples);
    rd_job_schedule sc;
    rd_job_schedule_get(d, &sc);
    sc.pass = 1;
    sc.stopped_by = RD_STOP_NONE;
    rd_error err = {0};
    cr_assert_eq(rd_job_schedule_set(d, &sc, &err), RD_ERR_INVALID, "a second pass was accepted");
    rd_image img;
    rd_job_take_image(d, &img);
    cr_assert_null(img.rgb);
    rd_job_free(d);
    rd_job_free(g);
    free(direct);
    free(want);
    free(got);
    rd_scene_free(&s);
}
