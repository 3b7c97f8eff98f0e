#include "grading.h"

#include <cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "asset_source.h"
#include "assignment.h"
#include "png_read.h"
#include "reference.h"
#include "scene_assets.h"
#include "scene_load.h"
#include "file_io.h"

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

void rd_grade_output_free(rd_grade_output *o)
{
    free(o->reference);
    free(o->image);
    o->reference = o->image = NULL;
}

rd_error_code rd_grade_run(const rd_grader *g, const char *name, const char *scene_text, size_t scene_len,
                           const char *source, const unsigned char *png, size_t png_len, rd_grade_output *out,
                           rd_error *err)
{
    memset(out, 0, sizeof *out);
    out->thresholds = rd_grade_thresholds_default();
    rd_scene s;
    rd_scene_init(&s);
    rd_error_code rc;
    char *dir = NULL;
    if (name) {
        rd_assignment a;
        rc = rd_assignment_load(g->assignments_dir, name, &a, err);
        if (rc) {
            out->status = rc == RD_ERR_IO ? RD_GRADE_UNKNOWN_ASSIGNMENT : RD_GRADE_FAILED;
            return rc;
        }
        snprintf(out->assignment, sizeof out->assignment, "%s", a.name);
        snprintf(out->title, sizeof out->title, "%s", a.title);
        out->thresholds = a.thresholds;
        rc = rd_scene_load_file(a.scene_path, &g->limits, &s, err);
        dir = rd_dirname(a.scene_path);
    } else {
        rc = rd_scene_parse(scene_text, scene_len, RD_FMT_AUTO, source, &g->limits, &s, err);
        dir = strdup(g->assets_dir ? g->assets_dir : ".");
    }
    if (!rc)
        rc = rd_scene_check_limits(&s, &g->limits, source ? source : name, err);
    if (!rc) {
        rd_asset_source src = rd_asset_folder(dir ? dir : ".");
        rc = rd_scene_load_assets(&s, &src, &g->limits, NULL, err);
    }
    free(dir);
    if (rc) {
        out->status = RD_GRADE_BAD_SCENE;
        rd_scene_free(&s);
        return rc;
    }
    /* The student's image first: a wrong upload should not cost a render. */
    if (!rd_png_sniff(png, png_len)) {
        rd_scene_free(&s);
        out->status = RD_GRADE_NOT_PNG;
        return rd_error_set(err, RD_ERR_SYNTAX, 0, 0, "the image is not a PNG file");
    }
    int iw, ih;
    rc = rd_grade_load_png(png, png_len, g->limits.max_pixels, &out->image, &iw, &ih, err);
    if (rc) {
        rd_scene_free(&s);
        out->status = rc == RD_ERR_LIMIT ? RD_GRADE_SIZE_MISMATCH : RD_GRADE_BAD_PNG;
        return rc;
    }
    if (iw != s.render.width || ih != s.render.height) {
        out->status = RD_GRADE_SIZE_MISMATCH;
        rc = rd_error_set(err, RD_ERR_INVALID, 0, 0, "the image is %dx%d; the %s renders %dx%d", iw, ih,
                          name ? "assignment" : "scene", s.render.width, s.render.height);
        rd_scene_free(&s);
        rd_grade_output_free(out);
        return rc;
    }
    double t0 = now_ms();
    int w, h;
    rc = rd_reference_get(&s, g->cache_dir, g->threads, &out->reference, &w, &h, &out->reference_cached, err);
    out->reference_ms = now_ms() - t0;
    rd_scene_free(&s);
    if (rc) {
        out->status = RD_GRADE_FAILED;
        rd_grade_output_free(out);
        return rc;
    }
    out->width = w;
    out->height = h;
    rd_grade_compare(out->reference, out->image, w, h, &out->thresholds, &out->result);
    out->status = RD_GRADE_OK;
    return RD_OK;
}

char *rd_grade_json(const rd_grade_output *o, const char *diff_url)
{
    const rd_grade_result *r = &o->result;
    cJSON *root = cJSON_CreateObject();
    if (o->assignment[0])
        cJSON_AddStringToObject(root, "assignment", o->assignment);
    else
        cJSON_AddNullToObject(root, "assignment");
    if (o->title[0])
        cJSON_AddStringToObject(root, "title", o->title);
    cJSON_AddBoolToObject(root, "pass", r->pass);
    cJSON_AddNumberToObject(root, "width", r->width);
    cJSON_AddNumberToObject(root, "height", r->height);
    cJSON *m = cJSON_AddObjectToObject(root, "metrics");
    cJSON_AddNumberToObject(m, "rmse", r->rmse);
    cJSON_AddNumberToObject(m, "psnr_db", r->psnr_db);
    cJSON_AddNumberToObject(m, "ssim", r->ssim);
    cJSON_AddNumberToObject(m, "max_abs", r->max_abs);
    cJSON_AddNumberToObject(m, "mean_abs", r->mean_abs);
    cJSON_AddNumberToObject(m, "failed_pixels", (double)r->failed_pixels);
    cJSON_AddNumberToObject(m, "failed_fraction", r->failed_fraction);
    cJSON_AddNumberToObject(m, "hard_failed_pixels", (double)r->hard_pixels);
    cJSON *t = cJSON_AddObjectToObject(root, "thresholds");
    cJSON_AddNumberToObject(t, "fail", o->thresholds.fail);
    cJSON_AddNumberToObject(t, "fail_fraction", o->thresholds.fail_fraction);
    cJSON_AddNumberToObject(t, "hard_fail", o->thresholds.hard_fail);
    cJSON_AddNumberToObject(t, "hard_fail_pixels", o->thresholds.hard_fail_pixels);
    cJSON *wst = cJSON_AddObjectToObject(root, "worst");
    cJSON_AddNumberToObject(wst, "x", r->worst_x);
    cJSON_AddNumberToObject(wst, "y", r->worst_y);
    int e[3] = {r->expected[0], r->expected[1], r->expected[2]}, g[3] = {r->got[0], r->got[1], r->got[2]};
    cJSON_AddItemToObject(wst, "expected", cJSON_CreateIntArray(e, 3));
    cJSON_AddItemToObject(wst, "got", cJSON_CreateIntArray(g, 3));
    if (r->has_box)
        cJSON_AddItemToObject(root, "failed_box", cJSON_CreateIntArray(r->box, 4));
    else
        cJSON_AddNullToObject(root, "failed_box");
    if (diff_url)
        cJSON_AddStringToObject(root, "diff_url", diff_url);
    char *text = cJSON_Print(root);
    cJSON_Delete(root);
    return text;
}
