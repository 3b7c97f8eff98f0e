/* The course's Material::calcReflectedLight, one function per material type. */
#ifndef RD_MATERIAL_H
#define RD_MATERIAL_H

#include "ray.h"
#include "rayd/scene.h"

/* Light reflected toward `outgoing` (unit, away from the surface: the
 * course's outgoingDir, V) for unit light arriving along `incoming` (from
 * the light to the surface: incomingDir, L), per unit light colour. Excludes
 * ambient and recursion. Finite and non-negative for any unit inputs;
 * zero when the light is behind the shading normal hit->n. */
rd_rgb rd_calc_reflected_light(const rd_material *m, const rd_hit *hit, rd_vec3 incoming, rd_vec3 outgoing);

/* cos α = -N·L of light arriving along L, clamped to 1 (rounding can
 * pass it); 0 when the light is behind the surface or grazes it, where
 * every material reflects nothing. */
static inline double rd_incidence(const rd_hit *hit, rd_vec3 L)
{
    double cosa = -v3_dot(hit->n, L);
    if (!(cosa > 0))
        return 0;
    return cosa > 1 ? 1 : cosa;
}

rd_rgb rd_diffuse_reflected(const rd_material *m, const rd_hit *hit, rd_vec3 L, rd_vec3 V);
rd_rgb rd_phong_reflected(const rd_material *m, const rd_hit *hit, rd_vec3 L, rd_vec3 V);
rd_rgb rd_blinn_phong_reflected(const rd_material *m, const rd_hit *hit, rd_vec3 L, rd_vec3 V);
rd_rgb rd_cook_torrance_reflected(const rd_material *m, const rd_hit *hit, rd_vec3 L, rd_vec3 V);

/* max(a·b, 0)^n for unit a and b, computed from |a-b| so that a narrow lobe
 * (n up to 1e9 and beyond) keeps its shape instead of collapsing into the
 * few representable cosines just below 1. 0^0 is 1. */
double rd_pow_cos(rd_vec3 a, rd_vec3 b, double n);

/* Whether the material sends secondary rays (mirror, glass). */
int rd_material_is_recursive(const rd_material *m);

#endif
