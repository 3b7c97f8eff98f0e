#include "rayd/image.h"

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

uint8_t rd_display8(double c, double gamma) { return (uint8_t)floor(rd_display(c, gamma) * 255.0 + 0.5); }

/* rd_display8 is a staircase in c: 0 up to edge[1], k from edge[k] on.
 * Each edge is found by bisecting the doubles of [0, 1] (ordered as their
 * bit patterns) with rd_display8 itself as the judge, so the table agrees
 * with it wherever pow is monotonic; where it might not be, within GUARD of
 * an edge, rd_display8 is asked again. A cell of CELLS tells where to start
 * looking. */
enum { CELLS = 4096, TABLE_MIN = 1 << 16 };
#define GUARD 1e-9

typedef struct {
    double edge[257]; /* edge[0] = 0, edge[256] = +inf */
    uint8_t start[CELLS];
} display_table;

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

static void table_make(display_table *t, double gamma)
{
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

static uint8_t table_look(const display_table *t, double c, double gamma)
{
    if (!(c > 0 && c < 1))
        return rd_display8(c, gamma);
    int k = t->start[(int)(c * CELLS)];
    while (c >= t->edge[k + 1])
        k++;
    if (c - t->edge[k] <= GUARD * c || t->edge[k + 1] - c <= GUARD * c)
        return rd_display8(c, gamma);
    return (uint8_t)k;
}

void rd_image_to_rgb8(const rd_image *img, double gamma, uint8_t *out)
{
    size_t n = (size_t)img->width * (size_t)img->height * 3;
    if (gamma == 1) {
        /* floor of a value in [0.5, 255.5] is its truncation; the library's
         * floor, a call per channel, was a tenth of a 1080p render. */
        for (size_t i = 0; i < n; i++) {
            double c = img->rgb[i];
            out[i] = c == c ? (uint8_t)(rd_clamp01(c) * 255.0 + 0.5) : rd_display8(c, gamma);
        }
        return;
    }
    /* And pow per channel costs as much again. */
    if (n < TABLE_MIN) {
        for (size_t i = 0; i < n; i++)
            out[i] = rd_display8(img->rgb[i], gamma);
        return;
    }
    display_table *t = malloc(sizeof *t);
    if (!t) {
        for (size_t i = 0; i < n; i++)
            out[i] = rd_display8(img->rgb[i], gamma);
        return;
    }
    table_make(t, gamma);
    for (size_t i = 0; i < n; i++)
        out[i] = table_look(t, img->rgb[i], gamma);
    free(t);
}
