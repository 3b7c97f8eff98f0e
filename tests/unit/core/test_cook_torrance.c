/* rd_cook_torrance_reflected (core/shading/material.h) against shading.md:
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
#include <criterion/criterion.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "material.h"
#include "rayd/scene.h"

static rd_material ct_mat(rd_rgb kd, rd_rgb ks, double roughness)
{
    rd_material m;
    memset(&m, 0, sizeof m);
    rd_material_defaults(&m, RD_MAT_COOK_TORRANCE);
    m.kd = kd;
    m.ks = ks;
    m.roughness = roughness;
    return m;
}

static rd_hit ct_hit(rd_vec3 n)
{
    rd_hit h;
    memset(&h, 0, sizeof h);
    h.n = n;
    h.ng = n;
    h.front = 1;
    return h;
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

#define assert_rel(got, want, tol, what)                                                                  \
    cr_assert(fabs((got) - (want)) <= (tol) * fabs(want), "%s: %.17g, expected %.17g", what, (double)(got), \
              (double)(want))

Test(ct_formula, mirror_direction_by_hand)
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
    rd_hit h = ct_hit(v3(0, 0, 1));
    rd_vec3 V = v3(r, 0, r), L = v3(r, 0, -r);
    rd_rgb got = rd_cook_torrance_reflected(&m, &h, L, V);
    double D = 1 / (M_PI * 0.04), s = pow(1 - r, 5), spec = D / (4 * r);
    double want[3] = {0.1 * r + (0.04 + 0.96 * s) * spec, 0.2 * r + (0.5 + 0.5 * s) * spec,
                      0.3 * r + (0.95 + 0.05 * s) * spec};
    /* The printed approximations above, to 8 digits. */
    cr_assert(fabs(want[0] - 0.18907209) < 1e-8 && fabs(want[1] - 1.5511978) < 1e-7 &&
                  fabs(want[2] - 2.8852493) < 1e-7,
              "hand values: %.10g %.10g %.10g", want[0], want[1], want[2]);
    /* A handful of roundings separate the two computations: 1e-13 relative. */
    assert_rel(got.x, want[0], 1e-13, "red");
    assert_rel(got.y, want[1], 1e-13, "green");
    assert_rel(got.z, want[2], 1e-13, "blue");
    /* Through the dispatcher too. */
    rd_rgb via = rd_calc_reflected_light(&m, &h, L, V);
    cr_assert(via.x == got.x && via.y == got.y && via.z == got.z);
}

Test(ct_formula, general_configuration_with_masking)
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
    rd_hit h = ct_hit(N);
    rd_vec3 H = v3_normalize(v3_sub(V, L));
    double nh = v3_dot(N, H), vh = v3_dot(V, H), nv = v3_dot(N, V);
    cr_assert(2 * nh * nv / vh < 1, "the configuration should be masked: G2 = %g", 2 * nh * nv / vh);
    rd_rgb want = ct_reference(&m, N, L, V), got = rd_cook_torrance_reflected(&m, &h, L, V);
    assert_rel(got.x, want.x, 1e-12, "red");
    assert_rel(got.y, want.y, 1e-12, "green");
    assert_rel(got.z, want.z, 1e-12, "blue");
    /* The specular part is there (not only kd·cos α). */
    cr_assert_gt(got.x - 0.3 * cos(tl), 0.1); /* G = 0.57, spec = 0.16 */
}

Test(ct_formula, random_configurations_match_the_formula)
{
    /* 20,000 configurations with N·V, cos α and N·H away from 0 (where the
     * reference itself is well conditioned): agreement to 1e-10 relative. */
    uint64_t s = 0x1234567;
    int checked = 0;
    for (int i = 0; i < 20000; i++) {
        double u[6];
        for (int k = 0; k < 6; k++) {
            s = s * 6364136223846793005ull + 1442695040888963407ull;
            u[k] = (double)(s >> 11) * 0x1.0p-53;
        }
        double tv = acos(0.05 + 0.95 * u[0]), tl = acos(0.05 + 0.95 * u[1]), pl = 2 * M_PI * u[2];
        double rough = 0.05 + 0.95 * u[3];
        rd_vec3 N = v3(0, 0, 1);
        rd_vec3 V = v3(sin(tv), 0, cos(tv));
        rd_vec3 L = v3_neg(v3(sin(tl) * cos(pl), sin(tl) * sin(pl), cos(tl)));
        rd_material m = ct_mat(v3(u[4], u[5], 0.5), v3(u[5], 0.04, u[4]), rough);
        rd_hit h = ct_hit(N);
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

Test(ct_formula, finite_and_non_negative_everywhere)
{
    double nvs[] = {1, 0.5, 0.1, 1e-3, 1e-8, 1e-16, 1e-100, 1e-300, 1e-310, DBL_TRUE_MIN, 0};
    double roughs[] = {1, 0.5, 0.1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6};
    /* Light elevation as cos θl: head-on down to grazing, and exactly in
     * the tangent plane. */
    double cls[] = {1, 0.9, 0.5, 0.1, 1e-3, 1e-8, 1e-16, 1e-300, 0};
    /* Azimuth of the light relative to the viewer: 180° is the mirror side. */
    double phis[] = {0, 45, 90, 135, 179.9999, 180};
    rd_rgb kss[] = {{0, 0, 0}, {0.04, 0.5, 0.9}, {1, 1, 1}};
    rd_hit h = ct_hit(v3(0, 0, 1));
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

Test(ct_formula, light_behind_or_viewer_below)
{
    rd_material m = ct_mat(v3(0.5, 0.5, 0.5), v3(1, 1, 1), 0.1);
    rd_hit h = ct_hit(v3(0, 0, 1));
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
