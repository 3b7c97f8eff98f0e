/* The frame a render writes into (core/render/job.c): a one-sample render
 * stores its sample without the running mean's division, and must keep
 * the bits the general path gives. */
#include <criterion/criterion.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "camera.h"
#include "rayd/render.h"
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
