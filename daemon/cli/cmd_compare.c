#include <cJSON.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "compare.h"
#include "file_io.h"
#include "grade.h"
#include "json_text.h"

static const char compare_help[] = "usage: rayd compare A.png B.png [--limit-pixels N]\n"
                                   "\n"
                                   "Decodes two PNG images of the same size (any layout: grey, palette, alpha,\n"
                                   "16-bit; compared as 8-bit RGB, alpha dropped) and prints how they differ as\n"
                                   "one JSON object on stdout:\n"
                                   "\n"
                                   "  width, height, pixels\n"
                                   "  rmse              root-mean-square difference over every pixel and channel,\n"
                                   "                    in 0..1 (1 = 255 levels, the units of error_estimate)\n"
                                   "  psnr_db           20·log10(1/rmse) in dB, at most 99, which identical images\n"
                                   "                    get (as in rayd grade)\n"
                                   "  identical         true when every channel of every pixel is equal\n"
                                   "  max_diff          the largest channel difference, 0..255\n"
                                   "  differing_pixels  pixels that differ in any channel\n"
                                   "  differing_pixels_over_1  of which by more than 1 level in some channel\n"
                                   "  mean_a, mean_b    each image's mean channel value, 0..1\n"
                                   "\n"
                                   "  --limit-pixels N  refuse an image of more pixels before decoding it\n"
                                   "                    (default as 'rayd limits'); a file longer than any PNG\n"
                                   "                    of N pixels can be is refused before it is read\n"
                                   "\n"
                                   "Exit status: 0 compared (whatever the result); 1 usage error; 2 not a PNG,\n"
                                   "damaged, over the limit, or the sizes differ; 3 a file could not be read.\n";

/* No PNG of P pixels needs more than 8 bytes a pixel (16-bit RGBA, stored
 * uncompressed) plus a filter byte a row; the rest is room for headers and
 * ancillary chunks, which the decoder skips. */
static size_t file_cap(size_t max_pixels)
{
    size_t room = (size_t)1 << 20;
    return max_pixels > (SIZE_MAX - room) / 9 ? SIZE_MAX : 9 * max_pixels + room;
}

static int load(const char *path, size_t max_pixels, uint8_t **rgb, int *w, int *h)
{
    rd_error err = {0};
    char *data = NULL;
    size_t len = 0;
    rd_error_code rc = rd_read_file(path, file_cap(max_pixels), rd_limit_flag(offsetof(rd_scene_limits, max_pixels)),
                                    &data, &len, &err);
    if (rc) {
        fprintf(stderr, "rayd compare: %s\n", err.message);
        return rc == RD_ERR_IO ? RD_EXIT_IO : RD_EXIT_SCENE;
    }
    rc = rd_grade_load_png((const unsigned char *)data, len, max_pixels, rgb, w, h, &err);
    free(data);
    if (rc) {
        fprintf(stderr, "rayd compare: %s: %s\n", path, err.message);
        return rc == RD_ERR_IO ? RD_EXIT_IO : RD_EXIT_SCENE;
    }
    return RD_EXIT_OK;
}

static char *result_json(int w, int h, const rd_compare_result *r)
{
    cJSON *o = cJSON_CreateObject();
    int ok = o != NULL;
    ok = ok && cJSON_AddNumberToObject(o, "width", w);
    ok = ok && cJSON_AddNumberToObject(o, "height", h);
    ok = ok && cJSON_AddNumberToObject(o, "pixels", (double)r->pixels);
    ok = ok && cJSON_AddNumberToObject(o, "rmse", r->rmse);
    /* The name and the number rayd grade reports (99 for identical images). */
    ok = ok && cJSON_AddNumberToObject(o, "psnr_db", rd_psnr_db_reported(r->rmse));
    ok = ok && cJSON_AddBoolToObject(o, "identical", r->differing_pixels == 0);
    ok = ok && cJSON_AddNumberToObject(o, "max_diff", r->max_diff);
    ok = ok && cJSON_AddNumberToObject(o, "differing_pixels", (double)r->differing_pixels);
    ok = ok && cJSON_AddNumberToObject(o, "differing_pixels_over_1", (double)r->differing_pixels_over_1);
    ok = ok && cJSON_AddNumberToObject(o, "mean_a", r->mean_a);
    ok = ok && cJSON_AddNumberToObject(o, "mean_b", r->mean_b);
    if (!ok) {
        cJSON_Delete(o);
        return NULL;
    }
    return rd_json_print(o);
}

int rd_cmd_compare(int argc, char **argv)
{
    rd_scene_limits lim = rd_scene_limits_default();
    int lrc = rd_cli_take_limits(&argc, argv, &lim, "rayd compare", NULL);
    if (lrc)
        return lrc;
    const char *path[2] = {NULL, NULL};
    int n = 0;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            fputs(compare_help, stdout);
            return RD_EXIT_OK;
        }
        if (argv[i][0] == '-' && argv[i][1] != 0) {
            fprintf(stderr, "rayd compare: unknown option '%s'\n(try 'rayd compare --help')\n", argv[i]);
            return RD_EXIT_USAGE;
        }
        if (n == 2) {
            fprintf(stderr, "rayd compare: expected two images, A.png and B.png, only\n");
            return RD_EXIT_USAGE;
        }
        path[n++] = argv[i];
    }
    if (n != 2) {
        fprintf(stderr, "rayd compare: expected two images, A.png and B.png\n(try 'rayd compare --help')\n");
        return RD_EXIT_USAGE;
    }
    uint8_t *img[2] = {NULL, NULL};
    int w[2], h[2];
    int rc = load(path[0], lim.max_pixels, &img[0], &w[0], &h[0]);
    if (!rc)
        rc = load(path[1], lim.max_pixels, &img[1], &w[1], &h[1]);
    if (!rc && (w[0] != w[1] || h[0] != h[1])) {
        fprintf(stderr, "rayd compare: the sizes differ: %s is %dx%d, %s is %dx%d\n", path[0], w[0], h[0], path[1],
                w[1], h[1]);
        rc = RD_EXIT_SCENE;
    }
    char *text = NULL;
    if (!rc) {
        rd_compare_result r;
        rd_compare_rgb8(img[0], img[1], (size_t)w[0] * (size_t)h[0], &r);
        text = result_json(w[0], h[0], &r);
        if (!text) {
            fprintf(stderr, "rayd compare: out of memory\n");
            rc = RD_EXIT_IO;
        }
    }
    free(img[0]);
    free(img[1]);
    if (text) {
        fputs(text, stdout);
        free(text);
        if (fflush(stdout) != 0)
            rc = RD_EXIT_IO;
    }
    return rc;
}
