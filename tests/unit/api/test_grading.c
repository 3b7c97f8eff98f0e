/* Grading without the daemon (api/grading/): the metrics against their
 * formulas, the heat map's colours, the verdict JSON, the reference cache
 * (memory, disk, eviction, accounting) and the pipeline's stages. */
#include <criterion/criterion.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "file_io.h"
#include "grade.h"
#include "grading.h"
#include "png_write.h"
#include "reference.h"

/* A w x h image whose pixels follow a fixed pattern, different per seed. */
static uint8_t *pattern(int w, int h, unsigned seed)
{
    uint8_t *p = malloc((size_t)w * h * 3);
    cr_assert(p);
    uint32_t x = 2463534242u ^ seed;
    for (int i = 0; i < w * h * 3; i++) {
        x ^= x << 13, x ^= x >> 17, x ^= x << 5;
        p[i] = (uint8_t)(x >> 24);
    }
    return p;
}

static uint8_t *flat(int w, int h, uint8_t v)
{
    uint8_t *p = malloc((size_t)w * h * 3);
    cr_assert(p);
    memset(p, v, (size_t)w * h * 3);
    return p;
}

Test(grading, ssim_of_identical_images_is_one)
{
    uint8_t *a = pattern(23, 17, 1);
    cr_assert_float_eq(rd_ssim(a, a, 23, 17), 1.0, 1e-12);
    free(a);
}

/* Flat images have no variance: SSIM is the luminance term alone,
 * (2ab + C1) / (a² + b² + C1) with C1 = (0.01·255)². */
Test(grading, ssim_of_flat_images_is_the_luminance_term)
{
    uint8_t *a = flat(16, 16, 100), *b = flat(16, 16, 140);
    double ya = 100 * (0.299 + 0.587 + 0.114), yb = 140 * (0.299 + 0.587 + 0.114), c1 = 2.55 * 2.55;
    double want = (2 * ya * yb + c1) / (ya * ya + yb * yb + c1);
    cr_assert_float_eq(rd_ssim(a, b, 16, 16), want, 1e-9);
    free(a);
    free(b);
}

Test(grading, ssim_is_symmetric_and_falls_with_noise)
{
    int w = 32, h = 24;
    uint8_t *a = pattern(w, h, 2), *noise = pattern(w, h, 3);
    double last = 1.0;
    for (int amp = 8; amp <= 128; amp *= 2) {
        uint8_t *b = malloc((size_t)w * h * 3);
        cr_assert(b);
        for (int i = 0; i < w * h * 3; i++) {
            int v = a[i] + (noise[i] * amp / 255) - amp / 2;
            b[i] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
        }
        double s = rd_ssim(a, b, w, h);
        cr_assert_float_eq(s, rd_ssim(b, a, w, h), 1e-12, "not symmetric at amplitude %d", amp);
        cr_assert_lt(s, last, "SSIM %g at amplitude %d, not below %g", s, amp, last);
        last = s;
        free(b);
    }
    free(a);
    free(noise);
}

/* One channel of one pixel of four off by 51 = 0.2: RMSE = sqrt(0.2² / 12). */
Test(grading, compare_gives_the_formulas_values)
{
    uint8_t *ref = flat(2, 2, 100), *img = flat(2, 2, 100);
    img[3 * 3 + 1] = 151; /* pixel (1, 1), green */
    rd_grade_thresholds t = rd_grade_thresholds_default();
    rd_grade_result r;
    rd_grade_compare(ref, img, 2, 2, &t, &r);
    cr_assert_float_eq(r.rmse, 0.2 / sqrt(12.0), 1e-12);
    cr_assert_float_eq(r.psnr_db, 20 * log10(sqrt(12.0) / 0.2), 1e-9);
    cr_assert_eq(r.max_abs, 51);
    cr_assert_float_eq(r.mean_abs, 51 / 4.0, 1e-12);
    cr_assert_eq(r.failed_pixels, 1);
    cr_assert_eq(r.hard_pixels, 1);
    cr_assert_eq(r.worst_x, 1);
    cr_assert_eq(r.worst_y, 1);
    cr_assert_eq(r.got[1], 151);
    cr_assert(r.has_box);
    cr_assert_eq(r.box[0], 1);
    cr_assert_eq(r.box[3], 1);
    cr_assert_not(r.pass, "a quarter of the pixels failed");
    free(ref);
    free(img);
}

Test(grading, heat_map_colours)
{
    /* Pixel 0 within the threshold, 1 just over it, 2 as far off as can be. */
    uint8_t ref[9] = {100, 150, 200, 0, 0, 0, 0, 0, 0}, img[9] = {102, 150, 200, 4, 0, 0, 255, 0, 0};
    uint8_t out[9];
    rd_grade_heatmap(ref, img, 3, 1, 3, out);
    uint8_t grey = (uint8_t)(40 + (0.299 * 100 + 0.587 * 150 + 0.114 * 200) * 0.5);
    cr_assert(out[0] == grey && out[1] == grey && out[2] == grey, "within: %d %d %d, not grey %d", out[0], out[1],
              out[2], grey);
    cr_assert(out[3] == 255 && out[4] > 200 && out[5] == 0, "just over: %d %d %d, not yellow", out[3], out[4], out[5]);
    cr_assert(out[6] == 215 && out[7] == 0 && out[8] == 220, "255 off: %d %d %d, not magenta", out[6], out[7], out[8]);
}

static double number(const cJSON *o, const char *path0, const char *path1)
{
    const cJSON *n = cJSON_GetObjectItem(o, path0);
    if (path1)
        n = cJSON_GetObjectItem(n, path1);
    cr_assert(cJSON_IsNumber(n), "%s.%s is not a number", path0, path1 ? path1 : "");
    return n->valuedouble;
}

Test(grading, verdict_json_has_every_field)
{
    rd_grade_output o;
    memset(&o, 0, sizeof o);
    o.thresholds = rd_grade_thresholds_default();
    uint8_t *ref = flat(2, 2, 100), *img = flat(2, 2, 100);
    img[0] = 120;
    rd_grade_compare(ref, img, 2, 2, &o.thresholds, &o.result);
    o.reference_cached = 1;
    cJSON *v = rd_grade_json(&o);
    cr_assert(v);
    cr_assert(cJSON_IsNull(cJSON_GetObjectItem(v, "assignment")), "a given scene has assignment null");
    cr_assert_null(cJSON_GetObjectItem(v, "title"), "no title, no field");
    cr_assert(cJSON_IsFalse(cJSON_GetObjectItem(v, "pass")));
    cr_assert(cJSON_IsTrue(cJSON_GetObjectItem(v, "reference_cached")));
    cr_assert_eq(number(v, "width", NULL), 2);
    cr_assert_float_eq(number(v, "metrics", "rmse"), o.result.rmse, 1e-15);
    cr_assert_float_eq(number(v, "metrics", "ssim"), o.result.ssim, 1e-15);
    cr_assert_eq(number(v, "metrics", "max_abs"), 20);
    cr_assert_eq(number(v, "metrics", "failed_pixels"), 1);
    cr_assert_eq(number(v, "thresholds", "fail"), 3);
    cr_assert_eq(number(v, "thresholds", "hard_fail_pixels"), 16);
    cr_assert_eq(number(v, "worst", "x"), 0);
    const cJSON *got = cJSON_GetObjectItem(cJSON_GetObjectItem(v, "worst"), "got");
    cr_assert(cJSON_IsArray(got) && cJSON_GetArraySize(got) == 3 && cJSON_GetArrayItem(got, 0)->valueint == 120);
    const cJSON *box = cJSON_GetObjectItem(v, "failed_box");
    cr_assert(cJSON_IsArray(box) && cJSON_GetArraySize(box) == 4);
    cJSON_Delete(v);

    /* Identical: no failed box; an assignment's name and title. */
    snprintf(o.assignment, sizeof o.assignment, "phong");
    snprintf(o.title, sizeof o.title, "Phong");
    rd_grade_compare(ref, ref, 2, 2, &o.thresholds, &o.result);
    v = rd_grade_json(&o);
    cr_assert(v);
    cr_assert_str_eq(cJSON_GetObjectItem(v, "assignment")->valuestring, "phong");
    cr_assert_str_eq(cJSON_GetObjectItem(v, "title")->valuestring, "Phong");
    cr_assert(cJSON_IsNull(cJSON_GetObjectItem(v, "failed_box")));
    cr_assert(cJSON_IsTrue(cJSON_GetObjectItem(v, "pass")));
    cr_assert_eq(number(v, "metrics", "psnr_db"), 99);
    cr_assert(cJSON_IsNull(cJSON_GetObjectItem(v, "worst")), "no pixel differs: no worst pixel, not (0, 0)");
    cJSON_Delete(v);
    free(ref);
    free(img);
}

/* What on_bytes heard, to compare with what the cache says it holds. */
static void heard(void *user, long long delta) { *(long long *)user += delta; }

Test(grading, ref_cache_keeps_the_most_recently_used_within_its_bytes)
{
    long long told = 0;
    /* 10x10 references are 300 bytes: two fit, not three. */
    rd_ref_cache *c = rd_ref_cache_new(700, NULL, heard, &told);
    cr_assert(c);
    uint8_t *a = pattern(10, 10, 1), *b = pattern(10, 10, 2), *d = pattern(10, 10, 3);
    rd_ref_cache_put(c, "aaaaaaaaaaaaaaaa", a, 10, 10);
    rd_ref_cache_put(c, "bbbbbbbbbbbbbbbb", b, 10, 10);
    uint8_t *got = rd_ref_cache_get(c, "aaaaaaaaaaaaaaaa", 10, 10); /* a is now the most recent */
    cr_assert(got && memcmp(got, a, 300) == 0);
    free(got);
    rd_ref_cache_put(c, "dddddddddddddddd", d, 10, 10);
    cr_assert_eq(rd_ref_cache_bytes(c), 600);
    cr_assert_eq(told, 600, "on_bytes heard %lld, the cache holds 600", told);
    cr_assert_null(rd_ref_cache_get(c, "bbbbbbbbbbbbbbbb", 10, 10), "the least recently used was kept");
    got = rd_ref_cache_get(c, "aaaaaaaaaaaaaaaa", 10, 10);
    cr_assert(got, "the most recently used was dropped");
    free(got);
    cr_assert_null(rd_ref_cache_get(c, "aaaaaaaaaaaaaaaa", 10, 11), "a reference of another size was found");
    rd_ref_cache_set_max_bytes(c, 300);
    cr_assert_eq(rd_ref_cache_bytes(c), 300);
    cr_assert_eq(told, 300);
    rd_ref_cache_set_max_bytes(c, 0);
    cr_assert_eq(told, 0);
    rd_ref_cache_free(c);
    free(a);
    free(b);
    free(d);
}

Test(grading, ref_cache_on_disk_survives_the_process_and_refuses_bad_files)
{
    char dir[] = "/tmp/rayd-ref-cache-XXXXXX";
    cr_assert(mkdtemp(dir));
    uint8_t *a = pattern(12, 9, 4);
    rd_ref_cache *c = rd_ref_cache_new(0, dir, NULL, NULL); /* memory holds nothing */
    cr_assert(c);
    rd_ref_cache_put(c, "0123456789abcdef", a, 12, 9);
    cr_assert_eq(rd_ref_cache_bytes(c), 0);
    rd_ref_cache_free(c);

    c = rd_ref_cache_new(1 << 20, dir, NULL, NULL);
    cr_assert(c);
    uint8_t *got = rd_ref_cache_get(c, "0123456789abcdef", 12, 9);
    cr_assert(got && memcmp(got, a, 12 * 9 * 3) == 0, "the reference did not come back from disk intact");
    free(got);
    cr_assert_eq(rd_ref_cache_bytes(c), 12 * 9 * 3, "a reference read from disk is kept in memory");
    cr_assert_null(rd_ref_cache_get(c, "0123456789abcdef", 9, 12), "a file of another size was taken");

    char path[200];
    snprintf(path, sizeof path, "%s/fedcba9876543210.png", dir);
    rd_error err;
    cr_assert_eq(rd_write_file(path, "\x89PNG\r\n\x1a\nnot really", 18, &err), RD_OK);
    cr_assert_null(rd_ref_cache_get(c, "fedcba9876543210", 12, 9), "a damaged file was taken");
    rd_ref_cache_free(c);
    remove(path);
    snprintf(path, sizeof path, "%s/0123456789abcdef.png", dir);
    remove(path);
    rmdir(dir);
    free(a);
}

static rd_grader grader(rd_ref_cache *cache)
{
    rd_grader g = {.assignments_dir = "scenes/assignments", .limits = rd_scene_limits_default(), .cache = cache};
    return g;
}

static rd_error_code prepare(const rd_grader *g, const char *assignment, const unsigned char *png, size_t len,
                             rd_grade_output *o, rd_error *err)
{
    rd_grade_input in = {.assignment = assignment, .png = png, .png_len = len};
    rd_scene s;
    rd_scene_init(&s);
    rd_error_code rc = rd_grade_prepare(g, &in, &s, o, err);
    rd_scene_free(&s);
    return rc;
}

Test(grading, each_failure_names_its_stage)
{
    rd_grader g = grader(NULL);
    rd_grade_output o;
    rd_error err;
    static const unsigned char not_png[] = "GIF89a, not a PNG";
    cr_assert_eq(prepare(&g, "nosuch", not_png, sizeof not_png, &o, &err), RD_ERR_NOT_FOUND);
    cr_assert_eq(o.stage, RD_GRADE_STAGE_ASSIGNMENT);
    rd_grade_output_free(&o);
    cr_assert_eq(prepare(&g, "phong", not_png, sizeof not_png, &o, &err), RD_ERR_UNSUPPORTED);
    cr_assert_eq(o.stage, RD_GRADE_STAGE_IMAGE);
    rd_grade_output_free(&o);
    /* A PNG signature and an IHDR of 4x3, where phong renders 320x240. */
    static const unsigned char small[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0,
                                          13,   'I', 'H', 'D', 'R',  0,    0,    0,    4, 0, 0,
                                          0,    3,   8,   2,   0,    0,    0,    0,    0, 0, 0};
    cr_assert_eq(prepare(&g, "phong", small, sizeof small, &o, &err), RD_ERR_INVALID);
    cr_assert_eq(o.stage, RD_GRADE_STAGE_IMAGE);
    cr_assert(strstr(err.message, "4x3") && strstr(err.message, "320x240"), "%s", err.message);
    rd_grade_output_free(&o);
}

/* rayd grade's path: the first grade renders and caches, the second finds
 * the reference, and both give the same verdict for the reference itself. */
Test(grading, the_pipeline_renders_once_and_passes_the_reference)
{
    rd_ref_cache *cache = rd_ref_cache_new(16 << 20, NULL, NULL, NULL);
    cr_assert(cache);
    rd_grader g = grader(cache);
    rd_grade_output o;
    rd_error err;
    /* The student's image: any 320x240 PNG, to get the reference. */
    uint8_t *grey = flat(320, 240, 128);
    rd_png_options po = rd_png_options_default();
    unsigned char *png;
    size_t len;
    cr_assert_eq(rd_png_encode(grey, 320, 240, &po, &png, &len, &err), RD_OK);
    rd_grade_input in = {.assignment = "phong", .png = png, .png_len = len};
    cr_assert_eq(rd_grade_run(&g, &in, 2, &o, &err), RD_OK, "%s", err.message);
    cr_assert_not(o.reference_cached);
    cr_assert_not(o.result.pass, "a grey image passed");
    unsigned char *ref_png;
    size_t ref_len;
    cr_assert_eq(rd_png_encode(o.reference, 320, 240, &po, &ref_png, &ref_len, &err), RD_OK);
    rd_grade_output_free(&o);
    free(png);

    in.png = ref_png;
    in.png_len = ref_len;
    cr_assert_eq(rd_grade_run(&g, &in, 2, &o, &err), RD_OK, "%s", err.message);
    cr_assert(o.reference_cached, "the second grade rendered again");
    cr_assert(o.result.pass);
    cr_assert_eq(o.result.max_abs, 0);
    cr_assert_eq(o.stage, RD_GRADE_STAGE_NONE);
    rd_grade_output_free(&o);
    free(ref_png);
    free(grey);
    rd_ref_cache_free(cache);
}
