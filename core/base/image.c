#include "rayd/image.h"

#include <math.h>
#include <stdlib.h>

#include "rayd/vec3.h"

void rd_image_free(rd_image *img)
{
    free(img->rgb);
    img->rgb = NULL;
    img->width = img->height = 0;
}

double rd_display(double c, double gamma)
{
    c = rd_clamp01(c);
    return gamma == 1 ? c : pow(c, 1.0 / gamma);
}

uint8_t rd_display8(double c, double gamma) { return (uint8_t)floor(rd_display(c, gamma) * 255.0 + 0.5); }

void rd_image_to_rgb8(const rd_image *img, double gamma, uint8_t *out)
{
    size_t n = (size_t)img->width * (size_t)img->height * 3;
    for (size_t i = 0; i < n; i++)
        out[i] = rd_display8(img->rgb[i], gamma);
}
