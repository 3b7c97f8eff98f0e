/* Reading an EXR back with OpenEXRCore's decoder, for the tests of the
 * EXR writer and of the daemon's EXR answers: an independent reader, the
 * library's own, not rayd's code. */
#ifndef RD_TEST_EXR_READ_H
#define RD_TEST_EXR_READ_H

#include <stddef.h>

/* Decodes an RGB scanline EXR of len bytes into *rgb, malloc'ed
 * width·height·3 floats (top row first, RGB per pixel), which the caller
 * frees. Returns 0, or -1 with *why naming what failed (then *rgb is
 * NULL). */
int exr_read_rgb(const unsigned char *data, size_t len, int *width, int *height, float **rgb, const char **why);

/* Its channel names in file order ("BGR" for B, G, R) and compression
 * (the exr_compression_t value); 0 or -1. */
int exr_read_layout(const unsigned char *data, size_t len, char names[8], int *compression);

#endif
