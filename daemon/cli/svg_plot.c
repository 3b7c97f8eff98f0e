#include "svg_plot.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "strbuf.h"

#define put rd_strbuf_printf

char *rd_svg_loglog(const char *title, const char *xlabel, const char *ylabel, const rd_svg_series *series,
                    size_t nseries)
{
    double xmin = INFINITY, xmax = -INFINITY, ymin = INFINITY, ymax = -INFINITY;
    for (size_t k = 0; k < nseries; k++)
        for (size_t i = 0; i < series[k].n; i++) {
            double x = series[k].x[i], y = series[k].y[i];
            if (!(x > 0) || !(y > 0))
                continue;
            xmin = fmin(xmin, x);
            xmax = fmax(xmax, x);
            ymin = fmin(ymin, y);
            ymax = fmax(ymax, y);
        }
    if (!(xmax > 0)) {
        xmin = ymin = 1;
        xmax = ymax = 10;
    }
    double lx0 = floor(log10(xmin)), lx1 = ceil(log10(xmax)), ly0 = floor(log10(ymin)), ly1 = ceil(log10(ymax));
    if (lx1 <= lx0)
        lx1 = lx0 + 1;
    if (ly1 <= ly0)
        ly1 = ly0 + 1;
    const double W = 720, H = 480, L = 80, R = 20, T = 40, B = 60;
    rd_strbuf b = {0};
#define PX(v) (L + (log10(v) - lx0) / (lx1 - lx0) * (W - L - R))
#define PY(v) (H - B - (log10(v) - ly0) / (ly1 - ly0) * (H - T - B))
    put(&b,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0f\" height=\"%.0f\" viewBox=\"0 0 %.0f %.0f\" "
        "font-family=\"sans-serif\" font-size=\"12\">\n",
        W, H, W, H);
    put(&b, "<rect width=\"100%%\" height=\"100%%\" fill=\"white\"/>\n");
    put(&b, "<text x=\"%.0f\" y=\"24\" font-size=\"15\" text-anchor=\"middle\">%s</text>\n", W / 2, title);
    for (double e = lx0; e <= lx1; e++)
        for (int m = 1; m <= 9; m++) {
            double v = m * pow(10, e);
            if (log10(v) > lx1 + 1e-9)
                break;
            put(&b, "<line x1=\"%.1f\" y1=\"%.0f\" x2=\"%.1f\" y2=\"%.0f\" stroke=\"%s\"/>\n", PX(v), T, PX(v), H - B,
                m == 1 ? "#bbb" : "#eee");
            if (m == 1)
                put(&b, "<text x=\"%.1f\" y=\"%.0f\" text-anchor=\"middle\">%g</text>\n", PX(v), H - B + 18, v);
        }
    for (double e = ly0; e <= ly1; e++)
        for (int m = 1; m <= 9; m++) {
            double v = m * pow(10, e);
            if (log10(v) > ly1 + 1e-9)
                break;
            put(&b, "<line x1=\"%.0f\" y1=\"%.1f\" x2=\"%.0f\" y2=\"%.1f\" stroke=\"%s\"/>\n", L, PY(v), W - R, PY(v),
                m == 1 ? "#bbb" : "#eee");
            if (m == 1)
                put(&b, "<text x=\"%.0f\" y=\"%.1f\" text-anchor=\"end\">%g</text>\n", L - 6, PY(v) + 4, v);
        }
    put(&b, "<rect x=\"%.0f\" y=\"%.0f\" width=\"%.0f\" height=\"%.0f\" fill=\"none\" stroke=\"#333\"/>\n", L, T,
        W - L - R, H - T - B);
    put(&b, "<text x=\"%.0f\" y=\"%.0f\" text-anchor=\"middle\">%s</text>\n", (L + W - R) / 2, H - 16, xlabel);
    put(&b, "<text x=\"18\" y=\"%.0f\" text-anchor=\"middle\" transform=\"rotate(-90 18 %.0f)\">%s</text>\n",
        (T + H - B) / 2, (T + H - B) / 2, ylabel);
    for (size_t k = 0; k < nseries; k++) {
        const rd_svg_series *s = &series[k];
        put(&b, "<polyline fill=\"none\" stroke=\"%s\" stroke-width=\"2\"%s points=\"", s->color,
            s->dashed ? " stroke-dasharray=\"6 4\"" : "");
        for (size_t i = 0; i < s->n; i++)
            if (s->x[i] > 0 && s->y[i] > 0)
                put(&b, "%.1f,%.1f ", PX(s->x[i]), PY(s->y[i]));
        put(&b, "\"/>\n");
        for (size_t i = 0; i < s->n; i++)
            if (s->x[i] > 0 && s->y[i] > 0)
                put(&b, "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"3\" fill=\"%s\"/>\n", PX(s->x[i]), PY(s->y[i]), s->color);
        double ly = T + 18 + 18 * (double)k;
        put(&b, "<line x1=\"%.0f\" y1=\"%.0f\" x2=\"%.0f\" y2=\"%.0f\" stroke=\"%s\" stroke-width=\"2\"%s/>\n",
            W - R - 190, ly, W - R - 160, ly, s->color, s->dashed ? " stroke-dasharray=\"6 4\"" : "");
        put(&b, "<text x=\"%.0f\" y=\"%.0f\">%s</text>\n", W - R - 154, ly + 4, s->label);
    }
#undef PX
#undef PY
    put(&b, "</svg>\n");
    return rd_strbuf_take(&b, NULL);
}
