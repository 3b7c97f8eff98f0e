/* Calibration of the grading thresholds (grading.md, "The defaults are
 * calibrated, not guessed"): a correct implementation in float must pass
 * every assignment, and each typical wrong one must fail every assignment
 * it touches.
 *
 * The reference of each case is rayd's own (rd_reference_get, no cache).
 * The students are tests/oracles/student_float.c: an independent single-precision
 * renderer written from shading.md that reads the scene through rayd's
 * parser, correct or with one sf_bug at a time.
 *
 * Correct students (their worst case sets the lower end of the gap):
 *   - "correct": t_min = 1e-3 for secondary rays, the tutorials' habit;
 *   - "correct_eps3e-4": t_min = 3e-4, small enough for a few float hit
 *     points to shadow themselves at the terminator (a handful of pixels):
 *     the sloppiest student that still counts as correct.
 * Printed, not asserted: "acne_eps1e-4" (t_min = 1e-4: a visible band of
 * shadow acne along every terminator, ~0.06-0.14 % of the pixels; the spec
 * rules self-intersection out, so it is a bug, just not one of the list).
 *
 * Which cases each bug touches (a bug that does not touch a case renders
 * it exactly like the correct student; the test checks that too):
 *   - no_max_cos: no assignment. Every point that a light is behind lies in
 *     that light's shadow: the spheres are closed (the shadow ray toward a
 *     light behind the tangent plane goes through the sphere itself) and
 *     every light is above the floor. So the extra case "diffuse+light_below"
 *     (diffuse.cfg with a light under the two-sided floor; rayd's image is
 *     unchanged by it, a student without max(.,0) whose shadow rays start
 *     on the surface with t_min darkens the floor; one who pushes the origin
 *     along N shadows the floor with itself and still passes: only shading
 *     normals that differ from the geometric ones, as on a smooth OBJ mesh,
 *     catch every such student).
 *   - reflect_sign, blinn_for_phong: the Phong lobe only: phong,
 *     textured_phong (and phong@gamma2.2).
 *   - shininess_half: every lobe with a shininess: phong, blinn_phong,
 *     textured_phong (and phong@gamma2.2). Not cook_torrance (roughness).
 *   - light_reversed, no_ambient, ambient_per_light: every case (each has
 *     lights, lit non-recursive surfaces with ambient, and >= 2 lights).
 *   - gamma_twice: no assignment (all have gamma 1, where it changes
 *     nothing), so the extra case "phong@gamma2.2" (phong.cfg, gamma 2.2).
 *
 * Margins: over the correct students the largest failed_fraction and hard
 * pixel count; over the touched wrong cells the smallest; the thresholds
 * must lie inside the gap with a margin on both sides, near its middle on a
 * log scale. */
#include <criterion/criterion.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "assignment.h"
#include "grade.h"
#include "oracles/student_float.h"
#include "rayd/render.h"
#include "support/load.h"
#include "support/scene_fixture.h"

#define CAL_DIR "scenes/assignments"

/* The thresholds this calibration recommends: {fail, fail_fraction,
 * hard_fail, hard_fail_pixels}. They equal rd_grade_thresholds_default()
 * today; once the defaults are meant to follow this test, replace the
 * initializer by rd_grade_thresholds_default(). -DCAL_THRESHOLDS=... tries
 * other candidates. */
#ifndef CAL_THRESHOLDS
#define CAL_THRESHOLDS (rd_grade_thresholds_default())
#endif

/* Margins the thresholds must keep: the failed-fraction threshold at least
 * this factor above the worst correct student and below the best wrong
 * one; and inside the middle half of the gap on a log scale. */
#define CAL_MIN_FACTOR 4.0

enum { CAL_NBUGS = SF_BUG_COUNT };

typedef struct {
    const char *name; /* assignment, or the extra case's name */
    const char *base; /* assignment it is built from */
    int extra;        /* 1: not an assignment (gamma 2.2, light below) */
    unsigned touched; /* sf_bug bits that change this case */
} cal_case;

#define ALL_AMBIENT_LIGHT (SF_BUG_LIGHT_REVERSED | SF_BUG_NO_AMBIENT | SF_BUG_AMBIENT_PER_LIGHT)
#define PHONG_LOBE (SF_BUG_REFLECT_SIGN | SF_BUG_BLINN_FOR_PHONG | SF_BUG_SHININESS_HALVED)

static const cal_case cal_cases[] = {
    {"diffuse", "diffuse", 0, ALL_AMBIENT_LIGHT},
    {"phong", "phong", 0, ALL_AMBIENT_LIGHT | PHONG_LOBE},
    {"blinn_phong", "blinn_phong", 0, ALL_AMBIENT_LIGHT | SF_BUG_SHININESS_HALVED},
    {"cook_torrance", "cook_torrance", 0, ALL_AMBIENT_LIGHT},
    {"perfect_specular", "perfect_specular", 0, ALL_AMBIENT_LIGHT},
    {"specular_refraction", "specular_refraction", 0, ALL_AMBIENT_LIGHT},
    {"textured_phong", "textured_phong", 0, ALL_AMBIENT_LIGHT | PHONG_LOBE},
    {"phong_gamma", "phong_gamma", 0, ALL_AMBIENT_LIGHT | PHONG_LOBE | SF_BUG_GAMMA_TWICE},
    {"phong@gamma2.2", "phong", 1, ALL_AMBIENT_LIGHT | PHONG_LOBE | SF_BUG_GAMMA_TWICE},
    {"diffuse+light_below", "diffuse", 1, ALL_AMBIENT_LIGHT | SF_BUG_NO_MAX_COS},
};
#define CAL_NCASES (sizeof cal_cases / sizeof cal_cases[0])

/* Loads a case: its scene with assets, its own thresholds (the .grade
 * file; the defaults for extra cases) and rayd's reference. */
static void cal_load(const cal_case *c, rd_scene *s, rd_grade_thresholds *own, uint8_t **ref, int *w, int *h)
{
    rd_assignment a;
    rd_error err = {0};
    cr_assert_eq(rd_assignment_load(CAL_DIR, c->base, &a, &err), RD_OK, "%s: %s", c->base, err.message);
    *own = c->extra ? rd_grade_thresholds_default() : a.thresholds;
    load_cfg(a.scene_path, s);
    if (strcmp(c->name, "phong@gamma2.2") == 0) {
        s->render.gamma = 2.2;
    } else if (strcmp(c->name, "diffuse+light_below") == 0) {
        add_point_light(s, v3(0, -3, 3), v3(0.6, 0.6, 0.6));
    }
    /* rayd's reference is its render, as grading makes it. */
    rd_render_options ro = {.threads = 2};
    rd_image img;
    rd_render_stats st;
    cr_assert_eq(rd_render(s, &ro, &img, &st, &err), RD_OK, "%s: %s", c->name, err.message);
    *w = img.width;
    *h = img.height;
    *ref = malloc((size_t)img.width * (size_t)img.height * 3);
    cr_assert(*ref);
    rd_image_to_rgb8(&img, s->render.gamma, *ref);
    rd_image_free(&img);
}

/* The students of one row of the table. */
typedef struct {
    const char *label;
    unsigned bugs;
    float eps;
    int role; /* 0 correct (asserted to pass), 1 wrong, 2 printed only */
} cal_student;

static size_t cal_students(cal_student *out)
{
    size_t n = 0;
    out[n++] = (cal_student){"correct", SF_CORRECT, SF_EPS_DEFAULT, 0};
    out[n++] = (cal_student){"correct_eps3e-4", SF_CORRECT, 3e-4f, 0};
    out[n++] = (cal_student){"acne_eps1e-4", SF_CORRECT, 1e-4f, 2};
    for (int b = 0; b < CAL_NBUGS; b++)
        out[n++] = (cal_student){sf_bug_name(1u << b), 1u << b, SF_EPS_DEFAULT, 1};
    return n;
}

static int cal_same(const rd_grade_thresholds *a, const rd_grade_thresholds *b)
{
    return a->fail == b->fail && a->fail_fraction == b->fail_fraction && a->hard_fail == b->hard_fail &&
           a->hard_fail_pixels == b->hard_fail_pixels;
}

/* Histogram of pixel differences (rd_pixel_diff). */
static void cal_hist(const uint8_t *a, const uint8_t *b, size_t npix, size_t hist[256])
{
    memset(hist, 0, 256 * sizeof hist[0]);
    for (size_t i = 0; i < npix; i++)
        hist[rd_pixel_diff(a + 3 * i, b + 3 * i)]++;
}

/* Pixels whose difference exceeds f. */
static size_t cal_above(const size_t hist[256], int f)
{
    size_t n = 0;
    for (int d = f + 1; d < 256; d++)
        n += hist[d];
    return n;
}

Test(grading_calibration, float_student_passes_wrong_ones_fail, .timeout = 300)
{
    const rd_grade_thresholds T = CAL_THRESHOLDS;
    const rd_grade_thresholds D = rd_grade_thresholds_default();
    cal_student st[3 + CAL_NBUGS];
    size_t nst = cal_students(st);

    double worst_correct_ff = 0, best_wrong_ff = INFINITY;
    size_t worst_correct_hard = 0, best_wrong_hard = (size_t)-1;
    char worst_correct_at[128] = "-", best_wrong_at[128] = "-";
    /* Per-pixel level: the smallest `fail` with which every correct student
     * passes the fraction rule (lo) and the largest with which every wrong
     * one still fails it (hi). */
    int fail_lo = 0, fail_hi = 256;
    size_t npix_min = (size_t)-1;

    printf("\nGrading calibration: thresholds under test fail=%d fail_fraction=%g hard_fail=%d "
           "hard_fail_pixels=%d\n",
           T.fail, T.fail_fraction, T.hard_fail, T.hard_fail_pixels);
    printf("%-21s %-18s %-7s %10s %7s %5s %4s %-4s %-5s\n", "case", "student", "touches", "failed_frac", "failed",
           "hard", "max", "pass", ".grade");
    fflush(stdout);

    for (size_t ci = 0; ci < CAL_NCASES; ci++) {
        const cal_case *c = &cal_cases[ci];
        rd_scene s;
        rd_grade_thresholds own;
        uint8_t *ref = NULL;
        int w = 0, h = 0;
        cal_load(c, &s, &own, &ref, &w, &h);
        size_t npix = (size_t)w * (size_t)h;
        npix_min = npix < npix_min ? npix : npix_min;
        /* A fraction test at T passes at most this many failed pixels. */
        size_t allowed = (size_t)floor(T.fail_fraction * (double)npix);

        for (size_t k = 0; k < nst; k++) {
            uint8_t *img = NULL;
            int iw = 0, ih = 0;
            cr_assert_eq(sf_render_eps(&s, st[k].bugs, st[k].eps, &img, &iw, &ih), 0, "%s", c->name);
            cr_assert(iw == w && ih == h, "%s: student image %dx%d, reference %dx%d", c->name, iw, ih, w, h);
            /* rd_grade_compare also computes SSIM, the slow part: once per
             * distinct set of thresholds. */
            rd_grade_result r, rd, ro;
            rd_grade_compare(ref, img, w, h, &T, &r);
            if (cal_same(&D, &T))
                rd = r;
            else
                rd_grade_compare(ref, img, w, h, &D, &rd);
            if (cal_same(&own, &T))
                ro = r;
            else if (cal_same(&own, &D))
                ro = rd;
            else
                rd_grade_compare(ref, img, w, h, &own, &ro);
            size_t hist[256];
            cal_hist(ref, img, npix, hist);

            int touched = st[k].role == 1 && (c->touched & st[k].bugs);
            const char *tag = st[k].role == 0 ? "correct" : st[k].role == 2 ? "info" : touched ? "yes" : "no";
            printf("%-21s %-18s %-7s %10.6f %7zu %5zu %4d %-4s %-5s\n", c->name, st[k].label, tag, r.failed_fraction,
                   r.failed_pixels, r.hard_pixels, r.max_abs, r.pass ? "PASS" : "FAIL", ro.pass ? "PASS" : "FAIL");
            fflush(stdout);

            if (st[k].role == 0) {
                cr_expect(r.pass, "%s/%s fails the calibrated thresholds (%zu failed, %zu hard)", c->name, st[k].label,
                          r.failed_pixels, r.hard_pixels);
                cr_expect(rd.pass, "%s/%s fails rd_grade_thresholds_default()", c->name, st[k].label);
                cr_expect(ro.pass, "%s/%s fails its own .grade thresholds", c->name, st[k].label);
                if (r.failed_fraction >= worst_correct_ff) {
                    worst_correct_ff = r.failed_fraction;
                    snprintf(worst_correct_at, sizeof worst_correct_at, "%s/%s", c->name, st[k].label);
                }
                if (r.hard_pixels > worst_correct_hard)
                    worst_correct_hard = r.hard_pixels;
                /* Smallest fail level at which the fraction rule passes. */
                int lo = 0;
                while (lo < 255 && cal_above(hist, lo) > allowed)
                    lo++;
                fail_lo = lo > fail_lo ? lo : fail_lo;
            } else if (st[k].role == 1 && touched) {
                cr_expect(!r.pass, "%s/%s passes the calibrated thresholds (%zu failed, max %d)", c->name, st[k].label,
                          r.failed_pixels, r.max_abs);
                cr_expect(!rd.pass, "%s/%s passes rd_grade_thresholds_default()", c->name, st[k].label);
                cr_expect(!ro.pass, "%s/%s passes its own .grade thresholds", c->name, st[k].label);
                if (r.failed_fraction < best_wrong_ff) {
                    best_wrong_ff = r.failed_fraction;
                    snprintf(best_wrong_at, sizeof best_wrong_at, "%s/%s", c->name, st[k].label);
                }
                if (r.hard_pixels < best_wrong_hard)
                    best_wrong_hard = r.hard_pixels;
                /* Largest fail level at which the fraction rule still fails. */
                int hi = -1;
                while (hi + 1 < 255 && cal_above(hist, hi + 1) > allowed)
                    hi++;
                fail_hi = hi < fail_hi ? hi : fail_hi;
            } else if (st[k].role == 1) {
                /* An untouched case renders like the correct student. */
                cr_expect(r.pass && r.max_abs <= 2, "%s/%s: classified untouched but differs (max %d, %zu failed)",
                          c->name, st[k].label, r.max_abs, r.failed_pixels);
            }
            free(img);
        }
        free(ref);
        rd_scene_free(&s);
    }

    /* The gap, on a log scale. A failed fraction of 0 is measured as one
     * pixel: the smallest fraction the metric can tell from zero. */
    double floor_ff = 1.0 / (double)npix_min;
    double lo_ff = worst_correct_ff > floor_ff ? worst_correct_ff : floor_ff;
    double mid_ff = sqrt(lo_ff * best_wrong_ff);
    double gap_decades = log10(best_wrong_ff / lo_ff);
    double pos = log10(T.fail_fraction / lo_ff) / gap_decades; /* 0 = correct end, 1 = wrong end */
    double mid_fail = sqrt((fail_lo > 1 ? fail_lo : 1) * (double)fail_hi);
    printf("\nfailed_fraction: largest over correct students %.6f (%s), smallest over wrong ones %.6f (%s)\n",
           worst_correct_ff, worst_correct_at, best_wrong_ff, best_wrong_at);
    printf("  gap %.2f decades from %.6f; log-midpoint %.6f; fail_fraction %g sits at %.0f%% of the gap, "
           "%.1fx above the correct end and %.1fx below the wrong end\n",
           gap_decades, lo_ff, mid_ff, T.fail_fraction, 100 * pos, T.fail_fraction / lo_ff,
           best_wrong_ff / T.fail_fraction);
    printf("hard pixels (> %d): largest over correct students %zu, smallest over wrong ones %zu "
           "(hard_fail_pixels %d: a guard for silhouettes, not what rejects the wrong students)\n",
           T.hard_fail, worst_correct_hard, best_wrong_hard, T.hard_fail_pixels);
    printf("fail level: correct students need fail >= %d, every wrong one is still rejected for fail <= %d; "
           "log-midpoint %.1f; fail = %d\n\n",
           fail_lo, fail_hi, mid_fail, T.fail);
    fflush(stdout);

    /* Separation with margin. */
    cr_expect(worst_correct_ff * CAL_MIN_FACTOR <= T.fail_fraction,
              "fail_fraction %g is within %gx of the worst correct student (%g at %s)", T.fail_fraction, CAL_MIN_FACTOR,
              worst_correct_ff, worst_correct_at);
    cr_expect(T.fail_fraction * CAL_MIN_FACTOR <= best_wrong_ff,
              "fail_fraction %g is within %gx of the best wrong student (%g at %s)", T.fail_fraction, CAL_MIN_FACTOR,
              best_wrong_ff, best_wrong_at);
    cr_expect(pos >= 0.25 && pos <= 0.75, "fail_fraction %g is outside the middle half of the gap (at %.0f%%)",
              T.fail_fraction, 100 * pos);
    cr_expect(worst_correct_hard <= (size_t)T.hard_fail_pixels, "a correct student has %zu hard pixels",
              worst_correct_hard);
    cr_expect(fail_lo <= T.fail && T.fail < fail_hi, "fail %d outside [%d, %d)", T.fail, fail_lo, fail_hi);
}
