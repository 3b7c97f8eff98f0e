/* The code grade in a few lines for the student at a terminal: the
 * verdict, then each cause with its words and one example. It is read off
 * the answer's JSON (code_json.c), so that it says nothing the HTTP answer
 * does not. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "codegrade.h"
#include "strbuf.h"

static const cJSON *get(const cJSON *o, const char *name) { return cJSON_GetObjectItemCaseSensitive(o, name); }

static const char *text_of(const cJSON *o, const char *name)
{
    const char *s = cJSON_GetStringValue(get(o, name));
    return s ? s : "";
}

static double number_of(const cJSON *o, const char *name)
{
    const cJSON *n = get(o, name);
    return cJSON_IsNumber(n) ? n->valuedouble : NAN;
}

/* "(0.5, 0.25, 0)"; a null channel (NaN or infinity in the answer) as NaN. */
static void triple(rd_strbuf *b, const char *label, const cJSON *a)
{
    rd_strbuf_printf(b, "%s (", label);
    for (int i = 0; i < 3; i++) {
        const cJSON *e = cJSON_GetArrayItem(a, i);
        if (cJSON_IsNumber(e))
            rd_strbuf_printf(b, "%s%.6g", i ? ", " : "", e->valuedouble);
        else
            rd_strbuf_printf(b, "%sNaN", i ? ", " : "");
    }
    rd_strbuf_printf(b, ")");
}

/* The material's parameter its model has (none for diffuse). */
static void parameter(rd_strbuf *b, const char *material, const cJSON *m)
{
    if (strcmp(material, "phong") == 0 || strcmp(material, "blinn_phong") == 0)
        rd_strbuf_printf(b, ", shininess %.6g", number_of(m, "shininess"));
    else if (strcmp(material, "cook_torrance") == 0)
        rd_strbuf_printf(b, ", roughness %.6g", number_of(m, "roughness"));
}

static void example(rd_strbuf *b, const char *material, const cJSON *e)
{
    rd_strbuf_printf(b, "    for example (%s): ", text_of(e, "group"));
    triple(b, "N", get(e, "N"));
    triple(b, ", L", get(e, "L"));
    triple(b, ", V", get(e, "V"));
    parameter(b, material, get(e, "material"));
    triple(b, ": expected", get(e, "expected"));
    if (cJSON_IsArray(get(e, "got")))
        triple(b, ", got", get(e, "got"));
    else
        rd_strbuf_printf(b, ", got no value");
    rd_strbuf_printf(b, "\n");
}

static void causes(rd_strbuf *b, const char *material, const cJSON *list)
{
    const cJSON *c;
    cJSON_ArrayForEach(c, list)
    {
        double count = number_of(c, "count");
        rd_strbuf_printf(b, "  %s", text_of(c, "cause"));
        if (!isnan(count))
            rd_strbuf_printf(b, ", %.0f configuration%s", count, count == 1 ? "" : "s");
        rd_strbuf_printf(b, ": %s\n", text_of(c, "words"));
        if (get(c, "example"))
            example(b, material, get(c, "example"));
    }
}

/* The first of the compiler's errors, as the student's file names it. */
static void first_error(rd_strbuf *b, const cJSON *compile)
{
    const cJSON *d;
    cJSON_ArrayForEach(d, get(compile, "diagnostics"))
    {
        if (strstr(text_of(d, "severity"), "error")) {
            rd_strbuf_printf(b, "  the compiler: %s:%.0f:%.0f: %s: %s\n", text_of(d, "file"), number_of(d, "line"),
                             number_of(d, "column"), text_of(d, "severity"), text_of(d, "message"));
            return;
        }
    }
    rd_strbuf_printf(b, "  the compiler's messages are in compile.messages of --json\n");
}

/* The image's verdict; the fraction to three digits, so that 0.104% is not
 * shown as the 0.10% it fails against. */
static void image(rd_strbuf *b, const cJSON *img)
{
    if (!cJSON_IsObject(img)) {
        rd_strbuf_printf(b, "; the image was not graded");
        return;
    }
    rd_strbuf_printf(b, "; the image %s (%.3g%% of pixels off, at most %.3g%%)",
                     cJSON_IsTrue(get(img, "pass")) ? "passes" : "fails",
                     100 * number_of(get(img, "metrics"), "failed_fraction"),
                     100 * number_of(get(img, "thresholds"), "fail_fraction"));
}

static void verdict(rd_strbuf *b, const cJSON *answer, const cJSON *function)
{
    double n = number_of(function, "configurations"), failed = number_of(function, "failed");
    if (cJSON_IsTrue(get(answer, "pass")))
        rd_strbuf_printf(b, "pass: %.0f of %.0f configurations right", n - failed, n);
    else
        rd_strbuf_printf(b, "fails: %.0f of %.0f configurations wrong", failed, n);
    image(b, get(answer, "image"));
    rd_strbuf_printf(b, "\n");
}

char *rd_codegrade_summary(const cJSON *answer)
{
    rd_strbuf b = {0};
    const char *material = text_of(answer, "material");
    const cJSON *compile = get(answer, "compile"), *function = get(answer, "function");
    rd_strbuf_printf(&b, "%s (%s): ", text_of(answer, "assignment"), text_of(answer, "class"));
    if (!cJSON_IsTrue(get(compile, "ok"))) {
        rd_strbuf_printf(&b, "the code does not compile\n");
        /* a cause in the student's terms makes the adapter's errors noise */
        if (cJSON_GetArraySize(get(compile, "causes")))
            causes(&b, material, get(compile, "causes"));
        else
            first_error(&b, compile);
    } else if (cJSON_IsObject(function)) {
        verdict(&b, answer, function);
        causes(&b, material, get(function, "causes"));
    } else {
        rd_strbuf_printf(&b, "the code was not graded\n");
    }
    if (cJSON_IsString(get(answer, "note")))
        rd_strbuf_printf(&b, "  note: %s\n", text_of(answer, "note"));
    if (!cJSON_IsTrue(get(answer, "pass")))
        rd_strbuf_printf(&b, "(--json gives the whole answer: every group, the compiler's messages, the output)\n");
    return rd_strbuf_take(&b, NULL);
}
