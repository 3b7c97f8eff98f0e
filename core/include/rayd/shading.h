/* The course's calcReflectedLight as a public function: the reference the
 * code grader compares a student's function with. */
#ifndef RD_SHADING_H
#define RD_SHADING_H

#include "rayd/scene.h"
#include "rayd/vec3.h"

/* Light reflected toward V (unit, away from the surface) for unit light
 * arriving along L (from the light to the surface) at a surface of unit
 * normal n, per unit light colour, without ambient: exactly what the
 * renderer uses (m->reflect is ignored). Finite and non-negative for any
 * unit inputs; 0 when the light is behind n. */
rd_rgb rd_reflected_light(const rd_material *m, rd_vec3 n, rd_vec3 L, rd_vec3 V);

#endif
