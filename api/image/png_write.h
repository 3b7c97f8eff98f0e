/* PNG encoding of 8-bit RGB images with libpng. */
#ifndef RD_PNG_WRITE_H
#define RD_PNG_WRITE_H

#include <stddef.h>
#include <stdint.h>

#include "rayd/error.h"

typedef struct {
    int level;  /* zlib level 0..9 */
    int filter; /* one of RD_PNG_FILTER_* */
} rd_png_options;

enum { RD_PNG_FILTER_NONE, RD_PNG_FILTER_SUB, RD_PNG_FILTER_ALL };

/* zlib level 1 with the SUB filter: small renders are dominated by
 * encoding, and this is several times faster than libpng's default for a
 * modestly larger file. */
rd_png_options rd_png_options_default(void);

/* Encodes width·height·3 bytes of RGB (rows top first) as an 8-bit RGB,
 * non-interlaced PNG into a malloc'ed buffer *out of *len bytes; the
 * caller frees it. */
rd_error_code rd_png_encode(const uint8_t *rgb, int width, int height, const rd_png_options *opt, unsigned char **out,
                            size_t *len, rd_error *err);

#endif
