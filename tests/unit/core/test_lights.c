/* Lights (scene-format.md light keys, shading.md trace() step 3): area
 * lights shrinking to a point, the spot cut-off and falloff, lights that
 * cannot contribute (zero colour, behind every surface) sending no shadow
 * rays, and directional lights having no distance dependence.
 *
 * Exact values come from rd_trace (core/render/trace.h) on a ray aimed at a chosen
 * point, so the geometry is known to the last bit up to the ray's rounding
 * (a few ulps); whole images come from rd_render. Materials are diffuse
 * with zero ambient unless stated, so a lit value is
 *     colour · spot factor · kd · cos α,  cos α = -N·L. */
#include <criterion/criterion.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "light.h"
#include "rayd/render.h"
#include "rayd/scene.h"
#include "support/scene_fixture.h"
#include "trace.h"

/* Radiance along the ray from the eye through world point x, and the ray
 * counts it took. */
static rd_rgb trace_to(const rd_scene *s, rd_vec3 x, rd_ray_counts *counts)
{
    rd_plan p;
    rd_error err = {0};
    cr_assert_eq(rd_plan_build(&p, s, &err), RD_OK, "%s", err.message);
    rd_ray r;
    r.o = v3(0, 0, 0); /* the eye, in the world's camera-relative frame */
    r.d = v3_normalize(v3_sub(x, s->camera.eye));
    rd_rng rng = rd_rng_make(s->render.seed, 0, 0);
    rd_ray_counts local = {0};
    rd_rgb c = rd_trace(&p, r, 0, &rng, counts ? counts : &local);
    rd_plan_free(&p);
    return c;
}

/* ---- area light of vanishing size ------------------------------------------ */

static void area_vs_point_scene(rd_scene *s, int area)
{
    fixture_scene(s, 48, 36);
    int red = add_diffuse(s, v3(0.7, 0.2, 0.1), v3(0.02, 0.02, 0.02));
    int grey = add_diffuse(s, v3(0.6, 0.6, 0.6), v3(0.02, 0.02, 0.02));
    s->materials[red].type = RD_MAT_PHONG;
    s->materials[red].ks = v3(0.3, 0.3, 0.3);
    s->materials[red].shininess = 20;
    add_sphere(s, v3(0, 0, 0), 1, red);
    add_plane(s, v3(0, -1, 0), v3(0, 1, 0), grey);
    rd_vec3 corner = v3(2, 3, 3);
    if (area) {
        rd_light *l = add_light(s, RD_LIGHT_AREA, v3(1, 0.9, 0.8));
        l->corner = corner;
        l->edge1 = v3(1e-9, 0, 0);
        l->edge2 = v3(0, 0, 1e-9);
        l->samples = 4;
    } else {
        rd_light *l = add_light(s, RD_LIGHT_POINT, v3(1, 0.9, 0.8));
        l->position = corner;
    }
}

Test(lights, tiny_area_light_matches_point_light)
{
    /* Its 16 points lie within 1.5e-9 of the corner and carry colour/16
     * each: the sum is the point light's value up to ~1e-9 relative, so
     * bytes agree within the rounding of floor(c·255 + 0.5): +-1. The
     * shadow terminator can move by the light's size only, far below a
     * pixel. */
    rd_scene a, p;
    area_vs_point_scene(&a, 1);
    area_vs_point_scene(&p, 0);
    rd_image ia, ip;
    uint8_t *ba, *bp;
    rd_render_stats sa, sp;
    ba = render_bytes(&a, NULL, &ia, &sa);
    bp = render_bytes(&p, NULL, &ip, &sp);
    size_t n = (size_t)ia.width * ia.height * 3;
    int lit = 0;
    for (size_t i = 0; i < n; i++) {
        int d = (int)ba[i] - (int)bp[i];
        cr_assert(d >= -1 && d <= 1, "pixel %zu channel %zu: area light %d, point light %d", i / 3, i % 3, ba[i],
                  bp[i]);
        lit += bp[i] > 20;
    }
    cr_assert_gt(lit, (int)n / 4, "the scene is hardly lit: the comparison would prove nothing");
    /* 16 shadow rays for each 1 of the point light. */
    cr_assert_eq(sa.shadow_rays, 16 * sp.shadow_rays);
    free(ba);
    free(bp);
    rd_image_free(&ia);
    rd_image_free(&ip);
    rd_scene_free(&a);
    rd_scene_free(&p);
}

/* ---- spot lights ------------------------------------------------------------ */

/* A spot 1 above the plane z = 0 pointing straight down: the floor point
 * at distance tan θ from the foot is θ off axis. */
static void spot_scene(rd_scene *s, double falloff)
{
    fixture_scene(s, 8, 8);
    s->camera.eye = v3(0.25, -0.5, 6);
    int m = add_diffuse(s, v3(0.5, 0.25, 0.75), v3(0, 0, 0));
    add_plane(s, v3(0, 0, 0), v3(0, 0, 1), m);
    rd_light *l = add_light(s, RD_LIGHT_SPOT, v3(1, 1, 1));
    l->position = v3(0, 0, 1);
    l->direction = v3(0, 0, -1);
    l->angle_deg = 30;
    l->falloff = falloff;
}

Test(lights, spot_cutoff_is_exact)
{
    rd_scene s;
    spot_scene(&s, 0);
    /* Along several azimuths, so the test does not depend on one axis. */
    for (int az = 0; az < 8; az++) {
        double phi = az * M_PI / 4 + 0.1;
        double tin = tan(29.999 * M_PI / 180), tout = tan(30.001 * M_PI / 180);
        rd_vec3 xin = v3(tin * cos(phi), tin * sin(phi), 0);
        rd_vec3 xout = v3(tout * cos(phi), tout * sin(phi), 0);
        rd_ray_counts cin = {0}, cout = {0};
        rd_rgb in = trace_to(&s, xin, &cin);
        rd_rgb out = trace_to(&s, xout, &cout);
        /* Inside: kd · cos α with cos α = cos 29.999° (N = +z, the spot
         * straight above the foot). Angular rounding is ~1e-16 against a
         * margin of 1.7e-5 rad. */
        double ca = cos(29.999 * M_PI / 180);
        cr_assert(fabs(in.x - 0.5 * ca) < 1e-12 && fabs(in.y - 0.25 * ca) < 1e-12 && fabs(in.z - 0.75 * ca) < 1e-12,
                  "29.999° off axis (azimuth %d): (%.17g, %.17g, %.17g), expected kd·%.17g", az, in.x, in.y, in.z, ca);
        cr_assert_eq(cin.shadow, 1);
        cr_assert(out.x == 0 && out.y == 0 && out.z == 0, "30.001° off axis (azimuth %d) is lit: (%.17g, %.17g, %.17g)",
                  az, out.x, out.y, out.z);
    }
    rd_scene_free(&s);
}

Test(lights, spot_cutoff_at_the_light_level)
{
    /* The same at rd_light_sample_at, with exact directions: at 29.999° the
     * sample exists, at 30.001° it does not. Axis tilted off the
     * coordinate axes. */
    rd_light l;
    memset(&l, 0, sizeof l);
    l.type = RD_LIGHT_SPOT;
    l.color = v3(1, 1, 1);
    l.position = v3(1, 2, 3);
    l.direction = v3(1, -2, -0.5);
    l.angle_deg = 30;
    l.falloff = 0;
    rd_light_prep lp;
    rd_light_prepare(&lp, &l, v3(0, 0, 0));
    rd_vec3 d = v3_normalize(l.direction);
    rd_vec3 u = v3_normalize(v3_cross(d, v3(0, 0, 1)));
    for (int k = 0; k < 2; k++) {
        double th = (k ? 30.001 : 29.999) * M_PI / 180;
        rd_vec3 dir = v3_add(v3_scale(d, cos(th)), v3_scale(u, sin(th)));
        rd_vec3 p = v3_add(l.position, v3_scale(dir, 7.0));
        rd_light_sample ls;
        int got = rd_light_sample_at(&lp, p, 0, 0.5, 0.5, &ls);
        cr_assert_eq(got, !k, "%s the cone: rd_light_sample_at returned %d", k ? "outside" : "inside", got);
        if (got)
            cr_assert(ls.color.x == 1 && ls.color.y == 1 && ls.color.z == 1, "falloff 0 must not scale the colour");
    }
}

Test(lights, spot_falloff_by_hand)
{
    /* Spot at S = (0,0,2), axis (1,0,-2)/√5, colour (0.8,0.6,1), falloff 3;
     * floor z = 0 with kd (0.5,0.25,0.75); hit X = (1.5,0.5,0).
     *   L = (X - S)/|X - S| = (1.5, 0.5, -2)/√6.5
     *   spot cosine c = L·axis = (1.5 + 4)/(√5·√6.5) = 5.5/√32.5 = 0.96476...
     *     (15.26° off axis, inside 30°)
     *   cos α = -N·L = 2/√6.5 = 0.78446...
     *   value = colour · c³ · kd · cos α. */
    rd_scene s;
    fixture_scene(&s, 8, 8);
    int m = add_diffuse(&s, v3(0.5, 0.25, 0.75), v3(0, 0, 0));
    add_plane(&s, v3(0, 0, 0), v3(0, 0, 1), m);
    rd_light *l = add_light(&s, RD_LIGHT_SPOT, v3(0.8, 0.6, 1.0));
    l->position = v3(0, 0, 2);
    l->direction = v3(1, 0, -2);
    l->angle_deg = 30;
    l->falloff = 3;
    double c = 5.5 / sqrt(32.5), ca = 2 / sqrt(6.5);
    double f = c * c * c * ca;
    rd_rgb want = v3(0.8 * 0.5 * f, 0.6 * 0.25 * f, 1.0 * 0.75 * f);
    rd_rgb got = trace_to(&s, v3(1.5, 0.5, 0), NULL);
    cr_assert(fabs(got.x - want.x) < 1e-12 && fabs(got.y - want.y) < 1e-12 && fabs(got.z - want.z) < 1e-12,
              "spot with falloff 3: (%.17g, %.17g, %.17g), by hand (%.17g, %.17g, %.17g)", got.x, got.y, got.z, want.x,
              want.y, want.z);
    /* Falloff 0.5 at the same point: c^0.5. */
    s.lights[0].falloff = 0.5;
    f = sqrt(c) * ca;
    got = trace_to(&s, v3(1.5, 0.5, 0), NULL);
    cr_assert(fabs(got.x - 0.8 * 0.5 * f) < 1e-12 && fabs(got.z - 0.75 * f) < 1e-12,
              "spot with falloff 0.5: %.17g, by hand %.17g", got.x, 0.8 * 0.5 * f);
    rd_scene_free(&s);
}

/* ---- lights that cannot contribute ------------------------------------------ */

static void dark_scene(rd_scene *s)
{
    fixture_scene(s, 16, 12);
    int m = add_diffuse(s, v3(0.6, 0.5, 0.4), v3(0.0625, 0.125, 0.25));
    add_sphere(s, v3(0, 0, 0), 1, m);
    add_plane(s, v3(0, -1, 0), v3(0, 1, 0), m);
}

Test(lights, zero_colour_light_sends_no_shadow_rays)
{
    rd_scene s, ref;
    dark_scene(&s);
    dark_scene(&ref);
    rd_light *l = add_light(&s, RD_LIGHT_POINT, v3(0, 0, 0));
    l->position = v3(2, 3, 4);
    l = add_light(&s, RD_LIGHT_AREA, v3(0, 0, 0));
    l->corner = v3(-2, 3, 1);
    l->edge1 = v3(1, 0, 0);
    l->edge2 = v3(0, 0, 1);
    l = add_light(&s, RD_LIGHT_DIRECTIONAL, v3(0, 0, 0));
    l->direction = v3(0, -1, -1);
    rd_image i1, i2;
    rd_render_stats st, st2;
    render_ok(&s, NULL, &i1, &st);
    render_ok(&ref, NULL, &i2, &st2);
    cr_assert_eq(st.shadow_rays, 0, "black lights sent %llu shadow rays", (unsigned long long)st.shadow_rays);
    /* And contribute nothing: the image is the one without them, bit for bit. */
    cr_assert(memcmp(i1.rgb, i2.rgb, sizeof(double) * 3 * 16 * 12) == 0);
    /* A black light next to a real one costs nothing either. */
    rd_scene s2, ref2;
    dark_scene(&s2);
    dark_scene(&ref2);
    add_light(&s2, RD_LIGHT_POINT, v3(0, 0, 0))->position = v3(2, 3, 4);
    add_light(&s2, RD_LIGHT_POINT, v3(1, 1, 1))->position = v3(-2, 3, 4);
    add_light(&ref2, RD_LIGHT_POINT, v3(1, 1, 1))->position = v3(-2, 3, 4);
    rd_image i3, i4;
    rd_render_stats st3, st4;
    render_ok(&s2, NULL, &i3, &st3);
    render_ok(&ref2, NULL, &i4, &st4);
    cr_assert_gt(st4.shadow_rays, 0);
    cr_assert_eq(st3.shadow_rays, st4.shadow_rays);
    cr_assert(memcmp(i3.rgb, i4.rgb, sizeof(double) * 3 * 16 * 12) == 0);
    rd_image_free(&i1);
    rd_image_free(&i2);
    rd_image_free(&i3);
    rd_image_free(&i4);
    rd_scene_free(&s);
    rd_scene_free(&ref);
    rd_scene_free(&s2);
    rd_scene_free(&ref2);
}

Test(lights, light_behind_every_surface_sends_no_shadow_rays)
{
    /* Every surface faces the camera (+z); every light is on the -z side of
     * all of them, so cos α <= 0 at every hit: no contribution, no shadow
     * ray, and each pixel is exactly the ambient. */
    rd_scene s;
    fixture_scene(&s, 16, 12);
    rd_rgb amb = v3(0.0625, 0.125, 0.25);
    int m = add_diffuse(&s, v3(0.6, 0.5, 0.4), amb);
    add_plane(&s, v3(0, 0, 0), v3(0, 0, 1), m);
    add_triangle(&s, v3(-1, -1, 0.5), v3(1, -1, 0.5), v3(0, 1, 0.5), m);
    add_triangle(&s, v3(-0.5, 0.2, 1), v3(0.5, 0.2, 1), v3(0, 0.8, 1), m);
    add_light(&s, RD_LIGHT_POINT, v3(1, 1, 1))->position = v3(0.5, 0.5, -5);
    add_light(&s, RD_LIGHT_DIRECTIONAL, v3(1, 1, 1))->direction = v3(0.1, 0.2, 1);
    rd_light *sp = add_light(&s, RD_LIGHT_SPOT, v3(1, 1, 1));
    sp->position = v3(0, 0, -2);
    sp->direction = v3(0, 0, 1);
    sp->angle_deg = 80;
    rd_light *ar = add_light(&s, RD_LIGHT_AREA, v3(1, 1, 1));
    ar->corner = v3(-1, -1, -3);
    ar->edge1 = v3(2, 0, 0);
    ar->edge2 = v3(0, 2, 0);
    rd_image img;
    rd_render_stats st;
    render_ok(&s, NULL, &img, &st);
    cr_assert_eq(st.shadow_rays, 0, "lights behind every surface sent %llu shadow rays",
                 (unsigned long long)st.shadow_rays);
    for (int i = 0; i < 16 * 12; i++)
        cr_assert(img.rgb[3 * i] == amb.x && img.rgb[3 * i + 1] == amb.y && img.rgb[3 * i + 2] == amb.z,
                  "pixel %d = (%.17g, %.17g, %.17g), expected the ambient", i, img.rgb[3 * i], img.rgb[3 * i + 1],
                  img.rgb[3 * i + 2]);
    rd_image_free(&img);
    rd_scene_free(&s);
}

/* ---- directional lights ------------------------------------------------------ */

Test(lights, directional_light_has_no_distance_falloff)
{
    /* Plane facing the camera at distance 5, 15 and 1005; light travelling
     * along (1,-1,-2)/√6: cos α = 2/√6 everywhere on the plane, and every
     * pixel is kd·2/√6 whatever the distance. */
    double ca = 2 / sqrt(6.0);
    rd_rgb kd = v3(0.5, 0.25, 0.75);
    double zs[] = {0, -10, -1000};
    for (int k = 0; k < 3; k++) {
        rd_scene s;
        fixture_scene(&s, 9, 7);
        int m = add_diffuse(&s, kd, v3(0, 0, 0));
        add_plane(&s, v3(0, 0, zs[k]), v3(0, 0, 1), m);
        add_light(&s, RD_LIGHT_DIRECTIONAL, v3(1, 1, 1))->direction = v3(1, -1, -2);
        rd_image img;
        rd_render_stats st;
        render_ok(&s, NULL, &img, &st);
        cr_assert_eq(st.shadow_rays, 9 * 7);
        for (int i = 0; i < 9 * 7; i++) {
            const double *p = &img.rgb[3 * i];
            cr_assert(
                fabs(p[0] - kd.x * ca) < 1e-15 && fabs(p[1] - kd.y * ca) < 1e-15 && fabs(p[2] - kd.z * ca) < 1e-15,
                "plane at z = %g, pixel %d: (%.17g, %.17g, %.17g), expected kd·%.17g", zs[k], i, p[0], p[1], p[2], ca);
        }
        rd_image_free(&img);
        rd_scene_free(&s);
    }
}
