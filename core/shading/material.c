#include "material.h"

rd_rgb rd_calc_reflected_light(const rd_material *m, const rd_hit *hit, rd_vec3 incoming, rd_vec3 outgoing)
{
    switch (m->type) {
    case RD_MAT_DIFFUSE: return rd_diffuse_reflected(m, hit, incoming, outgoing);
    case RD_MAT_PHONG:
    case RD_MAT_TEXTURED_PHONG: return rd_phong_reflected(m, hit, incoming, outgoing);
    case RD_MAT_BLINN_PHONG: return rd_blinn_phong_reflected(m, hit, incoming, outgoing);
    case RD_MAT_COOK_TORRANCE: return rd_cook_torrance_reflected(m, hit, incoming, outgoing);
    default: return v3(0, 0, 0); /* mirror, glass: light comes by recursion */
    }
}

int rd_material_is_recursive(const rd_material *m)
{
    return m->type == RD_MAT_PERFECT_SPECULAR || m->type == RD_MAT_SPECULAR_REFRACTION;
}
