#include "material.h"

rd_rgb rd_blinn_phong_reflected(const rd_material *m, const rd_hit *hit, rd_vec3 L, rd_vec3 V)
{
    double cosa = rd_incidence(hit, L);
    if (cosa == 0)
        return v3(0, 0, 0);
    /* V - L is never zero here: L = V would put the light behind N. */
    rd_vec3 H = v3_normalize(v3_sub(V, L));
    double spec = rd_pow_cos(hit->n, H, m->shininess);
    return v3_add(v3_scale(m->kd, cosa), v3_scale(m->ks, spec));
}
