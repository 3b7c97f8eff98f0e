#include "codegrade.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "code_frames.h"
#include "code_image.h"
#include "file_io.h"
#include "rayd/clock.h"
#include "sandbox.h"

/* The types a student writes, simplest first, with the course's class. */
static const struct {
    rd_material_type type;
    const char *word, *cls;
    int kind; /* the adapter's RAYD_KIND */
} kinds[] = {
    {RD_MAT_DIFFUSE, "diffuse", "DiffuseMaterial", 1},
    {RD_MAT_PHONG, "phong", "PhongMaterial", 2},
    {RD_MAT_BLINN_PHONG, "blinn_phong", "BlinnPhongMaterial", 3},
    {RD_MAT_COOK_TORRANCE, "cook_torrance", "CookTorranceMaterial", 4},
};
#define NKINDS (sizeof kinds / sizeof *kinds)

/* The course's files the compile needs, copied into /rayd/course/. */
static const char *const course_files[] = {
    "my_algebra.h",
    "HitRecord.h",
    "Material.h",
    "rayd_code.h",
    "adapter.cpp",
    "decl/DiffuseMaterial.h",
    "decl/PhongMaterial.h",
    "decl/BlinnPhongMaterial.h",
    "decl/CookTorranceMaterial.h",
};
#define NCOURSE (sizeof course_files / sizeof *course_files)

rd_codegrade_config rd_codegrade_config_default(void)
{
    rd_codegrade_config c;
    memset(&c, 0, sizeof c);
    c.compile_ms = 30000;
    c.run_ms = 20000;
    c.stall_ms = 2000;
    c.max_queries = (size_t)1 << 20; /* 192 MiB of queries; an assignment takes some 100 000 */
    c.max_bytes = RD_CODE_MAX_BYTES_DEFAULT;
    c.threads = 1;
    c.uid = 65534;
    c.gid = 65534;
    return c;
}

const char *rd_codegrade_class(rd_material_type t)
{
    for (size_t i = 0; i < NKINDS; i++)
        if (kinds[i].type == t)
            return kinds[i].cls;
    return NULL;
}

static int kind_of(const rd_scene *s)
{
    int best = -1;
    for (size_t i = 0; i < s->material_count; i++)
        for (int k = 0; k < (int)NKINDS; k++)
            if (s->materials[i].type == kinds[k].type && k > best)
                best = k;
    return best;
}

/* The scene's graded materials must lie in the domain the assignment
 * states: the image's calls are judged like the configurations, and code
 * right for every n the text allows must pass both. */
static rd_error_code check_domain(const rd_scene *s, rd_material_type t, rd_shininess_domain d, const char *assignment,
                                  rd_error *err)
{
    for (size_t i = 0; d == RD_SHININESS_NATURAL && i < s->material_count; i++) {
        double n = s->materials[i].shininess;
        if (s->materials[i].type == t && (n < 1 || n != floor(n)))
            return rd_error_set(err, RD_ERR_INVALID, 0, 0,
                                "the assignment %s states a natural shininess, but its scene's material %s has "
                                "shininess %g",
                                assignment, s->materials[i].name ? s->materials[i].name : "(unnamed)", n);
    }
    return RD_OK;
}

static int has_suffix(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a > b && strcmp(s + a - b, suffix) == 0;
}

/* A name the sandbox can hold and the compiler's messages can show: plain
 * characters, a C++ suffix, and none of the course's own names. */
static rd_error_code check_input(const rd_codegrade_config *cfg, const rd_codegrade_input *in, char dest[80],
                                 rd_error *err)
{
    const char *f = in->filename ? in->filename : "";
    size_t n = strlen(f);
    int ok = n > 0 && n <= 64 && f[0] != '.' &&
             strspn(f, "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz"
                       "0123456789_.-") == n;
    int cpp = has_suffix(f, ".cpp") || has_suffix(f, ".cc") || has_suffix(f, ".c");
    if (!ok || !(cpp || has_suffix(f, ".h") || has_suffix(f, ".hpp")))
        return rd_error_set(
            err, RD_ERR_INVALID, 0, 0,
            "the file's name \"%.64s\" is not a C++ header or source (PhongMaterial.h, or a .cpp or .c)", f);
    if (!in->source || in->len == 0)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "the file %s is empty", f);
    if (in->len > cfg->max_bytes)
        return rd_error_set(err, RD_ERR_LIMIT, 0, 0, "the file %s has %zu bytes; at most %zu (--max-code-bytes)", f,
                            in->len, cfg->max_bytes);
    if (memchr(in->source, '\0', in->len))
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "the file %s holds NUL bytes: it is not C++ text", f);
    int clash = 0;
    for (size_t i = 0; i < NCOURSE; i++)
        clash |= strcmp(f, course_files[i]) == 0;
    snprintf(dest, 80, "/work/%s", clash ? (cpp ? "student.cpp" : "student.h") : f);
    return RD_OK;
}

/* The scene, its reference, the configurations and every call of the
 * image, the configurations' first. */
typedef struct {
    rd_scene scene;
    int kind;
    rd_code_query *q;
    size_t nq, cap;
} prepared;

static rd_error_code add_cases(prepared *p, rd_codegrade_result *out)
{
    p->cap = out->ncases + 4096;
    p->q = calloc(p->cap, sizeof *p->q);
    if (!p->q)
        return RD_ERR_NOMEM;
    for (size_t i = 0; i < out->ncases; i++) {
        const rd_code_case *c = &out->cases[i];
        rd_code_query *q = &p->q[p->nq++];
        q->m = rd_code_material_of(&c->m);
        q->h = (rayd_code_hit){{c->n.x, c->n.y, c->n.z}, {0, 0, 0}, 1};
        memcpy(q->incoming, (double[3]){c->L.x, c->L.y, c->L.z}, sizeof q->incoming);
        memcpy(q->outgoing, (double[3]){c->V.x, c->V.y, c->V.z}, sizeof q->outgoing);
    }
    return RD_OK;
}

static rd_error_code prepare(const rd_codegrade_config *cfg, const rd_codegrade_input *in, prepared *p,
                             rd_codegrade_result *out, rd_error *err)
{
    rd_grade_input gi = {0};
    gi.assignment = in->assignment;
    rd_error_code rc = rd_grade_prepare_reference(&cfg->grader, &gi, &p->scene, &out->grade, err);
    if (rc)
        return rc;
    snprintf(out->assignment, sizeof out->assignment, "%s", out->grade.assignment);
    p->kind = kind_of(&p->scene);
    out->grade.stage = RD_GRADE_STAGE_ASSIGNMENT; /* what fails now is the assignment's */
    if (p->kind < 0)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0,
                            "the assignment %s has no diffuse, phong, blinn_phong or cook_torrance material: "
                            "there is no calcReflectedLight to grade",
                            out->assignment);
    out->material = kinds[p->kind].word;
    out->class_name = kinds[p->kind].cls;
    rd_material_type t = kinds[p->kind].type;
    /* before the reference, whose render moves the stage on */
    if ((rc = check_domain(&p->scene, t, out->grade.shininess, out->assignment, err)))
        return rc;
    if (!out->grade.reference &&
        (rc = rd_grade_render_reference(&cfg->grader, &p->scene, cfg->threads, &out->grade, err)))
        return rc;
    if ((rc = rd_code_cases(t, out->grade.shininess, &out->cases, &out->ncases, err)))
        return rc;
    if (add_cases(p, out))
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    rc = rd_code_record(&p->scene, kinds[p->kind].type, out->ncases + cfg->max_queries, &p->q, &p->nq, &p->cap, err);
    if (!rc)
        out->grade.stage = RD_GRADE_STAGE_NONE;
    return rc;
}

/* The queries as the file the evaluator reads. */
static unsigned char *queries_file(const prepared *p, size_t *len)
{
    rd_queries_header h = {RD_QUERIES_MAGIC, (uint32_t)p->nq};
    *len = sizeof h + p->nq * sizeof *p->q;
    unsigned char *b = malloc(*len);
    if (b) {
        memcpy(b, &h, sizeof h);
        memcpy(b + sizeof h, p->q, p->nq * sizeof *p->q);
    }
    return b;
}

/* The course's files and the evaluator as the sandbox's files[0..NCOURSE];
 * paths and dests hold their names. */
static void course_files_in(const rd_codegrade_config *cfg, rd_sandbox_file *files, char paths[][1024],
                            char dests[][64])
{
    for (size_t i = 0; i < NCOURSE; i++) {
        snprintf(paths[i], sizeof paths[i], "%s/%s", cfg->course_dir, course_files[i]);
        snprintf(dests[i], sizeof dests[i], "/rayd/course/%s", course_files[i]);
        files[i] = (rd_sandbox_file){dests[i], paths[i], NULL, 0, 0};
    }
    files[NCOURSE] = (rd_sandbox_file){"/rayd/rayd-eval", cfg->eval, NULL, 0, 1};
}

/* The sandbox of a grade of nq queries; files: NCOURSE + 3 of them. */
static rd_sandbox_spec sandbox_spec(const rd_codegrade_config *cfg, const rd_sandbox_file *files, size_t nq)
{
    size_t qlen = sizeof(rd_queries_header) + nq * sizeof(rd_code_query);
    rd_sandbox_spec sp = rd_sandbox_spec_default();
    sp.bwrap = cfg->bwrap;
    sp.files = files;
    sp.nfiles = NCOURSE + 3;
    sp.wall_ms = cfg->compile_ms + cfg->run_ms + 10000;
    sp.cpu_s = (unsigned long)((cfg->compile_ms + cfg->run_ms) / 1000) + 5;
    sp.data_max = nq * sizeof(rd_frame_value) + ((size_t)1 << 20);
    /* bwrap writes the queries under the sandbox's limits too */
    if (sp.file_size < qlen + ((size_t)1 << 20))
        sp.file_size = qlen + ((size_t)1 << 20);
    sp.uid = cfg->uid;
    sp.gid = cfg->gid;
    sp.cancel = cfg->cancel;
    return sp;
}

size_t rd_codegrade_memory_bytes(const rd_codegrade_config *cfg, size_t source_len)
{
    /* the most queries a grade may have: the image's bound and the
     * configurations, which are far fewer than the margin */
    size_t nq = cfg->max_queries + ((size_t)1 << 16);
    char paths[NCOURSE][1024], dests[NCOURSE][64];
    rd_sandbox_file files[NCOURSE + 3];
    course_files_in(cfg, files, paths, dests);
    size_t qlen = sizeof(rd_queries_header) + nq * sizeof(rd_code_query);
    files[NCOURSE + 1] = (rd_sandbox_file){"/rayd/queries.bin", NULL, NULL, qlen, 0};
    files[NCOURSE + 2] = (rd_sandbox_file){"/work/student", NULL, NULL, source_len, 0};
    rd_sandbox_spec sp = sandbox_spec(cfg, files, nq);
    /* and on the daemon's side the queries and the values that come back */
    return (size_t)rd_sandbox_memory_bytes(&sp) + nq * sizeof(rd_code_query) + sp.data_max;
}

static rd_error_code run_sandbox(const rd_codegrade_config *cfg, const rd_codegrade_input *in, const char *dest,
                                 const prepared *p, rd_sandbox_result *res, rd_error *err)
{
    size_t qlen;
    unsigned char *qfile = queries_file(p, &qlen);
    char paths[NCOURSE][1024], dests[NCOURSE][64], num[3][32];
    rd_sandbox_file files[NCOURSE + 3];
    if (!qfile)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    course_files_in(cfg, files, paths, dests);
    files[NCOURSE + 1] = (rd_sandbox_file){"/rayd/queries.bin", NULL, qfile, qlen, 0};
    files[NCOURSE + 2] = (rd_sandbox_file){dest, NULL, in->source, in->len, 0};
    char kind[8];
    snprintf(kind, sizeof kind, "%d", kinds[p->kind].kind);
    snprintf(num[0], sizeof num[0], "%.0f", cfg->compile_ms);
    snprintf(num[1], sizeof num[1], "%.0f", cfg->stall_ms);
    snprintf(num[2], sizeof num[2], "%.0f", cfg->run_ms);
    const char *argv[] = {"/rayd/rayd-eval",
                          kind,
                          kinds[p->kind].cls,
                          dest,
                          "/rayd/course",
                          "/rayd/queries.bin",
                          num[0],
                          num[1],
                          num[2],
                          NULL};
    rd_sandbox_spec sp = sandbox_spec(cfg, files, p->nq);
    sp.argv = argv;
    rd_error_code rc = rd_sandbox_run(&sp, res, err);
    free(qfile);
    return rc;
}

static int value_status(int32_t s)
{
    switch (s) {
    case RD_VALUE_RETURNED: return RD_CODE_RETURNED;
    case RD_VALUE_CRASHED: return RD_CODE_CRASHED;
    case RD_VALUE_EXITED: return RD_CODE_EXITED;
    case RD_VALUE_TIMED_OUT: return RD_CODE_TIMED_OUT;
    default: return RD_CODE_NOT_RUN;
    }
}

static char *text_copy(const char *p, size_t n)
{
    char *t = malloc(n + 1);
    if (t) {
        for (size_t i = 0; i < n; i++)
            t[i] = p[i] == '\n' || p[i] == '\t' || (unsigned char)p[i] >= 0x20 ? p[i] : '?';
        t[n] = '\0';
    }
    return t;
}

/* The sandbox's end when the evaluator could not report its values. */
static const char *sandbox_end_words(const rd_sandbox_result *r)
{
    switch (r->end) {
    case RD_SANDBOX_TIMED_OUT: return "the code ran past the time limit";
    case RD_SANDBOX_OUTPUT_LIMIT: return "the code printed past the output limit";
    case RD_SANDBOX_DATA_LIMIT: return "the evaluator's report was too long";
    case RD_SANDBOX_CANCELLED: return "the grade was cancelled";
    case RD_SANDBOX_SIGNALED: return "the evaluator was killed by a signal";
    default: return "the evaluator ended before reporting";
    }
}

static void take_compile(const rd_code_frames *f, const rd_sandbox_result *res, rd_codegrade_result *out)
{
    rd_code_compile *c = &out->compile;
    if (!f->has_compile) {
        c->result = RD_COMPILE_FAILED;
        rd_code_compile_messages(c, res->output, res->output_len);
        if (!out->note)
            out->note = strdup(sandbox_end_words(res));
        return;
    }
    c->result = f->compile.result;
    c->status = f->compile.status;
    c->ms = f->compile.ms;
    rd_code_compile_messages(c, f->messages, f->messages_len);
}

/* The configurations' values, then the image's; NULL values: not run. */
static void take_values(const rd_code_frames *f, rd_codegrade_result *out, rd_frame_value *image, size_t nimage)
{
    for (size_t i = 0; i < out->ncases; i++) {
        rd_frame_value fv = rd_code_frame_value(f, i);
        out->values[i].status = value_status(fv.status);
        out->values[i].got = v3(fv.rgb[0], fv.rgb[1], fv.rgb[2]);
    }
    for (size_t i = 0; i < nimage; i++)
        image[i] = rd_code_frame_value(f, out->ncases + i);
    if (f->values) {
        out->restarts = f->vhead.restarts;
        out->calls_ms = f->vhead.ms;
    }
    if (f->has_output) {
        out->output_total = f->output.total;
        out->output_limited = f->output.limited != 0;
        out->output = text_copy(f->printed, f->printed_len);
    }
}

/* The image with the student's values, graded like a student's PNG. */
static rd_error_code grade_image(prepared *p, const rd_frame_value *image, rd_codegrade_result *out, rd_error *err)
{
    uint8_t *rgb = NULL;
    int w, h;
    size_t mismatched = 0;
    rd_error_code rc = rd_code_replay(&p->scene, kinds[p->kind].type, p->q + out->ncases, image, out->image_calls, &rgb,
                                      &w, &h, &mismatched, err);
    if (rc)
        return rc;
    if (mismatched || w != out->grade.width || h != out->grade.height) {
        free(rgb);
        return rd_error_set(err, RD_ERR_INVALID, 0, 0,
                            "the image's shading calls were not the recorded ones (%zu differ): the render is "
                            "not deterministic",
                            mismatched);
    }
    out->grade.image = rgb;
    if (rd_grade_finish(&out->grade))
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory comparing the images");
    out->image_graded = 1;
    return RD_OK;
}

static rd_error_code evaluate(const rd_sandbox_result *res, prepared *p, rd_codegrade_result *out, rd_error *err)
{
    rd_code_frames f;
    rd_code_read_frames(res->data, res->data_len, p->nq, &f);
    if (f.note)
        out->note = text_copy(f.note, f.note_len);
    take_compile(&f, res, out);
    if (out->compile.result != RD_COMPILE_OK)
        return RD_OK;
    if (!f.values && !out->note)
        out->note = strdup(sandbox_end_words(res));
    out->image_calls = p->nq - out->ncases;
    out->values = calloc(out->ncases ? out->ncases : 1, sizeof *out->values);
    rd_frame_value *image = malloc((out->image_calls ? out->image_calls : 1) * sizeof *image);
    if (!out->values || !image) {
        free(image);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    }
    take_values(&f, out, image, out->image_calls);
    rd_code_check(out->cases, out->values, out->ncases, &out->report);
    rd_error_code rc = grade_image(p, image, out, err);
    free(image);
    return rc;
}

static int ident_char(char c) { return c == '_' || isalnum((unsigned char)c); }

static int is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

/* The class is defined at src[i] (a whole word there). */
static int defined_at(const char *src, size_t len, size_t i, size_t n)
{
    size_t a = i + n, b = i;
    if ((i && ident_char(src[i - 1])) || (a < len && ident_char(src[a])))
        return 0;
    while (a < len && is_space(src[a]))
        a++;
    if (a + 1 < len && src[a] == ':' && src[a + 1] == ':')
        return 1;
    while (b && is_space(src[b - 1]))
        b--;
    int keyword = (b >= 5 && memcmp(src + b - 5, "class", 5) == 0) || (b >= 6 && memcmp(src + b - 6, "struct", 6) == 0);
    return keyword && b < i && a < len && (src[a] == ':' || src[a] == '{');
}

/* Whether the source defines the class: "class NAME" or "struct NAME"
 * followed by ':' or '{', or "NAME::" (a .cpp's definitions); comments
 * and strings are not told apart, which a failed compile tolerates. */
static int defines_class(const char *src, size_t len, const char *cls)
{
    size_t n = strlen(cls);
    for (size_t i = 0; i + n <= len; i++)
        if (src[i] == cls[0] && memcmp(src + i, cls, n) == 0 && defined_at(src, len, i, n))
            return 1;
    return 0;
}

/* A compile that failed because the file is another assignment's: the
 * adapter's errors about the missing class would hide that. */
static void name_wrong_class(const rd_codegrade_input *in, rd_codegrade_result *out)
{
    if (!out->class_name || defines_class(in->source, in->len, out->class_name))
        return;
    for (size_t k = 0; k < NKINDS; k++)
        if (kinds[k].cls != out->class_name && defines_class(in->source, in->len, kinds[k].cls)) {
            out->compile.cause = "wrong_class";
            snprintf(out->compile.words, sizeof out->compile.words,
                     "this file defines %s; %s expects %s (upload %s.h, or grade this file with a %s assignment)",
                     kinds[k].cls, out->assignment, out->class_name, out->class_name, kinds[k].word);
            return;
        }
}

rd_error_code rd_codegrade_run(const rd_codegrade_config *cfg, const rd_codegrade_input *in, rd_codegrade_result *out,
                               rd_error *err)
{
    double t0 = rd_now_ms();
    memset(out, 0, sizeof *out);
    out->compile.result = -1;
    char dest[80];
    rd_error_code rc = check_input(cfg, in, dest, err);
    if (rc)
        return rc;
    prepared p;
    memset(&p, 0, sizeof p);
    rd_scene_init(&p.scene);
    rc = prepare(cfg, in, &p, out, err);
    rd_sandbox_result res;
    memset(&res, 0, sizeof res);
    if (!rc)
        rc = run_sandbox(cfg, in, dest, &p, &res, err);
    if (!rc) {
        out->sandbox_ms = res.ms;
        rc = evaluate(&res, &p, out, err);
    }
    if (!rc && out->compile.result == RD_COMPILE_FAILED)
        name_wrong_class(in, out);
    rd_sandbox_result_free(&res);
    rd_scene_free(&p.scene);
    free(p.q);
    out->pass =
        !rc && out->compile.result == RD_COMPILE_OK && out->report.pass && out->image_graded && out->grade.result.pass;
    out->ms = rd_now_ms() - t0;
    return rc;
}

void rd_codegrade_result_free(rd_codegrade_result *r)
{
    free(r->compile.messages);
    free(r->compile.diags);
    free(r->cases);
    free(r->values);
    free(r->output);
    free(r->note);
    rd_grade_output_free(&r->grade);
    memset(r, 0, sizeof *r);
}
