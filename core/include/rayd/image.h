/* A rendered image in linear colour, and the one rule that turns it into
 * the 8-bit values every output (PNG, grading, the daemon's partial
 * images) is made of.
 *
 * Ownership: whoever fills an rd_image (rd_render, rd_job_take_image)
 * allocates rgb; the holder frees it with rd_image_free. */
#ifndef RD_IMAGE_H
#define RD_IMAGE_H

#include <stddef.h>
#include <stdint.h>

#include "rayd/vec3.h"

typedef struct {
    int width, height;
    double *rgb; /* linear colour, row-major, 3 per pixel, top row first */
} rd_image;

/* Frees rgb and leaves an empty image; safe on an empty one. */
void rd_image_free(rd_image *img);

/* Display value of one channel: clamp to [0,1], then ^(1/gamma). */
double rd_display(double c, double gamma);

/* The 8-bit value of one channel: floor(display·255 + 0.5); 0 for NaN. */
uint8_t rd_display8(double c, double gamma);

/* rd_display8(c, 1) without the library's floor, a call per channel:
 * floor of a value in [0.5, 255.5] is its truncation. */
static inline uint8_t rd_display8_linear(double c)
{
    return c == c ? (uint8_t)(rd_clamp01(c) * 255.0 + 0.5) : rd_display8(c, 1);
}

/* 8-bit RGB, 3 bytes per pixel, rd_display8 of each channel. out holds
 * width·height·3 bytes. */
void rd_image_to_rgb8(const rd_image *img, double gamma, uint8_t *out);

/* rd_display8 of many values of one gamma, in pieces, as rd_image_to_rgb8
 * converts them whole: a table of the 255 steps stands in for pow.
 * rd_display_table_new makes the one rd_image_to_rgb8 would use for n
 * values, or gives NULL where it would use none (gamma 1, fewer than 65536
 * values) or when out of memory; the bytes are the same either way. The
 * caller frees it with free(). */
typedef struct rd_display_table rd_display_table;
rd_display_table *rd_display_table_new(double gamma, size_t n);

/* out[i] = rd_display8(in[i], gamma) for i < n; t is NULL or the table of
 * this gamma, and is only read (threads may share it). */
void rd_display8_many(const rd_display_table *t, double gamma, const double *in, size_t n, uint8_t *out);

#endif
