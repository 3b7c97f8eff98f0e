#include "rayd/image.h"

#include <emmintrin.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

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

uint8_t rd_display8(double c, double gamma)
{
    /* NaN has no display value, and converting it to an integer is
     * undefined: black, the byte x86 gave it. */
    if (c != c)
        return 0;
    return (uint8_t)floor(rd_display(c, gamma) * 255.0 + 0.5);
}

/* rd_display8 is a staircase in c: 0 up to edge[1], k from edge[k] on.
 * Each edge is found by bisecting the doubles of [0, 1] (ordered as their
 * bit patterns) with rd_display8 itself as the judge, so the table agrees
 * with it wherever pow is monotonic; where it might not be, within GUARD of
 * an edge, rd_display8 is asked again. A cell of CELLS tells where to start
 * looking. */
enum { CELLS = 4096, TABLE_MIN = 1 << 16 };
#define GUARD 1e-9

struct rd_display_table {
    double gamma;
    double edge[257]; /* edge[0] = 0, edge[256] = +inf */
    uint8_t start[CELLS];
};

static double edge_of(int k, double gamma)
{
    uint64_t lo = 0, hi;
    double one = 1.0;
    memcpy(&hi, &one, sizeof hi);
    while (hi - lo > 1) {
        uint64_t mid = lo + (hi - lo) / 2;
        double c;
        memcpy(&c, &mid, sizeof c);
        if (rd_display8(c, gamma) >= k)
            hi = mid;
        else
            lo = mid;
    }
    double c;
    memcpy(&c, &hi, sizeof c);
    return c;
}

static void table_make(rd_display_table *t, double gamma)
{
    t->gamma = gamma;
    t->edge[0] = 0;
    for (int k = 1; k < 256; k++)
        t->edge[k] = edge_of(k, gamma);
    t->edge[256] = INFINITY;
    int k = 0;
    for (int j = 0; j < CELLS; j++) {
        double c = (double)j / CELLS;
        while (k < 255 && t->edge[k + 1] <= c)
            k++;
        t->start[j] = (uint8_t)k;
    }
}

static uint8_t table_look(const rd_display_table *t, double c)
{
    double gamma = t->gamma;
    if (!(c > 0 && c < 1))
        return rd_display8(c, gamma);
    int k = t->start[(int)(c * CELLS)];
    while (c >= t->edge[k + 1])
        k++;
    if (c - t->edge[k] <= GUARD * c || t->edge[k + 1] - c <= GUARD * c)
        return rd_display8(c, gamma);
    return (uint8_t)k;
}

/* Sixteen values of rd_display8_linear at a time, by the same operations
 * in each lane: max and min clamp as rd_clamp01 does any number (-0
 * becoming +0 gives the same 0.5), the product and sum round alike, and
 * cvttpd2dq truncates as the cast does. A block holding a NaN goes value
 * by value. */
static void linear8_many(const double *in, size_t n, uint8_t *out)
{
    const __m128d zero = _mm_setzero_pd(), one = _mm_set1_pd(1.0), k = _mm_set1_pd(255.0), half = _mm_set1_pd(0.5);
    size_t i = 0;
    for (; i + 16 <= n; i += 16) {
        __m128i q[4];
        int nan = 0;
        for (int v = 0; v < 4; v++) {
            __m128d a = _mm_loadu_pd(in + i + 4 * v), b = _mm_loadu_pd(in + i + 4 * v + 2);
            nan |= _mm_movemask_pd(_mm_cmpunord_pd(a, b));
            a = _mm_add_pd(_mm_mul_pd(_mm_min_pd(_mm_max_pd(a, zero), one), k), half);
            b = _mm_add_pd(_mm_mul_pd(_mm_min_pd(_mm_max_pd(b, zero), one), k), half);
            q[v] = _mm_unpacklo_epi64(_mm_cvttpd_epi32(a), _mm_cvttpd_epi32(b));
        }
        if (nan) {
            for (size_t m = i; m < i + 16; m++)
                out[m] = rd_display8_linear(in[m]);
            continue;
        }
        __m128i w = _mm_packus_epi16(_mm_packs_epi32(q[0], q[1]), _mm_packs_epi32(q[2], q[3]));
        _mm_storeu_si128((__m128i *)(out + i), w);
    }
    for (; i < n; i++)
        out[i] = rd_display8_linear(in[i]);
}

rd_display_table *rd_display_table_new(double gamma, size_t n)
{
    /* Below TABLE_MIN values, making the table costs more than pow does. */
    if (gamma == 1 || n < TABLE_MIN)
        return NULL;
    rd_display_table *t = malloc(sizeof *t);
    if (t)
        table_make(t, gamma);
    return t;
}

void rd_display8_many(const rd_display_table *t, double gamma, const double *in, size_t n, uint8_t *out)
{
    if (gamma == 1)
        linear8_many(in, n, out);
    else if (t)
        for (size_t i = 0; i < n; i++)
            out[i] = table_look(t, in[i]);
    else
        for (size_t i = 0; i < n; i++)
            out[i] = rd_display8(in[i], gamma);
}

void rd_image_to_rgb8(const rd_image *img, double gamma, uint8_t *out)
{
    size_t n = (size_t)img->width * (size_t)img->height * 3;
    rd_display_table *t = rd_display_table_new(gamma, n);
    rd_display8_many(t, gamma, img->rgb, n, out);
    free(t);
}
