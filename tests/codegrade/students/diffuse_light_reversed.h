// DiffuseMaterial, mistake: cos(alpha) = N.L as if incomingDir pointed to the light.
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
        // L points to the light, so cos(alpha) = N . L
        Real cosAlpha = dot(record.normal, incomingDir);
        return kd * std::max(cosAlpha, 0.0);
    }
};

#endif
