/* The linear image as high-dynamic-range files: OpenEXR (through
 * OpenEXRCore) and PFM, the portable float map.
 *
 * Both hold the render's linear radiance as it left the core, before the
 * clamp, gamma and 8-bit rounding of rd_display8: each channel is the
 * core's double rounded to the nearest 32-bit float, nothing else.
 *   EXR: one scanline part, channels R, G, B of 32-bit float, ZIP
 *        compression (lossless), data window 0,0 .. width-1,height-1, top
 *        row first.
 *   PFM: "PF\n<width> <height>\n-1\n", then little-endian floats (the
 *        negative scale says so), RGB, bottom row first as the format has
 *        it.
 *
 * Ownership: on success *out is a malloc'ed buffer of *len bytes that the
 * caller frees; on any error *out is NULL and *len 0. The image is only
 * read. Errors: RD_ERR_INVALID for an empty image, RD_ERR_NOMEM, and for
 * EXR anything else OpenEXRCore reports, as RD_ERR_IO with its message. */
#ifndef RD_HDR_WRITE_H
#define RD_HDR_WRITE_H

#include <stddef.h>

#include "rayd/error.h"
#include "rayd/image.h"

rd_error_code rd_exr_encode(const rd_image *img, unsigned char **out, size_t *len, rd_error *err);

rd_error_code rd_pfm_encode(const rd_image *img, unsigned char **out, size_t *len, rd_error *err);

#endif
