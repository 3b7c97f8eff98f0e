/* Unit tests for the pinhole camera (core/render/camera.h) against shading.md:
 *   w = normalize(eye - target), u = normalize(up × w), v = w × u,
 *   h = tan(fov/2), a = width/height,
 *   dir(x, y) = normalize((2x/width - 1)·a·h·u + (1 - 2y/height)·h·v - w).
 * Rays start at the origin because the world is camera-relative. */
#include <criterion/criterion.h>
#include <float.h>
#include <math.h>
#include <stdio.h>

#include "camera.h"
#include "support/assert.h"

#define TOL (8 * DBL_EPSILON)

static rd_camera cam_of(rd_vec3 eye, rd_vec3 target, rd_vec3 up, double fov)
{
    rd_camera c;
    c.eye = eye;
    c.target = target;
    c.up = up;
    c.fov_deg = fov;
    return c;
}

static rd_pinhole make_ok(rd_camera c, int w, int h)
{
    rd_pinhole p;
    rd_error err = {0};
    rd_error_code rc = rd_pinhole_make(&p, &c, w, h, &err);
    cr_assert_eq(rc, RD_OK, "rd_pinhole_make failed: %s", err.message);
    return p;
}

static void expect_invalid(rd_camera c, int w, int h, const char *what)
{
    rd_pinhole p;
    rd_error err = {0};
    rd_error_code rc = rd_pinhole_make(&p, &c, w, h, &err);
    cr_assert_eq(rc, RD_ERR_INVALID, "%s: expected RD_ERR_INVALID, got %d", what, (int)rc);
    cr_assert_eq(err.code, RD_ERR_INVALID, "%s: err.code not set", what);
    cr_assert(err.message[0] != 0, "%s: empty error message", what);
}

Test(camera, default_basis)
{
    /* eye (0,0,5), target 0, up +y: w = (0,0,1), u = y×z = (1,0,0), v = z×x = (0,1,0). */
    rd_pinhole p = make_ok(cam_of(v3(0, 0, 5), v3(0, 0, 0), v3(0, 1, 0), 90), 4, 2);
    assert_vec_near(p.w, 0, 0, 1, 0);
    assert_vec_near(p.u, 1, 0, 0, 0);
    assert_vec_near(p.v, 0, 1, 0, 0);
    assert_near(p.h, 1.0, TOL); /* tan(45°) */
    assert_near(p.aspect, 2.0, 0);
}

Test(camera, centre_ray_is_minus_w)
{
    /* At x = width/2, y = height/2 both screen terms vanish: dir = -w. Try an
     * oblique camera and both odd and even image sizes. */
    rd_camera c = cam_of(v3(1, 2, 3), v3(-4, 0.5, 7), v3(0.1, 1, -0.2), 37.5);
    int sizes[][2] = {{1, 1}, {3, 3}, {640, 480}, {17, 5}, {2, 9}};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) {
        rd_pinhole p = make_ok(c, sizes[i][0], sizes[i][1]);
        /* w by hand: eye - target = (5, 1.5, -4), |.|² = 25 + 2.25 + 16 = 43.25. */
        double l = sqrt(43.25);
        assert_vec_near(p.w, 5 / l, 1.5 / l, -4 / l, TOL);
        rd_ray r = rd_pinhole_ray(&p, sizes[i][0] / 2.0, sizes[i][1] / 2.0);
        cr_assert(r.o.x == 0 && r.o.y == 0 && r.o.z == 0, "ray origin must be the (camera-relative) origin");
        assert_vec_near(r.d, -5 / l, -1.5 / l, 4 / l, TOL);
    }
}

Test(camera, corner_rays_axis_aligned)
{
    /* eye (0,0,5) -> origin, fov 90 (h = 1), 4x2 (a = 2), u=(1,0,0), v=(0,1,0), w=(0,0,1).
     * Top-left corner (0,0): (2·0/4-1)·2·1 = -2, (1-0)·1 = 1 -> (-2, 1, -1)/√6.
     * Bottom-right corner (4,2): (+2, -1, -1)/√6.
     * Top-left pixel centre (0.5,0.5): (2·0.5/4-1)·2 = -1.5, (1-2·0.5/2) = 0.5
     *   -> (-1.5, 0.5, -1)/√3.5. */
    rd_pinhole p = make_ok(cam_of(v3(0, 0, 5), v3(0, 0, 0), v3(0, 1, 0), 90), 4, 2);
    double s6 = sqrt(6.0), s35 = sqrt(3.5);
    assert_vec_near(rd_pinhole_ray(&p, 0, 0).d, -2 / s6, 1 / s6, -1 / s6, TOL);
    assert_vec_near(rd_pinhole_ray(&p, 4, 2).d, 2 / s6, -1 / s6, -1 / s6, TOL);
    assert_vec_near(rd_pinhole_ray(&p, 4, 0).d, 2 / s6, 1 / s6, -1 / s6, TOL);
    assert_vec_near(rd_pinhole_ray(&p, 0, 2).d, -2 / s6, -1 / s6, -1 / s6, TOL);
    assert_vec_near(rd_pinhole_ray(&p, 0.5, 0.5).d, -1.5 / s35, 0.5 / s35, -1 / s35, TOL);
    /* x grows to the right (+u), y grows downward (-v). */
    cr_assert(rd_pinhole_ray(&p, 3.5, 1).d.x > 0);
    cr_assert(rd_pinhole_ray(&p, 2, 1.5).d.y < 0);
}

Test(camera, corner_rays_rotated_camera)
{
    /* eye (3,0,0) -> origin, up +z, fov 60, 2x2.
     * w = (1,0,0); u = up×w = (0,0,1)×(1,0,0) = (0,1,0); v = w×u = (1,0,0)×(0,1,0) = (0,0,1).
     * h = tan 30° = 1/√3, a = 1.
     * Corner (0,0): -h·u + h·v - w = (-1, -1/√3, 1/√3); its length is √(1 + 2/3) = √(5/3).
     * Corner (2,0): (+h)u + h v - w = (-1, 1/√3, 1/√3)/√(5/3). */
    rd_pinhole p = make_ok(cam_of(v3(3, 0, 0), v3(0, 0, 0), v3(0, 0, 1), 60), 2, 2);
    assert_vec_near(p.u, 0, 1, 0, TOL);
    assert_vec_near(p.v, 0, 0, 1, TOL);
    double h = 1 / sqrt(3.0), l = sqrt(5.0 / 3.0);
    assert_vec_near(rd_pinhole_ray(&p, 0, 0).d, -1 / l, -h / l, h / l, TOL);
    assert_vec_near(rd_pinhole_ray(&p, 2, 0).d, -1 / l, h / l, h / l, TOL);
    assert_vec_near(rd_pinhole_ray(&p, 1, 2).d, -1 / sqrt(4.0 / 3), 0, -h / sqrt(4.0 / 3), TOL);
}

Test(camera, basis_orthonormal_and_up_is_up)
{
    rd_pinhole p = make_ok(cam_of(v3(10, -3, 2), v3(0.5, 1, -7), v3(0.2, 0.9, 0.1), 70), 64, 48);
    assert_near(v3_len(p.u), 1, TOL);
    assert_near(v3_len(p.v), 1, TOL);
    assert_near(v3_len(p.w), 1, TOL);
    assert_near(v3_dot(p.u, p.v), 0, TOL);
    assert_near(v3_dot(p.u, p.w), 0, TOL);
    assert_near(v3_dot(p.v, p.w), 0, TOL);
    /* u ⟂ up, and v leans toward up (the image is not upside down). */
    assert_near(v3_dot(p.u, v3(0.2, 0.9, 0.1)), 0, TOL);
    cr_assert(v3_dot(p.v, v3(0.2, 0.9, 0.1)) > 0);
}

Test(camera, every_ray_is_unit)
{
    rd_pinhole p = make_ok(cam_of(v3(1, 1, 1), v3(2, -1, 0.25), v3(0, 0, 1), 120), 7, 3);
    for (int y = 0; y <= 3; y++)
        for (int x = 0; x <= 7; x++)
            assert_near(v3_len(rd_pinhole_ray(&p, x, y).d), 1.0, TOL);
}

Test(camera, error_eye_equals_target)
{
    expect_invalid(cam_of(v3(1, 2, 3), v3(1, 2, 3), v3(0, 1, 0), 45), 4, 4, "eye == target");
    expect_invalid(cam_of(v3(0, 0, 0), v3(0, 0, 0), v3(0, 1, 0), 45), 4, 4, "eye == target == 0");
}

Test(camera, error_fov_0_and_180)
{
    rd_vec3 e = v3(0, 0, 5), t = v3(0, 0, 0), up = v3(0, 1, 0);
    expect_invalid(cam_of(e, t, up, 0), 4, 4, "fov 0");
    expect_invalid(cam_of(e, t, up, 180), 4, 4, "fov 180");
    expect_invalid(cam_of(e, t, up, -10), 4, 4, "fov -10");
    expect_invalid(cam_of(e, t, up, 270), 4, 4, "fov 270");
    expect_invalid(cam_of(e, t, up, NAN), 4, 4, "fov NaN");
    /* Just inside the open interval is fine. */
    make_ok(cam_of(e, t, up, 1e-6), 4, 4);
    make_ok(cam_of(e, t, up, 179.999), 4, 4);
}

Test(camera, error_image_size)
{
    rd_camera c = cam_of(v3(0, 0, 5), v3(0, 0, 0), v3(0, 1, 0), 45);
    expect_invalid(c, 0, 4, "width 0");
    expect_invalid(c, 4, 0, "height 0");
}

Test(camera, error_up_parallel_simple)
{
    /* Looking straight down -y with up = ±y (and any positive multiple), or a zero up. */
    rd_vec3 e = v3(0, 5, 0), t = v3(0, 0, 0);
    expect_invalid(cam_of(e, t, v3(0, 1, 0), 45), 4, 4, "up == view");
    expect_invalid(cam_of(e, t, v3(0, -3, 0), 45), 4, 4, "up anti-parallel");
    expect_invalid(cam_of(e, t, v3(0, 0, 0), 45), 4, 4, "up zero");
    /* Nearly but not exactly parallel is a valid (if unusual) camera. */
    make_ok(cam_of(e, t, v3(0, 1, 1e-3), 45), 4, 4);
}

Test(camera, error_up_parallel_oblique)
{
    /* An up vector that is an exact integer multiple of eye - target is
     * parallel to the view in exact arithmetic, so the header promises
     * RD_ERR_INVALID. normalize(k·d) and normalize(d) may differ in the last
     * bit, so a test for an exactly zero up×w accepts some of them and then
     * builds u from rounding noise (an arbitrary image orientation).
     * Every eye in 1..9³ with up = k·eye, k = 2..7, target at the origin. */
    int accepted = 0, total = 0;
    char first[200] = "";
    for (int a = 1; a <= 9; a++)
        for (int b = 1; b <= 9; b++)
            for (int c = 1; c <= 9; c++)
                for (int k = 2; k <= 7; k++) {
                    rd_camera cam = cam_of(v3(a, b, c), v3(0, 0, 0), v3(k * a, k * b, k * c), 45);
                    rd_pinhole p;
                    rd_error err = {0};
                    total++;
                    if (rd_pinhole_make(&p, &cam, 4, 4, &err) != RD_ERR_INVALID) {
                        if (!accepted)
                            snprintf(first, sizeof first, "eye (%d,%d,%d), target 0, up (%d,%d,%d) -> u = (%g, %g, %g)",
                                     a, b, c, k * a, k * b, k * c, p.u.x, p.u.y, p.u.z);
                        accepted++;
                    }
                }
    cr_assert_eq(accepted, 0, "%d of %d exactly parallel up vectors were accepted, e.g. %s", accepted, total, first);
}
