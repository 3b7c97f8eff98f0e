#include "code_lobe.h"

#include <math.h>

#include "rayd/shading.h"
#include "strbuf.h"

enum { W = 480, H = 260, LEFT = 56, RIGHT = 16, TOP = 28, BOTTOM = 44 };

/* Luminance: one curve stands for the three channels. */
static double luma(rd_rgb c) { return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z; }

static double px(double angle) { return LEFT + (angle + 90) / 180 * (W - LEFT - RIGHT); }
static double py(double y, double top) { return H - BOTTOM - fmin(fmax(y / top, -0.05), 1.05) * (H - TOP - BOTTOM); }

/* The plot's top: the reference's peak, or the student's up to 3 times it. */
static double scale(const rd_code_case *c, const rd_code_value *v, size_t n)
{
    double ref = 0, got = 0;
    for (size_t i = 0; i < n; i++) {
        if (c[i].group != RD_CODE_LOBE)
            continue;
        ref = fmax(ref, luma(rd_reflected_light(&c[i].m, c[i].n, c[i].L, c[i].V)));
        if (v[i].status == RD_CODE_RETURNED && v3_is_finite(v[i].got))
            got = fmax(got, fabs(luma(v[i].got)));
    }
    ref = ref > 0 ? ref : 1;
    return fmax(ref, fmin(got, 3 * ref)) * 1.1;
}

static void axes(rd_strbuf *b, double top)
{
    rd_strbuf_printf(b, "<rect x=\"0\" y=\"0\" width=\"%d\" height=\"%d\" fill=\"#fbfcfd\"/>\n", W, H);
    for (int a = -90; a <= 90; a += 45) {
        rd_strbuf_printf(b, "<line x1=\"%.1f\" y1=\"%d\" x2=\"%.1f\" y2=\"%d\" stroke=\"#e6e9ed\"/>\n", px(a), TOP,
                         px(a), H - BOTTOM);
        rd_strbuf_printf(b, "<text x=\"%.1f\" y=\"%d\" text-anchor=\"middle\">%d°</text>\n", px(a), H - BOTTOM + 16, a);
    }
    for (int k = 0; k <= 4; k++)
        rd_strbuf_printf(b, "<text x=\"%d\" y=\"%.1f\" text-anchor=\"end\">%.3g</text>\n", LEFT - 6,
                         py(top * k / 4, top) + 4, top * k / 4);
    rd_strbuf_printf(b,
                     "<path d=\"M%d %d V%d H%d\" fill=\"none\" stroke=\"#9aa4ae\"/>\n"
                     "<text x=\"%.1f\" y=\"%d\" text-anchor=\"middle\">the eye's angle from the normal (the mirror "
                     "direction at 45°)</text>\n"
                     "<text x=\"14\" y=\"%d\" transform=\"rotate(-90 14 %d)\" text-anchor=\"middle\">reflected light "
                     "(luminance)</text>\n",
                     LEFT, TOP, H - BOTTOM, W - RIGHT, px(0), H - 8, (TOP + H - BOTTOM) / 2, (TOP + H - BOTTOM) / 2);
}

/* One curve; student: only the values that returned and are finite, a
 * gap where one did not. */
static void curve(rd_strbuf *b, const rd_code_case *c, const rd_code_value *v, size_t n, double top, int student)
{
    rd_strbuf_printf(b, "<path fill=\"none\" stroke=\"%s\" stroke-width=\"2\"%s d=\"", student ? "#b3261e" : "#2f6fdf",
                     student ? " stroke-dasharray=\"5 3\"" : "");
    int pen = 0;
    for (size_t i = 0; i < n; i++) {
        if (c[i].group != RD_CODE_LOBE)
            continue;
        double y = student ? luma(v[i].got) : luma(rd_reflected_light(&c[i].m, c[i].n, c[i].L, c[i].V));
        if (student && (v[i].status != RD_CODE_RETURNED || !isfinite(y))) {
            pen = 0;
            continue;
        }
        rd_strbuf_printf(b, "%s%.1f %.1f", pen ? " L" : " M", px(c[i].angle_deg), py(y, top));
        pen = 1;
    }
    rd_strbuf_printf(b, "\"/>\n");
}

char *rd_code_lobe_svg(const rd_code_case *c, const rd_code_value *v, size_t n)
{
    size_t lobes = 0;
    for (size_t i = 0; i < n; i++)
        lobes += c[i].group == RD_CODE_LOBE;
    if (!lobes)
        return NULL;
    double top = scale(c, v, n);
    rd_strbuf b = {0};
    rd_strbuf_printf(&b,
                     "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%d\" height=\"%d\" viewBox=\"0 0 %d %d\" "
                     "font-family=\"system-ui, sans-serif\" font-size=\"11\" fill=\"#5b6570\">\n",
                     W, H, W, H);
    axes(&b, top);
    curve(&b, c, v, n, top, 0);
    curve(&b, c, v, n, top, 1);
    rd_strbuf_printf(&b,
                     "<text x=\"%d\" y=\"16\" fill=\"#2f6fdf\">— rayd's</text>\n"
                     "<text x=\"%d\" y=\"16\" fill=\"#b3261e\">- - yours</text>\n"
                     "<text x=\"%d\" y=\"16\" text-anchor=\"end\">light 45° from the left</text>\n</svg>\n",
                     LEFT, LEFT + 70, W - RIGHT);
    return rd_strbuf_take(&b, NULL);
}
