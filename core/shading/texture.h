/* Texture lookup. */
#ifndef RD_TEXTURE_H
#define RD_TEXTURE_H

#include "rayd/scene.h"

/* Bilinear, wrapping in both directions. Texel (i, j) has its centre at
 * u = (i + 0.5)/width, v = (j + 0.5)/height, with v = 0 at the top row. */
rd_rgb rd_texture_sample(const rd_texture *t, double u, double v);

#endif
