/* Comparing a student's image with the reference (grading.md). All images
 * are 8-bit RGB, rows top first, 3 bytes per pixel. */
#ifndef RD_GRADE_H
#define RD_GRADE_H

#include <stddef.h>
#include <stdint.h>

#include "rayd/error.h"

typedef struct {
    int fail;             /* a pixel fails when its difference exceeds this (8-bit steps) */
    double fail_fraction; /* the image fails when more than this fraction of pixels fail */
    int hard_fail;        /* a difference above this is a hard failure ... */
    int hard_fail_pixels; /* ... and more than this many hard failures fail the image */
} rd_grade_thresholds;

/* The calibrated defaults (docs/grading.md explains how). */
rd_grade_thresholds rd_grade_thresholds_default(void);

typedef struct {
    int pass;
    int width, height;
    double rmse;          /* over all channels, 1 = 255 levels */
    double psnr_db;       /* 20·log10(1/rmse); 99 for identical images */
    double ssim;          /* Wang et al. 2004 on luminance, Gaussian 11x11, σ = 1.5 */
    int max_abs;          /* largest pixel difference, 8-bit steps */
    double mean_abs;      /* mean pixel difference, 8-bit steps */
    size_t failed_pixels; /* difference > fail */
    double failed_fraction;
    size_t hard_pixels;   /* difference > hard_fail */
    int worst_x, worst_y; /* first pixel with the largest difference */
    uint8_t expected[3], got[3];
    int has_box;
    int box[4]; /* x0, y0, x1, y1 (inclusive) of failed pixels */
} rd_grade_result;

/* A pixel's difference: the largest absolute difference over R, G, B. */
static inline int rd_pixel_diff(const uint8_t *a, const uint8_t *b)
{
    int m = 0;
    for (int c = 0; c < 3; c++) {
        int d = a[c] > b[c] ? a[c] - b[c] : b[c] - a[c];
        m = d > m ? d : m;
    }
    return m;
}

/* RD_ERR_NOMEM when there is no memory for SSIM's luminance planes (out's
 * ssim is then NaN). */
rd_error_code rd_grade_compare(const uint8_t *ref, const uint8_t *img, int width, int height,
                               const rd_grade_thresholds *t, rd_grade_result *out);

/* SSIM of the two images' luminance (Y = 0.299 R + 0.587 G + 0.114 B),
 * mean over every 11x11 window inside the image (smaller images: one window
 * of their size). NaN when out of memory. */
double rd_ssim(const uint8_t *a, const uint8_t *b, int width, int height);

/* The diff heat map: the reference in grey, failed pixels coloured by the
 * size of their difference (yellow just above `fail`, through orange and red
 * to magenta at 255). out: width·height·3 bytes. */
void rd_grade_heatmap(const uint8_t *ref, const uint8_t *img, int width, int height, int fail, uint8_t *out);

/* Decodes a student's PNG of any layout into 8-bit RGB (16-bit rounded,
 * alpha dropped, grey and palette expanded). RD_ERR_SYNTAX: not a PNG or
 * damaged. *out is malloc'ed. */
rd_error_code rd_grade_load_png(const unsigned char *data, size_t len, size_t max_pixels, uint8_t **out, int *width,
                                int *height, rd_error *err);

#endif
