#include "grade.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "compare.h"
#include "png_read.h"
#include "scene_limits.h"

rd_grade_thresholds rd_grade_thresholds_default(void)
{
    rd_grade_thresholds t = {3, 0.001, 48, 16};
    return t;
}

rd_error_code rd_grade_compare(const uint8_t *ref, const uint8_t *img, int w, int h, const rd_grade_thresholds *t,
                               rd_grade_result *out)
{
    memset(out, 0, sizeof *out);
    out->width = w;
    out->height = h;
    size_t npix = (size_t)w * (size_t)h;
    double sq = 0, sum = 0;
    int x0 = w, y0 = h, x1 = -1, y1 = -1;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            size_t i = (size_t)y * w + x;
            const uint8_t *a = ref + 3 * i, *b = img + 3 * i;
            for (int c = 0; c < 3; c++) {
                double d = ((double)a[c] - b[c]) / 255.0;
                sq += d * d;
            }
            int d = rd_pixel_diff(a, b);
            sum += d;
            if (d > out->max_abs) {
                out->max_abs = d;
                out->worst_x = x;
                out->worst_y = y;
                memcpy(out->expected, a, 3);
                memcpy(out->got, b, 3);
            }
            if (d > t->fail) {
                out->failed_pixels++;
                x0 = x < x0 ? x : x0;
                y0 = y < y0 ? y : y0;
                x1 = x > x1 ? x : x1;
                y1 = y > y1 ? y : y1;
            }
            if (d > t->hard_fail)
                out->hard_pixels++;
        }
    if (out->max_abs == 0) {
        memcpy(out->expected, ref, 3);
        memcpy(out->got, img, 3);
    }
    out->rmse = sqrt(sq / (3.0 * (double)npix));
    out->psnr_db = rd_psnr_db_reported(out->rmse);
    out->mean_abs = sum / (double)npix;
    out->failed_fraction = (double)out->failed_pixels / (double)npix;
    out->has_box = x1 >= 0;
    if (out->has_box) {
        out->box[0] = x0;
        out->box[1] = y0;
        out->box[2] = x1;
        out->box[3] = y1;
    }
    out->ssim = rd_ssim(ref, img, w, h);
    out->pass = out->failed_fraction <= t->fail_fraction && out->hard_pixels <= (size_t)t->hard_fail_pixels;
    /* SSIM of two real images is never NaN: its denominators hold C1, C2 > 0. */
    return isnan(out->ssim) ? RD_ERR_NOMEM : RD_OK;
}

static double *luminance(const uint8_t *p, size_t n)
{
    double *y = malloc(n * sizeof *y);
    if (y)
        for (size_t i = 0; i < n; i++)
            y[i] = 0.299 * p[3 * i] + 0.587 * p[3 * i + 1] + 0.114 * p[3 * i + 2];
    return y;
}

double rd_ssim(const uint8_t *a, const uint8_t *b, int w, int h)
{
    size_t n = (size_t)w * (size_t)h;
    double *ya = luminance(a, n), *yb = luminance(b, n);
    if (!ya || !yb) {
        free(ya);
        free(yb);
        return NAN;
    }
    int wx = w < 11 ? w : 11, wy = h < 11 ? h : 11;
    /* The Gaussian window of Wang et al.: σ = 1.5, normalised to sum 1. */
    double gx[11], gy[11], sx = 0, sy = 0;
    for (int i = 0; i < wx; i++) {
        double d = i - (wx - 1) / 2.0;
        gx[i] = exp(-d * d / (2 * 1.5 * 1.5));
        sx += gx[i];
    }
    for (int i = 0; i < wy; i++) {
        double d = i - (wy - 1) / 2.0;
        gy[i] = exp(-d * d / (2 * 1.5 * 1.5));
        sy += gy[i];
    }
    const double C1 = (0.01 * 255) * (0.01 * 255), C2 = (0.03 * 255) * (0.03 * 255);
    double total = 0;
    size_t windows = 0;
    for (int y = 0; y + wy <= h; y++)
        for (int x = 0; x + wx <= w; x++) {
            double ma = 0, mb = 0, vaa = 0, vbb = 0, vab = 0;
            for (int j = 0; j < wy; j++)
                for (int i = 0; i < wx; i++) {
                    double g = gx[i] * gy[j] / (sx * sy);
                    size_t k = (size_t)(y + j) * w + (x + i);
                    ma += g * ya[k];
                    mb += g * yb[k];
                    vaa += g * ya[k] * ya[k];
                    vbb += g * yb[k] * yb[k];
                    vab += g * ya[k] * yb[k];
                }
            double saa = vaa - ma * ma, sbb = vbb - mb * mb, sab = vab - ma * mb;
            total += ((2 * ma * mb + C1) * (2 * sab + C2)) / ((ma * ma + mb * mb + C1) * (saa + sbb + C2));
            windows++;
        }
    free(ya);
    free(yb);
    return windows ? total / (double)windows : 1.0;
}

void rd_grade_heatmap(const uint8_t *ref, const uint8_t *img, int w, int h, int fail, uint8_t *out)
{
    size_t n = (size_t)w * (size_t)h;
    for (size_t i = 0; i < n; i++) {
        const uint8_t *a = ref + 3 * i, *b = img + 3 * i;
        int d = rd_pixel_diff(a, b);
        uint8_t *o = out + 3 * i;
        if (d <= fail) {
            /* The reference, grey and dimmed, so colours stand out. */
            double y = 0.299 * a[0] + 0.587 * a[1] + 0.114 * a[2];
            uint8_t g = (uint8_t)(40 + y * 0.5);
            o[0] = o[1] = o[2] = g;
            continue;
        }
        /* t in (0, 1]: how far from just failing to the largest difference. */
        double t = (double)(d - fail) / (255 - fail > 0 ? 255 - fail : 1);
        t = sqrt(t < 0 ? 0 : (t > 1 ? 1 : t));
        double r, g, bl;
        if (t < 0.33) {
            double u = t / 0.33;
            r = 255, g = 230 - 90 * u, bl = 0;
        } else if (t < 0.66) {
            double u = (t - 0.33) / 0.33;
            r = 255, g = 140 - 140 * u, bl = 0;
        } else {
            double u = (t - 0.66) / 0.34;
            r = 255 - 40 * u, g = 0, bl = 220 * u;
        }
        /* Rounded: truncation left the worst pixel at 219, not 220. */
        o[0] = (uint8_t)(r + 0.5);
        o[1] = (uint8_t)(g + 0.5);
        o[2] = (uint8_t)(bl + 0.5);
    }
}

rd_error_code rd_grade_load_png(const unsigned char *data, size_t len, size_t max_pixels, uint8_t **out, int *w, int *h,
                                rd_error *err)
{
    rd_png_image img;
    *out = NULL;
    rd_error_code rc =
        rd_png_decode(data, len, max_pixels, rd_limit_flag(offsetof(rd_scene_limits, max_pixels)), &img, err);
    if (rc)
        return rc;
    size_t n = (size_t)img.width * (size_t)img.height * 3;
    uint8_t *p = malloc(n);
    if (!p) {
        free(img.rgb);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    }
    for (size_t i = 0; i < n; i++)
        p[i] = img.maxval == 255 ? (uint8_t)img.rgb[i] : (uint8_t)((img.rgb[i] * 255u + 32767u) / 65535u);
    free(img.rgb);
    *out = p;
    *w = img.width;
    *h = img.height;
    return RD_OK;
}
