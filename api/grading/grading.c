#include "grading.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "assignment.h"
#include "png_read.h"
#include "rayd/render.h"
#include "scene_open.h"

void rd_grade_output_free(rd_grade_output *o)
{
    free(o->reference);
    free(o->image);
    o->reference = o->image = NULL;
}

static rd_error_code open_scene(const rd_grader *g, const rd_grade_input *in, rd_scene *s, rd_grade_output *o,
                                rd_error *err)
{
    rd_scene_source src = {0};
    if (in->assignment) {
        o->stage = RD_GRADE_STAGE_ASSIGNMENT;
        rd_assignment a;
        rd_error_code rc = rd_assignment_load(g->assignments_dir, in->assignment, &a, err);
        if (rc)
            return rc;
        snprintf(o->assignment, sizeof o->assignment, "%s", a.name);
        snprintf(o->title, sizeof o->title, "%s", a.title);
        o->thresholds = a.thresholds;
        o->shininess = a.shininess;
        /* Named within the folder: a grade's answer shows no server path. */
        char name[80];
        snprintf(name, sizeof name, "%s.cfg", a.name);
        src.path = a.scene_path;
        src.source = name;
        return rd_scene_open(&src, NULL, &g->limits, s, NULL, err);
    }
    o->stage = RD_GRADE_STAGE_SCENE;
    src.path = in->scene_path;
    src.text = in->scene_text;
    src.len = in->scene_len;
    src.source = in->source;
    src.assets_dir = g->assets_dir;
    return rd_scene_open(&src, in->ov, &g->limits, s, NULL, err);
}

/* Width and height from a PNG's IHDR, which the signature check put at a
 * fixed place: a wrong size is found before anything is decoded. */
static int png_size(const unsigned char *p, size_t len, unsigned *w, unsigned *h)
{
    if (len < 24 || memcmp(p + 12, "IHDR", 4) != 0)
        return 0;
    *w = (unsigned)p[16] << 24 | (unsigned)p[17] << 16 | (unsigned)p[18] << 8 | p[19];
    *h = (unsigned)p[20] << 24 | (unsigned)p[21] << 16 | (unsigned)p[22] << 8 | p[23];
    return 1;
}

static rd_error_code size_mismatch(const rd_grade_input *in, unsigned iw, unsigned ih, const rd_scene *s, rd_error *err)
{
    return rd_error_set(err, RD_ERR_INVALID, 0, 0, "the image is %ux%u; the %s renders %dx%d", iw, ih,
                        in->assignment ? "assignment" : "scene", s->render.width, s->render.height);
}

static rd_error_code open_image(const rd_grader *g, const rd_grade_input *in, const rd_scene *s, rd_grade_output *o,
                                rd_error *err)
{
    o->stage = RD_GRADE_STAGE_IMAGE;
    if (!rd_png_sniff(in->png, in->png_len))
        return rd_error_set(err, RD_ERR_UNSUPPORTED, 0, 0, "the image is not a PNG file");
    unsigned iw, ih;
    if (png_size(in->png, in->png_len, &iw, &ih) &&
        (iw != (unsigned)s->render.width || ih != (unsigned)s->render.height))
        return size_mismatch(in, iw, ih, s, err);
    int w, h;
    rd_error_code rc = rd_grade_load_png(in->png, in->png_len, g->limits.max_pixels, &o->image, &w, &h, err);
    if (rc)
        return rc;
    if (w != s->render.width || h != s->render.height)
        return size_mismatch(in, (unsigned)w, (unsigned)h, s, err);
    o->width = w;
    o->height = h;
    return RD_OK;
}

/* The reference's key, and the reference itself when the cache has it. */
static rd_error_code find_reference(const rd_grader *g, const rd_scene *s, rd_grade_output *o, rd_error *err)
{
    o->stage = RD_GRADE_STAGE_REFERENCE;
    rd_error_code rc = rd_reference_key(s, o->key, err);
    if (rc)
        return rc;
    if (g->cache)
        o->reference = rd_ref_cache_get(g->cache, o->key, o->width, o->height);
    o->reference_cached = o->reference != NULL;
    o->stage = RD_GRADE_STAGE_NONE;
    return RD_OK;
}

rd_error_code rd_grade_prepare(const rd_grader *g, const rd_grade_input *in, rd_scene *s, rd_grade_output *o,
                               rd_error *err)
{
    memset(o, 0, sizeof *o);
    o->thresholds = rd_grade_thresholds_default();
    rd_error_code rc = open_scene(g, in, s, o, err);
    /* The student's image before the reference: a wrong upload should not
     * cost a render. */
    if (!rc)
        rc = open_image(g, in, s, o, err);
    return rc ? rc : find_reference(g, s, o, err);
}

rd_error_code rd_grade_prepare_reference(const rd_grader *g, const rd_grade_input *in, rd_scene *s, rd_grade_output *o,
                                         rd_error *err)
{
    memset(o, 0, sizeof *o);
    o->thresholds = rd_grade_thresholds_default();
    rd_error_code rc = open_scene(g, in, s, o, err);
    if (rc)
        return rc;
    o->width = s->render.width;
    o->height = s->render.height;
    return find_reference(g, s, o, err);
}

rd_error_code rd_grade_set_reference(const rd_grader *g, rd_grade_output *o, const uint8_t *rgb, int w, int h,
                                     rd_error *err)
{
    o->stage = RD_GRADE_STAGE_REFERENCE;
    if (w != o->width || h != o->height)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "the reference is %dx%d, the image %dx%d", w, h, o->width,
                            o->height);
    size_t n = (size_t)w * (size_t)h * 3;
    free(o->reference);
    if (!(o->reference = malloc(n)))
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    memcpy(o->reference, rgb, n);
    if (g->cache)
        rd_ref_cache_put(g->cache, o->key, rgb, w, h);
    o->stage = RD_GRADE_STAGE_NONE;
    return RD_OK;
}

rd_error_code rd_grade_finish(rd_grade_output *o)
{
    return rd_grade_compare(o->reference, o->image, o->width, o->height, &o->thresholds, &o->result);
}

rd_error_code rd_grade_render_reference(const rd_grader *g, const rd_scene *s, int threads, rd_grade_output *o,
                                        rd_error *err)
{
    rd_render_options ro = {0};
    ro.threads = threads;
    rd_image img;
    rd_render_stats st;
    o->stage = RD_GRADE_STAGE_REFERENCE;
    rd_error_code rc = rd_render(s, &ro, &img, &st, err);
    if (rc)
        return rc;
    uint8_t *rgb = malloc((size_t)img.width * (size_t)img.height * 3);
    if (!rgb) {
        rd_image_free(&img);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    }
    rd_image_to_rgb8(&img, s->render.gamma, rgb);
    rc = rd_grade_set_reference(g, o, rgb, img.width, img.height, err);
    free(rgb);
    rd_image_free(&img);
    return rc;
}

rd_error_code rd_grade_run(const rd_grader *g, const rd_grade_input *in, int threads, rd_grade_output *o, rd_error *err)
{
    rd_scene s;
    rd_scene_init(&s);
    rd_error_code rc = rd_grade_prepare(g, in, &s, o, err);
    if (!rc && !o->reference)
        rc = rd_grade_render_reference(g, &s, threads, o, err);
    rd_scene_free(&s);
    if (!rc && rd_grade_finish(o))
        rc = rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory comparing the images");
    return rc;
}

static int add_number(cJSON *o, const char *name, double v) { return cJSON_AddNumberToObject(o, name, v) != NULL; }

static int add_metrics(cJSON *root, const rd_grade_result *r)
{
    cJSON *m = cJSON_AddObjectToObject(root, "metrics");
    return m && add_number(m, "rmse", r->rmse) && add_number(m, "psnr_db", r->psnr_db) &&
           add_number(m, "ssim", r->ssim) && add_number(m, "max_abs", r->max_abs) &&
           add_number(m, "mean_abs", r->mean_abs) && add_number(m, "failed_pixels", (double)r->failed_pixels) &&
           add_number(m, "failed_fraction", r->failed_fraction) &&
           add_number(m, "hard_failed_pixels", (double)r->hard_pixels);
}

static int add_thresholds(cJSON *root, const rd_grade_thresholds *th)
{
    cJSON *t = cJSON_AddObjectToObject(root, "thresholds");
    return t && add_number(t, "fail", th->fail) && add_number(t, "fail_fraction", th->fail_fraction) &&
           add_number(t, "hard_fail", th->hard_fail) && add_number(t, "hard_fail_pixels", th->hard_fail_pixels);
}

static int add_int_array(cJSON *o, const char *name, const int *v, int n)
{
    cJSON *a = cJSON_CreateIntArray(v, n);
    if (a && !cJSON_AddItemToObject(o, name, a)) {
        cJSON_Delete(a);
        return 0;
    }
    return a != NULL;
}

/* null when no pixel differs: a perfect grade has no worst pixel, and (0, 0)
 * would read as one. */
static int add_worst(cJSON *root, const rd_grade_result *r)
{
    if (r->max_abs == 0)
        return cJSON_AddNullToObject(root, "worst") != NULL;
    cJSON *w = cJSON_AddObjectToObject(root, "worst");
    int e[3] = {r->expected[0], r->expected[1], r->expected[2]}, g[3] = {r->got[0], r->got[1], r->got[2]};
    return w && add_number(w, "x", r->worst_x) && add_number(w, "y", r->worst_y) &&
           add_int_array(w, "expected", e, 3) && add_int_array(w, "got", g, 3);
}

cJSON *rd_grade_json(const rd_grade_output *o)
{
    const rd_grade_result *r = &o->result;
    cJSON *root = cJSON_CreateObject();
    int ok = root != NULL;
    ok = ok && (o->assignment[0] ? cJSON_AddStringToObject(root, "assignment", o->assignment)
                                 : cJSON_AddNullToObject(root, "assignment"));
    ok = ok && (!o->title[0] || cJSON_AddStringToObject(root, "title", o->title));
    ok = ok && cJSON_AddBoolToObject(root, "pass", r->pass) && add_number(root, "width", r->width) &&
         add_number(root, "height", r->height);
    ok = ok && add_metrics(root, r) && add_thresholds(root, &o->thresholds) && add_worst(root, r);
    ok = ok && (r->has_box ? add_int_array(root, "failed_box", r->box, 4)
                           : cJSON_AddNullToObject(root, "failed_box") != NULL);
    ok = ok && cJSON_AddBoolToObject(root, "reference_cached", o->reference_cached);
    if (!ok) {
        cJSON_Delete(root);
        return NULL;
    }
    return root;
}
