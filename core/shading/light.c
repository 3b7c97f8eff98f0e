#include "light.h"

void rd_light_prepare(rd_light_prep *lp, const rd_light *l, rd_vec3 origin)
{
    lp->type = l->type;
    lp->color = l->color;
    lp->pos = v3_sub(l->position, origin);
    lp->dir = v3_normalize(l->direction);
    lp->cos_cutoff = cos(l->angle_deg * M_PI / 180.0);
    lp->falloff = l->falloff;
    lp->corner = v3_sub(l->corner, origin);
    lp->e1 = l->edge1;
    lp->e2 = l->edge2;
    lp->side = l->type == RD_LIGHT_AREA ? (l->samples > 0 ? l->samples : 1) : 1;
    lp->samples = lp->side * lp->side;
}

int rd_light_sample_at(const rd_light_prep *lp, rd_vec3 p, int k, double ux, double uy, rd_light_sample *out)
{
    rd_vec3 at;
    out->color = lp->color;
    out->infinite = 0;
    switch (lp->type) {
    case RD_LIGHT_DIRECTIONAL:
        out->L = lp->dir;
        out->to_light = v3_neg(lp->dir);
        out->infinite = 1;
        return 1;
    case RD_LIGHT_AREA: {
        double s = lp->side;
        double a = ((k % lp->side) + ux) / s, b = ((k / lp->side) + uy) / s;
        at = v3_add(lp->corner, v3_add(v3_scale(lp->e1, a), v3_scale(lp->e2, b)));
        out->color = v3_scale(lp->color, 1.0 / lp->samples);
        break;
    }
    default: at = lp->pos; break;
    }
    out->to_light = v3_sub(at, p);
    out->L = v3_normalize(v3_neg(out->to_light));
    if (!(v3_max_abs(out->L) > 0))
        return 0;
    if (lp->type == RD_LIGHT_SPOT) {
        double c = v3_dot(out->L, lp->dir);
        if (!(c >= lp->cos_cutoff) || !(c > 0))
            return 0;
        if (c > 1)
            c = 1;
        if (lp->falloff != 0)
            out->color = v3_scale(out->color, pow(c, lp->falloff));
    }
    return 1;
}
