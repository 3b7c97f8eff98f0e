/* rd_fresnel_dielectric (core/shading/fresnel.h): the exact unpolarised Fresnel
 * reflectance of shading.md, step 5.
 *
 * The reference values are computed here from angles, not cosines: Snell's
 * law sin θt = (n1/n2) sin θi with asin, then the classic sine/tangent forms
 *     rs = -sin(θi - θt) / sin(θi + θt),  rp = tan(θi - θt) / tan(θi + θt),
 *     R  = (rs² + rp²) / 2,
 * which share no arithmetic with the implementation's cosine forms. Both are
 * well conditioned away from normal incidence (0/0 there, so 0° is checked
 * against (n1-n2)²/(n1+n2)² instead) and the critical angle, so they agree
 * to a few ulps of the angle: 1e-12 absolute is generous for rounding yet
 * far below any real error (Schlick's approximation, for instance, is off by
 * up to ~0.01 at these indices). */
#include <criterion/criterion.h>
#include <float.h>
#include <math.h>

#include "fresnel.h"

static double deg(double d) { return d * M_PI / 180.0; }

/* Reference reflectance for incidence angle thi (radians) below any
 * critical angle; *cost gets cos θt. */
static double ref_fresnel(double thi, double n1, double n2, double *cost)
{
    double tht = asin(n1 / n2 * sin(thi));
    *cost = cos(tht);
    if (thi == 0) {
        double r = (n1 - n2) / (n1 + n2);
        return r * r;
    }
    double rs = -sin(thi - tht) / sin(thi + tht);
    double rp = tan(thi - tht) / tan(thi + tht);
    return 0.5 * (rs * rs + rp * rp);
}

Test(fresnel, normal_incidence_is_0_04)
{
    double cost = -1;
    double R = rd_fresnel_dielectric(1.0, 1.0, 1.5, &cost);
    /* ((1.5 - 1) / (1.5 + 1))² = (0.5/2.5)² = 0.04 */
    cr_assert(fabs(R - 0.04) <= 1e-12, "R(0°, 1 -> 1.5) = %.17g, expected 0.04", R);
    cr_assert(fabs(cost - 1.0) <= 1e-15, "cos θt = %.17g at normal incidence", cost);
    /* The same from inside the glass: reciprocity at normal incidence. */
    R = rd_fresnel_dielectric(1.0, 1.5, 1.0, &cost);
    cr_assert(fabs(R - 0.04) <= 1e-12, "R(0°, 1.5 -> 1) = %.17g, expected 0.04", R);
}

Test(fresnel, matches_snell_formula_air_to_glass)
{
    /* 0.0°, 0.1°, ..., 89.9° */
    for (int i = 0; i < 900; i++) {
        double th = deg(i / 10.0);
        double ct_ref, ct = -1;
        double want = ref_fresnel(th, 1.0, 1.5, &ct_ref);
        double R = rd_fresnel_dielectric(cos(th), 1.0, 1.5, &ct);
        cr_assert(fabs(R - want) <= 1e-12, "at %.1f°: R = %.17g, Snell/Fresnel gives %.17g", i / 10.0, R, want);
        cr_assert(fabs(ct - ct_ref) <= 1e-12, "at %.1f°: cos θt = %.17g, expected %.17g", i / 10.0, ct, ct_ref);
        cr_assert(R >= 0 && R <= 1);
    }
}

Test(fresnel, matches_snell_formula_glass_to_air_below_critical)
{
    double crit = asin(1 / 1.5); /* 41.81° */
    /* Up to 41.0°: 0.8° short of the critical angle, where the reference is
     * still well conditioned. */
    for (int i = 0; i <= 410; i++) {
        double th = deg(i / 10.0);
        cr_assert(th < crit);
        double ct_ref, ct = -1;
        double want = ref_fresnel(th, 1.5, 1.0, &ct_ref);
        double R = rd_fresnel_dielectric(cos(th), 1.5, 1.0, &ct);
        cr_assert(fabs(R - want) <= 1e-12, "at %.1f°: R = %.17g, Snell/Fresnel gives %.17g", i / 10.0, R, want);
        cr_assert(fabs(ct - ct_ref) <= 1e-12, "at %.1f°: cos θt = %.17g, expected %.17g", i / 10.0, ct, ct_ref);
    }
}

Test(fresnel, total_internal_reflection_past_critical_angle)
{
    double crit = asin(1 / 1.5);
    /* Just past the critical angle, then on to grazing. */
    double past[] = {crit + 1e-9, crit + 1e-6, crit + deg(0.1), deg(45), deg(60), deg(89.9), M_PI / 2};
    for (size_t i = 0; i < sizeof past / sizeof *past; i++) {
        double cost = -1;
        double R = rd_fresnel_dielectric(cos(past[i]), 1.5, 1.0, &cost);
        cr_assert(R == 1.0, "at %.12f°: R = %.17g, expected exactly 1 (TIR)", past[i] * 180 / M_PI, R);
        cr_assert(cost == 0.0, "under TIR cos θt = %.17g, expected 0", cost);
    }
    cr_assert(rd_fresnel_dielectric(0.0, 1.5, 1.0, &(double){0}) == 1.0);
    /* Just below it: partial reflection, R < 1. */
    double below[] = {crit - 1e-6, crit - 1e-4, crit - deg(0.1)};
    for (size_t i = 0; i < sizeof below / sizeof *below; i++) {
        double cost = -1;
        double R = rd_fresnel_dielectric(cos(below[i]), 1.5, 1.0, &cost);
        cr_assert(R < 1.0 && R > 0.0, "at %.12f°: R = %.17g, expected in (0, 1)", below[i] * 180 / M_PI, R);
        cr_assert(cost > 0.0);
    }
}

Test(fresnel, monotone_toward_one_at_critical_angle)
{
    double crit = asin(1 / 1.5);
    /* Over the last 10° before the critical angle R rises strictly (the
     * internal Brewster angle, 33.7°, is the minimum of rp²; past it both
     * rs² and rp² increase). */
    double prev = -1, c;
    for (int i = 0; i <= 10000; i++) {
        double th = crit - deg(10) + deg(10) * i / 10000.0 * (1 - 1e-9);
        double R = rd_fresnel_dielectric(cos(th), 1.5, 1.0, &c);
        cr_assert(R > prev, "R not increasing at %.9f°: %.17g after %.17g", th * 180 / M_PI, R, prev);
        prev = R;
    }
    /* ... and reaches close to 1: R -> 1 as θ -> θc (the sqrt-shaped
     * approach makes R(θc - 1e-10) about 1 - 4e-5). */
    double R = rd_fresnel_dielectric(cos(crit - 1e-10), 1.5, 1.0, &c);
    cr_assert(R > 0.999 && R < 1.0, "R just below the critical angle = %.17g", R);
    /* From the outside the unpolarised R never falls as θ grows (up to
     * rounding noise of 1e-16 near 0°, where it is flat). */
    prev = -1;
    for (int i = 0; i <= 9000; i++) {
        double R2 = rd_fresnel_dielectric(cos(deg(i / 100.0)), 1.0, 1.5, &c);
        cr_assert(R2 >= prev - 1e-15, "R(1 -> 1.5) falls at %.2f°: %.17g after %.17g", i / 100.0, R2, prev);
        prev = R2;
    }
}

Test(fresnel, index_one_reflects_nothing)
{
    /* Matched media: no boundary, R = 0 and the ray goes straight on. */
    for (int i = 0; i < 900; i++) {
        double th = deg(i / 10.0), cost = -1;
        double R = rd_fresnel_dielectric(cos(th), 1.0, 1.0, &cost);
        cr_assert(R >= 0 && R <= 1e-15, "ior 1 at %.1f°: R = %.17g, expected 0", i / 10.0, R);
        cr_assert(fabs(cost - cos(th)) <= 1e-9, "ior 1 at %.1f°: cos θt = %.17g, expected %.17g", i / 10.0, cost,
                  cos(th));
    }
    double R = rd_fresnel_dielectric(1.0, 1.7, 1.7, &(double){0});
    cr_assert(R == 0.0, "n1 = n2 = 1.7 at normal incidence: R = %.17g", R);
}

/* Near grazing with n1 = n2 there is still no boundary: R must stay 0. A
 * cos θt computed as sqrt(1 - η²(1 - cos²θi)) loses every digit here (the
 * 1 - cos² rounds to 1), which turns a matched interface into a mirror;
 * cos²θt = (1 - η²) + η²cos²θi has no such cancellation and gives R = 0
 * exactly at η = 1. */
Test(fresnel, index_one_reflects_nothing_near_grazing)
{
    double cs[] = {1e-4, 1e-6, 1e-8, 1e-9, 1e-12, 0.0};
    for (size_t i = 0; i < sizeof cs / sizeof *cs; i++) {
        double cost = -1;
        double R = rd_fresnel_dielectric(cs[i], 1.0, 1.0, &cost);
        cr_expect(R >= 0 && R <= 1e-12, "ior 1 at cos θi = %g: R = %.17g, expected 0", cs[i], R);
    }
}

Test(fresnel, cosine_outside_unit_range_is_clamped)
{
    double cost;
    /* Slightly above 1: treated as 1 (normal incidence). */
    double ups[] = {1 + DBL_EPSILON, 1 + 1e-12, 1.5, 1e300, INFINITY};
    for (size_t i = 0; i < sizeof ups / sizeof *ups; i++) {
        for (int dir = 0; dir < 2; dir++) {
            double n1 = dir ? 1.5 : 1.0, n2 = dir ? 1.0 : 1.5;
            double want = rd_fresnel_dielectric(1.0, n1, n2, &(double){0});
            cost = -1;
            double R = rd_fresnel_dielectric(ups[i], n1, n2, &cost);
            cr_assert(isfinite(R) && R >= 0 && R <= 1, "cosi = %g: R = %g", ups[i], R);
            cr_assert(R == want, "cosi = %g: R = %.17g, expected R(1) = %.17g", ups[i], R, want);
            cr_assert(isfinite(cost) && cost >= 0 && cost <= 1, "cosi = %g: cos θt = %g", ups[i], cost);
        }
    }
    /* Slightly below 0: treated as 0 (grazing). Into glass that is R = 1
     * (rs = -1, rp = 1); out of glass it is TIR. */
    double downs[] = {-DBL_MIN, -DBL_EPSILON, -1e-12, -0.5, -1e300, -INFINITY};
    for (size_t i = 0; i < sizeof downs / sizeof *downs; i++) {
        cost = -1;
        double R = rd_fresnel_dielectric(downs[i], 1.0, 1.5, &cost);
        cr_assert(isfinite(R) && R >= 0 && R <= 1, "cosi = %g: R = %g", downs[i], R);
        cr_assert(fabs(R - 1.0) <= 1e-15, "cosi = %g into glass: R = %.17g, expected R(0) = 1", downs[i], R);
        cr_assert(isfinite(cost) && cost >= 0 && cost <= 1);
        cost = -1;
        R = rd_fresnel_dielectric(downs[i], 1.5, 1.0, &cost);
        cr_assert(R == 1.0 && cost == 0.0, "cosi = %g out of glass: R = %.17g", downs[i], R);
    }
}
