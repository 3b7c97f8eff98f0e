/* The code grade as JSON (docs/grading.md, "Grading code"), and the
 * skeletons a student starts from. */
#include <stdio.h>
#include <string.h>

#include "code_frames.h"
#include "codegrade.h"
#include "file_io.h"

static const char *compile_word(int r)
{
    switch (r) {
    case RD_COMPILE_OK: return "ok";
    case RD_COMPILE_TIME_LIMIT: return "time_limit";
    case RD_COMPILE_OUTPUT_LIMIT: return "output_limit";
    case -1: return "not_run";
    default: return "failed";
    }
}

static cJSON *diag_json(const rd_code_diag *d)
{
    cJSON *o = cJSON_CreateObject();
    if (o && !(cJSON_AddStringToObject(o, "file", d->file) && cJSON_AddNumberToObject(o, "line", d->line) &&
               cJSON_AddNumberToObject(o, "column", d->column) && cJSON_AddStringToObject(o, "severity", d->severity) &&
               cJSON_AddStringToObject(o, "message", d->message))) {
        cJSON_Delete(o);
        o = NULL;
    }
    return o;
}

/* compile.causes: what the student reads before the compiler's words,
 * shaped like function.causes. */
static int add_compile_causes(cJSON *o, const rd_code_compile *c)
{
    cJSON *a = cJSON_AddArrayToObject(o, "causes");
    if (!a || !c->cause)
        return a != NULL;
    cJSON *e = cJSON_CreateObject();
    if (!e || !cJSON_AddStringToObject(e, "cause", c->cause) || !cJSON_AddStringToObject(e, "words", c->words) ||
        !cJSON_AddItemToArray(a, e)) {
        cJSON_Delete(e);
        return 0;
    }
    return 1;
}

static int add_compile(cJSON *root, const rd_code_compile *c)
{
    cJSON *o = cJSON_AddObjectToObject(root, "compile");
    cJSON *d = o ? cJSON_AddArrayToObject(o, "diagnostics") : NULL;
    if (!d || !add_compile_causes(o, c) || !cJSON_AddBoolToObject(o, "ok", c->result == RD_COMPILE_OK) ||
        !cJSON_AddStringToObject(o, "result", compile_word(c->result)) || !cJSON_AddNumberToObject(o, "ms", c->ms) ||
        !cJSON_AddStringToObject(o, "messages", c->messages ? c->messages : ""))
        return 0;
    for (int i = 0; i < c->ndiags; i++) {
        cJSON *e = diag_json(&c->diags[i]);
        if (!e || !cJSON_AddItemToArray(d, e)) {
            cJSON_Delete(e);
            return 0;
        }
    }
    return 1;
}

static int add_output(cJSON *root, const rd_codegrade_result *r)
{
    cJSON *o = cJSON_AddObjectToObject(root, "output");
    return o && cJSON_AddStringToObject(o, "text", r->output ? r->output : "") &&
           cJSON_AddNumberToObject(o, "bytes", (double)r->output_total) &&
           cJSON_AddBoolToObject(o, "limited", r->output_limited);
}

static int add_function(cJSON *root, const rd_codegrade_result *r)
{
    if (!r->values)
        return cJSON_AddNullToObject(root, "function") != NULL;
    cJSON *f = rd_code_report_json(&r->report, r->cases, r->values);
    if (!f || !cJSON_AddItemToObject(root, "function", f)) {
        cJSON_Delete(f);
        return 0;
    }
    return cJSON_AddNumberToObject(f, "restarts", (double)r->restarts) && cJSON_AddNumberToObject(f, "ms", r->calls_ms);
}

static int add_image(cJSON *root, const rd_codegrade_result *r)
{
    if (!r->image_graded)
        return cJSON_AddNullToObject(root, "image") != NULL;
    cJSON *g = rd_grade_json(&r->grade);
    if (!g || !cJSON_AddItemToObject(root, "image", g)) {
        cJSON_Delete(g);
        return 0;
    }
    return 1;
}

cJSON *rd_codegrade_json(const rd_codegrade_result *r)
{
    cJSON *o = cJSON_CreateObject();
    int ok = o && cJSON_AddStringToObject(o, "assignment", r->assignment) &&
             cJSON_AddStringToObject(o, "material", r->material ? r->material : "") &&
             cJSON_AddStringToObject(o, "class", r->class_name ? r->class_name : "") &&
             cJSON_AddBoolToObject(o, "pass", r->pass) && add_compile(o, &r->compile) && add_function(o, r) &&
             add_image(o, r) && cJSON_AddNumberToObject(o, "shading_calls", (double)r->image_calls) &&
             add_output(o, r) &&
             (r->note ? cJSON_AddStringToObject(o, "note", r->note) : cJSON_AddNullToObject(o, "note")) &&
             cJSON_AddNumberToObject(o, "ms", r->ms) && cJSON_AddNumberToObject(o, "sandbox_ms", r->sandbox_ms);
    if (!ok) {
        cJSON_Delete(o);
        return NULL;
    }
    return o;
}

static const struct {
    const char *word, *file;
} skeletons[] = {
    {"diffuse", "skeleton/DiffuseMaterial.h"},
    {"phong", "skeleton/PhongMaterial.h"},
    {"blinn_phong", "skeleton/BlinnPhongMaterial.h"},
    {"cook_torrance", "skeleton/CookTorranceMaterial.h"},
};

rd_error_code rd_codegrade_skeleton(const char *course_dir, const char *material, char **text, size_t *len,
                                    rd_error *err)
{
    for (size_t i = 0; i < sizeof skeletons / sizeof *skeletons; i++)
        if (strcmp(material, skeletons[i].word) == 0) {
            char path[1024];
            snprintf(path, sizeof path, "%s/%s", course_dir, skeletons[i].file);
            return rd_read_file(path, (size_t)1 << 20, "--course", text, len, err);
        }
    return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0,
                        "no skeleton for \"%.64s\": diffuse, phong, blinn_phong or cook_torrance", material);
}
