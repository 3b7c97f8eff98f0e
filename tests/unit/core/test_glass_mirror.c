/* Recursive materials (shading.md, trace() step 5) through full renders
 * (rd_render) of scenes built in code: specular_refraction and
 * perfect_specular.
 *
 * - A glass sphere of ior 1 and tint 1 is invisible: every ray crosses it
 *   undeviated (F = 0, refracted = incident), so with ambient-only lighting
 *   the image is byte-identical to the scene without it, once max_depth
 *   lets rays through both of its surfaces. It is still an object, so it
 *   still casts a shadow.
 * - A mirror with ks = 0 adds nothing to its ambient.
 * - Between two facing mirrors every camera ray bounces for ever, and the
 *   pixel is the truncated geometric series sum_{k=0}^{D} ks^k ambient. */
#include <criterion/criterion.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rayd/render.h"
#include "rayd/scene.h"
#include "support/scene_fixture.h"

static uint8_t expect_byte(double c)
{
    c = c < 0 ? 0 : (c > 1 ? 1 : c);
    return (uint8_t)floor(c * 255.0 + 0.5);
}

/* The ior-1 glass scene: a coloured diffuse sphere and a back wall, lit by
 * ambient terms only, and (with_glass) a glass sphere in front of both. */
static void glass_scene(rd_scene *s, int with_glass, int max_depth)
{
    fixture_scene(s, 64, 48);
    s->render.max_depth = max_depth;
    s->render.background = v3(0.05, 0.05, 0.05); /* never seen: the wall fills the view */
    int wall = add_material(s, RD_MAT_DIFFUSE);
    s->materials[wall].ambient = v3(0.2, 0.4, 0.6);
    int ball = add_material(s, RD_MAT_PHONG);
    s->materials[ball].ambient = v3(0.9, 0.1, 0.3);
    add_plane(s, v3(0, 0, -3), v3(0, 0, 1), wall);
    add_sphere(s, v3(0.5, 0.3, -1.5), 0.8, ball);
    if (with_glass) {
        int glass = add_material(s, RD_MAT_SPECULAR_REFRACTION);
        s->materials[glass].ior = 1.0;
        s->materials[glass].ks = v3(1, 1, 1);
        add_sphere(s, v3(-0.2, 0, 1), 1.0, glass);
    }
}

Test(glass_mirror, ior_one_glass_is_invisible_under_ambient_light)
{
    rd_scene a, b;
    glass_scene(&a, 0, 8);
    glass_scene(&b, 1, 8);
    rd_image ia, ib;
    uint8_t *ba, *bb;
    rd_render_stats sb;
    ba = render_bytes(&a, NULL, &ia, NULL);
    bb = render_bytes(&b, NULL, &ib, &sb);
    /* The glass is really in view: it sent secondary rays. */
    cr_assert_gt(sb.secondary_rays, 500);
    size_t n = (size_t)ia.width * ia.height * 3;
    for (size_t i = 0; i < n; i++)
        cr_assert_eq(ba[i], bb[i], "pixel (%zu,%zu) channel %zu: %d without the glass, %d with it", (i / 3) % 64,
                     (i / 3) / 64, i % 3, ba[i], bb[i]);
    free(ba);
    free(bb);
    rd_image_free(&ia);
    rd_image_free(&ib);
    rd_scene_free(&a);
    rd_scene_free(&b);
}

Test(glass_mirror, ior_one_glass_needs_depth_to_be_seen_through)
{
    /* The control for the test above: with max_depth 1 a ray that enters
     * the glass ends inside it (depth 1 = max_depth: ambient 0 only), so
     * the glass shows as black. Depth 2 (in, out, then the wall) is enough
     * for every ray that crosses the sphere once. */
    rd_scene a, b, c;
    glass_scene(&a, 0, 8);
    glass_scene(&b, 1, 1);
    glass_scene(&c, 1, 2);
    rd_image ia, ib, ic;
    uint8_t *ba, *bb, *bc;
    ba = render_bytes(&a, NULL, &ia, NULL);
    bb = render_bytes(&b, NULL, &ib, NULL);
    bc = render_bytes(&c, NULL, &ic, NULL);
    size_t n = (size_t)ia.width * ia.height, black = 0, diff2 = 0;
    for (size_t i = 0; i < n; i++) {
        if (memcmp(&ba[3 * i], &bb[3 * i], 3) != 0) {
            cr_assert(bb[3 * i] == 0 && bb[3 * i + 1] == 0 && bb[3 * i + 2] == 0);
            black++;
        }
        diff2 += memcmp(&ba[3 * i], &bc[3 * i], 3) != 0;
    }
    /* The sphere (radius 1 at distance 4) covers about 1/8 of the frame. */
    cr_assert_gt(black, n / 20, "only %zu pixels see the glass", black);
    /* At depth 2 only rays that hit the glass at grazing incidence and bounce
     * more may differ: a thin rim at most. */
    cr_assert_lt(diff2, black / 10, "%zu of %zu glass pixels differ at max_depth 2", diff2, black);
    free(ba);
    free(bb);
    free(bc);
    rd_image_free(&ia);
    rd_image_free(&ib);
    rd_image_free(&ic);
    rd_scene_free(&a);
    rd_scene_free(&b);
    rd_scene_free(&c);
}

/* Floor y = -1, a glass sphere (ior 1) of radius 0.5 at the origin, a point
 * light straight above. The camera looks at (0,-1,0), the centre of the
 * sphere's shadow, past the sphere (the sight line misses
 * its centre by 0.98). 33x33 so the centre pixel's ray goes exactly at the target. */
static void shadow_scene(rd_scene *s, int with_glass)
{
    fixture_scene(s, 33, 33);
    s->render.max_depth = 8;
    s->camera.eye = v3(0, 0.2, 6);
    s->camera.target = v3(0, -1, 0);
    int floor_m = add_material(s, RD_MAT_DIFFUSE);
    s->materials[floor_m].ambient = v3(0.125, 0.125, 0.125);
    s->materials[floor_m].kd = v3(0.5, 0.5, 0.5);
    add_plane(s, v3(0, -1, 0), v3(0, 1, 0), floor_m);
    add_point_light(s, v3(0, 10, 0), v3(1, 1, 1));
    if (with_glass) {
        int glass = add_material(s, RD_MAT_SPECULAR_REFRACTION);
        s->materials[glass].ior = 1.0;
        add_sphere(s, v3(0, 0, 0), 0.5, glass);
    }
}

Test(glass_mirror, ior_one_glass_still_casts_a_shadow)
{
    rd_scene a, b;
    shadow_scene(&a, 0);
    shadow_scene(&b, 1);
    rd_image ia, ib;
    uint8_t *ba, *bb;
    ba = render_bytes(&a, NULL, &ia, NULL);
    bb = render_bytes(&b, NULL, &ib, NULL);
    size_t c = (16 * 33 + 16) * 3;
    /* Without the sphere: kd·cos α + ambient = 0.5·1 + 0.125 (the light is
     * straight above the hit, up to the rounding of the camera ray). */
    cr_assert(fabs(ia.rgb[c] - 0.625) < 1e-12, "lit floor = %.17g", ia.rgb[c]);
    /* With it: the shadow ray meets the glass, only the ambient is left. */
    cr_assert(ib.rgb[c] == 0.125 && ib.rgb[c + 1] == 0.125 && ib.rgb[c + 2] == 0.125,
              "shadowed floor = (%.17g, %.17g, %.17g), expected the ambient 0.125", ib.rgb[c], ib.rgb[c + 1],
              ib.rgb[c + 2]);
    cr_assert_lt(bb[c], ba[c], "shadowed byte %d not darker than lit %d", bb[c], ba[c]);
    free(ba);
    free(bb);
    rd_image_free(&ia);
    rd_image_free(&ib);
    rd_scene_free(&a);
    rd_scene_free(&b);
}

Test(glass_mirror, mirror_with_zero_ks_is_its_ambient)
{
    /* A ks = 0 mirror sphere in front of a lit wall, with a light shining on
     * it: the mirror's pixels are exactly its ambient (its light comes only
     * by recursion, and ks = 0 sends none). 9x9 at fov 45: the 3x3 block
     * at the centre lies within the sphere (tan 0.092 < tan(asin(1/5)) =
     * 0.204). */
    rd_scene s;
    fixture_scene(&s, 9, 9);
    s.render.max_depth = 5;
    rd_rgb amb = v3(0.3, 0.55, 0.7);
    int mirror = add_material(&s, RD_MAT_PERFECT_SPECULAR);
    s.materials[mirror].ambient = amb;
    s.materials[mirror].ks = v3(0, 0, 0);
    int wall = add_material(&s, RD_MAT_DIFFUSE);
    s.materials[wall].ambient = v3(0.1, 0.1, 0.1);
    add_sphere(&s, v3(0, 0, 0), 1, mirror);
    add_plane(&s, v3(0, 0, 6), v3(0, 0, -1), wall); /* behind the camera: what a mirror would show */
    add_plane(&s, v3(0, 0, -4), v3(0, 0, 1), wall);
    add_point_light(&s, v3(0, 0, 4), v3(1, 1, 1));
    rd_image img;
    uint8_t *b;
    rd_render_stats st;
    b = render_bytes(&s, NULL, &img, &st);
    for (int y = 3; y <= 5; y++)
        for (int x = 3; x <= 5; x++) {
            const double *p = &img.rgb[(y * 9 + x) * 3];
            cr_assert(p[0] == amb.x && p[1] == amb.y && p[2] == amb.z,
                      "mirror pixel (%d,%d) = (%.17g, %.17g, %.17g), expected its ambient", x, y, p[0], p[1], p[2]);
            const uint8_t *q = &b[(y * 9 + x) * 3];
            cr_assert(q[0] == expect_byte(amb.x) && q[1] == expect_byte(amb.y) && q[2] == expect_byte(amb.z));
        }
    cr_assert_eq(st.secondary_rays, 0, "a ks = 0 mirror sent %llu secondary rays",
                 (unsigned long long)st.secondary_rays);
    free(b);
    rd_image_free(&img);
    rd_scene_free(&s);
}

/* Eye at the origin between mirrors z = -1 and z = +1: every camera ray
 * (any direction with a z component) bounces between them for ever. */
static void mirrors_scene(rd_scene *s, int depth, rd_rgb ks, rd_rgb amb)
{
    fixture_scene(s, 3, 3);
    s->camera.eye = v3(0, 0, 0);
    s->camera.target = v3(0, 0, -1);
    s->render.max_depth = depth;
    s->render.background = v3(1, 1, 1);
    int m = add_material(s, RD_MAT_PERFECT_SPECULAR);
    s->materials[m].ambient = amb;
    s->materials[m].ks = ks;
    add_plane(s, v3(0, 0, -1), v3(0, 0, 1), m);
    add_plane(s, v3(0, 0, 1), v3(0, 0, -1), m);
    /* A light, which mirrors ignore (they are lit only by recursion). */
    add_point_light(s, v3(0.1, 0.2, 0.3), v3(1, 1, 1));
}

static double series(double ks, double amb, int D)
{
    /* sum_{k=0}^{D} ks^k · amb, term by term */
    double sum = 0;
    for (int k = 0; k <= D; k++)
        sum += pow(ks, k) * amb;
    return sum;
}

Test(glass_mirror, facing_mirrors_give_the_geometric_series)
{
    rd_rgb ks = v3(0.5, 0.25, 0.75), amb = v3(0.1, 0.2, 0.05);
    int depths[] = {0, 1, 5};
    /* By hand, e.g. D = 5, red: 0.1·(1 + 1/2 + 1/4 + 1/8 + 1/16 + 1/32) = 0.196875. */
    double red5 = 0.1 * (1 + 0.5 + 0.25 + 0.125 + 0.0625 + 0.03125);
    cr_assert(fabs(series(0.5, 0.1, 5) - red5) < 1e-16);
    for (size_t di = 0; di < 3; di++) {
        int D = depths[di];
        rd_scene s;
        mirrors_scene(&s, D, ks, amb);
        rd_image img;
        uint8_t *b;
        rd_render_stats st;
        b = render_bytes(&s, NULL, &img, &st);
        double want[3] = {series(ks.x, amb.x, D), series(ks.y, amb.y, D), series(ks.z, amb.z, D)};
        for (int px = 0; px < 9; px++)
            for (int ch = 0; ch < 3; ch++) {
                double got = img.rgb[px * 3 + ch];
                /* Both sums have D+1 terms of at most 0.2: rounding stays
                 * below 1e-15, while one term more or less is >= 0.05·0.25^6
                 * = 1.2e-5. */
                cr_assert(fabs(got - want[ch]) < 1e-15, "max_depth %d, pixel %d channel %d: %.17g, series gives %.17g",
                          D, px, ch, got, want[ch]);
                cr_assert_eq(b[px * 3 + ch], expect_byte(want[ch]));
            }
        /* One secondary ray per bounce, none toward the light. */
        cr_assert_eq(st.secondary_rays, (uint64_t)9 * D);
        cr_assert_eq(st.shadow_rays, 0);
        if (D == 5)
            cr_assert(fabs(img.rgb[4 * 3] - red5) < 1e-15);
        free(b);
        rd_image_free(&img);
        rd_scene_free(&s);
    }
}
