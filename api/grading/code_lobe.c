#include "code_lobe.h"

#include <math.h>

#include "rayd/shading.h"
#include "strbuf.h"

/* One polar panel per incidence angle: the surface along the bottom, the
 * eye's direction as the angle, the reflected light as the radius. */
enum { PANEL = 220, PH = 150, TOP = 30, R = 100, MAXPANELS = 8 };

/* Luminance: one curve stands for the three channels. */
static double luma(rd_rgb c) { return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z; }

static double ref_of(const rd_code_case *c) { return luma(rd_reflected_light(&c->m, c->n, c->L, c->V)); }

static int usable(const rd_code_value *v) { return v->status == RD_CODE_RETURNED && v3_is_finite(v->got); }

/* A panel's scale: the reference's peak, or the student's up to 3 times it. */
static double scale(const rd_code_case *c, const rd_code_value *v, size_t n, double incidence)
{
    double ref = 0, got = 0;
    for (size_t i = 0; i < n; i++)
        if (c[i].group == RD_CODE_LOBE && c[i].incidence_deg == incidence) {
            ref = fmax(ref, ref_of(&c[i]));
            if (usable(&v[i]))
                got = fmax(got, fabs(luma(v[i].got)));
        }
    ref = ref > 0 ? ref : 1;
    return fmax(ref, fmin(got, 3 * ref)) * 1.05;
}

static void point(rd_strbuf *b, double cx, double cy, double angle_deg, double r, int pen)
{
    double t = angle_deg * M_PI / 180;
    rd_strbuf_printf(b, "%s%.1f %.1f", pen ? " L" : " M", cx + r * sin(t), cy - r * cos(t));
}

/* One curve of a panel; the student's only where it returned a finite
 * value, negative light drawn at the centre. */
static void curve(rd_strbuf *b, const rd_code_case *c, const rd_code_value *v, size_t n, double incidence, double top,
                  double cx, double cy, int student)
{
    rd_strbuf_printf(b, "<path fill=\"none\" stroke=\"%s\" stroke-width=\"2\"%s d=\"", student ? "#b3261e" : "#2f6fdf",
                     student ? " stroke-dasharray=\"5 3\"" : "");
    int pen = 0;
    for (size_t i = 0; i < n; i++) {
        if (c[i].group != RD_CODE_LOBE || c[i].incidence_deg != incidence)
            continue;
        if (student && !usable(&v[i])) {
            pen = 0;
            continue;
        }
        double y = student ? luma(v[i].got) : ref_of(&c[i]);
        point(b, cx, cy, c[i].angle_deg, R * fmin(fmax(y / top, 0), 1.1), pen);
        pen = 1;
    }
    rd_strbuf_printf(b, "\"/>\n");
}

static void panel(rd_strbuf *b, const rd_code_case *c, const rd_code_value *v, size_t n, double incidence, int k)
{
    double cx = PANEL * k + PANEL / 2.0, cy = TOP + R + 4, top = scale(c, v, n, incidence);
    rd_strbuf_printf(b, "<path d=\"M%.1f %.1f A%d %d 0 0 1 %.1f %.1f\" fill=\"none\" stroke=\"#e6e9ed\"/>\n", cx - R,
                     cy, R, R, cx + R, cy);
    rd_strbuf_printf(b, "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#9aa4ae\"/>\n", cx - R - 6, cy,
                     cx + R + 6, cy);
    double t = incidence * M_PI / 180; /* the light arrives from the left */
    rd_strbuf_printf(b,
                     "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#e0a100\" stroke-width=\"2\"/>\n",
                     cx - 1.1 * R * sin(t), cy - 1.1 * R * cos(t), cx - 0.25 * R * sin(t), cy - 0.25 * R * cos(t));
    curve(b, c, v, n, incidence, top, cx, cy, 0);
    curve(b, c, v, n, incidence, top, cx, cy, 1);
    rd_strbuf_printf(b, "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"middle\">light at %.0f°, the ring %.3g</text>\n", cx,
                     cy + 18, incidence, top);
}

char *rd_code_lobe_svg(const rd_code_case *c, const rd_code_value *v, size_t n)
{
    double incidences[MAXPANELS];
    int panels = 0;
    for (size_t i = 0; i < n; i++) {
        if (c[i].group != RD_CODE_LOBE)
            continue;
        int seen = 0;
        for (int k = 0; k < panels; k++)
            seen |= incidences[k] == c[i].incidence_deg;
        if (!seen && panels < MAXPANELS)
            incidences[panels++] = c[i].incidence_deg;
    }
    if (!panels)
        return NULL;
    rd_strbuf b = {0};
    int w = PANEL * panels, h = TOP + R + 4 + 28;
    rd_strbuf_printf(&b,
                     "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%d\" height=\"%d\" viewBox=\"0 0 %d %d\" "
                     "font-family=\"system-ui, sans-serif\" font-size=\"11\" fill=\"#5b6570\">\n"
                     "<rect x=\"0\" y=\"0\" width=\"%d\" height=\"%d\" fill=\"#fbfcfd\"/>\n",
                     w, h, w, h, w, h);
    for (int k = 0; k < panels; k++)
        panel(&b, c, v, n, incidences[k], k);
    rd_strbuf_printf(&b,
                     "<text x=\"8\" y=\"16\" fill=\"#2f6fdf\">— rayd's</text>\n"
                     "<text x=\"64\" y=\"16\" fill=\"#b3261e\">- - yours</text>\n"
                     "<text x=\"%d\" y=\"16\" text-anchor=\"end\">reflected light (luminance) by the eye's "
                     "direction, in the plane of incidence</text>\n</svg>\n",
                     w - 8);
    return rd_strbuf_take(&b, NULL);
}
