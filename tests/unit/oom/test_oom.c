/* Out of memory, everywhere (suite oom): every allocation an operation
 * makes is failed in turn, as SQLite's test_malloc does, through the
 * fault-injecting allocator of tests/support/fault_alloc.h.
 *
 * For each operation, k = 1, 2, 3, ... until a run reaches no failure:
 * the k-th allocation from the start of the run fails, once, and then
 * again with every allocation after it failing too (a lasting shortage).
 * Every such run must
 *   - return RD_ERR_NOMEM with a message that says "memory", or else
 *     succeed with exactly the result of a run without failures (a failure
 *     the code may absorb: a shrinking realloc, a cache copy), or, for an
 *     input that is wrong, give exactly its usual error;
 *   - leave what its contract promises on error (no image, no text, no
 *     pixels);
 *   - free, after the caller's documented cleanup (rd_scene_free,
 *     rd_image_free, rd_grade_output_free, free), every block it
 *     allocated: the allocator's count of live blocks is the same before
 *     and after (and LeakSanitizer checks the same at exit under ASan);
 *   - not crash (a crash fails the test).
 *
 * Operations covered (each test prints how many allocation points it
 * tested and how long it took):
 *   parsing     tests/unit/oom/scene.cfg and its JSON twin scene.json (every
 *               section kind, light type and material type); a cfg scene
 *               naming a material that does not exist and a JSON scene with
 *               a duplicate key (the error must stay the same);
 *   opening     rd_scene_open of scenes/textured_phong.cfg and of
 *               tests/unit/oom/scene.cfg (the file, the parse, OBJ meshes,
 *               PNG textures), and of a posted text;
 *   rendering   rd_render of scene.cfg with 1 thread and of
 *               textured_phong.cfg with 2 (16x12), of 125 spheres (8x6: the
 *               BVH grows its node array), and a progressive, adaptive
 *               render with 2 threads: world, BVH, lights, job, workers, image; the job
 *               interface the daemon schedules (passes, tiles, rd_job_image);
 *   images      decoding scenes/textures/checker.png, encoding a render;
 *   grading     rd_grade_run on a posted 12x9 textured scene with a PNG:
 *               without a cache, twice through a memory cache and twice
 *               through a disk cache (the second grade finds the reference
 *               there); the verdict JSON; the assignment list of
 *               scenes/assignments; a class's roster;
 *   writing     scene.cfg written as cfg and as JSON; the JSON Schema; a
 *               render's statistics as rayd render's object and as a job
 *               status.
 *
 * cJSON's allocations are failed too (rd_fault_route_cjson); those of
 * libpng and zlib are not (fault_alloc.h says why). Every test runs from
 * the repository root. */
#include <criterion/criterion.h>
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "assignment.h"
#include "file_io.h"
#include "grading.h"
#include "job_status.h"
#include "json_text.h"
#include "png_read.h"
#include "png_write.h"
#include "rayd/job.h"
#include "rayd/render.h"
#include "reference.h"
#include "roster.h"
#include "scene_load.h"
#include "scene_open.h"
#include "scene_schema.h"
#include "scene_write.h"
#include "support/fault_alloc.h"

#define FIXTURE "tests/unit/oom/scene.cfg"
#define FIXTURE_JSON "tests/unit/oom/scene.json"
#define TEXTURED "scenes/textured_phong.cfg"

/* ---- one operation ---------------------------------------------------------- */

/* What one run of an operation leaves; each operation uses its own members. */
typedef struct {
    rd_scene scene;
    rd_image image;
    rd_render_stats stats;
    char *text;
    unsigned char *bytes;
    size_t len;
    rd_png_image png;
    rd_grade_output grade[2];
    rd_ref_cache *cache;
    rd_assignment *list;
    size_t count;
    rd_roster roster;
} result;

typedef struct {
    const char *name;
    /* One run into r (zeroed before). */
    rd_error_code (*run)(result *r, rd_error *err);
    /* What is wrong with what a failed run left, or NULL (may be NULL). */
    const char *(*after_error)(const result *r);
    /* Whether two successful runs gave the same result (NULL for an
     * operation whose correct answer is an error). */
    int (*same)(const result *a, const result *b);
    /* The caller's documented cleanup, after success or failure. */
    void (*release)(result *r);
} operation;

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

/* Runs op once with the k-th allocation failing (and every later one when
 * persist); returns whether a failure was injected. */
static int attempt(const operation *op, const result *ref, rd_error_code ref_rc, const rd_error *ref_err, long k,
                   int persist, int *absorbed)
{
    const char *mode = persist ? " and every one after" : "";
    result r;
    memset(&r, 0, sizeof r);
    rd_error err;
    memset(&err, 0, sizeof err);
    long live = rd_fault_live();
    rd_fault_arm(k, persist);
    rd_error_code rc = op->run(&r, &err);
    long injected = rd_fault_injected();
    rd_fault_disarm();
    if (!injected) {
        cr_assert_eq(rc, ref_rc, "%s: without a failure: %s (%s)", op->name, rd_error_name(rc), err.message);
        if (rc == RD_OK)
            cr_assert(op->same(&r, ref), "%s: without a failure, another result", op->name);
        else
            cr_assert_str_eq(err.message, ref_err->message, "%s: without a failure", op->name);
    } else if (rc == RD_ERR_NOMEM) {
        cr_assert(strstr(err.message, "memory"), "%s: allocation %ld failed%s: message '%s'", op->name, k, mode,
                  err.message);
        const char *why = op->after_error ? op->after_error(&r) : NULL;
        cr_assert(!why, "%s: allocation %ld failed%s: %s", op->name, k, mode, why);
    } else if (rc == ref_rc) {
        if (rc == RD_OK)
            cr_assert(op->same(&r, ref), "%s: allocation %ld failed%s, and it succeeded with another result", op->name,
                      k, mode);
        else
            cr_assert_str_eq(err.message, ref_err->message, "%s: allocation %ld failed%s: another error", op->name, k,
                             mode);
        (*absorbed)++;
    } else {
        cr_assert_fail("%s: allocation %ld failed%s: %s, not nomem: %s", op->name, k, mode, rd_error_name(rc),
                       err.message);
    }
    op->release(&r);
    long leaked = rd_fault_live() - live;
    cr_assert_eq(leaked, 0, "%s: allocation %ld failed%s: %ld blocks not freed", op->name, k, mode, leaked);
    return injected > 0;
}

/* The whole walk of one operation. */
static void exercise(const operation *op)
{
    double t0 = now_ms();
    result ref;
    memset(&ref, 0, sizeof ref);
    rd_error ref_err;
    memset(&ref_err, 0, sizeof ref_err);
    long calls = rd_fault_calls(), live = rd_fault_live();
    rd_error_code ref_rc = op->run(&ref, &ref_err);
    long points = rd_fault_calls() - calls;
    if (op->same)
        cr_assert_eq(ref_rc, RD_OK, "%s: %s", op->name, ref_err.message);
    else
        cr_assert_neq(ref_rc, RD_OK, "%s: should fail", op->name);
    cr_assert(points > 0, "%s: allocates nothing", op->name);
    long tested[2] = {0, 0};
    int absorbed[2] = {0, 0};
    for (int persist = 0; persist < 2; persist++)
        for (long k = 1; attempt(op, &ref, ref_rc, &ref_err, k, persist, &absorbed[persist]); k++) {
            tested[persist]++;
            cr_assert(k <= 4 * points + 100, "%s: still failing at allocation %ld of %ld", op->name, k, points);
        }
    op->release(&ref);
    cr_assert_eq(rd_fault_live(), live, "%s: the run without failures leaked", op->name);
    printf("oom: %-34s %5ld allocation points (%ld failed once, %ld failed for good; absorbed %d and %d), %.0f ms\n",
           op->name, points, tested[0], tested[1], absorbed[0], absorbed[1], now_ms() - t0);
    fflush(stdout);
}

static void setup(void) { rd_fault_route_cjson(); }

TestSuite(oom, .init = setup);

/* ---- inputs (read without failures) ----------------------------------------- */

static char *g_text;
static size_t g_len;
static rd_scene_format g_format;
static const char *g_source;
static const char *g_path;
static rd_scene g_scene;
static rd_render_options g_ro;
static uint8_t *g_rgb8;
static int g_w, g_h;
static rd_grader g_grader;
static rd_grade_input g_in;

static void read_text(const char *path)
{
    rd_error err;
    cr_assert_eq(rd_read_file(path, 1 << 20, "-", &g_text, &g_len, &err), RD_OK, "%s", err.message);
    g_source = path;
}

static void open_scene(const char *path, rd_scene *s)
{
    rd_error err;
    rd_scene_source src = {0};
    src.path = path;
    rd_scene_init(s);
    cr_assert_eq(rd_scene_open(&src, NULL, NULL, s, NULL, &err), RD_OK, "%s", err.message);
}

/* ---- comparing results ------------------------------------------------------ */

static int same_str(const char *a, const char *b) { return (!a && !b) || (a && b && strcmp(a, b) == 0); }

/* memcmp that takes the NULL arrays of empty ones. */
static int same_mem(const void *a, const void *b, size_t n) { return n == 0 || (a && b && !memcmp(a, b, n)); }

static int same_scene(const result *ra, const result *rb)
{
    const rd_scene *a = &ra->scene, *b = &rb->scene;
    if (a->light_count != b->light_count || a->material_count != b->material_count ||
        a->object_count != b->object_count || a->texture_count != b->texture_count || a->mesh_count != b->mesh_count)
        return 0;
    char *ta = NULL, *tb = NULL;
    rd_error err;
    int same =
        rd_scene_write_cfg(a, &ta, &err) == RD_OK && rd_scene_write_cfg(b, &tb, &err) == RD_OK && strcmp(ta, tb) == 0;
    free(ta);
    free(tb);
    for (size_t i = 0; same && i < a->material_count; i++)
        same = a->materials[i].texture_index == b->materials[i].texture_index &&
               same_str(a->materials[i].where, b->materials[i].where);
    for (size_t i = 0; same && i < a->object_count; i++)
        same = a->objects[i].material == b->objects[i].material && a->objects[i].mesh == b->objects[i].mesh &&
               same_str(a->objects[i].where, b->objects[i].where);
    for (size_t i = 0; same && i < a->mesh_count; i++) {
        const rd_mesh *x = &a->meshes[i], *y = &b->meshes[i];
        same = x->npositions == y->npositions && x->nnormals == y->nnormals && x->nuvs == y->nuvs &&
               x->nfaces == y->nfaces && same_mem(x->positions, y->positions, x->npositions * sizeof *x->positions) &&
               same_mem(x->normals, y->normals, x->nnormals * sizeof *x->normals) &&
               same_mem(x->uvs, y->uvs, x->nuvs * sizeof *x->uvs) &&
               same_mem(x->faces, y->faces, x->nfaces * sizeof *x->faces);
    }
    for (size_t i = 0; same && i < a->texture_count; i++) {
        const rd_texture *x = &a->textures[i], *y = &b->textures[i];
        same = x->width == y->width && x->height == y->height &&
               same_mem(x->rgb, y->rgb, (size_t)x->width * x->height * 3 * sizeof *x->rgb);
    }
    return same;
}

static void release_scene(result *r) { rd_scene_free(&r->scene); }

static int same_render(const result *a, const result *b)
{
    const rd_render_stats *x = &a->stats, *y = &b->stats;
    if (a->image.width != b->image.width || a->image.height != b->image.height || !a->image.rgb || !b->image.rgb)
        return 0;
    if (memcmp(a->image.rgb, b->image.rgb, (size_t)a->image.width * a->image.height * 3 * sizeof(double)))
        return 0;
    if (x->camera_rays != y->camera_rays || x->shadow_rays != y->shadow_rays ||
        x->secondary_rays != y->secondary_rays || x->nonfinite != y->nonfinite || x->samples != y->samples ||
        x->mean_samples != y->mean_samples || x->error_estimate != y->error_estimate || x->passes != y->passes ||
        x->curve_len != y->curve_len || x->stopped_by != y->stopped_by || x->bvh_nodes != y->bvh_nodes ||
        x->primitives != y->primitives)
        return 0;
    for (int i = 0; i < x->curve_len; i++)
        if (x->curve[i].samples != y->curve[i].samples || x->curve[i].error != y->curve[i].error)
            return 0;
    return 1;
}

static const char *render_after_error(const result *r)
{
    return r->image.rgb || r->image.width || r->image.height ? "the image is not empty" : NULL;
}

static void release_render(result *r) { rd_image_free(&r->image); }

static int same_text(const result *a, const result *b) { return a->text && b->text && !strcmp(a->text, b->text); }

static const char *text_after_error(const result *r) { return r->text ? "a text came back" : NULL; }

static void release_text(result *r) { free(r->text); }

/* ---- parsing ---------------------------------------------------------------- */

static rd_error_code run_parse(result *r, rd_error *err)
{
    rd_scene_init(&r->scene);
    return rd_scene_parse(g_text, g_len, g_format, g_source, NULL, &r->scene, err);
}

static const operation parse_op = {"parse", run_parse, NULL, same_scene, release_scene};

Test(oom, parse_cfg)
{
    read_text(FIXTURE);
    g_format = RD_FMT_CFG;
    operation op = parse_op;
    op.name = "parse cfg";
    exercise(&op);
    free(g_text);
}

Test(oom, parse_json)
{
    read_text(FIXTURE_JSON);
    g_format = RD_FMT_JSON;
    operation op = parse_op;
    op.name = "parse JSON";
    exercise(&op);
    free(g_text);
}

static void parse_wrong(const char *name, const char *text, rd_scene_format fmt)
{
    g_text = (char *)text;
    g_len = strlen(text);
    g_format = fmt;
    g_source = "<upload>";
    operation op = {name, run_parse, NULL, NULL, release_scene};
    exercise(&op);
}

Test(oom, parse_cfg_unknown_material)
{
    parse_wrong("parse cfg, unknown material",
                "[light]\nposition = 1 2 3\n[material matte]\ntype = diffuse\n[material shiny]\ntype = phong\n"
                "[sphere ball]\ncenter = 0 0 0\nradius = 1\nmaterial = shiny\n"
                "[sphere]\ncenter = 2 0 0\nradius = 1\nmaterial = matt\n",
                RD_FMT_CFG);
}

Test(oom, parse_json_duplicate_key)
{
    parse_wrong("parse JSON, duplicate key",
                "{\"materials\": {\"m\": {\"type\": \"diffuse\"}},\n"
                " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, 0], \"radius\": 1, \"material\": \"m\"},\n"
                "             {\"type\": \"sphere\", \"center\": [0, 0, 0], \"radius\": 1, \"radius\": 2, "
                "\"material\": \"m\"}]}\n",
                RD_FMT_JSON);
}

/* ---- opening, with assets --------------------------------------------------- */

static rd_error_code run_open(result *r, rd_error *err)
{
    rd_scene_source src = {0};
    src.path = g_path;
    rd_scene_init(&r->scene);
    rd_warnings w = {0};
    return rd_scene_open(&src, NULL, NULL, &r->scene, &w, err);
}

Test(oom, open_textured_phong)
{
    g_path = TEXTURED;
    operation op = {"open textured_phong.cfg", run_open, NULL, same_scene, release_scene};
    exercise(&op);
}

Test(oom, open_fixture)
{
    g_path = FIXTURE;
    operation op = {"open scene.cfg", run_open, NULL, same_scene, release_scene};
    exercise(&op);
}

/* A posted scene without files: its assets folder defaults to ".". */
static rd_error_code run_open_text(result *r, rd_error *err)
{
    rd_scene_source src = {0};
    src.text = g_text;
    src.len = g_len;
    src.source = "<upload>";
    rd_scene_init(&r->scene);
    return rd_scene_open(&src, NULL, NULL, &r->scene, NULL, err);
}

Test(oom, open_text)
{
    g_text = "[light]\nposition = 1 2 3\n[material m]\ntype = phong\nshininess = 8\n"
             "[sphere]\ncenter = 0 0 0\nradius = 1\nmaterial = m\n";
    g_len = strlen(g_text);
    operation op = {"open posted text", run_open_text, NULL, same_scene, release_scene};
    exercise(&op);
}

/* ---- rendering -------------------------------------------------------------- */

static rd_error_code run_render(result *r, rd_error *err)
{
    return rd_render(&g_scene, &g_ro, &r->image, &r->stats, err);
}

static void render_test(const char *name, const char *path, int threads, int samples, int adaptive)
{
    open_scene(path, &g_scene);
    g_scene.render.width = 16;
    g_scene.render.height = 12;
    if (samples)
        g_scene.render.samples = samples;
    memset(&g_ro, 0, sizeof g_ro);
    g_ro.threads = threads;
    g_ro.tile = 8;
    if (adaptive) {
        /* Progressive: passes of 2, 2, 4 samples; the target is never met. */
        g_ro.target_error = 1e-12;
        g_ro.adaptive = 1;
    }
    operation op = {name, run_render, render_after_error, same_render, release_render};
    exercise(&op);
    rd_scene_free(&g_scene);
}

Test(oom, render_1_thread) { render_test("render scene.cfg, 1 thread", FIXTURE, 1, 0, 0); }

Test(oom, render_2_threads) { render_test("render textured_phong, 2 threads", TEXTURED, 2, 0, 0); }

Test(oom, render_progressive) { render_test("render progressive, adaptive", FIXTURE, 2, 8, 1); }

/* Spheres and triangles strewn at random (one triangle every fifth
 * sphere; every turn when `spheres` is 0), rendered. */
static void render_strewn(const char *name, int spheres, int turns)
{
    static char text[24576];
    int n = snprintf(text, sizeof text,
                     "[render]\nwidth = 8\nheight = 6\n[light]\nposition = 0 10 10\n"
                     "[material m]\ntype = diffuse\n");
    uint32_t x = 2463534242u;
    double v[4];
    for (int i = 0; i < turns; i++) {
        for (int k = 0; k < 4; k++) {
            x ^= x << 13, x ^= x >> 17, x ^= x << 5;
            v[k] = (double)(x >> 8) / (1u << 24);
        }
        if (spheres)
            n += snprintf(text + n, sizeof text - (size_t)n,
                          "[sphere]\ncenter = %.3f %.3f %.3f\nradius = %.3f\nmaterial = m\n", 6 * v[0] - 3,
                          6 * v[1] - 3, -8 * v[2], 0.05 + 0.25 * v[3]);
        if (!spheres || i % 5 == 0)
            n += snprintf(text + n, sizeof text - (size_t)n,
                          "[triangle]\nv0 = %.3f %.3f %.3f\nv1 = %.3f %.3f %.3f\nv2 = %.3f %.3f %.3f\nmaterial = m\n",
                          6 * v[1] - 3, 6 * v[2] - 3, -8 * v[0], 6 * v[1] - 2.7, 6 * v[2] - 3, -8 * v[0], 6 * v[1] - 3,
                          6 * v[2] - 2.7, -8 * v[3]);
    }
    rd_error err;
    rd_scene_init(&g_scene);
    cr_assert_eq(rd_scene_parse(text, (size_t)n, RD_FMT_CFG, "<strewn>", NULL, &g_scene, &err), RD_OK, "%s",
                 err.message);
    memset(&g_ro, 0, sizeof g_ro);
    g_ro.threads = 1;
    operation op = {name, run_render, render_after_error, same_render, release_render};
    exercise(&op);
    rd_scene_free(&g_scene);
}

/* More BVH nodes than the builder first reserves, so that it grows its
 * node array while it builds; both kinds laid out in leaf order. */
Test(oom, render_many_spheres) { render_strewn("render 125 spheres, 25 triangles", 1, 125); }

/* Triangles alone, which are moved into leaf order in place. */
Test(oom, render_many_triangles) { render_strewn("render 60 triangles", 0, 60); }

/* The job interface that the daemon schedules itself: a job, two
 * progressive passes over its tiles, a copy of the image. */
static rd_error_code run_job(result *r, rd_error *err)
{
    /* Two adaptive passes of 2 samples: an unreachable target error runs
     * them to the cap of 4. */
    rd_job_options jo = {8, {4, 0, 1e-12, 1}, 1, 0, NULL};
    rd_job *j;
    rd_error_code rc = rd_job_create(&g_scene, &jo, &j, err);
    if (rc)
        return rc;
    rd_job_counts c = {0};
    for (int n = rd_job_first_pass(j); n > 0; n = rd_job_end_pass(j))
        for (int t = 0; t < rd_job_tile_count(j); t++)
            rd_job_render_tile(j, t, &c);
    r->stats.camera_rays = c.camera;
    r->stats.shadow_rays = c.shadow;
    r->stats.error_estimate = rd_job_error_estimate(j);
    rd_job_take_image(j, &r->image);
    rd_job_free(j);
    return RD_OK;
}

Test(oom, job)
{
    open_scene(FIXTURE, &g_scene);
    operation op = {"job: passes, tiles, image", run_job, render_after_error, same_render, release_render};
    exercise(&op);
    rd_scene_free(&g_scene);
}

/* ---- images ----------------------------------------------------------------- */

static rd_error_code run_decode(result *r, rd_error *err)
{
    return rd_png_decode((const unsigned char *)g_text, g_len, 1 << 20, "--limit-texture-pixels", &r->png, err);
}

static int same_png(const result *a, const result *b)
{
    const rd_png_image *x = &a->png, *y = &b->png;
    return x->width == y->width && x->height == y->height && x->depth == y->depth && x->maxval == y->maxval &&
           x->had_alpha == y->had_alpha && x->was_palette == y->was_palette && x->was_grey == y->was_grey && x->rgb &&
           y->rgb && !memcmp(x->rgb, y->rgb, (size_t)x->width * x->height * 3 * sizeof *x->rgb);
}

static const char *png_after_error(const result *r) { return r->png.rgb ? "pixels came back" : NULL; }

static void release_png(result *r) { free(r->png.rgb); }

Test(oom, png_decode)
{
    read_text("scenes/textures/checker.png");
    operation op = {"decode PNG", run_decode, png_after_error, same_png, release_png};
    exercise(&op);
    free(g_text);
}

static rd_error_code run_encode(result *r, rd_error *err)
{
    return rd_png_encode(g_rgb8, g_w, g_h, NULL, &r->bytes, &r->len, err);
}

static int same_bytes(const result *a, const result *b)
{
    return a->bytes && b->bytes && a->len == b->len && !memcmp(a->bytes, b->bytes, a->len);
}

static const char *bytes_after_error(const result *r) { return r->bytes || r->len ? "bytes came back" : NULL; }

static void release_bytes(result *r) { free(r->bytes); }

/* 8-bit pixels of a render of path at w x h, into g_rgb8. */
static void render_rgb8(const char *path, int w, int h)
{
    open_scene(path, &g_scene);
    g_scene.render.width = g_w = w;
    g_scene.render.height = g_h = h;
    rd_image img;
    rd_render_stats st;
    rd_error err;
    cr_assert_eq(rd_render(&g_scene, NULL, &img, &st, &err), RD_OK, "%s", err.message);
    g_rgb8 = malloc((size_t)w * h * 3);
    cr_assert(g_rgb8);
    rd_image_to_rgb8(&img, g_scene.render.gamma, g_rgb8);
    rd_image_free(&img);
    rd_scene_free(&g_scene);
}

Test(oom, png_encode)
{
    render_rgb8(FIXTURE, 16, 12);
    operation op = {"encode PNG", run_encode, bytes_after_error, same_bytes, release_bytes};
    exercise(&op);
    free(g_rgb8);
}

/* ---- grading ---------------------------------------------------------------- */

static const char posted[] = "[render]\nwidth = 12\nheight = 9\n"
                             "[camera]\neye = 0 2.5 9\ntarget = 0 1 0\nfov = 40\n"
                             "[light key]\nposition = 6 10 8\n"
                             "[material checker]\ntype = textured_phong\ntexture = textures/checker.png\n"
                             "ks = 0.3 0.3 0.3\nshininess = 30\n"
                             "[sphere]\ncenter = -1.6 1.2 0\nradius = 1.2\nmaterial = checker\n"
                             "[mesh]\nfile = meshes/cube.obj\nscale = 1.4\ntranslate = 1.8 0.7 0.5\n"
                             "material = checker\n"
                             "[plane]\npoint = 0 0 0\nnormal = 0 1 0\nmaterial = checker\n";

/* The posted scene, its student image (the reference with a few pixels
 * off, so that the verdict has something to say) as a PNG, and a grader
 * resolving its files in scenes/. */
static void grading_inputs(void)
{
    rd_error err;
    rd_scene s;
    rd_scene_source src = {0};
    src.text = posted;
    src.len = strlen(posted);
    src.assets_dir = "scenes";
    rd_scene_init(&s);
    cr_assert_eq(rd_scene_open(&src, NULL, NULL, &s, NULL, &err), RD_OK, "%s", err.message);
    rd_image img;
    rd_render_stats st;
    cr_assert_eq(rd_render(&s, NULL, &img, &st, &err), RD_OK, "%s", err.message);
    g_w = img.width;
    g_h = img.height;
    uint8_t *rgb = malloc((size_t)g_w * g_h * 3);
    cr_assert(rgb);
    rd_image_to_rgb8(&img, s.render.gamma, rgb);
    for (int i = 0; i < 7; i++)
        rgb[3 * (13 * i + 5)] ^= (uint8_t)(0x10 << (i % 3));
    rd_image_free(&img);
    rd_scene_free(&s);
    unsigned char *png;
    size_t len;
    cr_assert_eq(rd_png_encode(rgb, g_w, g_h, NULL, &png, &len, &err), RD_OK, "%s", err.message);
    free(rgb);
    memset(&g_in, 0, sizeof g_in);
    g_in.scene_text = posted;
    g_in.scene_len = strlen(posted);
    g_in.source = "<upload>";
    g_in.png = png;
    g_in.png_len = len;
    memset(&g_grader, 0, sizeof g_grader);
    g_grader.assignments_dir = "scenes/assignments";
    g_grader.assets_dir = "scenes";
    g_grader.limits = rd_scene_limits_default();
}

/* Field by field: the structs have padding. */
static int same_verdict(const rd_grade_result *x, const rd_grade_result *y)
{
    return x->pass == y->pass && x->width == y->width && x->height == y->height && x->rmse == y->rmse &&
           x->psnr_db == y->psnr_db && x->ssim == y->ssim && x->max_abs == y->max_abs && x->mean_abs == y->mean_abs &&
           x->failed_pixels == y->failed_pixels && x->failed_fraction == y->failed_fraction &&
           x->hard_pixels == y->hard_pixels && x->worst_x == y->worst_x && x->worst_y == y->worst_y &&
           !memcmp(x->expected, y->expected, 3) && !memcmp(x->got, y->got, 3) && x->has_box == y->has_box &&
           !memcmp(x->box, y->box, sizeof x->box);
}

static int same_output(const rd_grade_output *x, const rd_grade_output *y)
{
    size_t n = (size_t)x->width * x->height * 3;
    const rd_grade_thresholds *a = &x->thresholds, *b = &y->thresholds;
    return x->stage == y->stage && !strcmp(x->key, y->key) && !strcmp(x->assignment, y->assignment) &&
           !strcmp(x->title, y->title) && x->width == y->width && x->height == y->height && x->reference &&
           y->reference && x->image && y->image && !memcmp(x->reference, y->reference, n) &&
           !memcmp(x->image, y->image, n) && same_verdict(&x->result, &y->result) && a->fail == b->fail &&
           a->fail_fraction == b->fail_fraction && a->hard_fail == b->hard_fail &&
           a->hard_fail_pixels == b->hard_fail_pixels;
}

static rd_error_code run_grade(result *r, rd_error *err)
{
    return rd_grade_run(&g_grader, &g_in, 1, &r->grade[0], err);
}

static int same_grade(const result *a, const result *b)
{
    return same_output(&a->grade[0], &b->grade[0]) && a->grade[0].reference_cached == b->grade[0].reference_cached;
}

static void release_grade(result *r)
{
    rd_grade_output_free(&r->grade[0]);
    rd_grade_output_free(&r->grade[1]);
    rd_ref_cache_free(r->cache);
}

Test(oom, grade)
{
    grading_inputs();
    operation op = {"grade a posted scene", run_grade, NULL, same_grade, release_grade};
    exercise(&op);
    free((void *)g_in.png);
}

/* Two grades through one memory cache: the second takes the reference
 * from it. A cache that could not keep a copy only costs the second grade
 * a render, so reference_cached is not compared. */
static rd_error_code run_grade_cached(result *r, rd_error *err)
{
    r->cache = rd_ref_cache_new(1 << 20, NULL, NULL, NULL);
    if (!r->cache)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory (the cache)");
    rd_grader g = g_grader;
    g.cache = r->cache;
    rd_error_code rc = rd_grade_run(&g, &g_in, 1, &r->grade[0], err);
    return rc ? rc : rd_grade_run(&g, &g_in, 1, &r->grade[1], err);
}

static int same_grades(const result *a, const result *b)
{
    return same_output(&a->grade[0], &b->grade[0]) && same_output(&a->grade[1], &b->grade[1]);
}

Test(oom, grade_cached)
{
    grading_inputs();
    operation op = {"grade twice through a cache", run_grade_cached, NULL, same_grades, release_grade};
    exercise(&op);
    free((void *)g_in.png);
}

/* The same through a cache on disk that keeps nothing in memory: the
 * first grade writes the reference as a PNG, the second reads it back.
 * Every run starts with an empty folder. */
static char g_dir[64];

static void empty_dir(void)
{
    DIR *d = opendir(g_dir);
    cr_assert(d);
    struct dirent *e;
    char path[400];
    while ((e = readdir(d)))
        if (e->d_name[0] != '.') {
            snprintf(path, sizeof path, "%s/%s", g_dir, e->d_name);
            unlink(path);
        }
    closedir(d);
}

static rd_error_code run_grade_disk(result *r, rd_error *err)
{
    empty_dir();
    r->cache = rd_ref_cache_new(0, g_dir, NULL, NULL);
    if (!r->cache)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory (the cache)");
    rd_grader g = g_grader;
    g.cache = r->cache;
    rd_error_code rc = rd_grade_run(&g, &g_in, 1, &r->grade[0], err);
    return rc ? rc : rd_grade_run(&g, &g_in, 1, &r->grade[1], err);
}

Test(oom, grade_disk_cache)
{
    grading_inputs();
    snprintf(g_dir, sizeof g_dir, "/tmp/rayd-oom-XXXXXX");
    cr_assert(mkdtemp(g_dir));
    operation op = {"grade twice through a disk cache", run_grade_disk, NULL, same_grades, release_grade};
    exercise(&op);
    empty_dir();
    rmdir(g_dir);
    free((void *)g_in.png);
}

/* The verdict as JSON text, from one grade made without failures. */
static rd_grade_output g_out;

static rd_error_code run_verdict(result *r, rd_error *err)
{
    cJSON *j = rd_grade_json(&g_out);
    r->text = j ? rd_json_print(j) : NULL;
    return r->text ? RD_OK : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
}

Test(oom, verdict_json)
{
    grading_inputs();
    rd_error err;
    cr_assert_eq(rd_grade_run(&g_grader, &g_in, 1, &g_out, &err), RD_OK, "%s", err.message);
    operation op = {"verdict JSON", run_verdict, text_after_error, same_text, release_text};
    exercise(&op);
    rd_grade_output_free(&g_out);
    free((void *)g_in.png);
}

static rd_error_code run_list(result *r, rd_error *err)
{
    return rd_assignment_list("scenes/assignments", &r->list, &r->count, err);
}

static int same_list(const result *a, const result *b)
{
    return a->count == b->count && a->list && b->list && !memcmp(a->list, b->list, a->count * sizeof *a->list);
}

static const char *list_after_error(const result *r) { return r->list || r->count ? "a list came back" : NULL; }

static void release_list(result *r) { free(r->list); }

Test(oom, assignment_list)
{
    operation op = {"list assignments", run_list, list_after_error, same_list, release_list};
    exercise(&op);
}

static const char ROSTER[] = "\xEF\xBB\xBFstudent,name,email\r\ns02,\"Two, B\",b@x\r\ns01,One,a@x\r\n"
                             "yamada,\xE5\xB1\xB1\xE7\x94\xB0,\r\n";

static rd_error_code run_roster(result *r, rd_error *err)
{
    return rd_roster_parse(ROSTER, sizeof ROSTER - 1, "roster.csv", &r->roster, err);
}

static int same_roster(const result *a, const result *b)
{
    if (a->roster.n != b->roster.n)
        return 0;
    for (size_t i = 0; i < a->roster.n; i++)
        if (!same_str(a->roster.e[i].student, b->roster.e[i].student) ||
            !same_str(a->roster.e[i].name, b->roster.e[i].name) ||
            !same_str(a->roster.e[i].email, b->roster.e[i].email))
            return 0;
    return 1;
}

static const char *roster_after_error(const result *r)
{
    return r->roster.e || r->roster.n ? "a roster came back" : NULL;
}

static void release_roster(result *r) { rd_roster_free(&r->roster); }

Test(oom, roster)
{
    operation op = {"read a roster", run_roster, roster_after_error, same_roster, release_roster};
    exercise(&op);
}

/* ---- writing ---------------------------------------------------------------- */

static rd_error_code run_write_cfg(result *r, rd_error *err) { return rd_scene_write_cfg(&g_scene, &r->text, err); }

static rd_error_code run_write_json(result *r, rd_error *err) { return rd_scene_write_json(&g_scene, &r->text, err); }

static void write_test(const char *name, rd_error_code (*run)(result *, rd_error *))
{
    open_scene(FIXTURE, &g_scene);
    operation op = {name, run, text_after_error, same_text, release_text};
    exercise(&op);
    rd_scene_free(&g_scene);
}

Test(oom, write_cfg) { write_test("write cfg", run_write_cfg); }

Test(oom, write_json) { write_test("write JSON", run_write_json); }

static rd_error_code run_schema(result *r, rd_error *err) { return rd_scene_schema(&r->text, err); }

Test(oom, schema)
{
    operation op = {"JSON Schema", run_schema, text_after_error, same_text, release_text};
    exercise(&op);
}

/* A finished render's statistics, with a curve of every pass. */
static rd_render_stats g_stats;

static void progressive_stats(void)
{
    memset(&g_stats, 0, sizeof g_stats);
    g_stats.samples = 16;
    g_stats.passes = RD_CURVE_MAX;
    g_stats.curve_len = RD_CURVE_MAX;
    for (int i = 0; i < RD_CURVE_MAX; i++)
        g_stats.curve[i] = (rd_curve_point){10.0 * i, 2.0 * i, 1.0 / (i + 1)};
    g_stats.stopped_by = RD_STOP_TARGET_ERROR;
}

static rd_error_code run_stats_object(result *r, rd_error *err)
{
    cJSON *o = cJSON_CreateObject();
    if (rd_stats_json(o, &g_stats, RD_STATS_STOPPED | RD_STATS_COSTS | RD_STATS_PROCESS)) {
        cJSON_Delete(o);
        o = NULL;
    }
    r->text = o ? rd_json_print(o) : NULL;
    return r->text ? RD_OK : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
}

static rd_error_code run_job_status(result *r, rd_error *err)
{
    rd_job_status s = {.id = "0123456789abcdef", .status = RD_JQ_DONE, .progress = 1, .stats = g_stats};
    r->text = rd_job_status_json(&s);
    return r->text ? RD_OK : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
}

Test(oom, stats_json)
{
    progressive_stats();
    operation op = {"statistics object", run_stats_object, text_after_error, same_text, release_text};
    exercise(&op);
    operation status = {"job status", run_job_status, text_after_error, same_text, release_text};
    exercise(&status);
}
