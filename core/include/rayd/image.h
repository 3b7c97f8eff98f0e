/* A rendered image in linear colour, and the one rule that turns it into
 * the 8-bit values every output (PNG, grading, the daemon's partial
 * images) is made of.
 *
 * Ownership: whoever fills an rd_image (rd_render, rd_job_take_image)
 * allocates rgb; the holder frees it with rd_image_free. */
#ifndef RD_IMAGE_H
#define RD_IMAGE_H

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

/* The 8-bit value of one channel: floor(display·255 + 0.5). */
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

#endif
