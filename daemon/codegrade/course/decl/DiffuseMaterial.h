/* DiffuseMaterial: Lambert's diffuse reflection.
 * calcReflectedLight is only declared: a .cpp that includes this file
 * defines vec3 DiffuseMaterial::calcReflectedLight(...). */
#ifndef DIFFUSEMATERIAL_H
#define DIFFUSEMATERIAL_H

#include "Material.h"

class DiffuseMaterial : public Material
{
  public:
    vec3 kd; // diffuse reflectance k_d, per RGB channel

    DiffuseMaterial() : kd(0) {}

    virtual vec3 calcReflectedLight(const HitRecord &record, const vec3 &incomingDir, const vec3 &outgoingDir);
};

#endif
