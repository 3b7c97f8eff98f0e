// DiffuseMaterial, mistake: the Lambert BRDF k_d/pi instead of k_d.
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
        // Lambert BRDF is k_d / pi
        Real cosAlpha = std::max(-dot(record.normal, incomingDir), 0.0);
        return kd / M_PI * cosAlpha;
    }
};

#endif
