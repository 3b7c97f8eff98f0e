#include "texture.h"

static int wrap(long long i, int n)
{
    long long m = i % n;
    return (int)(m < 0 ? m + n : m);
}

rd_rgb rd_texture_sample(const rd_texture *t, double u, double v)
{
    if (!t || t->width < 1 || t->height < 1 || !isfinite(u) || !isfinite(v))
        return v3(0, 0, 0);
    /* Wrap first so that huge coordinates keep their fraction. */
    u -= floor(u);
    v -= floor(v);
    double x = u * t->width - 0.5, y = v * t->height - 0.5;
    double fx0 = floor(x), fy0 = floor(y);
    double fx = x - fx0, fy = y - fy0;
    int x0 = wrap((long long)fx0, t->width), x1 = wrap((long long)fx0 + 1, t->width);
    int y0 = wrap((long long)fy0, t->height), y1 = wrap((long long)fy0 + 1, t->height);
    const float *p00 = &t->rgb[3 * ((size_t)y0 * t->width + x0)];
    const float *p10 = &t->rgb[3 * ((size_t)y0 * t->width + x1)];
    const float *p01 = &t->rgb[3 * ((size_t)y1 * t->width + x0)];
    const float *p11 = &t->rgb[3 * ((size_t)y1 * t->width + x1)];
    double c[3];
    for (int k = 0; k < 3; k++)
        c[k] = (1 - fy) * ((1 - fx) * p00[k] + fx * p10[k]) + fy * ((1 - fx) * p01[k] + fx * p11[k]);
    return v3(c[0], c[1], c[2]);
}
