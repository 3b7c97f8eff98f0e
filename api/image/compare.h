/* How two 8-bit RGB images of the same size differ, pixel by pixel: the
 * figures `rayd compare` prints and the benchmark reads, in one place so
 * that grading can use them too. Pure functions over buffers the caller
 * owns and keeps; nothing is allocated, nothing can fail. */
#ifndef RD_COMPARE_H
#define RD_COMPARE_H

#include <stddef.h>
#include <stdint.h>

#include "rayd/image.h"

typedef struct {
    size_t pixels;
    /* Root-mean-square difference over every pixel and channel, in output
     * units (1 = 255 levels: the units of rayd's error_estimate). */
    double rmse;
    /* 20·log10(1 / rmse) in dB; +infinity when the images are identical. */
    double psnr_db;
    int max_diff;                   /* largest channel difference, 0..255 */
    size_t differing_pixels;        /* pixels that differ in any channel */
    size_t differing_pixels_over_1; /* of which by more than 1 level in some channel */
    double mean_a, mean_b;          /* each image's mean channel value, 0..1 */
} rd_compare_result;

/* The PSNR that rayd prints, in grade and compare alike: 20·log10(1 /
 * rmse) in dB, at most RD_PSNR_CAP_DB, which identical images (rmse 0)
 * get. JSON has no infinity, and a capped number keeps CSV columns
 * sortable; no two 8-bit images that differ reach it unless they differ in
 * a few channels of a large image, where PSNR says nothing anyway. */
#define RD_PSNR_CAP_DB 99.0
double rd_psnr_db_reported(double rmse);

/* Compares a and b, each pixels·3 bytes (R, G, B per pixel). With no pixels
 * every figure is 0 and psnr_db is +infinity, as for identical images. */
void rd_compare_rgb8(const uint8_t *a, const uint8_t *b, size_t pixels, rd_compare_result *out);

/* The true error of a render against a converged one, in the units of its
 * error_estimate: the RMSE of img's display values (rd_display with gamma)
 * against ref, width·height·3 display values. */
double rd_compare_display_rmse(const rd_image *img, const double *ref, double gamma);

/* Least-squares slope of log(y) against log(x) over the points where both
 * are > 0: how an error falls with samples. NAN with fewer than two. */
double rd_loglog_slope(const double *x, const double *y, int n);

#endif
