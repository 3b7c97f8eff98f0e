// DiffuseMaterial, correct, computed in float locals.
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
        float nx = record.normal.x, ny = record.normal.y, nz = record.normal.z;
        float lx = incomingDir.x, ly = incomingDir.y, lz = incomingDir.z;
        float cosAlpha = -(nx * lx + ny * ly + nz * lz);
        if (cosAlpha < 0.0f)
            cosAlpha = 0.0f;
        float r = kd.x * cosAlpha;
        float g = kd.y * cosAlpha;
        float b = kd.z * cosAlpha;
        return vec3(r, g, b);
    }
};

#endif
