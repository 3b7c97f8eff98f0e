/* What the tracer knows about a ray's hit: where, the unit normal there,
 * and how far along the ray. */
#ifndef HITRECORD_H
#define HITRECORD_H

#include "my_algebra.h"

struct HitRecord {
    vec3 position; // the hit point
    vec3 normal;   // unit surface normal at the hit point
    Real t;        // distance along the ray

    HitRecord() : t(0) {}
};

#endif
