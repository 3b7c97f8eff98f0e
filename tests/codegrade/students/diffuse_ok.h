// DiffuseMaterial, correct: k_d max{-N.L, 0} in double.
#ifndef DIFFUSEMATERIAL_H
#define DIFFUSEMATERIAL_H

#include "Material.h"

class DiffuseMaterial : public Material
{
  public:
    vec3 kd; // diffuse reflectance

    DiffuseMaterial() : kd(0) {}

    virtual vec3 calcReflectedLight(const HitRecord &record, const vec3 &incomingDir, const vec3 &outgoingDir)
    {
        Real cosAlpha = -dot(record.normal, incomingDir);
        return kd * std::max(cosAlpha, 0.0);
    }
};

#endif
