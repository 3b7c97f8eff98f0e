/* The tolerance: a student who computes in float rather than double must
 * pass. float rounds each operation by 6e-8; a cosine from float vectors
 * is off by a few 1e-7. Values then are off by far less than
 * RD_CODE_REL_TOL = 1e-3 relative (tests/unit/api/test_code_check.c
 * measures 3.2e-5 at most outside the stiff group); RD_CODE_ABS_TOL =
 * 2e-5 covers values that are nearly 0 (grazing light, a lobe's tail). A
 * highlight cos^n multiplies the cosine's error by n, which at the stiff
 * shininess (up to 1e6) is no longer small: there the tolerance adds what
 * the reference itself does when its highlight cosine moves by
 * RD_CODE_COS_SLACK, a few float steps. Every mistake of
 * tests/codegrade/students is off by far more than all that somewhere:
 * ambient adds 0.03, 1/pi takes two thirds, half the exponent doubles a
 * highlight's width. */
#include "code_check.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rayd/shading.h"

#define RD_CODE_COS_SLACK 4e-7

static rd_rgb expected(const rd_code_case *c) { return rd_reflected_light(&c->m, c->n, c->L, c->V); }

static double incidence(const rd_code_case *c) { return -v3_dot(c->n, c->L); }

/* The highlight's cosine of the case's model: R.V (Phong) or N.H (Blinn). */
static double highlight_cos(const rd_code_case *c, int sign)
{
    if (c->m.type == RD_MAT_BLINN_PHONG)
        return v3_dot(c->n, v3_normalize(v3_sub(c->V, c->L)));
    return sign * v3_dot(v3_reflect(c->L, c->n), c->V);
}

/* How much cos^n moves when cos moves by RD_CODE_COS_SLACK (0 for the
 * types without a cos^n highlight). */
static double slack(const rd_code_case *c)
{
    if ((c->m.type != RD_MAT_PHONG && c->m.type != RD_MAT_BLINN_PHONG) || incidence(c) <= 0)
        return 0;
    double k = highlight_cos(c, 1);
    if (!(k > 0))
        return 0;
    return pow(fmin(k + RD_CODE_COS_SLACK, 1), c->m.shininess) - pow(fmax(k - RD_CODE_COS_SLACK, 0), c->m.shininess);
}

static int channel_ok(double got, double want, double spec_slack)
{
    return isfinite(got) && fabs(got - want) <= RD_CODE_ABS_TOL + RD_CODE_REL_TOL * fabs(want) + spec_slack;
}

int rd_code_value_ok(const rd_code_case *c, const rd_code_value *v)
{
    rd_rgb e = expected(c);
    double s = slack(c);
    return v->status == RD_CODE_RETURNED && channel_ok(v->got.x, e.x, s * c->m.ks.x) &&
           channel_ok(v->got.y, e.y, s * c->m.ks.y) && channel_ok(v->got.z, e.z, s * c->m.ks.z);
}

/* ---- the usual mistakes, each as the formula it computes ---------------- */

static rd_rgb lit(const rd_code_case *c, double diffuse, double spec)
{
    return v3_add(v3_scale(c->m.kd, diffuse), v3_scale(c->m.ks, spec));
}

static rd_rgb v_missing_max(const rd_code_case *c)
{
    if (c->m.type == RD_MAT_DIFFUSE)
        return v3_scale(c->m.kd, incidence(c));
    return lit(c, incidence(c), pow(fmax(highlight_cos(c, 1), 0), c->m.shininess));
}

static rd_rgb v_back_lit(const rd_code_case *c)
{
    if (incidence(c) > 0)
        return expected(c);
    return lit(c, 0, pow(fmax(highlight_cos(c, 1), 0), c->m.shininess));
}

static rd_rgb v_no_spec_clamp(const rd_code_case *c)
{
    if (incidence(c) <= 0)
        return v3(0, 0, 0);
    return lit(c, incidence(c), pow(highlight_cos(c, 1), c->m.shininess));
}

static rd_rgb v_reflect_sign(const rd_code_case *c)
{
    if (incidence(c) <= 0)
        return v3(0, 0, 0);
    return lit(c, incidence(c), pow(fmax(highlight_cos(c, -1), 0), c->m.shininess));
}

/* H = normalize(L + V), as if incomingDir pointed to the light, with no
 * early return. Where L + V is 0 this is finite and the student's NaN is
 * not: that stays "not_finite". */
static rd_rgb v_half_sum(const rd_code_case *c)
{
    double nh = v3_dot(c->n, v3_normalize(v3_add(c->L, c->V)));
    return lit(c, fmax(incidence(c), 0), pow(fmax(nh, 0), c->m.shininess));
}

static rd_rgb with(const rd_code_case *c, rd_material m) { return rd_reflected_light(&m, c->n, c->L, c->V); }

/* Neither clamp: the diffuse cosine and the highlight's both as they come. */
static rd_rgb v_no_max(const rd_code_case *c) { return lit(c, incidence(c), pow(highlight_cos(c, 1), c->m.shininess)); }

/* A power that is right for whole n only: s *= cos in a loop of i < n
 * (ceil) or of (int)n (floor) steps. */
static rd_rgb whole_power(const rd_code_case *c, double (*whole)(double))
{
    rd_material m = c->m;
    m.shininess = whole(m.shininess);
    return with(c, m);
}
static rd_rgb v_power_ceil(const rd_code_case *c) { return whole_power(c, ceil); }
static rd_rgb v_power_floor(const rd_code_case *c) { return whole_power(c, floor); }

static rd_rgb v_light_reversed(const rd_code_case *c) { return rd_reflected_light(&c->m, c->n, v3_neg(c->L), c->V); }
static rd_rgb v_ambient(const rd_code_case *c) { return v3_add(expected(c), c->m.ambient); }
static rd_rgb v_pi(const rd_code_case *c) { return v3_scale(expected(c), 1 / M_PI); }

static rd_rgb v_other_model(const rd_code_case *c)
{
    rd_material m = c->m;
    m.type = m.type == RD_MAT_PHONG ? RD_MAT_BLINN_PHONG : RD_MAT_PHONG;
    return with(c, m);
}

static rd_rgb v_half_exponent(const rd_code_case *c)
{
    rd_material m = c->m;
    m.shininess *= 0.5;
    return with(c, m);
}

static rd_rgb v_double_exponent(const rd_code_case *c)
{
    rd_material m = c->m;
    m.shininess *= 2;
    return with(c, m);
}

static rd_rgb v_no_kd(const rd_code_case *c)
{
    rd_material m = c->m;
    m.kd = v3(0, 0, 0);
    return with(c, m);
}

static rd_rgb v_no_ks(const rd_code_case *c)
{
    rd_material m = c->m;
    m.ks = v3(0, 0, 0);
    return with(c, m);
}

enum { DIF = 1, PHO = 2, BLI = 4, COO = 8, LOBES = PHO | BLI, ALL = DIF | PHO | BLI | COO };

typedef struct {
    const char *cause, *words;
    rd_rgb (*formula)(const rd_code_case *c);
    int types;
} mistake;

static const mistake mistakes[] = {
    {"light_reversed",
     "incomingDir points from the light to the surface, not toward the light: the cosine is -N·L, and the mirror "
     "direction is reflect(incomingDir, N). Yours is lit from behind and dark in front.",
     v_light_reversed, ALL},
    {"missing_max",
     "Light from behind the surface gives negative light: clamp the cosine, max(-N·L, 0), and return black when the "
     "light is behind the surface.",
     v_missing_max, DIF | LOBES},
    {"missing_max",
     "Neither cosine is clamped: light from behind the surface gives negative light, and a negative highlight cosine "
     "a negative or NaN highlight. Return black when -N·L <= 0, and use pow(max(cos, 0), shininess).",
     v_no_max, LOBES},
    {"back_lit_not_black",
     "With the light behind the surface the result must be black, but yours keeps a highlight: return vec3(0) when "
     "-N·L <= 0, before the specular term.",
     v_back_lit, LOBES},
    {"ambient_inside",
     "The result includes the ambient term. calcReflectedLight returns only the light reflected from the light; the "
     "tracer adds ambient itself (equation (8)).",
     v_ambient, ALL},
    {"divided_by_pi", "It is divided by pi: the course's Lambert term is k_d cos(alpha), without 1/pi.", v_pi, ALL},
    {"reflect_sign",
     "The mirror direction has the wrong sign: R = reflect(incomingDir, N) = L - 2(L·N)N with L = incomingDir. Yours "
     "points the other way, so the highlight is where it should not be.",
     v_reflect_sign, PHO},
    {"blinn_not_phong",
     "That is Blinn's half-vector highlight (N·H). This assignment's Phong uses max(R·V, 0)^n with R the mirror "
     "direction of the light.",
     v_other_model, PHO},
    {"phong_not_blinn",
     "That is Phong's R·V highlight. Blinn-Phong uses max(N·H, 0)^n with H = normalize(outgoingDir - incomingDir).",
     v_other_model, BLI},
    {"half_vector_sign",
     "The highlight uses the half vector normalize(incomingDir + outgoingDir): that is not Phong's highlight, and it "
     "is 0/0 when the eye looks straight back at the light. Phong's is max(R·V, 0)^n with R = reflect(incomingDir, "
     "N).",
     v_half_sum, PHO},
    {"half_vector_sign",
     "The half vector has the wrong sign: incomingDir points from the light to the surface, so H = "
     "normalize(outgoingDir - incomingDir); normalize(incomingDir + outgoingDir) is not halfway between the light "
     "and the eye, and is 0/0 when the eye looks straight back at the light.",
     v_half_sum, BLI},
    {"shininess_wrong", "The highlight has the wrong width: the exponent must be exactly shininess (not shininess/2).",
     v_half_exponent, LOBES},
    {"shininess_wrong", "The highlight has the wrong width: the exponent must be exactly shininess (not 2 shininess).",
     v_double_exponent, LOBES},
    {"no_specular_clamp",
     "The highlight's cosine is not clamped: where it is negative, pow() gives negative light or NaN. Use "
     "pow(max(cos, 0), shininess).",
     v_no_spec_clamp, LOBES},
    {"integer_power",
     "The highlight's power is right only for a whole shininess: cos multiplied by itself in a loop is cos^ceil(n) "
     "(or cos^floor(n)) at a fractional n such as 0.5 or 7.5, which this assignment allows. Use pow(max(cos, 0), "
     "shininess).",
     v_power_ceil, LOBES},
    {"integer_power",
     "The highlight's power is right only for a whole shininess: (int)shininess steps of a loop give "
     "cos^floor(n) at a fractional n such as 0.5 or 7.5, which this assignment allows. Use pow(max(cos, 0), "
     "shininess).",
     v_power_floor, LOBES},
    {"kd_missing", "The diffuse term k_d cos(alpha) is missing: only the highlight is there.", v_no_kd, LOBES | COO},
    {"ks_missing", "The specular term is missing: only the diffuse light is there.", v_no_ks, LOBES | COO},
};
#define NMISTAKES (sizeof mistakes / sizeof *mistakes)

static int type_bit(rd_material_type t)
{
    return t == RD_MAT_DIFFUSE ? DIF : t == RD_MAT_PHONG ? PHO : t == RD_MAT_BLINN_PHONG ? BLI : COO;
}

/* Whether a mistake's formula gives what the student got: the same
 * channels not finite, the rest within ten times the tolerance. */
static int same(double got, double want)
{
    if (!isfinite(want) || !isfinite(got))
        return !isfinite(want) && !isfinite(got);
    return fabs(got - want) <= 10 * (RD_CODE_ABS_TOL + RD_CODE_REL_TOL * fabs(want));
}

/* A mistake explains a failing value when it fails there too (else a
 * formula that is right at a configuration would explain any value just
 * outside the tolerance) and gives what the student got. */
static int explains(const mistake *k, const rd_code_case *c, const rd_code_value *v)
{
    rd_rgb w = k->formula(c);
    rd_code_value as_mistake = {w, RD_CODE_RETURNED};
    return !rd_code_value_ok(c, &as_mistake) && same(v->got.x, w.x) && same(v->got.y, w.y) && same(v->got.z, w.z);
}

/* ---- the report ---------------------------------------------------------- */

enum { OPEN = 1, EXPLAINED = 2, RIGHT = 3 }; /* a configuration's state: failing (open, explained), right */

static void add_cause(rd_code_report *r, const char *cause, const char *words, size_t count, size_t example)
{
    if (count && r->ncauses < RD_CODE_MAX_CAUSES)
        r->causes[r->ncauses++] = (rd_code_cause){cause, words, count, example};
}

static const char *const status_words[] = {
    NULL,
    "calcReflectedLight crashed (a signal: a bad pointer, an index out of bounds, abort()). Each crash costs the "
    "configuration it happened on; after 16 the rest were not run.",
    "calcReflectedLight ended the program (exit()): return the colour instead.",
    "calcReflectedLight did not return within the time limit (an endless loop?); the rest were not run.",
    "calcReflectedLight was not called on these configurations: the run stopped before them (after crashes, a call "
    "that did not return, too much printed output, or the time limit for all the calls).",
};
static const char *const status_ids[] = {NULL, "crashed", "exited", "timed_out", "not_run"};

static void status_causes(rd_code_report *r, const rd_code_value *v, size_t n)
{
    for (int s = RD_CODE_CRASHED; s <= RD_CODE_NOT_RUN; s++) {
        size_t count = 0, first = 0;
        for (size_t i = 0; i < n; i++)
            if (v[i].status == s && !count++)
                first = i;
        add_cause(r, status_ids[s], status_words[s], count, first);
    }
}

/* Whether the mistake's formula is wrong at c (a student who makes it is). */
static int wrong_there(const mistake *k, const rd_code_case *c)
{
    rd_code_value as_mistake = {k->formula(c), RD_CODE_RETURNED};
    return !rd_code_value_ok(c, &as_mistake);
}

/* The mistake that explains most of the open failures, less the right
 * values it would have made wrong (of two formulas that both explain the
 * failures, the one the student's right values agree with), or -1. */
static int best_mistake(const rd_code_case *c, const rd_code_value *v, const unsigned char *state, size_t n,
                        size_t *count, size_t *example)
{
    int best = -1;
    long best_score = 0;
    *count = 0;
    for (size_t k = 0; n && k < NMISTAKES; k++) {
        if (!(mistakes[k].types & type_bit(c[0].m.type)))
            continue;
        size_t m = 0, first = 0, contradicted = 0;
        for (size_t i = 0; i < n; i++) {
            if (state[i] == OPEN && explains(&mistakes[k], &c[i], &v[i]) && !m++)
                first = i;
            else if (state[i] == RIGHT && wrong_there(&mistakes[k], &c[i]))
                contradicted++;
        }
        long score = (long)m - (long)contradicted;
        if (m && score > best_score) {
            best = (int)k;
            best_score = score;
            *count = m;
            *example = first;
        }
    }
    return best;
}

/* What can give NaN in the type's own formula: a student of Phong has no
 * half vector to divide by zero. */
static const char *not_finite_words(rd_material_type t)
{
    if (t == RD_MAT_DIFFUSE)
        return "It returned NaN or infinity: a division by zero, sqrt of a negative number, or normalize() of a zero "
               "vector. Guard those cases.";
    if (t == RD_MAT_PHONG)
        return "It returned NaN or infinity: a division by zero, pow or sqrt of a negative number, or normalize() of "
               "a zero vector. Guard those cases.";
    return "It returned NaN or infinity: a division by zero, sqrt or pow of a negative number, or normalize() of a "
           "zero vector (for example a half vector when the eye looks straight back at the light). Guard those "
           "cases.";
}

static void explain(const rd_code_case *c, const rd_code_value *v, unsigned char *state, size_t n, rd_code_report *r)
{
    size_t count, example;
    int k;
    /* The mistakes first: each names what the student wrote, where a NaN
     * left unexplained only names a symptom, so it comes after them */
    while (r->ncauses < RD_CODE_MAX_CAUSES && (k = best_mistake(c, v, state, n, &count, &example)) >= 0) {
        add_cause(r, mistakes[k].cause, mistakes[k].words, count, example);
        for (size_t i = 0; i < n; i++)
            if (state[i] == OPEN && explains(&mistakes[k], &c[i], &v[i]))
                state[i] = EXPLAINED;
    }
    size_t nan = 0, nan_first = 0, other = 0, other_first = 0;
    for (size_t i = 0; i < n; i++) {
        if (state[i] != OPEN)
            continue;
        if (!v3_is_finite(v[i].got) && !nan++)
            nan_first = i;
        else if (v3_is_finite(v[i].got) && !other++)
            other_first = i;
    }
    if (n)
        add_cause(r, "not_finite", not_finite_words(c[0].m.type), nan, nan_first);
    add_cause(r, "wrong_value",
              "Wrong values that none of the usual mistakes explains: compare yours with the expected value in the "
              "example, and see which group of configurations fails.",
              other, other_first);
}

void rd_code_check(const rd_code_case *c, const rd_code_value *v, size_t n, rd_code_report *r)
{
    memset(r, 0, sizeof *r);
    r->configurations = n;
    /* without memory the failures are counted but not explained */
    unsigned char *state = calloc(n ? n : 1, 1);
    size_t m = state ? n : 0;
    for (size_t i = 0; i < n; i++) {
        int ok = rd_code_value_ok(&c[i], &v[i]);
        r->failed += !ok;
        r->group_total[c[i].group]++;
        r->group_failed[c[i].group] += !ok;
        r->crashed += v[i].status == RD_CODE_CRASHED;
        r->exited += v[i].status == RD_CODE_EXITED;
        r->timed_out += v[i].status == RD_CODE_TIMED_OUT;
        r->not_run += v[i].status == RD_CODE_NOT_RUN;
        r->not_finite += v[i].status == RD_CODE_RETURNED && !v3_is_finite(v[i].got);
        if (i < m)
            state[i] = ok ? RIGHT : v[i].status == RD_CODE_RETURNED ? OPEN : 0;
    }
    r->pass = r->failed == 0;
    status_causes(r, v, n);
    explain(c, v, state, m, r);
    free(state);
}

/* ---- JSON ---------------------------------------------------------------- */

static cJSON *triple(rd_vec3 v)
{
    /* NaN and infinities are not JSON numbers: they go as null */
    cJSON *a = cJSON_CreateArray();
    double x[3] = {v.x, v.y, v.z};
    for (int i = 0; a && i < 3; i++) {
        cJSON *e = isfinite(x[i]) ? cJSON_CreateNumber(x[i]) : cJSON_CreateNull();
        if (!e || !cJSON_AddItemToArray(a, e)) {
            cJSON_Delete(e);
            cJSON_Delete(a);
            return NULL;
        }
    }
    return a;
}

static int put(cJSON *o, const char *name, cJSON *item)
{
    if (item && cJSON_AddItemToObject(o, name, item))
        return 1;
    cJSON_Delete(item);
    return 0;
}

static cJSON *example(const rd_code_case *c, const rd_code_value *v)
{
    cJSON *e = cJSON_CreateObject(), *m = e ? cJSON_AddObjectToObject(e, "material") : NULL;
    int ok =
        m && cJSON_AddStringToObject(e, "group", rd_code_group_name(c->group)) && put(e, "N", triple(c->n)) &&
        put(e, "L", triple(c->L)) && put(e, "V", triple(c->V)) && put(e, "expected", triple(expected(c))) &&
        (v->status == RD_CODE_RETURNED ? put(e, "got", triple(v->got)) : cJSON_AddNullToObject(e, "got") != NULL) &&
        put(m, "kd", triple(c->m.kd)) && put(m, "ks", triple(c->m.ks)) && put(m, "ambient", triple(c->m.ambient)) &&
        cJSON_AddNumberToObject(m, "shininess", c->m.shininess) &&
        cJSON_AddNumberToObject(m, "roughness", c->m.roughness);
    if (!ok) {
        cJSON_Delete(e);
        return NULL;
    }
    return e;
}

static int add_counts(cJSON *o, const rd_code_report *r)
{
    const struct {
        const char *name;
        size_t value;
    } counts[] = {{"configurations", r->configurations},
                  {"failed", r->failed},
                  {"not_finite", r->not_finite},
                  {"crashed", r->crashed},
                  {"exited", r->exited},
                  {"timed_out", r->timed_out},
                  {"not_run", r->not_run}};
    for (size_t i = 0; i < sizeof counts / sizeof *counts; i++)
        if (!cJSON_AddNumberToObject(o, counts[i].name, (double)counts[i].value))
            return 0;
    cJSON *g = cJSON_AddObjectToObject(o, "groups");
    for (int i = 0; g && i < RD_CODE_GROUPS; i++) {
        if (!r->group_total[i])
            continue;
        cJSON *e = cJSON_AddObjectToObject(g, rd_code_group_name((rd_code_group)i));
        if (!e || !cJSON_AddStringToObject(e, "what", rd_code_group_words((rd_code_group)i)) ||
            !cJSON_AddNumberToObject(e, "configurations", (double)r->group_total[i]) ||
            !cJSON_AddNumberToObject(e, "failed", (double)r->group_failed[i]))
            return 0;
    }
    return g != NULL;
}

cJSON *rd_code_report_json(const rd_code_report *r, const rd_code_case *c, const rd_code_value *v)
{
    cJSON *o = cJSON_CreateObject(), *causes = o ? cJSON_AddArrayToObject(o, "causes") : NULL;
    int ok = causes && cJSON_AddBoolToObject(o, "pass", r->pass) && add_counts(o, r);
    for (int i = 0; ok && i < r->ncauses; i++) {
        const rd_code_cause *k = &r->causes[i];
        cJSON *e = cJSON_CreateObject();
        ok = e && cJSON_AddStringToObject(e, "cause", k->cause) && cJSON_AddStringToObject(e, "words", k->words) &&
             cJSON_AddNumberToObject(e, "count", (double)k->count) &&
             put(e, "example", example(&c[k->example], &v[k->example])) && cJSON_AddItemToArray(causes, e);
        if (!ok)
            cJSON_Delete(e);
    }
    if (!ok) {
        cJSON_Delete(o);
        return NULL;
    }
    return o;
}
