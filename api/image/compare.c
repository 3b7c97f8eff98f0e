#include "compare.h"

#include <math.h>

void rd_compare_rgb8(const uint8_t *a, const uint8_t *b, size_t pixels, rd_compare_result *out)
{
    /* Integer sums are exact: at most 3·255² per pixel, so 2^64 covers far
     * more pixels than any image limit allows. */
    uint64_t sq = 0, sum_a = 0, sum_b = 0;
    size_t differ = 0, over1 = 0;
    int max_diff = 0;
    for (size_t p = 0; p < pixels; p++) {
        const uint8_t *pa = a + 3 * p, *pb = b + 3 * p;
        int worst = 0;
        for (int c = 0; c < 3; c++) {
            int d = (int)pa[c] - (int)pb[c];
            int ad = d < 0 ? -d : d;
            sq += (uint64_t)(d * d);
            sum_a += pa[c];
            sum_b += pb[c];
            worst = ad > worst ? ad : worst;
        }
        differ += worst > 0;
        over1 += worst > 1;
        max_diff = worst > max_diff ? worst : max_diff;
    }
    out->pixels = pixels;
    out->max_diff = max_diff;
    out->differing_pixels = differ;
    out->differing_pixels_over_1 = over1;
    if (pixels == 0) {
        out->rmse = out->mean_a = out->mean_b = 0;
        out->psnr_db = INFINITY;
        return;
    }
    double n = 3.0 * (double)pixels;
    out->rmse = sqrt((double)sq / n) / 255.0;
    out->psnr_db = sq == 0 ? INFINITY : -20.0 * log10(out->rmse);
    out->mean_a = (double)sum_a / n / 255.0;
    out->mean_b = (double)sum_b / n / 255.0;
}

double rd_psnr_db_reported(double rmse)
{
    if (!(rmse > 0))
        return RD_PSNR_CAP_DB;
    double db = -20.0 * log10(rmse);
    return db < RD_PSNR_CAP_DB ? db : RD_PSNR_CAP_DB;
}

double rd_compare_display_rmse(const rd_image *img, const double *ref, double gamma)
{
    size_t n = (size_t)img->width * (size_t)img->height * 3;
    double sum = 0;
    for (size_t i = 0; i < n; i++) {
        double d = rd_display(img->rgb[i], gamma) - ref[i];
        sum += d * d;
    }
    return n ? sqrt(sum / (double)n) : 0;
}

double rd_loglog_slope(const double *x, const double *y, int n)
{
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    int m = 0;
    for (int i = 0; i < n; i++) {
        if (!(x[i] > 0) || !(y[i] > 0))
            continue;
        double a = log(x[i]), b = log(y[i]);
        sx += a;
        sy += b;
        sxx += a * a;
        sxy += a * b;
        m++;
    }
    double d = m * sxx - sx * sx;
    return m >= 2 && d != 0 ? (m * sxy - sx * sy) / d : NAN;
}
