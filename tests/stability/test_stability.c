/* The numerical-stability suite (tests/stability/cases.h): one test per
 * case of the table, each asserting that the case passes its stated
 * tolerance, that no rendered value is NaN or infinite and that every
 * render reported stats.nonfinite == 0. The cases, their properties and
 * tolerances are documented in tests/stability/cases.c and, with measured
 * values, in docs/stability.md (`make stability`). Run from the repository
 * root (scenes/extreme/). */
#include <criterion/criterion.h>

#include "stability/cases.h"

static void check(const char *name)
{
    const rd_case *c = rd_case_find(name);
    cr_assert(c, "no stability case named %s", name);
    rd_case_result r;
    rd_case_run(c, &r);
    cr_assert(!r.error, "%s: %s", name, r.detail);
    cr_expect_eq(r.bad_values, 0, "%s: %llu non-finite values in the images: %s", name,
                 (unsigned long long)r.bad_values, r.detail);
    cr_expect_eq(r.nonfinite, 0, "%s: stats.nonfinite = %llu: %s", name, (unsigned long long)r.nonfinite, r.detail);
    cr_assert(r.pass, "%s: %s\n  measured worst %g (%s), tolerance %g: %s", name, c->property, r.worst, c->unit,
              c->tolerance, r.detail);
}

#define CASE(n) \
    Test(stability, n, .timeout = 120) { check(#n); }

CASE(scale_pow2)
CASE(scale_pow2_wide)
CASE(scale_decimal)
CASE(translate_far)
CASE(scale_acne)
CASE(tiny_far_spheres)
CASE(huge_near_sphere)
CASE(planet_as_plane)
CASE(grazing_light)
CASE(camera_inside_sphere)
CASE(camera_on_surface)
CASE(rays_parallel)
CASE(tri_watertight)
CASE(tri_degenerate)
CASE(tri_flat_bvh)
CASE(tri_cancel_normals)
CASE(shininess_lobe)
CASE(highlight_disc)
CASE(cook_torrance_limits)
CASE(cook_torrance_lobe)
CASE(cook_torrance_image)
CASE(blinn_degenerate_h)
CASE(fresnel_critical)
CASE(glass_ior1)
CASE(cos_above_one)
CASE(light_inside_closed)
CASE(light_inside_near_shell)
CASE(light_on_surface)
CASE(light_far_point)
CASE(light_far_extreme)
CASE(light_intensity_1e38)
CASE(light_intensity_overflow)
CASE(light_zero)
CASE(area_light_zero_area)
CASE(mirror_series)
CASE(mirror_rays_linear)
CASE(stack_depth)
CASE(glass_rays_linear)
CASE(camera_fov_tiny)
CASE(camera_fov_wide)
CASE(camera_1x1)
CASE(camera_strips)
CASE(same_sphere_twice)
CASE(shuffled_order)

/* Every case of the table has a test above. */
Test(stability, table_complete)
{
    static const char *const listed[] = {
        "scale_pow2", "scale_pow2_wide", "scale_decimal", "translate_far", "scale_acne", "tiny_far_spheres",
        "huge_near_sphere", "planet_as_plane", "grazing_light", "camera_inside_sphere", "camera_on_surface",
        "rays_parallel", "tri_watertight", "tri_degenerate", "tri_flat_bvh", "tri_cancel_normals", "shininess_lobe",
        "highlight_disc", "cook_torrance_limits", "cook_torrance_lobe", "cook_torrance_image", "blinn_degenerate_h",
        "fresnel_critical", "glass_ior1", "cos_above_one", "light_inside_closed", "light_inside_near_shell",
        "light_on_surface", "light_far_point", "light_far_extreme", "light_intensity_1e38",
        "light_intensity_overflow", "light_zero", "area_light_zero_area", "mirror_series", "mirror_rays_linear",
        "stack_depth", "glass_rays_linear", "camera_fov_tiny", "camera_fov_wide", "camera_1x1", "camera_strips",
        "same_sphere_twice", "shuffled_order"};
    size_t n = sizeof listed / sizeof listed[0];
    cr_assert_eq(n, rd_case_count, "%zu tests for %zu cases", n, rd_case_count);
    for (size_t i = 0; i < rd_case_count; i++) {
        int found = 0;
        for (size_t k = 0; k < n; k++)
            found |= strcmp(listed[k], rd_cases[i].name) == 0;
        cr_assert(found, "case %s has no test", rd_cases[i].name);
    }
}
