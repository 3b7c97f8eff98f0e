// DiffuseMaterial, mistake: no max{.., 0}, negative when the light is behind the surface.
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
        // equation (1)
        Real cosAlpha = -dot(record.normal, incomingDir);
        return kd * cosAlpha;
    }
};

#endif
