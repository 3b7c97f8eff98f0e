#include "material.h"

#include "rayd/shading.h"

/* A callback's channel as the renderer can use it: NaN, infinities and
 * negatives are 0, the rest is capped where radiance saturates (trace.c). */
static double usable(double v)
{
    if (!(v > 0) || isinf(v))
        return 0;
    return v < 1e300 ? v : 1e300;
}

static rd_rgb from_callback(const rd_material *m, const rd_hit *hit, rd_vec3 L, rd_vec3 V)
{
    rd_rgb c = m->reflect(m->reflect_user, m, hit->n, hit->p, hit->t, L, V);
    return v3(usable(c.x), usable(c.y), usable(c.z));
}

static rd_rgb by_type(const rd_material *m, const rd_hit *hit, rd_vec3 incoming, rd_vec3 outgoing)
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

rd_rgb rd_calc_reflected_light(const rd_material *m, const rd_hit *hit, rd_vec3 incoming, rd_vec3 outgoing)
{
    if (m->reflect)
        return from_callback(m, hit, incoming, outgoing);
    return by_type(m, hit, incoming, outgoing);
}

rd_rgb rd_reflected_light(const rd_material *m, rd_vec3 n, rd_vec3 L, rd_vec3 V)
{
    rd_hit h = {0};
    h.n = n;
    h.ng = n;
    h.front = 1;
    return by_type(m, &h, L, V);
}

int rd_material_is_recursive(const rd_material *m)
{
    return m->type == RD_MAT_PERFECT_SPECULAR || m->type == RD_MAT_SPECULAR_REFRACTION;
}
