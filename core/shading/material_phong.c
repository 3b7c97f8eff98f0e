#include "material.h"

rd_rgb rd_phong_reflected(const rd_material *m, const rd_hit *hit, rd_vec3 L, rd_vec3 V)
{
    double cosa = rd_incidence(hit, L);
    if (cosa == 0)
        return v3(0, 0, 0);
    rd_vec3 R = v3_reflect(L, hit->n);
    double spec = rd_pow_cos(R, V, m->shininess);
    return v3_add(v3_scale(m->kd, cosa), v3_scale(m->ks, spec));
}
