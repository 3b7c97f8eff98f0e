// DiffuseMaterial, mistake: adds ambient inside calcReflectedLight.
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
        vec3 color = kd * std::max(cosAlpha, 0.0);
        color += ambient; // equation (8): I = I_d + I_a
        return color;
    }
};

#endif
