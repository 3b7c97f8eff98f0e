/* api/grading/code_{cases,check,lobe}: the configurations, the tolerance a
 * float student passes, each usual mistake named, the report's JSON and
 * the lobe plot. The mistakes are the ones of tests/codegrade/students,
 * written again here in C. */
#include <criterion/criterion.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "code_cases.h"
#include "code_check.h"
#include "code_lobe.h"
#include "rayd/shading.h"

typedef rd_rgb (*student_fn)(const rd_code_case *c);

static rd_code_case *cases_in(rd_material_type t, rd_shininess_domain d, size_t *n)
{
    rd_code_case *c = NULL;
    rd_error err = {0};
    cr_assert_eq(rd_code_cases(t, d, &c, n, &err), RD_OK, "%s", err.message);
    cr_assert_gt(*n, 2800, "several thousand configurations (%zu)", *n);
    return c;
}

/* Any positive shininess: the widest domain, the most mistakes seen. */
static rd_code_case *cases_of(rd_material_type t, size_t *n) { return cases_in(t, RD_SHININESS_REAL, n); }

/* The student's values for every configuration of the domain, and the report. */
static rd_code_report grade_in(rd_material_type t, rd_shininess_domain d, student_fn f, rd_code_case **cases,
                               rd_code_value **values, size_t *n)
{
    *cases = cases_in(t, d, n);
    *values = calloc(*n, sizeof **values);
    for (size_t i = 0; i < *n; i++)
        (*values)[i] = (rd_code_value){f(&(*cases)[i]), RD_CODE_RETURNED};
    rd_code_report r;
    rd_code_check(*cases, *values, *n, &r);
    return r;
}

static rd_code_report grade(rd_material_type t, student_fn f, rd_code_case **cases, rd_code_value **values, size_t *n)
{
    return grade_in(t, RD_SHININESS_REAL, f, cases, values, n);
}

static const char *first_cause(rd_material_type t, student_fn f)
{
    rd_code_case *c;
    rd_code_value *v;
    size_t n;
    rd_code_report r = grade(t, f, &c, &v, &n);
    free(c);
    free(v);
    cr_assert_eq(r.pass, 0, "the mistake passes");
    cr_assert_gt(r.ncauses, 0);
    cr_assert_gt(strlen(r.causes[0].words), 30);
    return r.causes[0].cause;
}

/* ---- students ------------------------------------------------------------ */

static rd_rgb reference(const rd_code_case *c) { return rd_reflected_light(&c->m, c->n, c->L, c->V); }

static double cos_in(const rd_code_case *c) { return -v3_dot(c->n, c->L); }
static rd_vec3 mirror(const rd_code_case *c) { return v3_reflect(c->L, c->n); }
static rd_rgb lit(const rd_code_case *c, double d, double s)
{
    return v3_add(v3_scale(c->m.kd, d), v3_scale(c->m.ks, s));
}

/* The course's formulas in float, as a student with float locals writes them. */
static rd_rgb float_student(const rd_code_case *c)
{
    float n[3] = {(float)c->n.x, (float)c->n.y, (float)c->n.z}, l[3] = {(float)c->L.x, (float)c->L.y, (float)c->L.z},
          v[3] = {(float)c->V.x, (float)c->V.y, (float)c->V.z};
    float nl = n[0] * l[0] + n[1] * l[1] + n[2] * l[2], ca = -nl;
    if (ca <= 0)
        return v3(0, 0, 0);
    float spec = 0;
    if (c->m.type == RD_MAT_PHONG) {
        float r[3] = {l[0] - 2 * nl * n[0], l[1] - 2 * nl * n[1], l[2] - 2 * nl * n[2]};
        spec = powf(fmaxf(r[0] * v[0] + r[1] * v[1] + r[2] * v[2], 0), (float)c->m.shininess);
    } else if (c->m.type == RD_MAT_BLINN_PHONG) {
        float h[3] = {v[0] - l[0], v[1] - l[1], v[2] - l[2]};
        float len = sqrtf(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
        float nh = len > 0 ? (n[0] * h[0] + n[1] * h[1] + n[2] * h[2]) / len : 0;
        spec = powf(fmaxf(nh, 0), (float)c->m.shininess);
    }
    float kd[3] = {(float)c->m.kd.x, (float)c->m.kd.y, (float)c->m.kd.z};
    float ks[3] = {(float)c->m.ks.x, (float)c->m.ks.y, (float)c->m.ks.z};
    int d = c->m.type == RD_MAT_DIFFUSE;
    return v3(kd[0] * ca + (d ? 0 : ks[0] * spec), kd[1] * ca + (d ? 0 : ks[1] * spec),
              kd[2] * ca + (d ? 0 : ks[2] * spec));
}

static rd_rgb d_missing_max(const rd_code_case *c) { return v3_scale(c->m.kd, cos_in(c)); }
static rd_rgb d_light_reversed(const rd_code_case *c) { return v3_scale(c->m.kd, fmax(v3_dot(c->n, c->L), 0)); }
static rd_rgb d_ambient(const rd_code_case *c) { return v3_add(reference(c), c->m.ambient); }
static rd_rgb d_pi(const rd_code_case *c) { return v3_scale(reference(c), 1 / M_PI); }

static rd_rgb p_missing_max(const rd_code_case *c)
{
    return lit(c, cos_in(c), pow(fmax(v3_dot(mirror(c), c->V), 0), c->m.shininess));
}
static rd_rgb p_reflect_sign(const rd_code_case *c)
{
    return cos_in(c) <= 0 ? v3(0, 0, 0) : lit(c, cos_in(c), pow(fmax(-v3_dot(mirror(c), c->V), 0), c->m.shininess));
}
static rd_rgb p_blinn(const rd_code_case *c)
{
    rd_vec3 h = v3_normalize(v3_sub(c->V, c->L));
    return cos_in(c) <= 0 ? v3(0, 0, 0) : lit(c, cos_in(c), pow(fmax(v3_dot(c->n, h), 0), c->m.shininess));
}
static rd_rgb p_half(const rd_code_case *c)
{
    return cos_in(c) <= 0 ? v3(0, 0, 0) : lit(c, cos_in(c), pow(fmax(v3_dot(mirror(c), c->V), 0), c->m.shininess / 2));
}
static rd_rgb p_no_clamp(const rd_code_case *c)
{
    return cos_in(c) <= 0 ? v3(0, 0, 0) : lit(c, cos_in(c), pow(v3_dot(mirror(c), c->V), c->m.shininess));
}
static rd_rgb p_kd_missing(const rd_code_case *c)
{
    return cos_in(c) <= 0 ? v3(0, 0, 0) : lit(c, 0, pow(fmax(v3_dot(mirror(c), c->V), 0), c->m.shininess));
}
static rd_rgb p_ks_missing(const rd_code_case *c) { return cos_in(c) <= 0 ? v3(0, 0, 0) : lit(c, cos_in(c), 0); }

/* No clamp at all: -N·L and R·V as they come. */
static rd_rgb p_no_max(const rd_code_case *c)
{
    return lit(c, cos_in(c), pow(v3_dot(mirror(c), c->V), c->m.shininess));
}

/* for (int i = 0; i < shininess; i++) s *= cosGamma; right for whole n only. */
static rd_rgb p_loop_power(const rd_code_case *c)
{
    if (cos_in(c) <= 0)
        return v3(0, 0, 0);
    double g = fmax(v3_dot(mirror(c), c->V), 0), s = 1;
    for (int i = 0; i < c->m.shininess; i++)
        s *= g;
    return lit(c, cos_in(c), s);
}

/* H = normalize(L + V): 0/0 when the eye looks back at the light. */
static rd_rgb p_nan(const rd_code_case *c)
{
    rd_vec3 s = v3_add(c->L, c->V);
    rd_vec3 h = v3_scale(s, 1 / v3_len(s));
    double nh = v3_dot(c->n, h);
    nh = nh < 0 ? 0 : nh; /* std::max(nh, 0.0) keeps a NaN, as C's fmax would not */
    return lit(c, fmax(cos_in(c), 0), pow(nh, c->m.shininess));
}

/* ---- tests --------------------------------------------------------------- */

static const rd_material_type types[] = {RD_MAT_DIFFUSE, RD_MAT_PHONG, RD_MAT_BLINN_PHONG, RD_MAT_COOK_TORRANCE};

Test(code_check, rayds_own_values_pass_everywhere)
{
    for (size_t k = 0; k < 4; k++) {
        rd_code_case *c;
        rd_code_value *v;
        size_t n;
        rd_code_report r = grade(types[k], reference, &c, &v, &n);
        cr_assert(r.pass && r.failed == 0 && r.ncauses == 0, "type %zu: %zu failed", k, r.failed);
        free(c);
        free(v);
    }
}

/* A float student passes; and how far it is, which the tolerance is for. */
Test(code_check, a_float_student_passes)
{
    for (size_t k = 0; k < 3; k++) {
        rd_code_case *c;
        rd_code_value *v;
        size_t n;
        rd_code_report r = grade(types[k], float_student, &c, &v, &n);
        double worst = 0;
        for (size_t i = 0; i < n; i++) {
            if (c[i].group == RD_CODE_STIFF) /* cos^n: the tolerance's slack covers it */
                continue;
            rd_rgb e = reference(&c[i]);
            double d[3] = {fabs(v[i].got.x - e.x), fabs(v[i].got.y - e.y), fabs(v[i].got.z - e.z)};
            double m[3] = {fabs(e.x), fabs(e.y), fabs(e.z)};
            for (int j = 0; j < 3; j++)
                if (m[j] > 1e-3)
                    worst = fmax(worst, d[j] / m[j]);
        }
        printf("code_check: a float student of type %zu is off by %.2g relative at most (stiff group aside)\n", k,
               worst);
        cr_assert(worst < RD_CODE_REL_TOL / 2, "float is off by %g: the tolerance leaves too little room", worst);
        cr_assert(r.pass, "type %zu: a float student fails %zu (first cause %s)", k, r.failed,
                  r.ncauses ? r.causes[0].cause : "-");
        free(c);
        free(v);
    }
}

Test(code_check, each_usual_mistake_is_named)
{
    const struct {
        rd_material_type t;
        student_fn f;
        const char *cause;
    } m[] = {
        {RD_MAT_DIFFUSE, d_missing_max, "missing_max"},      {RD_MAT_DIFFUSE, d_light_reversed, "light_reversed"},
        {RD_MAT_DIFFUSE, d_ambient, "ambient_inside"},       {RD_MAT_DIFFUSE, d_pi, "divided_by_pi"},
        {RD_MAT_PHONG, p_missing_max, "missing_max"},        {RD_MAT_PHONG, p_reflect_sign, "reflect_sign"},
        {RD_MAT_PHONG, p_blinn, "blinn_not_phong"},          {RD_MAT_PHONG, p_half, "shininess_wrong"},
        {RD_MAT_PHONG, p_no_clamp, "no_specular_clamp"},     {RD_MAT_PHONG, p_kd_missing, "kd_missing"},
        {RD_MAT_PHONG, p_nan, "half_vector_sign"},           {RD_MAT_PHONG, p_no_max, "missing_max"},
        {RD_MAT_PHONG, p_loop_power, "integer_power"},       {RD_MAT_PHONG, d_ambient, "ambient_inside"},
        {RD_MAT_COOK_TORRANCE, d_ambient, "ambient_inside"}, {RD_MAT_BLINN_PHONG, d_pi, "divided_by_pi"},
        {RD_MAT_PHONG, p_ks_missing, "ks_missing"},
    };
    for (size_t i = 0; i < sizeof m / sizeof *m; i++) {
        const char *got = first_cause(m[i].t, m[i].f);
        cr_expect_str_eq(got, m[i].cause, "mistake %zu is named %s, not %s", i, got, m[i].cause);
    }
}

/* H = normalize(L + V): NaN where the eye looks back at the light, and the
 * wrong half vector everywhere else; both are named, the half vector the
 * student wrote first, its NaN after. */
Test(code_check, a_half_vector_of_the_wrong_sign_is_named_before_its_nan)
{
    rd_code_case *c;
    rd_code_value *v;
    size_t n;
    rd_code_report r = grade(RD_MAT_PHONG, p_nan, &c, &v, &n);
    cr_assert_geq(r.ncauses, 2);
    cr_assert_str_eq(r.causes[0].cause, "half_vector_sign");
    cr_assert_str_eq(r.causes[1].cause, "not_finite");
    free(c);
    free(v);
}

/* No max anywhere gives NaN at a fractional n (pow of a negative cosine):
 * the causes speak of the clamps the student left out, never of a half
 * vector the student does not have. */
Test(code_check, no_max_anywhere_is_named_by_its_clamps_first)
{
    rd_code_case *c;
    rd_code_value *v;
    size_t n;
    rd_code_report r = grade(RD_MAT_PHONG, p_no_max, &c, &v, &n);
    cr_assert_gt(r.not_finite, 0, "fractional shininess makes NaN here");
    cr_assert_str_eq(r.causes[0].cause, "missing_max");
    for (int i = 0; i < r.ncauses; i++) {
        cr_expect_null(strstr(r.causes[i].words, "half vector"), "%s speaks of a half vector", r.causes[i].cause);
        cr_expect_str_neq(r.causes[i].cause, "wrong_value", "%zu values unexplained", r.causes[i].count);
    }
    free(c);
    free(v);
}

/* The course's n is natural: a loop power is right there, and where an
 * assignment allows any n its failures have a name of their own. */
Test(code_check, a_loop_power_passes_natural_shininess_and_is_named_outside_it)
{
    rd_code_case *c;
    rd_code_value *v;
    size_t n;
    rd_code_report r = grade_in(RD_MAT_PHONG, RD_SHININESS_NATURAL, p_loop_power, &c, &v, &n);
    for (size_t i = 0; i < n; i++)
        cr_assert(c[i].m.shininess >= 1 && c[i].m.shininess == floor(c[i].m.shininess), "case %zu: shininess %g", i,
                  c[i].m.shininess);
    cr_assert(r.pass, "%zu fail (first cause %s)", r.failed, r.ncauses ? r.causes[0].cause : "-");
    free(c);
    free(v);
    r = grade(RD_MAT_PHONG, p_loop_power, &c, &v, &n);
    cr_assert_eq(r.ncauses, 1, "one cause (first %s)", r.causes[0].cause);
    cr_assert_str_eq(r.causes[0].cause, "integer_power");
    cr_assert_eq(r.causes[0].count, r.failed);
    cr_assert_neq(c[r.causes[0].example].m.shininess, floor(c[r.causes[0].example].m.shininess));
    free(c);
    free(v);
}

Test(code_check, no_configurations_pass_and_name_nothing)
{
    rd_code_report r;
    rd_code_check(NULL, NULL, 0, &r);
    cr_assert(r.pass && r.ncauses == 0 && r.configurations == 0);
}

Test(code_check, crashes_time_outs_and_calls_not_run_are_counted_and_named_first)
{
    size_t n;
    rd_code_case *c = cases_of(RD_MAT_PHONG, &n);
    rd_code_value *v = calloc(n, sizeof *v);
    for (size_t i = 0; i < n; i++)
        v[i] = (rd_code_value){reference(&c[i]), i < 3    ? RD_CODE_CRASHED
                                                 : i == 3 ? RD_CODE_TIMED_OUT
                                                 : i < 10 ? RD_CODE_NOT_RUN
                                                          : RD_CODE_RETURNED};
    v[20].got.y = NAN;
    rd_code_report r;
    rd_code_check(c, v, n, &r);
    cr_assert_eq(r.pass, 0);
    cr_assert_eq(r.failed, 11);
    cr_assert_eq(r.crashed, 3);
    cr_assert_eq(r.timed_out, 1);
    cr_assert_eq(r.not_run, 6);
    cr_assert_eq(r.not_finite, 1);
    cr_assert_str_eq(r.causes[0].cause, "crashed");
    cr_assert_eq(r.causes[0].count, 3);
    cr_assert_str_eq(r.causes[1].cause, "timed_out");
    cr_assert_str_eq(r.causes[2].cause, "not_run");
    cr_assert_eq(r.causes[2].count, 6);
    cr_assert_str_eq(r.causes[3].cause, "not_finite");
    cr_assert_eq(r.causes[3].example, 20);
    cJSON *j = rd_code_report_json(&r, c, v);
    cr_assert_not_null(j);
    char *text = cJSON_PrintUnformatted(j);
    cr_assert_null(strstr(text, "nan"), "NaN is not JSON: %s", text);
    cJSON *causes = cJSON_GetObjectItem(j, "causes");
    cr_assert_eq(cJSON_GetArraySize(causes), r.ncauses);
    cJSON *ex = cJSON_GetObjectItem(cJSON_GetArrayItem(causes, 3), "example");
    cr_assert(cJSON_IsNull(cJSON_GetArrayItem(cJSON_GetObjectItem(ex, "got"), 1)), "the NaN channel is null");
    cr_assert_not_null(cJSON_GetObjectItem(ex, "expected"));
    cr_assert_eq(cJSON_GetObjectItem(j, "crashed")->valuedouble, 3);
    cr_assert_eq(cJSON_GetObjectItem(cJSON_GetObjectItem(cJSON_GetObjectItem(j, "groups"), "general"), "configurations")
                     ->valuedouble,
                 1500);
    free(text);
    cJSON_Delete(j);
    free(c);
    free(v);
}

Test(code_check, the_configurations_are_fixed_unit_and_grouped)
{
    size_t n1, n2;
    rd_code_case *a = cases_of(RD_MAT_PHONG, &n1), *b = cases_of(RD_MAT_PHONG, &n2);
    cr_assert_eq(n1, n2);
    for (size_t i = 0; i < n1; i++)
        cr_assert(v3_eq(a[i].n, b[i].n) && v3_eq(a[i].L, b[i].L) && v3_eq(a[i].V, b[i].V) && a[i].group == b[i].group &&
                      v3_eq(a[i].m.kd, b[i].m.kd) && a[i].m.shininess == b[i].m.shininess,
                  "two calls differ at %zu", i);
    size_t groups[RD_CODE_GROUPS] = {0};
    for (size_t i = 0; i < n1; i++) {
        const rd_code_case *c = &a[i];
        cr_assert_float_eq(v3_len(c->n), 1, 1e-12);
        cr_assert_float_eq(v3_len(c->L), 1, 1e-12);
        cr_assert_float_eq(v3_len(c->V), 1, 1e-12);
        cr_assert_gt(v3_dot(c->V, c->n), 0, "case %zu: the eye is behind the surface", i);
        cr_assert(c->m.ambient.x > 0, "ambient is set, so that adding it shows");
        if (c->group == RD_CODE_BACK_LIT)
            cr_assert_lt(cos_in(c), 0);
        else
            cr_assert_gt(cos_in(c), 0, "case %zu of %s", i, rd_code_group_name(c->group));
        groups[c->group]++;
    }
    for (int g = 0; g < RD_CODE_GROUPS; g++)
        cr_assert_gt(groups[g], 0, "group %s is empty", rd_code_group_name((rd_code_group)g));
    free(a);
    free(b);
    rd_code_case *none = NULL;
    size_t nn = 1;
    rd_error err = {0};
    cr_assert_eq(rd_code_cases(RD_MAT_PERFECT_SPECULAR, RD_SHININESS_REAL, &none, &nn, &err), RD_ERR_UNSUPPORTED);
    cr_assert(none == NULL && nn == 0);
}

Test(code_check, the_lobe_plot_has_both_curves_and_no_nan)
{
    rd_code_case *c;
    rd_code_value *v;
    size_t n;
    grade(RD_MAT_PHONG, p_nan, &c, &v, &n);
    v[n - 1].got.x = INFINITY; /* the last lobe point */
    char *svg = rd_code_lobe_svg(c, v, n);
    cr_assert_not_null(svg);
    cr_assert_eq(strncmp(svg, "<svg ", 5), 0);
    cr_assert_not_null(strstr(svg, "</svg>\n"));
    size_t paths = 0;
    for (const char *p = strstr(svg, "stroke-width=\"2\""); p; p = strstr(p + 1, "stroke-width=\"2\""))
        paths++;
    cr_assert_geq(paths, 2, "two curves");
    /* every coordinate is a number: no nan, no inf */
    for (const char *d = strstr(svg, " d=\""); d; d = strstr(d + 1, " d=\"")) {
        size_t len = strcspn(d + 4, "\"");
        cr_assert_eq(strspn(d + 4, "MLAV H0123456789.-"), len, "a path has more than numbers: %.*s", (int)len, d + 4);
    }
    cr_assert_null(strstr(svg, "<script"));
    free(svg);
    cr_assert_null(rd_code_lobe_svg(c, v, 10), "the first ten configurations are not the lobe's");
    free(c);
    free(v);
}
