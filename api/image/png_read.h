/* Decoding PNG files of any layout (grey, grey+alpha, palette, RGB, RGBA;
 * 1 to 16 bits; interlaced or not) into RGB, with libpng. */
#ifndef RD_PNG_READ_H
#define RD_PNG_READ_H

#include <stddef.h>
#include <stdint.h>

#include "rayd/error.h"

typedef struct {
    int width, height;
    int depth;       /* 8 or 16: the precision the file carried */
    uint16_t *rgb;   /* 3 per pixel, top row first, in 0..maxval */
    unsigned maxval; /* 255 or 65535 */
    int had_alpha, was_palette, was_grey;
} rd_png_image;

/* Decodes len bytes of PNG into *out (the caller frees out->rgb). Refuses,
 * before allocating pixels, an image of more than max_pixels pixels
 * (RD_ERR_LIMIT naming limit_flag). Alpha is dropped, not composited.
 * RD_ERR_SYNTAX for a file that is not a PNG or is damaged, with libpng's
 * reason; RD_ERR_NOMEM when there is no memory for its pixels. */
rd_error_code rd_png_decode(const unsigned char *data, size_t len, size_t max_pixels, const char *limit_flag,
                            rd_png_image *out, rd_error *err);

/* The largest file a PNG of width x height pixels needs in any layout
 * (16-bit RGBA stored uncompressed, with filter bytes) plus 1 MiB of
 * other chunks: the read limit of a PNG whose size is known. */
size_t rd_png_file_bound(int width, int height);

/* 1 when the bytes begin with the PNG signature. */
int rd_png_sniff(const unsigned char *data, size_t len);

#endif
