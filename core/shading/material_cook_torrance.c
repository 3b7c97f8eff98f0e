#include "material.h"

/* Cap on the specular factor: far above anything that does not clamp to
 * white, far below overflow even times large light colours. */
#define RD_MAX_SPECULAR 1e200

/* Beckmann distribution for slope roughness m at cos θ_h = nh = N·H.
 * 1 - nh² is x(2 - x) with x = |N - H|²/2 = 1 - nh, without the
 * cancellation that ruins very smooth surfaces (roughness 1e-5 and below). */
static double beckmann(rd_vec3 N, rd_vec3 H, double nh, double m)
{
    if (!(nh > 0))
        return 0;
    rd_vec3 d = v3_sub(N, H);
    double x = 0.5 * v3_dot(d, d);
    double nh2 = nh * nh;
    double m2 = m * m;
    double e = -(x * (2 - x)) / (nh2 * m2);
    if (e < -700) /* exp underflows; also keeps nh⁴ away from 0/0 */
        return 0;
    return exp(e) / (M_PI * m2 * nh2 * nh2);
}

rd_rgb rd_cook_torrance_reflected(const rd_material *m, const rd_hit *hit, rd_vec3 L, rd_vec3 V)
{
    double cosa = rd_incidence(hit, L);
    if (cosa == 0)
        return v3(0, 0, 0);
    rd_rgb c = v3_scale(m->kd, cosa);
    double nv = v3_dot(hit->n, V);
    if (!(nv > 0))
        return c;
    if (nv > 1)
        nv = 1;
    rd_vec3 H = v3_normalize(v3_sub(V, L));
    double nh = fmin(1, v3_dot(hit->n, H));
    double vh = fmin(1, v3_dot(V, H));
    if (!(nh > 0) || !(vh > 0))
        return c;
    double D = beckmann(hit->n, H, nh, m->roughness);
    /* G/(N·V) taken term by term so that N·V -> 0 stays finite. */
    double g_nv = fmin(1 / nv, fmin(2 * nh / vh, 2 * nh * cosa / (vh * nv)));
    double s = pow(1 - vh, 5);
    rd_rgb F = v3(m->ks.x + (1 - m->ks.x) * s, m->ks.y + (1 - m->ks.y) * s, m->ks.z + (1 - m->ks.z) * s);
    /* The formula diverges like 1/(N·V) when V and L both graze in the
     * mirror configuration; keep it finite (any such value clamps to white). */
    double spec = fmin(D * g_nv / 4, RD_MAX_SPECULAR);
    return v3_add(c, v3_scale(F, spec));
}
