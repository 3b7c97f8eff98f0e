/* The base class of the course's materials. */
#ifndef MATERIAL_H
#define MATERIAL_H

#include "HitRecord.h"
#include "my_algebra.h"

class Material
{
  public:
    vec3 ambient; // I_a of equation (8); the tracer adds it, not calcReflectedLight

    Material() : ambient(0) {}
    virtual ~Material() {}

    vec3 getAmbientCoeff() const { return ambient; }

    /* The light reflected toward outgoingDir (unit, pointing away from the
     * surface) for light of unit colour arriving along incomingDir (unit,
     * pointing from the light to the surface), at record. Without ambient,
     * and without the light's colour: the tracer multiplies that in. */
    virtual vec3 calcReflectedLight(const HitRecord &record, const vec3 &incomingDir, const vec3 &outgoingDir) = 0;
};

#endif
