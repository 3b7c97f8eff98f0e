/* End-to-end tests of rd_render (core/include/rayd/render.h) on scenes built in code.
 *
 * Exact pixels: the camera sits at (0,0,5) looking at a unit sphere at the
 * origin. The centre pixel's ray is exactly -z, hits the sphere at (0,0,1)
 * with N = (0,0,1), V = (0,0,1); a point light at the eye gives
 * L = (0,0,-1), cos α = 1 exactly. Colours are binary fractions, so the
 * shading sums are exact and the byte is floor(clamp(c)·255 + 0.5) with no
 * rounding ambiguity (shading.md, Output).
 *
 * The other tests check properties that must hold bit for bit: thread and
 * tile independence, scale invariance, cancellation. The error estimate has
 * its own file, test_estimate.c. */
#include <criterion/criterion.h>
#include <math.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rayd/job.h"
#include "rayd/render.h"
#include "rayd/scene.h"
#include "support/rng.h"
#include "support/scene_fixture.h"

#define assert_px(bytes, w, x, y, r, g, b)                                                                             \
    do {                                                                                                               \
        const uint8_t *p_ = &(bytes)[((size_t)(y) * (size_t)(w) + (size_t)(x)) * 3];                                   \
        cr_assert(p_[0] == (r) && p_[1] == (g) && p_[2] == (b), "pixel (%d,%d) = (%d,%d,%d), expected (%d,%d,%d)",     \
                  (int)(x), (int)(y), p_[0], p_[1], p_[2], (int)(r), (int)(g), (int)(b));                              \
    } while (0)

/* ---- (1) exact pixel values -------------------------------------------------- */

Test(render, exact_diffuse_light_at_eye_1x1)
{
    /* kd = (0.25, 0.5, 0.75), ambient = (0.125, 0.0625, 0.5), light colour 1:
     *   c = kd·1 + ambient = (0.375, 0.5625, 1.25)
     *   R: 0.375·255 = 95.625, +0.5 = 96.125 -> 96
     *   G: 0.5625·255 = 143.4375, +0.5 = 143.9375 -> 143
     *   B: clamp(1.25) = 1 -> 255. */
    rd_scene s;
    fixture_scene(&s, 1, 1);
    int m = add_material(&s, RD_MAT_DIFFUSE);
    s.materials[m].kd = v3(0.25, 0.5, 0.75);
    s.materials[m].ambient = v3(0.125, 0.0625, 0.5);
    add_sphere(&s, v3(0, 0, 0), 1, m);
    add_point_light(&s, v3(0, 0, 5), v3(1, 1, 1));
    rd_image img;
    rd_render_stats st;
    uint8_t *b = render_bytes(&s, NULL, &img, &st);
    /* The linear value is exact: every step of the sum is exact in binary. */
    cr_assert(img.rgb[0] == 0.375 && img.rgb[1] == 0.5625 && img.rgb[2] == 1.25, "linear (%.17g, %.17g, %.17g)",
              img.rgb[0], img.rgb[1], img.rgb[2]);
    assert_px(b, 1, 0, 0, 96, 143, 255);
    cr_assert_eq(st.camera_rays, 1);
    cr_assert_eq(st.shadow_rays, 1);
    cr_assert_eq(st.nonfinite, 0);
    rd_image_free(&img);
    free(b);
    rd_scene_free(&s);
}

Test(render, exact_centre_hit_and_background_3x3)
{
    /* 3x3 at fov 45°: only the centre pixel sees the sphere. The edge
     * pixels' rays are at tan = (2/3)·tan 22.5° = 0.276 off axis, outside
     * the sphere's tan(asin(1/5)) = 0.204. Background (0.25, 0.125, 1):
     *   0.25·255 = 63.75 -> 64.25 -> 64; 0.125·255 = 31.875 -> 32.375 -> 32; 1 -> 255.
     * Light colour (2, 1, 0.5) scales kd per channel: kd = (0.25, 0.25, 0.25)
     *   -> (0.5, 0.25, 0.125) -> 127.5+0.5 = 128, 64, 32 (exact sums). */
    rd_scene s;
    fixture_scene(&s, 3, 3);
    s.render.background = v3(0.25, 0.125, 1);
    int m = add_material(&s, RD_MAT_DIFFUSE);
    s.materials[m].kd = v3(0.25, 0.25, 0.25);
    add_sphere(&s, v3(0, 0, 0), 1, m);
    add_point_light(&s, v3(0, 0, 5), v3(2, 1, 0.5));
    uint8_t *b = render_bytes(&s, NULL, NULL, NULL);
    for (int y = 0; y < 3; y++)
        for (int x = 0; x < 3; x++) {
            if (x == 1 && y == 1)
                assert_px(b, 3, x, y, 128, 64, 32);
            else
                assert_px(b, 3, x, y, 64, 32, 255);
        }
    free(b);
    rd_scene_free(&s);
}

Test(render, exact_phong_centre_highlight_is_kd_plus_ks)
{
    /* R = reflect((0,0,-1), (0,0,1)) = (0,0,1) = V: max(R·V,0)^20 = 1.
     *   c = kd + ks = (0.25 + 0.5, 0.25 + 0.375, 0.25 + 0.125) = (0.75, 0.625, 0.375)
     *   -> 191.25+0.5 = 191.75 -> 191; 159.375+0.5 -> 159; 95.625+0.5 -> 96. */
    rd_scene s;
    fixture_scene(&s, 1, 1);
    int m = add_material(&s, RD_MAT_PHONG);
    s.materials[m].kd = v3(0.25, 0.25, 0.25);
    s.materials[m].ks = v3(0.5, 0.375, 0.125);
    s.materials[m].shininess = 20;
    add_sphere(&s, v3(0, 0, 0), 1, m);
    add_point_light(&s, v3(0, 0, 5), v3(1, 1, 1));
    uint8_t *b = render_bytes(&s, NULL, NULL, NULL);
    assert_px(b, 1, 0, 0, 191, 159, 96);
    free(b);
    rd_scene_free(&s);
}

Test(render, exact_directional_light_at_60_degrees)
{
    /* Light travelling along (0, -sin 60°, -cos 60°): cos α = -N·L = cos 60° = 0.5
     * at the centre hit. kd = (0.75, 0.5, 0.25) -> (0.375, 0.25, 0.125)
     *   -> 96, 64 (63.75+0.5), 32 (31.875+0.5). */
    rd_scene s;
    fixture_scene(&s, 1, 1);
    int m = add_material(&s, RD_MAT_DIFFUSE);
    s.materials[m].kd = v3(0.75, 0.5, 0.25);
    add_sphere(&s, v3(0, 0, 0), 1, m);
    add_directional_light(&s, v3(0, -sin(M_PI / 3), -cos(M_PI / 3)), v3(1, 1, 1));
    rd_image img;
    uint8_t *b = render_bytes(&s, NULL, &img, NULL);
    cr_assert(fabs(img.rgb[0] - 0.375) < 1e-15, "linear R %.17g", img.rgb[0]);
    assert_px(b, 1, 0, 0, 96, 64, 32);
    rd_image_free(&img);
    free(b);
    rd_scene_free(&s);
}

Test(render, exact_shadowed_hit_gets_ambient_only)
{
    /* Same directional light, but a small sphere at (0,0,1) + 2·(0, sin 60°, cos 60°)
     * sits on the shadow ray (and off the camera ray). Only the ambient
     * (0.125, 0.25, 0.0625) remains: 32 (31.875+0.5), 64, 16 (15.9375+0.5). */
    rd_scene s;
    fixture_scene(&s, 1, 1);
    int m = add_material(&s, RD_MAT_DIFFUSE);
    s.materials[m].kd = v3(0.75, 0.5, 0.25);
    s.materials[m].ambient = v3(0.125, 0.25, 0.0625);
    add_sphere(&s, v3(0, 0, 0), 1, m);
    add_sphere(&s, v3(0, 2 * sin(M_PI / 3), 1 + 2 * cos(M_PI / 3)), 0.5, m);
    add_directional_light(&s, v3(0, -sin(M_PI / 3), -cos(M_PI / 3)), v3(1, 1, 1));
    uint8_t *b = render_bytes(&s, NULL, NULL, NULL);
    assert_px(b, 1, 0, 0, 32, 64, 16);
    free(b);
    rd_scene_free(&s);
}

Test(render, exact_gamma_2)
{
    /* kd = (0.5, 0.125, 0.0625), ambient = (0.0625, 0.015625, 0.078125):
     *   linear c = (0.5625, 0.140625, 0.140625)
     *   gamma 2: sqrt -> (0.75, 0.375, 0.375) -> 191.25+0.5 -> 191; 95.625+0.5 -> 96; 96.
     *   gamma 1 for comparison: 143.4375+0.5 -> 143; 35.859+0.5 -> 36; 36. */
    rd_scene s;
    fixture_scene(&s, 1, 1);
    s.render.gamma = 2;
    int m = add_material(&s, RD_MAT_DIFFUSE);
    s.materials[m].kd = v3(0.5, 0.125, 0.0625);
    s.materials[m].ambient = v3(0.0625, 0.015625, 0.078125);
    add_sphere(&s, v3(0, 0, 0), 1, m);
    add_point_light(&s, v3(0, 0, 5), v3(1, 1, 1));
    rd_image img;
    uint8_t *b = render_bytes(&s, NULL, &img, NULL);
    assert_px(b, 1, 0, 0, 191, 96, 96);
    uint8_t g1[3];
    rd_image_to_rgb8(&img, 1.0, g1);
    assert_px(g1, 1, 0, 0, 143, 36, 36);
    /* gamma 2.2 on linear 0.5: 0.5^(1/2.2) = exp(-0.693147/2.2) = 0.729740
     *   -> 186.08+0.5 -> 186. */
    img.rgb[0] = img.rgb[1] = img.rgb[2] = 0.5;
    rd_image_to_rgb8(&img, 2.2, g1);
    assert_px(g1, 1, 0, 0, 186, 186, 186);
    rd_image_free(&img);
    free(b);
    rd_scene_free(&s);
}

Test(render, exact_display_function)
{
    /* clamp to [0,1], then ^(1/gamma). */
    cr_assert_eq(rd_display(-0.5, 1), 0.0);
    cr_assert_eq(rd_display(7, 2.2), 1.0);
    cr_assert_eq(rd_display(0.5625, 2), 0.75);
    cr_assert_eq(rd_display(0.3, 1), 0.3);
    cr_assert(fabs(rd_display(0.5, 2.2) - 0.7297400528407231) < 1e-15);
    /* Bytes for the boundary values 0, 1 and a half step. */
    rd_image img = {3, 1, (double[]){0, 1, 0.5, -3, 4, 1.0 / 255, 0.25, 0.001, 0.999}};
    uint8_t b[9];
    rd_image_to_rgb8(&img, 1.0, b);
    /* 0 -> 0; 1 -> 255; 0.5·255 = 127.5 -> 128.0 -> 128; clamp(-3) -> 0; clamp(4) -> 255;
     * (1/255)·255 ≈ 1 -> 1.5 -> 1; 0.25·255 = 63.75 -> 64.25 -> 64;
     * 0.001·255 = 0.255 -> 0.755 -> 0; 0.999·255 = 254.745 -> 255.245 -> 255. */
    uint8_t want[9] = {0, 255, 128, 0, 255, 1, 64, 0, 255};
    for (int i = 0; i < 9; i++)
        cr_assert_eq(b[i], want[i], "byte %d = %d, expected %d", i, b[i], want[i]);
}

/* A whole image's bytes are rd_display8 of each channel, whatever shortcut
 * rd_image_to_rgb8 takes: every value near the 255 steps of each gamma
 * (the formula's edge and the doubles around it), random ones, and those
 * clamped. */
Test(render, image_bytes_are_display8_of_every_channel)
{
    const double gammas[] = {1, 2.2, 2, 1.8, 0.45, 3};
    size_t n = 0, cap = 3 * 80000;
    double *v = malloc(cap * sizeof *v);
    uint8_t *got = malloc(cap);
    cr_assert(v && got);
    for (size_t gi = 0; gi < sizeof gammas / sizeof *gammas; gi++) {
        double g = gammas[gi];
        test_rng r = {0x5eed + gi};
        n = 0;
        const double fixed[] = {0, 1, -0.0, -1, 2, INFINITY, -INFINITY, 4.9e-324, 1e-300, 0.5, 1 - 1e-16};
        for (size_t i = 0; i < sizeof fixed / sizeof *fixed; i++)
            v[n++] = fixed[i];
        for (int k = 1; k < 256; k++) {
            double e = pow((k - 0.5) / 255, g);
            for (int d = -40; d <= 40; d++) {
                double c = e;
                for (int s = 0; s < (d < 0 ? -d : d); s++)
                    c = nextafter(c, d < 0 ? 0 : 2);
                v[n++] = c;
            }
        }
        while (n < cap)
            v[n++] = rng_uniform(&r) * 1.1 - 0.05;
        rd_image img = {(int)(cap / 3), 1, v};
        rd_image_to_rgb8(&img, g, got);
        for (size_t i = 0; i < n; i++)
            if (got[i] != rd_display8(v[i], g))
                cr_assert_fail("gamma %g: %.17g gives %d, rd_display8 %d", g, v[i], got[i], rd_display8(v[i], g));
    }
    free(v);
    free(got);
}

/* Linear images (gamma 1) are converted sixteen values at a time: a NaN in
 * any lane, and images of every length modulo a block, still give
 * rd_display8 of each value, the NaN's neighbours included. */
Test(render, linear_bytes_are_display8_at_every_lane_and_length)
{
    enum { W_MAX = 22 }; /* 3w covers every remainder modulo 16 */
    const double fixed[] = {0,         -0.0,        1,        1 - 1e-16, 1 + 1e-16, -1e-300, 4.9e-324, 0.5 / 255,
                            1.5 / 255, 254.5 / 255, INFINITY, -INFINITY, 0.5,       2,       -2,       0.25};
    double v[3 * W_MAX];
    uint8_t got[3 * W_MAX];
    for (int nan_at = -1; nan_at < 3 * W_MAX; nan_at++)
        for (int w = 1; w <= W_MAX; w++) {
            for (int i = 0; i < 3 * W_MAX; i++)
                v[i] = i == nan_at ? NAN : fixed[(i * 7) % 16];
            rd_image img = {w, 1, v};
            rd_image_to_rgb8(&img, 1.0, got);
            for (int i = 0; i < 3 * w; i++)
                if (got[i] != rd_display8(v[i], 1.0))
                    cr_assert_fail("NaN at %d, %d values: value %d (%.17g) gives %d, rd_display8 %d", nan_at, 3 * w, i,
                                   v[i], got[i], rd_display8(v[i], 1.0));
        }
}

Test(render, exact_background_for_misses)
{
    /* An empty scene, and a scene whose only sphere is behind the camera:
     * every pixel is the background (0.5, 0.75, 0.125) -> 128 (127.5+0.5),
     * 191.75 -> 191, 32.375 -> 32. */
    for (int behind = 0; behind < 2; behind++) {
        rd_scene s;
        fixture_scene(&s, 4, 3);
        s.render.background = v3(0.5, 0.75, 0.125);
        int m = add_material(&s, RD_MAT_DIFFUSE);
        if (behind)
            add_sphere(&s, v3(0, 0, 10), 1, m);
        add_point_light(&s, v3(0, 0, 5), v3(1, 1, 1));
        uint8_t *b = render_bytes(&s, NULL, NULL, NULL);
        for (int y = 0; y < 3; y++)
            for (int x = 0; x < 4; x++)
                assert_px(b, 4, x, y, 128, 191, 32);
        free(b);
        rd_scene_free(&s);
    }
}

Test(render, exact_mirror_reflects_background)
{
    /* perfect_specular, ks = 0.5: the centre ray reflects straight back to +z
     * and misses -> ks·background = 0.5·(0.5, 0.25, 0.75) = (0.25, 0.125, 0.375)
     * -> 64, 32, 96. With max_depth = 0 no recursion: ambient only (0). */
    rd_scene s;
    fixture_scene(&s, 1, 1);
    s.render.background = v3(0.5, 0.25, 0.75);
    int m = add_material(&s, RD_MAT_PERFECT_SPECULAR);
    s.materials[m].ks = v3(0.5, 0.5, 0.5);
    add_sphere(&s, v3(0, 0, 0), 1, m);
    add_point_light(&s, v3(0, 0, 5), v3(1, 1, 1));
    uint8_t *b = render_bytes(&s, NULL, NULL, NULL);
    assert_px(b, 1, 0, 0, 64, 32, 96);
    free(b);
    s.render.max_depth = 0;
    b = render_bytes(&s, NULL, NULL, NULL);
    assert_px(b, 1, 0, 0, 0, 0, 0);
    free(b);
    rd_scene_free(&s);
}

Test(render, exact_glass_sphere_fresnel_normal_incidence)
{
    /* specular_refraction, ior 1.5, ks 1, max_depth 2, background b.
     * Normal incidence: F = ((1.5 - 1)/(1.5 + 1))² = 0.04 entering and leaving.
     *   depth 0 (front):  F·trace(reflected -> b) + (1-F)·trace(refracted, 1)
     *   depth 1 (back, leaving): F·trace(inside, 2) + (1-F)·trace(out -> b)
     *   depth 2 (front from inside): max depth reached -> ambient = 0.
     *   pixel = 0.04·b + 0.96·0.96·b = 0.9616·b
     * b = (0.5, 0.25, 1): (0.4808, 0.2404, 0.9616)
     *   -> 122.604+0.5 -> 123; 61.302+0.5 -> 61; 245.208+0.5 -> 245. */
    rd_scene s;
    fixture_scene(&s, 1, 1);
    s.render.background = v3(0.5, 0.25, 1);
    s.render.max_depth = 2;
    int m = add_material(&s, RD_MAT_SPECULAR_REFRACTION);
    s.materials[m].ior = 1.5;
    add_sphere(&s, v3(0, 0, 0), 1, m);
    rd_image img;
    rd_render_stats st;
    uint8_t *b = render_bytes(&s, NULL, &img, &st);
    cr_assert(fabs(img.rgb[2] - 0.9616) < 1e-12, "linear B %.17g, expected 0.9616", img.rgb[2]);
    assert_px(b, 1, 0, 0, 123, 61, 245);
    /* Secondary rays: 2 at depth 0, 2 at depth 1. */
    cr_assert_eq(st.secondary_rays, 4);
    rd_image_free(&img);
    free(b);
    rd_scene_free(&s);
}

Test(render, exact_pseudo_normal_color)
{
    /* (N + 1)/2 with N = (0,0,1): (0.5, 0.5, 1) -> 128 (127.5+0.5), 128, 255;
     * lights and ambient play no part. */
    rd_scene s;
    fixture_scene(&s, 1, 1);
    int m = add_material(&s, RD_MAT_PSEUDO_NORMAL_COLOR);
    s.materials[m].ambient = v3(0.5, 0.5, 0.5);
    add_sphere(&s, v3(0, 0, 0), 1, m);
    add_point_light(&s, v3(0, 0, 5), v3(1, 1, 1));
    uint8_t *b = render_bytes(&s, NULL, NULL, NULL);
    assert_px(b, 1, 0, 0, 128, 128, 255);
    free(b);
    rd_scene_free(&s);
}

/* ---- (6) perfect_specular with ks = 0 ------------------------------------- */

Test(render, exact_perfect_specular_ks0_is_ambient_alone)
{
    /* ks = 0: no reflection and no direct light, whatever the lights and the
     * background: only ambient (0.125, 0.25, 0.0625) -> 32, 64, 16. */
    rd_scene s;
    fixture_scene(&s, 1, 1);
    s.render.background = v3(1, 1, 1);
    int m = add_material(&s, RD_MAT_PERFECT_SPECULAR);
    s.materials[m].ks = v3(0, 0, 0);
    s.materials[m].kd = v3(1, 1, 1);
    s.materials[m].ambient = v3(0.125, 0.25, 0.0625);
    add_sphere(&s, v3(0, 0, 0), 1, m);
    add_point_light(&s, v3(0, 0, 5), v3(10, 10, 10));
    add_directional_light(&s, v3(0, 0, -1), v3(10, 10, 10));
    rd_image img;
    uint8_t *b = render_bytes(&s, NULL, &img, NULL);
    cr_assert(img.rgb[0] == 0.125 && img.rgb[1] == 0.25 && img.rgb[2] == 0.0625, "linear (%g, %g, %g)", img.rgb[0],
              img.rgb[1], img.rgb[2]);
    assert_px(b, 1, 0, 0, 32, 64, 16);
    rd_image_free(&img);
    free(b);
    rd_scene_free(&s);
}

/* ---- a scene with every implemented material ------------------------------ */

static void all_materials_scene(rd_scene *s, int w, int h)
{
    fixture_scene(s, w, h);
    s->camera.eye = v3(0.3, 1.2, 6);
    s->camera.target = v3(0, 0.5, 0);
    s->render.background = v3(0.1, 0.2, 0.3);
    s->render.max_depth = 8;
    s->render.seed = 17;
    rd_material_type ts[] = {RD_MAT_DIFFUSE,
                             RD_MAT_PHONG,
                             RD_MAT_BLINN_PHONG,
                             RD_MAT_COOK_TORRANCE,
                             RD_MAT_PERFECT_SPECULAR,
                             RD_MAT_SPECULAR_REFRACTION,
                             RD_MAT_PSEUDO_NORMAL_COLOR};
    int ms[7];
    for (int i = 0; i < 7; i++) {
        ms[i] = add_material(s, ts[i]);
        s->materials[ms[i]].ambient = v3(0.02, 0.02, 0.02);
        s->materials[ms[i]].ks = v3(0.6, 0.6, 0.6);
    }
    s->materials[ms[1]].shininess = 1e6;  /* needle highlight */
    s->materials[ms[2]].shininess = 0;    /* 0^0 */
    s->materials[ms[3]].roughness = 1e-3; /* near-mirror microfacets */
    s->materials[ms[3]].ks = v3(0.04, 0.5, 1);
    s->materials[ms[5]].ks = v3(1, 1, 1);
    int glass2 = add_material(s, RD_MAT_SPECULAR_REFRACTION);
    s->materials[glass2].ior = 0.6; /* total internal reflection from outside */
    for (int i = 0; i < 7; i++)
        add_sphere(s, v3(-3 + i, 0.5 + 0.3 * (i % 2), -i * 0.2), 0.45, ms[i]);
    add_sphere(s, v3(0, 2, 0), 0.7, glass2);
    add_sphere(s, v3(0.3, 1.2, 6), 0.5, ms[5]); /* the camera sits inside a glass ball */
    add_plane(s, v3(0, 0, 0), v3(0, 1, 0), ms[0]);
    add_plane(s, v3(0, 0, -10), v3(0, 0.1, 1), ms[4]);
    rd_object *t = add_triangle(s, v3(-2, 0, -2), v3(2, 0.01, -2), v3(0, 3, -3), ms[1]);
    t->has_normals = 1;
    t->n[0] = v3(0, 0, 1);
    t->n[1] = v3(0, 0, -1); /* cancelling normals at the midpoint */
    t->n[2] = v3(0, 1, 0);
    add_triangle(s, v3(-2, 0.5, 1), v3(2, 0.5, 1), v3(-2, 0.5, 1), ms[3]); /* degenerate */
    add_point_light(s, v3(2, 3, 3), v3(1, 1, 1));
    add_point_light(s, v3(1, 0, 1), v3(0.5, 0.5, 0.5)); /* exactly on the floor plane */
    add_directional_light(s, v3(-1, -1, -0.5), v3(0.3, 0.3, 0.3));
    add_directional_light(s, v3(1, 0, 0), v3(0.3, 0.3, 0.3)); /* grazing the floor */
    rd_light *sp = add_point_light(s, v3(-2, 4, 2), v3(0.8, 0.6, 0.4));
    sp->type = RD_LIGHT_SPOT;
    sp->direction = v3(0.3, -1, -0.4);
    sp->angle_deg = 25;
    sp->falloff = 3;
    add_area_light(s, v3(-1, 5, -1), v3(2, 0, 0), v3(0, 0, 2), 3, v3(0.7, 0.7, 0.7));
}

/* ---- (2) no NaN or infinity anywhere ---------------------------------------- */

Test(render, every_material_finite)
{
    rd_scene s;
    all_materials_scene(&s, 96, 64);
    s.render.samples = 2;
    rd_image img;
    rd_render_stats st;
    rd_render_options opt = {0};
    opt.threads = 2;
    uint8_t *b = render_bytes(&s, &opt, &img, &st);
    size_t n = (size_t)img.width * img.height * 3, bad = 0;
    for (size_t i = 0; i < n; i++)
        bad += !isfinite(img.rgb[i]);
    cr_assert_eq(bad, 0, "%zu non-finite channels in the image", bad);
    cr_assert_eq(st.nonfinite, 0, "stats.nonfinite = %llu", (unsigned long long)st.nonfinite);
    cr_assert_eq(st.camera_rays, 96 * 64 * 2);
    cr_assert(st.shadow_rays > 0 && st.secondary_rays > 0);
    /* Not a black image: every material took part. */
    size_t lit = 0;
    for (size_t i = 0; i < n; i++)
        lit += b[i] > 10;
    cr_assert(lit > n / 4, "only %zu of %zu channels lit", lit, n);
    rd_image_free(&img);
    free(b);
    rd_scene_free(&s);
}

/* ---- (3) thread and tile independence ----------------------------------------- */

Test(render, threads_and_tiles_byte_identical)
{
    rd_scene s;
    all_materials_scene(&s, 53, 37); /* sizes that no tile divides */
    s.render.samples = 4;
    rd_render_options o1 = {0};
    o1.threads = 1;
    o1.tile = 16;
    rd_image ref;
    rd_render_stats st_ref;
    uint8_t *b_ref = render_bytes(&s, &o1, &ref, &st_ref);
    size_t n = (size_t)53 * 37 * 3;
    int configs[][2] = {{2, 16}, {2, 7}, {1, 7}, {3, 1}};
    for (size_t c = 0; c < sizeof configs / sizeof configs[0]; c++) {
        rd_render_options o = {0};
        o.threads = configs[c][0];
        o.tile = configs[c][1];
        rd_image img;
        rd_render_stats st;
        uint8_t *b = render_bytes(&s, &o, &img, &st);
        cr_assert(memcmp(b, b_ref, n) == 0, "threads %d tile %d: bytes differ from threads 1 tile 16", o.threads,
                  o.tile);
        cr_assert(memcmp(img.rgb, ref.rgb, n * sizeof(double)) == 0, "threads %d tile %d: linear image differs",
                  o.threads, o.tile);
        cr_assert(st.error_estimate == st_ref.error_estimate, "threads %d tile %d: error estimate %.17g vs %.17g",
                  o.threads, o.tile, st.error_estimate, st_ref.error_estimate);
        cr_assert(st.camera_rays == st_ref.camera_rays && st.shadow_rays == st_ref.shadow_rays &&
                      st.secondary_rays == st_ref.secondary_rays,
                  "threads %d tile %d: ray counts differ", o.threads, o.tile);
        rd_image_free(&img);
        free(b);
    }
    /* Another seed changes the jitter, hence some pixels. */
    s.render.seed = 18;
    uint8_t *b2 = render_bytes(&s, &o1, NULL, NULL);
    cr_assert(memcmp(b2, b_ref, n) != 0, "seed had no effect");
    free(b2);
    rd_image_free(&ref);
    free(b_ref);
    rd_scene_free(&s);
}

/* ---- (4) scale invariance ------------------------------------------------------ */

/* The eye at the origin; every position (not direction) times f. */
static void scaled_scene(rd_scene *s, double f)
{
    fixture_scene(s, 40, 30);
    s->render.samples = 4;
    s->render.seed = 5;
    s->render.max_depth = 4;
    s->render.background = v3(0.05, 0.1, 0.2);
    s->camera.eye = v3(0, 0, 0);
    s->camera.target = v3_scale(v3(0.5, -1, -6), f);
    int dif = add_material(s, RD_MAT_DIFFUSE);
    int ph = add_material(s, RD_MAT_PHONG);
    s->materials[ph].ks = v3(0.5, 0.5, 0.5);
    s->materials[ph].shininess = 40;
    int ct = add_material(s, RD_MAT_COOK_TORRANCE);
    int mir = add_material(s, RD_MAT_PERFECT_SPECULAR);
    s->materials[mir].ks = v3(0.8, 0.8, 0.8);
    int gl = add_material(s, RD_MAT_SPECULAR_REFRACTION);
    for (int i = 0; i < 5; i++)
        s->materials[i].ambient = v3(0.03, 0.03, 0.03);
    add_sphere(s, v3_scale(v3(-1.5, -1, -6), f), 1 * f, ph);
    add_sphere(s, v3_scale(v3(1.2, -1.3, -5), f), 0.7 * f, gl);
    add_sphere(s, v3_scale(v3(0.3, -0.5, -8), f), 1.5 * f, mir);
    add_sphere(s, v3_scale(v3(-0.2, -1.6, -4), f), 0.4 * f, ct);
    add_plane(s, v3_scale(v3(0, -2, 0), f), v3(0, 1, 0), dif);
    add_triangle(s, v3_scale(v3(-3, -2, -10), f), v3_scale(v3(3, -2, -10), f), v3_scale(v3(0, 2, -11), f), dif);
    /* A ring of small spheres and triangles: enough primitives for the
     * world to use its acceleration structure, if it has one. */
    for (int i = 0; i < 24; i++) {
        double a = 2 * M_PI * i / 24;
        rd_vec3 c = v3(2.5 * cos(a), -1.8, -6 + 2.5 * sin(a));
        add_sphere(s, v3_scale(c, f), 0.2 * f, i % 2 ? ph : dif);
        add_triangle(s, v3_scale(v3_add(c, v3(0, 0.3, 0)), f), v3_scale(v3_add(c, v3(0.3, 0.6, 0.1)), f),
                     v3_scale(v3_add(c, v3(-0.2, 0.7, -0.1)), f), i % 3 ? ct : mir);
    }
    add_point_light(s, v3_scale(v3(3, 4, 0), f), v3(0.8, 0.8, 0.8));
    add_area_light(s, v3_scale(v3(-2, 3, -4), f), v3_scale(v3(1.5, 0, 0), f), v3_scale(v3(0, 0, 1.5), f), 3,
                   v3(0.6, 0.6, 0.6));
    rd_light *sp = add_point_light(s, v3_scale(v3(-3, 2, -2), f), v3(0.5, 0.4, 0.3));
    sp->type = RD_LIGHT_SPOT;
    sp->direction = v3(0.5, -0.7, -0.6);
    sp->angle_deg = 30;
    sp->falloff = 2;
}

Test(render, power_of_two_scaling_is_invisible)
{
    /* Scaling every position by 2^k about the eye multiplies every length by
     * an exact power of two; directions, cosines and colours are unchanged.
     * A renderer without absolute epsilons gives identical bytes. */
    rd_scene s;
    scaled_scene(&s, 1);
    rd_image ref;
    uint8_t *b_ref = render_bytes(&s, NULL, &ref, NULL);
    size_t n = (size_t)40 * 30 * 3;
    int ks[] = {-20, 20, -60, 60};
    for (int i = 0; i < 4; i++) {
        rd_scene t;
        scaled_scene(&t, ldexp(1, ks[i]));
        rd_image img;
        uint8_t *b = render_bytes(&t, NULL, &img, NULL);
        size_t diff = 0, first = n;
        for (size_t j = 0; j < n; j++)
            if (b[j] != b_ref[j]) {
                diff++;
                if (first == n)
                    first = j;
            }
        cr_assert_eq(diff, 0, "scale 2^%d: %zu of %zu bytes differ; first at pixel %zu: %d vs %d", ks[i], diff, n,
                     first / 3, diff ? b[first] : 0, diff ? b_ref[first] : 0);
        rd_image_free(&img);
        free(b);
        rd_scene_free(&t);
    }
    rd_image_free(&ref);
    free(b_ref);
    rd_scene_free(&s);
}

/* ---- (7) cancellation --------------------------------------------------------------- */

Test(render, cancel_flag_set_before_render)
{
    rd_scene s;
    soft_shadow_scene(&s, 4);
    atomic_int flag;
    atomic_init(&flag, 1);
    rd_render_options o = {0};
    o.cancel = &flag;
    o.threads = 2;
    rd_image img;
    rd_render_stats st;
    rd_error err = {0};
    rd_error_code rc = rd_render(&s, &o, &img, &st, &err);
    cr_assert_eq(rc, RD_ERR_CANCELLED, "rd_render returned %d", (int)rc);
    cr_assert_eq(err.code, RD_ERR_CANCELLED);
    cr_assert_null(img.rgb, "the image must be freed on cancel");
    rd_scene_free(&s);
}

static void count_progress(void *user, int done, int total)
{
    (void)total;
    atomic_int *max = user;
    int cur = atomic_load(max);
    while (done > cur && !atomic_compare_exchange_weak(max, &cur, done))
        ;
}

Test(render, cancel_unset_flag_renders_and_progress_completes)
{
    /* The same options with the flag clear render normally; progress
     * reaches tiles_total = ceil(32/8)·ceil(24/8) = 12. */
    rd_scene s;
    soft_shadow_scene(&s, 1);
    atomic_int flag, max_done;
    atomic_init(&flag, 0);
    atomic_init(&max_done, 0);
    rd_render_options o = {0};
    o.cancel = &flag;
    o.threads = 2;
    o.tile = 8;
    o.progress = count_progress;
    o.user = &max_done;
    uint8_t *b = render_bytes(&s, &o, NULL, NULL);
    cr_assert_eq(atomic_load(&max_done), 12);
    free(b);
    rd_scene_free(&s);
}

typedef struct {
    int calls, last_pass, samples[RD_CURVE_MAX + 1];
    rd_curve_point ended[RD_CURVE_MAX + 1];
    int had_ended[RD_CURVE_MAX + 1];
} pass_log;

static void log_pass(void *user, int pass, int samples, const rd_curve_point *ended)
{
    pass_log *l = user;
    cr_assert_eq(pass, l->calls, "pass %d reported as call %d", pass, l->calls);
    l->samples[l->calls] = samples;
    l->had_ended[l->calls] = ended != NULL;
    if (ended)
        l->ended[l->calls] = *ended;
    l->calls++;
}

Test(render, pass_callback_sees_every_pass_and_its_curve_point)
{
    /* A target error that cannot be met: passes of 2, 2, 4, 8 up to the
     * cap of 16 samples, then one last call with 0. */
    rd_scene s;
    soft_shadow_scene(&s, 16);
    pass_log l = {0};
    rd_render_options o = {0};
    o.threads = 2;
    o.target_error = 1e-9;
    o.pass = log_pass;
    o.user = &l;
    rd_image img;
    rd_render_stats st;
    render_ok(&s, &o, &img, &st);
    cr_assert_eq(st.passes, 4);
    cr_assert_eq(l.calls, 5);
    static const int want[] = {2, 2, 4, 8, 0};
    for (int i = 0; i < 5; i++) {
        cr_assert_eq(l.samples[i], want[i], "call %d: %d samples", i, l.samples[i]);
        cr_assert_eq(l.had_ended[i], i > 0);
        if (i > 0)
            cr_assert(memcmp(&l.ended[i], &st.curve[i - 1], sizeof st.curve[0]) == 0, "call %d: not curve point %d", i,
                      i - 1);
    }
    rd_image_free(&img);
    rd_scene_free(&s);
}

Test(render, invalid_camera_leaves_image_empty)
{
    rd_scene s;
    fixture_scene(&s, 4, 4);
    s.camera.target = s.camera.eye;
    rd_image img;
    rd_render_stats st;
    rd_error err = {0};
    cr_assert_eq(rd_render(&s, NULL, &img, &st, &err), RD_ERR_INVALID);
    cr_assert_null(img.rgb);
    rd_scene_free(&s);
}

/* Packets (rd_render_options.packets) change how rays are walked, never
 * what they find: every material, light type (area lights included, which
 * stay ray by ray), planes, a textureless mix of 300 small spheres and
 * triangles (so that the world has a BVH), progressive and adaptive
 * passes, and tiles that cut the 4x4 blocks, give the same bytes, linear
 * image, error estimate and ray counts as ray by ray. */
Test(render, packets_give_the_same_image)
{
    rd_scene s;
    all_materials_scene(&s, 45, 31);
    s.render.samples = 3;
    add_area_light(&s, v3(-1, 5, -1), v3(2, 0, 0), v3(0, 0, 2), 2, v3(0.4, 0.4, 0.4));
    test_rng g = {99};
    for (int i = 0; i < 300; i++) {
        double x = rng_range(&g, -3, 3), z = rng_range(&g, -3, 0);
        int mat = rng_int(&g, (int)s.material_count);
        if (i % 2)
            add_sphere(&s, v3(x, 0.1, z), 0.08, mat);
        else
            add_triangle(&s, v3(x, 0, z), v3(x + 0.2, 0.05, z), v3(x, 0.25, z + 0.1), mat);
    }
    rd_render_options schedules[3] = {{0}};
    schedules[1].target_error = 1e-12;
    schedules[1].time_budget_ms = 1e9;
    schedules[2] = schedules[1];
    schedules[2].adaptive = 1;
    for (int sc = 0; sc < 3; sc++) {
        rd_render_options o1 = schedules[sc];
        o1.threads = 1;
        o1.tile = 16;
        rd_image ref;
        rd_render_stats st_ref;
        uint8_t *b_ref = render_bytes(&s, &o1, &ref, &st_ref);
        cr_assert_gt(st_ref.bvh_nodes, 0, "the scene must have a BVH for packets to be walked");
        size_t n = (size_t)45 * 31 * 3;
        unsigned how[] = {RD_PACKETS_CAMERA, RD_PACKETS_SHADOW, RD_PACKETS_CAMERA | RD_PACKETS_SHADOW};
        int tiles[] = {16, 7, 5};
        for (int c = 0; c < 3; c++) {
            rd_render_options o = schedules[sc];
            o.threads = 1 + c % 2;
            o.tile = tiles[c];
            o.packets = how[c];
            rd_image img;
            rd_render_stats st;
            uint8_t *b = render_bytes(&s, &o, &img, &st);
            cr_assert(memcmp(b, b_ref, n) == 0, "schedule %d packets %u tile %d: bytes differ", sc, how[c], o.tile);
            cr_assert(memcmp(img.rgb, ref.rgb, n * sizeof(double)) == 0, "schedule %d packets %u: linear image differs",
                      sc, how[c]);
            cr_assert(st.error_estimate == st_ref.error_estimate && st.camera_rays == st_ref.camera_rays &&
                          st.shadow_rays == st_ref.shadow_rays && st.secondary_rays == st_ref.secondary_rays,
                      "schedule %d packets %u: estimate or ray counts differ", sc, how[c]);
            rd_image_free(&img);
            free(b);
        }
        rd_image_free(&ref);
        free(b_ref);
    }
    rd_scene_free(&s);
}
