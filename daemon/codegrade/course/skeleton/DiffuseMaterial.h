/* DiffuseMaterial: Lambert's diffuse reflection. Fill in calcReflectedLight. */
#ifndef DIFFUSEMATERIAL_H
#define DIFFUSEMATERIAL_H

#include "Material.h"

class DiffuseMaterial : public Material
{
  public:
    vec3 kd; // diffuse reflectance k_d, per RGB channel

    DiffuseMaterial() : kd(0) {}

    virtual vec3 calcReflectedLight(const HitRecord &record, const vec3 &incomingDir, const vec3 &outgoingDir)
    {
        // Fill in: return the diffusely reflected light, equation (2):
        //   I_d = k_d max{cos(alpha), 0}, for each of R, G and B (equations (3)-(5)).
        // record.normal is N, the unit surface normal.
        // incomingDir is L, a unit vector pointing FROM the light TO the surface,
        // so cos(alpha) = -(N . L); it is negative when the light is behind the surface.
        // outgoingDir is V, a unit vector pointing away from the surface (toward the
        // viewer); a diffuse surface looks the same from every direction.
        // Do not add ambient (the tracer adds getAmbientCoeff()) and do not multiply
        // by the light's colour I_in (the tracer does, with mult()).
        return vec3(0, 0, 0);
    }
};

#endif
