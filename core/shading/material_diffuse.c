#include "material.h"

rd_rgb rd_diffuse_reflected(const rd_material *m, const rd_hit *hit, rd_vec3 L, rd_vec3 V)
{
    (void)V;
    double cosa = rd_incidence(hit, L);
    if (cosa == 0)
        return v3(0, 0, 0);
    return v3_scale(m->kd, cosa);
}
