/* Unit tests for rd_calc_reflected_light, the per-material functions it
 * dispatches to, and rd_pow_cos (core/shading/material.h), against the table
 * in shading.md:
 *   cos α = max(-N·L, 0); 0 when cos α = 0 (whole term, no highlight leak)
 *   diffuse       kd·cos α
 *   phong         kd·cos α + ks·max(R·V, 0)^n,   R = reflect(L, N)
 *   blinn_phong   kd·cos α + ks·max(N·H, 0)^n,   H = normalize(V - L)
 *   cook_torrance kd·cos α + F·D·G/(4 N·V), Schlick F, Beckmann D, Cook-Torrance G
 *   perfect_specular, specular_refraction: 0.
 *
 * Geometry: the surface normal is +z. "Light at θ" means the light lies in
 * the xz-plane at θ from the normal on the +x side, so the unit vector
 * toward it is (sin θ, 0, cos θ) and L (light -> surface) is its negative.
 * "Viewer at θ" is V = (sin θ, 0, cos θ); negative θ is the -x side. The
 * expected values were worked out by hand (and checked to 30 digits), the
 * arithmetic in the comments, except where a test compares with the
 * formula evaluated straight from the vectors (ct_reference) or checks a
 * property over many random or extreme inputs. */
#include <criterion/criterion.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "material.h"
#include "scene_keys.h"
#include "support/assert.h"
#include "support/rng.h"

static double rad(double deg) { return deg * M_PI / 180.0; }

/* L for a light at θ degrees from the normal (+x side). */
static rd_vec3 light_at(double deg) { return v3(-sin(rad(deg)), 0, -cos(rad(deg))); }
/* V for a viewer at θ degrees from the normal (negative: -x side). */
static rd_vec3 view_at(double deg) { return v3(sin(rad(deg)), 0, cos(rad(deg))); }

/* A front hit whose normals are n. */
static rd_hit hit_along(rd_vec3 n)
{
    rd_hit h;
    memset(&h, 0, sizeof h);
    h.n = n;
    h.ng = n;
    h.front = 1;
    return h;
}

static rd_hit hit_up(void) { return hit_along(v3(0, 0, 1)); }

static rd_material mat(rd_material_type t)
{
    rd_material m;
    memset(&m, 0, sizeof m);
    rd_material_defaults(&m, t);
    return m;
}

/* ---- diffuse ----------------------------------------------------------- */

Test(materials, diffuse_lambert_cosine)
{
    rd_material m = mat(RD_MAT_DIFFUSE);
    m.kd = v3(0.8, 0.4, 0.2);
    rd_hit h = hit_up();
    /* Light overhead: cos α = 1 -> kd. */
    assert_vec_near(rd_calc_reflected_light(&m, &h, light_at(0), view_at(0)), 0.8, 0.4, 0.2, 1e-15);
    /* Light at 60°: cos α = cos 60° = 0.5 -> kd·0.5 = (0.4, 0.2, 0.1), whatever V is. */
    assert_vec_near(rd_calc_reflected_light(&m, &h, light_at(60), view_at(-45)), 0.4, 0.2, 0.1, 1e-15);
    assert_vec_near(rd_calc_reflected_light(&m, &h, light_at(60), view_at(80)), 0.4, 0.2, 0.1, 1e-15);
    /* Light at 45°: cos α = √2/2 = 0.70710678 -> 0.8·0.70710678 = 0.56568542. */
    assert_vec_near(rd_calc_reflected_light(&m, &h, light_at(45), view_at(0)), 0.565685424949238, 0.282842712474619,
                    0.141421356237310, 1e-14);
    /* The direct entry point agrees with the dispatcher. */
    assert_vec_near(rd_diffuse_reflected(&m, &h, light_at(60), view_at(0)), 0.4, 0.2, 0.1, 1e-15);
}

/* ---- phong ------------------------------------------------------------- */

Test(materials, phong_highlight_by_hand)
{
    rd_material m = mat(RD_MAT_PHONG);
    m.kd = v3(0.5, 0.5, 0.5);
    m.ks = v3(0.25, 0.5, 1);
    m.shininess = 2;
    rd_hit h = hit_up();
    /* Light at 60°: L = (-sin60, 0, -cos60), R = L - 2(L·N)N = (-sin60, 0, cos60),
     * the mirror direction at -60°. Viewer at -30°: R·V = cos(60° - 30°) = √3/2,
     * spec = (√3/2)² = 0.75. Result = kd·0.5 + ks·0.75
     *   = (0.25 + 0.1875, 0.25 + 0.375, 0.25 + 0.75) = (0.4375, 0.625, 1.0). */
    assert_vec_near(rd_calc_reflected_light(&m, &h, light_at(60), view_at(-30)), 0.4375, 0.625, 1.0, 1e-14);
    /* Viewer exactly at the mirror direction (-60°): spec = 1 -> kd·0.5 + ks. */
    assert_vec_near(rd_calc_reflected_light(&m, &h, light_at(60), view_at(-60)), 0.5, 0.75, 1.25, 1e-14);
    /* Viewer on the light's side at +60°: R·V = cos 120° = -0.5 -> max(·,0) = 0 -> kd·0.5. */
    assert_vec_near(rd_calc_reflected_light(&m, &h, light_at(60), view_at(60)), 0.25, 0.25, 0.25, 1e-15);
}

Test(materials, phong_shininess_50)
{
    rd_material m = mat(RD_MAT_PHONG);
    m.kd = v3(0, 0, 0);
    m.ks = v3(1, 1, 1);
    m.shininess = 50;
    rd_hit h = hit_up();
    /* Light at 30° -> R at -30°; viewer at -20°: angle 10°,
     * cos(10°)^50 = 0.98480775^50 = exp(50·ln 0.98480775) = exp(-0.765442) = 0.46512850. */
    assert_vec_near(rd_calc_reflected_light(&m, &h, light_at(30), view_at(-20)), 0.465128497295494, 0.465128497295494,
                    0.465128497295494, 1e-13);
    /* And it is Phong, not Blinn: Blinn would give cos(5°)^50 = 0.8264. */
}

/* ---- blinn_phong -------------------------------------------------------- */

Test(materials, blinn_phong_half_vector_by_hand)
{
    rd_material m = mat(RD_MAT_BLINN_PHONG);
    m.kd = v3(0.5, 0.5, 0.5);
    m.ks = v3(1, 0.5, 0);
    m.shininess = 4;
    rd_hit h = hit_up();
    /* Light at 60°, viewer at -30°: H = normalize(V - L) bisects the
     * directions to the viewer (-30°) and to the light (+60°): H at 15°.
     * N·H = cos 15°, spec = cos⁴15° = ((1 + cos 30°)/2)² = (0.93301270)² = 0.87051270.
     * Result = kd·0.5 + ks·0.87051270 = (1.12051270, 0.68525635, 0.25). */
    assert_vec_near(rd_calc_reflected_light(&m, &h, light_at(60), view_at(-30)), 1.120512701892219, 0.685256350946110,
                    0.25, 1e-14);
    /* Viewer at the mirror direction: H = N, spec = 1. */
    assert_vec_near(rd_calc_reflected_light(&m, &h, light_at(60), view_at(-60)), 1.25, 0.75, 0.25, 1e-14);
}

/* ---- cook_torrance ------------------------------------------------------ */

/* rd_cook_torrance_reflected against shading.md:
 *
 *   kd·cos α + F·D·G / (4 (N·V)),  0 specular where N·V <= 0,
 *   F = Schlick(F0 = ks, V·H) = ks + (1 - ks)(1 - V·H)^5,
 *   D = Beckmann(m = roughness, N·H) = exp(-tan²θh / m²) / (π m² cos⁴θh),
 *   G = min(1, 2(N·H)(N·V)/(V·H), 2(N·H)(cos α)/(V·H)),
 *   H = normalize(V - L), cos α = max(-N·L, 0).
 *
 * It must stay finite and non-negative everywhere, down to N·V = 1e-300,
 * subnormal and 0, roughness 1e-6 and grazing light, where the formula
 * itself divides by nearly zero. */

/* A Cook-Torrance material of kd, ks (F0) and roughness m. */
static rd_material ct_mat(rd_rgb kd, rd_rgb ks, double roughness)
{
    rd_material m = mat(RD_MAT_COOK_TORRANCE);
    m.kd = kd;
    m.ks = ks;
    m.roughness = roughness;
    return m;
}

/* The formula of shading.md, straight from the vectors. */
static rd_rgb ct_reference(const rd_material *m, rd_vec3 N, rd_vec3 L, rd_vec3 V)
{
    double cosa = fmax(-v3_dot(N, L), 0);
    double nv = v3_dot(N, V);
    rd_rgb c = v3_scale(m->kd, cosa);
    if (cosa == 0)
        return v3(0, 0, 0);
    if (nv <= 0)
        return c;
    rd_vec3 H = v3_normalize(v3_sub(V, L));
    double nh = v3_dot(N, H), vh = v3_dot(V, H);
    double tan2 = (1 - nh * nh) / (nh * nh), mm = m->roughness * m->roughness;
    double D = exp(-tan2 / mm) / (M_PI * mm * pow(nh, 4));
    double G = fmin(1, fmin(2 * nh * nv / vh, 2 * nh * cosa / vh));
    double s = pow(1 - vh, 5);
    rd_rgb F = v3(m->ks.x + (1 - m->ks.x) * s, m->ks.y + (1 - m->ks.y) * s, m->ks.z + (1 - m->ks.z) * s);
    return v3_add(c, v3_scale(F, D * G / (4 * nv)));
}

Test(materials, cook_torrance_viewer_overhead_light_60)
{
    /* F0 = ks = 0.04, m = 0.5, kd = 0.5. V = N, light at 60°:
     *   cos α = 0.5, N·V = 1, H at 30°: N·H = V·H = cos 30° = √3/2.
     *   D = exp(-tan²30°/m²) / (π m² cos⁴30°) = exp(-(1/3)/0.25) / (π·0.25·9/16)
     *     = exp(-4/3) / (9π/64) = 0.26359714 / 0.44178647 = 0.59666187
     *   G = min(1, 2·(√3/2)·1/(√3/2), 2·(√3/2)·0.5/(√3/2)) = min(1, 2, 1) = 1
     *   F = 0.04 + 0.96·(1 - √3/2)^5 = 0.04 + 0.96·4.3163066e-5 = 0.040041437
     *   spec = F·D·G/(4·1) = 0.040041437·0.59666187/4 = 0.0059727996
     * Result = 0.5·0.5 + 0.0059727996 = 0.2559727996. */
    rd_material m = mat(RD_MAT_COOK_TORRANCE);
    m.kd = v3(0.5, 0.5, 0.5);
    m.ks = v3(0.04, 0.04, 0.04);
    m.roughness = 0.5;
    rd_hit h = hit_up();
    rd_rgb c = rd_calc_reflected_light(&m, &h, light_at(60), view_at(0));
    assert_vec_near(c, 0.25597279957023830, 0.25597279957023830, 0.25597279957023830, 1e-13);
}

Test(materials, cook_torrance_mirror_configuration_schlick)
{
    /* Light at 60°, viewer at -60° (mirror): H = N, N·H = 1, V·H = N·V = cos α = 0.5.
     *   D = exp(0)/(π m²) = 1/(π·0.25) = 1.2732395
     *   G = min(1, 2·1·0.5/0.5, 2·1·0.5/0.5) = 1
     *   F = F0 + (1 - F0)(1 - 0.5)^5 = F0 + (1 - F0)/32: for F0 = 0.04 -> 0.07,
     *       for F0 = 1 -> 1, for F0 = 0 -> 1/32.
     *   spec = F·D/(4·0.5) = F·0.63661977: 0.044563384, 0.63661977, 0.019894368.
     * kd = 0 isolates the specular term. */
    rd_material m = mat(RD_MAT_COOK_TORRANCE);
    m.kd = v3(0, 0, 0);
    m.ks = v3(0.04, 1, 0);
    m.roughness = 0.5;
    rd_hit h = hit_up();
    rd_rgb c = rd_calc_reflected_light(&m, &h, light_at(60), view_at(-60));
    assert_vec_near(c, 0.0445633840657307, 0.636619772367581, 0.636619772367581 / 32, 1e-13);
}

Test(materials, cook_torrance_masking_term_limits)
{
    /* Viewer at 80° (grazing), light overhead: cos α = 1, N·V = cos 80° = 0.17364818,
     * H at 40°: N·H = V·H = cos 40° = 0.76604444.
     *   G = min(1, 2·N·H·N·V/V·H, 2·N·H·1/V·H) = min(1, 2·cos 80°, 2) = 0.34729636
     *   D = exp(-tan²40°/0.25)/(π·0.25·cos⁴40°) = exp(-0.70408819/0.25)/(π·0.25·0.34436251)
     *     = 0.22119117
     *   F = 0.04 + 0.96·(1 - cos 40°)^5 = 0.040672881
     *   spec = F·D·G/(4·N·V) = F·D·(2 N·V)/(4 N·V) = F·D/2 = 0.0044982411
     * Result = kd·1 + spec = 0.5044982411. */
    rd_material m = mat(RD_MAT_COOK_TORRANCE);
    m.kd = v3(0.5, 0.5, 0.5);
    m.ks = v3(0.04, 0.04, 0.04);
    m.roughness = 0.5;
    rd_hit h = hit_up();
    rd_rgb c = rd_calc_reflected_light(&m, &h, light_at(0), view_at(80));
    assert_vec_near(c, 0.50449824105298784, 0.50449824105298784, 0.50449824105298784, 1e-13);
}

Test(materials, cook_torrance_viewer_below_surface_no_specular)
{
    /* "0 where N·V <= 0": the specular fraction is undefined (division by
     * N·V) and contributes nothing; the diffuse part kd·cos α remains. */
    rd_material m = mat(RD_MAT_COOK_TORRANCE);
    m.kd = v3(0.5, 0.25, 1);
    m.ks = v3(1, 1, 1);
    m.roughness = 0.1;
    rd_hit h = hit_up();
    assert_vec_near(rd_calc_reflected_light(&m, &h, light_at(60), view_at(100)), 0.25, 0.125, 0.5, 1e-15);
    assert_vec_near(rd_calc_reflected_light(&m, &h, light_at(60), view_at(90)), 0.25, 0.125, 0.5, 1e-15);
}

static int finite_nonneg(rd_rgb c) { return v3_is_finite(c) && c.x >= 0 && c.y >= 0 && c.z >= 0; }

Test(materials, cook_torrance_finite_as_nv_to_zero_and_roughness_to_1e6)
{
    /* The header promises a finite, non-negative value for any unit inputs.
     * Sweep N·V = 10^-k (k = 1..307, all normal doubles) with roughness
     * down to 1e-6 and several light positions, including the mirror one
     * (light grazing from the other side), where H = N and D = 1/(π m²)
     * peaks at 3.2e11 while G/(N·V) grows like 1/(N·V). */
    double rough[] = {1, 0.3, 1e-2, 1e-4, 1e-6};
    rd_hit h = hit_up();
    int bad = 0, n = 0;
    char first[300] = "";
    for (size_t ri = 0; ri < sizeof rough / sizeof rough[0]; ri++) {
        rd_material m = mat(RD_MAT_COOK_TORRANCE);
        m.kd = v3(0.5, 0.5, 0.5);
        m.ks = v3(0.04, 0.5, 1);
        m.roughness = rough[ri];
        for (int k = 1; k <= 307; k++) {
            double e = pow(10, -k);
            rd_vec3 V = v3_normalize(v3(1, 0, e)); /* N·V = e */
            rd_vec3 Ls[4] = {
                v3_normalize(v3(1, 0, -e)), /* mirror: grazing light from -x */
                v3_normalize(v3(1, 0, -2 * e)),
                light_at(0), /* overhead */
                light_at(60),
            };
            for (int li = 0; li < 4; li++) {
                rd_rgb c = rd_calc_reflected_light(&m, &h, Ls[li], V);
                n++;
                if (!finite_nonneg(c)) {
                    if (!bad)
                        snprintf(
                            first, sizeof first,
                            "roughness %g, N·V = 1e-%d, L = (%.17g, %.17g, %.17g), V = (1, 0, 1e-%d) -> (%g, %g, %g)",
                            rough[ri], k, Ls[li].x, Ls[li].y, Ls[li].z, k, c.x, c.y, c.z);
                    bad++;
                }
            }
        }
    }
    cr_assert_eq(bad, 0, "%d of %d cook_torrance values were not finite and >= 0; first: %s", bad, n, first);
}

Test(materials, cook_torrance_mirror_direction_by_hand)
{
    /* N = +z; viewer and light both at 45°, opposite azimuths (the mirror
     * configuration): V = (√½, 0, √½), light from (-√½, 0, √½), so
     * L = (√½, 0, -√½).
     *   cos α = -N·L = √½ = 0.70710678;  N·V = √½
     *   H = normalize(V - L) = normalize(0, 0, 2√½) = N: N·H = 1, V·H = √½
     *   D = exp(-0/m²)/(π m²·1) = 1/(π·0.04) = 7.9577472   (m = 0.2)
     *   G = min(1, 2·1·√½/√½, 2·1·√½/√½) = min(1, 2, 2) = 1
     *   (1 - V·H)^5 = (1 - 0.70710678)^5 = 0.29289322^5 = 0.0021554928
     *   F = ks + (1 - ks)·0.0021554928:
     *       ks 0.04 -> 0.042069273, 0.5 -> 0.50107775, 0.95 -> 0.95010777
     *   spec = F·D·G/(4 N·V) = F·7.9577472/2.8284271 = F·2.8134884:
     *       0.11836142, 1.4097765, 2.6731173
     *   value = kd·√½ + spec, kd = (0.1, 0.2, 0.3):
     *       0.070710678 + 0.11836142 = 0.18907209
     *       0.14142136  + 1.4097765  = 1.5511978
     *       0.21213203  + 2.6731173  = 2.8852493 */
    double r = sqrt(0.5);
    rd_material m = ct_mat(v3(0.1, 0.2, 0.3), v3(0.04, 0.5, 0.95), 0.2);
    rd_hit h = hit_along(v3(0, 0, 1));
    rd_vec3 V = v3(r, 0, r), L = v3(r, 0, -r);
    rd_rgb got = rd_cook_torrance_reflected(&m, &h, L, V);
    double D = 1 / (M_PI * 0.04), s = pow(1 - r, 5), spec = D / (4 * r);
    double want[3] = {0.1 * r + (0.04 + 0.96 * s) * spec, 0.2 * r + (0.5 + 0.5 * s) * spec,
                      0.3 * r + (0.95 + 0.05 * s) * spec};
    /* The implementation against the hand values above (8 digits) ... */
    assert_rel(got.x, 0.18907209, 5e-8);
    assert_rel(got.y, 1.5511978, 5e-8);
    assert_rel(got.z, 2.8852493, 5e-8);
    /* ... and against the same formula in full precision: a handful of
     * roundings separate the two computations, 1e-13 relative. */
    assert_rel(got.x, want[0], 1e-13);
    assert_rel(got.y, want[1], 1e-13);
    assert_rel(got.z, want[2], 1e-13);
    /* Through the dispatcher too. */
    rd_rgb via = rd_calc_reflected_light(&m, &h, L, V);
    cr_assert(via.x == got.x && via.y == got.y && via.z == got.z);
}

Test(materials, cook_torrance_general_configuration_with_masking)
{
    /* A tilted normal and a viewer and light at grazing angles in
     * different planes, so that G < 1 (the second term, 2(N·H)(N·V)/(V·H),
     * is the minimum) and every factor is non-trivial. */
    rd_vec3 N = v3_normalize(v3(0.2, -0.3, 1));
    rd_vec3 t = v3_normalize(v3_cross(N, v3(1, 0, 0))), b = v3_cross(N, t);
    double tv = 84 * M_PI / 180, tl = 60 * M_PI / 180, pl = 165 * M_PI / 180;
    rd_vec3 V = v3_add(v3_scale(N, cos(tv)), v3_scale(t, sin(tv)));
    rd_vec3 toL = v3_add(v3_scale(N, cos(tl)), v3_add(v3_scale(t, sin(tl) * cos(pl)), v3_scale(b, sin(tl) * sin(pl))));
    rd_vec3 L = v3_neg(toL);
    rd_material m = ct_mat(v3(0.3, 0.5, 0.7), v3(0.04, 0.2, 0.9), 0.35);
    rd_hit h = hit_along(N);
    rd_vec3 H = v3_normalize(v3_sub(V, L));
    double nh = v3_dot(N, H), vh = v3_dot(V, H), nv = v3_dot(N, V);
    cr_assert(2 * nh * nv / vh < 1, "the configuration should be masked: G2 = %g", 2 * nh * nv / vh);
    rd_rgb want = ct_reference(&m, N, L, V), got = rd_cook_torrance_reflected(&m, &h, L, V);
    assert_rel(got.x, want.x, 1e-12);
    assert_rel(got.y, want.y, 1e-12);
    assert_rel(got.z, want.z, 1e-12);
    /* The specular part is there (not only kd·cos α). */
    cr_assert_gt(got.x - 0.3 * cos(tl), 0.1); /* G = 0.57, spec = 0.16 */
}

Test(materials, cook_torrance_random_configurations_match_the_formula)
{
    /* 20,000 configurations with N·V, cos α and N·H away from 0 (where the
     * reference itself is well conditioned): agreement to 1e-10 relative. */
    test_rng g = {0x1234567};
    int checked = 0;
    for (int i = 0; i < 20000; i++) {
        double u[6];
        for (int k = 0; k < 6; k++)
            u[k] = rng_uniform(&g);
        double tv = acos(0.05 + 0.95 * u[0]), tl = acos(0.05 + 0.95 * u[1]), pl = 2 * M_PI * u[2];
        double rough = 0.05 + 0.95 * u[3];
        rd_vec3 N = v3(0, 0, 1);
        rd_vec3 V = v3(sin(tv), 0, cos(tv));
        rd_vec3 L = v3_neg(v3(sin(tl) * cos(pl), sin(tl) * sin(pl), cos(tl)));
        rd_material m = ct_mat(v3(u[4], u[5], 0.5), v3(u[5], 0.04, u[4]), rough);
        rd_hit h = hit_along(N);
        rd_vec3 H = v3_normalize(v3_sub(V, L));
        if (v3_dot(N, H) < 0.05 || v3_dot(V, H) < 0.05)
            continue;
        rd_rgb want = ct_reference(&m, N, L, V), got = rd_cook_torrance_reflected(&m, &h, L, V);
        cr_assert(fabs(got.x - want.x) <= 1e-10 * fabs(want.x) + 1e-300 &&
                      fabs(got.y - want.y) <= 1e-10 * fabs(want.y) + 1e-300 &&
                      fabs(got.z - want.z) <= 1e-10 * fabs(want.z) + 1e-300,
                  "config %d (θv %.6f, θl %.6f, φ %.6f, m %.6f): (%.17g, %.17g, %.17g), formula (%.17g, %.17g, %.17g)",
                  i, tv, tl, pl, rough, got.x, got.y, got.z, want.x, want.y, want.z);
        checked++;
    }
    cr_assert_gt(checked, 15000);
}

Test(materials, cook_torrance_finite_and_non_negative_everywhere)
{
    double nvs[] = {1, 0.5, 0.1, 1e-3, 1e-8, 1e-16, 1e-100, 1e-300, 1e-310, DBL_TRUE_MIN, 0};
    double roughs[] = {1, 0.5, 0.1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6};
    /* Light elevation as cos θl: head-on down to grazing, and exactly in
     * the tangent plane. */
    double cls[] = {1, 0.9, 0.5, 0.1, 1e-3, 1e-8, 1e-16, 1e-300, 0};
    /* Azimuth of the light relative to the viewer: 180° is the mirror side. */
    double phis[] = {0, 45, 90, 135, 179.9999, 180};
    rd_rgb kss[] = {{0, 0, 0}, {0.04, 0.5, 0.9}, {1, 1, 1}};
    rd_hit h = hit_along(v3(0, 0, 1));
    long n = 0;
    for (size_t a = 0; a < sizeof nvs / sizeof *nvs; a++)
        for (size_t b = 0; b < sizeof roughs / sizeof *roughs; b++)
            for (size_t c = 0; c < sizeof cls / sizeof *cls; c++)
                for (size_t d = 0; d < sizeof phis / sizeof *phis; d++)
                    for (size_t e = 0; e < 3; e++) {
                        double nv = nvs[a], cl = cls[c], phi = phis[d] * M_PI / 180;
                        rd_vec3 V = v3(sqrt(1 - nv * nv), 0, nv);
                        double sl = sqrt(1 - cl * cl);
                        /* The light on the far side of the viewer's azimuth:
                         * phi = 180° puts it exactly in the mirror plane. */
                        rd_vec3 toL = v3(-sl * cos(phi), sl * sin(phi), cl);
                        if (phis[d] == 180)
                            toL = v3(-sl, 0, cl);
                        rd_vec3 L = v3_neg(toL);
                        rd_material m = ct_mat(v3(0.5, 0.5, 0.5), kss[e], roughs[b]);
                        rd_rgb r = rd_cook_torrance_reflected(&m, &h, L, V);
                        double ch[3] = {r.x, r.y, r.z};
                        for (int k = 0; k < 3; k++)
                            cr_assert(isfinite(ch[k]) && ch[k] >= 0,
                                      "N·V = %g, roughness %g, cos θl = %g, φ = %g°, ks %zu: channel %d = %g", nv,
                                      roughs[b], cl, phis[d], e, k, ch[k]);
                        if (cl == 0)
                            cr_assert(r.x == 0 && r.y == 0 && r.z == 0,
                                      "light in the tangent plane (cos α = 0) must give 0, got %g", r.x);
                        if (nv == 0 && cl > 0)
                            /* No specular where N·V <= 0: kd·cos α only. */
                            cr_assert(r.x == 0.5 * cl && r.y == 0.5 * cl && r.z == 0.5 * cl,
                                      "N·V = 0: %.17g, expected kd·cos α = %.17g", r.x, 0.5 * cl);
                        n++;
                    }
    cr_assert_eq(n, 11L * 8 * 9 * 6 * 3);
}

Test(materials, cook_torrance_light_behind_or_viewer_below)
{
    rd_material m = ct_mat(v3(0.5, 0.5, 0.5), v3(1, 1, 1), 0.1);
    rd_hit h = hit_along(v3(0, 0, 1));
    /* Light from below the surface: nothing at all, not even a highlight. */
    rd_vec3 Vs[] = {v3(0, 0, 1), v3(sqrt(0.5), 0, sqrt(0.5)), v3(1, 0, 0)};
    for (int i = 0; i < 3; i++) {
        rd_rgb r = rd_cook_torrance_reflected(&m, &h, v3_normalize(v3(0.3, 0, 1)), Vs[i]);
        cr_assert(r.x == 0 && r.y == 0 && r.z == 0, "light behind: %g", r.x);
    }
    /* Viewer below the surface: kd·cos α only. */
    rd_vec3 L = v3_normalize(v3(-1, 0, -1));
    rd_rgb r = rd_cook_torrance_reflected(&m, &h, L, v3_normalize(v3(1, 0, -0.2)));
    cr_assert(fabs(r.x - 0.5 * sqrt(0.5)) < 1e-15, "viewer below: %.17g", r.x);
}

/* ---- light behind the surface: exactly 0 for every material ------------- */

Test(materials, any_material_light_behind_gives_exact_zero)
{
    /* Lights with -N·L <= 0: from straight below, from 120° and 179°,
     * exactly grazing (cos α = 0) and a hair below grazing. For each, viewers
     * that would see the strongest highlight if it leaked: the reflection of
     * L, -L, the normal, and grazing. Shininess 0 makes max(·,0)^0 = 1,
     * so a missing cos α test would show ks even there. */
    rd_vec3 Ls[] = {v3(0, 0, 1),
                    light_at(120),
                    light_at(179),
                    v3(-1, 0, 0),
                    v3_normalize(v3(-1, 0, 1e-17)),
                    v3_normalize(v3(0.3, -0.4, 0.5))};
    double shin[] = {0, 1, 100};
    rd_hit h = hit_up();
    for (int t = 0; t < RD_MAT_COUNT; t++) {
        for (size_t si = 0; si < sizeof shin / sizeof shin[0]; si++) {
            rd_material m = mat((rd_material_type)t);
            m.kd = v3(0.7, 0.6, 0.5);
            m.ks = v3(1, 1, 1);
            m.shininess = shin[si];
            m.roughness = 0.01;
            for (size_t li = 0; li < sizeof Ls / sizeof Ls[0]; li++) {
                rd_vec3 L = Ls[li];
                rd_vec3 R = v3_reflect(L, h.n);
                rd_vec3 Vs[] = {R, v3_neg(R), v3_neg(L), L, h.n, v3(1, 0, 0), view_at(-89.9)};
                for (size_t vi = 0; vi < sizeof Vs / sizeof Vs[0]; vi++) {
                    rd_vec3 V = v3_normalize(Vs[vi]);
                    rd_rgb c = rd_calc_reflected_light(&m, &h, L, V);
                    cr_assert(c.x == 0 && c.y == 0 && c.z == 0,
                              "%s, shininess %g: L=(%g,%g,%g) V=(%g,%g,%g) gave (%g,%g,%g), expected exactly 0",
                              rd_material_type_words[t], shin[si], L.x, L.y, L.z, V.x, V.y, V.z, c.x, c.y, c.z);
                }
            }
        }
    }
}

Test(materials, mirror_and_glass_reflect_nothing_directly)
{
    /* perfect_specular and specular_refraction get their light by recursion:
     * calc_reflected_light is 0 even with the light in front and the viewer
     * in the mirror direction. */
    rd_material_type ts[] = {RD_MAT_PERFECT_SPECULAR, RD_MAT_SPECULAR_REFRACTION};
    rd_hit h = hit_up();
    for (int i = 0; i < 2; i++) {
        rd_material m = mat(ts[i]);
        m.kd = v3(1, 1, 1);
        m.ks = v3(1, 1, 1);
        double ang[] = {0, 30, 60, 89};
        for (int a = 0; a < 4; a++) {
            rd_rgb c = rd_calc_reflected_light(&m, &h, light_at(ang[a]), view_at(-ang[a]));
            cr_assert(c.x == 0 && c.y == 0 && c.z == 0, "%s gave (%g,%g,%g)", rd_material_type_words[ts[i]], c.x, c.y,
                      c.z);
        }
        cr_assert(rd_material_is_recursive(&m));
    }
    rd_material d = mat(RD_MAT_PHONG);
    cr_assert(!rd_material_is_recursive(&d));
}

Test(materials, any_material_finite_nonnegative_and_bounded_by_kd_when_no_ks)
{
    /* Random unit N, L, V and parameters: every value finite and >= 0, 0 when
     * -N·L <= 0, and equal to kd·cos α when ks = 0 (no specular term at all). */
    test_rng g = {42};
    rd_material_type ts[] = {RD_MAT_DIFFUSE, RD_MAT_PHONG, RD_MAT_BLINN_PHONG, RD_MAT_COOK_TORRANCE};
    for (int i = 0; i < 200000; i++) {
        rd_material m = mat(ts[i % 4]);
        m.kd = v3(rng_uniform(&g), rng_uniform(&g), rng_uniform(&g));
        int zero_ks = (i / 4) % 3 == 0;
        m.ks = zero_ks ? v3(0, 0, 0) : v3(rng_uniform(&g), rng_uniform(&g), rng_uniform(&g));
        m.shininess = pow(10, 9 * rng_uniform(&g));  /* 1 .. 1e9 */
        m.roughness = pow(10, -6 * rng_uniform(&g)); /* 1e-6 .. 1 */
        rd_hit h = hit_up();
        h.n = rng_unit(&g);
        rd_vec3 L = rng_unit(&g), V = rng_unit(&g);
        rd_rgb c = rd_calc_reflected_light(&m, &h, L, V);
        cr_assert(finite_nonneg(c), "%s: (%g,%g,%g)", rd_material_type_words[m.type], c.x, c.y, c.z);
        double cosa = -v3_dot(h.n, L);
        if (!(cosa > 0))
            cr_assert(c.x == 0 && c.y == 0 && c.z == 0);
        else if (zero_ks && m.type != RD_MAT_COOK_TORRANCE) /* CT's Fresnel is not 0 at ks = F0 = 0 */
            assert_vec_near(c, m.kd.x * cosa, m.kd.y * cosa, m.kd.z * cosa, 1e-15);
    }
}

/* ---- rd_pow_cos ---------------------------------------------------------- */

/* b at angle θ (radians) from a = +z. */
static rd_vec3 at_angle(double th) { return v3(sin(th), 0, cos(th)); }

Test(materials, pow_cos_peak_is_one)
{
    double ns[] = {0, 1, 1e3, 1e6, 1e9, 1e12};
    rd_vec3 as[] = {v3(0, 0, 1), v3_normalize(v3(1, 2, 3)), v3_normalize(v3(-0.3, 0.1, -7))};
    for (int i = 0; i < 6; i++)
        for (int k = 0; k < 3; k++)
            cr_assert_eq(rd_pow_cos(as[k], as[k], ns[i]), 1.0, "peak for n = %g is %.17g", ns[i],
                         rd_pow_cos(as[k], as[k], ns[i]));
}

Test(materials, pow_cos_n_zero_is_one)
{
    /* max(a·b, 0)^0 = 1, also where a·b <= 0 (0^0 = 1 by the header). */
    rd_vec3 a = v3(0, 0, 1);
    cr_assert_eq(rd_pow_cos(a, at_angle(1.0), 0), 1.0);
    cr_assert_eq(rd_pow_cos(a, v3(1, 0, 0), 0), 1.0);
    cr_assert_eq(rd_pow_cos(a, v3(0, 0, -1), 0), 1.0);
}

Test(materials, pow_cos_n_one_is_cosine)
{
    rd_vec3 a = v3(0, 0, 1);
    double th[] = {0.1, 0.5, 1.0, 1.5};
    for (int i = 0; i < 4; i++)
        assert_near(rd_pow_cos(a, at_angle(th[i]), 1), cos(th[i]), 4 * DBL_EPSILON);
    /* Beyond 90°: max(·, 0) = 0. */
    cr_assert_eq(rd_pow_cos(a, at_angle(2.0), 1), 0.0);
    cr_assert_eq(rd_pow_cos(a, v3(0, 0, -1), 1), 0.0);
    cr_assert_eq(rd_pow_cos(a, v3(0, 0, -1), 1e9), 0.0);
}

Test(materials, pow_cos_matches_pow_where_pow_is_accurate)
{
    /* For n up to 1e6 and moderate angles pow(cos θ, n) is accurate to
     * about n·ε relative: compare to 1e-9 relative. */
    rd_vec3 a = v3(0, 0, 1);
    struct {
        double n, th;
    } cs[] = {
        {2, 0.7}, {10, 0.3}, {1e3, 0.01}, {1e3, 0.05}, {1e6, 1e-3}, {1e6, 5e-4}, {1e6, 2e-3},
    };
    for (size_t i = 0; i < sizeof cs / sizeof cs[0]; i++) {
        double want = pow(cos(cs[i].th), cs[i].n);
        double got = rd_pow_cos(a, at_angle(cs[i].th), cs[i].n);
        cr_assert(fabs(got - want) <= 1e-9 * want, "n = %g, θ = %g: %.17g, pow gives %.17g", cs[i].n, cs[i].th, got,
                  want);
    }
    /* A hand value: n = 1e6, θ = 1e-3: ln cos θ = -θ²/2 - θ⁴/12 = -5.0000000833e-7,
     * ·1e6 = -0.50000000833, exp = 0.60653060917. */
    assert_near(rd_pow_cos(a, at_angle(1e-3), 1e6), 0.606530609168400, 1e-10);
}

Test(materials, pow_cos_gaussian_lobe_for_large_n)
{
    /* cos^n θ = exp(n ln cos θ) ≈ exp(-nθ²/2) when nθ⁴ is negligible. At
     * θ = k/√n the lobe is exp(-k²/2), whatever n: the shape survives even
     * where cos θ is within 1e-12 of 1. n = 1e9, θ = 3e-5: exp(-0.45) = 0.63762815;
     * θ⁴ term: n θ⁴/12 = 6.75e-11, negligible. */
    rd_vec3 a = v3(0, 0, 1);
    assert_near(rd_pow_cos(a, at_angle(3e-5), 1e9), 0.637628151621773, 1e-6);
    double ns[] = {1e6, 1e9, 1e12};
    double ks[] = {0.25, 0.5, 1, 2, 3};
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 5; k++) {
            double th = ks[k] / sqrt(ns[i]);
            double want = exp(-ks[k] * ks[k] / 2);
            double got = rd_pow_cos(a, at_angle(th), ns[i]);
            cr_assert(fabs(got - want) <= 1e-3 * want, "n = %g, θ = %g/√n: %.10g, expected exp(-%g) = %.10g", ns[i],
                      ks[k], got, ks[k] * ks[k] / 2, want);
        }
    /* Monotone: the lobe falls as θ grows. */
    double prev = 1;
    for (int j = 1; j <= 50; j++) {
        double v = rd_pow_cos(a, at_angle(j * 1e-6), 1e10);
        cr_assert(v < prev, "not decreasing at θ = %ge-6: %g >= %g", (double)j, v, prev);
        prev = v;
    }
}
